"""Is the MuJoCo plant's forced response linear at the test amplitude? (a check, not a speed benchmark)

Drives ``MujocoPlant(build_plant(spec))`` open loop with the structure's test
signal (:data:`vlab.experiment.config.TESTS`: pseudo-random, its band and RMS) at
the excitation point, once at full and once at ``--scale`` amplitude, and
prints, for the response at the test's response point:

- the relative difference of the two responses each divided by its force
  scale (0 for a linear plant), their norm ratio (1) and correlation (+1),
- the share of the response energy above the excitation band (a linear
  plant driven by band-limited lines answers in the band only, apart from
  its start-up transient).

Usage::

    python benchmarks/plant_linearity.py grid [--seconds 20] [--scale 0.1]
"""

from __future__ import annotations

import argparse
import os
import sys
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from vlab.lab.excitation import pseudo_random  # noqa: E402
from vlab.experiment.config import TESTS  # noqa: E402
from vlab.sim import MujocoPlant, build_plant  # noqa: E402
from vlab.spec import load_spec  # noqa: E402


def response(structure: str, seconds: float, scale: float, seed: int = 3) -> tuple[np.ndarray, float]:
    """Velocity [m/s] at the response point under the scaled test force, and the plant's step [s]."""
    spec = load_spec(structure)
    test = TESTS[structure]
    plant = MujocoPlant(build_plant(spec))
    dt = plant.timestep_s
    n = int(round(seconds / dt))
    force = scale * pseudo_random(np.arange(n) * dt, band_hz=test.band_hz, resolution_hz=1.0 / seconds,
                                  rms_n=test.rms_n, seed=seed)
    u = np.zeros(len(plant.actuator_points))
    k = plant.actuator_points.index(spec.instrumentation.excitation)
    v = np.empty(n)
    for i in range(n):
        u[k] = force[i]
        plant.set_forces(u)
        plant.step()
        v[i] = plant.velocities((test.response_point,))[0]
    return v, dt


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("structure", choices=sorted(TESTS))
    ap.add_argument("--seconds", type=float, default=20.0)
    ap.add_argument("--scale", type=float, default=0.1)
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    full, dt = response(args.structure, args.seconds, 1.0)
    small, _ = response(args.structure, args.seconds, args.scale)
    diff = np.linalg.norm(full - small / args.scale) / np.linalg.norm(full)
    norm_ratio = np.linalg.norm(small / args.scale) / np.linalg.norm(full)
    corr = float(np.corrcoef(full, small)[0, 1])
    f = np.fft.rfftfreq(full.size, dt)
    e = np.abs(np.fft.rfft(full)) ** 2
    lo, hi = TESTS[args.structure].band_hz
    print(f"{args.structure}: responses at 1 and {args.scale:g} x the test force, each divided by its scale, "
          f"differ by {diff:.3g} x the response norm (0 if linear)")
    print(f"norm ratio (scaled small / full): {norm_ratio:.3g}; correlation of the two responses: {corr:+.3f}")
    print(f"energy above the {hi:g} Hz band / in the band: {e[f > hi].sum() / e[(f >= lo) & (f <= hi)].sum():.3g}")
    print(f"({time.perf_counter() - t0:.0f} s for 2 x {args.seconds:g} s simulated)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
