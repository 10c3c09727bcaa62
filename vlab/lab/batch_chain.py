"""The hardware chain of Fig. 21 vectorised over N simulations and their channels.

Every setting is an array of shape (N, n_channels) -- per simulation, per
actuator (or sensor) channel -- filled from one :class:`vlab.lab.loop.HardwareChain`
per simulation, so that per-channel settings slot in without changing the
arithmetic. One tick advances all N simulations with one array operation per
block (:func:`vlab.lab.batch.run_batch`):

* computation delay ``D = m + f`` periods (Sec. 5.3: 1.35) with the zero-order
  hold: within physics step ``s`` of a period the DAC holds ``u[k-m-1]`` for
  ``d_old`` seconds then ``u[k-m]`` for ``d_new`` (``d_old + d_new = h``),
  the same pieces as :meth:`vlab.lab.blocks.SampleDelay.segments_over`;
* RC low-pass (677 Hz), exact over the two pieces and averaged over the step
  (:meth:`vlab.lab.blocks.RCLowPass.update_segments`)::

      y1   = u_old + (y0 - u_old) e_old,       e = exp(-d / tau)
      y    = u_new + (y1 - u_new) e_new
      ybar = [u_old d_old + (y0 - u_old) tau (1 - e_old)
              + u_new d_new + (y1 - u_new) tau (1 - e_new)] / h
           = u_new + (u_old - u_new) d_old / h + [(y0 - u_old) tau (1 - e_old) + (y1 - u_new) tau (1 - e_new)] / h

  a channel without filter has ``tau = 0`` (``e = 0``), which reduces this to
  the hold's step average ``(u_old d_old + u_new d_new) / h``;
* amplifier ``clip(gain * u, -limit, limit)`` (no limit: infinite), then the
  actuator gain; optional first-order lags on coil forces and sensors
  (``a = exp(-2 pi f_c dt)``, ``a = 0`` when off, which passes the signal).

The durations and exponentials depend only on the delay fraction, so they are
computed once per run (the blocks of :mod:`vlab.lab.blocks` recompute them
every step from absolute times; the two agree to rounding, ~1e-16 relative,
tests/test_loop_reference.py).

This is the one implementation of the chain's arithmetic: the batched loop
runs it for N simulations and the single loop (:func:`vlab.lab.loop.run_loop`)
with N = 1, where the DAC/RC/amplifier stage runs on Python floats channel by
channel (:func:`rc_step` serves both: the same operations, the same bits; a
few channels cost less as floats than as arrays).

Source: Sec. 5.3 and Fig. 21 (PC-1000 delay 1.35 periods, 677 Hz RC filter,
controlled-current amplifier); the blocks of :mod:`vlab.lab.blocks`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ModelError


def _per_channel(chains, points, read, what: str) -> np.ndarray:
    """(N, len(points)) array of ``read(chain, point)``; finite values only."""
    arr = np.array([[float(read(c, p)) for p in points] for c in chains], dtype=float).reshape(len(chains), len(points))
    if np.any(np.isnan(arr)):
        raise ModelError(f"hardware chain: {what} is NaN")
    return arr


def _value(setting, point):
    """A chain setting for one channel: a dict keyed by point id (missing: None) or one value for all."""
    if isinstance(setting, dict):
        return setting.get(point)
    return setting


def _reader(name: str, default, channel_field: str | None = None):
    """``read(chain, point)``: a chain setting at one channel, ``default`` where it is None (off).

    HardwareChain's per-channel dict (``channel_*``, keyed by point id; None there switches a lag or
    limit off) wins over the chain-wide setting for its points.
    """
    def read(c, p):
        ch = getattr(c, channel_field, None) or {} if channel_field else {}
        v = ch[p] if p in ch else _value(getattr(c, name), p)
        return default if v is None else v
    return read


def _delay_and_filter(chains, acts: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Whole and fractional delay [periods] and RC time constant [s] (0: no filter), each (N, n_act); checked."""
    delay = _per_channel(chains, acts, _reader("delay_periods", 0.0, "channel_delay_periods"), "delay_periods")
    if np.any(delay < 0) or not np.all(np.isfinite(delay)):
        raise ModelError(f"hardware chain: delay_periods must be finite and >= 0, got {delay.ravel().tolist()}")
    delay = np.where(np.abs(delay - np.round(delay)) < 1e-9, np.round(delay), delay)
    m = np.floor(delay).astype(int)
    frac = delay - m
    corner = _per_channel(chains, acts, _reader("filter_hz", math.inf), "filter_hz")
    if np.any(corner < 0):
        raise ModelError(f"hardware chain: filter_hz must be >= 0 (0 or None: no filter), got "
                         f"{corner.ravel().tolist()}")
    corner[corner == 0] = math.inf  # 0: no filter, as None
    tau = np.where(np.isfinite(corner), 1.0 / (2.0 * math.pi * np.where(np.isfinite(corner), corner, 1.0)), 0.0)
    return m, frac, tau


def _hold_steps(frac: np.ndarray, tau: np.ndarray, n_sub: int, period: float, h: float):
    """Per physics step: time on the older and newer DAC sample [s] and the RC decay over each (module notes)."""
    d_old = np.empty((n_sub, *frac.shape))
    for s in range(n_sub):
        a, b = s / n_sub, (s + 1) / n_sub
        d_old[s] = np.clip(frac - a, 0.0, b - a) * period
    d_new = h - d_old

    def decay(d):
        with np.errstate(divide="ignore", invalid="ignore"):
            e = np.where(tau > 0, np.exp(-d / np.where(tau > 0, tau, 1.0)), 0.0)
        return np.where(d == 0, 1.0, e)

    return d_old, d_new, decay(d_old), decay(d_new)


def lag_mean_weight(corner_hz, h_s: float) -> np.ndarray:
    """``g = (tau / h)(1 - exp(-h / tau))``, ``tau = 1 / (2 pi f_c)``, of first-order lags of corners
    ``corner_hz`` over a physics step ``h_s`` (:func:`lag_step`).

    Parameters
    ----------
    corner_hz : array_like, any shape
        Corner frequencies [Hz]; 0 or less: no lag (``g = 0``).
    h_s : float
        Physics step [s], > 0.

    Returns
    -------
    ndarray, shape of ``corner_hz``
        ``g`` [1], in (0, 1) where there is a lag.
    """
    fc = np.asarray(corner_hz, dtype=float)
    a = 2 * math.pi * np.where(fc > 0, fc, 1.0) * h_s  # h / tau
    return np.where(fc > 0, -np.expm1(-a) / a, 0.0)


def lag_step(y0, u, c, g):
    """One physics step of a continuous first-order lag ``tau y' = u - y`` whose input ``u`` is held over the
    step: returns ``(y1, mean)``, its value at the step's end ``y1 = c y0 + (1 - c) u`` and its exact
    average over the step ``u + g (y0 - u)`` (``c = exp(-h / tau)``, ``g = (tau / h)(1 - c)``), the force the
    plant holds over the step. The step's held input is the step average of what precedes the lag (the RC
    filter's exact average, :func:`rc_step`), a midpoint value; the lag's average is then its value at the
    midpoint too, to second order in ``h``, whatever the step: a lag's end-of-step value held over the step
    would lead the continuous lag by ``h / 2``.

    Parameters
    ----------
    y0 : float or ndarray
        The lag's value at the step's start [N].
    u : float or ndarray
        Its input, held over the step [N] (broadcast with ``y0``).
    c, g : float or ndarray
        ``exp(-h / tau)`` and :func:`lag_mean_weight` [1]; ``c = g = 0``: no lag (``mean = y1 = u``).

    Returns
    -------
    (y1, mean)
        The value at the step's end and the average over the step [N], shape of the broadcast inputs.

    Source: the exact solution ``y(t) = u + (y0 - u) e^{-t / tau}`` of the first-order lag under a constant
    input, averaged over ``0 <= t <= h``.
    """
    return c * y0 + (1 - c) * u, u + g * (y0 - u)


@dataclass(frozen=True)
class BatchChain:
    """Per-simulation, per-channel hardware settings and the step coefficients derived from them.

    Attributes
    ----------
    period_s : float
        Controller period T [s], common to all simulations.
    n_sub : int
        Physics steps per period.
    delay_int : ndarray of int, shape (N, n_act)
        ``m = floor(D)`` of each channel's delay.
    d_old_s, d_new_s : ndarray, shape (n_sub, N, n_act)
        Durations [s] of the older and newer held sample within each physics step.
    e_old, e_new : ndarray, shape (n_sub, N, n_act)
        RC decay ``exp(-d / tau)`` over them (0 without filter).
    w_old : ndarray, shape (n_sub, N, n_act)
        ``d_old / h``: share of the step holding the older sample.
    j_old, j_new : ndarray, shape (n_sub, N, n_act)
        ``tau (1 - e) / h``: the RC's decay weights in the step average.
    amp_gain : ndarray, shape (N, n_act)
        Amplifier gain [N/N].
    amp_limit_n : ndarray, shape (N, n_act)
        Saturation [N] (inf: linear).
    actuator_gain : ndarray, shape (N, n_act)
        Coil force gain [-].
    actuator_lag : ndarray, shape (N, n_act)
        ``c = exp(-h / tau)`` of the coil-force lag per physics step ``h`` (0: off).
    actuator_lag_mean : ndarray, shape (N, n_act)
        ``g = (tau / h)(1 - c)``: the weight of the lag's start in its output's average over the step
        (:func:`lag_step`; 0: off).
    sensor_gain : ndarray, shape (N, n_fb)
        Feedback sensor sensitivity [-].
    sensor_lag : ndarray, shape (N, n_fb)
        ``a`` of the sensor lag per period (0: off).
    noise_m_s : ndarray, shape (N, n_sensors)
        Sensor noise standard deviation [m/s].
    """

    period_s: float
    n_sub: int
    delay_int: np.ndarray
    d_old_s: np.ndarray
    d_new_s: np.ndarray
    e_old: np.ndarray
    e_new: np.ndarray
    w_old: np.ndarray
    j_old: np.ndarray
    j_new: np.ndarray
    amp_gain: np.ndarray
    amp_limit_n: np.ndarray
    actuator_gain: np.ndarray
    actuator_lag: np.ndarray
    actuator_lag_mean: np.ndarray
    sensor_gain: np.ndarray
    sensor_lag: np.ndarray
    noise_m_s: np.ndarray

    @property
    def history(self) -> int:
        """Depth of the DAC buffer: ``max(m) + 2`` samples."""
        return int(self.delay_int.max(initial=0)) + 2

    @classmethod
    def from_chains(cls, chains, *, timestep_s: float, actuators, feedback, n_sensors: int) -> BatchChain:
        """Vectorise one :class:`vlab.lab.loop.HardwareChain` per simulation.

        A chain setting may be one value for every channel (the current
        :class:`HardwareChain`) or a dict keyed by actuator / sensor point id
        (as ``actuator_gain`` and ``sensor_gain``; a missing point takes the
        neutral value: gain 1, no lag, no limit, and for delay and filter the
        chain's ``delay_periods`` / ``filter_hz`` defaults of Sec. 5.3). The
        chain's per-channel dicts (``channel_delay_periods``, ``channel_limit_n``,
        ``channel_actuator_lag_hz``, ``channel_sensor_lag_hz``) override the
        chain-wide value at their points, as in :func:`vlab.lab.loop.run_loop`.

        Parameters
        ----------
        chains : sequence of HardwareChain, length N
            All with the same ``period_s``.
        timestep_s : float
            Physics step h [s]; must divide the period.
        actuators : tuple of int
            Coil points (n_act).
        feedback : tuple of int
            Feedback sensor points (n_fb).
        n_sensors : int
            Number of sensors read per tick (feedback first), for the noise.

        Returns
        -------
        BatchChain

        Raises
        ------
        ModelError
            Different periods, a step that does not divide the period, a
            negative delay or filter corner (0: no filter), a limit <= 0, a
            negative noise level, a non-finite gain.
        """
        chains = list(chains)
        if not chains:
            raise ModelError("hardware chain: at least one simulation is needed")
        period = chains[0].period_s
        if any(abs(c.period_s - period) > 1e-12 * period for c in chains):
            raise ModelError(f"hardware chain: all simulations must share one period_s; got "
                             f"{sorted({c.period_s for c in chains})}")
        h = float(timestep_s)
        n_sub = int(round(period / h))
        if n_sub < 1 or abs(n_sub * h - period) > 1e-9 * period:
            raise ModelError(f"physics step {h:g} s must divide the controller period {period:g} s")
        acts, fb = tuple(actuators), tuple(feedback)
        m, frac, tau = _delay_and_filter(chains, acts)
        d_old, d_new, e_old, e_new = _hold_steps(frac, tau, n_sub, period, h)
        limit = _per_channel(chains, acts, _reader("amplifier_limit_n", math.inf, "channel_limit_n"),
                             "amplifier_limit_n")
        if np.any(limit <= 0):
            raise ModelError(f"hardware chain: amplifier_limit_n must be > 0, got {limit.ravel().tolist()}")
        lag_a = _per_channel(chains, acts, _reader("actuator_lag_hz", 0.0, "channel_actuator_lag_hz"),
                             "actuator_lag_hz")
        lag_s = _per_channel(chains, fb, _reader("sensor_lag_hz", 0.0, "channel_sensor_lag_hz"), "sensor_lag_hz")
        noise = np.array([[c.noise_m_s] * n_sensors for c in chains], dtype=float).reshape(len(chains), n_sensors)
        if np.any(noise < 0) or not np.all(np.isfinite(noise)):
            raise ModelError(f"hardware chain: noise_m_s must be finite and >= 0, got {noise[:, 0].tolist()}")
        gains = {name: _per_channel(chains, points, read, name) for name, points, read in (
            ("amplifier_gain", acts, _reader("amplifier_gain", 1.0)),
            ("actuator_gain", acts, lambda c, p: c.actuator_gain.get(p, 1.0)),
            ("sensor_gain", fb, lambda c, p: c.sensor_gain.get(p, 1.0)))}
        for name, g in gains.items():
            if not np.all(np.isfinite(g)):
                raise ModelError(f"hardware chain: {name} must be finite, got {g.ravel().tolist()}")
        return cls(
            period_s=float(period), n_sub=n_sub, delay_int=m, d_old_s=d_old, d_new_s=d_new,
            e_old=e_old, e_new=e_new, w_old=d_old / h,
            j_old=tau * (1.0 - e_old) / h, j_new=tau * (1.0 - e_new) / h,
            amp_gain=gains["amplifier_gain"], amp_limit_n=limit, actuator_gain=gains["actuator_gain"],
            actuator_lag=np.where(lag_a > 0, np.exp(-2 * math.pi * lag_a * h), 0.0),
            actuator_lag_mean=lag_mean_weight(lag_a, h),
            sensor_gain=gains["sensor_gain"],
            sensor_lag=np.where(lag_s > 0, np.exp(-2 * math.pi * lag_s * period), 0.0),
            noise_m_s=noise,
        )


#: Sensor noise is drawn per simulation in blocks of this many ticks (the same stream as one draw per tick).
NOISE_BLOCK = 512


def rc_step(rc, u_old, u_new, du, e_old, e_new, w_old, j_old, j_new):
    """One physics step of the DAC hold and the RC filter (the module notes' equations).

    The one implementation of that arithmetic: on arrays (N, n_act) for the
    batch, on floats (one channel) for the single loop -- the same IEEE
    operations in the same order, so both give the same bits.

    Parameters
    ----------
    rc : float or ndarray
        RC output ``y0`` at the start of the step [N].
    u_old, u_new : float or ndarray
        Older and newer held DAC samples [N]; ``du = u_old - u_new``.
    e_old, e_new, w_old, j_old, j_new : float or ndarray
        The step's coefficients (:class:`BatchChain`).

    Returns
    -------
    (rc_end, mean)
        RC output at the end of the step and its average over the step [N].
    """
    dy0 = rc - u_old
    y1 = u_old + dy0 * e_old
    dy1 = y1 - u_new
    return u_new + dy1 * e_new, u_new + (du * w_old + (dy0 * j_old + dy1 * j_new))


class ChainRun:
    """The running chain of N simulations: sensor stage and DAC/RC/amplifier stage, with their state.

    The one implementation of the chain's per-tick arithmetic: the batched
    loop (:func:`vlab.lab.batch.run_batch`) runs it for N simulations and the
    single loop (:func:`vlab.lab.loop.run_loop`) with N = 1.

    Per tick: :meth:`sense` (sensor gain, lag, noise: one array operation
    each for all N), :meth:`push` (the controller output into the DAC
    buffer), then :meth:`force` once per physics step. With N = 1,
    :meth:`push_one` and :meth:`force_one` do the DAC/RC/amplifier stage on
    Python floats, channel by channel (:func:`rc_step` and the same blocks,
    the same operations: a few channels cost less as floats than as arrays).
    A block whose setting is neutral everywhere (gain 1, no limit, no lag) is
    skipped: its operation would be exact (``x * 1.0 = x``), so skipping it
    changes no bit.

    Parameters
    ----------
    hw : BatchChain
        Settings of the N simulations.
    n_fb : int
        Feedback sensors (the first ``n_fb`` of the sensors read).
    seeds : sequence of int, length N
        Noise seed of each simulation (``numpy.random.default_rng(seed)``,
        ``standard_normal`` per sensor per tick, as :class:`vlab.lab.blocks.SensorNoise`;
        drawn :data:`NOISE_BLOCK` ticks at a time, the same stream).
    n_ticks : int
        Ticks of the run (noise drawn up to it).

    Raises
    ------
    ModelError
        A seed that is not an int (with noise on).

    Notes
    -----
    Source: Fig. 21 and Sec. 5.3; the update equations in the module notes.
    """

    def __init__(self, hw: BatchChain, *, n_fb: int, seeds, n_ticks: int) -> None:
        self.hw = hw
        n, n_act = hw.amp_gain.shape
        n_sens = hw.noise_m_s.shape[1]
        self._n_fb, self._n_ticks = n_fb, n_ticks
        self._rngs = None
        if n_sens and np.any(hw.noise_m_s > 0):
            bad = [s for s in seeds if isinstance(s, bool) or not isinstance(s, (int, np.integer))]
            if bad:
                raise ModelError(f"sensor noise: seed must be an int, got {bad[0]!r}")
            self._rngs = [np.random.default_rng(int(s)) for s in seeds]
        self._noise = None
        self._hist = np.zeros((hw.history, n, n_act))          # ring of the last u: u[k] at k mod history
        self._tick = 0
        self._uniform = bool(np.all(hw.delay_int == hw.delay_int.flat[0]))
        self._m0 = int(hw.delay_int.flat[0])
        self._gather = (np.arange(n)[:, None], np.arange(n_act)[None, :])
        self._rc = np.zeros((n, n_act))
        self._lag_act = np.zeros((n, n_act))
        self._lag_sen = np.zeros((n, n_fb))
        self._clip = bool(np.any(np.isfinite(hw.amp_limit_n)))
        self._amp = hw.amp_gain if np.any(hw.amp_gain != 1.0) else None
        self._act_gain = hw.actuator_gain if np.any(hw.actuator_gain != 1.0) else None
        self._sen_gain = hw.sensor_gain if np.any(hw.sensor_gain != 1.0) else None
        # a corner so high that c underflows to 0 keeps its (small) g
        self._use_lag_a = bool(np.any(hw.actuator_lag > 0) or np.any(hw.actuator_lag_mean > 0))
        self._use_lag_s = bool(np.any(hw.sensor_lag > 0))
        self._sense_fb = bool(n_fb and (self._sen_gain is not None or self._use_lag_s))
        # the step coefficients of each physics step s, looked up once
        self._steps = [(hw.e_old[s], hw.e_new[s], hw.w_old[s], hw.j_old[s], hw.j_new[s]) for s in range(hw.n_sub)]
        self._u_new = self._u_old = self._du = None
        if n == 1:  # the floats of push_one / force_one: per step s, per channel (i, m, e_old, e_new, w_old, j_old, j_new)
            self._hist1 = [[0.0] * n_act for _ in range(hw.history)]
            self._rc1 = [0.0] * n_act
            self._f1 = [0.0] * n_act
            self._lag1 = [0.0] * n_act
            self._steps1 = [list(zip(range(n_act), hw.delay_int[0].tolist(), *(c[0].tolist() for c in st)))
                            for st in self._steps]
            self._post1 = (self._amp is not None or self._clip or self._act_gain is not None or self._use_lag_a)
            self._coil1 = list(zip(hw.amp_gain[0].tolist(), hw.amp_limit_n[0].tolist(),
                                   hw.actuator_gain[0].tolist(), hw.actuator_lag[0].tolist(),
                                   hw.actuator_lag_mean[0].tolist()))

    def sense(self, v: np.ndarray, k: int, out: np.ndarray | None = None) -> np.ndarray:
        """Measured signals of tick ``k`` from the velocities ``v`` (N, n_sensors) [m/s]; same shape.

        ``y = sensor gain x v`` (lagged) on the feedback sensors, ``+ sigma w`` on every sensor.
        ``out`` (N, n_sensors), optional, receives them (and is returned); without it a new array.
        With N = 1, ``v`` and ``out`` may also be of shape (n_sensors,).
        """
        y = v
        if self._sense_fb:
            hw, n_fb = self.hw, self._n_fb
            y = v.copy()
            y2 = y.reshape(-1, y.shape[-1])
            y_fb = y2[:, :n_fb] * self._sen_gain if self._sen_gain is not None else y2[:, :n_fb]
            if self._use_lag_s:
                self._lag_sen = hw.sensor_lag * self._lag_sen + (1 - hw.sensor_lag) * y_fb
                y_fb = self._lag_sen
            y2[:, :n_fb] = y_fb
        if self._rngs is not None:
            i = k % NOISE_BLOCK
            if i == 0:
                nb = min(NOISE_BLOCK, self._n_ticks - k)
                noise = np.stack([r.standard_normal((nb, v.shape[-1])) for r in self._rngs], axis=1)
                self._noise = (noise * self.hw.noise_m_s).reshape(nb, *v.shape)
            return np.add(y, self._noise[i], out=out)
        if out is None:
            return y.copy() if y is v else y
        out[...] = y
        return out

    def push(self, u: np.ndarray) -> None:
        """Latch the controller outputs ``u`` (N, n_act) [N] of this tick into the DAC buffer."""
        h, t, n_h = self._hist, self._tick, len(self._hist)
        h[t % n_h] = u  # a ring: u[k - i] is at (k - i) mod history
        if self._uniform:
            self._u_new, self._u_old = h[(t - self._m0) % n_h], h[(t - self._m0 - 1) % n_h]
        else:
            m = self.hw.delay_int
            self._u_new, self._u_old = h[((t - m) % n_h, *self._gather)], h[((t - m - 1) % n_h, *self._gather)]
        self._du = self._u_old - self._u_new
        self._tick = t + 1

    def force(self, s: int, excitation: np.ndarray) -> np.ndarray:
        """Coil forces [N], shape (N, n_act), held over physics step ``s`` of the tick.

        ``excitation`` (N, n_act) [N] is added before the amplifier (Fig. 21).
        The DAC/RC step average is ``u_new + (u_old - u_new) d_old/h`` plus
        the RC's decay terms (:func:`rc_step`): exactly ``u_new`` when the
        step holds one sample and there is no filter, as
        ``SampleDelay.mean_over`` gives it.
        """
        hw = self.hw
        self._rc, f = rc_step(self._rc, self._u_old, self._u_new, self._du, *self._steps[s])
        f += excitation
        if self._amp is not None:
            f *= self._amp
        if self._clip:
            np.minimum(f, hw.amp_limit_n, out=f)
            np.maximum(f, -hw.amp_limit_n, out=f)
        if self._act_gain is not None:
            f *= self._act_gain
        if self._use_lag_a:
            self._lag_act, f = lag_step(self._lag_act, f, hw.actuator_lag, hw.actuator_lag_mean)
        return f

    def push_one(self, u: list) -> None:
        """:meth:`push` for N = 1 on floats: ``u`` the n_act controller outputs [N] of this tick."""
        h = self._hist1
        h.pop()
        h.insert(0, u)

    def force_one(self, s: int, excitation: list) -> list:
        """:meth:`force` for N = 1 on floats: the n_act coil forces [N] of physics step ``s`` (a list, reused).

        ``excitation``: n_act floats [N] added before the amplifier. The same
        operations as :meth:`force` channel by channel, so the same bits.
        """
        h, rc, f = self._hist1, self._rc1, self._f1
        for i, m, e_old, e_new, w_old, j_old, j_new in self._steps1[s]:
            u_new, u_old = h[m][i], h[m + 1][i]
            rc[i], fi = rc_step(rc[i], u_old, u_new, u_old - u_new, e_old, e_new, w_old, j_old, j_new)
            f[i] = fi + excitation[i]
        if self._post1:
            lag = self._lag1
            for i, (amp, limit, gain, c, g) in enumerate(self._coil1):
                fi = f[i] * amp if self._amp is not None else f[i]
                fi = max(min(fi, limit), -limit) if self._clip else fi
                fi = fi * gain if self._act_gain is not None else fi
                if self._use_lag_a:
                    lag[i], fi = lag_step(lag[i], fi, c, g)
                f[i] = fi
        return f
