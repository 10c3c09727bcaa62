"""The digital control loop of Fig. 21, run against any plant.

One controller tick every ``chain.period_s`` (Sec. 5.3: 0.5 ms, 2 kHz, for the DRF
controllers; 1 ms for LQG)::

    y_k  = sensor gain x velocity (x lag) + noise         (sampled at t_k; also recorded)
    u_k  = engine.step(y_k)                               (Eq. 5.1)
    DAC  : u_k appears 1.35 periods after t_k, held       (a channel may have its own delay)
    for each physics step h in the tick:
        RC  : filtered DAC voltage, averaged over the step (677 Hz, exact)
        f   = amplifier(RC output + excitation on one channel)
        plant.step(f)

The chain (sensor stage, DAC, RC, amplifier, lags) runs as the batched loop
runs it, with :class:`vlab.lab.batch_chain.ChainRun` for one simulation: one
implementation of its arithmetic for both loops, its coefficients computed
once per run. The blocks of :mod:`vlab.lab.blocks` (SampleDelay, RCLowPass,
CurrentAmplifier, SensorNoise) are the reference it is tested against
(tests/test_loop_reference.py).

The plant is anything with the :class:`Plant` protocol: the MuJoCo plant of
:mod:`vlab.sim` or the linear model of :mod:`vlab.lab.linear_plant`. Inputs
are checked once, before the first tick; the loop then trusts what it
produced itself. A plant may offer its own per-tick access, ``loop_io``
(see :class:`Plant`); the MuJoCo plant's computes the state at the sampling
instant once per tick (:class:`vlab.sim.loopio.LoopIO`). A diverging plant
stops the run with :class:`vlab.errors.SimulationError` saying when; the
recording made so far is attached to the error (``exc.partial``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Protocol

import numpy as np

from ..errors import ModelError, SimulationError
from .batch_chain import BatchChain, ChainRun
from .blocks import PC1000_DELAY_PERIODS, PC1000_PERIOD_S, RC_CORNER_HZ
from .engine import ControllerEngine
from ..io.recording import Recording


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
    Optional: a plant may also have a method ``loop_io(sensors,
    shape_points)`` that returns None or an object with ``sample()`` (the
    velocities at ``sensors`` [m/s], shape (n_sensors,)), ``displacements(out)``
    (at ``shape_points`` [m], after ``sample``, written into ``out`` of shape
    (n_shape,)) and ``drive(forces)`` (``set_forces`` then ``step``; ``forces``
    a list of n_act floats [N]): the same readings and steps without
    the per-call checks, for the loop's fixed points and finite forces.
    :class:`vlab.sim.runtime.MujocoPlant` has one; without it (or when it
    returns None) the loop calls the methods above.

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
        RC low-pass corner [Hz] (677; None or 0 = off).
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
        Corner frequency [Hz] of an extra first-order lag on each coil force:
        a continuous lag whose exact average over each physics step is the
        force held over it (:func:`vlab.lab.batch_chain.lag_step`; None = off).
        A diagnosis hypothesis (e.g. coil inductance), not part of the Sec. 5.3
        chain.
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


class _ProtocolIO:
    """The loop's access to any :class:`Plant` through its protocol methods (what a plant's own
    ``loop_io`` replaces, see :class:`Plant`): ``sample`` the sensor velocities, ``displacements`` at the
    shape points, ``drive(forces)`` one physics step."""

    def __init__(self, plant: Plant, sensors: tuple[int, ...], shape: tuple[int, ...]) -> None:
        self._plant, self._sensors, self._shape = plant, sensors, shape

    def sample(self) -> np.ndarray:
        return np.asarray(self._plant.velocities(self._sensors), dtype=float) if self._sensors else np.zeros(0)

    def displacements(self, out: np.ndarray) -> np.ndarray:
        out[...] = self._plant.displacements(self._shape)
        return out

    def drive(self, forces) -> None:
        self._plant.set_forces(np.array(forces, dtype=float))
        self._plant.step()


def _plant_io(plant: Plant, sensors: tuple[int, ...], shape: tuple[int, ...]):
    """The plant's own per-tick access (``loop_io``) where it has one for these points, else the protocol's."""
    own = getattr(plant, "loop_io", None)
    io = own(sensors, shape) if own is not None else None
    return io if io is not None else _ProtocolIO(plant, sensors, shape)


def _stepper(engine: ControllerEngine | None):
    """``f(y, out) -> out``: the engine's tick writing ``u_k`` into ``out``; None open loop.

    :meth:`ControllerEngine.step_trusted` (the loop has checked ``y``), unless a
    subclass overrides ``step``: then that ``step``, as the loop always called it.
    """
    if engine is None:
        return None
    if type(engine).step is ControllerEngine.step:
        return engine.step_trusted

    def step(y, out):
        out[...] = engine.step(y)
        return out
    return step


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
        feedback points, in the given orders (open loop too); the draws of
        ``numpy.random.default_rng(seed).standard_normal(n_sensors)`` once per
        tick (:class:`vlab.lab.blocks.SensorNoise`), taken in blocks of ticks.
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
        an actuator (feedback sensor for the sensor lag), a chain setting is
        out of range (a negative delay, filter corner or noise level, a limit
        <= 0, a non-finite gain: :meth:`vlab.lab.batch_chain.BatchChain.from_chains`), the run is
        shorter than two periods, the excitation has not one finite value per
        tick, the seed is not an int (noise on), or the engine's inputs/outputs
        do not match the feedback points/actuators. All checked before the
        first tick.
    SimulationError
        If the plant diverges (non-finite or huge velocity); ``exc.partial`` holds
        the :class:`LoopResult` up to that tick. (A plant that detects its own
        divergence, as the MuJoCo plant's bad-acceleration check, raises its
        own SimulationError.)

    Notes
    -----
    Source: Fig. 21, Sec. 5.3 (chain), Eq. (5.1) (engine); one tick's work: :func:`run_ticks`.
    """
    fb, meas = tuple(feedback_points), tuple(measured_points)
    h, n_sub, acts, exc, exc_ch = _checked_run(plant, engine, chain, fb, excitation_point, excitation, duration_s)
    # the sensors: feedback points, then the other measured points; one signal each
    sensors = fb + tuple(dict.fromkeys(p for p in meas if p not in fb))
    shape = tuple(shape_points) if shape_points is not None else meas
    # the chain of Fig. 21 as the batch runs it, one simulation; coefficients made once for the run
    hw = BatchChain.from_chains([chain], timestep_s=h, actuators=acts, feedback=fb, n_sensors=len(sensors))
    run = ChainRun(hw, n_fb=len(fb), seeds=[seed], n_ticks=len(exc))
    io = _plant_io(plant, sensors, shape)
    ys, cmds, disp, done, failure = run_ticks(io, run, _stepper(engine), exc, exc_ch, n_sub=n_sub, n_fb=len(fb),
                                              n_act=len(acts), sensors=sensors, shape=shape, period_s=chain.period_s,
                                              progress=progress)
    result = LoopResult(_recording(chain.period_s, excitation_point, exc[:done], meas, sensors, ys[:done], metadata),
                        cmds[:done], disp[:done], shape)
    if failure is not None:
        failure.partial = result  # type: ignore[attr-defined]
        raise failure
    if progress is not None:
        progress(1.0)
    return result


def _recording(period_s: float, excitation_point: int, exc: np.ndarray, meas: tuple[int, ...],
               sensors: tuple[int, ...], ys: np.ndarray, metadata: dict | None) -> Recording:
    """The run's recording: the excitation force and the measured points' velocities (columns of ``ys``)."""
    signals = {f"force{excitation_point}": exc}
    for p in meas:
        signals[f"vel{p}"] = ys[:, sensors.index(p)]
    return Recording.from_signals(period_s, signals, metadata=dict(metadata or {}))


def _checked_run(plant: Plant, engine: ControllerEngine | None, chain: HardwareChain, fb: tuple[int, ...],
                 excitation_point: int, excitation, duration_s: float):
    """The checks of :func:`run_loop` before its first tick, in its order; ``(h, n_sub, acts, exc, exc_ch)``."""
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
    if not np.all(np.isfinite(exc)):
        raise ModelError(f"excitation is not finite at tick {int(np.flatnonzero(~np.isfinite(exc))[0])}")
    n_fb = len(fb)
    if engine is not None and (engine.n_inputs != n_fb or engine.n_outputs != n_act):
        raise ModelError(
            f"controller engine has {engine.n_inputs} inputs/{engine.n_outputs} outputs; "
            f"loop has {n_fb} feedback sensors and {n_act} actuators"
        )
    _check_channels(chain, acts, fb)
    return h, n_sub, acts, exc, exc_ch


def run_ticks(io, run: ChainRun, step_u, exc: np.ndarray, exc_ch: int, *, n_sub: int, n_fb: int, n_act: int,
              sensors: tuple[int, ...], shape: tuple[int, ...], period_s: float,
              progress: Callable[[float], None] | None):
    """The ticks of :func:`run_loop`: sample, sense, control, push, and step the plant ``n_sub`` times.

    Parameters
    ----------
    io : plant I/O
        The plant's per-tick access (``sample``, ``drive``, ``displacements``; see ``_plant_io``).
    run : ChainRun
        The hardware chain of the run (one simulation).
    step_u : callable or None
        ``f(y, out) -> out``, the engine's tick; None open loop.
    exc : ndarray, shape (n_ticks,)
        Excitation [N] per tick, finite.
    exc_ch : int
        Actuator channel of the excitation.
    n_sub : int
        Physics steps per tick.
    n_fb : int
        Feedback sensors (the first ``n_fb`` of ``sensors``).
    n_act : int
        Actuator channels.
    sensors : tuple of int
        Every sensor point, feedback points first.
    shape : tuple of int
        Points whose displacement is sampled each tick (may be empty).
    period_s : float
        Controller period [s] (for the divergence message).
    progress : callable or None
        Called with the fraction done about every 1 % of the run.

    Returns
    -------
    ys : ndarray, shape (n_ticks, n_sensors)
        Every sensor's measured velocity [m/s].
    cmds : ndarray, shape (n_ticks, n_act)
        Controller commands.
    disp : ndarray, shape (n_ticks, len(shape))
        Displacements [m].
    done : int
        Ticks run (fewer than ``n_ticks`` when the plant diverged).
    failure : SimulationError or None
        The divergence, not raised.

    Notes
    -----
    Source: Fig. 21, Sec. 5.3 (chain), Eq. (5.1) (engine). Per tick the loop
    reads the sensors, runs :meth:`ChainRun.sense <vlab.lab.batch_chain.ChainRun.sense>`,
    the engine's :meth:`~vlab.lab.engine.ControllerEngine.step_trusted` (its ``step``
    without the input check: the loop checked the velocities; a subclass that
    overrides ``step`` is called through it), :meth:`ChainRun.push_one
    <vlab.lab.batch_chain.ChainRun.push_one>` and, per physics step,
    :meth:`ChainRun.force_one <vlab.lab.batch_chain.ChainRun.force_one>` (the
    chain's arithmetic on floats, the same operations as the batch's arrays)
    and the plant's step; the time per tick against MuJoCo's own loop is in
    docs/validation/data/batch_speed.txt (``benchmarks/batch_speed.py``).
    """
    n_ticks = len(exc)
    ys = np.zeros((n_ticks, len(sensors)))  # every sensor's signal; the measured points' columns are recorded
    disp = np.zeros((n_ticks, len(shape)))
    cmds = np.zeros((n_ticks, n_act))
    u_open = [0.0] * n_act
    e_list = [0.0] * n_act
    exc_list = exc.tolist()
    report_every = max(1, n_ticks // 100)
    sample, drive = io.sample, io.drive
    sense, push, force = run.sense, run.push_one, run.force_one
    subs, dot = range(n_sub), np.dot
    done = n_ticks
    failure: SimulationError | None = None
    for k, y, e_k, u_k, z_k in zip(range(n_ticks), ys, exc_list, cmds, disp):  # rows of the records
        v = sample()
        # diverged: a velocity above 1e3 m/s or NaN; |v|^2 <= 1e6 rules both out with one product
        if not dot(v, v) <= 1e6 and not np.abs(v).max(initial=0.0) <= 1e3:
            failure = SimulationError(
                f"simulation diverged at t = {k * period_s:.4f} s (velocity {np.max(np.abs(v)):.3g} m/s at "
                f"points {sensors}): controller unstable on this plant or timestep too large"
            )
            done = k
            break
        sense(v, k, y)
        if shape:
            io.displacements(z_k)
        # the loop checked v, so y is finite: the engine's own input check is not repeated
        push(step_u(y[:n_fb], u_k).tolist() if step_u is not None else u_open)
        e_list[exc_ch] = e_k
        for s in subs:
            drive(force(s, e_list))
        if progress is not None and k % report_every == 0:
            progress(k / n_ticks)
    return ys, cmds, disp, done, failure
