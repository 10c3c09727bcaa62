"""Excitation signals: a periodic multisine and a band-limited plain random force.

Both are generated at the signal generator's own rate and held between its
samples (a DAC's zero-order hold). This module never imports vlab.
"""

from __future__ import annotations

import numpy as np
import scipy.signal


def multisine(period_s: float, rate_hz: float, band_hz, rms_n: float,
              rng: np.random.Generator) -> np.ndarray:
    """One period of a flat-spectrum multisine with random phases.

    Parameters
    ----------
    period_s : float
        Period T [s]; the lines are at multiples of 1/T.
    rate_hz : float
        Generator rate [Hz]; T * rate must be an integer.
    band_hz : (float, float)
        Lowest and highest excited line [Hz].
    rms_n : float
        RMS of the force [N].
    rng : numpy.random.Generator
        Source of the random phases (Pintelon & Schoukens, *System
        Identification*, 2012, Sec. 2.3: random-phase multisine).

    Returns
    -------
    ndarray, shape (n,)
        Force samples [N] of one period, n = T * rate.

    Raises
    ------
    ValueError
        A period that is not a whole number of samples, or an empty band.
    """
    n = round(period_s * rate_hz)
    if abs(n - period_s * rate_hz) > 1e-9 * n or n < 4:
        raise ValueError(f"period {period_s} s is not a whole number of samples at {rate_hz} Hz")
    lines = np.arange(1, n // 2)
    f = lines / period_s
    sel = lines[(f >= band_hz[0]) & (f <= band_hz[1])]
    if sel.size == 0:
        raise ValueError(f"no line of a {period_s} s period in the band {band_hz} Hz")
    spec = np.zeros(n // 2 + 1, complex)
    spec[sel] = np.exp(2j * np.pi * rng.random(sel.size))
    x = np.fft.irfft(spec, n)
    return x * rms_n / np.sqrt(np.mean(x**2))


def plain_random(duration_s: float, rate_hz: float, band_hz, rms_n: float,
                 rng: np.random.Generator) -> np.ndarray:
    """Gaussian noise band-limited by a 4th-order Butterworth band-pass.

    Parameters
    ----------
    duration_s : float
        Length [s].
    rate_hz : float
        Generator rate [Hz].
    band_hz : (float, float)
        Pass band [Hz].
    rms_n : float
        RMS of the force [N].
    rng : numpy.random.Generator

    Returns
    -------
    ndarray, shape (round(duration * rate),)
        Force samples [N].
    """
    n = round(duration_s * rate_hz)
    sos = scipy.signal.butter(4, band_hz, btype="bandpass", fs=rate_hz, output="sos")
    x = scipy.signal.sosfilt(sos, rng.standard_normal(n + 4 * round(rate_hz)))[-n:]
    return x * rms_n / np.sqrt(np.mean(x**2))


def hold(x: np.ndarray, factor: int) -> np.ndarray:
    """Zero-order hold of generator samples onto a grid ``factor`` times finer.

    Parameters
    ----------
    x : ndarray, shape (n,)
    factor : int

    Returns
    -------
    ndarray, shape (n * factor,)
    """
    return np.repeat(np.asarray(x, float), int(factor))
