"""Modal parameters read off FRF peaks; analysis/experiment peak levels.

* :func:`find_peaks` — resonance peaks, refined by a parabola through the
  log magnitude of the three highest lines.
* :func:`half_power_damping` — ``zeta = (f2 - f1) / (2 f_n)`` from the
  half-power (-3 dB) points.
* :func:`peak_levels`, :func:`peak_level_ratios`, :func:`average_peak_error`
  — the dissertation's comparison of analytical and experimental FRF peak
  levels (Tables 10, 19-21): ratio = analysis / experiment per mode and
  average error = mean ``|1 - ratio|``.

The least-squares curve fit of the FRF near its peaks is
:func:`vlab.measure.modal_fit.fit_modes`; the damping of a free decay is
:func:`vlab.measure.decay.decay_damping`.

Frequencies are in [Hz]; FRFs are complex arrays in SI units (any of
receptance [m/N], mobility [(m/s)/N], accelerance). Functions take plain
arrays plus a ``name`` used in error messages (pass ``frf.name``).

Sources: Ewins, *Modal Testing: Theory, Practice and Application*, 2nd ed.
(2000), Sec. 4.3 (peak picking, half power); the dissertation, Sec. 5.4.1
and Tables 10, 19-21 (peak levels).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy import signal

from ..errors import MeasurementError


# --------------------------------------------------------------------------- helpers
def frf_arrays(freq_hz, h, name: str) -> tuple[np.ndarray, np.ndarray]:
    """An FRF's frequencies and values as arrays, checked.

    Parameters
    ----------
    freq_hz : array_like, shape (n_freq,)
        Frequencies [Hz], strictly increasing, at least 3.
    h : array_like, shape (n_freq,)
        FRF values (complex or magnitude).
    name : str
        FRF name for messages.

    Returns
    -------
    f : ndarray, shape (n_freq,)
    h : ndarray, shape (n_freq,)

    Raises
    ------
    MeasurementError
        Shapes that differ or are not 1-D, fewer than 3 lines, frequencies
        not increasing, non-finite values.
    """
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


def _log_magnitude(freq_hz, h, name: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """An FRF checked by :func:`frf_arrays`: its frequencies [Hz], ``|H|`` and ``ln|H|`` (``|H|`` floored at
    1e-300), each of shape (n_freq,); raises :class:`MeasurementError` as :func:`frf_arrays`."""
    f, hh = frf_arrays(freq_hz, h, name)
    mag = np.abs(hh)
    return f, mag, np.log(np.maximum(mag, 1e-300))


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


def _peak_at(f: np.ndarray, logm: np.ndarray, i: int) -> Peak:
    """The :class:`Peak` at line ``i`` of ``ln|H|`` (``logm``, shape (n_freq,)), refined by :func:`_refine`."""
    fp, lm = _refine(f, logm, i)
    return Peak(freq_hz=fp, magnitude=math.exp(lm), index=i)


def refine_peak(freq_hz, h, index: int, *, name: str = "frf") -> Peak:
    """Refine the peak at line ``index`` by a parabola through ``ln|H|`` of its three lines.

    Parameters
    ----------
    freq_hz, h, name
        As :func:`frf_arrays`.
    index : int
        Line of the local maximum.

    Returns
    -------
    Peak
        The line itself at the ends of the FRF or if the parabola opens upwards.

    Raises
    ------
    MeasurementError
        Bad arrays or index out of range.
    """
    f, _, logm = _log_magnitude(freq_hz, h, name)
    if not 0 <= index < f.size:
        raise MeasurementError(f"{name}: peak index {index} outside 0..{f.size - 1}")
    return _peak_at(f, logm, int(index))


def find_peaks(freq_hz, h, *, band_hz: tuple[float, float] | None = None, n_peaks: int | None = None,
               prominence_db: float = 3.0, name: str = "frf") -> list[Peak]:
    """Resonance peaks of ``|H|`` in a band.

    Local maxima of ``20 log10 |H|`` with at least ``prominence_db``
    prominence (:func:`scipy.signal.find_peaks`), each refined by a parabola
    through the log magnitude of its three lines.

    Parameters
    ----------
    freq_hz, h, name
        As :func:`frf_arrays`.
    band_hz : (float, float), optional
        Search band [Hz]; whole range by default.
    n_peaks : int, optional
        Keep the ``n_peaks`` most prominent.
    prominence_db : float
        Minimum prominence [dB].

    Returns
    -------
    list of Peak
        Sorted by frequency (possibly empty).

    Raises
    ------
    MeasurementError
        Bad arrays or an empty band.
    """
    f, mag, logm = _log_magnitude(freq_hz, h, name)
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
    return [_peak_at(f, logm, int(i)) for i in idx]


class _NoPeak(MeasurementError):
    """A search window holds lines but no peak (the mode does not show as a peak at this point)."""


def _level_at(f: np.ndarray, logm: np.ndarray, f0: float) -> float:
    """``|H|`` at ``f0`` [Hz], ``ln|H|`` (``logm``, shape (n_freq,)) interpolated between its lines."""
    return math.exp(float(np.interp(f0, f, logm)))


def _nearest_max(f: np.ndarray, mag: np.ndarray, near_hz: float, half_band_hz: float, name: str) -> int:
    """The highest peak of ``|H|`` (``mag``, shape (n_freq,)) within ``half_band_hz`` of ``near_hz`` [Hz]: a line
    inside the FRF at least as high as both its neighbours. The highest line of the window is not enough: where
    the mode shows no peak at the point (a closed-loop mode beside an antiresonance), it is the window's edge on
    a neighbouring mode's flank, and its level depends on where the window ends. Raises
    :class:`MeasurementError` when the window holds no line, :class:`_NoPeak` (one) when it holds no peak."""
    sel = np.flatnonzero((f >= near_hz - half_band_hz) & (f <= near_hz + half_band_hz))
    if sel.size == 0:
        raise MeasurementError(f"{name}: no line within {half_band_hz} Hz of {near_hz} Hz")
    inner = sel[(sel > 0) & (sel < f.size - 1)]
    peaks = inner[(mag[inner] >= mag[inner - 1]) & (mag[inner] >= mag[inner + 1])]
    if peaks.size == 0:
        raise _NoPeak(f"{name}: no peak of |H| (a line above both neighbours) within {half_band_hz:.4g} Hz "
                               f"of {near_hz:.4g} Hz: the mode does not show as a peak at this point")
    return int(peaks[np.argmax(mag[peaks])])


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
        Approximate peak frequency [Hz]; the highest peak (a line above both
        neighbours) within ``search_half_band_hz`` of it is used.
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
        :func:`vlab.measure.modal_fit.fit_modes`).

    Notes
    -----
    Source: Ewins, *Modal Testing*, 2nd ed., Sec. 4.3.
    """
    f, mag, logm = _log_magnitude(freq_hz, h, name)
    df = float(np.median(np.diff(f)))
    hb = max(0.05 * peak_hz, 2 * df) if search_half_band_hz is None else search_half_band_hz
    i = _nearest_max(f, mag, peak_hz, hb, name)
    fn, lm = _refine(f, logm, i)
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


# --------------------------------------------------------------------------- peak levels
def peak_levels(freq_hz, h, near_hz: Sequence[float], *, half_band_hz: float | Sequence[float],
                name: str = "frf") -> np.ndarray:
    """Peak magnitudes ``|H|`` near given frequencies (the dissertation's "peak levels").

    For each frequency the highest peak within ``half_band_hz`` (a line at
    least as high as both its neighbours) is refined by a parabola through
    ``ln|H|``; where the window holds no peak (a heavily damped mode, or one
    beside an antiresonance at this point), the level at the frequency
    itself, ``ln|H|`` interpolated between its lines (Sec. 5.4.1: "Peak
    levels ... were then determined at each natural frequency").

    Parameters
    ----------
    freq_hz, h, name
        As :func:`frf_arrays`.
    near_hz : sequence of float, shape (n_modes,)
        Natural frequencies [Hz] to look near.
    half_band_hz : float or sequence of float
        Search half width [Hz] (per mode or shared).

    Returns
    -------
    ndarray, shape (n_modes,)
        Peak levels in FRF units.

    Raises
    ------
    MeasurementError
        No line within the search band.
    """
    f, mag, logm = _log_magnitude(freq_hz, h, name)
    near = np.atleast_1d(np.asarray(near_hz, dtype=float))
    hbs = np.broadcast_to(np.asarray(half_band_hz, dtype=float), near.shape)
    out = np.empty(near.size)
    for k, (fk, hb) in enumerate(zip(near, hbs)):
        try:
            out[k] = _peak_at(f, logm, _nearest_max(f, mag, fk, hb, name)).magnitude
        except _NoPeak:  # a heavily damped mode, or one beside an antiresonance: the level at the frequency itself
            out[k] = _level_at(f, logm, fk)
    return out


def paired_peak_levels(freq_hz, h_analysis, h_experiment, near_analysis_hz: float, near_experiment_hz: float, *,
                       half_band_hz: float, name: str = "frf") -> tuple[float, float]:
    """One mode's peak levels in an analytical and a measured FRF, read by one rule on one window.

    The window spans both natural frequencies: centred between them, half width ``half_band_hz`` plus half
    their difference. Where both FRFs hold a peak there (a line at least as high as both neighbours), each
    level is its highest peak refined by a parabola through ``ln|H|``; where either holds none (a heavily
    damped mode, or one beside an antiresonance at this point), both are read at their own natural
    frequencies (``ln|H|`` interpolated). A ratio of a peak to a level read by the other rule, or on another
    window, compares two quantities: a 6 mHz offset of the natural frequency put a flank's maximum inside one
    window and outside the other.

    Parameters
    ----------
    freq_hz, name
        As :func:`frf_arrays`.
    h_analysis, h_experiment : array_like, complex, shape (n_freq,)
        The two FRFs on the same lines (same units).
    near_analysis_hz, near_experiment_hz : float
        The mode's natural frequency in each [Hz].
    half_band_hz : float
        Search half width [Hz] about each.

    Returns
    -------
    (float, float)
        The analytical and the measured level, in FRF units (Sec. 5.4.1).

    Raises
    ------
    MeasurementError
        Bad arrays, or no line within the window.
    """
    f, mag_a, log_a = _log_magnitude(freq_hz, h_analysis, name)
    _, mag_e, log_e = _log_magnitude(freq_hz, h_experiment, name)
    centre = 0.5 * (near_analysis_hz + near_experiment_hz)
    half = half_band_hz + 0.5 * abs(near_analysis_hz - near_experiment_hz)
    try:
        i_a, i_e = (_nearest_max(f, mag, centre, half, name) for mag in (mag_a, mag_e))
    except _NoPeak:
        return _level_at(f, log_a, near_analysis_hz), _level_at(f, log_e, near_experiment_hz)
    return _peak_at(f, log_a, i_a).magnitude, _peak_at(f, log_e, i_e).magnitude


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
