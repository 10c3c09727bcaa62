"""The diagnosis's FRF prediction with one BLAS thread and with BLAS's default, side by side in one run.

The diagnosis evaluates the FE model's FRFs (:func:`vlab.diagnose.model.labmodel.predict_frf`: a modal
analysis and a receptance with the damping coupling of a changed structure) thousands of times in its
fits. This script times that prediction for the grid (the FE model meshed as the MuJoCo plant resolves
it, an added mass at a measured point, the test's lines) alternately under
``threadpool_limits(1, "blas")`` (:func:`vlab.diagnose.data.run.one_blas_thread`, what ``diagnose`` uses)
and without a limit, and prints the medians and their ratio with the load average (2-core machines are
noisy: run it alone).

    python benchmarks/blas_threads.py [--repeats 20] [--structure grid]
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import numpy as np
from threadpoolctl import threadpool_info, threadpool_limits

from vlab.diagnose.effects.specedit import add_mass
from vlab.diagnose.model.labmodel import LabState, predict_frf
from vlab.diagnose.model.nominal import plant_resolution
from vlab.fe.assembly import build_fe_model
from vlab.experiment.config import default_chain, test_definition
from vlab.spec import load_spec


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=20)
    ap.add_argument("--structure", default="grid")
    args = ap.parse_args(argv)
    spec = plant_resolution(load_spec(args.structure))
    td = test_definition(spec)
    lab = LabState(spec, build_fe_model(spec), default_chain("none", noise_m_s=1e-6), None)
    lab = lab.with_spec(add_mass(spec, td.measured_points[1], 0.2))
    f = np.arange(td.band_hz[0], td.band_hz[1], td.resolution_hz)
    exc = spec.instrumentation.actuators[0]

    def once() -> float:
        t = time.perf_counter()
        predict_frf(lab, f, excitation_point=exc, output_points=td.measured_points)
        return time.perf_counter() - t

    once()
    one, default = [], []
    for _ in range(args.repeats):  # interleaved, so that a change of load hits both
        with threadpool_limits(limits=1, user_api="blas"):
            one.append(once())
        default.append(once())
    threads = max((p.get("num_threads", 1) for p in threadpool_info() if p.get("user_api") == "blas"), default=1)
    a, b = statistics.median(one), statistics.median(default)
    print(f"{args.structure}: FE model {lab.fe.n} DOFs, {f.size} lines, {len(td.measured_points)} points; "
          f"load average {os.getloadavg()[0]:.2f}")
    print(f"predict_frf median: one BLAS thread {1e3 * a:.1f} ms, default ({threads} threads) {1e3 * b:.1f} ms; "
          f"default / one = {b / a:.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
