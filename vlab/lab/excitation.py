"""Excitation signals of the modal and control tests (Sec. 5.4.1).

The STI-11/23 system drove one actuator with a broadband pseudo-random
signal (0-10 Hz on the grid; 0-25 Hz is used for the BCC) or an incremental
sine sweep that could be focused on narrow bands; impulse (hammer-like)
excitation is added for decay measurements. Every function returns the
sampled force [N] on a given time grid ``t_s`` [s] (shape (n,)); random
signals are fully determined by ``seed``.

For leakage-free FRFs use :func:`pseudo_random` with ``resolution_hz`` equal
to the analysis resolution and a record holding whole periods: each analysis
block then contains exactly one period of every line (see
:func:`vlab.measure.frf.h1`, ``window="boxcar"``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from scipy import signal

from ..errors import ModelError
from .block import positive

_UNIFORM_RTOL = 1e-9


def time_grid(*, dt_s: float, duration_s: float) -> np.ndarray:
    """Sample instants ``k * dt_s`` for ``k = 0 .. round(duration_s / dt_s) - 1`` [s].

    Raises
    ------
    ModelError
        Non-positive ``dt_s`` or ``duration_s < dt_s``.
    """
    dt = positive(dt_s, what="dt_s")
    dur = positive(duration_s, what="duration_s")
    n = int(round(dur / dt))
    if n < 1:
        raise ModelError(f"duration_s={duration_s} is shorter than one step dt_s={dt_s}")
    return np.arange(n) * dt


def _time(t_s, *, uniform: bool = False) -> tuple[np.ndarray, float | None]:
    """Validate a time grid; return it and its step if uniform (``None`` otherwise)."""
    t = np.asarray(t_s, dtype=float)
    if t.ndim != 1 or t.size < 1:
        raise ModelError(f"t_s must be a non-empty 1-D array of times [s], got shape {t.shape}")
    if not np.all(np.isfinite(t)):
        raise ModelError("t_s contains non-finite times")
    if t.size == 1:
        if uniform:
            raise ModelError("t_s needs at least two samples for a uniformly sampled signal")
        return t, None
    d = np.diff(t)
    if np.any(d <= 0):
        raise ModelError("t_s must be strictly increasing")
    dt = float(d.mean())
    is_uniform = bool(np.all(np.abs(d - dt) <= 1e-6 * dt))
    if uniform and not is_uniform:
        raise ModelError("t_s must be uniformly spaced for this signal")
    return t, (dt if is_uniform else None)


def _below_nyquist(f_top_hz: float, dt: float) -> None:
    """Refuse a band whose upper edge ``f_top_hz`` [Hz] reaches the Nyquist frequency ``0.5 / dt``."""
    if f_top_hz >= 0.5 / dt:
        raise ModelError(f"band_hz upper edge {f_top_hz} Hz reaches the Nyquist frequency {0.5 / dt} Hz")


def _band(band_hz, what: str = "band_hz") -> tuple[float, float]:
    try:
        lo, hi = (float(b) for b in band_hz)
    except (TypeError, ValueError):
        raise ModelError(f"{what} must be a pair (f_low_hz, f_high_hz), got {band_hz!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi)) or lo < 0 or hi <= lo:
        raise ModelError(f"{what} must satisfy 0 <= f_low < f_high, got {band_hz!r}")
    return lo, hi


def _rng(seed) -> np.random.Generator:
    if isinstance(seed, np.random.Generator):
        return seed
    if isinstance(seed, (int, np.integer)) and not isinstance(seed, bool):
        return np.random.default_rng(int(seed))
    raise ModelError(f"seed must be an int or numpy.random.Generator, got {seed!r}")


def multisine_lines_hz(band_hz: tuple[float, float], resolution_hz: float) -> np.ndarray:
    """Frequencies [Hz] of the lines of :func:`pseudo_random`: multiples ``k * df`` in the band, ``k >= 1``.

    Parameters
    ----------
    band_hz : (float, float)
        Band [Hz], edges included.
    resolution_hz : float
        Line spacing ``df`` [Hz].

    Returns
    -------
    ndarray, shape (n_lines,)

    Raises
    ------
    ModelError
        Bad band or resolution, or no line in the band.
    """
    lo, hi = _band(band_hz)
    df = positive(resolution_hz, what="resolution_hz")
    k0 = max(1, math.ceil(lo / df - 1e-9))
    k1 = math.floor(hi / df + 1e-9)
    if k1 < k0:
        raise ModelError(f"no multiple of resolution_hz={df} lies in band_hz={band_hz}")
    return np.arange(k0, k1 + 1) * df


def pseudo_random(t_s, *, band_hz: tuple[float, float], resolution_hz: float, rms_n: float,
                  seed=None, phases: str = "random") -> np.ndarray:
    """Band-limited periodic pseudo-random force (a multisine).

    ::

        f(t) = A * sum_k cos(2 pi k df t + phi_k),   k df in band_hz, k >= 1
        A    = rms_n * sqrt(2 / K)                   (K lines: RMS over a period = rms_n)

    The period is ``1 / resolution_hz``: a record of whole periods analysed
    with blocks of one period gives an FRF at exactly these lines, free of
    leakage.

    Parameters
    ----------
    t_s : array_like, shape (n,)
        Sample instants [s]. Any increasing grid; a uniform grid whose step
        divides the period (the usual case) is evaluated by one inverse FFT.
    band_hz : (float, float)
        Excited band [Hz], e.g. (0, 25) for the BCC, (0, 10) for the grid.
    resolution_hz : float
        Line spacing ``df`` [Hz] = 1 / period.
    rms_n : float
        RMS force over one period [N].
    seed : int or numpy.random.Generator
        Required for ``phases="random"``.
    phases : {"random", "schroeder"}
        Uniform random phases, or Schroeder's low-crest-factor phases
        ``phi_k = -pi k (k - 1) / K`` (deterministic).

    Returns
    -------
    ndarray, shape (n,)
        The multisine force [N] at each instant of ``t_s``.

    Raises
    ------
    ModelError
        Bad band, resolution, RMS, seed or phases; a band reaching the
        Nyquist frequency of a uniform grid.

    Notes
    -----
    Source: Sec. 5.4.1 ("broadband pseudo-random function"); multisine design
    after Pintelon & Schoukens, *System Identification*, ch. 2; Schroeder,
    IEEE Trans. Inf. Theory 16 (1970) 85-89.
    """
    t, dt = _time(t_s)
    lines = multisine_lines_hz(band_hz, resolution_hz)
    df = float(resolution_hz)
    rms = positive(rms_n, what="rms_n")
    K = lines.size
    if phases == "random":
        if seed is None:
            raise ModelError("pseudo_random with phases='random' needs a seed")
        phi = _rng(seed).uniform(0.0, 2.0 * np.pi, K)
    elif phases == "schroeder":
        k = np.arange(1, K + 1)
        phi = -np.pi * k * (k - 1) / K
    else:
        raise ModelError(f"phases must be 'random' or 'schroeder', got {phases!r}")
    amp = rms * math.sqrt(2.0 / K)
    if dt is not None:
        _below_nyquist(lines[-1], dt)
        n_per = round(1.0 / (df * dt))
        n0 = t[0] / dt
        if (abs(n_per * df * dt - 1.0) < _UNIFORM_RTOL and abs(n0 - round(n0)) < 1e-6):
            spec = np.zeros(n_per // 2 + 1, dtype=complex)
            k_idx = np.rint(lines / df).astype(int)
            spec[k_idx] = 0.5 * n_per * amp * np.exp(1j * phi)
            period = np.fft.irfft(spec, n_per)
            idx = (round(n0) + np.arange(t.size)) % n_per
            return period[idx]
    out = np.empty(t.size)
    w = 2.0 * np.pi * lines
    for s in range(0, t.size, 4096):
        tt = t[s:s + 4096, None]
        out[s:s + 4096] = amp * np.cos(tt * w + phi).sum(axis=1)
    return out


def filtered_random(t_s, *, band_hz: tuple[float, float], rms_n: float, seed,
                    order: int = 8) -> np.ndarray:
    """Gaussian white noise through a Butterworth filter, scaled to ``rms_n`` over the record.

    A low-pass filter when ``band_hz[0] == 0``, band-pass otherwise.

    Parameters
    ----------
    t_s : array_like, shape (n,)
        Uniformly spaced sample instants [s].
    band_hz : (float, float)
        Pass band [Hz]; the upper edge must lie below the Nyquist frequency.
    rms_n : float
        RMS force over the record [N].
    seed : int or numpy.random.Generator
        Random seed.
    order : int
        Butterworth order (even for a band-pass; per edge).

    Returns
    -------
    ndarray, shape (n,)
        The filtered-noise force [N], of RMS ``rms_n`` over the record.

    Raises
    ------
    ModelError
        Non-uniform grid, bad band/RMS/seed/order.

    Notes
    -----
    Not periodic: analyse with a Hann window and overlap (Bendat & Piersol,
    *Random Data*, 4th ed., Sec. 11.5).
    """
    t, dt = _time(t_s, uniform=True)
    lo, hi = _band(band_hz)
    rms = positive(rms_n, what="rms_n")
    if isinstance(order, bool) or int(order) != order or order < 1:
        raise ModelError(f"order must be a positive integer, got {order!r}")
    _below_nyquist(hi, dt)
    fs = 1.0 / dt
    if lo == 0:
        sos = signal.butter(int(order), hi, btype="lowpass", fs=fs, output="sos")
    else:
        sos = signal.butter(int(order), (lo, hi), btype="bandpass", fs=fs, output="sos")
    x = signal.sosfilt(sos, _rng(seed).standard_normal(t.size))
    return x * (rms / np.sqrt(np.mean(x**2)))


def sine_sweep(t_s, *, f_start_hz: float, f_stop_hz: float, amplitude_n: float,
               method: str = "linear") -> np.ndarray:
    """Continuous sine sweep (chirp) from ``f_start_hz`` at ``t_s[0]`` to ``f_stop_hz`` at ``t_s[-1]``.

    ``f(t) = amplitude_n * cos(phi(t))`` with instantaneous frequency varying
    linearly or logarithmically (:func:`scipy.signal.chirp`).

    Parameters
    ----------
    t_s : array_like, shape (n,)
        Sample instants [s], at least two.
    f_start_hz, f_stop_hz : float
        Start and stop frequencies [Hz] (> 0 for ``method="logarithmic"``).
    amplitude_n : float
        Force amplitude [N].
    method : {"linear", "logarithmic"}
        Frequency law.

    Returns
    -------
    ndarray, shape (n,)
        The swept force [N] at each instant of ``t_s``.

    Raises
    ------
    ModelError
        Bad frequencies, amplitude or method.
    """
    t, _ = _time(t_s)
    if t.size < 2:
        raise ModelError("sine_sweep needs at least two time samples")
    amp = positive(amplitude_n, what="amplitude_n")
    f0, f1 = float(f_start_hz), float(f_stop_hz)
    if method not in ("linear", "logarithmic"):
        raise ModelError(f"method must be 'linear' or 'logarithmic', got {method!r}")
    if not (math.isfinite(f0) and math.isfinite(f1)) or f0 < 0 or f1 < 0 or \
            (method == "logarithmic" and min(f0, f1) <= 0):
        raise ModelError(f"bad sweep frequencies f_start_hz={f_start_hz}, f_stop_hz={f_stop_hz}")
    tt = t - t[0]
    return amp * signal.chirp(tt, f0=f0, t1=tt[-1], f1=f1, method=method)


def stepped_sine(t_s, *, freqs_hz: Sequence[float], dwell_s: float, amplitude_n: float,
                 start_s: float | None = None) -> np.ndarray:
    """Incremental (stepped) sine sweep: a sine dwell at each frequency in turn.

    Dwell ``i`` occupies ``[start + i * dwell_s, start + (i+1) * dwell_s)``
    at frequency ``freqs_hz[i]``; the phase is continuous across the steps so
    the force has no jumps::

        f(t) = amplitude_n * sin(phi(t)),   dphi/dt = 2 pi freqs_hz[i]  in dwell i

    After the last dwell the force is zero (as it is before ``start``).

    Parameters
    ----------
    t_s : array_like, shape (n,)
        Sample instants [s].
    freqs_hz : sequence of float, shape (n_steps,)
        Dwell frequencies [Hz], > 0.
    dwell_s : float
        Length of each dwell [s]; allow several time constants
        ``1 / (zeta * omega)`` for the response to settle before analysing.
    amplitude_n : float
        Force amplitude [N].
    start_s : float, optional
        Start of the first dwell; ``t_s[0]`` by default.

    Returns
    -------
    ndarray, shape (n,)
        The stepped-sine force [N]; zero before ``start_s`` and after the last dwell.

    Raises
    ------
    ModelError
        Bad frequencies, dwell or amplitude.

    Notes
    -----
    Source: Sec. 5.4.1 ("incremental sine sweep ... focused on narrower
    frequency bands"); Ewins, *Modal Testing*, 2nd ed., Sec. 3.7.
    """
    t, _ = _time(t_s)
    f = np.asarray(freqs_hz, dtype=float)
    if f.ndim != 1 or f.size < 1 or not np.all(np.isfinite(f)) or np.any(f <= 0):
        raise ModelError(f"freqs_hz must be a non-empty 1-D array of positive frequencies, got {freqs_hz!r}")
    dwell = positive(dwell_s, what="dwell_s")
    amp = positive(amplitude_n, what="amplitude_n")
    t0 = float(t[0] if start_s is None else start_s)
    tau = t - t0
    i = np.floor(tau / dwell).astype(int)
    active = (i >= 0) & (i < f.size)
    ic = np.clip(i, 0, f.size - 1)
    # phase at the start of each dwell (continuous)
    phase0 = np.concatenate(([0.0], np.cumsum(2 * np.pi * f * dwell)))[:-1]
    phase = phase0[ic] + 2 * np.pi * f[ic] * (tau - ic * dwell)
    return np.where(active, amp * np.sin(phase), 0.0)


def _finite_peak(peak_n: float, start_s: float) -> float:
    """``peak_n`` as a float, after checking it and the pulse start ``start_s`` are finite."""
    p = float(peak_n)
    if not math.isfinite(p) or not math.isfinite(float(start_s)):
        raise ModelError(f"peak_n and start_s must be finite, got {peak_n!r}, {start_s!r}")
    return p


def _half_sine(tau: np.ndarray, inside: np.ndarray, peak_n: float, duration_s: float) -> np.ndarray:
    """``peak_n * sin(pi tau / duration_s)`` where ``inside``, 0 elsewhere (``tau`` [s] from the pulse's start)."""
    return np.where(inside, peak_n * np.sin(np.pi * np.clip(tau, 0, duration_s) / duration_s), 0.0)


def half_sine_pulse(t_s, *, peak_n: float, duration_s: float, start_s: float = 0.0) -> np.ndarray:
    """Half-sine force pulse (an idealised impact).

    ::

        f(t) = peak_n * sin(pi (t - start_s) / duration_s)   for start_s <= t <= start_s + duration_s
        f(t) = 0                                             otherwise

    Its impulse is ``2 peak_n duration_s / pi`` [N s]; its spectrum is
    nearly flat below ``~0.5 / duration_s`` and has its first zero at
    ``1.5 / duration_s`` [Hz].

    Parameters
    ----------
    t_s : array_like, shape (n,)
        Sample instants [s]; resolve the pulse with several samples.
    peak_n : float
        Peak force [N] (may be negative).
    duration_s : float
        Pulse length [s].
    start_s : float
        Pulse start [s].

    Returns
    -------
    ndarray, shape (n,)
        The pulse force [N]; zero outside the pulse.

    Raises
    ------
    ModelError
        Non-positive duration or non-finite values.

    Notes
    -----
    Source: Ewins, *Modal Testing*, 2nd ed., Sec. 3.9 (impact excitation).
    """
    t, _ = _time(t_s)
    dur = positive(duration_s, what="duration_s")
    p = _finite_peak(peak_n, start_s)
    tau = t - float(start_s)
    return _half_sine(tau, (tau >= 0) & (tau <= dur), p, dur)


def periodic_chirp(t_s, *, band_hz: tuple[float, float], period_s: float, amplitude_n: float) -> np.ndarray:
    """Linear sine sweep repeated every ``period_s`` (a periodic chirp).

    ::

        f(t) = amplitude_n * cos(2 pi (f0 tau + (f1 - f0) tau^2 / (2 P))),   tau = t mod P

    with ``(f0, f1) = band_hz`` and ``P = period_s``. The force repeats exactly
    every record of ``P`` seconds, so once the response has settled each
    record is one period of a periodic steady state: an H1 estimate with a
    rectangular window over blocks of ``P`` seconds is free of leakage at the
    lines ``k / P`` (like :func:`pseudo_random`), which a single sweep across
    the whole run is not (its transient tails and its spectrum, spread over
    the run, bias the lightly damped peaks).

    Parameters
    ----------
    t_s : array_like, shape (n,)
        Sample instants [s].
    band_hz : (float, float)
        Start and stop frequencies of each sweep [Hz].
    period_s : float
        Sweep (and record) length [s], ``1 / resolution_hz``.
    amplitude_n : float
        Force amplitude [N].

    Returns
    -------
    ndarray, shape (n,)
        The periodic-chirp force [N], of period ``period_s``.

    Raises
    ------
    ModelError
        Bad band, period or amplitude.

    Notes
    -----
    Source: Sec. 5.4.1 (sine sweep); periodic chirp after Pintelon &
    Schoukens, *System Identification*, 2nd ed., Sec. 2.4 (periodic
    excitations and leakage-free FRF measurement).
    """
    t, _ = _time(t_s)
    f0, f1 = _band(band_hz)
    period = positive(period_s, what="period_s")
    amp = positive(amplitude_n, what="amplitude_n")
    tau = np.mod(t, period)
    return amp * np.cos(2.0 * np.pi * (f0 * tau + 0.5 * (f1 - f0) * tau**2 / period))


def pulse_train(t_s, *, peak_n: float, duration_s: float, period_s: float, start_s: float = 0.0) -> np.ndarray:
    """Half-sine pulses (:func:`half_sine_pulse`) repeated every ``period_s`` (repeated impacts).

    ::

        f(t) = peak_n * sin(pi tau / duration_s)   for 0 <= tau <= duration_s,  tau = (t - start_s) mod P
        f(t) = 0                                   otherwise

    One pulse per record of ``P = period_s`` seconds: after the response has
    settled every record is one period of a periodic steady state, so H1
    with a rectangular window over blocks of ``P`` is exact at the lines
    ``k / P`` even when the free decay of a lightly damped mode outlasts one
    record (the tail of the previous impact is part of the steady state).

    Parameters
    ----------
    t_s : array_like, shape (n,)
        Sample instants [s].
    peak_n : float
        Peak force [N] (may be negative).
    duration_s : float
        Pulse length [s]; the spectrum of one pulse is nearly flat below
        ``~0.5 / duration_s`` and has its first zero at ``1.5 / duration_s`` [Hz].
    period_s : float
        Repetition period [s], at least ``duration_s``.
    start_s : float
        Start of the first pulse [s].

    Returns
    -------
    ndarray, shape (n,)
        The pulse-train force [N]; zero between the pulses.

    Raises
    ------
    ModelError
        Non-positive duration or period, a period shorter than the pulse,
        non-finite values.

    Notes
    -----
    Source: Ewins, *Modal Testing*, 2nd ed., Sec. 3.9 (impact excitation);
    Sec. 5.4.1 of the dissertation (decay measurements).
    """
    t, _ = _time(t_s)
    dur = positive(duration_s, what="duration_s")
    period = positive(period_s, what="period_s")
    if period < dur:
        raise ModelError(f"period_s={period_s} is shorter than the pulse duration_s={duration_s}")
    p = _finite_peak(peak_n, start_s)
    tau = np.mod(t - float(start_s), period)
    return _half_sine(tau, (t >= float(start_s)) & (tau <= dur), p, dur)
