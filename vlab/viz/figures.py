"""Static figures (PNG/SVG/PDF) with matplotlib, without a display.

The FRF figures follow the dissertation's Figs. 22-31: FRF magnitude on a
logarithmic axis against frequency on a linear axis (e.g. Fig. 23: 0-10 Hz,
0.1-1000 (in/s)/lbf), analysis and experiment of the same FRF in one plot;
here analysis is dashed and drawn over the solid experimental curve.

The figures are built on :class:`matplotlib.figure.Figure` with the Agg
canvas directly, not through ``pyplot``: no global backend is selected, no
window is opened, nothing is kept alive after the file is written, and
importing this module changes no matplotlib state.

Every function writes one file and returns its path. The pixel size of a
PNG is exactly ``figsize * dpi`` (constrained layout, no tight bounding box).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import DataFileError, MeasurementError

__all__ = ["comparison_bar", "frf_figure", "frf_panels_figure", "misfit_overlay"]

_FORMATS = {".png": "png", ".svg": "svg", ".pdf": "pdf"}
#: Labels containing one of these words are drawn dashed by :func:`frf_figure` (analysis over experiment).
ANALYSIS_WORDS = ("analysis", "analytical", "model", "fe", "predicted")


def _new_figure(figsize: tuple[float, float], dpi: float, nrows: int = 1, **subplot_kw: Any):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize, dpi=dpi, layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(nrows, 1, squeeze=False, **subplot_kw)[:, 0]
    return fig, axes


def _save(fig, path: str | Path, dpi: float) -> Path:
    p = Path(path)
    fmt = _FORMATS.get(p.suffix.lower())
    if fmt is None:
        raise DataFileError(f"{p}: figure format {p.suffix!r} not supported; use one of {sorted(_FORMATS)}")
    p.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(p, dpi=dpi, format=fmt)
    return p


def _magnitude(values: Any, what: str, n: int | None) -> np.ndarray:
    """|values| as float, 1-D of length n; zeros become NaN (no point on a log axis)."""
    v = np.asarray(values)
    if v.ndim != 1 or (n is not None and v.size != n):
        expect = f"({n},)" if n is not None else "(n_freq,)"
        raise MeasurementError(f"{what}: expected shape {expect}, got {v.shape}")
    if not np.all(np.isfinite(v)):
        raise MeasurementError(f"{what}: non-finite values")
    mag = np.abs(v).astype(float)
    mag[mag == 0.0] = np.nan
    return mag


def _freq(values: Any, what: str) -> np.ndarray:
    f = np.asarray(values, dtype=float)
    if f.ndim != 1 or f.size < 2:
        raise MeasurementError(f"{what}: expected a 1-D array of at least 2 frequencies [Hz], got shape {f.shape}")
    if not np.all(np.isfinite(f)) or np.any(np.diff(f) <= 0):
        raise MeasurementError(f"{what}: frequencies must be finite and strictly increasing")
    return f


def _curve(label: str, value: Any, freq_hz: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """(freq, magnitude) of one curve: an array on ``freq_hz``, a (freq, values) pair or an FRF object."""
    if hasattr(value, "freq_hz") and hasattr(value, "h"):
        f = _freq(value.freq_hz, f"curve {label!r} freq_hz")
        return f, _magnitude(value.h, f"curve {label!r}", f.size)
    if isinstance(value, tuple) and len(value) == 2:
        f = _freq(value[0], f"curve {label!r} freq_hz")
        return f, _magnitude(value[1], f"curve {label!r}", f.size)
    if freq_hz is None:
        raise MeasurementError(f"curve {label!r}: freq_hz is None, so the curve must be a (freq_hz, values) pair")
    return freq_hz, _magnitude(value, f"curve {label!r}", freq_hz.size)


def _is_analysis(label: str) -> bool:
    words = label.lower().replace("-", " ").replace("_", " ").split()
    return any(w in ANALYSIS_WORDS for w in words)


def _curve_styles(labels: Sequence[str], dashed: set[str]) -> dict[str, dict[str, Any]]:
    """Line style of each FRF curve, in drawing order: measured (solid) first, analysis (dashed, wider) over them.

    Colours ``C0``, ``C1``, ... follow the order of ``labels``, not the drawing order.
    """
    color_of = {lb: f"C{i % 10}" for i, lb in enumerate(labels)}
    order = [lb for lb in labels if lb not in dashed] + [lb for lb in labels if lb in dashed]
    return {lb: dict(color=color_of[lb], lw=1.6 if lb in dashed else 1.2, ls="--" if lb in dashed else "-",
                     zorder=2 + z) for z, lb in enumerate(order)}


def _frequency_axis(ax, f_lo: float, f_hi: float, log_freq: bool) -> None:
    """Set the frequency axis to [f_lo, f_hi] Hz, logarithmic when ``log_freq`` (lines at 0 Hz or below
    are left out of a log axis: its lower limit is the first positive frequency, given as ``f_lo``)."""
    if log_freq:
        ax.set_xscale("log")
        ax.grid(True, which="minor", axis="x", alpha=0.15)
    ax.set_xlim(f_lo, f_hi)


def _x_range(f: np.ndarray, log_freq: bool) -> tuple[float, float]:
    """The plotted frequency range [Hz] of lines ``f``: from the first positive line on a log axis."""
    if log_freq:
        pos = f[f > 0]
        if pos.size < 2:
            raise MeasurementError("log frequency axis: fewer than two lines above 0 Hz")
        return float(pos[0]), float(f[-1])
    return float(f[0]), float(f[-1])


def frf_figure(freq_hz: Any, curves: Mapping[str, Any], title: str = "", ylabel: str = "|H|",
               path: str | Path = "frf.png", *, dashed: Sequence[str] | None = None,
               peaks_hz: Mapping[str, Sequence[float]] | None = None,
               xlim_hz: tuple[float, float] | None = None, ylim: tuple[float, float] | None = None,
               xlabel: str = "Frequency [Hz]", figsize: tuple[float, float] = (7.0, 4.5),
               dpi: float = 120.0, log_freq: bool = False) -> Path:
    """Log-magnitude FRF plot in the style of the dissertation's Figs. 22-31.

    Parameters
    ----------
    freq_hz : array_like, shape (n_freq,), or None
        Common frequency grid [Hz], strictly increasing. May be None when
        every curve carries its own grid.
    curves : mapping of str to FRF
        Legend label -> one of: an array shape (n_freq,) on ``freq_hz``
        (complex FRF or magnitude; ``|.|`` is plotted); a pair
        ``(freq_hz_i, values_i)`` on its own grid; an object with
        ``freq_hz`` and ``h`` (:class:`vlab.io.frf.FRF`). Plotted in
        the given order; zero magnitudes are left out (log axis).
    title, ylabel : str
        Axes title and y label (give the unit, e.g. ``"|H| [(m/s)/N]"``).
    path : str or Path
        Output file, ``.png``, ``.svg`` or ``.pdf``; parent folders are created.
    dashed : sequence of str, optional
        Labels drawn dashed (analysis). Default: labels containing a word
        of :data:`ANALYSIS_WORDS` ("analysis", "model", ...). Dashed curves
        are drawn over solid ones.
    peaks_hz : mapping of str to sequence of float, optional
        Label -> frequencies [Hz] to mark on that curve (e.g. the modal
        frequencies), at the curve's magnitude interpolated in log.
    xlim_hz, ylim : (float, float), optional
        Axis limits ([Hz]; magnitude in the FRF's unit). Default: the data.
    xlabel : str
        x label.
    figsize : (float, float)
        Figure size [in]; the PNG is ``figsize * dpi`` pixels.
    dpi : float
        Resolution [dots per inch].
    log_freq : bool
        Frequency on a logarithmic axis (lines at 0 Hz left out) instead of the dissertation's linear one.

    Returns
    -------
    Path
        ``path``, the FRF magnitude figure.

    Raises
    ------
    MeasurementError
        No curves, a curve whose shape does not match its frequency grid
        (names the curve), non-finite values, non-increasing frequencies,
        or a ``peaks_hz``/``dashed`` label that is not a curve.
    DataFileError
        Unsupported file suffix.
    """
    if not curves:
        raise MeasurementError("frf_figure: no curves to plot")
    f_common = None if freq_hz is None else _freq(freq_hz, "freq_hz")
    data = {label: _curve(label, v, f_common) for label, v in curves.items()}
    dashed_set = {lb for lb in curves if _is_analysis(lb)} if dashed is None else set(dashed)
    for lb in list(dashed_set) + list(peaks_hz or {}):
        if lb not in data:
            raise MeasurementError(f"frf_figure: label {lb!r} is not a curve; curves: {list(data)}")

    fig, (ax,) = _new_figure(figsize, dpi)
    styles = _curve_styles(list(data), dashed_set)
    for lb, style in styles.items():
        f, mag = data[lb]
        ax.semilogy(f, mag, label=lb, **style)
    for lb, fp in (peaks_hz or {}).items():
        f, mag = data[lb]
        fp = np.asarray(fp, dtype=float)
        with np.errstate(invalid="ignore"):
            m = 10.0 ** np.interp(fp, f, np.log10(mag))
        ax.plot(fp, m, ls="none", marker="v", ms=6, color=styles[lb]["color"], zorder=10 + len(styles))
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    if title:
        ax.set_title(title)
    if xlim_hz is not None:
        _frequency_axis(ax, *xlim_hz, log_freq)
    else:
        ranges = [_x_range(d[0], log_freq) for d in data.values()]
        _frequency_axis(ax, min(r[0] for r in ranges), max(r[1] for r in ranges), log_freq)
    if ylim is not None:
        ax.set_ylim(*ylim)
    ax.grid(True, which="major", alpha=0.4)
    ax.grid(True, which="minor", alpha=0.15)
    ax.legend(loc="best", fontsize="small")
    return _save(fig, path, dpi)


def frf_panels_figure(freq_hz: Any, curves: Mapping[str, Any], coherence: Any, *, unit: str,
                      path: str | Path = "frf.png", title: str = "",
                      figsize: tuple[float, float] = (7.0, 7.5), dpi: float = 120.0, log_freq: bool = False) -> Path:
    """FRF magnitude, phase and coherence in three panels sharing the frequency axis.

    The magnitude is drawn on a log axis as the dissertation's Figs. 22-31;
    curves whose label contains a word of :data:`ANALYSIS_WORDS` are dashed
    and drawn over the measured (solid) ones. The phase is ``angle(H)`` in
    degrees, the coherence the H1 estimate's ordinary coherence gamma^2.

    Parameters
    ----------
    freq_hz : array_like, shape (n_freq,)
        Frequency lines [Hz], strictly increasing (the excited band).
    curves : mapping of str to array_like
        Legend label -> complex FRF, shape (n_freq,), in ``unit``.
    coherence : array_like, shape (n_freq,)
        Coherence [-] of the measured FRF, in [0, 1].
    unit : str
        Unit of the FRF values, e.g. ``"(m/s)/N"``, written on the magnitude axis.
    path : str or Path
        Output file, ``.png``, ``.svg`` or ``.pdf``; parent folders are created.
    title : str
        Figure title.
    figsize, dpi, log_freq
        As :func:`frf_figure`.

    Returns
    -------
    Path
        ``path``, the magnitude, phase and coherence figure.

    Raises
    ------
    MeasurementError
        No curves, a curve or the coherence whose shape does not match
        ``freq_hz`` (names it), non-finite values, coherence outside [0, 1].
    DataFileError
        Unsupported file suffix.
    """
    if not curves:
        raise MeasurementError("frf_panels_figure: no curves to plot")
    f = _freq(freq_hz, "freq_hz")
    data = {}
    for lb, v in curves.items():
        h = np.asarray(v)
        if h.shape != f.shape:
            raise MeasurementError(f"curve {lb!r}: expected shape {f.shape}, got {h.shape}")
        if not np.all(np.isfinite(h)):
            raise MeasurementError(f"curve {lb!r}: non-finite values")
        data[lb] = h.astype(complex)
    coh = np.asarray(coherence, dtype=float)
    if coh.shape != f.shape:
        raise MeasurementError(f"coherence: expected shape {f.shape}, got {coh.shape}")
    if not np.all(np.isfinite(coh)) or np.any(coh < -1e-12) or np.any(coh > 1 + 1e-9):
        raise MeasurementError("coherence: values must be finite and within [0, 1]")
    fig, (ax_m, ax_p, ax_c) = _new_figure(figsize, dpi, nrows=3, sharex=True)
    for lb, style in _curve_styles(list(data), {lb for lb in data if _is_analysis(lb)}).items():
        h = data[lb]
        mag = np.abs(h)
        mag[mag == 0] = np.nan
        ax_m.semilogy(f, mag, label=lb, **style)
        ax_p.plot(f, np.degrees(np.angle(h)), **style)
    ax_c.plot(f, coh, color="C0", lw=1.2)
    ax_m.set_ylabel(f"|H| [{unit}]")
    ax_p.set_ylabel("phase [deg]")
    ax_p.set_ylim(-180, 180)
    ax_p.set_yticks([-180, -90, 0, 90, 180])
    ax_c.set_ylabel("coherence [-]")
    ax_c.set_ylim(0, 1.05)
    ax_c.set_xlabel("Frequency [Hz]")
    _frequency_axis(ax_c, *_x_range(f, log_freq), log_freq)
    for ax in (ax_m, ax_p, ax_c):
        ax.grid(True, which="major", alpha=0.4)
    ax_m.legend(loc="best", fontsize="small")
    if title:
        ax_m.set_title(title)
    return _save(fig, path, dpi)


def _log_misfit(measured: np.ndarray, model: np.ndarray) -> np.ndarray:
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.log10(model) - np.log10(measured)


def misfit_overlay(freq_hz: Any, measured: Any, before: Any, after: Any, *, title: str = "",
                   ylabel: str = "|H|", path: str | Path = "misfit.png",
                   labels: tuple[str, str, str] = ("measured", "model before", "model after"),
                   xlim_hz: tuple[float, float] | None = None, figsize: tuple[float, float] | None = None,
                   dpi: float = 120.0, phase: bool = False, log_freq: bool = False) -> Path:
    """Measured FRF with the model before and after a fit, and their log-magnitude misfit.

    Top panel: ``|H|`` on a log axis, measured solid black, model before
    dashed red, model after dashed blue. With ``phase``, a second panel: the
    phase ``angle(H)`` [deg] of the three in the same styles. Bottom panel: the misfit
    ``e(f) = log10|H_model(f)| - log10|H_measured(f)|`` (decades; 0.1 is
    26 %) before and after, with its root mean square over the plotted band
    in the legend.

    Parameters
    ----------
    freq_hz : array_like, shape (n_freq,)
        Frequency grid [Hz], strictly increasing, common to all three.
    measured, before, after : array_like, shape (n_freq,)
        Complex FRFs or magnitudes in the same unit (complex with ``phase``).
    title, ylabel : str
        Title and y label of the top panel.
    path : str or Path
        Output file (``.png``, ``.svg``, ``.pdf``).
    labels : (str, str, str)
        Legend labels of measured, before, after.
    xlim_hz : (float, float), optional
        Frequency band shown and used for the RMS [Hz].
    figsize : (float, float), optional
        Figure size [in]; default (7, 6), (7, 8) with ``phase``.
    dpi, log_freq
        As :func:`frf_figure`.
    phase : bool
        Add the phase panel.

    Returns
    -------
    Path
        ``path``, the overlay and misfit figure.

    Raises
    ------
    MeasurementError
        An array whose shape is not ``(n_freq,)`` (named: ``measured``,
        ``before`` or ``after``), non-finite values; with ``phase``, an array that is not complex.
    DataFileError
        Unsupported file suffix.
    """
    f = _freq(freq_hz, "freq_hz")
    meas = _magnitude(measured, "measured", f.size)
    b = _magnitude(before, "before", f.size)
    a = _magnitude(after, "after", f.size)
    band = np.ones(f.size, bool) if xlim_hz is None else (f >= xlim_hz[0]) & (f <= xlim_hz[1])
    e_b, e_a = _log_misfit(meas, b), _log_misfit(meas, a)

    def rms(e: np.ndarray) -> float:
        v = e[band & np.isfinite(e)]
        return float(np.sqrt(np.mean(v**2))) if v.size else float("nan")

    styles = ({"color": "k", "ls": "-", "lw": 1.3, "zorder": 2}, {"color": "tab:red", "ls": "--", "lw": 1.3, "zorder": 3},
              {"color": "tab:blue", "ls": "--", "lw": 1.5, "zorder": 4})
    complex_h = [np.asarray(v) for v in (measured, before, after)]
    if phase:
        for name, v in zip(("measured", "before", "after"), complex_h):
            if not np.iscomplexobj(v):
                raise MeasurementError(f"{name}: the phase panel needs a complex FRF, got {v.dtype} values")
    ratios = (2.0, 1.0, 1.0) if phase else (2.0, 1.0)
    fig, axes = _new_figure(figsize or ((7.0, 8.0) if phase else (7.0, 6.0)), dpi, nrows=len(ratios), sharex=True,
                            gridspec_kw={"height_ratios": ratios})
    ax, ax2 = axes[0], axes[-1]
    for mag, lb, st in zip((meas, b, a), labels, styles):
        ax.semilogy(f, mag, label=lb, **st)
    if phase:
        for v, st in zip(complex_h, styles):
            axes[1].plot(f, np.degrees(np.angle(v)), **st)
        axes[1].set_ylabel("phase [deg]")
        axes[1].set_ylim(-180, 180)
        axes[1].set_yticks([-180, -90, 0, 90, 180])
        axes[1].grid(True, alpha=0.4)
    ax.set_ylabel(ylabel)
    if title:
        ax.set_title(title)
    ax.grid(True, which="major", alpha=0.4)
    ax.legend(loc="best", fontsize="small")
    ax2.axhline(0.0, color="k", lw=0.8)
    ax2.plot(f, e_b, color="tab:red", ls="--", lw=1.1, label=f"{labels[1]}: RMS {rms(e_b):.3g}")
    ax2.plot(f, e_a, color="tab:blue", ls="--", lw=1.3, label=f"{labels[2]}: RMS {rms(e_a):.3g}")
    ax2.set_ylabel("log10 misfit [decades]")
    ax2.set_xlabel("Frequency [Hz]")
    ax2.grid(True, alpha=0.4)
    ax2.legend(loc="best", fontsize="small")
    _frequency_axis(ax2, *(xlim_hz if xlim_hz is not None else _x_range(f, log_freq)), log_freq)
    return _save(fig, path, dpi)


def comparison_bar(labels: Sequence[str], before: Any, after: Any, *, title: str = "",
                   ylabel: str = "", path: str | Path = "comparison.png",
                   names: tuple[str, str] = ("before", "after"), reference: Any = None,
                   reference_name: str = "measured", figsize: tuple[float, float] = (7.0, 4.0),
                   dpi: float = 120.0) -> Path:
    """Grouped bars of one quantity per item before and after a fit (optionally with the measured value).

    Typical use: per-mode frequency error [%] or peak-level ratio (Tables
    20-21) before and after a diagnosis fit.

    Parameters
    ----------
    labels : sequence of str, shape (n_items,)
        Item names on the x axis (``"mode 1"``, ...).
    before, after : array_like, shape (n_items,)
        Values before and after.
    title, ylabel : str
        Title and y label (give the unit).
    path : str or Path
        Output file (``.png``, ``.svg``, ``.pdf``).
    names : (str, str)
        Legend names of ``before`` and ``after``.
    reference : array_like, shape (n_items,), optional
        A third bar per item, e.g. the measured value.
    reference_name : str
        Legend name of ``reference``.
    figsize, dpi
        As :func:`frf_figure`.

    Returns
    -------
    Path
        ``path``, the bar chart.

    Raises
    ------
    MeasurementError
        No labels, or ``before``/``after``/``reference`` not of shape
        ``(n_items,)`` or not finite (names the array).
    DataFileError
        Unsupported file suffix.
    """
    labels = [str(x) for x in labels]
    n = len(labels)
    if n == 0:
        raise MeasurementError("comparison_bar: no labels")
    series = [(names[0], before, "before"), (names[1], after, "after")]
    if reference is not None:
        series.insert(0, (reference_name, reference, "reference"))
    values = []
    for _, v, what in series:
        arr = np.asarray(v, dtype=float)
        if arr.shape != (n,):
            raise MeasurementError(f"{what}: expected shape ({n},) (one value per label), got {arr.shape}")
        if not np.all(np.isfinite(arr)):
            raise MeasurementError(f"{what}: non-finite values")
        values.append(arr)
    colors = {"reference": "0.3", "before": "tab:red", "after": "tab:blue"}

    fig, (ax,) = _new_figure(figsize, dpi)
    x = np.arange(n)
    width = 0.8 / len(series)
    for i, ((name, _, what), arr) in enumerate(zip(series, values)):
        ax.bar(x + (i - (len(series) - 1) / 2) * width, arr, width, label=name, color=colors[what])
    ax.axhline(0.0, color="k", lw=0.8)
    ax.set_xticks(x, labels, rotation=30 if n > 8 else 0)
    ax.set_ylabel(ylabel)
    if title:
        ax.set_title(title)
    ax.grid(True, axis="y", alpha=0.4)
    ax.legend(loc="best", fontsize="small")
    return _save(fig, path, dpi)


def point_value_map(spec, values: Mapping[int, float], path: str | Path, *, label: str, title: str = "",
                    figsize: tuple[float, float] = (7.0, 4.0), dpi: float = 120) -> Path:
    """A value per point drawn on the structure's plan: members as lines, points coloured on a log scale.

    Parameters
    ----------
    spec : StructureSpec
        Its ``points`` (id -> (x, y) [m]) and ``members`` (each with ``points``).
    values : mapping of int to float
        Point id -> positive value (its unit in ``label``); each point is annotated with it.
    path : str or Path
        ``.png``, ``.svg`` or ``.pdf``.
    label : str
        Colour-bar label (``log10`` of it is coloured).
    title : str
    figsize, dpi
        As :func:`frf_figure`.

    Returns
    -------
    Path
        ``path``, the map of the structure.

    Raises
    ------
    DataFileError
        An unknown point id, a value that is not positive and finite, or an unsupported format.
    """
    pts = sorted(values)
    unknown = [p for p in pts if p not in spec.points]
    if unknown:
        raise DataFileError(f"{path}: points {unknown} are not points of {spec.name}")
    vals = np.array([float(values[p]) for p in pts])
    if vals.size == 0 or not np.all(np.isfinite(vals) & (vals > 0)):
        raise DataFileError(f"{path}: values to draw must be positive and finite, got {vals.tolist()}")
    fig, (ax,) = _new_figure(figsize, dpi)
    for m in spec.members:
        xy = np.array([spec.points[p] for p in m.points])
        ax.plot(xy[:, 0], xy[:, 1], color="0.6", lw=2, zorder=1)
    xy = np.array([spec.points[p] for p in pts])
    sc = ax.scatter(xy[:, 0], xy[:, 1], c=np.log10(vals), cmap="viridis_r", s=90, zorder=2)
    for (x, y), p, v in zip(xy, pts, vals):
        ax.annotate(f"{p}: {v:.2g}", (x, y), textcoords="offset points", xytext=(5, 6), fontsize=8)
    fig.colorbar(sc, ax=ax, label=f"log10 {label}")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    if title:
        ax.set_title(title)
    return _save(fig, path, dpi)
