"""How often does the instability detector's envelope gate pass a stable, noise-driven mode? (a check)

The detector (:mod:`vlab.measure.instability`) takes an incoherent spectral line for a self-excited
oscillation only if, among other gates, its envelope is nearly constant: coefficient of variation below
:data:`~vlab.measure.instability.MAX_ENVELOPE_CV`. The null hypothesis it guards against is a stable, lightly
damped mode driven by noise -- a narrowband Gaussian process, whose envelope is Rayleigh distributed with a
coefficient of variation of 0.52 *over a long record* (Bendat & Piersol, *Random Data*, 4th ed., Sec. 3.4.3).
Over a window not much longer than the mode's correlation time the estimate is biased low and scattered:
the envelope has had no time to vary. This script measures, for a resonator of natural frequency ``f0`` and
damping ratio ``zeta`` driven by white noise, with white sensor noise 40 dB below the resonance's peak:

- the 1 %, 5 % and 50 % quantiles of the envelope's coefficient of variation as the detector computes it
  (its band-pass filter and window: the record's second half less its last tenth);
- the share of records whose coefficient lies below the gate;
- the share the whole detector (:func:`vlab.measure.instability.find_instability`, no force channel: every
  line counts as incoherent, so the period-change gate does not apply) declares unstable -- a false alarm;

against ``B T_w = pi zeta f0 T_w``, the number of the envelope's correlation times in the window ``T_w``
(the noise bandwidth of a second-order resonance, ``pi zeta f0`` [Hz]).

Usage::

    python benchmarks/envelope_null.py [--records 100] [--seconds 60] [--seed 1]
        [--csv docs/validation/data/envelope_null.csv]   # writes the table measured here
"""

from __future__ import annotations

import argparse
import csv
import math
import os
import sys
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402
from scipy import signal  # noqa: E402

from vlab.io.recording import Channel, Recording  # noqa: E402
from vlab.measure import instability  # noqa: E402

FS_HZ = 2000.0
#: (f0 [Hz], damping ratio) pairs measured: the BCC's and the grid's lightly damped modes' range.
CASES = [(f0, z) for f0 in (5.0, 14.0) for z in (0.0005, 0.001, 0.002, 0.005, 0.01, 0.02)]
#: Sensor noise below the resonance's peak spectral level [dB] (the line stands 40 dB over the floor).
SENSOR_NOISE_DB = 40.0


def noise_driven_mode(f0: float, zeta: float, seconds: float, rng: np.random.Generator) -> np.ndarray:
    """Velocity-like record [arbitrary units], shape (seconds * FS_HZ,): a resonator driven by white noise,
    settled (started 20 time constants before the record), plus white sensor noise ``SENSOR_NOISE_DB``
    below the resonance's peak spectral level."""
    w = 2 * math.pi * f0
    b, a = signal.bilinear([w, 0.0], [1.0, 2 * zeta * w, w * w], FS_HZ)
    n = int(seconds * FS_HZ)
    lead = int(20.0 / (zeta * w) * FS_HZ)
    y = signal.lfilter(b, a, rng.standard_normal(n + lead))[lead:]
    peak = abs(np.polyval(b, np.exp(1j * w / FS_HZ)) / np.polyval(a, np.exp(1j * w / FS_HZ)))
    return y + peak * 10 ** (-SENSOR_NOISE_DB / 20) * rng.standard_normal(n)


def measure(f0: float, zeta: float, seconds: float, records: int, rng: np.random.Generator) -> dict:
    """The coefficient of variation's quantiles and the gate's and the detector's pass rates for one mode."""
    n = int(seconds * FS_HZ)
    nper = instability.welch_block(n)
    df = FS_HZ / nper
    cvs, alarms = [], 0
    for _ in range(records):
        y = noise_driven_mode(f0, zeta, seconds, rng)
        cvs.append(instability.line_statistics(y, FS_HZ, f0, df, None)[3])
        rec = Recording(1.0 / FS_HZ, (Channel("vel1", 1, "velocity", y),))
        alarms += bool(instability.find_instability(rec, force_channel=None).unstable)
    cvs = np.asarray(cvs)
    q01, q05, q50 = np.quantile(cvs, [0.01, 0.05, 0.5])
    window = seconds * (0.5 - 0.1)
    return {"f0_hz": f0, "damping_ratio": zeta, "window_s": window,
            "correlation_times_in_window": math.pi * zeta * f0 * window,
            "cv_q01": q01, "cv_q05": q05, "cv_q50": q50,
            "share_below_gate": float(np.mean(cvs < instability.MAX_ENVELOPE_CV)),
            "share_declared_unstable": alarms / records, "records": records}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--records", type=int, default=100)
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--csv", help="write the table here")
    a = ap.parse_args(argv)
    if a.records < 1:
        ap.error(f"--records must be at least 1, got {a.records}")
    if not a.seconds >= 2.0:  # the detector needs 256 samples at 2 kHz, and a resonator 20 time constants' lead
        ap.error(f"--seconds must be at least 2, got {a.seconds:g}")
    rng = np.random.default_rng(a.seed)
    rows = []
    t0 = time.perf_counter()
    print(f"# python benchmarks/envelope_null.py --records {a.records} --seconds {a.seconds:g} --seed {a.seed}")
    print(f"# gate: envelope coefficient of variation < {instability.MAX_ENVELOPE_CV:.3f} "
          f"(Rayleigh over a long record: {instability.ENVELOPE_CV_RAYLEIGH:.3f})")
    print(" f0 [Hz]   zeta     B*T_w   cv 1%   cv 5%   cv 50%   below gate   declared unstable")
    for f0, zeta in CASES:
        r = measure(f0, zeta, a.seconds, a.records, rng)
        rows.append(r)
        print(f"{f0:8.1f} {zeta:7.4f} {r['correlation_times_in_window']:8.2f} {r['cv_q01']:7.3f} {r['cv_q05']:7.3f} "
              f"{r['cv_q50']:8.3f} {r['share_below_gate']:12.2f} {r['share_declared_unstable']:19.2f}",
              flush=True)
    print(f"# {time.perf_counter() - t0:.0f} s")
    if a.csv:
        tmp = a.csv + ".tmp"
        with open(tmp, "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items()} for r in rows)
        os.replace(tmp, a.csv)
    return 0


if __name__ == "__main__":
    sys.exit(main())
