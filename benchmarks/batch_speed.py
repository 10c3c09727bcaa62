"""Speed of the batched lab against MuJoCo's own C loop and vlab's single closed loop, side by side.

All on the BCC plant (default options), measured in one run so that the
machine's speed (and its load) cancels in the ratios:

* ``C loop mj_step``     -- ``mujoco.mj_step(m, d, nstep=n)``, one thread: the ceiling of one simulation;
* ``C rollout N=16``     -- ``mujoco.rollout.rollout`` of 16 open-loop copies on ``--threads`` threads
  (aggregate): the ceiling of the machine;
* ``mujoco.batch step N=16`` -- ``Batch.step(stage=mjSTAGE_VEL)`` once per physics step on a 16-simulation
  batch with no controller, no damping and no Python work between the steps: the ceiling of the batched loop;
* ``+ applied modal damping`` and ``+ a bare feedback law u = F11 y`` -- the same batch with the plant's
  applied modal damping (three numpy products a tick), then also a direct velocity feedback with no
  chain, delay, filter or noise (one gather, one product, one write a tick; the issue's "simple
  vectorised feedback law"): what any batched closed loop on this plant costs at the least;
* ``Python mj_step + damping`` -- a bare Python loop of the plant's own work per tick (the applied
  modal damping of :mod:`vlab.sim.damping` and ``mj_step``): the floor of any Python loop on this plant;
* ``vlab run_loop``      -- the single 2 kHz closed loop (:func:`vlab.lab.loop.run_loop` on
  :class:`vlab.sim.MujocoPlant`); with ``--baseline DIR`` also the run_loop of another vlab source
  tree (e.g. ``git archive <rev> | tar -x -C DIR``), timed in a subprocess in the same run;
* ``vlab batch N=...``   -- :func:`vlab.lab.batch.run_batch` on :class:`vlab.sim.batch_plant.MujocoBatchPlant`
  with ``--threads`` threads, aggregate over the N simulations (and N = 16 on one thread, to show
  what the second thread adds on a loaded machine).

The closed loops run MFDRF (Table 7 gains) with the full PC-1000 chain of
Sec. 5.3 (1.35-period delay, 677 Hz RC filter, amplifier, 1e-6 m/s sensor
noise on every sensor) and a random excitation at point 9; each batch
simulation has its own excitation record and noise seed. Printed: wall time
per controller tick of one simulation (N > 1: aggregate wall time / N), real-time factor
(simulated seconds per wall second), its ratio to the single C loop and to
``run_loop``, and the memory per simulation (growth
of the resident set when the N = 64 batch is made and run, recordings
included, divided by 64). Each timing is the best of ``--repeats``.

Usage::

    python benchmarks/batch_speed.py [--seconds 1.0] [--threads 2] [--repeats 2] [--baseline DIR]
                                     [--out docs/validation/data/batch_speed.txt]
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import subprocess
import sys

import mujoco
import mujoco.rollout
import numpy as np

from vlab.lab.batch import run_batch
from vlab.lab.engine import ControllerEngine
from vlab.lab.loop import HardwareChain, run_loop
from vlab.reference import bcc_gain
from vlab.sim import MujocoPlant, build_plant
from vlab.sim.batch_plant import MujocoBatchPlant
from vlab.sim.contract import sensor_rows
from vlab.spec import load_spec

from _listing import best_time, emit

ACTS = (5, 7, 9)
MEAS = (5, 7, 9, 6)
PERIOD_S = 0.5e-3
BATCH_SIZES = (1, 4, 16, 64)


def _rss_bytes() -> int:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def _autogroup() -> str:
    """This process's scheduler autogroup and its nice (Linux): with autogroups on, a process's own nice
    does not rank it against other sessions' processes, so the batch's second thread may get no core."""
    try:
        with open("/proc/self/autogroup") as f:
            return f.read().strip()
    except OSError:
        return "n/a"


def _bcc(seconds: float):
    """The BCC plant, the MFDRF engine, the loop's keywords and the excitation records (N_max, n_ticks)."""
    plant = build_plant(load_spec("bcc"))
    sim = MujocoPlant(plant)
    eng = ControllerEngine.from_gain(bcc_gain("mfdrf"), period_s=PERIOD_S)
    kw = dict(feedback_points=ACTS, measured_points=MEAS, excitation_point=9, duration_s=seconds,
              chain=HardwareChain(noise_m_s=1e-6))
    exc = np.random.default_rng(1).standard_normal((max(BATCH_SIZES), int(round(seconds / PERIOD_S))))
    return plant, sim, eng, kw, exc


def _time_run_loop(seconds: float, repeats: int) -> float:
    """Real-time factor of run_loop (the vlab on ``sys.path``) on the BCC, best of ``repeats``."""
    _, sim, eng, kw, exc = _bcc(seconds)

    def single():
        sim.reset()
        run_loop(sim, eng, excitation=exc[0], seed=1, **kw)

    return seconds / best_time(single, repeats)


def _time_baseline(src: str, seconds: float, repeats: int) -> float:
    """Real-time factor of the run_loop of the vlab source tree ``src``, timed by this script in a subprocess."""
    env = {**os.environ, "PYTHONPATH": os.path.abspath(src)}
    run = subprocess.run([sys.executable, os.path.abspath(__file__), "--run-loop-only", "--seconds", str(seconds),
                          "--repeats", str(repeats)], env=env, capture_output=True, text=True)
    if run.returncode:
        raise SystemExit(f"--baseline {src}: the timing subprocess failed:\n{run.stderr}")
    got = json.loads(run.stdout.strip().splitlines()[-1])
    if not got["vlab"].startswith(os.path.abspath(src)):
        raise SystemExit(f"--baseline {src}: the subprocess imported vlab from {got['vlab']}")
    return got["real_time"]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=1.0, help="simulated seconds per simulation [s]")
    ap.add_argument("--threads", type=int, default=2, help="threads of the batch and the rollout")
    ap.add_argument("--repeats", type=int, default=2, help="timings per case (best kept)")
    ap.add_argument("--baseline", default=None, metavar="DIR",
                    help="also time run_loop of the vlab source tree DIR (e.g. an earlier commit's)")
    ap.add_argument("--out", default=None, help="also write the table to this file")
    ap.add_argument("--run-loop-only", action="store_true", help=argparse.SUPPRESS)  # --baseline's subprocess
    a = ap.parse_args(argv)
    if a.run_loop_only:
        import vlab

        print(json.dumps({"vlab": os.path.abspath(vlab.__file__), "real_time": _time_run_loop(a.seconds, a.repeats)}))
        return 0

    plant, sim, eng, kw, exc = _bcc(a.seconds)
    m = plant.model
    h = plant.timestep_s
    rows = []

    n_steps = int(round(a.seconds / h))
    d = mujoco.MjData(m)
    d.qpos[:] = sim.data.qpos
    mujoco.mj_forward(m, d)
    t = best_time(lambda: mujoco.mj_step(m, d, nstep=n_steps), a.repeats)
    rt_c = n_steps * h / t
    rows.append(("C loop mj_step (1 thread)", rt_c))

    n_roll = 16
    state0 = np.zeros(mujoco.mj_stateSize(m, mujoco.mjtState.mjSTATE_FULLPHYSICS))
    mujoco.mj_getState(m, d, state0, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    datas = [mujoco.MjData(m) for _ in range(a.threads)]
    ctrl = np.random.default_rng(0).standard_normal((n_roll, n_steps, m.nu)) * 0.1
    t = best_time(lambda: mujoco.rollout.rollout(m, datas, np.tile(state0, (n_roll, 1)), ctrl), a.repeats)
    rows.append((f"C rollout N={n_roll} ({a.threads} threads), aggregate", n_roll * n_steps * h / t))
    bare = MujocoBatchPlant(sim, n_roll, nthread=a.threads).batch
    vel_stage = int(mujoco.mjtStage.mjSTAGE_VEL)

    def batch_steps():
        for _ in range(n_steps):
            bare.step(stage=vel_stage)

    rows.append((f"mujoco.batch step N={n_roll} ({a.threads} threads), aggregate",
                 n_roll * n_steps * h / best_time(batch_steps, a.repeats)))
    del bare
    ceiling = MujocoBatchPlant(sim, n_roll, nthread=a.threads)

    def damped_steps():
        ceiling.reset()
        for _ in range(n_steps):
            ceiling.step(sample=True)

    rows.append(("  + applied modal damping, aggregate", n_roll * n_steps * h / best_time(damped_steps, a.repeats)))
    rows_v = np.array([sensor_rows(m)[p] for p in ACTS])  # the vel<ID> rows of sensordata
    coils = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_ACTUATOR, f"coil{p}") for p in ACTS]
    gain = np.ascontiguousarray(np.asarray(eng.F11).T)  # u = F11 y as rows: u = y F11^T, one product for all
    y = np.empty((n_roll, len(ACTS)))
    u = np.empty((n_roll, len(ACTS)))

    def minimal_loop():
        ceiling.reset()
        sensordata, ctrl = ceiling.batch.bind("sensordata"), ceiling.batch.bind("ctrl")
        cols = slice(coils[0], coils[-1] + 1) if coils == list(range(coils[0], coils[-1] + 1)) else coils
        for _ in range(n_steps):
            np.take(sensordata, rows_v, axis=1, out=y)
            np.matmul(y, gain, out=u)
            ctrl[:, cols] = u
            ceiling.step(sample=True)

    rows.append(("  + a bare feedback law u = F11 y, aggregate", n_roll * n_steps * h / best_time(minimal_loop, a.repeats)))
    del ceiling

    if sim.modal_damping is not None:
        def plant_only():
            mujoco.mj_resetData(m, d)
            d.qpos[:] = sim.data.qpos
            for _ in range(n_steps):
                sim.modal_damping.step(m, d)

        rows.append(("Python mj_step + damping (plant only)", a.seconds / best_time(plant_only, a.repeats)))

    if a.baseline:
        rows.append(("vlab run_loop, baseline tree", _time_baseline(a.baseline, a.seconds, a.repeats)))
    rt_loop = _time_run_loop(a.seconds, a.repeats)
    rows.append(("vlab run_loop (single closed loop)", rt_loop))

    rss_per_sim = None
    cases = [(n, a.threads) for n in BATCH_SIZES] + [(16, 1)]
    for n, threads in cases:
        rss0 = _rss_bytes()
        bp = MujocoBatchPlant(sim, n, nthread=threads)

        def batch():
            bp.reset()
            return run_batch(bp, eng, excitation=exc[:n], seeds=list(range(n)), **kw)

        t = best_time(batch, a.repeats)
        if n == max(BATCH_SIZES):
            rss_per_sim = (_rss_bytes() - rss0) / n
        rows.append((f"vlab batch N={n} ({threads} thread{'s' if threads > 1 else ''}), aggregate",
                     n * a.seconds / t))
        del bp

    lines = [
        f"batch_speed.py  {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC  "
        f"{platform.node()}  {os.cpu_count()} CPUs  load average {os.getloadavg()[0]:.2f}  mujoco {mujoco.__version__}",
        f"process nice {os.nice(0)}, scheduler autogroup: {_autogroup()}",
        f"BCC plant: nv = {m.nv}, physics step {h * 1e3:g} ms, controller period {PERIOD_S * 1e3:g} ms; "
        f"{a.seconds:g} s simulated per simulation; MFDRF with the full PC-1000 chain + noise; best of {a.repeats}",
        *([f"baseline tree: {a.baseline}"] if a.baseline else []),
        "us / tick: wall time per controller tick of one simulation (aggregate rows: per simulation)",
        "",
        f"{'case':<46} {'us / tick':>10} {'real-time x':>12} {'/ C loop':>10} {'/ run_loop':>11}",
    ]
    for name, rt in rows:
        lines.append(f"{name:<46} {PERIOD_S / rt * 1e6:>10.1f} {rt:>12.2f} {rt / rt_c:>10.3f} {rt / rt_loop:>11.2f}")
    lines.append("")
    lines.append(f"memory per simulation (N = {max(BATCH_SIZES)} batch, recordings of {a.seconds:g} s included): "
                 f"{rss_per_sim / 1e6:.2f} MB")
    return emit(lines, a.out)


if __name__ == "__main__":
    raise SystemExit(main())
