"""Speed of the diagnosis's look-alike reruns: K MuJoCo reruns in processes against one mujoco.batch.

The diagnosis reruns the recorded test on several candidate labs
(:func:`vlab.diagnose.data.rerun_jobs.reruns`): before, one process per rerun
(two at a time on this 2-core machine); now, where the candidates' plants
share one layout, one ``mujoco.batch`` (:mod:`vlab.diagnose.data.batchrerun`).
Both ways are timed here in one run, on the BCC with MFDRF and the PC-1000
chain, the BCC test's 20 s excitation period (0.05 Hz lines) and the
diagnosis's warm-started window (a guard of the lab's settling time to
:data:`vlab.diagnose.data.warmstart.GUARD_DECAY`, then one analysed period),
for K = 2 and 4 value-only candidates (members stiffer by 10-40 %, a mode's
damping). Each way starts from an empty rerun cache and includes building the
candidates' plants and their warm starts. Printed: wall time of each way (best
of ``--repeats``), the ratio processes / batch (> 1: the batch is faster), the
batch on two threads as well (what :data:`vlab.diagnose.data.rerun_jobs.BATCH_THREAD_MIN`
is chosen from), whether the two ways gave the same recordings bit for bit,
and the load average before and after (``/proc/loadavg``: other jobs share
the machine). Run it as ``nice -n -10 python benchmarks/rerun_batch_speed.py``.

Usage::

    python benchmarks/rerun_batch_speed.py [--ks 2 4] [--repeats 2] [--resolution 0.05] [--out FILE]
"""

from __future__ import annotations

import argparse
import datetime
import os
import time

import mujoco
import numpy as np

from vlab.diagnose.data.batchrerun import rerun_together
from vlab.diagnose.data.measured import FrfData
from vlab.diagnose.data.replay import mujoco_plant
from vlab.diagnose.data.rerun_jobs import last_reruns_note, reruns
from vlab.diagnose.data.warmstart import GUARD_DECAY, rerun_window
from vlab.diagnose.effects import specedit
from vlab.diagnose.model.labmodel import LabState
from vlab.diagnose.model.nominal import nominal_design, settling_time
from vlab.lab.excitation import pseudo_random
from vlab.experiment.config import TESTS, default_chain
from vlab.io.recording import Recording
from vlab.models import nominal_fe_model

from _listing import emit, load_average

PTS = (5, 6, 7, 9)


class _Problem:
    """What :func:`reruns` reads of a problem: the data and the guard; a fresh rerun cache each time."""

    def __init__(self, data: FrfData, guard_s: float) -> None:
        self.data = data
        self.guard_s = guard_s


def _setup(resolution_hz: float, k_max: int):
    fe = nominal_fe_model("bcc")
    lab = LabState(fe.spec, fe, default_chain("mfdrf", noise_m_s=1e-6), nominal_design(fe, "mfdrf", 0))
    test = TESTS["bcc"]
    dt = lab.chain.period_s
    n_per = int(round(1 / (resolution_hz * dt)))
    t = np.arange(3 * n_per) * dt
    force = pseudo_random(t, band_hz=test.band_hz, resolution_hz=resolution_hz, rms_n=test.rms_n, seed=3)
    rec = Recording.from_signals(dt, {"force9": force, **{f"vel{p}": np.zeros(t.size) for p in PTS}})
    lines = np.arange(1, int(test.band_hz[1] / resolution_hz) + 1) * resolution_hz
    ones = np.ones((lines.size, len(PTS)))
    data = FrfData("bcc", "recording", lines, ones, ones, 9, PTS, recording=rec, analysed_from_s=2 * n_per * dt)
    guard_s = settling_time(lab, test.band_hz, decay=GUARD_DECAY)
    spec = lab.spec
    members = [m.id for m in spec.members]
    cands = [lab.with_spec(specedit.scale_member(spec, members[j % len(members)], 1.1 + 0.1 * j))
             for j in range(k_max - 1)] + [lab.with_spec(specedit.set_modal_damping(spec, 1, 0.02))]
    return lab, data, guard_s, cands


def _best(fn, repeats: int):
    best, out = float("inf"), None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ks", type=int, nargs="+", default=[2, 4], help="numbers of look-alike reruns")
    ap.add_argument("--repeats", type=int, default=2, help="timings per case (best kept)")
    ap.add_argument("--resolution", type=float, default=TESTS["bcc"].resolution_hz, help="line spacing [Hz]")
    ap.add_argument("--out", help="also write the table here")
    a = ap.parse_args(argv)
    load0 = load_average()
    lab, data, guard_s, cands = _setup(a.resolution, max(a.ks))
    start, period, stop = rerun_window(data, data.recording.dt_s, guard_s=guard_s)
    sim_s = (stop - start) * data.recording.dt_s
    force = np.asarray(data.recording["force9"])
    rows = []
    for k in a.ks:
        jobs = [(st, None) for st in cands[:k]]
        t_proc, r_proc = _best(lambda: reruns(_Problem(data, guard_s), jobs, "mujoco", batch=False), a.repeats)
        probs = []

        def batched():
            probs.append(_Problem(data, guard_s))
            return reruns(probs[-1], jobs, "mujoco", batch=True)

        t_batch, r_batch = _best(batched, a.repeats)
        note = last_reruns_note(probs[-1])
        same = all(np.array_equal(x.as_array(), y.as_array()) for x, y in zip(r_proc, r_batch))
        t_thr, _ = _best(lambda: rerun_together(cands[:k], [mujoco_plant(st, PTS) for st in cands[:k]], force,
                                                excitation_point=9, measured_points=PTS, start=start,
                                                period=period, stop=stop, nthread=2), a.repeats)
        rows.append((k, t_proc, t_batch, t_thr, same, note))
    lines = [
        f"rerun_batch_speed.py  {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC  "
        f"{os.cpu_count()} CPUs  mujoco {mujoco.__version__}  nice {os.nice(0)}",
        f"BCC, MFDRF, PC-1000 chain; {1 / a.resolution:g} s excitation period; rerun window ticks {start}..{stop} "
        f"({sim_s:g} s simulated per rerun: a guard of min(settling time {guard_s:.1f} s, one period) + one period); best of {a.repeats}",
        f"load average before: {load0}",
        "",
        f"{'K':>2} {'processes [s]':>14} {'batch [s]':>10} {'proc/batch':>11} {'batch 2 thr [s]':>16} "
        f"{'same bits':>10}  how",
    ]
    for k, tp, tb, tt, same, note in rows:
        lines.append(f"{k:>2} {tp:>14.2f} {tb:>10.2f} {tp / tb:>11.2f} {tt:>16.2f} {str(same):>10}  {note}")
    lines += ["", f"load average after: {load_average()}"]
    return emit(lines, a.out)


if __name__ == "__main__":
    raise SystemExit(main())
