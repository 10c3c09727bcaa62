"""N closed-loop experiments advanced together: the 2 kHz loop of Fig. 21 vectorised over simulations.

The same loop as :func:`vlab.lab.loop.run_loop`, with every block an array
operation over the N simulations (and their channels) per tick::

    Y   = sensor gain x velocities (x lag) + noise            (N, n_sensors), sampled at t_k
    U   = F11 Y_fb + F12 X ;  X <- F21 Y_fb + F22 X           (N, n_u), Eq. (5.1), own gains per simulation
    DAC : U pushed into the (history, N, n_act) buffer       (delay D = m + f periods, per channel)
    for each physics step s of the tick:
        RC  : exact step average of the two held pieces       (677 Hz, per channel)
        F   = clip(gain x (RC + excitation)) x actuator gain  (N, n_act)
        plant.step()                                          (all N on one mujoco.batch.Batch)

Each simulation has its own plant parameters (:class:`vlab.sim.batch_plant.MujocoBatchPlant`),
controller gains, hardware chain, excitation record and noise seed. For the
same seed a simulation's recording matches the single loop's bit for bit: both
run the chain with :class:`vlab.lab.batch_chain.ChainRun` (the single loop with
N = 1), and ``mujoco.batch`` steps as one ``MjData`` does (tests/test_batch.py).

A simulation that diverges (non-finite or > 1e3 m/s velocity, or reset by
MuJoCo after a bad acceleration) is stopped at that tick and the others go
on; :attr:`BatchResult.failures` says when.

Source: Eq. (5.1), Sec. 5.3, Fig. 21; the blocks of :mod:`vlab.lab.blocks`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ModelError
from .batch_chain import BatchChain, ChainRun
from .loop import HardwareChain, LoopResult
from ..io.recording import Recording

#: Every this many ticks the simulations' clocks are checked (MuJoCo restarts a diverged one).
_TIME_CHECK = 50


@dataclass(frozen=True)
class BatchResult:
    """Sampled signals of N runs at the controller rate.

    Attributes
    ----------
    period_s : float
        Controller period [s].
    excitation_point : int
        Point of the excitation channel.
    excitation : ndarray, shape (N, n_ticks)
        Excitation command of each simulation [N].
    velocities : ndarray, shape (N, n_ticks, n_meas)
        Measured velocities [m/s] at ``measured_points`` (as :class:`LoopResult`).
    commands : ndarray, shape (N, n_ticks, n_act)
        Controller outputs ``u_k`` [N].
    displacements : ndarray, shape (N, n_ticks, n_shape)
        Displacements from the settled state [m] at ``shape_points``.
    measured_points, shape_points : tuple of int
    done : ndarray of int, shape (N,)
        Ticks completed by each simulation (n_ticks unless it diverged).
    failures : dict of int to str
        Simulation index -> why it stopped.
    """

    period_s: float
    excitation_point: int
    excitation: np.ndarray
    velocities: np.ndarray
    commands: np.ndarray
    displacements: np.ndarray
    measured_points: tuple[int, ...]
    shape_points: tuple[int, ...]
    done: np.ndarray
    failures: dict

    def result(self, sim: int, metadata: dict | None = None) -> LoopResult:
        """Simulation ``sim``'s run as a :class:`LoopResult` (truncated where it diverged).

        Parameters
        ----------
        sim : int
            Simulation index, 0..N-1.
        metadata : dict, optional
            Stored in the recording.

        Raises
        ------
        ModelError
            ``sim`` out of range.
        """
        n = self.velocities.shape[0]
        if not 0 <= sim < n:
            raise ModelError(f"simulation {sim} out of range 0..{n - 1}")
        k = int(self.done[sim])
        signals = {f"force{self.excitation_point}": self.excitation[sim, :k]}
        for j, p in enumerate(self.measured_points):
            signals[f"vel{p}"] = self.velocities[sim, :k, j]
        rec = Recording.from_signals(self.period_s, signals, metadata=dict(metadata or {}))
        return LoopResult(rec, self.commands[sim, :k], self.displacements[sim, :k], self.shape_points)


def _stack(matrices, n_sim: int, shape: tuple[int, int], name: str) -> np.ndarray:
    arr = np.asarray(matrices, dtype=float)
    if arr.shape == shape:
        arr = np.broadcast_to(arr, (n_sim, *shape))
    if arr.shape != (n_sim, *shape):
        raise ModelError(f"{name}: expected shape {shape} or ({n_sim}, {shape[0]}, {shape[1]}), found {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ModelError(f"{name}: contains non-finite entries")
    return np.ascontiguousarray(arr)


@dataclass(frozen=True)
class BatchController:
    """Eq. (5.1) for N simulations, made with :meth:`of`: ``u = F11 y + F12 x``, ``x <- F21 y + F22 x``.

    Attributes
    ----------
    f11 : ndarray, shape (N, n_u, n_y)
        Direct feedthrough [N/(m/s)].
    f12 : ndarray, shape (N, n_u, n_x)
    f21 : ndarray, shape (N, n_x, n_y)
    f22 : ndarray, shape (N, n_x, n_x)

    Source: Eq. (5.1), Sec. 5.3 (y [m/s], u [N]).
    """

    f11: np.ndarray
    f12: np.ndarray
    f21: np.ndarray
    f22: np.ndarray

    @classmethod
    def of(cls, engines, n_sim: int) -> BatchController:
        """Stack one :class:`vlab.lab.engine.ControllerEngine` per simulation (or one for all).

        Parameters
        ----------
        engines : ControllerEngine or list of N of them
        n_sim : int
            N.

        Raises
        ------
        ModelError
            A count other than ``n_sim``, or engines of different sizes.
        """
        if not isinstance(engines, (list, tuple)):
            engines = [engines] * n_sim
        if len(engines) != n_sim:
            raise ModelError(f"engines: expected {n_sim} controller engines (one per simulation), got {len(engines)}")
        e0 = engines[0]
        sizes = {(e.n_outputs, e.n_inputs, e.n_states) for e in engines}
        if len(sizes) != 1:
            raise ModelError(f"engines: all simulations need controllers of one size (n_u, n_y, n_x); "
                             f"got {sorted(sizes)}")
        n_u, n_y, n_x = e0.n_outputs, e0.n_inputs, e0.n_states
        return cls(_stack([e.F11 for e in engines], n_sim, (n_u, n_y), "F11"),
                   _stack([e.F12 for e in engines], n_sim, (n_u, n_x), "F12"),
                   _stack([e.F21 for e in engines], n_sim, (n_x, n_y), "F21"),
                   _stack([e.F22 for e in engines], n_sim, (n_x, n_x), "F22"))


def for_each(chain: HardwareChain | list, n_sim: int) -> list:
    """One chain per simulation: ``chain`` repeated, or the given list (length checked).

    Raises
    ------
    ModelError
        A list whose length is not ``n_sim``.
    """
    if isinstance(chain, HardwareChain):
        return [chain] * n_sim
    chains = list(chain)
    if len(chains) != n_sim:
        raise ModelError(f"chains: expected {n_sim} hardware chains (one per simulation), got {len(chains)}")
    return chains


def _stop_diverged(plant, v, k, period, check_time, sensors, done, failures) -> bool:
    """Stop the live simulations that diverged at tick ``k`` (record when and why); True if any stopped.

    Diverged: a velocity above 1e3 m/s or not finite, or (checked every
    :data:`_TIME_CHECK` ticks) a clock that restarted -- MuJoCo resets a
    simulation after a bad acceleration.
    """
    bad = ~(np.abs(v).max(axis=1, initial=0.0) <= 1e3)
    t_now = plant.time_s()
    if check_time:
        bad |= np.abs(t_now - k * period) > 0.25 * period
    bad &= plant.alive
    if not bad.any():
        return False
    for i in np.flatnonzero(bad):
        reset = abs(t_now[i] - k * period) > 0.25 * period
        done[i] = k - int(round(t_now[i] / period)) if reset else k
        failures[int(i)] = (f"simulation {i} diverged at t = {done[i] * period:.4f} s ("
                            + ("MuJoCo reset it after a bad acceleration" if reset else
                               f"velocity {np.max(np.abs(v[i])):.3g} m/s at points {sensors}")
                            + "): controller unstable on this plant or timestep too large")
    plant.stop(np.flatnonzero(bad))
    return True


def _matvec(a: np.ndarray, x: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """Stacked ``a[i] @ x[i]``: (N, r, c) x (N, c) -> (N, r), into ``out`` (N, r) when given."""
    if out is None:
        return np.matmul(a, x[:, :, None])[:, :, 0]
    np.matmul(a, x[:, :, None], out=out[:, :, None])
    return out


def run_batch(
    plant,
    engines,
    *,
    feedback_points: tuple[int, ...],
    measured_points: tuple[int, ...],
    excitation_point: int,
    excitation: np.ndarray,
    duration_s: float,
    chain: HardwareChain | list = HardwareChain(),
    seeds=0,
    shape_points: tuple[int, ...] = (),
    initial_states: np.ndarray | None = None,
) -> BatchResult:
    """Run N closed loops for ``duration_s`` on a batch plant and record them at the controller rate.

    Parameters
    ----------
    plant : BatchPlant
        N settled plants (:class:`vlab.sim.batch_plant.MujocoBatchPlant`).
    engines : ControllerEngine, list of N of them, or None
        Eq. (5.1) engines (inputs ``feedback_points``, outputs the plant's
        actuators); one for all, one per simulation, or None (open loop).
    feedback_points, measured_points : tuple of int
        As :func:`vlab.lab.loop.run_loop`.
    excitation_point : int
        Actuator point that carries the excitation.
    excitation : ndarray, shape (n_ticks,) or (N, n_ticks)
        Excitation command [N] per tick, one record for all or one per simulation.
    duration_s : float
        Run length [s], rounded down to whole ticks.
    chain : HardwareChain or list of N of them
        Hardware of each simulation (Sec. 5.3).
    seeds : int or sequence of N int
        Sensor-noise seed of each simulation (the draws of :func:`run_loop`:
        one per sensor per tick, feedback sensors first).
    shape_points : tuple of int
        Points whose displacement is sampled (needs a plant with ``sample_sites``).
    initial_states : ndarray, shape (N, n_x), optional
        Controller states ``x_0`` of Eq. (5.1) per simulation (default zeros), e.g.
        the states a warm start left in each :class:`vlab.lab.engine.ControllerEngine`
        (``engine.state``), which :func:`vlab.lab.loop.run_loop` starts from.

    Returns
    -------
    BatchResult

    Raises
    ------
    ModelError
        As :func:`run_loop` (step not dividing the period, excitation point
        not an actuator, run shorter than two periods, wrong excitation shape,
        engine sizes not matching), and a wrong number of chains, engines or seeds,
        or ``initial_states`` of the wrong shape, non-finite, or given open loop.
    """
    n = plant.n_sim
    chains = for_each(chain, n)
    acts = tuple(plant.actuator_points)
    if excitation_point not in acts:
        raise ModelError(f"excitation point {excitation_point} is not an actuator point {acts}")
    n_act = len(acts)
    exc_ch = acts.index(excitation_point)
    fb, meas, shape = tuple(feedback_points), tuple(measured_points), tuple(shape_points)
    sensors = fb + tuple(dict.fromkeys(p for p in meas if p not in fb))
    n_fb, n_sens = len(fb), len(sensors)
    hw = BatchChain.from_chains(chains, timestep_s=plant.timestep_s, actuators=acts, feedback=fb, n_sensors=n_sens)
    period = hw.period_s
    n_ticks = int(math.floor(duration_s / period + 1e-9))
    if n_ticks < 2:
        raise ModelError(f"duration {duration_s} s is shorter than two controller periods")
    exc = _batch_excitation(excitation, n, n_ticks)
    ctl = _batch_controller(engines, n, n_act, n_fb)
    seeds = [seeds] * n if isinstance(seeds, (int, np.integer)) else list(seeds)
    if len(seeds) != n:
        raise ModelError(f"seeds: expected {n} seeds (one per simulation), got {len(seeds)}")
    chain_run = ChainRun(hw, n_fb=n_fb, seeds=seeds, n_ticks=n_ticks)
    x = _initial_states(ctl, n, initial_states)
    vel, cmds, disp, done, failures = run_batch_ticks(plant, hw, chain_run, ctl, x, exc, exc_ch, sensors=sensors,
                                                      meas=meas, shape=shape, n_fb=n_fb, n_act=n_act)
    return BatchResult(period, excitation_point, np.array(exc), vel, cmds, disp, meas, shape, done, failures)


def _batch_excitation(excitation, n: int, n_ticks: int) -> np.ndarray:
    """The excitation as (n, n_ticks): one record for all simulations broadcast, or one per simulation."""
    exc = np.asarray(excitation, dtype=float)
    if exc.shape == (n_ticks,):
        exc = np.broadcast_to(exc, (n, n_ticks))
    if exc.shape != (n, n_ticks):
        raise ModelError(f"excitation must have one value per tick: expected ({n_ticks},) or ({n}, {n_ticks}), "
                         f"found {exc.shape}")
    return exc


def _batch_controller(engines, n: int, n_act: int, n_fb: int) -> BatchController | None:
    """The engines stacked (None open loop), their sizes checked against the loop's."""
    if engines is None:
        return None
    ctl = BatchController.of(engines, n)
    if ctl.f11.shape[1:] != (n_act, n_fb):
        raise ModelError(f"controller engine has {ctl.f11.shape[2]} inputs/{ctl.f11.shape[1]} outputs; "
                         f"loop has {n_fb} feedback sensors and {n_act} actuators")
    return ctl


def _initial_states(ctl: BatchController | None, n: int, initial_states) -> np.ndarray | None:
    """Controller states x_0, shape (n, n_x): zeros or ``initial_states`` checked; None open loop."""
    x = np.zeros((n, ctl.f22.shape[1])) if ctl is not None else None
    if initial_states is not None:
        x0 = np.asarray(initial_states, dtype=float)
        if x is None or x0.shape != x.shape or not np.all(np.isfinite(x0)):
            raise ModelError(f"initial_states: expected finite controller states of shape "
                             f"{None if x is None else x.shape}, found {x0.shape}")
        x = x0.copy()
    return x


def run_batch_ticks(plant, hw: BatchChain, chain_run: ChainRun, ctl: BatchController | None, x: np.ndarray | None,
                    exc: np.ndarray, exc_ch: int, *, sensors: tuple[int, ...], meas: tuple[int, ...],
                    shape: tuple[int, ...], n_fb: int, n_act: int):
    """The ticks of :func:`run_batch`: every simulation sampled, sensed, controlled and stepped at once.

    Per tick: the velocities of ``sensors`` (a diverged simulation is stopped,
    its tick and reason recorded), the chain's sensing, Eq. (5.1) as stacked
    matrix products, the DAC push and ``hw.n_sub`` physics steps with the
    chain's force.

    Parameters
    ----------
    plant : BatchPlant
        The N plants.
    hw : BatchChain
        The hardware of the N simulations.
    chain_run : ChainRun
        Its state for this run.
    ctl : BatchController or None
        The stacked engines; None open loop.
    x : ndarray, shape (N, n_x), or None
        Controller states at the start.
    exc : ndarray, shape (N, n_ticks)
        Excitation [N] per simulation and tick.
    exc_ch : int
        Actuator channel of the excitation.
    sensors, meas, shape : tuple of int
        Sensor points (feedback first), recorded velocity points, displacement points.
    n_fb, n_act : int
        Feedback sensors and actuator channels.

    Returns
    -------
    vel, cmds, disp : ndarray, shape (N, n_ticks, k)
        Measured velocities [m/s], commands, displacements [m].
    done : ndarray of int, shape (N,)
        Ticks each simulation ran.
    failures : dict
        Simulation index -> the reason it stopped.
    """
    n, n_ticks = exc.shape
    n_sens, period = len(sensors), hw.period_s
    meas_idx = np.array([sensors.index(p) for p in meas], dtype=int)
    all_sensors = np.array_equal(meas_idx, np.arange(n_sens))  # then the sensors' signals are the recording's
    # the records, tick-major while running (a tick's rows are contiguous; written in place)
    vel = np.zeros((n_ticks, n, len(meas)))
    disp = np.zeros((n_ticks, n, len(shape)))
    cmds = np.zeros((n_ticks, n, n_act))
    y_buf = np.zeros((n, n_sens))
    dynamic = ctl is not None and ctl.f22.shape[1] > 0
    e_mat = np.zeros((n, n_act))
    exc_t = np.ascontiguousarray(exc.T)
    done = np.full(n, n_ticks, dtype=int)
    failures: dict[int, str] = {}
    any_stopped = False
    last = hw.n_sub - 1
    for k, vel_k, u, e_k in zip(range(n_ticks), vel, cmds, exc_t):
        v = plant.velocities(sensors) if n_sens else np.zeros((n, 0))
        check_time = k % _TIME_CHECK == 0
        # diverged: a velocity above 1e3 m/s or NaN; a sum of squares <= 1e6 rules both out with one product
        vv = v.ravel()
        if check_time or (not vv @ vv <= 1e6 and not np.abs(v).max(initial=0.0) <= 1e3):
            if _stop_diverged(plant, v, k, period, check_time, sensors, done, failures):
                any_stopped = True
                if not plant.alive.any():
                    break
        if all_sensors:
            y = chain_run.sense(v, k, vel_k)
        else:
            y = chain_run.sense(v, k, y_buf)
            vel_k[...] = y[:, meas_idx]
        if shape:
            disp[k] = plant.displacements(shape)
        if ctl is not None:
            yf = y[:, :n_fb]
            _matvec(ctl.f11, yf, out=u)
            if dynamic:
                u += _matvec(ctl.f12, x)
                x = _matvec(ctl.f21, yf) + _matvec(ctl.f22, x)
        if any_stopped:
            u[~plant.alive] = 0.0
        chain_run.push(u)
        e_mat[:, exc_ch] = e_k
        for s in range(hw.n_sub):
            plant.set_forces(chain_run.force(s, e_mat))
            plant.step(sample=s == last)
    vel, cmds, disp = (np.ascontiguousarray(a.transpose(1, 0, 2)) for a in (vel, cmds, disp))
    return vel, cmds, disp, done, failures

