"""Replays of a recorded test: its excitation force played back through the lab loop on a plant of a lab state.

The recorded excitation force is played back through the 2 kHz loop of
:func:`vlab.lab.loop.run_loop` (same controller, hardware chain and
sampling) on a plant built from the lab state -- the MuJoCo plant of
:mod:`vlab.sim` built from the (modified) spec when the effect can be
expressed in a spec and MuJoCo is available, else the exact linear plant
(:class:`vlab.lab.linear_plant.LinearPlant`). With periodic excitation both
runs (nominal and with the effect) start one period before the analysed
ones, in the lab's periodic steady state, and simulate one analysed period
(:mod:`vlab.diagnose.data.warmstart`); otherwise they start from rest, as the
recording did.

The same replay gives the reference of a recording (the nominal plant's
replay, :mod:`vlab.diagnose.data.reference`), the look-alike reruns of the
selection (:func:`vlab.diagnose.fit.selection.tie_break_by_rerun`) and the
validation (:mod:`vlab.diagnose.validate`): reruns are made in parallel
processes or in the background -- several MuJoCo reruns whose plants share
one layout as one ``mujoco.batch`` (:mod:`vlab.diagnose.data.batchrerun`) --
and kept in the diagnosis's run context (:mod:`vlab.diagnose.data.rerun_jobs`).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ...fe.damping import structural_damping
from ...errors import ModelError
from ...lab.engine import ControllerEngine
from ...lab.linear_plant import LinearPlant
from ...lab.loop import run_loop
from ...io.recording import Recording
from ...measure.frf import h1
from ...measure.transient import periodic_spectra
from ..model.labmodel import LabState
from .measured import FrfData
from .warmstart import warm_start

#: Level of the reruns that give a MuJoCo plant's best linear approximation [1] (:func:`distortion_variance`):
#: a distortion that grows at least in proportion to the level keeps at most this fraction of itself there.
#: The lab's own nonlinear elements scale exactly (:func:`vlab.diagnose.data.replay.at_amplitude`). A chosen
#: level; a lower one changes the estimated distortion by at most this fraction.
LOW_LEVEL = 0.1



class FrictionPlant:
    """A linear plant with Coulomb friction at some points (the loop's Plant protocol).

    The friction force ``-F tanh(v / v_s)`` at each point is computed from the
    velocity at the start of every physics step and held over it (explicit;
    ``v_s`` is a small regularising velocity, 1e-6 m/s, so that the force does
    not chatter around ``v = 0``).

    Parameters
    ----------
    inner : LinearPlant
        With the friction points appended to its actuator points.
    actuator_points : tuple of int
        The coil points (the first inputs of ``inner``).
    frictions : sequence of (int, float) or (int, float, float)
        ``(point, F [N])``, optionally with the equivalent dashpot ``c_eq`` [N*s/m]
        (for the warm start, :meth:`set_periodic_state`; 0 without).
    """

    def __init__(self, inner: LinearPlant, actuator_points: tuple[int, ...], frictions, *, v_s: float = 1e-6):
        self.inner = inner
        self.actuator_points = tuple(actuator_points)
        self.timestep_s = inner.timestep_s
        self._fp = tuple(fr[0] for fr in frictions)
        self._ff = np.array([fr[1] for fr in frictions], dtype=float)
        self._c_eq = np.array([fr[2] if len(fr) > 2 else 0.0 for fr in frictions], dtype=float)
        self._v_s = v_s
        self._f = np.zeros(len(self.actuator_points))

    def set_periodic_state(self, freq_hz, forces) -> None:
        """The inner plant's periodic steady state of the coil forces ``forces`` (n_f, n_act) at
        ``freq_hz`` [Hz], with each friction force replaced by its equivalent dashpot (the describing
        function the frequency-domain model uses; what it misses decays in the guard period of
        :mod:`vlab.diagnose.data.warmstart`)."""
        F = np.asarray(forces, dtype=complex)
        self.inner.set_periodic_state(freq_hz, np.hstack([F, np.zeros((F.shape[0], len(self._fp)))]),
                                      extra_damping=dict(zip(self._fp, self._c_eq)))

    def set_forces(self, forces) -> None:
        """Coil forces [N], shape (n_act,)."""
        self._f = np.asarray(forces, dtype=float)

    def step(self) -> None:
        """One physics step with the friction force of the current velocity."""
        v = self.inner.velocities(self._fp)
        self.inner.set_forces(np.concatenate([self._f, -self._ff * np.tanh(v / self._v_s)]))
        self.inner.step()

    def velocities(self, points) -> np.ndarray:
        """Velocities [m/s] at ``points``."""
        return self.inner.velocities(points)

    def displacements(self, points) -> np.ndarray:
        """Displacements [m] at ``points``."""
        return self.inner.displacements(points)


def at_amplitude(state: LabState, scale: float) -> LabState:
    """The lab whose every force level is scaled by ``scale``: the amplifier's force limits, the Coulomb
    friction forces, the RMS command forces of the saturation's describing function and the controller's
    sensor noise (the equivalent dashpots are ratios of force to velocity and stay). Played back with the
    recorded force times ``scale``, every response of the lab's own elements -- linear ones, and the
    saturation and friction, whose forces are homogeneous of degree one in the level -- is the recorded
    level's times ``scale``; what does not scale is the plant's own amplitude dependence (a MuJoCo plant's
    finite rotations, a tensioned cable's stretch): the best linear approximation of a nonlinear plant and
    its nonlinear distortion (Pintelon & Schoukens, *System Identification: A Frequency Domain Approach*,
    2nd ed., Wiley 2012, Ch. 3).

    Parameters
    ----------
    state : LabState
    scale : float
        Level factor [1], > 0.

    Returns
    -------
    LabState

    Raises
    ------
    ValueError
        A scale that is not a positive finite number.
    """
    if not (np.isfinite(scale) and scale > 0.0):
        raise ValueError(f"amplitude scale must be a positive finite number, got {scale!r}")
    ch = state.chain
    lim = None if ch.amplifier_limit_n is None else ch.amplifier_limit_n * scale
    chain = replace(ch, amplifier_limit_n=lim, noise_m_s=ch.noise_m_s * scale,
                    channel_limit_n={p: (None if v is None else v * scale) for p, v in ch.channel_limit_n.items()})
    return replace(state, chain=chain, frictions=tuple((p, f * scale, c) for p, f, c in state.frictions),
                   rms_force_n={p: v * scale for p, v in state.rms_force_n.items()})


def expectation(state: LabState) -> LabState:
    """The lab whose controller's sensor noise is off: what a rerun predicts is the response expected for
    the recorded force, the recording's own noise being counted once, in the data's variance.

    A rerun with the sensor noise of the recorded chain adds a second, independent noise to the compared
    FRFs and time histories: an exact model's rerun then misses the recording by about ``sqrt(2)`` times
    what the recording's noise alone leaves, which is where a remainder starts to count as resolved
    (:func:`vlab.diagnose.fit.confirm.remainder_resolved`). The noise's share of a nonlinear element's
    action (a friction's dither, a clip's) is left out with it: the chain's noise (``noise_m_s``) is
    orders below a recorded test's response.

    Parameters
    ----------
    state : LabState

    Returns
    -------
    LabState
        ``state`` itself where its chain has no noise.
    """
    if state.chain.noise_m_s == 0.0:
        return state
    return replace(state, chain=replace(state.chain, noise_m_s=0.0))


def linear_plant(state: LabState):
    """The exact linear plant of a lab state: proportional modal damping of the spec, point dashpots,
    and Coulomb friction (:class:`FrictionPlant`) where the state has it.

    Raises
    ------
    ModelError
        A dashpot or friction at a point without a free out-of-plane DOF.
    """
    fe = state.fe
    c = np.array(structural_damping(fe, state.spec))  # a copy: the dashpots are added to it
    for p, cp in state.dashpots:
        i = fe.dofs.index(p, "w")
        c[i, i] += cp
    pidx = {p: fe.dofs.index(p, "w") for p in state.spec.points if (p, "w") in fe.dofs}
    if not state.frictions:
        return LinearPlant(fe.m, c, fe.k, point_index=pidx, actuator_points=state.actuators, timestep_s=state.h_s)
    for p, _f, _c in state.frictions:
        fe.dofs.index(p, "w")
    inputs = state.actuators + tuple(p for p, _f, _c in state.frictions)
    inner = LinearPlant(fe.m, c, fe.k, point_index=pidx, actuator_points=inputs, timestep_s=state.h_s)
    return FrictionPlant(inner, state.actuators, state.frictions)


def mujoco_plant(state: LabState, sensors=()):
    """The MuJoCo plant of ``state``: loaded from its ``mjcf`` file, else built from its spec (:func:`vlab.sim.build_plant`).

    Parameters
    ----------
    state : LabState
    sensors : sequence of int
        Points whose velocity will be read (an MJCF must have ``vel<ID>`` sensors there).

    Raises
    ------
    ModelError
        When the state carries changes a spec cannot express (dashpots, an
        edited FE stiffness), the simulation package cannot build it, or the
        MJCF breaks the naming contract (:func:`vlab.sim.contract.check_plant_contract`).
    DataFileError
        The MJCF cannot be loaded.
    """
    if state.dashpots or state.frictions:
        raise ModelError("point dashpots and friction cannot be expressed in the spec the MuJoCo plant is built from")
    try:
        from ...fe import build_fe_model
        from ...sim import MujocoPlant, build_plant
        from ...sim.runtime import load_plant_for_experiment
    except ImportError as exc:  # pragma: no cover - depends on the installation
        raise ModelError(f"MuJoCo plant unavailable: {exc}") from None
    if state.mjcf is not None:
        return load_plant_for_experiment(state.spec, mjcf=state.mjcf, sensors=tuple(sensors))[0]
    rebuilt = build_fe_model(state.spec)
    if not np.array_equal(rebuilt.k, state.fe.k):
        raise ModelError("the state's FE stiffness is edited beyond its spec (gravity pre-stress)")
    return MujocoPlant(build_plant(state.spec))


def plant_step_s(state: LabState) -> float:
    """The physics step [s] of ``state``'s MuJoCo plant (:func:`mujoco_plant`), the step over which its coil
    forces are held, which the lab model of a comparison through that plant must use
    (:attr:`LabState.step_s <vlab.diagnose.model.labmodel.LabState>`: the RC filter's and the coil lag's step
    averages).

    Raises
    ------
    ModelError, DataFileError
        As :func:`mujoco_plant`.
    SimulationError
        The plant cannot be built (:func:`vlab.sim.build_plant`).
    """
    return float(mujoco_plant(state).timestep_s)


def rerun(state: LabState, force: np.ndarray, *, excitation_point: int, measured_points: tuple[int, ...],
          plant: str = "linear", seed: int = 0, start: int = 0, period: int = 0,
          stop: int | None = None) -> tuple[Recording, str]:
    """Play the recorded excitation back through the lab loop, from rest or from a warm start.

    Parameters
    ----------
    state : LabState
    force : ndarray, shape (n_ticks,)
        Excitation command, one value per controller period [N].
    excitation_point : int
    measured_points : tuple of int
        Velocity channels to record.
    plant : {"linear", "mujoco"}
    seed : int
        Seed of the controller's sensor noise (the chain's ``noise_m_s``).
    start : int
        Tick to start at.
    period : int
        Ticks per excitation period: given (> 0), the rerun begins in the
        lab's periodic steady state at ``start``
        (:func:`vlab.diagnose.data.warmstart.warm_start`); 0: from rest.
    stop : int, optional
        Tick to stop before (default: the end of ``force``).

    Returns
    -------
    (Recording, str)
        The rerun from tick ``start`` on (its metadata ``start_s`` says where
        it begins on the recording's time axis [s]) and a description of the
        plant used.

    Raises
    ------
    ModelError
        Unknown plant kind or a state the plant cannot carry.
    SimulationError
        The plant diverged.
    """
    if plant == "linear":
        p, kind = linear_plant(state), "linear FE plant"
    elif plant == "mujoco":
        p = mujoco_plant(state, sensors=measured_points)
        kind = "MuJoCo plant" if state.mjcf is None else f"MuJoCo plant of {state.mjcf}"
    else:
        raise ModelError(f"unknown plant {plant!r}; use 'linear' or 'mujoco'")
    d = state.design
    engine = None
    if d is not None:
        engine = ControllerEngine(d.f11, d.f12, d.f21, d.f22, period_s=state.chain.period_s)
    force = np.asarray(force, dtype=float)
    if period:  # from the whole record: the period after ``start`` may reach past ``stop``
        warm_start(state, p, engine, force, excitation_point=excitation_point, start=start, n_per=period)
    force = force[:stop]
    n = len(force) - start
    loop = run_loop(p, engine, feedback_points=state.actuators, measured_points=tuple(measured_points),
                    excitation_point=excitation_point, excitation=force[start:],
                    duration_s=n * state.chain.period_s, chain=state.chain, seed=seed,
                    shape_points=(), metadata={"start_s": start * state.chain.period_s})
    return loop.recording, kind


def _offset(rec: Recording, data: FrfData) -> tuple[int, int]:
    """First analysed sample of ``data``'s recording and of the rerun ``rec`` (which may begin later,
    at its metadata ``start_s``)."""
    first = int(round(data.analysed_from_s / rec.dt_s))
    return first, first - int(round(float(rec.metadata.get("start_s", 0.0)) / rec.dt_s))


def frf_of(rec: Recording, data: FrfData) -> np.ndarray:
    """FRFs of the rerun ``rec`` on the lines of ``data``, the same periods analysed, shape (n_f, n_o); periodic
    excitation over two or more periods: the transient removed as for the recording
    (:func:`vlab.measure.transient.periodic_spectra`); a transient excitation over the recording's records with
    its force window (:func:`vlab.measure.impact.transient_h1`)."""
    dt = rec.dt_s
    f0 = data.freq_hz
    df = float(np.min(np.diff(f0)))  # the lines are multiples of the resolution
    if data.records is not None:  # a transient excitation: the recording's records and force window
        from ...measure.impact import transient_h1

        x = np.asarray(rec[f"force{data.excitation_point}"])
        ys = np.stack([np.asarray(rec[f"vel{p}"]) for p in data.output_points], axis=1)
        e = transient_h1(x, ys, dt_s=dt, resolution_hz=df, records=data.records)
        k = np.rint(f0 / df).astype(int)
        return e.h[k]
    if not data.periodic:
        x = np.asarray(rec[f"force{data.excitation_point}"])
        out = np.empty((f0.size, len(data.output_points)), dtype=complex)
        for j, p in enumerate(data.output_points):
            frf = h1(x, np.asarray(rec[f"vel{p}"]), dt_s=dt, resolution_hz=df, window="hann")
            out[:, j] = np.interp(f0, frf.freq_hz, frf.h.real) + 1j * np.interp(f0, frf.freq_hz, frf.h.imag)
        return out
    n_per = int(round(1.0 / (df * dt)))
    start = _offset(rec, data)[1]
    x = np.asarray(rec[f"force{data.excitation_point}"])[start:]
    m = x.size // n_per
    x = x[: m * n_per].reshape(m, n_per)
    k = np.rint(f0 / df).astype(int)
    X = np.fft.rfft(x, axis=1)[:, k]
    ys = [np.asarray(rec[f"vel{p}"])[start:start + m * n_per] for p in data.output_points]
    if m >= 2:  # the estimator of the recording (vlab.diagnose.data.frfestimate): what is left of a transient removed
        return periodic_spectra(np.stack(ys, axis=1), n_per, k).y / X.mean(axis=0)[:, None]
    return np.stack([np.mean(np.fft.rfft(y.reshape(m, n_per), axis=1)[:, k] / X, axis=0) for y in ys], axis=1)


def time_error(rec: Recording, data: FrfData) -> float:
    """``||v_rerun - v_recorded|| / ||v_recorded||`` of the rerun ``rec`` against the recording of ``data``,
    over the velocity channels after the transient (a warm-started rerun aligned by its ``start_s``)."""
    first, own = _offset(rec, data)
    num = den = 0.0
    for p in data.output_points:
        a = np.asarray(data.recording[f"vel{p}"])[first:]
        b = np.asarray(rec[f"vel{p}"])[own:]
        n = min(a.size, b.size)
        a, b = a[:n], b[:n]
        num += float(np.sum((b - a) ** 2))
        den += float(np.sum(a**2))
    return float(np.sqrt(num / den)) if den > 0 else float("nan")


def rerun_payload(state: LabState, force: np.ndarray, excitation_point: int, points: tuple[int, ...], plant: str,
                  seed: int, window: tuple = (0, 0, None)) -> tuple[float, dict, dict]:
    """A rerun in a form a worker process can send back: :func:`rerun` over the ticks ``window``.

    Parameters
    ----------
    state : LabState
        The lab rerun.
    force : ndarray, shape (n_ticks,)
        The excitation command [N].
    excitation_point : int
        Point of the excited coil.
    points : tuple of int
        Points whose velocities are recorded.
    plant : {"linear", "mujoco"}
    seed : int
        Seed of the controller's sensor noise.
    window : tuple
        ``(start, period, stop)`` ticks (:func:`vlab.diagnose.data.warmstart.rerun_window`).

    Returns
    -------
    (dt_s, signals, metadata)
        Sampling interval [s], ``{channel: samples}`` and the recording's metadata
        (:func:`recording_of` makes the :class:`Recording` again).

    Raises
    ------
    ModelError, SimulationError
        As :func:`rerun`.
    """
    rec, _ = rerun(state, force, excitation_point=excitation_point, measured_points=points, plant=plant, seed=seed,
                   start=window[0], period=window[1], stop=window[2])
    return rec.dt_s, {c.name: np.asarray(c.samples) for c in rec.channels}, dict(rec.metadata)


def rerun_split(state: LabState, force: np.ndarray, *, excitation_point: int, measured_points: tuple[int, ...],
                plant: str, seed: int, start: int, first: int, period: int, stop: int | None,
                workers: int = 2) -> Recording:
    """A warm-started rerun made as ``workers`` shorter reruns in parallel processes.

    The analysed ticks ``[first, stop)`` are cut into ``workers`` consecutive pieces; each is rerun from
    its own warm start (:func:`vlab.diagnose.data.warmstart.warm_start`: the excitation is periodic, so the
    lab's steady state is known at any tick) the same guard ``first - start`` before it, and the pieces
    are joined. Each piece's start error decays over its guard as the single rerun's does, so the join is
    the single rerun's analysed part to that accuracy, in about ``(guard + analysed / workers) /
    (guard + analysed)`` of its time on ``workers`` cores. One rerun where no process pool can start.

    Parameters
    ----------
    state : LabState
    force : ndarray, shape (n_ticks,)
        Excitation command [N], periodic with ``period`` ticks (continued periodically past its end
        where a piece's warm start needs it).
    excitation_point : int
    measured_points : tuple of int
    plant : {"linear", "mujoco"}
    seed : int
        As :func:`rerun`.
    start, first : int
        Tick of the warm start and first analysed tick (``start <= first``).
    period : int
        Ticks per excitation period (> 0).
    stop : int or None
        Tick to stop before (None: the end of ``force``).
    workers : int
        Processes (pieces).

    Returns
    -------
    Recording
        From tick ``first`` (its metadata ``start_s``) to ``stop``.

    Raises
    ------
    ModelError, SimulationError
        As :func:`rerun`.
    """
    force = np.asarray(force, dtype=float)
    stop = force.size if stop is None else int(stop)
    guard = first - start
    n = stop - first
    bounds = [first + (n * j) // workers for j in range(workers + 1)]
    ext = force
    need = bounds[-2] - guard + period  # the last piece's warm start reads one period from its start
    if need > force.size:
        k = np.arange(force.size, need)
        ext = np.concatenate([force, force[k - period * ((k - force.size) // period + 1)]])
    jobs = [(a - guard, b) for a, b in zip(bounds[:-1], bounds[1:])]
    pieces = None
    if workers > 1:
        from concurrent.futures import ProcessPoolExecutor
        from concurrent.futures.process import BrokenProcessPool

        try:
            with ProcessPoolExecutor(workers) as ex:
                futs = [ex.submit(rerun_payload, state, ext, excitation_point, tuple(measured_points), plant, seed,
                                  (a, period, b)) for a, b in jobs]
                pieces = [recording_of(f.result()) for f in futs]
        except (OSError, BrokenProcessPool):
            pieces = None
    if pieces is None:
        pieces = [rerun(state, ext, excitation_point=excitation_point, measured_points=measured_points,
                        plant=plant, seed=seed, start=a, period=period, stop=b)[0] for a, b in jobs]
    joined = {c.name: np.concatenate([np.asarray(r[c.name])[guard:] for r in pieces]) for c in pieces[0].channels}
    dt = pieces[0].dt_s
    return Recording.from_signals(dt, joined, metadata={**pieces[0].metadata, "start_s": first * dt})


def recording_of(payload: tuple[float, dict, dict]) -> Recording:
    """The :class:`Recording` of a :func:`rerun_payload` result ``(dt_s, signals, metadata)``."""
    dt, signals, meta = payload
    return Recording.from_signals(dt, signals, metadata=meta)


def distortion_variance(full: tuple, low: tuple) -> np.ndarray:
    """The relative variance [1] per line of a plant's own level dependence: ``sum_i |d_i|^2``,
    ``d_i = H_i / H_low,i - 1``, over the plays ``full`` at the recorded level and ``low`` at :data:`LOW_LEVEL`
    x it of the same runs (each ``d`` the nonlinear distortion, to within ``LOW_LEVEL`` of itself), shape
    (n_f, n_o); 0 where a ratio is not finite.

    Whether the recorded structure shares the plant's level dependence (a hinge chain's finite rotations, a
    cable's stretch) is not known: it is the plant's model form, not the effect's. So the validation's
    reruns (nominal and modified) are judged by their best linear approximations (the low-level reruns,
    which keep the lab's saturation and friction, :func:`vlab.diagnose.data.replay.at_amplitude`) with both
    distortions as a variance about them, one covariance for both, and a replay that is the data's reference
    carries its own (:func:`vlab.diagnose.data.reference.with_replay_distortion`) (Pintelon & Schoukens,
    *System Identification: A Frequency Domain Approach*, 2nd ed., Wiley 2012, Ch. 3: the best linear
    approximation and its nonlinear distortions).

    Parameters
    ----------
    full, low : tuple of ndarray, complex, shape (n_f, n_o)
        The runs' FRFs [(m/s)/N] at the recorded level and, in the same order, at the low level.

    Returns
    -------
    ndarray, shape (n_f, n_o)
        Relative complex variance [1] per line and channel.
    """
    var = np.zeros(np.shape(full[0]))
    for h, h_low in zip(full, low):
        with np.errstate(divide="ignore", invalid="ignore"):
            d = h / h_low - 1.0
        var = var + np.where(np.isfinite(d), np.abs(d) ** 2, 0.0)
    return var
