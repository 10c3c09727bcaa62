"""The structure in a rerun recording: its members at rest and its animated deformed shape.

The structure lies in the (x, y) plane, y up (see :mod:`vlab.spec`); the
out-of-plane displacement ``w`` is drawn along z, multiplied by a scale
factor so that it is visible (:func:`auto_scale`). The animation is
decimated to a frame rate (:func:`frame_indices`) and written columnar on
the ``sim_time`` timeline (entity paths in :mod:`vlab.viz.rerun_log`).

Source: rerun-sdk 0.41 Python API (``LineStrips3D``, ``Points3D``,
``send_columns``, ``TimeColumn``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ..errors import MeasurementError, ModelError
from .rerun_common import (MEMBER_COLOR, POINT_COLOR, SIM_TIMELINE, STRUCTURE_MEMBERS, STRUCTURE_POINTS,
                           STRUCTURE_UNDEFORMED, UNDEFORMED_COLOR, positive_number, rerun_module)

def structure_geometry(spec) -> tuple[dict[int, tuple[float, float]], tuple[tuple[int, ...], ...]]:
    """Points and member polylines of a :class:`~vlab.spec.StructureSpec`.

    Returns
    -------
    points : dict of int to (float, float)
        Point id -> (x, y) [m], in the spec's order.
    members : tuple of tuple of int
        Point ids of each member polyline.
    """
    return dict(spec.points), tuple(tuple(m.points) for m in spec.members)


def _points_table(structure_points: Mapping[int, Sequence[float]],
                  point_ids: Sequence[int] | None) -> tuple[list[int], np.ndarray]:
    if not structure_points:
        raise ModelError("structure_points is empty")
    ids = list(structure_points) if point_ids is None else [int(p) for p in point_ids]
    if len(set(ids)) != len(ids):
        raise ModelError(f"point_ids: duplicate point id(s) {sorted({p for p in ids if ids.count(p) > 1})}")
    xy = np.empty((len(ids), 2))
    for i, p in enumerate(ids):
        if p not in structure_points:
            raise ModelError(f"point_ids: unknown point id {p}; structure points are {sorted(structure_points)}")
        c = np.asarray(structure_points[p], dtype=float)
        if c.shape != (2,) or not np.all(np.isfinite(c)):
            raise ModelError(f"structure_points[{p}]: expected finite (x, y) [m], got {structure_points[p]!r}")
        xy[i] = c
    return ids, xy


def _member_rows(members: Sequence[Any], ids: Sequence[int]) -> list[np.ndarray]:
    """Row indices (into ``ids``) of each member polyline; members are id sequences or have ``.points``."""
    if not members:
        raise ModelError("members is empty: nothing to draw")
    index = {p: i for i, p in enumerate(ids)}
    rows = []
    for k, m in enumerate(members):
        pts = getattr(m, "points", m)
        name = getattr(m, "id", k)
        pts = [int(p) for p in pts]
        if len(pts) < 2:
            raise ModelError(f"member {name!r}: a polyline needs at least 2 points, got {pts}")
        missing = [p for p in pts if p not in index]
        if missing:
            raise ModelError(f"member {name!r}: unknown point id(s) {missing}; points are {sorted(index)}")
        rows.append(np.array([index[p] for p in pts], dtype=int))
    return rows


def log_structure(rec, structure_points: Mapping[int, Sequence[float]], members: Sequence[Any]) -> list[str]:
    """Log the undeformed structure (static): members as grey strips, labelled points.

    Parameters
    ----------
    rec : rerun.RecordingStream
        From :func:`vlab.viz.rerun_log.open_recording`.
    structure_points : mapping of int to (float, float)
        Point id -> (x, y) [m] in the structure plane.
    members : sequence
        Each a sequence of point ids (a polyline) or an object with a
        ``points`` attribute (:class:`vlab.spec.Member`).

    Returns
    -------
    list of str
        ``["structure/undeformed"]``.

    Raises
    ------
    ModelError
        No points or members, a malformed coordinate, a member with fewer
        than two points or an unknown point id.
    """
    rr = rerun_module()
    ids, xy = _points_table(structure_points, None)
    rows = _member_rows(members, ids)
    xyz = np.column_stack([xy, np.zeros(len(ids))])
    rec.log("structure", rr.ViewCoordinates.RIGHT_HAND_Y_UP, static=True)
    rec.log(STRUCTURE_UNDEFORMED,
            rr.LineStrips3D([xyz[r] for r in rows], colors=[UNDEFORMED_COLOR], radii=[_radius(xy) * 0.5]),
            static=True)
    return [STRUCTURE_UNDEFORMED]


def _radius(xy: np.ndarray) -> float:
    """Line radius [m]: 0.4 % of the structure's size (at least 1 mm)."""
    return max(0.004 * _structure_size(xy), 1e-3)


def _structure_size(xy: np.ndarray) -> float:
    """Size [m] of the structure: the largest extent of its points ``xy`` (n_points, 2); 1.0 for one point."""
    return float(np.max(np.ptp(xy, axis=0))) if xy.shape[0] > 1 else 1.0


def frame_indices(n_frames: int, dt_s: float, fps: float) -> np.ndarray:
    """Indices of the frames kept when decimating to ``fps`` frames per simulated second.

    Frame ``k`` is at ``k * dt_s`` [s]; the first frame of every
    ``1 / fps`` interval is kept, so the kept frames are evenly spaced when
    ``1 / (fps * dt_s)`` is an integer. All frames are kept when they are
    already sparser than ``fps``.

    Returns
    -------
    numpy.ndarray of int, shape (n_kept,)

    Raises
    ------
    MeasurementError
        Non-positive ``n_frames``, ``dt_s`` or ``fps``.
    """
    if int(n_frames) != n_frames or n_frames < 1:
        raise MeasurementError(f"n_frames must be a positive integer, got {n_frames!r}")
    dt_s = positive_number(dt_s, "dt_s")
    fps = positive_number(fps, "fps")
    t = np.arange(int(n_frames)) * dt_s
    bins = np.floor(t * fps + 1e-9).astype(np.int64)
    _, first = np.unique(bins, return_index=True)
    return first


def auto_scale(structure_xy: Any, displacement: Any, *, fraction: float = 0.1) -> float:
    """Scale factor that draws the largest displacement as ``fraction`` of the structure's size.

    Parameters
    ----------
    structure_xy : array_like, shape (n_points, 2)
        Point coordinates [m].
    displacement : array_like, shape (n_frames, n_points)
        Out-of-plane displacements [m].
    fraction : float
        Largest drawn deflection / largest extent of the structure.

    Returns
    -------
    float
        Dimensionless factor (1.0 when all displacements are zero).
    """
    xy = np.asarray(structure_xy, dtype=float)
    w_max = float(np.max(np.abs(displacement))) if np.size(displacement) else 0.0
    size = _structure_size(xy)
    if w_max == 0.0 or size == 0.0:
        return 1.0
    return fraction * size / w_max


def log_deformed_shapes(rec, structure_points: Mapping[int, Sequence[float]], members: Sequence[Any],
                        displacement: Any, *, dt_s: float, point_ids: Sequence[int] | None = None,
                        t0_s: float = 0.0, fps: float = 50.0, scale: float | None = None) -> float:
    """Animate the deformed structure on ``sim_time`` (line strips + points), columnar.

    Each kept frame draws every member polyline through its points at
    ``(x, y, scale * w)``: the structure plane is (x, y), z is the
    out-of-plane direction.

    Parameters
    ----------
    rec : rerun.RecordingStream
        From :func:`vlab.viz.rerun_log.open_recording`.
    structure_points : mapping of int to (float, float)
        Point id -> (x, y) [m].
    members : sequence
        Point-id polylines or objects with ``points`` (:class:`vlab.spec.Member`).
    displacement : array_like, shape (n_frames, n_points)
        Out-of-plane displacement ``w`` [m] of the points, frame ``k`` at
        ``t0_s + k * dt_s``; column ``j`` belongs to ``point_ids[j]``.
    dt_s : float
        Interval between displacement frames [s].
    point_ids : sequence of int, shape (n_points,), optional
        Point of each column; default: the order of ``structure_points``.
        Every member point must be among them.
    t0_s : float
        Time of frame 0 [s].
    fps : float
        Frames per simulated second kept (decimation, :func:`frame_indices`).
    scale : float, optional
        Display factor on ``w``; default :func:`auto_scale` (largest
        deflection = 10 % of the structure's size).

    Returns
    -------
    float
        The scale factor used (also logged in the entity's label).

    Raises
    ------
    MeasurementError
        ``displacement`` not 2-D, its column count not ``len(point_ids)``,
        non-finite values, or bad ``dt_s``/``fps``/``scale``.
    ModelError
        Unknown point ids or malformed members.
    """
    rr = rerun_module()
    ids, xy = _points_table(structure_points, point_ids)
    rows = _member_rows(members, ids)
    w = np.asarray(displacement, dtype=float)
    if w.ndim != 2 or w.shape[1] != len(ids):
        raise MeasurementError(
            f"displacement: expected shape (n_frames, {len(ids)}) (one column per point of "
            f"point_ids {ids}), got {w.shape}")
    bad = np.argwhere(~np.isfinite(w))
    if bad.size:
        raise MeasurementError(f"displacement: non-finite value at frame {bad[0, 0]}, point {ids[bad[0, 1]]}")
    t0 = float(t0_s)
    if not math.isfinite(t0):
        raise MeasurementError(f"t0_s must be finite, got {t0_s!r}")
    keep = frame_indices(w.shape[0], dt_s, fps)
    s = auto_scale(xy, w) if scale is None else positive_number(scale, "scale")
    wk = w[keep] * s                                   # (n_kept, n_points)
    n_kept, n_pts = wk.shape
    times = t0 + keep * float(dt_s)

    # points: (n_kept, n_points, 3)
    pos = np.empty((n_kept, n_pts, 3), dtype=np.float32)
    pos[:, :, 0] = xy[:, 0]
    pos[:, :, 1] = xy[:, 1]
    pos[:, :, 2] = wk
    strips = [pos[k, r] for k in range(n_kept) for r in rows]
    index = [rr.TimeColumn(SIM_TIMELINE, duration=times)]
    radius = _radius(xy)
    rec.log(STRUCTURE_MEMBERS,
            rr.LineStrips3D.from_fields(colors=[MEMBER_COLOR], radii=[radius],
                                        labels=[f"w x {s:.3g}"], show_labels=False),
            static=True)
    rec.send_columns(STRUCTURE_MEMBERS, indexes=index,
                     columns=rr.LineStrips3D.columns(strips=strips).partition([len(rows)] * n_kept))
    rec.log(STRUCTURE_POINTS,
            rr.Points3D.from_fields(colors=[POINT_COLOR], radii=[2.5 * radius],
                                    labels=[str(p) for p in ids], show_labels=True),
            static=True)
    rec.send_columns(STRUCTURE_POINTS, indexes=index,
                     columns=rr.Points3D.columns(positions=pos.reshape(-1, 3)).partition([n_pts] * n_kept))
    return s
