"""Damping of a single-mode free decay (impulse runs): :func:`decay_damping`.

The logarithmic decrement comes from the Hilbert envelope: straight lines
fitted to the log envelope and to the unwrapped phase of the analytic
signal give the decay rate and the damped frequency.

Sources: Ewins, *Modal Testing*, 2nd ed. (2000), Sec. 4.7 (free decay);
Feldman, *Hilbert Transform Applications in Mechanical Vibration* (2011), ch. 3.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import signal

from ..errors import MeasurementError


@dataclass(frozen=True)
class DecayFit:
    """Damping of a free decay.

    Attributes
    ----------
    freq_hz : float
        Undamped natural frequency ``sqrt(omega_d^2 + sigma^2) / 2 pi`` [Hz].
    damping_ratio : float
        ``zeta = sigma / omega_n`` [-].
    log_decrement : float
        ``delta = sigma T_d = 2 pi sigma / omega_d`` [-].
    decay_rate : float
        ``sigma`` [1/s] (envelope ``~ exp(-sigma t)``).
    window_s : (float, float)
        Time window fitted [s].
    """

    freq_hz: float
    damping_ratio: float
    log_decrement: float
    decay_rate: float
    window_s: tuple[float, float]


def decay_damping(y, *, dt_s: float, band_hz: tuple[float, float] | None = None,
                  start_s: float | None = None, stop_s: float | None = None,
                  min_level: float = 0.05, name: str = "signal") -> DecayFit:
    """Damping ratio of a single-mode free decay (logarithmic decrement via the Hilbert envelope).

    The analytic signal ``y + i H[y]`` gives the envelope ``A(t)`` and the
    phase ``phi(t)``. Straight lines fitted by least squares to
    ``ln A(t) = c - sigma t`` and ``phi(t) = omega_d t + phi_0`` give::

        delta = 2 pi sigma / omega_d,   zeta = sigma / sqrt(sigma^2 + omega_d^2)

    Parameters
    ----------
    y : array_like, shape (n_samples,)
        Response after an impulse, e.g. velocity [m/s].
    dt_s : float
        Sampling interval [s].
    band_hz : (float, float), optional
        Isolate one mode with a zero-phase 4th-order Butterworth band-pass
        first (:func:`scipy.signal.sosfiltfilt`).
    start_s, stop_s : float, optional
        Fit window [s]. Default: from the envelope maximum to where the
        envelope falls below ``min_level`` times that maximum, and never in
        the last 5 % of the record (Hilbert end effects).
    min_level : float
        Relative envelope level that ends the default window (above the noise).
    name : str
        Channel name for messages.

    Returns
    -------
    DecayFit

    Raises
    ------
    MeasurementError
        Non-finite samples, a window shorter than two cycles or 16 samples,
        a non-decaying envelope.

    Notes
    -----
    Source: Ewins, *Modal Testing*, 2nd ed., Sec. 4.7 (free decay); Feldman,
    *Hilbert Transform Applications in Mechanical Vibration* (2011), ch. 3.
    """
    ya = np.asarray(y, dtype=float)
    if ya.ndim != 1 or ya.size < 16:
        raise MeasurementError(f"{name}: need a 1-D record of at least 16 samples, got shape {ya.shape}")
    if not np.all(np.isfinite(ya)):
        raise MeasurementError(f"{name}: non-finite samples")
    if not dt_s > 0:
        raise MeasurementError(f"{name}: dt_s must be > 0, got {dt_s}")
    fs = 1.0 / dt_s
    if band_hz is not None:
        lo, hi = band_hz
        if not 0 < lo < hi < fs / 2:
            raise MeasurementError(f"{name}: band_hz must satisfy 0 < low < high < {fs / 2} Hz, got {band_hz}")
        sos = signal.butter(4, (lo, hi), btype="bandpass", fs=fs, output="sos")
        ya = signal.sosfiltfilt(sos, ya)
    z = signal.hilbert(ya)
    env = np.abs(z)
    n = ya.size
    n_end = n - max(1, int(0.05 * n))
    i0 = int(np.argmax(env[:n_end])) if start_s is None else int(round(start_s / dt_s))
    if not 0 <= i0 < n_end:
        raise MeasurementError(f"{name}: start_s={start_s} outside the usable record")
    if stop_s is None:
        below = np.flatnonzero(env[i0:n_end] < min_level * env[i0])
        i1 = i0 + int(below[0]) if below.size else n_end
    else:
        i1 = min(int(round(stop_s / dt_s)), n)
    if i1 - i0 < 16:
        raise MeasurementError(f"{name}: decay window of {i1 - i0} samples is too short")
    t = np.arange(i0, i1) * dt_s
    slope, _ = np.polyfit(t, np.log(np.maximum(env[i0:i1], 1e-300)), 1)
    sigma = -slope
    phase = np.unwrap(np.angle(z[i0:i1]))
    wd = abs(np.polyfit(t, phase, 1)[0])
    if wd * (t[-1] - t[0]) < 4 * np.pi:
        raise MeasurementError(f"{name}: decay window holds fewer than two cycles")
    if sigma <= 0:
        raise MeasurementError(f"{name}: the envelope does not decay (sigma = {sigma:.3g} 1/s)")
    wn = math.hypot(wd, sigma)
    return DecayFit(freq_hz=wn / (2 * np.pi), damping_ratio=sigma / wn,
                    log_decrement=2 * np.pi * sigma / wd, decay_rate=float(sigma),
                    window_s=(float(t[0]), float(t[-1])))
