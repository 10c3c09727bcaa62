"""Speed of the MuJoCo plants: steps per second and real-time factor, one core.

For each structure (``bcc``, ``grid`` when its TOML exists) the plant is built
with its default options (automatic timestep) and stepped three ways in the
same run:

* ``mj_step x N``  -- ``mujoco.mj_step(m, d, nstep=N)``: the C loop, the
  ceiling;
* ``bare mj_step`` -- one ``mujoco.mj_step(m, d)`` call per step from Python;
* ``lab step``     -- what the control loop does per physics step:
  ``MujocoPlant.set_forces`` + ``step`` + ``velocities(sensor points)``.

Each drives the coils with random forces (0.5 N rms, held 10 ms): at rest the
constraint solver of a plant with loops has nothing to do and the step is not
representative (before 2026-11-25 the script stepped the plant at rest).

Reported: microseconds per step, steps per second, real-time factor
``steps/s * dt`` and the ratio of each to the bare ``mj_step`` (measured in
this run, so machine speed cancels). Targets (issue): BCC >= 20x real time,
grid >= 1x real time, both at the plant's own timestep.

With ``--accuracy`` it also checks that the chosen step is fine enough: a
10 ms, 10 mN force pulse at the first actuator, 4 s of sensor velocities
sampled at 2 kHz, at the plant's step and at a quarter of it (the reference);
printed are the relative difference of the responses (all of it, and in 1-20
Hz, the lab's band, from the spectra by Parseval) and the rms difference of the
response spectra's log-magnitude in 1-20 Hz [dB]. The full-band difference is
dominated by modes above the band (50-200 Hz on the BCC), whose phase drifts
over the 4 s.

Usage::

    python benchmarks/sim_speed.py [--seconds 2.0] [--accuracy] [--json]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import time

import mujoco
import numpy as np

from vlab.sim import MujocoPlant, SimOptions, build_plant
from vlab.sim.timestep import LAB_PERIOD_S
from vlab.spec import STRUCTURES_DIR, load_spec

from _listing import best_time

TARGET_RT = {"bcc": 20.0, "grid": 1.0}


def measure(name: str, sim_seconds: float) -> dict:
    """Time one structure's plant (default options); returns a dict of the numbers."""
    t0 = time.perf_counter()
    plant = build_plant(load_spec(name))
    build_s = time.perf_counter() - t0
    out = measure_plant(plant, sim_seconds)
    out["build_s"] = build_s
    return out


def measure_plant(plant, sim_seconds: float) -> dict:
    """Time a built plant three ways (C loop, bare ``mj_step``, lab step); returns a dict of the numbers.

    All three drive the coils with the same random forces (0.5 N rms, a new value every 10 ms): a plant
    at rest is not representative, as MuJoCo's constraint solver then has nothing to do.
    """
    name = plant.spec.name
    m = plant.model
    dt = plant.timestep_s
    hold = max(1, int(round(0.01 / dt)))
    n = max(200, int(sim_seconds / dt)) // hold * hold
    n_act = len(plant.actuator_points)
    forces = np.random.default_rng(0).normal(0.0, 0.5, (n // hold, n_act))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)

    def c_loop():
        for f in forces:
            d.ctrl[:n_act] = f
            mujoco.mj_step(m, d, nstep=hold)

    def bare():
        step = mujoco.mj_step
        for f in forces:
            d.ctrl[:n_act] = f
            for _ in range(hold):
                step(m, d)

    sim = MujocoPlant(plant)
    pts = plant.sensor_points

    def lab():
        for f in forces:
            for _ in range(hold):
                sim.set_forces(f)
                sim.step()
                sim.velocities(pts)

    c_loop()  # warm-up
    t_c = best_time(c_loop) / n
    t_bare = best_time(bare) / n
    t_lab = best_time(lab) / n
    out = {"structure": name, "timestep_s": dt, "nv": m.nv, "steps": n}
    for key, t in (("c_loop", t_c), ("bare_mj_step", t_bare), ("lab_step", t_lab)):
        out[key] = {"us_per_step": t * 1e6, "steps_per_s": 1.0 / t, "real_time_factor": dt / t,
                    "ratio_to_bare": t_bare / t}
    out["target_real_time_factor"] = TARGET_RT.get(name)
    # the target is judged on the lab step: the bare mj_step skips the applied modal damping
    out["meets_target"] = out["lab_step"]["real_time_factor"] >= TARGET_RT.get(name, 0.0)
    return out


def pulse_response(plant, seconds: float = 4.0) -> np.ndarray:
    """Sensor velocities [m/s], shape (2000 * seconds, n_sensors), after a 10 ms, 10 mN pulse."""
    sim = MujocoPlant(plant)
    sub = int(round(LAB_PERIOD_S / plant.timestep_s))
    f = np.zeros(len(plant.actuator_points))
    out = []
    for k in range(int(round(seconds / LAB_PERIOD_S))):
        f[0] = 0.01 if k < 20 else 0.0
        sim.set_forces(f)
        for _ in range(sub):
            sim.step()
        out.append(sim.velocities(plant.sensor_points).copy())
    return np.array(out)


def accuracy(name: str, options: SimOptions | None = None) -> dict:
    """The plant's pulse response against the same plant (same ``options``) at a quarter of its step."""
    spec = load_spec(name)
    options = options or SimOptions()
    plant = build_plant(spec, options)
    ref_plant = build_plant(spec, dataclasses.replace(options, timestep_s=plant.timestep_s / 4))
    y, ref = pulse_response(plant), pulse_response(ref_plant)
    freq = np.fft.rfftfreq(len(y), LAB_PERIOD_S)
    band = (freq > 1.0) & (freq < 20.0)
    Y, R = np.fft.rfft(y, axis=0)[band], np.fft.rfft(ref, axis=0)[band]
    db = 20 * np.log10(np.abs(Y) / np.abs(R))
    return {"structure": name, "timestep_s": plant.timestep_s, "reference_timestep_s": ref_plant.timestep_s,
            "time_rel_diff": float(np.linalg.norm(y - ref) / np.linalg.norm(ref)),
            "band_rel_diff": float(np.linalg.norm(Y - R) / np.linalg.norm(R)),
            "spectrum_db_rms": float(np.sqrt(np.mean(db**2)))}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=2.0, help="simulated seconds per measurement")
    ap.add_argument("--accuracy", action="store_true", help="also compare a pulse response with a 4x finer step")
    ap.add_argument("--json", action="store_true", help="print JSON instead of a table")
    args = ap.parse_args()
    names = [s for s in ("bcc", "grid") if (STRUCTURES_DIR / f"{s}.toml").exists()]
    results = [measure(s, args.seconds) for s in names]
    acc = [accuracy(s) for s in names] if args.accuracy else []
    if args.json:
        print(json.dumps({"speed": results, "accuracy": acc} if acc else results, indent=2))
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
    for a in acc:
        print(f"{a['structure']:9s} pulse response at {a['timestep_s'] * 1e3:.4g} ms vs "
              f"{a['reference_timestep_s'] * 1e3:.4g} ms: difference {a['time_rel_diff'] * 100:.2f} % "
              f"(1-20 Hz: {a['band_rel_diff'] * 100:.2f} %), "
              f"spectrum 1-20 Hz {a['spectrum_db_rms']:.3f} dB rms")


if __name__ == "__main__":
    main()
