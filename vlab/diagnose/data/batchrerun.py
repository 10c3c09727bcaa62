"""Several MuJoCo reruns of one recorded force advanced together on one ``mujoco.batch``.

The diagnosis reruns the recorded test on several lab states at once: the
look-alike candidates of :func:`vlab.diagnose.fit.selection.tie_break_by_rerun`
and the validation pair (nominal and modified) of :mod:`vlab.diagnose.validate`.
Where their MuJoCo plants differ only in values -- masses, stiffnesses,
damping, gains, the hardware chain -- and not in the sizes of what ``MjData``
holds, the reruns run as one :func:`vlab.lab.batch.run_batch` on a
:class:`vlab.sim.batch_plant.MujocoBatchPlant` with one compiled model per
simulation (``models=``), instead of one process each.

Each simulation is started as :func:`vlab.diagnose.data.replay.rerun` starts
its single plant: from rest in its settled state, or warm-started
(:func:`vlab.diagnose.data.warmstart.warm_start` on the candidate's own
single plant and controller engine, whose joint state and controller state
are then copied into the batch: :meth:`MujocoBatchPlant.set_state`, the
``initial_states`` of :func:`run_batch`). The batched loop runs the single
loop's arithmetic (tests/test_batch.py), so a batched rerun's recording is the
single rerun's bit for bit (tests/test_diagnose_batchrerun.py).

Candidates that cannot share a batch -- a different layout (an added mass
is a new geom), controllers of different sizes, another physics step or
controller period, a measured point without a velocity sensor -- are told
apart by :func:`batch_key` and :func:`why_apart`; the caller reruns them
the single way (processes).

Source: ``mujoco.batch.Batch.set_models`` (mujoco 4.0: "the same sizes of
everything MjData holds, as models compiled from one spec with different
parameters ... do").
"""

from __future__ import annotations

import numpy as np

from ...errors import ModelError, SimulationError, VlabError
from ...lab.engine import ControllerEngine
from ...sim.batch_plant import layout
from ..model.labmodel import LabState
from .warmstart import warm_start

def batch_key(state: LabState, plant, measured_points: tuple[int, ...]) -> tuple | None:
    """What reruns must share to run on one batch; None when ``plant`` cannot be batched at all.

    Parameters
    ----------
    state : LabState
        The lab rerun (its controller design and hardware chain).
    plant : vlab.sim.runtime.MujocoPlant
        Its MuJoCo plant (:func:`vlab.diagnose.data.replay.mujoco_plant`).
    measured_points : tuple of int
        The velocity channels recorded; each needs a ``vel<ID>`` sensor (the
        batch reads sensors only, the single plant may read a site).

    Returns
    -------
    tuple or None
        ``(layout, physics step [s], controller period [s], actuator points,
        controller size, damped modes)``: reruns with equal keys can share a
        batch.
    """
    if not all(p in plant.sensor_points for p in measured_points):
        return None
    d = state.design
    ctl = None if d is None else (np.shape(d.f11), np.shape(d.f22))
    md = plant.modal_damping
    return (layout(plant.model), float(plant.timestep_s), float(state.chain.period_s), tuple(state.actuators),
            ctl, None if md is None else md.A.shape)


def why_apart(a: tuple | None, b: tuple | None) -> str:
    """A short reason why two :func:`batch_key` results differ ('' when they are equal)."""
    if a == b:
        return ""
    if a is None or b is None:
        return "a measured point without a velocity sensor"
    if a[0] != b[0]:
        da, db = dict(a[0]), dict(b[0])
        diff = [f"{k} {da.get(k)} vs {db.get(k)}" for k in sorted(set(da) | set(db)) if da.get(k) != db.get(k)]
        return "model sizes differ (" + ", ".join(diff[:3]) + ")"
    what = ("", "physics step", "controller period", "actuator points", "controller size", "modal damping size")
    return next(f"{what[i]} differs" for i in range(1, len(a)) if a[i] != b[i])


def rerun_together(states: list, plants: list, force: np.ndarray, *, excitation_point: int,
                   measured_points: tuple[int, ...], seed: int = 0, start: int = 0, period: int = 0,
                   stop: int | None = None, nthread: int = 0) -> list:
    """The reruns of :func:`vlab.diagnose.data.replay.rerun` on the MuJoCo plant for several lab states, on one batch.

    Parameters
    ----------
    states : list of LabState
        N >= 1 labs, all with one :func:`batch_key`.
    plants : list of MujocoPlant
        Their plants, built for them (changed here: a warm start sets their state).
    force : ndarray, shape (n_ticks,)
        Excitation command, one value per controller period [N].
    excitation_point : int
    measured_points : tuple of int
    seed : int
        Seed of every simulation's sensor noise (as :func:`rerun`).
    start, period : int
        As :func:`rerun`: the start tick, and ticks per excitation period for a warm start (0: from rest).
    stop : int, optional
        Tick to stop before (default: the end of ``force``).
    nthread : int
        Threads of the batch (0: all CPUs).

    Returns
    -------
    list of Recording or VlabError
        Per state, the rerun from tick ``start`` on (metadata ``start_s`` [s]) as
        :func:`rerun` returns it, or the error that stopped it (a warm start that
        failed, a diverged simulation: ``SimulationError``).

    Raises
    ------
    ModelError
        Reruns that cannot share a batch (different :func:`batch_key`), or
        counts of ``states`` and ``plants`` that differ.
    """
    from ...lab.batch import run_batch
    from ...sim.batch_plant import MujocoBatchPlant

    if len(states) != len(plants) or not states:
        raise ModelError(f"rerun_together: {len(states)} states and {len(plants)} plants")
    pts = tuple(measured_points)
    keys = [batch_key(st, p, pts) for st, p in zip(states, plants)]
    if keys[0] is None or any(k != keys[0] for k in keys):
        bad = next((k for k in keys if k != keys[0]), keys[0])
        raise ModelError(f"these reruns cannot share one batch: {why_apart(keys[0], bad)}")
    force = np.asarray(force, dtype=float)
    out: list = [None] * len(states)
    engines = []
    for i, (st, p) in enumerate(zip(states, plants)):
        d = st.design
        eng = None if d is None else ControllerEngine(d.f11, d.f12, d.f21, d.f22, period_s=st.chain.period_s)
        engines.append(eng)
        if period:  # as rerun(): from the whole record
            try:
                warm_start(st, p, eng, force, excitation_point=excitation_point, start=start, n_per=period)
            except VlabError as exc:
                out[i] = exc
    live = [i for i in range(len(states)) if out[i] is None]
    if not live:
        return out
    force = force[:stop]
    n = len(force) - start
    dt = states[live[0]].chain.period_s
    bp = MujocoBatchPlant(plants[live[0]], len(live), nthread=nthread, models=[plants[i].model for i in live])
    if period:
        bp.set_state(np.array([plants[i].data.qpos for i in live]), np.array([plants[i].data.qvel for i in live]))
    ctl = None if engines[live[0]] is None else [engines[i] for i in live]
    x0 = None if ctl is None else np.array([e.state for e in ctl])
    res = run_batch(bp, ctl, feedback_points=states[live[0]].actuators, measured_points=pts,
                    excitation_point=excitation_point, excitation=force[start:], duration_s=n * dt,
                    chain=[states[i].chain for i in live], seeds=seed, initial_states=x0)
    for j, i in enumerate(live):
        if j in res.failures:
            out[i] = SimulationError(res.failures[j])
        else:
            out[i] = res.result(j, {"start_s": start * dt}).recording
    return out

