"""The exact modes of the digital loop (:func:`sampled_data_modes`): plant, controller engine (Eq. 5.1),
computation delay, zero-order hold and RC filter (Sec. 5.3) advanced by one sampling period; the
eigenvalues ``z`` of that map give each closed-loop mode's frequency and damping ``s = ln(z) / T``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from ..errors import ModelError
from ..lab.blocks import PC1000_DELAY_PERIODS

#: Band searched for the limit cycle [Hz] (the unmodelled modes around the observed 41 Hz).
BAND_HZ = (25.0, 120.0)


@dataclass(frozen=True)
class SampledDataModes:
    """Modes of a sampled-data closed loop.

    Attributes
    ----------
    freq_hz, zeta : ndarray, shape (n,)
        ``|s| / 2 pi`` and ``-Re s / |s|`` of ``s = ln(z) / T`` (one per
        complex pair, ``Im s > 0``, and per positive real ``z``), sorted by frequency.
    max_abs_z : float
        Spectral radius; > 1 means an unstable loop.
    """

    freq_hz: np.ndarray
    zeta: np.ndarray
    max_abs_z: float

    def in_band(self, band_hz: tuple[float, float] = BAND_HZ) -> tuple[np.ndarray, np.ndarray]:
        """Frequencies and damping of the modes in ``band_hz``."""
        sel = (self.freq_hz >= band_hz[0]) & (self.freq_hz <= band_hz[1])
        return self.freq_hz[sel], self.zeta[sel]

    def least_damped(self, band_hz: tuple[float, float] = BAND_HZ) -> tuple[float, float]:
        """(frequency [Hz], damping) of the least damped mode in ``band_hz``."""
        f, z = self.in_band(band_hz)
        if not len(f):
            return math.nan, math.nan
        i = int(np.argmin(z))
        return float(f[i]), float(z[i])


def sampled_data_modes(m, c, k, u, f11, f12, f21, f22, period_s: float, *, delay_periods: float = PC1000_DELAY_PERIODS,
                       filter_hz: float | None = 677.0) -> SampledDataModes:
    """Exact modes of the digital loop: plant, engine (Eq. 5.1), delay, hold, RC filter.

    Plant ``m q'' + c q' + k q = U f``, sensors ``y = U^T q'`` (collocated
    velocity), RC filter ``v' = w_c (dac - v)``, ``f = v``. With the delay
    ``D = d + phi`` periods the DAC holds ``u[k-d-1]`` over the first
    ``phi T`` of period ``k`` and ``u[k-d]`` over the rest (as
    :class:`vlab.lab.blocks.SampleDelay`); the state
    ``[z_k; x_k; u_{k-1} .. u_{k-d-1}]`` then advances linearly by one
    period, and the loop's modes are the eigenvalues of that map.

    Parameters
    ----------
    m, c, k : ndarray, shape (n, n)
        Plant [SI].
    u : ndarray, shape (n, n_a)
        Actuator load distribution (sensors collocated).
    f11, f12, f21, f22 : ndarray
        Engine coefficients, ``u_k = F11 y_k + F12 x_k``, ``x_{k+1} = F21 y_k + F22 x_k`` [SI].
    period_s : float
        Sampling period T [s].
    delay_periods : float
        Computation delay D >= 0 [periods] (Sec. 5.3: 1.35).
    filter_hz : float or None
        RC corner [Hz] (677) or None.

    Returns
    -------
    SampledDataModes

    Raises
    ------
    ModelError
        Negative delay or inconsistent shapes.

    Source: Eq. (5.1), Sec. 5.3; zero-order-hold discretisation by the matrix exponential.
    """
    if delay_periods < 0:
        raise ModelError(f"delay_periods must be >= 0, got {delay_periods}")
    m, c, k, u = (np.asarray(a, dtype=float) for a in (m, c, k, u))
    na = u.shape[1]
    f11, f12, f21, f22 = (np.asarray(a, dtype=float) for a in (f11, f12, f21, f22))
    if f11.shape != (na, na):
        raise ModelError(f"F11 must be ({na}, {na}) for {na} collocated pairs, got {f11.shape}")
    az, bz, cz = _filtered_plant(m, c, k, u, filter_hz)
    acl = _period_map(az, bz, cz, (f11, f12, f21, f22), period_s, delay_periods)
    zz = np.linalg.eigvals(acl)
    zz = zz[np.abs(zz) > 1e-12]
    s = np.log(zz.astype(complex)) / period_s
    keep = (s.imag > 1e-9) | ((np.abs(s.imag) <= 1e-9) & (zz.real > 0))
    s = s[keep]
    w = np.abs(s)
    f = w / (2 * np.pi)  # undamped natural frequency, as vlab.analysis.closed_loop_modes
    zeta = np.where(w > 0, -s.real / np.where(w > 0, w, 1.0), 1.0)
    o = np.argsort(f)
    return SampledDataModes(f[o], zeta[o], float(np.max(np.abs(zz))))


def _filtered_plant(m: np.ndarray, c: np.ndarray, k: np.ndarray, u: np.ndarray,
                    filter_hz: float | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(A, B, C)`` of the plant from the DAC output to the collocated velocities, state ``[q'; q]`` and,
    with an RC corner ``filter_hz`` [Hz], the filter state ``v' = w_c (dac - v)`` (force ``f = v``)."""
    n, na = u.shape
    minv = np.linalg.inv(m)
    a = np.block([[-minv @ c, -minv @ k], [np.eye(n), np.zeros((n, n))]])
    b = np.vstack([minv @ u, np.zeros((n, na))])
    cy = np.hstack([u.T, np.zeros((na, n))])
    if not filter_hz:
        return a, b, cy
    wc = 2 * np.pi * filter_hz
    az = np.block([[a, b], [np.zeros((na, 2 * n)), -wc * np.eye(na)]])
    bz = np.vstack([np.zeros((2 * n, na)), wc * np.eye(na)])
    cz = np.hstack([cy, np.zeros((na, na))])
    return az, bz, cz


def _period_map(az: np.ndarray, bz: np.ndarray, cz: np.ndarray, engine: tuple, period_s: float,
                delay_periods: float) -> np.ndarray:
    """The loop's one-period map of ``[z_k; x_k; u_{k-1} .. u_{k-d-1}]`` (see :func:`sampled_data_modes`);
    ``engine`` = ``(F11, F12, F21, F22)``."""
    f11, f12, f21, f22 = engine
    nz, na = bz.shape

    def hold(h: float) -> tuple[np.ndarray, np.ndarray]:
        big = np.zeros((nz + na, nz + na))
        big[:nz, :nz] = az * h
        big[:nz, nz:] = bz * h
        e = scipy.linalg.expm(big)
        return e[:nz, :nz], e[:nz, nz:]

    d = int(math.floor(delay_periods + 1e-12))
    phi = delay_periods - d
    ad, _ = hold(period_s)
    _, g1 = hold(phi * period_s)
    a2, g2 = hold((1 - phi) * period_s)
    g_old, g_new = a2 @ g1, g2  # u[k-d-1] over the first phi T, u[k-d] over the rest
    nx = f22.shape[0]
    nb = d + 1  # buffer u_{k-1} .. u_{k-d-1}
    big_n = nz + nx + nb * na
    acl = np.zeros((big_n, big_n))

    def bi(j: int) -> slice:
        return slice(nz + nx + j * na, nz + nx + (j + 1) * na)

    acl[:nz, :nz] = ad
    if d == 0:  # u_k itself acts over the second part of the period
        acl[:nz, :nz] += g_new @ f11 @ cz
        acl[:nz, nz:nz + nx] += g_new @ f12
        acl[:nz, bi(0)] += g_old
    else:
        acl[:nz, bi(d - 1)] += g_new
        acl[:nz, bi(d)] += g_old
    acl[nz:nz + nx, :nz] = f21 @ cz
    acl[nz:nz + nx, nz:nz + nx] = f22
    acl[bi(0), :nz] = f11 @ cz
    acl[bi(0), nz:nz + nx] = f12
    for j in range(1, nb):
        acl[bi(j), bi(j - 1)] = np.eye(na)
    return acl
