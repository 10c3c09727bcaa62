"""Mode shapes drawn on the structure's geometry (matplotlib, no display).

One panel per mode, the natural frequency in its title. The structure lies in the (x, y) plane (see
:mod:`vlab.spec`) and its modes move out of it (``w``): a structure whose points lie on a vertical or
horizontal line (the BCC) is drawn in 2-D, ``w`` against the position along the line (the way a beam's
mode shapes are drawn); any other (the grid) in 3-D, upright, ``w`` as the depth. Members are
the spec's polylines through its points; the deformed members are drawn through the shape's values at
the points, unscaled (the shapes are normalised, largest displacement +1), over the members at rest
(grey, dashed).

Like :mod:`vlab.viz.figures`, the figure is built on :class:`matplotlib.figure.Figure` with the Agg
canvas (no pyplot, no window). :func:`mode_shapes_axes` builds it and returns it (its deformed lines
carry ``gid`` ``"mode<r>:member<k>"``, r and k from 1); :func:`mode_shapes_figure` writes it to a file.

Source: Ewins, *Modal Testing* (2nd ed., 2000), Sec. 8.1 (display of mode shapes).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ModelError
from .figures import _save
from .rerun_structure import _member_rows, _points_table

__all__ = ["mode_shapes_axes", "mode_shapes_figure", "line_positions", "shape_comparison_figure"]


def _line_axis(xy: np.ndarray) -> int | None:
    """0 when every point has the same y (a horizontal line), 1 for the same x (vertical), else None."""
    ptp = np.ptp(xy, axis=0) if len(xy) > 1 else np.zeros(2)
    size = max(float(np.max(ptp)), 1e-12)
    if ptp[0] <= 1e-9 * size:
        return 1
    if ptp[1] <= 1e-9 * size:
        return 0
    return None


def _check(ids: list[int], w: Any, freq_hz: Any) -> tuple[np.ndarray, np.ndarray]:
    w = np.asarray(w, dtype=float)
    f = np.asarray(freq_hz, dtype=float).reshape(-1)
    if w.ndim != 2 or w.shape[0] != len(ids) or w.shape[1] != f.size or f.size == 0:
        raise ModelError(f"mode shapes: expected w of shape ({len(ids)}, n_modes) and freq_hz of shape (n_modes,), "
                         f"n_modes >= 1; got {w.shape} and {f.shape}")
    if not (np.all(np.isfinite(w)) and np.all(np.isfinite(f))):
        raise ModelError("mode shapes: non-finite shape value or frequency")
    return w, f


def mode_shapes_axes(structure_points: Mapping[int, Sequence[float]], members: Sequence[Any], point_ids: Sequence[int],
                     w: Any, freq_hz: Any, *, title: str = "", ncols: int | None = None, dpi: float = 120.0):
    """Build the figure of the mode shapes, one panel per mode.

    Parameters
    ----------
    structure_points : mapping of int to (float, float)
        Point id -> (x, y) [m] (:func:`vlab.viz.rerun_structure.structure_geometry`).
    members : sequence
        Point-id polylines, or objects with ``points`` (:class:`vlab.spec.Member`).
    point_ids : sequence of int, length n_points
        The point of each row of ``w``; every member point must be among them.
    w : array_like, shape (n_points, n_modes)
        Out-of-plane shape of each mode at the points [1] (e.g. :attr:`vlab.fe.point_shapes.PointShapes.w`).
    freq_hz : array_like, shape (n_modes,)
        Natural frequency of each mode [Hz], shown in its panel's title.
    title : str
        Figure title.
    ncols : int, optional
        Panels per row; default up to 4 (3 for 3-D panels).
    dpi : float
        Resolution [dots per inch].

    Returns
    -------
    matplotlib.figure.Figure
        With an Agg canvas; panel ``r`` (from 0) is ``fig.axes[r]``.

    Raises
    ------
    ModelError
        Unknown point ids, malformed members, or ``w`` / ``freq_hz`` of the wrong shape or not finite.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    ids, xy = _points_table(structure_points, point_ids)
    rows = _member_rows(members, ids)
    w, f = _check(ids, w, freq_hz)
    axis = _line_axis(xy)
    n = f.size
    nc = ncols or min(n, 4 if axis is not None else 3)
    nr = math.ceil(n / nc)
    panel = (2.4, 3.4) if axis == 1 else (3.4, 2.8)
    fig = Figure(figsize=(panel[0] * nc, panel[1] * nr + 0.4), dpi=dpi, layout="constrained")
    FigureCanvasAgg(fig)
    for r in range(n):
        if axis is None:
            ax = fig.add_subplot(nr, nc, r + 1, projection="3d")
            _draw_3d(ax, xy, rows, w[:, r], r)
        else:
            ax = fig.add_subplot(nr, nc, r + 1)
            _draw_line(ax, xy, rows, w[:, r], r, axis)
        ax.set_title(f"mode {r + 1}: {f[r]:.3f} Hz", fontsize="medium")
    if title:
        fig.suptitle(title)
    return fig


def _draw_line(ax, xy: np.ndarray, rows: list[np.ndarray], w: np.ndarray, r: int, axis: int) -> None:
    """2-D panel: ``w`` against the coordinate along the line (vertical line: w on x, y on y)."""
    for k, rr in enumerate(rows):
        s = xy[rr, axis]
        pair = ((np.zeros_like(s), s), (w[rr], s)) if axis == 1 else ((s, np.zeros_like(s)), (s, w[rr]))
        ax.plot(*pair[0], color="0.6", ls="--", lw=1.0)
        ax.plot(*pair[1], color="C0", lw=1.6, marker="o", ms=3.5, gid=f"mode{r + 1}:member{k + 1}")
    lim = (-1.15, 1.15)
    if axis == 1:
        ax.set_xlim(*lim)
        ax.set_xlabel("w [normalised]")
        ax.set_ylabel("y [m]")
    else:
        ax.set_ylim(*lim)
        ax.set_ylabel("w [normalised]")
        ax.set_xlabel("x [m]")
    ax.grid(True, alpha=0.3)


def _draw_3d(ax, xy: np.ndarray, rows: list[np.ndarray], w: np.ndarray, r: int) -> None:
    """3-D panel, the structure upright: members at rest in the (x, y) plane, deformed ones moved by ``w``.

    Matplotlib's axes are (x, w, y): the structure's y is drawn vertical, ``w`` is the depth.
    """
    for k, rr in enumerate(rows):
        ax.plot(xy[rr, 0], np.zeros(len(rr)), xy[rr, 1], color="0.6", ls="--", lw=0.8)
        ax.plot(xy[rr, 0], w[rr], xy[rr, 1], color="C0", lw=1.4, marker="o", ms=2.5,
                gid=f"mode{r + 1}:member{k + 1}")
    ax.set_ylim(-1.15, 1.15)
    ptp = np.ptp(xy, axis=0)
    ax.set_box_aspect((max(ptp[0], 1e-3), 0.5 * max(ptp.max(), 1e-3), max(ptp[1], 1e-3)))
    ax.set_xlabel("x [m]", fontsize="small")
    ax.set_ylabel("w", fontsize="small")
    ax.set_zlabel("y [m]", fontsize="small")
    ax.tick_params(labelsize="x-small")
    ax.view_init(elev=12, azim=-62)


def mode_shapes_figure(structure_points: Mapping[int, Sequence[float]], members: Sequence[Any],
                       point_ids: Sequence[int], w: Any, freq_hz: Any, path: str | Path, *, title: str = "",
                       dpi: float = 120.0) -> Path:
    """Write the mode shapes drawn on the structure (:func:`mode_shapes_axes`) to ``path`` and return ``path``.

    ``structure_points``, ``members``, ``point_ids``, ``w``, ``freq_hz``, ``title`` and ``dpi`` are those of
    :func:`mode_shapes_axes`; ``path`` ends in ``.png``, ``.svg`` or ``.pdf`` (parent folders are created).
    Raises ModelError as :func:`mode_shapes_axes`, DataFileError for another file suffix.
    """
    fig = mode_shapes_axes(structure_points, members, point_ids, w, freq_hz, title=title, dpi=dpi)
    return _save(fig, path, dpi)


def line_positions(structure_points: Mapping[int, Sequence[float]], point_ids: Sequence[int]) -> np.ndarray | None:
    """Position of each point along the structure's line [m] when all its points lie on one vertical or
    horizontal line (the BCC: the height), else None.

    Parameters
    ----------
    structure_points : mapping of int to (float, float)
        Point id -> (x, y) [m] of every point of the structure.
    point_ids : sequence of int, length n_points
        The points wanted.

    Returns
    -------
    ndarray, shape (n_points,) or None

    Raises
    ------
    ModelError
        A point id not in ``structure_points``.
    """
    ids, xy = _points_table(structure_points, list(structure_points))
    axis = _line_axis(xy)
    if axis is None:
        return None
    missing = [p for p in point_ids if p not in ids]
    if missing:
        raise ModelError(f"point ids {missing} are not points of the structure {sorted(ids)}")
    return np.array([xy[ids.index(p), axis] for p in point_ids], dtype=float)


def shape_comparison_figure(point_ids: Sequence[int], w_identified: Any, freq_hz: Any, w_model: Any, mac: Any,
                            path: str | Path, *, positions: Any = None, title: str = "", dpi: float = 120.0) -> Path:
    """Identified mode shapes at the measured points beside the paired model shapes, one panel per mode.

    Each panel draws the identified shape (markers, solid) and the model's (dashed), both scaled to a
    largest displacement of +1, the model's sign turned to agree with the identified one (a shape's sign is
    arbitrary), against the position of the points (or their order when no positions are given); its title
    gives the identified frequency and the MAC of the pair.

    Parameters
    ----------
    point_ids : sequence of int, length n_points
        Measured points, in row order.
    w_identified : array_like, shape (n_points, n_modes)
        Identified shapes [-] (e.g. :attr:`vlab.measure.shapes.IdentifiedShapes.shapes`).
    freq_hz : array_like, shape (n_modes,)
        Identified natural frequencies [Hz].
    w_model : array_like, shape (n_points, n_modes)
        The paired model shape of each identified mode (any scale); a NaN column for an unpaired mode.
    mac : array_like, shape (n_modes,)
        MAC of each pair [-] (NaN when unpaired).
    path : str or Path
        ``.png``, ``.svg`` or ``.pdf`` file (parent folders are created).
    positions : array_like, shape (n_points,), optional
        Position of each point along the structure [m] (:func:`line_positions`); default the row order.
    title : str
        Figure title.
    dpi : float
        Resolution [dots per inch].

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    ModelError
        Arrays of the wrong shape, a non-finite identified shape or frequency.
    DataFileError
        Another file suffix.

    Source: Ewins, *Modal Testing* (2nd ed., 2000), Secs. 8.1-8.2 (display and correlation of shapes).
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    ids = [int(p) for p in point_ids]
    w, f = _check(ids, w_identified, freq_hz)
    wm = np.asarray(w_model, dtype=float)
    m = np.asarray(mac, dtype=float).reshape(-1)
    x = np.arange(len(ids), dtype=float) if positions is None else np.asarray(positions, dtype=float)
    if wm.shape != w.shape or m.size != f.size or x.shape != (len(ids),):
        raise ModelError(f"shape comparison: w_model {wm.shape}, mac {m.shape} and positions {x.shape} must match "
                         f"w_identified {w.shape}")
    order = np.argsort(x, kind="stable")
    nc = min(f.size, 4)
    nr = math.ceil(f.size / nc)
    fig = Figure(figsize=(3.2 * nc, 2.7 * nr + 0.5), dpi=dpi, layout="constrained")
    FigureCanvasAgg(fig)
    for r in range(f.size):
        ax = fig.add_subplot(nr, nc, r + 1)
        ax.axhline(0.0, color="0.7", lw=0.8)
        ax.plot(x[order], w[order, r], "o-", color="C0", label="identified")
        col = wm[:, r]
        if np.all(np.isfinite(col)) and np.any(col != 0):
            col = col / col[np.argmax(np.abs(col))]
            col = -col if col @ w[:, r] < 0 else col
            ax.plot(x[order], col[order], "s--", color="C1", mfc="none", label="model")
        ax.set_title(f"mode {r + 1}: {f[r]:.3f} Hz, MAC {m[r]:.3f}", fontsize="medium")
        ax.set_xticks(x[order], [str(ids[i]) for i in order])
        ax.set_xlabel("point" if positions is None else "point (at its position)")
        if r == 0:
            ax.legend(fontsize="small")
    if title:
        fig.suptitle(title)
    return _save(fig, path, dpi)
