"""The diagnosis's modal sum (``vlab.diagnose.model.labmodel._receptance``), its former form against the current.

Every hypothesis the diagnosis screens or fits is scored by the lab's FRF on the data's lines
(:func:`vlab.diagnose.model.labmodel.predict_frf`), and most of that is the receptance between the measured
and driven points summed over the modes. A profile of a grid diagnosis (py-spy, a concealed mass under
MFDRF) put a quarter of its samples there. The former form multiplied, for each line, the shapes by the
line's modal factors and then by the shapes (a batch of small products, ``n_f`` of ``n_p x n`` by
``n x n_p``, twice: real and imaginary parts); the current one forms ``ph[a, k] ph[b, k]`` once and takes
the sum over the modes for every line as one product ``(n_f x n) (n x n_p^2)``. The same arithmetic, in
another order: the results agree to rounding (printed).

Measured in one run, on the grid's nominal lab (FE model at the plant's resolution, 91 DOFs) and the BCC's,
with one BLAS thread (as the diagnosis runs), the best of ``--repeats`` timings of each.

Usage::

    python benchmarks/receptance_speed.py [--repeats 7] [--lines 491]
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from vlab.diagnose.model import labmodel  # noqa: E402
from vlab.fe import build_fe_model, modal_analysis  # noqa: E402
from vlab.fe.damping import structural_ratios  # noqa: E402
from vlab.models import nominal_fe_model  # noqa: E402
from vlab.diagnose.model.nominal import plant_resolution  # noqa: E402
from vlab.experiment.config import test_definition  # noqa: E402


def former(omega, zeta, ph, w):
    """The former classical modal sum: a batch of per-line products, real and imaginary parts apart."""
    den = omega[None, :] ** 2 - w[:, None] ** 2 + 2j * zeta[None, :] * omega[None, :] * w[:, None]
    r = 1.0 / den
    return (ph[None] * r.real[:, None, :]) @ ph.T + 1j * ((ph[None] * r.imag[:, None, :]) @ ph.T)


def best_of(fn, repeats: int, inner: int = 20) -> float:
    """Best mean time of ``inner`` calls of ``fn`` over ``repeats`` tries [s]."""
    out = []
    for _ in range(repeats):
        t = time.perf_counter()
        for _ in range(inner):
            fn()
        out.append((time.perf_counter() - t) / inner)
    return min(out)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--lines", type=int, default=491, help="frequency lines (a 0.02 Hz grid test: 491)")
    a = ap.parse_args()
    print(f"{'structure':10s} {'DOFs':>5s} {'points':>6s} {'former [ms]':>12s} {'current [ms]':>13s} "
          f"{'ratio':>6s} {'max rel diff':>13s}")
    for name in ("bcc", "grid"):
        fe = build_fe_model(plant_resolution(nominal_fe_model(name).spec))
        md = modal_analysis(fe.m, fe.k)
        zeta = structural_ratios(fe, md)
        test = test_definition(name)
        pts = tuple(dict.fromkeys(tuple(test.measured_points) + tuple(fe.spec.instrumentation.actuators)
                                  + (fe.spec.instrumentation.excitation,)))
        ph = md.shapes[fe.dofs.indices(pts, "w"), :]
        w = 2 * np.pi * np.linspace(test.band_hz[0], test.band_hz[1], a.lines)
        old, new = former(md.omega, zeta, ph, w), labmodel._receptance(md.omega, zeta, ph, w)
        diff = float(np.max(np.abs(old - new)) / np.max(np.abs(old)))
        t_old = best_of(lambda: former(md.omega, zeta, ph, w), a.repeats)
        t_new = best_of(lambda: labmodel._receptance(md.omega, zeta, ph, w), a.repeats)
        print(f"{name:10s} {fe.n:5d} {len(pts):6d} {1e3 * t_old:12.3f} {1e3 * t_new:13.3f} "
              f"{t_old / t_new:6.2f} {diff:13.2e}")


if __name__ == "__main__":
    main()
