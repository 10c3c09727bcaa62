"""Mode shapes in a rerun recording: each mode animated at its own frequency, on its own timeline.

Mode ``r`` (from 1) moves as ``w_r(p) cos(2 pi f_r t)``: its members and points are logged under
``modes/mode_<r>/members`` and ``modes/mode_<r>/points`` on the timeline ``mode_<r>_time`` (duration,
seconds of real time: ``cycles`` periods of the mode, ``frames_per_cycle`` frames per period), so each mode
plays at its own frequency when its timeline is selected. The structure at rest is static under
``modes/undeformed``. The structure lies in the (x, y) plane and ``w`` is drawn along z, multiplied by a
scale factor (default: the largest deflection is 10 % of the structure's size,
:func:`vlab.viz.rerun_structure.auto_scale`). The default layout shows one 3-D view per mode.

Source: rerun-sdk 0.41 Python API (``LineStrips3D``, ``Points3D``, ``set_time``, blueprints); Ewins,
*Modal Testing* (2nd ed., 2000), Sec. 8.1 (animated display of mode shapes).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ..errors import ModelError
from .rerun_common import MEMBER_COLOR, POINT_COLOR, UNDEFORMED_COLOR, positive_number, rerun_module
from .rerun_structure import _member_rows, _points_table, _radius, auto_scale

__all__ = ["MODES_ROOT", "log_mode_shapes", "mode_blueprint", "mode_entity", "mode_timeline"]

#: Root entity of the mode shapes.
MODES_ROOT = "modes"


def mode_timeline(r: int) -> str:
    """Name of the timeline of mode ``r`` (from 1): ``"mode_<r>_time"``."""
    return f"mode_{int(r)}_time"


def mode_entity(r: int) -> str:
    """Entity path of mode ``r`` (from 1): ``"modes/mode_<r>"``."""
    return f"{MODES_ROOT}/mode_{int(r)}"


def mode_blueprint(freq_hz: Sequence[float]):
    """Default layout: one 3-D view per mode (titled with its frequency), the time panel on mode 1's timeline.

    Parameters
    ----------
    freq_hz : sequence of float, length n_modes
        Natural frequencies [Hz].

    Returns
    -------
    rerun.blueprint.Blueprint
    """
    import rerun.blueprint as rrb

    views = [rrb.Spatial3DView(origin=mode_entity(r + 1), name=f"mode {r + 1}: {f:.3f} Hz",
                               contents=["$origin/**", f"/{MODES_ROOT}/undeformed"])
             for r, f in enumerate(freq_hz)]
    return rrb.Blueprint(rrb.Grid(*views), rrb.TimePanel(timeline=mode_timeline(1)), collapse_panels=False)


def log_mode_shapes(rec, structure_points: Mapping[int, Sequence[float]], members: Sequence[Any],
                    point_ids: Sequence[int], w: Any, freq_hz: Any, *, cycles: float = 2.0,
                    frames_per_cycle: int = 24, scale: float | None = None) -> list[str]:
    """Log each mode animated at its frequency, one timeline per mode.

    Parameters
    ----------
    rec : rerun.RecordingStream
        From :func:`vlab.viz.rerun_log.open_recording` (pass ``blueprint=mode_blueprint(freq_hz)``).
    structure_points : mapping of int to (float, float)
        Point id -> (x, y) [m].
    members : sequence
        Point-id polylines or objects with ``points`` (:class:`vlab.spec.Member`).
    point_ids : sequence of int, length n_points
        The point of each row of ``w``; every member point must be among them.
    w : array_like, shape (n_points, n_modes)
        Mode shapes at the points (e.g. normalised, largest +1: :attr:`vlab.fe.point_shapes.PointShapes.w`).
    freq_hz : array_like, shape (n_modes,)
        Natural frequency of each mode [Hz], > 0.
    cycles : float
        Periods of each mode logged, > 0.
    frames_per_cycle : int
        Frames per period, >= 4.
    scale : float, optional
        Display factor on ``w``; default :func:`vlab.viz.rerun_structure.auto_scale` (largest drawn
        deflection 10 % of the structure's size).

    Returns
    -------
    list of str
        The entity paths written: ``modes/undeformed``, then ``modes/mode_<r>/members`` and
        ``modes/mode_<r>/points`` for each mode.

    Raises
    ------
    ModelError
        Unknown point ids, malformed members, ``w`` / ``freq_hz`` of the wrong shape, not finite or a
        frequency that is not positive, ``frames_per_cycle`` below 4.
    MeasurementError
        A ``cycles`` or ``scale`` that is not a positive number.
    """
    rr = rerun_module()
    ids, xy = _points_table(structure_points, point_ids)
    rows = _member_rows(members, ids)
    w = np.asarray(w, dtype=float)
    f = np.asarray(freq_hz, dtype=float).reshape(-1)
    if w.ndim != 2 or w.shape != (len(ids), f.size) or not (np.all(np.isfinite(w)) and np.all(f > 0)):
        raise ModelError(f"log_mode_shapes: w must be finite of shape ({len(ids)}, n_modes) and freq_hz positive of "
                         f"shape (n_modes,); got {w.shape} and {f.shape}")
    if int(frames_per_cycle) != frames_per_cycle or frames_per_cycle < 4:
        raise ModelError(f"frames_per_cycle must be an integer >= 4, got {frames_per_cycle!r}")
    n_frames = max(int(round(positive_number(cycles, "cycles") * frames_per_cycle)), 1)
    s = auto_scale(xy, w.T) if scale is None else positive_number(scale, "scale")
    radius = _radius(xy)
    rest = np.column_stack([xy, np.zeros(len(ids))])
    undeformed = f"{MODES_ROOT}/undeformed"
    rec.log(undeformed, rr.LineStrips3D([rest[r] for r in rows], colors=[UNDEFORMED_COLOR], radii=[0.5 * radius]),
            static=True)
    written = [undeformed]
    for r in range(f.size):
        base = mode_entity(r + 1)
        for k in range(n_frames):
            t = k / (frames_per_cycle * f[r])
            pos = rest.copy()
            pos[:, 2] = s * w[:, r] * np.cos(2 * np.pi * f[r] * t)
            rec.set_time(mode_timeline(r + 1), duration=t)
            rec.log(f"{base}/members", rr.LineStrips3D([pos[i] for i in rows], colors=[MEMBER_COLOR], radii=[radius]))
            rec.log(f"{base}/points", rr.Points3D(pos, colors=[POINT_COLOR], radii=[2.5 * radius],
                                                  labels=[str(p) for p in ids]))
        rec.reset_time()
        written += [f"{base}/members", f"{base}/points"]
    return written
