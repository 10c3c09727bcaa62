"""Mode shapes in a rerun recording: each mode animated at its own frequency, on its own timeline.

Mode ``r`` (from 1) moves as ``w_r(p) cos(2 pi f_r t)``: its members and points are logged under
``modes/mode_<r>/members`` and ``modes/mode_<r>/points`` on the timeline ``mode_<r>_time`` (duration,
seconds of real time: ``cycles`` periods of the mode, ``frames_per_cycle`` frames per period), so each mode
plays at its own frequency when its timeline is selected. The structure at rest is static under
``modes/undeformed``. The structure lies in the (x, y) plane and ``w`` is drawn along z, multiplied by a
scale factor (default: the largest deflection is 10 % of the structure's size,
:func:`vlab.viz.rerun_structure.auto_scale`). The default layout shows one 3-D view per mode.

Shapes identified from a test (:func:`log_identified_shapes`, :mod:`vlab.measure.shapes`) are known at the
measured points only: each identified mode ``m`` moves its points as ``w_m(p) cos(2 pi f_m t)`` at its
identified frequency under ``modes/identified/mode_<m>/measured`` on the timeline
``identified_mode_<m>_time``, with the paired model shape at the same points beside it
(``modes/identified/mode_<m>/model``, its sign turned to the identified shape's) so that a MAC can be seen.

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

__all__ = ["IDENTIFIED_ROOT", "MODES_ROOT", "identified_timeline", "identified_views", "log_identified_shapes",
           "log_mode_shapes", "mode_blueprint", "mode_entity", "mode_timeline"]

#: Root entity of the mode shapes.
MODES_ROOT = "modes"
#: Root entity of the shapes identified from a test.
IDENTIFIED_ROOT = f"{MODES_ROOT}/identified"
#: Colour of the paired model shape beside an identified one (RGB).
MODEL_SHAPE_COLOR = (90, 160, 230)


def mode_timeline(r: int) -> str:
    """Name of the timeline of mode ``r`` (from 1): ``"mode_<r>_time"``."""
    return f"mode_{int(r)}_time"


def mode_entity(r: int) -> str:
    """Entity path of mode ``r`` (from 1): ``"modes/mode_<r>"``."""
    return f"{MODES_ROOT}/mode_{int(r)}"


def identified_timeline(mode: int) -> str:
    """Name of the timeline of identified mode ``mode``: ``"identified_mode_<mode>_time"``."""
    return f"identified_mode_{int(mode)}_time"


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
    n_frames = _frame_count(cycles, frames_per_cycle)
    s = auto_scale(xy, w.T) if scale is None else positive_number(scale, "scale")
    radius = _radius(xy)
    rest = np.column_stack([xy, np.zeros(len(ids))])
    undeformed = f"{MODES_ROOT}/undeformed"
    rec.log(undeformed, rr.LineStrips3D([rest[r] for r in rows], colors=[UNDEFORMED_COLOR], radii=[0.5 * radius]),
            static=True)
    written = [undeformed]
    labels = [str(p) for p in ids]
    for r in range(f.size):
        base = mode_entity(r + 1)

        def frame(c, base=base, z=s * w[:, r]):
            pos = _lifted(rest, c * z)
            rec.log(f"{base}/members", rr.LineStrips3D([pos[i] for i in rows], colors=[MEMBER_COLOR], radii=[radius]))
            rec.log(f"{base}/points", rr.Points3D(pos, colors=[POINT_COLOR], radii=[2.5 * radius], labels=labels))

        _animate(rec, mode_timeline(r + 1), f[r], n_frames, frames_per_cycle, frame)
        written += [f"{base}/members", f"{base}/points"]
    return written


def _animate(rec, timeline: str, f_hz: float, n_frames: int, frames_per_cycle: int, frame) -> None:
    """Call ``frame(cos(2 pi f_hz t_k))`` at ``n_frames`` instants ``t_k = k / (frames_per_cycle f_hz)`` [s] of
    ``timeline``, then leave the timeline."""
    for k in range(n_frames):
        t = k / (frames_per_cycle * f_hz)
        rec.set_time(timeline, duration=t)
        frame(np.cos(2 * np.pi * f_hz * t))
    rec.reset_time()


def _lifted(rest: np.ndarray, z: np.ndarray) -> np.ndarray:
    """The points at rest (n, 3) with their z set to ``z`` (n,) [m]."""
    pos = rest.copy()
    pos[:, 2] = z
    return pos


def _frame_count(cycles: float, frames_per_cycle: int) -> int:
    """Frames of ``cycles`` periods at ``frames_per_cycle`` (an integer >= 4, else ModelError)."""
    if int(frames_per_cycle) != frames_per_cycle or frames_per_cycle < 4:
        raise ModelError(f"frames_per_cycle must be an integer >= 4, got {frames_per_cycle!r}")
    return max(int(round(positive_number(cycles, "cycles") * frames_per_cycle)), 1)


def _turned_to(model: np.ndarray, w: np.ndarray) -> np.ndarray | None:
    """``model`` (n,) scaled to the largest ``|w|`` and turned to the sign that best matches ``w``; None when it
    is not finite or zero (no pair)."""
    if not np.all(np.isfinite(model)) or np.max(np.abs(model), initial=0.0) == 0:
        return None
    scaled = model * np.max(np.abs(w)) / np.max(np.abs(model))
    return scaled if scaled @ w >= 0 else -scaled


def identified_views(modes: Sequence[int], freq_hz: Sequence[float]) -> list:
    """One 3-D view per identified mode (titled with its frequency), with the structure at rest.

    Parameters
    ----------
    modes : sequence of int
        The identified modes' numbers (:attr:`vlab.measure.shapes.IdentifiedShapes.modes`).
    freq_hz : sequence of float, same length
        Their identified frequencies [Hz].

    Returns
    -------
    list of rerun.blueprint.Spatial3DView
    """
    import rerun.blueprint as rrb

    return [rrb.Spatial3DView(origin=f"{IDENTIFIED_ROOT}/mode_{int(m)}", name=f"identified mode {m}: {f:.3f} Hz",
                              contents=["$origin/**", "/structure/undeformed"])
            for m, f in zip(modes, freq_hz)]


def log_identified_shapes(rec, structure_points: Mapping[int, Sequence[float]], point_ids: Sequence[int], w: Any,
                          freq_hz: Any, modes: Sequence[int], *, w_model: Any = None, cycles: float = 2.0,
                          frames_per_cycle: int = 24, scale: float | None = None) -> list[str]:
    """Log each identified mode animated at its identified frequency, with the paired model shape beside it.

    Parameters
    ----------
    rec : rerun.RecordingStream
        An open recording (:func:`vlab.viz.rerun_log.open_recording`).
    structure_points : mapping of int to (float, float)
        Point id -> (x, y) [m].
    point_ids : sequence of int, length n_points
        The measured point of each row of ``w``.
    w : array_like, shape (n_points, n_modes)
        Identified shapes, real (:attr:`vlab.measure.shapes.IdentifiedShapes.shapes`, largest +1).
    freq_hz : array_like, shape (n_modes,)
        Identified frequencies [Hz], > 0.
    modes : sequence of int, length n_modes
        The identified modes' numbers (entity and timeline names).
    w_model : array_like, shape (n_points, n_modes), optional
        The paired model shape at the same points, a column of NaN where a mode has no pair; drawn scaled to
        the identified shape's largest value and turned to its sign.
    cycles, frames_per_cycle, scale
        As :func:`log_mode_shapes` (the scale from the identified shapes).

    Returns
    -------
    list of str
        The entity paths written: ``modes/identified/mode_<m>/measured`` and, where paired,
        ``modes/identified/mode_<m>/model``.

    Raises
    ------
    ModelError
        Unknown point ids; ``w``, ``w_model``, ``freq_hz`` or ``modes`` of the wrong shape; ``w`` or
        ``freq_hz`` not finite or a frequency that is not positive; ``frames_per_cycle`` below 4.
    MeasurementError
        A ``cycles`` or ``scale`` that is not a positive number.
    """
    rr = rerun_module()
    ids, xy = _points_table(structure_points, point_ids)
    w = np.asarray(w, dtype=float)
    f = np.asarray(freq_hz, dtype=float).reshape(-1)
    wm = np.full(w.shape, np.nan) if w_model is None else np.asarray(w_model, dtype=float)
    if (w.ndim != 2 or w.shape != (len(ids), f.size) or wm.shape != w.shape or len(modes) != f.size
            or not (np.all(np.isfinite(w)) and np.all(f > 0))):
        raise ModelError(f"log_identified_shapes: w and w_model must be of shape ({len(ids)}, n_modes) with w "
                         f"finite, freq_hz positive and modes of shape (n_modes,); got {w.shape}, {wm.shape}, "
                         f"{f.shape} and {len(modes)} modes")
    n_frames = _frame_count(cycles, frames_per_cycle)
    s = auto_scale(xy, w.T) if scale is None else positive_number(scale, "scale")
    radius = _radius(xy)
    rest = np.column_stack([xy, np.zeros(len(ids))])
    labels = [str(p) for p in ids]
    written = []
    for r, m in enumerate(modes):
        base = f"{IDENTIFIED_ROOT}/mode_{int(m)}"
        model = _turned_to(wm[:, r], w[:, r])

        def frame(c, base=base, z=s * w[:, r], zm=None if model is None else s * model):
            rec.log(f"{base}/measured", rr.Points3D(_lifted(rest, c * z), colors=[POINT_COLOR],
                                                    radii=[2.5 * radius], labels=labels))
            if zm is not None:
                rec.log(f"{base}/model", rr.Points3D(_lifted(rest, c * zm), colors=[MODEL_SHAPE_COLOR],
                                                     radii=[1.5 * radius]))

        _animate(rec, identified_timeline(m), f[r], n_frames, frames_per_cycle, frame)
        paired = model is not None
        written += [f"{base}/measured"] + ([f"{base}/model"] if paired else [])
    return written
