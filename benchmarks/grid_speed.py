"""The grid plant's speed and accuracy, its former build against the current one, side by side.

Builds of the hanging grid compared in one run (so that the machine's speed
and load cancel in the ratios):

* ``before`` -- ``SimOptions(topology="tree", torsion_hinges="all",
  integrator="implicitfast")``: the build of commit 3c4910a (the same model
  arrays): one spanning tree, 9 loop welds each through an in-plane release,
  a torsion hinge at every Gauss point, implicit joint damping;
* ``after`` -- the default options: the forest topology (members as chains
  from junctions hung from the world, member ends held by linear equalities),
  one torsion hinge per segment, explicit damping (:class:`vlab.sim.SimOptions`);
* with ``--steps`` also the intermediate builds (one change at a time).

Measured for each: DOFs and constraint rows; the C loop and the lab step
(``MujocoPlant.set_forces`` + ``step`` + ``velocities``) with random coil
forces (``sim_speed.measure_plant``); the closed loop
(:func:`vlab.lab.loop.run_loop`, the test's excitation point, actuators and
measured points, sensor noise and the PC-1000 chain) with the thesis's LQG
(1 kHz) and MFDRF (2 kHz) designs; the cross-check against the FE model on the
thesis mesh and at the plant's resolution (max |frequency error| of the 12
modes paired one-to-one, min MAC); the pulse response against the same build at
a quarter of its step (``sim_speed.accuracy``). Real-time factors are the best
of ``--repeats``, the cases interleaved.

Usage::

    python benchmarks/grid_speed.py [--seconds 3] [--repeats 3] [--steps] [--out FILE]
"""

from __future__ import annotations

import argparse
import datetime
import os
import platform
import time
from pathlib import Path

import mujoco
import numpy as np
from sim_speed import accuracy, measure_plant

from vlab.design import design_controller
from vlab.fe import build_fe_model
from vlab.lab.engine import ControllerEngine
from vlab.experiment.config import default_chain, test_definition
from vlab.lab.loop import run_loop
from vlab.sim import MujocoPlant, SimOptions, build_plant, crosscheck
from vlab.spec import load_spec

BEFORE = SimOptions(topology="tree", torsion_hinges="all", integrator="implicitfast")
CASES = {"before": BEFORE, "after": SimOptions()}
STEPS = {  # one change at a time
    "before + one torsion hinge": SimOptions(topology="tree", integrator="implicitfast"),
    "after with all torsion hinges": SimOptions(torsion_hinges="all"),
    "after with implicitfast": SimOptions(integrator="implicitfast"),
}


def closed_loop_s(sim: MujocoPlant, engine: ControllerEngine, chain, test, acts, exc_point: int,
                  seconds: float) -> float:
    """Wall time [s] of ``seconds`` of the closed loop with a pseudo-random excitation (0.2 N rms)."""
    n = int(round(seconds / chain.period_s))
    excitation = np.random.default_rng(0).standard_normal(n) * 0.2
    meas = tuple(dict.fromkeys(test.measured_points + acts))
    sim.reset()
    t0 = time.perf_counter()
    run_loop(sim, engine, feedback_points=acts, measured_points=meas, excitation_point=exc_point,
             excitation=excitation, duration_s=seconds, chain=chain, seed=1)
    return time.perf_counter() - t0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=3.0, help="simulated seconds per timing [s]")
    ap.add_argument("--repeats", type=int, default=3, help="timings per case (best kept)")
    ap.add_argument("--steps", action="store_true", help="also the intermediate builds")
    ap.add_argument("--out", default=None, help="also write the table to this file")
    a = ap.parse_args(argv)

    spec = load_spec("grid")
    fe = build_fe_model(spec)
    test = test_definition(spec)
    acts, exc_point = tuple(spec.instrumentation.actuators), spec.instrumentation.excitation
    cases = dict(CASES, **(STEPS if a.steps else {}))
    plants = {k: build_plant(spec, o) for k, o in cases.items()}
    sims = {k: MujocoPlant(p, actuators=acts) for k, p in plants.items()}
    loops = {}
    for ctl in ("lqg", "mfdrf"):
        chain = default_chain(ctl)
        d = design_controller(fe, ctl, period_s=chain.period_s, seed=0)
        loops[ctl] = (ControllerEngine(d.f11, d.f12, d.f21, d.f22, period_s=chain.period_s), chain)

    rt = {k: {} for k in cases}
    for _ in range(a.repeats):
        for k, p in plants.items():
            steps = measure_plant(p, a.seconds)
            for key in ("c_loop", "lab_step"):
                rt[k][key] = max(rt[k].get(key, 0.0), steps[key]["real_time_factor"])
            for ctl, (engine, chain) in loops.items():
                wall = closed_loop_s(sims[k], engine, chain, test, acts, exc_point, a.seconds)
                rt[k][ctl] = max(rt[k].get(ctl, 0.0), a.seconds / wall)

    rows = []
    for k, p in plants.items():
        d = p.make_data()
        cc = crosscheck(p, 12)
        ccp = crosscheck(p, 12, mesh="plant")
        acc = accuracy("grid", cases[k])
        rows.append((k, p.model.nv, d.nefc, rt[k], cc, ccp, acc))

    lines = [
        f"grid_speed.py  {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC  {platform.node()}  "
        f"{os.cpu_count()} CPUs  load average {os.getloadavg()[0]:.2f}  mujoco {mujoco.__version__}",
        f"{a.seconds:g} s simulated per timing, best of {a.repeats}; real-time factors (x)",
        "",
        f"{'build':<28} {'nv':>4} {'rows':>5} {'C loop':>7} {'lab step':>9} {'LQG loop':>9} {'MFDRF loop':>11} "
        f"{'thesis mesh':>16} {'plant mesh':>16} {'pulse 1-20 Hz':>15}",
    ]
    for k, nv, nefc, r, cc, ccp, acc in rows:
        lines.append(
            f"{k:<28} {nv:>4} {nefc:>5} {r['c_loop']:>7.2f} {r['lab_step']:>9.2f} {r['lqg']:>9.2f} "
            f"{r['mfdrf']:>11.2f} {cc.max_error_pct():>6.2f} % {cc.min_mac():.4f} "
            f"{ccp.max_error_pct():>6.2f} % {ccp.min_mac():.4f} "
            f"{100 * acc['band_rel_diff']:>6.2f} % {acc['spectrum_db_rms']:.2f} dB")
    lines += ["", "thesis mesh / plant mesh: max |frequency error| of the 12 modes paired one-to-one and min MAC; "
              "pulse: difference from the same build at a quarter of its step, and its spectrum's rms in dB"]
    print(*lines, sep="\n")
    if a.out:
        Path(a.out).write_text("\n".join(lines) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
