"""Write an experiment to a rerun recording (``.rrd``) for the rerun viewer.

One recording holds what a laboratory run produced, under fixed entity paths:

================================  =============================================
entity path                       content
================================  =============================================
``signals/<name>``                a time series per sensor / actuator channel
                                  (``signals/vel6``, ``signals/force9``,
                                  ``signals/u5``) on the ``sim_time`` timeline
``structure/undeformed``          the members at rest (static, grey)
``structure/members``             animated deformed shape: one 3-D line strip
                                  per member polyline, on ``sim_time``
``structure/points``              animated structure points, labelled by id
``frf/<name>/magnitude``          ``log10 |H(f)|`` of one FRF on the
                                  ``frequency_mhz`` timeline; ``phase`` [deg]
                                  and ``coherence`` beside it
                                  (:mod:`vlab.viz.rerun_frf`)
``modes/identified/mode_<m>``     an identified mode shape animated at its
                                  frequency on ``identified_mode_<m>_time``,
                                  the paired model shape beside it
                                  (:mod:`vlab.viz.rerun_modes`)
``meta/run``                      the run's metadata as a JSON text document
================================  =============================================

Geometry: the structure lies in the (x, y) plane, y up (see
:mod:`vlab.spec`); the out-of-plane displacement ``w`` is drawn along z,
multiplied by a scale factor so that it is visible.

Timelines
---------
``sim_time``
    Simulation time, a rerun *duration* timeline in seconds. Sample ``k`` of
    a :class:`~vlab.io.recording.Recording` sits at ``k * dt_s``.
``frequency_mhz``
    Frequency of the FRF points as a rerun *sequence* timeline in integer
    millihertz (1 Hz = 1000). rerun has no non-time numeric x axis; a
    sequence timeline shows plain numbers (5 Hz reads ``5000``), whereas a
    duration timeline would label the axis in seconds. Frequencies must
    therefore be distinct after rounding to 1 mHz. The viewer plots against
    the timeline selected in its time panel: pick ``frequency_mhz`` to see
    the FRFs, ``sim_time`` for signals and the animation.

rerun has no logarithmic scalar axis, so FRF magnitudes are logged as
``log10 |H|`` (the dissertation's Figs. 22-31 plot ``|H|`` on a log axis;
same picture). Points where ``|H| = 0`` are logged as NaN (a gap).

Everything is written columnar (:func:`rerun.send_columns`), so a recording
of 100 000 samples per channel takes a fraction of a second. The module has
no import-time side effects: nothing touches rerun's global recording; every
function takes an explicit :class:`rerun.RecordingStream`.

Reading back: :func:`rrd_entity_paths` and :func:`rrd_row_counts` use
:class:`rerun.chunk.RrdReader`.

The structure's entities are written by :mod:`vlab.viz.rerun_structure`, a
live viewer is started by :mod:`vlab.viz.viewer`, and the entity paths and
timelines are the constants of :mod:`vlab.viz.rerun_common`.

Source: rerun-sdk 0.41 Python API (``RecordingStream``, ``send_columns``,
``TimeColumn``, ``rerun.chunk.RrdReader``).
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import DataFileError, MeasurementError, ModelError
from .rerun_common import FRF_ROOT, META_ENTITY, SIGNALS_ROOT, SIM_TIMELINE, check_name, finite_1d, rerun_module
from .rerun_frf import frf_panels, frf_views, log_frfs
from .rerun_modes import identified_views, log_identified_shapes
from .rerun_structure import log_deformed_shapes, log_structure
from .viewer import spawn_viewer

__all__ = [
    "close_recording",
    "default_blueprint",
    "log_experiment",
    "log_frfs",
    "log_metadata",
    "log_recording",
    "log_signals",
    "open_recording",
    "rrd_entity_paths",
    "rrd_row_counts",
]


# -------------------------------------------------------------- recording ---


def default_blueprint(*, signals: bool = True, structure: bool = True, frfs: bool = True,
                      frf_paths: Mapping[str, Sequence[str]] | None = None,
                      identified: tuple[Sequence[int], Sequence[float]] | None = None):
    """The viewer layout: 3-D structure left, signal and FRF plots right.

    Parameters
    ----------
    signals, structure, frfs : bool
        Which views to include (a view of an empty entity is just blank).
    frf_paths : mapping of str to sequence of str, optional
        Quantity -> entity paths (:func:`vlab.viz.rerun_frf.frf_panels`): the FRFs in one view per
        quantity (magnitude, phase, coherence; :func:`vlab.viz.rerun_frf.frf_views`) instead of one view of
        everything under ``frf/``.
    identified : (modes, freq_hz), optional
        Identified mode shapes: one tab per mode beside the deformed shape
        (:func:`vlab.viz.rerun_modes.identified_views`).

    Returns
    -------
    rerun.blueprint.Blueprint
        With the time panel on the ``sim_time`` timeline.
    """
    import rerun.blueprint as rrb

    plots = []
    if signals:
        plots.append(rrb.TimeSeriesView(origin=SIGNALS_ROOT, name="signals vs sim_time [s]"))
    if frfs and frf_paths:
        plots.extend(frf_views(frf_paths))
    elif frfs:
        plots.append(rrb.TimeSeriesView(origin=FRF_ROOT,
                                        name="FRF log10|H| vs frequency_mhz (1 Hz = 1000)"))
    views = []
    if structure:
        views.append(rrb.Spatial3DView(origin="structure", name="deformed shape"))
    if identified is not None and len(identified[0]):
        views.append(rrb.Tabs(*identified_views(*identified), name="identified mode shapes"))
    if plots:
        views.append(rrb.Vertical(*plots) if len(plots) > 1 else plots[0])
    if not views:
        views.append(rrb.TimeSeriesView(origin="/"))
    root = rrb.Horizontal(*views) if len(views) > 1 else views[0]
    return rrb.Blueprint(root, rrb.TimePanel(timeline=SIM_TIMELINE), collapse_panels=False)


def open_recording(path: str | Path | None, *, app_id: str = "vlab", recording_id: str | None = None,
                   spawn: bool = False, blueprint: Any = None):
    """Open a rerun recording stream that writes ``path`` (and optionally a live viewer).

    Parameters
    ----------
    path : str or Path or None
        Output ``.rrd`` file; parent folders are created. ``None`` only with
        ``spawn=True`` (viewer only, nothing saved).
    app_id : str
        rerun application id (groups recordings in the viewer).
    recording_id : str, optional
        Fixed recording id (e.g. derived from the run's seed); random if None.
    spawn : bool
        Also start a rerun viewer process with :func:`vlab.viz.viewer.spawn_viewer` (its
        gRPC server listens on the loopback address only) and stream to it
        live. Needs a display.
    blueprint : rerun.blueprint.Blueprint, optional
        Default layout; :func:`default_blueprint` if None.

    Returns
    -------
    rerun.RecordingStream
        A private stream (rerun's global recording is not touched), with the
        wall-clock ``log_time`` timeline disabled so that content depends
        only on the data. Close it with :func:`close_recording`.

    Raises
    ------
    DataFileError
        ``path`` is None without ``spawn``, or does not end in ``.rrd``.
    RuntimeError
        ``spawn`` and the viewer did not start (see :func:`vlab.viz.viewer.spawn_viewer`).
    """
    rr = rerun_module()
    if path is None and not spawn:
        raise DataFileError("open_recording: path is None and spawn is False: nothing would be written")
    if path is not None:
        path = Path(path)
        if path.suffix != ".rrd":
            raise DataFileError(f"{path}: a rerun recording must have the suffix '.rrd'")
        path.parent.mkdir(parents=True, exist_ok=True)
    bp = default_blueprint() if blueprint is None else blueprint
    rec = rr.RecordingStream(app_id, recording_id=recording_id)
    rec.set_log_time_enabled(False)
    if spawn:
        _process, url = spawn_viewer()
        sinks = [rr.GrpcSink(url)]
        if path is not None:
            sinks.append(rr.FileSink(str(path)))
        rec.set_sinks(*sinks, default_blueprint=bp)
    else:
        rec.save(str(path), default_blueprint=bp)
    return rec


def close_recording(rec) -> None:
    """Flush ``rec`` and close its file / viewer connection (the ``.rrd`` is complete after this)."""
    rec.flush()
    rec.disconnect()


# ---------------------------------------------------------------- signals ---


def log_signals(rec, time_s: Any, signals: Mapping[str, Any], *,
                units: Mapping[str, str] | None = None, root: str = SIGNALS_ROOT) -> list[str]:
    """Log time series as scalars on the ``sim_time`` timeline, columnar.

    Parameters
    ----------
    rec : rerun.RecordingStream
        From :func:`open_recording`.
    time_s : array_like, shape (n_samples,)
        Sample instants [s], finite.
    signals : mapping of str to array_like, each shape (n_samples,)
        Name (``"vel6"``, ``"force9"``, ``"u5"``) -> values in SI units.
    units : mapping of str to str, optional
        Unit per name, shown in the series legend (``"vel6 [m/s]"``).
    root : str
        Parent entity; each series goes to ``<root>/<name>``.

    Returns
    -------
    list of str
        The entity paths written, one per signal.

    Raises
    ------
    MeasurementError
        A name that is not a valid entity path, or a ``time_s`` / signal
        array that is not 1-D, not finite, or of another length than
        ``time_s`` (the message names the signal).
    """
    rr = rerun_module()
    t = finite_1d(time_s, "time_s")
    units = dict(units or {})
    paths = []
    for name, values in signals.items():
        check_name(name, "signal")
        y = finite_1d(values, f"signal {name!r}", n=t.size)
        entity = f"{root}/{name}"
        label = f"{name} [{units[name]}]" if name in units else name
        rec.log(entity, rr.SeriesLines(names=label), static=True)
        rec.send_columns(entity, indexes=[rr.TimeColumn(SIM_TIMELINE, duration=t)],
                         columns=rr.Scalars.columns(scalars=y))
        paths.append(entity)
    return paths


def log_recording(rec, recording, *, extra_signals: Mapping[str, Any] | None = None,
                  extra_units: Mapping[str, str] | None = None) -> list[str]:
    """Log every channel of a :class:`~vlab.io.recording.Recording` under ``signals/``.

    Parameters
    ----------
    rec : rerun.RecordingStream
        From :func:`open_recording`.
    recording : vlab.io.recording.Recording
        Channels of ``n_samples`` samples at ``dt_s`` [s]; logged as
        ``signals/<channel name>`` with the channel's SI unit in the legend.
    extra_signals : mapping of str to array_like, each shape (n_samples,), optional
        Further series on the same time base, e.g. controller commands
        ``{"u5": ...}`` [N] that are not recorded channels.
    extra_units : mapping of str to str, optional
        Units of ``extra_signals``.

    Returns
    -------
    list of str
        The entity paths written, one per channel and extra signal.

    Raises
    ------
    MeasurementError
        An extra signal whose name clashes with a channel, or whose length
        is not ``recording.n_samples``; invalid names.
    """
    signals: dict[str, Any] = {c.name: c.samples for c in recording.channels}
    units = {c.name: c.unit for c in recording.channels}
    for name, values in (extra_signals or {}).items():
        if name in signals:
            raise MeasurementError(f"extra signal {name!r} clashes with a recording channel of that name")
        signals[name] = values
    units.update(extra_units or {})
    return log_signals(rec, recording.time_s, signals, units=units)


def log_metadata(rec, metadata: Mapping[str, Any], *, entity: str = META_ENTITY) -> str:
    """Log run metadata as a static JSON text document at ``entity``.

    Parameters
    ----------
    rec : rerun.RecordingStream
        The recording to log into.
    metadata : mapping
        Run metadata; values that are not JSON types are written with ``str``.
    entity : str
        Entity path.

    Returns
    -------
    str
        The entity path.
    """
    rr = rerun_module()
    text = json.dumps(dict(metadata), indent=2, sort_keys=True, default=str)
    rec.log(entity, rr.TextDocument(f"```json\n{text}\n```", media_type=rr.MediaType.MARKDOWN),
            static=True)
    return entity


# ------------------------------------------------------------------ entry ---


def _frame_step(recording, structure_points, members, displacement, displacement_dt_s, extra_signals):
    """The animation's frame interval [s] of :func:`log_experiment`, its arguments checked (see there)."""
    if (structure_points is None) != (members is None):
        raise ModelError("structure_points and members must be given together")
    if displacement is not None:
        if structure_points is None:
            raise ModelError("displacement needs structure_points and members to be drawn")
        if displacement_dt_s is None:
            if recording is None:
                raise MeasurementError("displacement needs displacement_dt_s (or a recording to take dt_s from)")
            displacement_dt_s = recording.dt_s
    if extra_signals and recording is None:
        raise MeasurementError("extra_signals need a recording for their time base")
    return displacement_dt_s


def log_experiment(path: str | Path | None, *, recording=None,
                   structure_points: Mapping[int, Sequence[float]] | None = None,
                   members: Sequence[Any] | None = None, displacement: Any = None,
                   displacement_dt_s: float | None = None, point_ids: Sequence[int] | None = None,
                   frfs: Mapping[str, Any] | None = None, extra_signals: Mapping[str, Any] | None = None,
                   extra_units: Mapping[str, str] | None = None, metadata: Mapping[str, Any] | None = None,
                   fps: float = 50.0, scale: float | None = None, spawn: bool = False,
                   app_id: str = "vlab", recording_id: str | None = None, frf_phase: bool = False,
                   identified_shapes: Mapping[str, Any] | None = None) -> Path | None:
    """Write one experiment (signals, animated structure, FRFs) to a ``.rrd`` file.

    Every part is optional; what is given is logged (see the module
    docstring for the entity paths).

    Parameters
    ----------
    path : str or Path or None
        Output ``.rrd`` file (parents created); ``None`` only with ``spawn``.
    recording : vlab.io.recording.Recording, optional
        Channels -> ``signals/<name>`` on ``sim_time``; its metadata ->
        ``meta/run`` (merged under ``metadata``).
    structure_points : mapping of int to (float, float), optional
        Point id -> (x, y) [m]. With ``members``: ``structure/undeformed``.
    members : sequence, optional
        Point-id polylines or :class:`vlab.spec.Member` objects.
    displacement : array_like, shape (n_frames, n_points), optional
        Out-of-plane displacement [m] of the points in ``point_ids`` order
        -> ``structure/members`` and ``structure/points``. Needs
        ``structure_points`` and ``members``.
    displacement_dt_s : float, optional
        Frame interval of ``displacement`` [s]; default ``recording.dt_s``.
    point_ids : sequence of int, optional
        Point of each ``displacement`` column; default the order of
        ``structure_points``.
    frfs : mapping of str to FRF, optional
        See :func:`~vlab.viz.rerun_frf.log_frfs` -> ``frf/<name>/magnitude``, and ``frf/<name>/coherence``
        for an FRF with a coherence (an H1 estimate).
    extra_signals, extra_units : mapping, optional
        Series on the recording's time base that are not channels, e.g.
        controller commands ``{"u5": ...}`` [N] -> ``signals/u5``.
    metadata : mapping, optional
        Written to ``meta/run`` as JSON.
    fps : float
        Animation frames per simulated second.
    scale : float, optional
        Display factor on the displacement (default :func:`vlab.viz.rerun_structure.auto_scale`).
    spawn : bool
        Also open a live rerun viewer.
    app_id, recording_id : str
        rerun application / recording id.
    frf_phase : bool
        Also log each FRF's phase, ``frf/<name>/phase`` [deg]; the layout then shows magnitude, phase and
        coherence in views of their own.
    identified_shapes : mapping, optional
        Mode shapes identified from the test: the arguments ``point_ids``, ``w``, ``freq_hz``, ``modes`` and
        ``w_model`` of :func:`vlab.viz.rerun_modes.log_identified_shapes` -> ``modes/identified/mode_<m>``
        (needs ``structure_points``).

    Returns
    -------
    Path or None
        ``path`` once the file is complete (None when only spawned).

    Raises
    ------
    MeasurementError
        Shape mismatches (the message names the array), displacement
        without a time step, extra signals without a recording.
    ModelError
        Displacement or identified shapes without geometry; unknown point ids in members or shapes.
    DataFileError
        Bad ``path``.
    """
    has_geom = structure_points is not None and members is not None
    displacement_dt_s = _frame_step(recording, structure_points, members, displacement, displacement_dt_s,
                                    extra_signals)
    bp = _experiment_blueprint(recording is not None, has_geom, frfs, frf_phase, structure_points,
                               identified_shapes)
    rec = open_recording(path, app_id=app_id, recording_id=recording_id, spawn=spawn, blueprint=bp)
    try:
        meta = {**(recording.metadata if recording is not None else {}), **(metadata or {})}
        if meta:
            log_metadata(rec, meta)
        if has_geom:
            log_structure(rec, structure_points, members)
            if displacement is not None:
                log_deformed_shapes(rec, structure_points, members, displacement, dt_s=displacement_dt_s,
                                    point_ids=point_ids, fps=fps, scale=scale)
        if recording is not None:
            log_recording(rec, recording, extra_signals=extra_signals, extra_units=extra_units)
        if frfs:
            log_frfs(rec, frfs, phase=frf_phase)
        if identified_shapes is not None:
            log_identified_shapes(rec, structure_points, **identified_shapes)
    finally:
        close_recording(rec)
    return None if path is None else Path(path)


def _experiment_blueprint(signals: bool, structure: bool, frfs, frf_phase: bool, structure_points,
                          identified_shapes):
    """:func:`default_blueprint` of what :func:`log_experiment` is given (ModelError: identified shapes without
    the points' positions)."""
    if identified_shapes is not None and structure_points is None:
        raise ModelError("log_experiment: identified_shapes need structure_points (their positions)")
    ident = None if identified_shapes is None else (identified_shapes["modes"], identified_shapes["freq_hz"])
    return default_blueprint(signals=signals, structure=structure, frfs=bool(frfs),
                             frf_paths=frf_panels(frfs, phase=frf_phase) if frfs and frf_phase else None,
                             identified=ident)


# --------------------------------------------------------------- reading ---


def _store(path: str | Path):
    from rerun.chunk import RrdReader

    p = Path(path)
    if not p.is_file():
        raise DataFileError(f"{p}: no such rerun recording")
    try:
        return RrdReader(str(p)).store()
    except Exception as exc:  # the reader raises plain errors for corrupt files
        raise DataFileError(f"{p}: cannot read rerun recording: {exc}") from exc


def rrd_entity_paths(path: str | Path) -> list[str]:
    """Entity paths (without the leading '/') holding data in a ``.rrd`` file, sorted.

    Reads the first recording store with :class:`rerun.chunk.RrdReader`;
    rerun's internal ``__properties`` entity is left out.

    Raises
    ------
    DataFileError
        Missing or unreadable file.
    """
    paths = _store(path).schema().entity_paths()
    return sorted(p.lstrip("/") for p in paths if not p.lstrip("/").startswith("__"))


def rrd_row_counts(path: str | Path, *, timeline: str | None = None) -> dict[str, int]:
    """Number of time-indexed rows per entity in a ``.rrd`` file (static rows not counted).

    Parameters
    ----------
    path : str or Path
        The recording.
    timeline : str, optional
        Count only chunks indexed by this timeline (``"sim_time"``,
        ``"frequency_mhz"``).

    Returns
    -------
    dict of str to int
        Entity path (no leading '/') -> rows, e.g. ``n_samples`` for
        ``signals/vel6`` and the number of kept frames for
        ``structure/members``.

    Raises
    ------
    DataFileError
        Missing or unreadable file.
    """
    counts: dict[str, int] = {}
    for chunk in _store(path).stream():
        if chunk.is_static or (timeline is not None and timeline not in chunk.timeline_names):
            continue
        key = chunk.entity_path.lstrip("/")
        counts[key] = counts.get(key, 0) + chunk.num_rows
    return counts
