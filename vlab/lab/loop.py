"""The digital control loop of Fig. 21, run against any plant.

One controller tick every ``chain.period_s`` (Sec. 5.3: 0.5 ms, 2 kHz, for the DRF
controllers; 1 ms for LQG)::

    y_k  = sensor gain x velocity (x lag) + noise         (sampled at t_k; also recorded)
    u_k  = engine.step(y_k)                               (Eq. 5.1)
    DAC  : u_k appears 1.35 periods after t_k, held       (SampleDelay; a channel may have its own delay)
    for each physics step h in the tick:
        RC  : filtered DAC voltage, averaged over the step (677 Hz, exact)
        f   = amplifier(RC output + excitation on one channel)
        plant.step(f)

The plant is anything with the :class:`Plant` protocol: the MuJoCo plant of
:mod:`vlab.sim` or the linear model of :mod:`vlab.lab.linear_plant`. A
diverging plant stops the run with :class:`vlab.errors.SimulationError`
saying when; the recording made so far is attached to the error
(``exc.partial``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Protocol

import numpy as np

from ..errors import ModelError, SimulationError
from .blocks import PC1000_DELAY_PERIODS, PC1000_PERIOD_S, RC_CORNER_HZ, CurrentAmplifier, RCLowPass, SampleDelay, SensorNoise
from .engine import ControllerEngine
from .recording import Recording


class Plant(Protocol):
    """What the loop needs from a plant.

    ``timestep_s`` is the physics step [s]; ``actuator_points`` the point ids of
    the force inputs (order of ``set_forces``); ``velocities(points)`` the
    out-of-plane velocities [m/s]; ``displacements(points)`` the out-of-plane
    displacements from the settled state [m]; ``step()`` advances one physics
    step with the forces last set [N]. Implemented by
    :class:`vlab.sim.runtime.MujocoPlant` and
    :class:`vlab.lab.linear_plant.LinearPlant`.

    Attributes
    ----------
    timestep_s : float
        Physics step h [s]; it must divide the controller period
        (:attr:`HardwareChain.period_s`) into a whole number of steps.
    actuator_points : tuple of int, length n_act
        Point ids of the coil (force) channels, in the order of the force
        vector given to :meth:`set_forces`.

    Notes
    -----
    This is a structural type (``typing.Protocol``): it is never
    instantiated, and its constructor is the placeholder
    ``__init__(self, *args, **kwargs)`` that ``typing.Protocol`` supplies;
    ``args`` and ``kwargs`` mean nothing here. How a concrete plant is built
    is up to its own class.
    """

    timestep_s: float
    actuator_points: tuple[int, ...]

    def set_forces(self, forces: np.ndarray) -> None:
        """Set the coil forces held over the following physics steps.

        ``forces`` is an ndarray of shape (n_act,) [N]: one out-of-plane force
        per channel, in the order of ``actuator_points`` (the amplifier output
        of Fig. 21); the forces stay applied until the next call.
        """
        ...

    def step(self) -> None:
        """Advance the plant by one physics step.

        Takes no parameters: the step is ``timestep_s`` [s] long and uses the
        forces last given to :meth:`set_forces`. A plant that detects its own
        divergence may raise :class:`vlab.errors.SimulationError`; the loop
        also checks the velocities it reads.
        """
        ...

    def velocities(self, points: tuple[int, ...]) -> np.ndarray:
        """Out-of-plane velocities at some points.

        ``points`` is a tuple of n_p point ids; the result is an ndarray of
        shape (n_p,) [m/s] in the order of ``points``. The loop reads the
        feedback sensors and the measured points through it once per
        controller tick.
        """
        ...

    def displacements(self, points: tuple[int, ...]) -> np.ndarray:
        """Out-of-plane displacements from the settled state at some points.

        ``points`` is a tuple of n_p point ids; the result is an ndarray of
        shape (n_p,) [m], measured from the settled (static equilibrium)
        state, in the order of ``points``. The loop samples it once per tick
        for the deformed-shape animation.
        """
        ...


@dataclass(frozen=True)
class HardwareChain:
    """Settings of the hardware between controller and coils (Sec. 5.3), each switchable.

    Attributes
    ----------
    period_s : float
        Controller sampling period [s] (0.5 ms: 2000 samples/s).
    delay_periods : float
        Computation delay from sample to DAC output, in periods (1.35; 0 = off).
    filter_hz : float or None
        RC low-pass corner [Hz] (677; None = off).
    amplifier_gain : float
        Controlled-current amplifier and coil: force per unit command [N/N].
    amplifier_limit_n : float or None
        Force saturation [N] (None = linear).
    noise_m_s : float
        Velocity-sensor noise standard deviation [m/s] (0 = off), on every
        sensor: the feedback sensors and the measured points (one independent
        draw per sensor per tick), so it is in the recording as in the
        feedback.
    actuator_gain : dict[int, float]
        Per-channel force gain [-] keyed by actuator point id, multiplying the
        amplifier output of that coil (missing points: 1). Not in the
        dissertation: a hardware deviation that :mod:`vlab.diagnose` can fit
        (e.g. a coil constant that is off).
    sensor_gain : dict[int, float]
        Per-channel sensitivity [-] keyed by feedback (sensor) point id,
        multiplying the velocity that sensor measures (missing points: 1): the
        controller reads it and, where the point is measured, the recording
        holds it. A diagnosis hypothesis, like ``actuator_gain``.
    actuator_lag_hz : float or None
        Corner frequency [Hz] of an extra first-order lag on each coil force,
        applied at every physics step (None = off). A diagnosis hypothesis
        (e.g. coil inductance), not part of the Sec. 5.3 chain.
    sensor_lag_hz : float or None
        Corner frequency [Hz] of an extra first-order lag on each feedback
        sensor's velocity, applied once per controller period before the noise
        (None = off); the recorded channel of that point carries it too. A
        diagnosis hypothesis, not part of the Sec. 5.3 chain.
    channel_delay_periods : dict[int, float]
        Per-channel delay from sample to DAC output [periods], keyed by
        actuator point id (>= 0; missing points: ``delay_periods``): e.g. one
        coil's DAC output later than the others. A diagnosis hypothesis.
    channel_actuator_lag_hz : dict[int, float or None]
        Per-channel actuator-lag corner [Hz] keyed by actuator point id
        (None: no lag on that coil; missing points: ``actuator_lag_hz``).
    channel_sensor_lag_hz : dict[int, float or None]
        Per-channel sensor-lag corner [Hz] keyed by feedback sensor point id
        (None: no lag on that sensor; missing points: ``sensor_lag_hz``).
    channel_limit_n : dict[int, float or None]
        Per-channel force limit [N] of the amplifier keyed by actuator point
        id (None: linear; missing points: ``amplifier_limit_n``).

    Raises
    ------
    ModelError
        A per-channel entry whose key is not an int or whose value is not a
        finite number in range (delay >= 0, corner or limit > 0), naming the
        field, key and value. The nominal chain has no per-channel entries;
        with none set, the loop runs the original (global) path.
    """

    period_s: float = PC1000_PERIOD_S
    delay_periods: float = PC1000_DELAY_PERIODS
    filter_hz: float | None = RC_CORNER_HZ
    amplifier_gain: float = 1.0
    amplifier_limit_n: float | None = None
    noise_m_s: float = 0.0
    actuator_gain: dict[int, float] = field(default_factory=dict)
    sensor_gain: dict[int, float] = field(default_factory=dict)
    actuator_lag_hz: float | None = None
    sensor_lag_hz: float | None = None
    channel_delay_periods: dict[int, float] = field(default_factory=dict)
    channel_actuator_lag_hz: dict[int, float | None] = field(default_factory=dict)
    channel_sensor_lag_hz: dict[int, float | None] = field(default_factory=dict)
    channel_limit_n: dict[int, float | None] = field(default_factory=dict)

    def __post_init__(self) -> None:
        for name, low, allow_none in (("channel_delay_periods", 0.0, False), ("channel_actuator_lag_hz", None, True),
                                      ("channel_sensor_lag_hz", None, True), ("channel_limit_n", None, True)):
            for p, v in getattr(self, name).items():
                if isinstance(p, bool) or not isinstance(p, (int, np.integer)):
                    raise ModelError(f"HardwareChain.{name}: key {p!r} must be a point id (int)")
                if v is None and allow_none:
                    continue
                ok = isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool) \
                    and math.isfinite(v) and (v >= low if low is not None else v > 0)
                if not ok:
                    raise ModelError(f"HardwareChain.{name}[{p}] = {v!r}: must be a finite number "
                                     + (f">= {low:g}" if low is not None else "> 0")
                                     + (" or None" if allow_none else ""))

    def delay_of(self, point: int) -> float:
        """Delay [periods] of the actuator channel at ``point``: its ``channel_delay_periods`` entry, else the global."""
        return float(self.channel_delay_periods.get(point, self.delay_periods))

    def actuator_lag_of(self, point: int) -> float | None:
        """Actuator-lag corner [Hz] (None: off) of the coil at ``point``: its entry, else ``actuator_lag_hz``."""
        return self.channel_actuator_lag_hz.get(point, self.actuator_lag_hz)

    def sensor_lag_of(self, point: int) -> float | None:
        """Sensor-lag corner [Hz] (None: off) of the feedback sensor at ``point``: its entry, else ``sensor_lag_hz``."""
        return self.channel_sensor_lag_hz.get(point, self.sensor_lag_hz)

    def limit_of(self, point: int) -> float | None:
        """Force limit [N] (None: linear) of the coil at ``point``: its entry, else ``amplifier_limit_n``."""
        return self.channel_limit_n.get(point, self.amplifier_limit_n)

    @property
    def saturates(self) -> bool:
        """True when some channel has a force limit (global or per channel)."""
        return self.amplifier_limit_n is not None or any(v is not None for v in self.channel_limit_n.values())


@dataclass(frozen=True)
class LoopResult:
    """Sampled signals of a run at the controller rate.

    ``recording`` holds the excitation force ``force<exc>`` [N] and the
    velocities ``vel<p>`` [m/s] of every measured point as the sensors
    measured them: at a feedback sensor point the very signal the controller
    read (sensor gain, sensor lag and noise included), at any other measured
    point the velocity plus its own sensor noise (same sigma, independent);
    ``commands`` the controller outputs ``u_k`` (n_ticks, n_act) [N];
    ``displacements`` (n_ticks, n_points) [m] at ``shape_points`` (noise-free,
    for the animated shape).

    Attributes
    ----------
    recording : Recording
        ``force<exc>`` [N] and ``vel<p>`` [m/s] at the controller rate.
    commands : ndarray, shape (n_ticks, n_act)
        Controller outputs [N] (zeros open loop).
    displacements : ndarray, shape (n_ticks, n_points)
        Displacements from the settled state [m] at ``shape_points``.
    shape_points : tuple of int
        Points of the columns of ``displacements``.
    """

    recording: Recording
    commands: np.ndarray
    displacements: np.ndarray
    shape_points: tuple[int, ...]


def check_design_period(design, chain: HardwareChain) -> None:
    """Raise unless ``design`` was realised at the chain's sampling period (Eqs. 5.2-5.5 depend on it).

    Parameters
    ----------
    design : ControllerDesign or None
        The controller run (its ``period_s`` [s]); None (open loop) passes.
    chain : HardwareChain
        The loop's chain (its ``period_s`` [s]).

    Raises
    ------
    ModelError
        The two periods differ.
    """
    if design is None:
        return
    p = getattr(design, "period_s", chain.period_s)
    if abs(p - chain.period_s) > 1e-12 * chain.period_s:
        raise ModelError(
            f"the {design.controller} design was realised at a {p * 1e3:g} ms period but the loop runs at "
            f"{chain.period_s * 1e3:g} ms: design it with period_s={chain.period_s!r}"
        )


def _check_channels(chain: HardwareChain, acts: tuple[int, ...], fb: tuple[int, ...]) -> None:
    """Raise ModelError for a per-channel entry of ``chain`` keyed by a point that is not an actuator
    (delay, actuator lag, limit) or a feedback sensor (sensor lag) of the loop."""
    for name, points, what in (("channel_delay_periods", acts, "actuator"),
                               ("channel_actuator_lag_hz", acts, "actuator"), ("channel_limit_n", acts, "actuator"),
                               ("channel_sensor_lag_hz", fb, "feedback sensor")):
        bad = sorted(set(getattr(chain, name)) - set(points))
        if bad:
            raise ModelError(f"HardwareChain.{name} names point(s) {bad}, which are not {what} points {tuple(points)}")


def _lag_pole(global_hz: float | None, by_channel: dict, points: tuple[int, ...], step_s: float):
    """Pole ``exp(-2 pi f_c step)`` of the first-order lag of each channel at ``points``: a scalar when all
    channels share the global corner (the original path), a vector (0 = no lag) with per-channel corners,
    None when no channel has a lag."""
    if not by_channel:
        return math.exp(-2 * math.pi * global_hz * step_s) if global_hz else None
    corners = [by_channel.get(p, global_hz) for p in points]
    if not any(corners):
        return None
    return np.array([math.exp(-2 * math.pi * f * step_s) if f else 0.0 for f in corners])


def _dac_channels(dacs, t0: float, t1: float, n_act: int) -> np.ndarray:
    """DAC (and RC) output averaged over ``[t0, t1]`` [s], shape (n_act,), assembled from the delay lines of
    channels with different delays (each ``(channel indices, SampleDelay, RCLowPass or None)``)."""
    out = np.empty(n_act)
    for idx, dl, rcx in dacs:
        if rcx is not None:
            rcx.update_segments(dl.segments_over(t0, t1))
            out[idx] = rcx.mean()
        else:
            out[idx] = dl.mean_over(t0, t1)
    return out


def run_loop(
    plant: Plant,
    engine: ControllerEngine | None,
    *,
    feedback_points: tuple[int, ...],
    measured_points: tuple[int, ...],
    excitation_point: int,
    excitation: Callable[[np.ndarray], np.ndarray] | np.ndarray,
    duration_s: float,
    chain: HardwareChain = HardwareChain(),
    seed: int = 0,
    progress: Callable[[float], None] | None = None,
    metadata: dict | None = None,
    shape_points: tuple[int, ...] | None = None,
) -> LoopResult:
    """Run the closed loop for ``duration_s`` and record it at the controller rate.

    Parameters
    ----------
    plant : Plant
        Settled plant; its ``actuator_points`` are the coil channels.
    engine : ControllerEngine or None
        Eq. (5.1) engine with inputs ``feedback_points`` and outputs the plant's
        actuators; None runs open loop.
    feedback_points : tuple of int
        Sensor points fed to the controller (collocated with the actuators).
    measured_points : tuple of int
        Points whose measured velocity is recorded (a feedback point records
        the controller's own input; see :class:`LoopResult`).
    excitation_point : int
        Actuator point that carries the excitation (added before the amplifier).
    excitation : ndarray, shape (n_ticks,), or callable t_s -> force [N]
        Excitation command, one value per controller tick (held over the tick).
    duration_s : float
        Run length [s]; rounded down to whole ticks.
    chain : HardwareChain
        Hardware between controller and coils (Sec. 5.3); the default is the
        PC-1000 chain (0.5 ms period, 1.35-period delay, 677 Hz RC filter).
    seed : int
        Seed of the sensor noise: each tick draws one value per sensor, the
        feedback points first, then the measured points that are not
        feedback points, in the given orders (open loop too).
    progress : callable, optional
        Called with the fraction done, about every 1 % of the run.
    metadata : dict, optional
        Stored in the recording.
    shape_points : tuple of int, optional
        Points whose displacement is sampled for the deformed-shape animation
        (default: ``measured_points``; ``()`` samples none, as a rerun that
        only compares velocities needs).

    Returns
    -------
    LoopResult

    Raises
    ------
    ModelError
        If the physics step does not divide the period, the excitation point is
        not an actuator, a per-channel chain entry names a point that is not
        an actuator (feedback sensor for the sensor lag), the run is shorter than two periods, the excitation
        has not one value per tick, or the engine's inputs/outputs do not match
        the feedback points/actuators.
    SimulationError
        If the plant diverges (non-finite or huge velocity); ``exc.partial`` holds
        the :class:`LoopResult` up to that tick.
    """
    period = chain.period_s
    h = plant.timestep_s
    n_sub = int(round(period / h))
    if n_sub < 1 or abs(n_sub * h - period) > 1e-9 * period:
        raise ModelError(f"physics step {h:g} s must divide the controller period {period:g} s")
    acts = tuple(plant.actuator_points)
    if excitation_point not in acts:
        raise ModelError(f"excitation point {excitation_point} is not an actuator point {acts}")
    n_act = len(acts)
    exc_ch = acts.index(excitation_point)
    n_ticks = int(math.floor(duration_s / period + 1e-9))
    if n_ticks < 2:
        raise ModelError(f"duration {duration_s} s is shorter than two controller periods")
    t_ticks = np.arange(n_ticks) * period
    exc = np.asarray(excitation(t_ticks) if callable(excitation) else excitation, dtype=float)
    if exc.shape != (n_ticks,):
        raise ModelError(f"excitation must have one value per tick: expected ({n_ticks},), found {exc.shape}")

    fb = tuple(feedback_points)
    if engine is not None and (engine.n_inputs != len(fb) or engine.n_outputs != n_act):
        raise ModelError(
            f"controller engine has {engine.n_inputs} inputs/{engine.n_outputs} outputs; "
            f"loop has {len(fb)} feedback sensors and {n_act} actuators"
        )
    _check_channels(chain, acts, fb)
    # one DAC delay line (and RC filter) per distinct channel delay; the nominal chain has one for all channels
    groups: dict[float, list[int]] = {}
    for i, p in enumerate(acts):
        groups.setdefault(chain.delay_of(p), []).append(i)
    dacs = [(np.array(idx), SampleDelay(period_s=period, delay_periods=d, size=len(idx), name="DAC"),
             RCLowPass(step_s=h, corner_hz=chain.filter_hz, size=len(idx), name="RC") if chain.filter_hz else None)
            for d, idx in groups.items()]
    if len(dacs) > 1:
        delay = rc = None
    else:
        _, delay, rc = dacs[0]
    limits = [chain.limit_of(p) for p in acts]
    limit = (None if all(v is None for v in limits) else chain.amplifier_limit_n if not chain.channel_limit_n
             else np.array([np.finfo(float).max if v is None else v for v in limits]))
    amp = CurrentAmplifier(gain=chain.amplifier_gain, limit=limit, size=n_act)
    meas = tuple(measured_points)
    # the sensors: feedback points, then the other measured points; one signal each
    sensors = fb + tuple(dict.fromkeys(p for p in meas if p not in fb))
    n_fb = len(fb)
    meas_idx = np.array([sensors.index(p) for p in meas], dtype=int)
    noise = (SensorNoise(sigma_m_s=chain.noise_m_s, seed=seed, size=len(sensors), name="sensor noise")
             if chain.noise_m_s > 0 and sensors else None)
    act_gain = np.array([chain.actuator_gain.get(p, 1.0) for p in acts])
    sen_gain = np.array([chain.sensor_gain.get(p, 1.0) for p in fb])
    a_act = _lag_pole(chain.actuator_lag_hz, chain.channel_actuator_lag_hz, acts, h)
    a_sen = _lag_pole(chain.sensor_lag_hz, chain.channel_sensor_lag_hz, fb, period)
    lag_act = np.zeros(n_act)
    lag_sen = np.zeros(n_fb)

    vel = np.zeros((n_ticks, len(meas)))
    shape = tuple(shape_points) if shape_points is not None else meas
    disp = np.zeros((n_ticks, len(shape)))
    cmds = np.zeros((n_ticks, n_act))
    e_vec = np.zeros(n_act)
    report_every = max(1, n_ticks // 100)
    done = n_ticks
    failure: SimulationError | None = None
    for k in range(n_ticks):
        t_k = k * period
        v_sens = np.asarray(plant.velocities(sensors), dtype=float) if sensors else np.zeros(0)
        if not np.abs(v_sens).max(initial=0.0) <= 1e3:  # also catches NaN
            failure = SimulationError(
                f"simulation diverged at t = {t_k:.4f} s (velocity {np.max(np.abs(v_sens)):.3g} m/s at "
                f"points {sensors}): controller unstable on this plant or timestep too large"
            )
            done = k
            break
        y_all = v_sens.copy()
        if n_fb:
            y_fb = v_sens[:n_fb] * sen_gain
            if a_sen is not None:
                lag_sen = a_sen * lag_sen + (1 - a_sen) * y_fb
                y_fb = lag_sen
            y_all[:n_fb] = y_fb
        if noise is not None:
            y_all = noise.output(y_all)
        vel[k] = y_all[meas_idx]
        if shape:
            disp[k] = plant.displacements(shape)
        if engine is not None:
            u = engine.step(y_all[:n_fb])
        else:
            u = np.zeros(n_act)
        cmds[k] = u
        if delay is not None:
            delay.update(u)
        else:
            for idx, dl, _ in dacs:
                dl.update(u[idx])
        e_vec[:] = 0.0
        e_vec[exc_ch] = exc[k]
        for s in range(n_sub):
            t = t_k + s * h
            if delay is None:
                dac = _dac_channels(dacs, t, t + h, n_act)
            elif rc is not None:
                # the force is held over the physics step: the RC's exact average over it
                rc.update_segments(delay.segments_over(t, t + h))
                dac = rc.mean()
            else:
                dac = delay.mean_over(t, t + h)
            f = amp.output(dac + e_vec) * act_gain
            if a_act is not None:
                lag_act = a_act * lag_act + (1 - a_act) * f
                f = lag_act
            plant.set_forces(f)
            plant.step()
        if progress is not None and k % report_every == 0:
            progress(k / n_ticks)

    signals = {f"force{excitation_point}": exc[:done]}
    for j, p in enumerate(meas):
        signals[f"vel{p}"] = vel[:done, j]
    rec = Recording.from_signals(period, signals, metadata=dict(metadata or {}))
    result = LoopResult(rec, cmds[:done], disp[:done], shape)
    if failure is not None:
        failure.partial = result  # type: ignore[attr-defined]
        raise failure
    if progress is not None:
        progress(1.0)
    return result
