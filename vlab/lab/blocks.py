"""Blocks of the digital control loop of Fig. 21 (Sec. 5.3).

The physical chain from sensor to structure in the dissertation's laboratory
is::

    velocity sensor --(+ noise)--> PC-1000 [sample, Eq. (5.1), DAC with
    zero-order hold, total delay 1.35 dt] --> RC low-pass (677 Hz) -->
    controlled-current amplifier --> force coil

Each block here is a small object in the style of Drake's
``ZeroOrderHold``/``DiscreteTimeDelay``: its update equation in the
docstring, named signals (``u`` in, ``y`` out), an explicit period or step in
seconds, ``update(u)`` to advance the state and ``output()`` to read it. Every
block carries a vector of ``size`` channels; inputs must have shape
``(size,)``.

Two clocks meet in the loop: the controller period ``period_s`` (0.5 ms at
2 kHz) and the physics step ``step_s`` of the plant integration, which
divides it (e.g. 0.5 ms / 10). :meth:`SampleDelay.output_at` gives the
held-and-delayed DAC voltage at any physics time, so a plant stepped at
``step_s`` sees the switch that happens 1.35 dt after each sample instant.

A typical loop (controller period ``dt``, ``n_sub`` physics steps per period)::

    for k in range(n_periods):
        t_k = k * dt
        y_k = noise.output(sensor(plant))          # sample at t_k
        u_k = engine.step(y_k)                     # Eq. (5.1)
        dac.update(u_k)                            # DAC switches at t_k + 1.35 dt
        for s in range(n_sub):
            t = t_k + s * h
            rc.update_segments(dac.segments_over(t, t + h))  # 677 Hz smoothing, exact
            f = amp.output(rc.mean() + f_exc(t))   # coil force held over [t, t+h): the RC's
                                                   # step average; the excitation joins
                                                   # before the amplifier (Fig. 21)
            plant.step(h, f)

The lab's loops do not run these objects: :func:`vlab.lab.loop.run_loop` and
:func:`vlab.lab.batch.run_batch` both run the chain with
:class:`vlab.lab.batch_chain.ChainRun`, vectorised, its step coefficients
computed once per run (the block objects, each checking its input on every
call, took most of the single loop's time per tick). The blocks remain the
reference implementation, with absolute switch times and the exact step
average written out, that the shared chain is tested against
(tests/test_loop_reference.py), and a documented model of each piece of the
hardware.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import ModelError, SimulationError
from .block import Block, positive

#: Sampling period of the PC-1000 at its maximum rate of 2000 samples/s [s] (Sec. 5.3).
PC1000_PERIOD_S = 0.5e-3
#: Delay through the PC-1000 from sample to DAC output, in sampling periods (Sec. 5.3).
PC1000_DELAY_PERIODS = 1.35
#: Corner frequency of the passive RC smoothing filters [Hz] (Sec. 5.3).
RC_CORNER_HZ = 677.0

#: Relative tolerance, in periods, for deciding on which side of a switch instant a time lies.
_TIME_TOL = 1e-9


class ZeroOrderHold(Block):
    """Sample-and-hold of a signal at a fixed period.

    Update and output (sample ``n`` at ``t_n = offset_s + n * period_s``)::

        x[n+1] = u[n]                   (update, at t_n)
        y(t)   = x[n+1] = u[n]          for t_n <= t < t_{n+1}

    Before the first update ``y = initial_value``.

    Parameters
    ----------
    period_s : float
        Sampling period [s], e.g. :data:`PC1000_PERIOD_S`.
    size : int
        Number of channels; ``u`` and ``y`` have shape (size,).
    initial_value : float or array_like, shape (size,)
        Held value before the first sample.
    offset_s : float
        Time of sample 0 [s].
    name : str
        Used in error messages (``"zoh.u: ..."``).

    Raises
    ------
    ModelError
        Non-positive period, bad size or shapes.
    SimulationError
        Non-finite input (the loop diverged).

    Notes
    -----
    Source: the PC-1000's zero-order-hold DAC, Sec. 5.3; block layout after
    Drake's ``ZeroOrderHold``.
    """

    def __init__(self, *, period_s: float, size: int = 1, initial_value=0.0,
                 offset_s: float = 0.0, name: str = "zoh") -> None:
        super().__init__(size=size, name=name)
        self.period_s = positive(period_s, what=f"{name}.period_s")
        self.offset_s = float(offset_s)
        self._x0 = self._initial(initial_value)
        self.reset()

    def reset(self) -> None:
        """Return to the initial state (held ``initial_value``, no sample taken)."""
        self._x = self._x0.copy()
        self.n_samples = 0

    @property
    def state(self) -> np.ndarray:
        """Held value ``x``, shape (size,) (a copy)."""
        return self._x.copy()

    def sample_time(self, n: int) -> float:
        """Instant of sample ``n`` [s]: ``offset_s + n * period_s``."""
        return self.offset_s + n * self.period_s

    def update(self, u) -> None:
        """Latch sample ``u[n]``, shape (size,): ``x <- u``."""
        self._x = self._input(u)
        self.n_samples += 1

    def output(self) -> np.ndarray:
        """Held value ``y = x``, shape (size,)."""
        return self._x.copy()


class SampleDelay(Block):
    """Zero-order hold followed by a pure delay of ``delay_periods`` sampling periods.

    Models the PC-1000 DAC, whose output changes ``D * dt`` after the sample
    instant (``D = 1.35``, Sec. 5.3). Write ``D = m + f`` with integer
    ``m = floor(D)`` and ``0 <= f < 1``. Samples ``u[n]`` enter at
    ``t_n = offset_s + n * dt``; the continuous-time output is piecewise
    constant::

        y(t) = u[j],  j = floor((t - offset_s) / dt - D)      (u[j<0] = initial_value)

    i.e. inside each period ``[t_n, t_{n+1})`` it is ``u[n-m-1]`` for the
    first ``f * dt`` and ``u[n-m]`` for the rest: one switch per period, at
    ``t_n + f * dt``. :meth:`output_at` returns this exact value at any
    (physics) time and :meth:`mean_over` its average over an interval.

    Discrete-time output (the average of ``y(t)`` over ``[t_n, t_{n+1})``,
    equal to linear interpolation between the two delayed samples)::

        y[n] = (1 - f) u[n-m] + f u[n-m-1]

    For integer ``D`` this is Drake's ``DiscreteTimeDelay``: ``y[n] = u[n-D]``.

    Parameters
    ----------
    period_s : float
        Sampling period ``dt`` [s].
    delay_periods : float
        Delay ``D >= 0`` in sampling periods (may be fractional; 1.35 for the PC-1000).
    initial_value : float or array_like, shape (size,)
        Output before the first delayed sample arrives.
    offset_s : float
        Time of sample 0 [s].
    size, name
        As :class:`vlab.lab.block.Block`: the number of channels and the name used in error messages.

    Raises
    ------
    ModelError
        Bad period, negative or non-finite delay, bad shapes.
    SimulationError
        Non-finite input; :meth:`output_at` asked for a time whose sample
        has not been pushed yet or has already left the buffer.

    Notes
    -----
    State: a buffer of the last ``m + 2`` samples. Switch instants are taken
    as right-continuous within ``1e-9 * dt`` so that a physics step landing
    on a switch (e.g. ``0.35 dt = 7 * dt/20``) sees the new value.
    """

    def __init__(self, *, period_s: float, delay_periods: float, size: int = 1,
                 initial_value=0.0, offset_s: float = 0.0, name: str = "delay") -> None:
        super().__init__(size=size, name=name)
        self.period_s = positive(period_s, what=f"{name}.period_s")
        d = float(delay_periods)
        if not math.isfinite(d) or d < 0.0:
            raise ModelError(f"{name}.delay_periods must be finite and >= 0, got {delay_periods!r}")
        if abs(d - round(d)) < _TIME_TOL:
            d = float(round(d))
        self.delay_periods = d
        self._m = int(math.floor(d))
        self._f = d - self._m
        self.offset_s = float(offset_s)
        self._x0 = self._initial(initial_value)
        self.reset()

    @property
    def delay_s(self) -> float:
        """Delay ``D * dt`` [s]."""
        return self.delay_periods * self.period_s

    def reset(self) -> None:
        """Fill the buffer with ``initial_value``; no sample pushed."""
        # _buf[i] = u[n - i], n = index of the newest sample (n = -1 before any update)
        self._buf = np.tile(self._x0, (self._m + 2, 1))
        self.n_samples = 0

    @property
    def state(self) -> np.ndarray:
        """Buffer ``[u[n], u[n-1], ..., u[n-m-1]]``, shape (m+2, size) (a copy)."""
        return self._buf.copy()

    def update(self, u) -> None:
        """Push sample ``u[n]``, shape (size,), taken at ``t_n``."""
        u = self._input(u)
        self._buf[1:] = self._buf[:-1]  # numpy buffers the overlapping copy
        self._buf[0] = u
        self.n_samples += 1

    def output(self) -> np.ndarray:
        """Discrete output ``y[n] = (1-f) u[n-m] + f u[n-m-1]``, shape (size,)."""
        return (1.0 - self._f) * self._buf[self._m] + self._f * self._buf[self._m + 1]

    def _sample_index(self, t_s: float) -> int:
        x = (float(t_s) - self.offset_s) / self.period_s - self.delay_periods
        return int(math.floor(x + _TIME_TOL))

    def _value(self, j: int, t_s: float) -> np.ndarray:
        newest = self.n_samples - 1
        if j > newest:
            raise SimulationError(
                f"{self.name}: output at t = {t_s!r} s needs sample {j}, but only samples "
                f"0..{newest} were pushed; call update() at each sample instant first")
        if j < 0:
            return self._x0.copy()
        i = newest - j
        if i >= self._buf.shape[0]:
            raise SimulationError(
                f"{self.name}: output at t = {t_s!r} s needs sample {j}, which has left the "
                f"buffer (newest sample {newest}); query times within the current period")
        return self._buf[i].copy()

    def output_at(self, t_s: float) -> np.ndarray:
        """Held-and-delayed output ``y(t)`` at time ``t_s`` [s], shape (size,).

        After pushing sample ``n`` it is defined for
        ``t_{n-1} + f * dt <= t_s < t_{n+1} + D * dt``, which includes the
        whole current period ``[t_n, t_{n+1})``.
        """
        return self._value(self._sample_index(t_s), t_s)

    def segments_over(self, t_start_s: float, t_end_s: float) -> list[tuple[float, np.ndarray]]:
        """The held pieces of ``y(t)`` over ``[t_start_s, t_end_s]``, in time order.

        Parameters
        ----------
        t_start_s, t_end_s : float
            Interval [s], within the times :meth:`output_at` accepts.

        Returns
        -------
        list of (float, ndarray of shape (size,))
            ``(duration [s], held value)`` for each constant piece; the
            durations sum to ``t_end_s - t_start_s`` (one piece of zero length
            for an empty interval). What :meth:`RCLowPass.update_segments`
            takes.

        Raises
        ------
        ModelError
            If ``t_end_s < t_start_s``.
        SimulationError
            If a needed sample was not pushed yet or has left the buffer.
        """
        t0, t1 = float(t_start_s), float(t_end_s)
        if t1 < t0:
            raise ModelError(f"{self.name}.segments_over: t_end_s {t1} < t_start_s {t0}")
        if t1 - t0 <= _TIME_TOL * self.period_s:
            return [(t1 - t0, self.output_at(t0))]
        j0 = self._sample_index(t0)
        # last sample whose hold interval starts strictly before t1
        x1 = (t1 - self.offset_s) / self.period_s - self.delay_periods
        j1 = max(j0, int(math.ceil(x1 - _TIME_TOL)) - 1)
        if j1 == j0:
            return [(t1 - t0, self._value(j0, t0))]
        out = []
        for j in range(j0, j1 + 1):
            a = t0 if j == j0 else self.offset_s + (j + self.delay_periods) * self.period_s
            b = t1 if j == j1 else self.offset_s + (j + 1 + self.delay_periods) * self.period_s
            if b > a:
                out.append((b - a, self._value(j, t0 if j == j0 else a)))
        return out

    def mean_over(self, t_start_s: float, t_end_s: float) -> np.ndarray:
        """Average of ``y(t)`` over ``[t_start_s, t_end_s]``, shape (size,).

        Gives a plant integrator the exact impulse of the switched signal over
        a physics step that contains a switch instant.
        """
        t0, t1 = float(t_start_s), float(t_end_s)
        if t1 < t0:
            raise ModelError(f"{self.name}.mean_over: t_end_s {t1} < t_start_s {t0}")
        segs = self.segments_over(t0, t1)
        if len(segs) == 1:
            return segs[0][1]
        return sum(d * v for d, v in segs) / (t1 - t0)


class RCLowPass(Block):
    """Single-stage passive RC low-pass, exact for a piecewise-constant input, with its step average.

    Continuous: ``tau * dy/dt = u - y`` with ``tau = 1 / (2 pi f_c)``. Over a
    piece of duration ``d`` on which ``u`` is constant, starting from ``y0``::

        y(s)            = u + (y0 - u) exp(-s / tau),                      0 <= s <= d
        y_end           = u + (y0 - u) e,            e = exp(-d / tau)
        int_0^d y(s) ds = u d + (y0 - u) tau (1 - e)

    :meth:`update_segments` chains these over the pieces of one physics step
    (e.g. the DAC staircase with a switch inside the step,
    :meth:`SampleDelay.segments_over`) and keeps the end value (the state)
    and the step average ``mean = (sum of the integrals) / (sum of d)``.
    For ``u`` held over a whole step ``h`` (:meth:`update`) this is::

        y[k+1]   = a y[k] + (1 - a) u[k],                    a = exp(-2 pi f_c h)
        ybar[k]  = u[k] + (y[k] - u[k]) (1 - a) tau / h      (average over the step)

    both exact (step response ``y[k] = 1 - a**k = 1 - exp(-t_k / tau)``).

    Parameters
    ----------
    step_s : float
        Integration step ``h`` [s] (the physics step, e.g. 0.5 ms / 10) used by :meth:`update`.
    corner_hz : float
        Corner frequency ``f_c`` [Hz]; 677 Hz in the laboratory (Sec. 5.3).
    initial_value : float or array_like, shape (size,)
        Initial capacitor voltage ``y[0]``.
    size, name
        As :class:`vlab.lab.block.Block`: the number of channels and the name used in error messages.

    Raises
    ------
    ModelError
        Non-positive step or corner frequency, bad shapes, a negative or
        non-finite piece duration.
    SimulationError
        Non-finite input.

    Notes
    -----
    A plant holds a force constant over its physics step, so the value to
    apply over ``[t_k, t_k + h)`` is the step average :meth:`mean` after
    ``update_segments(dac.segments_over(t_k, t_k + h))``: it carries the
    filter's exact impulse over the step, where the end-of-step value
    :meth:`output` would lead the continuous filter by ``h / 2``. Source:
    the 677 Hz RC smoothing filters of Sec. 5.3 (Fig. 21).
    """

    def __init__(self, *, step_s: float, corner_hz: float = RC_CORNER_HZ, size: int = 1,
                 initial_value=0.0, name: str = "rc") -> None:
        super().__init__(size=size, name=name)
        self.step_s = positive(step_s, what=f"{name}.step_s")
        self.corner_hz = positive(corner_hz, what=f"{name}.corner_hz")
        self.a = math.exp(-2.0 * math.pi * self.corner_hz * self.step_s)
        self._x0 = self._initial(initial_value)
        self.reset()

    @property
    def time_constant_s(self) -> float:
        """``tau = RC = 1 / (2 pi f_c)`` [s]."""
        return 1.0 / (2.0 * math.pi * self.corner_hz)

    def reset(self) -> None:
        """Return to ``y = initial_value`` (and a step average equal to it)."""
        self._y = self._x0.copy()
        self._mean = self._x0.copy()

    @property
    def state(self) -> np.ndarray:
        """Filter output ``y[k]``, shape (size,) (a copy)."""
        return self._y.copy()

    def update(self, u) -> None:
        """Advance one step ``step_s`` with ``u`` (shape (size,)) held: ``y <- a y + (1-a) u``.

        Also sets :meth:`mean` to ``u + (y - u) (1 - a) tau / h``.
        """
        u = self._input(u)
        dy = self._y - u
        self._mean = u + dy * ((1.0 - self.a) * self.time_constant_s / self.step_s)
        self._y = u + self.a * dy

    def update_segments(self, segments) -> None:
        """Advance over consecutive pieces of constant input and keep their average.

        Parameters
        ----------
        segments : sequence of (float, array_like of shape (size,))
            ``(duration [s], input held over it)`` in time order, e.g.
            :meth:`SampleDelay.segments_over` of one physics step; durations
            >= 0, not all zero.

        Raises
        ------
        ModelError
            A negative or non-finite duration, or a total duration of zero.
        SimulationError
            Non-finite input.
        """
        tau = self.time_constant_s
        y = self._y
        acc = np.zeros(self.size)
        total = 0.0
        for d, u in segments:
            d = float(d)
            if not (d >= 0.0 and math.isfinite(d)):
                raise ModelError(f"{self.name}.update_segments: duration must be finite and >= 0 s, got {d!r}")
            u = self._input(u)
            e = math.exp(-d / tau)
            dy = y - u
            acc += u * d + dy * (tau * (1.0 - e))
            y = u + dy * e
            total += d
        if total <= 0.0:
            raise ModelError(f"{self.name}.update_segments: the pieces have no duration ({list(segments)!r})")
        self._y = y
        self._mean = acc / total

    def output(self) -> np.ndarray:
        """Filter output ``y[k]`` at the end of the last step, shape (size,)."""
        return self._y.copy()

    def mean(self) -> np.ndarray:
        """Average of the filter output over the last step, shape (size,): the value a plant holds over it."""
        return self._mean.copy()


class CurrentAmplifier(Block):
    """Controlled-current power amplifier driving the force coils (memoryless).

    ::

        y = clip(gain * u, -limit, +limit)

    The current is controlled, so the coil's back-EMF does not change the
    force (Sec. 5.2). vlab's controllers output force commands in [N], so the
    default ``gain = 1`` makes the amplifier transparent; a physical
    amplifier + coil has ``gain = g_amp [A/V] * k_f [N/A]``.

    Parameters
    ----------
    gain : float or array_like, shape (size,)
        Output per unit input (e.g. [N/N] or [A/V]).
    limit : float or array_like, shape (size,), optional
        Saturation level (> 0) in output units; ``None`` for a linear amplifier.
    size, name
        As :class:`vlab.lab.block.Block`: the number of channels and the name used in error messages.

    Attributes
    ----------
    saturation_count : int
        Number of channel-samples clipped since the last :meth:`reset`.

    Raises
    ------
    ModelError
        Non-finite gain, non-positive limit, bad shapes.
    SimulationError
        Non-finite input.
    """

    def __init__(self, *, gain=1.0, limit=None, size: int = 1, name: str = "amp") -> None:
        super().__init__(size=size, name=name)
        self.gain = self._initial(gain, what="gain")
        if limit is None:
            self.limit = None
        else:
            lim = self._initial(limit, what="limit")
            if np.any(lim <= 0):
                raise ModelError(f"{name}.limit must be > 0, got {lim}")
            self.limit = lim
        self.reset()

    def reset(self) -> None:
        """Clear :attr:`saturation_count`."""
        self.saturation_count = 0

    def output(self, u) -> np.ndarray:
        """Amplified (and possibly clipped) output for input ``u``, shape (size,)."""
        y = self.gain * self._input(u)
        if self.limit is not None:
            clipped = np.abs(y) > self.limit
            self.saturation_count += int(np.count_nonzero(clipped))
            y = np.clip(y, -self.limit, self.limit)
        return y


class SensorNoise(Block):
    """Additive white Gaussian measurement noise on the velocity sensors.

    ::

        y[n] = u[n] + sigma * w[n],     w[n] ~ N(0, I) independent

    MuJoCo does not apply sensor noise (its ``noise`` attribute is not simulated), so the lab adds it here.
    The sequence is fully determined by ``seed``.

    Parameters
    ----------
    sigma_m_s : float or array_like, shape (size,)
        Standard deviation [m/s] per channel, >= 0.
    seed : int or numpy.random.Generator
        Seed of (or) the generator; required so runs are reproducible.
    size, name
        As :class:`vlab.lab.block.Block`: the number of channels and the name used in error messages.

    Raises
    ------
    ModelError
        Negative or non-finite sigma, a seed that is neither int nor Generator.
    SimulationError
        Non-finite input.

    Notes
    -----
    Source: Sec. 5.1 (radio-frequency and 60 Hz pick-up on the coil leads);
    only the broadband part is modelled here.
    """

    def __init__(self, *, sigma_m_s, seed, size: int = 1, name: str = "noise") -> None:
        super().__init__(size=size, name=name)
        sig = self._initial(sigma_m_s, what="sigma_m_s")
        if np.any(sig < 0):
            raise ModelError(f"{name}.sigma_m_s must be >= 0, got {sig}")
        self.sigma_m_s = sig
        if isinstance(seed, np.random.Generator):
            self._seed = seed
        elif isinstance(seed, (int, np.integer)) and not isinstance(seed, bool):
            self._seed = int(seed)
        else:
            raise ModelError(f"{name}.seed must be an int or numpy.random.Generator, got {seed!r}")
        self.reset()

    def reset(self) -> None:
        """Restart the noise sequence (only reproducible for an int seed)."""
        self._rng = self._seed if isinstance(self._seed, np.random.Generator) \
            else np.random.default_rng(self._seed)

    def output(self, u) -> np.ndarray:
        """Noisy measurement ``u + sigma * w``, shape (size,); draws a new ``w``."""
        return self._input(u) + self.sigma_m_s * self._rng.standard_normal(self.size)
