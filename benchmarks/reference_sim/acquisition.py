"""A laboratory acquisition front end: anti-alias filter, sampling, noise, 16-bit ADC.

The analog anti-alias filter is an 8-pole Butterworth low-pass at 0.4 times the
sampling rate, modelled digitally on the simulator's fine grid (bilinear transform
with the corner pre-warped; at 40 kHz its response is within 0.1 dB of the analog
filter's below 2.5 kHz). Each channel is then sampled, receives its transducer's
noise and is quantised by a 16-bit converter whose input range is the smallest of
a 1-2-5 ladder above 1.25 times the channel's peak (the range a lab sets after a
trial run). This module never imports vlab.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.signal

RANGE_LADDER = np.array([m * 10.0**e for e in range(-6, 5) for m in (1.0, 2.0, 5.0)])
"""Input ranges of the converter (full scale +- R) in the channel's SI unit."""


@dataclass(frozen=True)
class Frontend:
    """Acquisition settings.

    Attributes
    ----------
    rate_hz : float
        Sampling rate [Hz] (5000).
    aa_order : int
        Anti-alias filter poles (8).
    aa_fraction : float
        Anti-alias corner as a fraction of the sampling rate (0.4).
    bits : int
        Converter resolution (16).
    accel_noise : float
        Accelerometer noise, RMS per sample [m/s^2] (1.5e-4: a seismic ICP
        accelerometer's broadband resolution).
    force_noise : float
        Force-channel noise, RMS per sample [N] (2e-3).
    velocity_noise : float
        Velocity-sensor noise, RMS per sample [m/s] (1e-6).
    """

    rate_hz: float = 5000.0
    aa_order: int = 8
    aa_fraction: float = 0.4
    bits: int = 16
    accel_noise: float = 1.5e-4
    force_noise: float = 2e-3
    velocity_noise: float = 1e-6

    def anti_alias(self, fine_rate_hz: float) -> np.ndarray:
        """Second-order sections of the anti-alias filter at the fine rate.

        Parameters
        ----------
        fine_rate_hz : float
            Rate of the simulated continuous signal [Hz].

        Returns
        -------
        ndarray, shape (aa_order // 2, 6)
        """
        return scipy.signal.butter(self.aa_order, self.aa_fraction * self.rate_hz,
                                   fs=fine_rate_hz, output="sos")


def input_range(x: np.ndarray) -> float:
    """Smallest converter range (1-2-5 ladder) above 1.25 times the peak of x.

    Parameters
    ----------
    x : ndarray, shape (n,)

    Returns
    -------
    float
        Full scale R (the converter reads -R .. R).
    """
    peak = 1.25 * float(np.max(np.abs(x))) if x.size else 0.0
    fit = RANGE_LADDER[RANGE_LADDER >= peak]
    return float(fit[0] if fit.size else RANGE_LADDER[-1])


def quantise(x: np.ndarray, full_scale: float, bits: int = 16) -> np.ndarray:
    """Round to the converter's levels and clip to its range.

    Parameters
    ----------
    x : ndarray, shape (n,)
    full_scale : float
        R: the converter reads -R .. R - q.
    bits : int

    Returns
    -------
    ndarray, shape (n,)
        Quantised samples, step q = 2 R / 2**bits.
    """
    q = 2.0 * full_scale / 2**bits
    return np.clip(np.round(x / q), -(2 ** (bits - 1)), 2 ** (bits - 1) - 1) * q


def digitise(x: np.ndarray, noise_rms: float, fe: Frontend, rng: np.random.Generator):
    """Add a transducer's noise and quantise a sampled channel.

    Parameters
    ----------
    x : ndarray, shape (n,)
        Anti-alias-filtered samples.
    noise_rms : float
        Noise RMS per sample, in the unit of x.
    fe : Frontend
    rng : numpy.random.Generator

    Returns
    -------
    samples : ndarray, shape (n,)
    full_scale : float
        The range used.
    """
    noisy = x + noise_rms * rng.standard_normal(x.shape)
    full = input_range(noisy)
    return quantise(noisy, full, fe.bits), full
