"""Speed of the MuJoCo plants: steps per second and real-time factor, one core.

For each structure (``bcc``, ``grid`` when its TOML exists) the plant is built
with its default options (automatic timestep) and stepped three ways in the
same run:

* ``mj_step x N``  -- ``mujoco.mj_step(m, d, nstep=N)``: the C loop, the
  ceiling;
* ``bare mj_step`` -- one ``mujoco.mj_step(m, d)`` call per step from Python;
* ``lab step``     -- what the control loop does per physics step:
  ``MujocoPlant.set_forces`` + ``step`` + ``velocities(sensor points)``.

Reported: microseconds per step, steps per second, real-time factor
``steps/s * dt`` and the ratio of each to the bare ``mj_step`` (measured in
this run, so machine speed cancels). Targets (issue): BCC >= 20x real time,
grid >= 1x real time, both at the plant's own timestep.

Usage::

    python benchmarks/sim_speed.py [--seconds 2.0] [--json]
"""

from __future__ import annotations

import argparse
import json
import time

import mujoco
import numpy as np

from vlab.sim import MujocoPlant, build_plant
from vlab.spec import STRUCTURES_DIR, load_spec

TARGET_RT = {"bcc": 20.0, "grid": 1.0}


def _best_of(fn, repeats: int = 3) -> float:
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def measure(name: str, sim_seconds: float) -> dict:
    """Time one structure's plant; returns a dict of the numbers."""
    t0 = time.perf_counter()
    plant = build_plant(load_spec(name))
    build_s = time.perf_counter() - t0
    m = plant.model
    dt = plant.timestep_s
    n = max(200, int(sim_seconds / dt))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)

    def c_loop():
        mujoco.mj_step(m, d, nstep=n)

    def bare():
        step = mujoco.mj_step
        for _ in range(n):
            step(m, d)

    sim = MujocoPlant(plant)
    f = np.zeros(len(plant.actuator_points))
    pts = plant.sensor_points

    def lab():
        for _ in range(n):
            sim.set_forces(f)
            sim.step()
            sim.velocities(pts)

    c_loop()  # warm-up
    t_c = _best_of(c_loop) / n
    t_bare = _best_of(bare) / n
    t_lab = _best_of(lab) / n
    out = {"structure": name, "timestep_s": dt, "nv": m.nv, "build_s": build_s, "steps": n}
    for key, t in (("c_loop", t_c), ("bare_mj_step", t_bare), ("lab_step", t_lab)):
        out[key] = {"us_per_step": t * 1e6, "steps_per_s": 1.0 / t, "real_time_factor": dt / t,
                    "ratio_to_bare": t_bare / t}
    out["target_real_time_factor"] = TARGET_RT.get(name)
    # the target is judged on the lab step: the bare mj_step skips the applied modal damping
    out["meets_target"] = out["lab_step"]["real_time_factor"] >= TARGET_RT.get(name, 0.0)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=2.0, help="simulated seconds per measurement")
    ap.add_argument("--json", action="store_true", help="print JSON instead of a table")
    args = ap.parse_args()
    names = [s for s in ("bcc", "grid") if (STRUCTURES_DIR / f"{s}.toml").exists()]
    results = [measure(s, args.seconds) for s in names]
    if args.json:
        print(json.dumps(results, indent=2))
        return
    print(f"{'structure':9s} {'dt [ms]':>8s} {'nv':>4s} {'loop':>12s} {'us/step':>9s} {'steps/s':>10s} "
          f"{'x real time':>11s} {'vs bare':>8s}")
    for r in results:
        for key in ("c_loop", "bare_mj_step", "lab_step"):
            v = r[key]
            print(f"{r['structure']:9s} {r['timestep_s'] * 1e3:8.4f} {r['nv']:4d} {key:>12s} {v['us_per_step']:9.2f} "
                  f"{v['steps_per_s']:10.0f} {v['real_time_factor']:11.2f} {v['ratio_to_bare']:8.2f}")
        print(f"{'':9s} target {r['target_real_time_factor']}x real time at its timestep: "
              f"{'met' if r['meets_target'] else 'NOT met'} (lab step, modal damping included)")


if __name__ == "__main__":
    main()
