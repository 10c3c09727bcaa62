"""Modal parameters from FRFs and decay traces; analysis/experiment peak levels.

* :func:`find_peaks` — resonance peaks, refined by a parabola through the
  log magnitude of the three highest lines.
* :func:`half_power_damping` — ``zeta = (f2 - f1) / (2 f_n)`` from the
  half-power (-3 dB) points.
* :func:`fit_modes` — least-squares rational-fraction fit of the FRF near
  each peak (SDOF, or MDOF where peaks are close), giving frequency, damping
  and residue; ``method="lscf"`` uses sdypy-EMA's LSCF instead.
* :func:`decay_damping` — logarithmic decrement of a free decay from the
  Hilbert envelope (impulse runs).
* :func:`peak_levels`, :func:`peak_level_ratios`, :func:`average_peak_error`
  — the dissertation's comparison of analytical and experimental FRF peak
  levels (Tables 10, 19-21): ratio = analysis / experiment per mode and
  average error = mean ``|1 - ratio|``.

Frequencies are in [Hz]; FRFs are complex arrays in SI units (any of
receptance [m/N], mobility [(m/s)/N], accelerance). Functions take plain
arrays plus a ``name`` used in error messages (pass ``frf.name``).

Sources: Ewins, *Modal Testing: Theory, Practice and Application*, 2nd ed.
(2000), Secs. 4.3 (peak picking, half power), 4.4-4.5 (circle and
rational-fraction fits); Richardson & Formenti, IMAC 1 (1982) 167-181
(rational fraction polynomials); Sanathanan & Koerner, IEEE TAC 8 (1963)
56-58 (iterative reweighting).
"""

from __future__ import annotations

import contextlib
import io
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy import signal

from ..errors import MeasurementError

_FRF_FORMS = {"displacement": "receptance", "velocity": "mobility", "acceleration": "accelerance"}


# --------------------------------------------------------------------------- helpers
def _frf_arrays(freq_hz, h, name: str) -> tuple[np.ndarray, np.ndarray]:
    f = np.asarray(freq_hz, dtype=float)
    hh = np.asarray(h)
    if f.ndim != 1 or hh.shape != f.shape:
        raise MeasurementError(f"{name}: freq_hz {f.shape} and FRF {hh.shape} must be equal 1-D shapes")
    if f.size < 3:
        raise MeasurementError(f"{name}: need at least 3 frequency lines, got {f.size}")
    if np.any(np.diff(f) <= 0):
        raise MeasurementError(f"{name}: freq_hz must be strictly increasing")
    if not np.all(np.isfinite(f)) or not np.all(np.isfinite(hh)):
        raise MeasurementError(f"{name}: non-finite frequency or FRF values")
    return f, hh


def _refine(f: np.ndarray, logm: np.ndarray, i: int) -> tuple[float, float]:
    """Vertex of the parabola through (f, log|H|) at lines i-1, i, i+1: (freq, log magnitude)."""
    if i <= 0 or i >= f.size - 1:
        return float(f[i]), float(logm[i])
    x = f[i - 1:i + 2] - f[i]
    c2, c1, c0 = np.polyfit(x, logm[i - 1:i + 2], 2)
    if c2 >= 0:
        return float(f[i]), float(logm[i])
    xv = -c1 / (2 * c2)
    xv = min(max(xv, x[0]), x[2])
    return float(f[i] + xv), float(c0 + c1 * xv + c2 * xv * xv)


@dataclass(frozen=True)
class Peak:
    """A resonance peak of an FRF magnitude.

    Attributes
    ----------
    freq_hz : float
        Peak frequency [Hz], parabolically interpolated.
    magnitude : float
        Peak ``|H|`` (interpolated), FRF units.
    index : int
        Index of the highest line.
    """

    freq_hz: float
    magnitude: float
    index: int


def refine_peak(freq_hz, h, index: int, *, name: str = "frf") -> Peak:
    """Refine the peak at line ``index`` by a parabola through ``ln|H|`` of its three lines.

    Parameters
    ----------
    freq_hz : array_like, shape (n_freq,)
        Frequencies [Hz].
    h : array_like, shape (n_freq,)
        FRF.
    index : int
        Line of the local maximum.
    name : str
        FRF name for messages.

    Returns
    -------
    Peak
        The line itself at the ends of the FRF or if the parabola opens upwards.

    Raises
    ------
    MeasurementError
        Bad arrays or index out of range.
    """
    f, hh = _frf_arrays(freq_hz, h, name)
    if not 0 <= index < f.size:
        raise MeasurementError(f"{name}: peak index {index} outside 0..{f.size - 1}")
    fp, lm = _refine(f, np.log(np.maximum(np.abs(hh), 1e-300)), int(index))
    return Peak(freq_hz=fp, magnitude=math.exp(lm), index=int(index))


def find_peaks(freq_hz, h, *, band_hz: tuple[float, float] | None = None, n_peaks: int | None = None,
               prominence_db: float = 3.0, name: str = "frf") -> list[Peak]:
    """Resonance peaks of ``|H|`` in a band.

    Local maxima of ``20 log10 |H|`` with at least ``prominence_db``
    prominence (:func:`scipy.signal.find_peaks`), each refined by a parabola
    through the log magnitude of its three lines.

    Parameters
    ----------
    freq_hz : array_like, shape (n_freq,)
        Frequencies [Hz].
    h : array_like, shape (n_freq,)
        FRF (complex or magnitude).
    band_hz : (float, float), optional
        Search band [Hz]; whole range by default.
    n_peaks : int, optional
        Keep the ``n_peaks`` most prominent.
    prominence_db : float
        Minimum prominence [dB].
    name : str
        FRF name for messages.

    Returns
    -------
    list of Peak
        Sorted by frequency (possibly empty).

    Raises
    ------
    MeasurementError
        Bad arrays or an empty band.
    """
    f, hh = _frf_arrays(freq_hz, h, name)
    mag = np.abs(hh)
    lo, hi = (f[0], f[-1]) if band_hz is None else band_hz
    sel = np.flatnonzero((f >= lo) & (f <= hi))
    if sel.size < 3:
        raise MeasurementError(f"{name}: fewer than 3 lines in band {band_hz} Hz")
    db = 20 * np.log10(np.maximum(mag, 1e-300))
    idx, props = signal.find_peaks(db[sel], prominence=prominence_db)
    idx = sel[idx]
    prom = props["prominences"]
    if n_peaks is not None and idx.size > n_peaks:
        keep = np.sort(np.argsort(prom)[::-1][:n_peaks])
        idx = idx[keep]
    logm = np.log(np.maximum(mag, 1e-300))
    out = []
    for i in idx:
        fp, lm = _refine(f, logm, int(i))
        out.append(Peak(freq_hz=fp, magnitude=math.exp(lm), index=int(i)))
    return out


def _nearest_max(f: np.ndarray, mag: np.ndarray, near_hz: float, half_band_hz: float, name: str) -> int:
    sel = np.flatnonzero((f >= near_hz - half_band_hz) & (f <= near_hz + half_band_hz))
    if sel.size == 0:
        raise MeasurementError(f"{name}: no line within {half_band_hz} Hz of {near_hz} Hz")
    return int(sel[np.argmax(mag[sel])])


def half_power_damping(freq_hz, h, peak_hz: float, *, search_half_band_hz: float | None = None,
                       name: str = "frf") -> float:
    """Damping ratio from the half-power bandwidth of the peak near ``peak_hz``.

    ::

        zeta = (f2 - f1) / (2 f_n),   |H(f1)| = |H(f2)| = |H(f_n)| / sqrt(2)

    ``f_n`` and ``|H(f_n)|`` come from the parabolic refinement; ``f1`` and
    ``f2`` from linear interpolation of ``1/|H|^2`` (nearly a parabola in f
    near resonance) between the lines that bracket the half-power level.

    Parameters
    ----------
    freq_hz : array_like, shape (n_freq,)
        Frequencies [Hz].
    h : array_like, shape (n_freq,)
        FRF. Exact for an SDOF mobility; for a receptance the error is of
        order ``zeta^2``.
    peak_hz : float
        Approximate peak frequency [Hz]; the highest line within
        ``search_half_band_hz`` of it is used.
    search_half_band_hz : float, optional
        Default: 5 % of ``peak_hz`` or two lines, whichever is wider.
    name : str
        FRF name for messages.

    Returns
    -------
    float
        Viscous damping ratio ``zeta`` [-].

    Raises
    ------
    MeasurementError
        A half-power point is not found before the FRF ends or rises again
        (a neighbouring mode), or the half-power band spans fewer than two
        lines (resolution too coarse: use a finer resolution or
        :func:`fit_modes`).

    Notes
    -----
    Source: Ewins, *Modal Testing*, 2nd ed., Sec. 4.3.
    """
    f, hh = _frf_arrays(freq_hz, h, name)
    mag = np.abs(hh)
    df = float(np.median(np.diff(f)))
    hb = max(0.05 * peak_hz, 2 * df) if search_half_band_hz is None else search_half_band_hz
    i = _nearest_max(f, mag, peak_hz, hb, name)
    fn, lm = _refine(f, np.log(np.maximum(mag, 1e-300)), i)
    level2 = math.exp(2 * lm) / 2.0  # |H|^2 at half power
    inv = 1.0 / np.maximum(mag**2, 1e-300)
    target = 1.0 / level2

    def crossing(direction: int) -> float:
        j = i
        lowest = mag[i]
        while True:
            k = j + direction
            if k < 0 or k >= f.size:
                side = "below" if direction < 0 else "above"
                raise MeasurementError(
                    f"{name}: half-power point {side} the peak at {fn:.4g} Hz not found "
                    "before the end of the FRF")
            lowest = min(lowest, mag[k])
            if mag[k] > 1.1 * lowest and inv[k] < target:
                side = "below" if direction < 0 else "above"
                raise MeasurementError(
                    f"{name}: half-power point {side} the peak at {fn:.4g} Hz not reached "
                    f"before the FRF rises again at {f[k]:.4g} Hz (neighbouring mode); use fit_modes")
            if inv[k] >= target:
                # interpolate 1/|H|^2 between lines j and k
                w = (target - inv[j]) / (inv[k] - inv[j])
                return float(f[j] + w * (f[k] - f[j]))
            j = k

    f1, f2 = crossing(-1), crossing(+1)
    if f2 - f1 < 2 * df:
        raise MeasurementError(
            f"{name}: half-power band at {fn:.4g} Hz ({f2 - f1:.3g} Hz) spans fewer than two "
            f"lines of {df:.3g} Hz; use a finer resolution or fit_modes")
    return (f2 - f1) / (2 * fn)


# --------------------------------------------------------------------------- curve fit
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
                      pol_order_high=max(20, 4 * peaks.size), frf_form=_FRF_FORMS[response])
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
    f, hh = _frf_arrays(freq_hz, h, name)
    hh = hh.astype(complex)
    peaks = np.atleast_1d(np.asarray(peaks_hz, dtype=float))
    if peaks.ndim != 1 or peaks.size == 0 or np.any(peaks <= 0) or np.any(peaks > f[-1]) \
            or np.any(peaks < f[0]):
        raise MeasurementError(f"{name}: peaks_hz must be positive frequencies inside the FRF range, "
                               f"got {peaks_hz!r}")
    if response not in _FRF_FORMS:
        raise MeasurementError(f"{name}: unknown response {response!r}")
    w = np.ones(f.size) if weights is None else np.asarray(weights, dtype=float)
    if w.shape != f.shape or np.any(w < 0) or not np.all(np.isfinite(w)):
        raise MeasurementError(f"{name}: weights must be finite, >= 0, shape {f.shape}")
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
        hbs = np.array(hbs)
    else:
        hbs = np.broadcast_to(np.asarray(half_band_hz, dtype=float), peaks.shape).copy()
        if np.any(hbs <= 0):
            raise MeasurementError(f"{name}: half_band_hz must be > 0")

    if method == "lscf":
        lo = max(f[0], float(np.min(peaks - hbs)))
        hi = min(f[-1], float(np.max(peaks + hbs)))
        return _lscf(f, hh, peaks, response, (lo, hi), name)
    if method != "rfp":
        raise MeasurementError(f"{name}: method must be 'rfp' or 'lscf', got {method!r}")

    # group peaks whose bands overlap
    order = np.argsort(peaks)
    groups: list[list[int]] = []
    for i in order:
        lo_i = peaks[i] - hbs[i]
        if groups and lo_i <= max(peaks[j] + hbs[j] for j in groups[-1]):
            groups[-1].append(int(i))
        else:
            groups.append([int(i)])

    result: dict[int, ModeFit] = {}
    for g in groups:
        lo = max(f[0], min(peaks[j] - hbs[j] for j in g))
        hi = min(f[-1], max(peaks[j] + hbs[j] for j in g))
        sel = np.flatnonzero((f >= lo) & (f <= hi) & (f > 0))
        n = len(g)
        need = 4 * n + 6
        while sel.size < need and (sel[0] > 0 or sel[-1] < f.size - 1):
            sel = np.arange(max(sel[0] - 1, 0 if f[0] > 0 else 1), min(sel[-1] + 2, f.size))
        if sel.size < need or np.count_nonzero(w[sel]) < need:
            raise MeasurementError(f"{name}: only {sel.size} usable lines near {peaks[g]} Hz; "
                                   f"need {need}")
        poles, res = _rfp(2 * np.pi * f[sel], hh[sel], n, w[sel])
        cand = [k for k in range(poles.size) if poles[k].imag > 0]
        band = (float(f[sel[0]]), float(f[sel[-1]]))
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
    return [result[j] for j in range(peaks.size)]


# --------------------------------------------------------------------------- decay
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


# --------------------------------------------------------------------------- peak levels
def peak_levels(freq_hz, h, near_hz: Sequence[float], *, half_band_hz: float | Sequence[float],
                name: str = "frf") -> np.ndarray:
    """Peak magnitudes ``|H|`` near given frequencies (the dissertation's "peak levels").

    For each frequency the highest line within ``half_band_hz`` is refined
    by a parabola through ``ln|H|`` (Sec. 5.4.1: "Peak levels ... were then
    determined at each natural frequency").

    Parameters
    ----------
    freq_hz : array_like, shape (n_freq,)
        Frequencies [Hz].
    h : array_like, shape (n_freq,)
        FRF.
    near_hz : sequence of float, shape (n_modes,)
        Natural frequencies [Hz] to look near.
    half_band_hz : float or sequence of float
        Search half width [Hz] (per mode or shared).
    name : str
        FRF name for messages.

    Returns
    -------
    ndarray, shape (n_modes,)
        Peak levels in FRF units.

    Raises
    ------
    MeasurementError
        No line within the search band.
    """
    f, hh = _frf_arrays(freq_hz, h, name)
    mag = np.abs(hh)
    logm = np.log(np.maximum(mag, 1e-300))
    near = np.atleast_1d(np.asarray(near_hz, dtype=float))
    hbs = np.broadcast_to(np.asarray(half_band_hz, dtype=float), near.shape)
    out = np.empty(near.size)
    for k, (fk, hb) in enumerate(zip(near, hbs)):
        i = _nearest_max(f, mag, fk, hb, name)
        out[k] = math.exp(_refine(f, logm, i)[1])
    return out


def peak_level_ratios(analysis_levels, experiment_levels) -> np.ndarray:
    """Analytical/experimental peak level ratios per mode (Tables 10, 19-21).

    ``ratio = analysis / experiment``: > 1 when the analysis predicts a
    higher peak than measured.

    Parameters
    ----------
    analysis_levels, experiment_levels : array_like, shape (n_modes,)
        Peak levels (same units), e.g. from :func:`peak_levels`.

    Returns
    -------
    ndarray, shape (n_modes,)

    Raises
    ------
    MeasurementError
        Shape mismatch, or a non-positive/non-finite level.
    """
    a = np.atleast_1d(np.asarray(analysis_levels, dtype=float))
    e = np.atleast_1d(np.asarray(experiment_levels, dtype=float))
    if a.shape != e.shape or a.ndim != 1:
        raise MeasurementError(f"peak levels: analysis {a.shape} and experiment {e.shape} must be equal 1-D shapes")
    for arr, what in ((a, "analysis"), (e, "experiment")):
        bad = np.flatnonzero(~np.isfinite(arr) | (arr <= 0))
        if bad.size:
            raise MeasurementError(f"peak levels: {what} level of mode {bad[0] + 1} is {arr[bad[0]]}, must be > 0")
    return a / e


def average_peak_error(ratios) -> float:
    """Average error of peak level ratios: ``mean |1 - ratio|`` (last row of Tables 10, 19-21).

    Raises
    ------
    MeasurementError
        Empty or non-finite ratios.
    """
    r = np.atleast_1d(np.asarray(ratios, dtype=float))
    if r.size == 0 or not np.all(np.isfinite(r)):
        raise MeasurementError(f"ratios must be a non-empty finite array, got {ratios!r}")
    return float(np.mean(np.abs(1.0 - r)))
