"""Warm start of a rerun: the lab put in its periodic steady state, so that a rerun skips the settling.

A test with periodic excitation is recorded from rest; its first periods
are dropped (the transient of the lightly damped structure) and the rest
analysed (:mod:`vlab.diagnose.data.frfestimate`). A validation rerun only needs the
analysed periods. So the rerun starts :data:`GUARD_PERIODS` period(s) before
them, from the steady state the lab would have reached there: the
excitation's lines over one period (its discrete Fourier transform), the
coil forces and sensed velocities per line from the frequency-domain model
of the whole loop (:func:`vlab.diagnose.model.labmodel.predict_frf`, with the
MuJoCo plant's own modes for a MuJoCo plant), the plant set to their
steady state (``set_periodic_state`` of :class:`vlab.lab.linear_plant.LinearPlant`
and :class:`vlab.sim.runtime.MujocoPlant`) and the controller's state to
``x = Re sum_k (z_k I - F22)^-1 F21 Y_k``, ``z_k = exp(j w_k T)`` (Eq. 5.1 in
the z-domain). What the model misses -- the chain's short memories (delay,
filter), modes above the model, nonlinear effects such as saturation or
friction, whose describing functions set the start -- leaves a transient
that the guard period lets decay, as the recording's own dropped periods
did. This is the periodic steady-state initialisation of circuit
simulation (Aprille & Trick, Proc. IEEE 60 (1972) 108-114) done in the
frequency domain.

A rerun then simulates :data:`RERUN_PERIODS` analysed period: the grid's 100 s
test (3 dropped, 2 analysed 20 s periods) is rerun in 40 s of simulated time.
A test that drops less than the guard keeps is rerun as it was recorded
(:func:`recorded_window`): from rest through every analysed period when the
recording began at rest (its transient is then in both), else from the
steady state at its first tick (a recording taken once the excitation had
run, as an acquisition system records); one not estimated period by period
(H1 with a window) is rerun whole.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ...errors import ModelError
from ..model.labmodel import LabState, PointModes, predict_frf, sensor_path
from .measured import FrfData

#: Periods simulated before the analysed ones after a warm start. The start is
#: exact only for the linear model of the loop; what it misses decays as
#: ``exp(-t / tau)`` with the slowest structural ``tau = 1 / (zeta omega)``
#: (7 s for the grid's mode 1, 2 s for the BCC's): one 20 s period leaves
#: ``e^-2.8 = 6 %`` of an already small start error. A chosen margin.
GUARD_PERIODS = 1

#: Decay of the start error a shorter guard must reach: given the lab's slowest decay time, the guard is
#: ``ln(1 / GUARD_DECAY) * tau`` (:func:`guard_ticks`), at most :data:`GUARD_PERIODS` periods. Measured on
#: the default BCC MFDRF recording replayed on the MuJoCo plant: a guard of half a period (10 s, 9 tau)
#: gives the FRF of a one-period guard to 1.6e-6 (relative, largest line), a quarter period to 5e-4.
GUARD_DECAY = 1e-3

#: Analysed periods a rerun simulates (after the guard period). A rerun is noise-free
#: (:func:`vlab.diagnose.data.replay.expectation`), so one period gives its FRF and its time history to the
#: start error the guard leaves; the recording keeps all its analysed periods. A chosen length.
RERUN_PERIODS = 1

#: Lines of the excitation below this fraction of its largest are left out of the start.
LINE_FLOOR = 1e-6


def period_ticks(data: FrfData, dt_s: float) -> int:
    """Controller ticks per excitation period of ``data`` (``1 / (resolution dt)``).

    Parameters
    ----------
    data : FrfData
        Its lines are multiples of the resolution [Hz].
    dt_s : float
        Controller period [s].
    """
    df = float(np.min(np.diff(data.freq_hz))) if data.freq_hz.size > 1 else float(data.freq_hz[0])
    return int(round(1.0 / (df * dt_s)))


def guard_ticks(data: FrfData, dt_s: float, guard_s: float | None = None) -> int:
    """Ticks simulated after a warm start before the analysed part: :data:`GUARD_PERIODS` periods, or
    ``guard_s`` [s] where that is shorter (the lab's own decay, :data:`GUARD_DECAY`).

    Parameters
    ----------
    data : FrfData
    dt_s : float
        Controller period [s].
    guard_s : float, optional
        Time [s] for the slowest mode of the lab to decay by :data:`GUARD_DECAY`.
    """
    full = GUARD_PERIODS * period_ticks(data, dt_s)
    if guard_s is None or not np.isfinite(guard_s):
        return full
    return min(full, max(1, int(np.ceil(guard_s / dt_s))))


def start_tick(data: FrfData, dt_s: float, guard_s: float | None = None) -> int:
    """Tick at which a warm-started rerun of ``data`` begins: :func:`guard_ticks` before the analysed part
    (the excitation is periodic, so the steady state is known at any tick), 0 (a rerun from rest) for data
    not estimated period by period or without enough dropped samples.

    Parameters
    ----------
    data : FrfData
        With a recording.
    dt_s : float
        Controller period [s].
    guard_s : float, optional
        As :func:`guard_ticks`.
    """
    if not data.periodic or data.recording is None:
        return 0
    first = int(round(data.analysed_from_s / dt_s))
    k0 = first - guard_ticks(data, dt_s, guard_s)
    return k0 if k0 > 0 else 0


def rerun_window(data: FrfData, dt_s: float, periods: int | None = RERUN_PERIODS,
                 guard_s: float | None = None) -> tuple[int, int, int | None]:
    """``(start, period, stop)`` ticks of a rerun of ``data``'s test: a warm start one guard period before
    the analysed part where the test is periodic (:func:`start_tick`; else from
    rest, ``start = period = 0``), and the end after ``periods`` analysed periods (None, or a rerun from
    rest: the whole record). ``data``, ``dt_s`` and ``guard_s`` as in :func:`start_tick`.

    Parameters
    ----------
    periods : int or None
        Analysed periods to rerun (default :data:`RERUN_PERIODS`; None: to the end of the record).
    """
    k0 = start_tick(data, dt_s, guard_s)
    n_per = period_ticks(data, dt_s) if data.periodic else 0
    stop = None
    if periods is not None and n_per and k0:  # from rest: through every analysed period, as the recording's
        # transient is removed over all of them (vlab.measure.transient), so is the rerun's
        stop = int(round(data.analysed_from_s / dt_s)) + periods * n_per
    return (k0, n_per if k0 else 0, stop)


def excitation_lines(force: np.ndarray, dt_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Lines of one period of an excitation command: frequencies [Hz] and phasors [N], such that
    ``x(t) = Re sum_k X_k exp(j 2 pi f_k t)`` (the mean and the Nyquist line left out).

    Parameters
    ----------
    force : ndarray, shape (n_per,)
        One period of the command, starting where the phasors' ``t = 0`` is [N].
    dt_s : float
        Sampling interval [s].

    Returns
    -------
    freq_hz, phasors : ndarray, shape (n_lines,)
    """
    x = np.asarray(force, dtype=float)
    spec = np.fft.rfft(x) * (2.0 / x.size)
    f = np.fft.rfftfreq(x.size, dt_s)
    amp = np.abs(spec)
    keep = np.arange(1, spec.size - (1 if x.size % 2 == 0 else 0))
    keep = keep[amp[keep] > LINE_FLOOR * max(float(amp[keep].max(initial=0.0)), 1e-300)]
    return f[keep], spec[keep]


def warm_start(state: LabState, plant, engine, force: np.ndarray, *, excitation_point: int, start: int,
               n_per: int) -> None:
    """Set ``plant`` (and ``engine``) to the lab's periodic steady state at tick ``start``.

    Parameters
    ----------
    state : LabState
        The lab rerun (chain, controller design, structure).
    plant : LinearPlant, FrictionPlant or MujocoPlant
        Built for ``state``; has ``set_periodic_state``. A MuJoCo plant's own
        modes (``modal_model``) replace the FE model's in the loop model.
    engine : ControllerEngine or None
        The controller (open loop: None); its state is set.
    force : ndarray, shape (n_ticks,)
        The excitation command of the whole test [N]; periodic with ``n_per`` ticks.
    excitation_point : int
    start : int
        Tick of the start (a period's start).
    n_per : int
        Ticks per period.

    Raises
    ------
    ModelError
        Fewer than one period of force after ``start``, or a plant without ``set_periodic_state``.
    """
    dt = state.chain.period_s
    if force.size < start + n_per:
        raise ModelError(f"warm start at tick {start} needs a period ({n_per} ticks) of force; "
                         f"the record has {force.size}")
    if not hasattr(plant, "set_periodic_state"):
        raise ModelError(f"{type(plant).__name__} cannot be put in a periodic state")
    freq, cmd = excitation_lines(force[start:start + n_per], dt)
    acts = state.actuators
    if hasattr(plant, "modal_model"):  # the MuJoCo plant: its own modes
        omega, zeta, _phi, w = plant.modal_model(acts)
        state = replace(state, point_modes=PointModes(omega, zeta, w, tuple(acts), "the MuJoCo plant"))
    v, (f_coil, _cmd) = predict_frf(state, freq, excitation_point=excitation_point, output_points=acts,
                                    return_forces=True)
    plant.set_periodic_state(freq, f_coil * cmd[:, None])
    if engine is not None and engine.n_states:
        y = sensor_path(state, freq) * v * cmd[:, None]                        # (n_f, n_y) sensed velocities
        z = np.exp(2j * np.pi * freq * dt)
        n_x = engine.n_states
        xc = np.linalg.solve(z[:, None, None] * np.eye(n_x)[None] - engine.F22[None],
                             (engine.F21 @ y.T).T[:, :, None])[:, :, 0]
        engine.reset(np.sum(xc, axis=0).real)


def starts_at_rest(rec, points, *, head_s: float = 0.01, ratio: float = 0.2) -> bool:
    """Whether a recording began with the structure at rest (as ``vlab experiment`` starts): the velocities'
    RMS over its first ``head_s`` [s] is below ``ratio`` of their RMS over the whole record, on every channel
    (a structure at rest has no velocity; one started in its periodic steady state moves at once).

    Parameters
    ----------
    rec : Recording
    points : sequence of int
        Points whose ``vel<p>`` channels are looked at.
    head_s : float
        Length of the start looked at [s] (10 ms: a few samples, shorter than any mode's quarter period in
        the lab's bands).
    ratio : float
        Largest RMS ratio of a start at rest (the recording's noise alone gives about its noise-to-signal
        ratio, 1 % in the benchmark).

    Returns
    -------
    bool
    """
    n = max(2, int(round(head_s / rec.dt_s)))
    for p in points:
        v = np.asarray(rec[f"vel{p}"])
        whole = float(np.sqrt(np.mean(v ** 2)))
        if whole > 0 and float(np.sqrt(np.mean(v[:n] ** 2))) >= ratio * whole:
            return False
    return True


def recorded_window(data: FrfData, dt_s: float, periods: int | None = RERUN_PERIODS,
                    guard_s: float | None = None) -> tuple[int, int, int | None]:
    """``(start, period, stop)`` ticks of a rerun that starts as the recording did.

    :func:`rerun_window`, except where a periodic recording dropped less than the guard needs
    (``rerun_window`` then reruns from rest): a recording that began at rest (:func:`starts_at_rest`) carries
    the start's transient in its analysed periods, so the rerun starts at rest too and runs through all of
    them (the transient is in both); one that began in the steady state -- the excitation already running, as
    an acquisition system records -- is rerun from the steady state at its first tick (a rerun from rest would
    add a transient the recording does not have).

    Parameters
    ----------
    data, dt_s, guard_s
        As in :func:`start_tick`.
    periods : int or None
        Analysed periods to rerun (None: to the end of the record).

    Returns
    -------
    (int, int, int or None)
        Start tick, period in ticks (0: from rest), stop tick (None: the whole record).
    """
    start, period, stop = rerun_window(data, dt_s, periods, guard_s)
    if not data.periodic or period or data.recording is None:
        return start, period, stop
    if starts_at_rest(data.recording, data.output_points):
        return 0, 0, None
    period = period_ticks(data, dt_s)
    first = int(round(data.analysed_from_s / dt_s))
    return 0, period, (None if periods is None else first + periods * period)
