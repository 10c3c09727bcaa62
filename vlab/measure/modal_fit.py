"""Modal parameters from a least-squares curve fit of an FRF near its peaks: :func:`fit_modes`.

Around each peak a band is fitted by a rational fraction (SDOF, or MDOF
where the bands of close peaks overlap), giving frequency, damping and
residue; ``method="lscf"`` uses sdypy-EMA's LSCF instead. Peaks and the
half-power bandwidth that sizes the default band come from
:mod:`vlab.measure.modal`.

Frequencies are in [Hz]; FRFs are complex arrays in SI units (any of
receptance [m/N], mobility [(m/s)/N], accelerance).

Sources: Ewins, *Modal Testing: Theory, Practice and Application*, 2nd ed.
(2000), Secs. 4.4-4.5 (circle and rational-fraction fits); Richardson &
Formenti, IMAC 1 (1982) 167-181 (rational fraction polynomials); Sanathanan
& Koerner, IEEE TAC 8 (1963) 56-58 (iterative reweighting).
"""

from __future__ import annotations

import contextlib
import io
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import MeasurementError
from .modal import frf_arrays, half_power_damping

#: sdypy-EMA's name of the FRF form of each response quantity.
FRF_FORMS = {"displacement": "receptance", "velocity": "mobility", "acceleration": "accelerance"}


@dataclass(frozen=True)
class ModeFit:
    """Modal parameters of one mode from a curve fit.

    Attributes
    ----------
    freq_hz : float
        Undamped natural frequency ``|lambda| / 2 pi`` [Hz].
    damping_ratio : float
        ``zeta = -Re(lambda) / |lambda|`` [-].
    pole : complex
        ``lambda`` [rad/s], ``Im > 0``.
    residue : complex
        Residue of the FRF at ``lambda`` (FRF units x rad/s); NaN for ``method="lscf"``.
    band_hz : (float, float)
        Frequency band fitted [Hz].
    n_modes_in_band : int
        Number of modes fitted together (1 = SDOF).
    """

    freq_hz: float
    damping_ratio: float
    pole: complex
    residue: complex
    band_hz: tuple[float, float]
    n_modes_in_band: int


def _rfp(omega: np.ndarray, h: np.ndarray, n_modes: int, weights: np.ndarray,
         n_iter: int = 50) -> tuple[np.ndarray, np.ndarray]:
    """Rational-fraction LS fit ``H = N(s) / (s^2 D(s))``, D monic of degree 2n, deg N = 2n + 3.

    The partial fractions of this model are the n modes (complex residues)
    plus residual terms ``1/s^2, 1/s, 1, s`` for the modes outside the band.
    Sanathanan-Koerner iterations of Levy's linearised problem on
    ``s = i omega / omega_0`` (``omega_0`` = band centre) for conditioning.
    Returns (roots of D [rad/s], residues of H at them).
    """
    w0 = float(np.mean(omega))
    s = 1j * omega / w0
    nd = 2 * n_modes
    nn = nd + 3
    powers_n = s[:, None] ** np.arange(nn + 1)
    powers_d = s[:, None] ** np.arange(nd)
    s2 = s**2
    d_prev = np.ones(s.size)
    a = None
    for _ in range(n_iter):
        wk = weights / np.abs(s2 * d_prev)
        A = np.hstack([powers_n, -(h * s2)[:, None] * powers_d]) * wk[:, None]
        rhs = h * s2 * s**nd * wk
        Ar = np.vstack([A.real, A.imag])
        br = np.concatenate([rhs.real, rhs.imag])
        scale = np.linalg.norm(Ar, axis=0)
        scale[scale == 0] = 1.0
        theta = np.linalg.lstsq(Ar / scale, br, rcond=None)[0] / scale
        b, a_new = theta[:nn + 1], theta[nn + 1:]
        d_prev = powers_d @ a_new + s**nd
        converged = a is not None and np.linalg.norm(a_new - a) <= 1e-12 * (1 + np.linalg.norm(a))
        a = a_new
        if converged:
            break
    den = np.concatenate([[1.0], a[::-1]])          # highest power first
    num = b[::-1]
    roots = np.roots(den)
    res = w0 * np.polyval(num, roots) / (roots**2 * np.polyval(np.polyder(den), roots))
    return roots * w0, res


def _lscf(f: np.ndarray, hh: np.ndarray, peaks: np.ndarray, response: str, band: tuple[float, float],
          name: str) -> list[ModeFit]:
    try:
        from sdypy import EMA  # optional dependency
    except ImportError:  # pragma: no cover - depends on the environment
        raise MeasurementError(f"{name}: method='lscf' needs sdypy-EMA (pip install sdypy-EMA)") from None
    keep = f <= band[1]
    lo, hi = band[0], float(f[keep][-1])
    model = EMA.Model(frf=hh[keep][None, :], freq=f[keep], lower=lo, upper=hi,
                      pol_order_high=max(20, 4 * peaks.size), frf_form=FRF_FORMS[response])
    with contextlib.redirect_stderr(io.StringIO()):  # sdypy-EMA's stabilisation prints a progress bar
        model.get_poles(method="lscf", show_progress=False)
        model.select_closest_poles(list(peaks), f_window=max(4, int(round(hi - lo))))
    out = []
    for fn, zeta in zip(np.atleast_1d(model.nat_freq), np.atleast_1d(model.nat_xi)):
        wn = 2 * np.pi * fn
        pole = complex(-zeta * wn, wn * math.sqrt(max(1 - zeta**2, 0.0)))
        out.append(ModeFit(freq_hz=float(fn), damping_ratio=float(zeta), pole=pole,
                           residue=complex(np.nan, np.nan), band_hz=(float(lo), float(hi)),
                           n_modes_in_band=int(peaks.size)))
    return out


def _half_bands(f: np.ndarray, hh: np.ndarray, peaks: np.ndarray, half_band_hz, name: str) -> np.ndarray:
    """Half width [Hz] of the fitted band around each peak, shape (n_peaks,) (see :func:`fit_modes`)."""
    df = float(np.median(np.diff(f)))
    if half_band_hz is None:
        hbs = []
        for p in peaks:
            try:
                zeta = half_power_damping(f, hh, p, name=name)
                hb = 3 * 2 * zeta * p
            except MeasurementError:
                hb = 0.06 * p
            hbs.append(max(hb, 4 * df))
        return np.array(hbs)
    hbs = np.broadcast_to(np.asarray(half_band_hz, dtype=float), peaks.shape).copy()
    if np.any(hbs <= 0):
        raise MeasurementError(f"{name}: half_band_hz must be > 0")
    return hbs


def overlapping_bands(peaks, hbs) -> list[list[int]]:
    """The peaks (indices) in groups whose bands ``peak +- hbs`` overlap, in frequency order.

    Parameters
    ----------
    peaks : array_like, shape (n_peaks,)
        Peak frequencies [Hz].
    hbs : array_like, shape (n_peaks,)
        Half width of each peak's band [Hz].

    Returns
    -------
    list of list of int
        Indices into ``peaks``; each group's bands overlap in a chain, groups in frequency order. Modes of
        one group are fitted together (MDOF, Ewins 2000, Sec. 4.7).
    """
    peaks = np.asarray(peaks, dtype=float)
    hbs = np.asarray(hbs, dtype=float)
    order = np.argsort(peaks)
    groups: list[list[int]] = []
    for i in order:
        lo_i = peaks[i] - hbs[i]
        if groups and lo_i <= max(peaks[j] + hbs[j] for j in groups[-1]):
            groups[-1].append(int(i))
        else:
            groups.append([int(i)])
    return groups


def band_lines(f: np.ndarray, lo_hz: float, hi_hz: float, need: int) -> np.ndarray:
    """Indices of the positive lines of ``f`` [Hz] in ``[lo_hz, hi_hz]``, widened a line at a time on both
    sides until there are ``need`` (or the FRF ends), shape (n_sel,).

    Parameters
    ----------
    f : ndarray, shape (n_freq,)
        Increasing frequency lines [Hz].
    lo_hz, hi_hz : float
        The band [Hz].
    need : int
        Lines wanted at least.

    Returns
    -------
    ndarray of int
        Consecutive line indices; fewer than ``need`` only when the FRF has no more positive lines.
    """
    lo = max(f[0], lo_hz)
    hi = min(f[-1], hi_hz)
    sel = np.flatnonzero((f >= lo) & (f <= hi) & (f > 0))
    if sel.size == 0:
        sel = np.array([int(np.argmin(np.abs(f - 0.5 * (lo + hi))))])
    while sel.size < need and (sel[0] > 0 or sel[-1] < f.size - 1):
        sel = np.arange(max(sel[0] - 1, 0 if f[0] > 0 else 1), min(sel[-1] + 2, f.size))
    return sel


def _fit_group(f: np.ndarray, hh: np.ndarray, w: np.ndarray, peaks: np.ndarray, hbs: np.ndarray,
               g: list[int], name: str) -> dict[int, ModeFit]:
    """One rational-fraction fit (:func:`_rfp`) of the band covering the peaks ``g``: peak index -> its mode."""
    n = len(g)
    need = 4 * n + 6
    sel = band_lines(f, min(peaks[j] - hbs[j] for j in g), max(peaks[j] + hbs[j] for j in g), need)
    if sel.size < need or np.count_nonzero(w[sel]) < need:
        raise MeasurementError(f"{name}: only {sel.size} usable lines near {peaks[g]} Hz; "
                               f"need {need}")
    poles, res = _rfp(2 * np.pi * f[sel], hh[sel], n, w[sel])
    cand = [k for k in range(poles.size) if poles[k].imag > 0]
    band = (float(f[sel[0]]), float(f[sel[-1]]))
    result: dict[int, ModeFit] = {}
    for j in sorted(g, key=lambda j: peaks[j]):
        if not cand:
            raise MeasurementError(f"{name}: the fit in {band} Hz found no resonant pole near "
                                   f"{peaks[j]:.4g} Hz")
        k = min(cand, key=lambda k: abs(abs(poles[k]) / (2 * np.pi) - peaks[j]))
        cand.remove(k)
        lam = complex(poles[k])
        wn = abs(lam)
        result[j] = ModeFit(freq_hz=wn / (2 * np.pi), damping_ratio=-lam.real / wn, pole=lam,
                            residue=complex(res[k]), band_hz=band, n_modes_in_band=n)
    return result


def fit_modes(freq_hz, h, peaks_hz: Sequence[float], *, response: str = "velocity",
              half_band_hz: float | Sequence[float] | None = None, weights=None,
              method: str = "rfp", name: str = "frf") -> list[ModeFit]:
    """Least-squares curve fit of the FRF near each peak: frequency, damping, residue.

    ``method="rfp"`` (default, vlab's compact implementation): around each
    peak a band ``peak +- half_band_hz`` is fitted by the rational fraction::

        H(s) = (b_0 + b_1 s + ... + b_{2n+3} s^{2n+3}) / (s^2 (a_0 + a_1 s + ... + s^{2n})),   s = i omega

    with ``n`` the number of peaks in the band (bands that overlap are
    merged and fitted together as MDOF). In partial fractions this is ``n``
    modes with complex residues plus the residual terms ``1/s^2, 1/s, 1, s``
    that absorb the modes outside the band (lower and upper residuals of any
    FRF form). The linearised least-squares problem is solved repeatedly
    with Sanathanan-Koerner weights ``1/|s^2 D|``, which converges to the
    output-error fit. Poles are the roots of ``D``, matched one-to-one to
    the nearest peaks. sdypy-EMA is not a dependency of vlab; this fit is.

    ``method="lscf"`` uses the LSCF estimator of sdypy-EMA (if installed) on
    the band covering all peaks with stable-pole selection; it returns no
    residues.

    Parameters
    ----------
    freq_hz : array_like, shape (n_freq,)
        Frequencies [Hz].
    h : array_like, shape (n_freq,)
        Complex FRF.
    peaks_hz : sequence of float, shape (n_peaks,)
        Approximate natural frequencies [Hz] (e.g. from :func:`find_peaks`).
    response : {"velocity", "displacement", "acceleration"}
        Quantity of the FRF numerator (needed by ``"lscf"``).
    half_band_hz : float or sequence of float, optional
        Half width of the fitted band around each peak [Hz]. Default: three
        half-power bandwidths (estimated with :func:`half_power_damping`, or
        6 % of the peak frequency when that fails), at least 4 lines.
    weights : array_like, shape (n_freq,), optional
        Non-negative weights per line, e.g. ``coh / (1 - coh)`` from the
        coherence; uniform by default.
    method : {"rfp", "lscf"}
        Fitting method.
    name : str
        FRF name for messages.

    Returns
    -------
    list of ModeFit
        One per peak, in the order of ``peaks_hz``.

    Raises
    ------
    MeasurementError
        Bad arrays or options, too few lines in a band, or no resonant pole
        near a peak.
    """
    f, hh = frf_arrays(freq_hz, h, name)
    hh = hh.astype(complex)
    peaks = np.atleast_1d(np.asarray(peaks_hz, dtype=float))
    if peaks.ndim != 1 or peaks.size == 0 or np.any(peaks <= 0) or np.any(peaks > f[-1]) \
            or np.any(peaks < f[0]):
        raise MeasurementError(f"{name}: peaks_hz must be positive frequencies inside the FRF range, "
                               f"got {peaks_hz!r}")
    if response not in FRF_FORMS:
        raise MeasurementError(f"{name}: unknown response {response!r}")
    w = np.ones(f.size) if weights is None else np.asarray(weights, dtype=float)
    if w.shape != f.shape or np.any(w < 0) or not np.all(np.isfinite(w)):
        raise MeasurementError(f"{name}: weights must be finite, >= 0, shape {f.shape}")
    hbs = _half_bands(f, hh, peaks, half_band_hz, name)
    if method == "lscf":
        lo = max(f[0], float(np.min(peaks - hbs)))
        hi = min(f[-1], float(np.max(peaks + hbs)))
        return _lscf(f, hh, peaks, response, (lo, hi), name)
    if method != "rfp":
        raise MeasurementError(f"{name}: method must be 'rfp' or 'lscf', got {method!r}")
    result: dict[int, ModeFit] = {}
    for g in overlapping_bands(peaks, hbs):
        result.update(_fit_group(f, hh, w, peaks, hbs, g, name))
    return [result[j] for j in range(peaks.size)]


def fit_half_bands(freq_hz, modes_hz, damping_hint) -> np.ndarray:
    """Half width of the band fitted around each expected mode [Hz]: ``3 zeta f``, one and a half
    half-power bandwidths ``2 zeta f`` of the expected damping (``zeta`` clipped to [0.002, 0.3]), at least
    four lines.

    Parameters
    ----------
    freq_hz : array_like, shape (n_freq,)
        The FRF's lines [Hz] (their median spacing sets the four-line minimum).
    modes_hz : array_like, shape (n_modes,)
        Expected natural frequencies [Hz].
    damping_hint : array_like, shape (n_modes,)
        Expected damping ratios [-].

    Returns
    -------
    ndarray, shape (n_modes,)
        Half widths [Hz], to pass as ``half_band_hz`` of :func:`fit_modes`.

    Source: Ewins (2000), Sec. 4.3 (the half-power bandwidth ``2 zeta f`` of a mode).
    """
    df = float(np.median(np.diff(np.asarray(freq_hz, dtype=float))))
    f = np.asarray(modes_hz, dtype=float)
    zeta = np.clip(np.asarray(damping_hint, dtype=float), 0.002, 0.3)
    return np.maximum(3.0 * f * zeta, 4 * df)


def fit_each_mode(freq_hz, h, modes_hz, half_band_hz, *, response: str = "velocity",
                  weights=None, name: str = "frf") -> list[ModeFit | None]:
    """:func:`fit_modes` of the expected modes, the modes of overlapping bands together, group by group.

    Close modes whose bands overlap (:func:`overlapping_bands`) are fitted together (MDOF: fitted alone,
    each would have to explain its neighbour's response with its own pole, Ewins 2000, Sec. 4.7). A group
    whose fit fails (too few lines, or no resonant pole near one peak: an overdamped mode) has its modes
    fitted each on its own band; the other groups keep their joint fits. A mode that still fails is None.

    Parameters
    ----------
    freq_hz, h, response, weights, name
        As :func:`fit_modes`.
    modes_hz : array_like, shape (n_modes,)
        Expected natural frequencies [Hz] (the peaks to fit).
    half_band_hz : array_like, shape (n_modes,)
        Half width of each mode's band [Hz] (:func:`fit_half_bands`).

    Returns
    -------
    list of (ModeFit or None), length n_modes
        In the order of ``modes_hz``.

    Raises
    ------
    MeasurementError
        ``half_band_hz`` neither one value nor one per mode. Otherwise nothing: a fit that raises
        MeasurementError (bad or non-finite arrays included) gives None.
    """
    modes = [float(x) for x in np.atleast_1d(modes_hz)]
    halves = np.asarray(half_band_hz, dtype=float)
    if halves.ndim > 1 or halves.size not in (1, len(modes)):
        raise MeasurementError(f"{name}: half_band_hz must be one value or one per mode ({len(modes)}), "
                               f"got shape {halves.shape}")
    halves = np.broadcast_to(halves.ravel(), (len(modes),))

    def fit(idx: list[int]) -> list[ModeFit]:
        return fit_modes(freq_hz, h, [modes[j] for j in idx], response=response,
                         half_band_hz=[float(halves[j]) for j in idx], weights=weights, name=name)

    fits: list[ModeFit | None] = [None] * len(modes)
    for g in overlapping_bands(modes, halves):
        try:
            for j, m in zip(g, fit(g)):
                fits[j] = m
            continue
        except MeasurementError:
            pass
        for j in g:
            try:
                fits[j] = fit([j])[0]
            except MeasurementError:
                fits[j] = None
    return fits
