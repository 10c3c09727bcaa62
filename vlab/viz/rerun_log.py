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
                                  ``frequency_mhz`` timeline
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

Source: rerun-sdk 0.41 Python API (``RecordingStream``, ``send_columns``,
``TimeColumn``, ``rerun.chunk.RrdReader``).
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import DataFileError, MeasurementError, ModelError

__all__ = [
    "FREQUENCY_TIMELINE",
    "FRF_ROOT",
    "META_ENTITY",
    "SIGNALS_ROOT",
    "SIM_TIMELINE",
    "STRUCTURE_MEMBERS",
    "STRUCTURE_POINTS",
    "STRUCTURE_UNDEFORMED",
    "auto_scale",
    "close_recording",
    "default_blueprint",
    "frame_indices",
    "log_deformed_shapes",
    "log_experiment",
    "log_frfs",
    "log_metadata",
    "log_recording",
    "log_signals",
    "log_structure",
    "open_recording",
    "spawn_viewer",
    "viewer_command",
    "rrd_entity_paths",
    "rrd_row_counts",
    "structure_geometry",
]

#: Simulation-time timeline (duration, seconds).
SIM_TIMELINE = "sim_time"
#: Frequency timeline of the FRFs (sequence, integer millihertz).
FREQUENCY_TIMELINE = "frequency_mhz"
#: Parent entity of the time series.
SIGNALS_ROOT = "signals"
#: Animated deformed members (line strips).
STRUCTURE_MEMBERS = "structure/members"
#: Animated structure points.
STRUCTURE_POINTS = "structure/points"
#: Members at rest (static).
STRUCTURE_UNDEFORMED = "structure/undeformed"
#: Parent entity of the FRFs; each FRF goes to ``frf/<name>/magnitude``.
FRF_ROOT = "frf"
#: Run metadata (static JSON text document).
META_ENTITY = "meta/run"
#: The only address a viewer started by vlab listens on (loopback, IPv4).
VIEWER_BIND_ADDRESS = "127.0.0.1"

_SEGMENT_RE = re.compile(r"^[A-Za-z0-9_.\-]+$")
_MEMBER_COLOR = (40, 110, 200)
_UNDEFORMED_COLOR = (150, 150, 150)
_POINT_COLOR = (220, 80, 30)
# Tableau-10: the colours of successive FRF curves.
_PALETTE = (
    (31, 119, 180), (255, 127, 14), (44, 160, 44), (214, 39, 40), (148, 103, 189),
    (140, 86, 75), (227, 119, 194), (127, 127, 127), (188, 189, 34), (23, 190, 207),
)


def _rr():
    """Import rerun lazily (keeps ``import vlab.viz`` cheap and side-effect free)."""
    import rerun as rr

    return rr


# ------------------------------------------------------------- validation ---


def _check_name(name: str, what: str) -> str:
    """An entity-path name: segments of letters, digits, ``_ . -`` joined by '/'."""
    if not isinstance(name, str) or not name:
        raise MeasurementError(f"{what}: name must be a non-empty string, got {name!r}")
    for seg in name.split("/"):
        if not _SEGMENT_RE.match(seg):
            raise MeasurementError(
                f"{what}: name {name!r} is not a valid entity path; use letters, digits, "
                "'_', '.', '-' and '/' between non-empty parts")
    return name


def _finite_1d(values: Any, what: str, *, n: int | None = None, dtype: Any = float) -> np.ndarray:
    arr = np.asarray(values, dtype=dtype)
    if arr.ndim != 1:
        raise MeasurementError(f"{what}: expected a 1-D array, got shape {arr.shape}")
    if n is not None and arr.size != n:
        raise MeasurementError(f"{what}: expected shape ({n},), got {arr.shape}")
    bad = np.flatnonzero(~np.isfinite(arr))
    if bad.size:
        raise MeasurementError(f"{what}: {bad.size} non-finite value(s), first at index {bad[0]}")
    return arr


def _positive(value: float, what: str) -> float:
    v = float(value)
    if not math.isfinite(v) or v <= 0.0:
        raise MeasurementError(f"{what} must be a positive finite number, got {value!r}")
    return v


# -------------------------------------------------------------- recording ---


def default_blueprint(*, signals: bool = True, structure: bool = True, frfs: bool = True):
    """The viewer layout: 3-D structure left, signal and FRF plots right.

    Parameters
    ----------
    signals, structure, frfs : bool
        Which views to include (a view of an empty entity is just blank).

    Returns
    -------
    rerun.blueprint.Blueprint
        With the time panel on the ``sim_time`` timeline.
    """
    import rerun.blueprint as rrb

    plots = []
    if signals:
        plots.append(rrb.TimeSeriesView(origin=SIGNALS_ROOT, name="signals vs sim_time [s]"))
    if frfs:
        plots.append(rrb.TimeSeriesView(origin=FRF_ROOT,
                                        name="FRF log10|H| vs frequency_mhz (1 Hz = 1000)"))
    views = []
    if structure:
        views.append(rrb.Spatial3DView(origin="structure", name="deformed shape"))
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
        Also start a rerun viewer process with :func:`spawn_viewer` (its
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
        ``spawn`` and the viewer did not start (see :func:`spawn_viewer`).
    """
    rr = _rr()
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


def _viewer_executable() -> str | None:
    """The ``rerun`` viewer executable: on ``PATH`` or beside the Python interpreter."""
    import os
    import shutil
    import sys

    return shutil.which("rerun") or shutil.which("rerun", path=os.path.dirname(sys.executable))


def viewer_command(port: int, *, executable: str = "rerun", headless: bool = False,
                   memory_limit: str = "75%") -> list[str]:
    """The command line that starts a rerun viewer listening on the loopback address only.

    rerun's own :func:`rerun.spawn` (rerun-sdk 0.41) starts ``rerun --port P``
    without ``--bind``, and the viewer's gRPC server then listens on
    ``0.0.0.0`` (``rerun --help``: "--bind: What bind address IP to use
    [default: 0.0.0.0]"), i.e. on every network interface: anyone on the
    network could stream data into it. This command adds
    ``--bind 127.0.0.1``.

    Parameters
    ----------
    port : int
        TCP port of the viewer's gRPC server, 1-65535.
    executable : str
        The ``rerun`` executable.
    headless : bool
        Add ``--headless`` (no window; the gRPC server still runs).
    memory_limit : str
        The viewer's ``--memory-limit`` (rerun's default for spawned viewers).

    Returns
    -------
    list of str
        ``[executable, "--bind", "127.0.0.1", "--port", str(port), ...]``.

    Raises
    ------
    ValueError
        ``port`` is not an integer in 1-65535.
    """
    if isinstance(port, bool) or not isinstance(port, int) or not 1 <= port <= 65535:
        raise ValueError(f"viewer port must be an integer in 1-65535, got {port!r}")
    cmd = [executable, "--bind", VIEWER_BIND_ADDRESS, "--port", str(port),
           f"--memory-limit={memory_limit}", "--expect-data-soon"]
    if headless:
        cmd.append("--headless")
    return cmd


def _free_loopback_port() -> int:
    import socket

    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind((VIEWER_BIND_ADDRESS, 0))
        return int(s.getsockname()[1])


def _kill_group(proc) -> None:
    """Kill a process started with ``start_new_session=True`` and its children (the ``rerun``
    launcher script runs the viewer binary as a child)."""
    import os
    import signal

    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError, AttributeError):
        proc.kill()
    proc.wait()


def spawn_viewer(*, port: int | None = None, timeout_s: float = 20.0, headless: bool = False,
                 executable: str | None = None):
    """Start a rerun viewer whose gRPC server listens on 127.0.0.1 only, and wait until it accepts connections.

    Replaces :meth:`rerun.RecordingStream.spawn`, whose viewer listens on
    all interfaces (see :func:`viewer_command`). The viewer runs in its own
    session (detached, like rerun's ``detach_process=True``), so it stays
    open after the run; its stderr goes to a temporary file that is quoted
    if it fails to start.

    Parameters
    ----------
    port : int, optional
        TCP port; a free loopback port if None.
    timeout_s : float
        How long to wait [s] for the viewer to accept a TCP connection on
        ``127.0.0.1:port``.
    headless : bool
        Start it without a window (``--headless``).
    executable : str, optional
        The ``rerun`` executable; looked up on ``PATH`` and beside the
        Python interpreter if None.

    Returns
    -------
    process : subprocess.Popen
        The viewer process.
    url : str
        Its gRPC proxy URL, ``rerun+http://127.0.0.1:<port>/proxy``, for
        :class:`rerun.GrpcSink`.

    Raises
    ------
    RuntimeError
        No ``rerun`` executable; the viewer exited before accepting
        connections (the message quotes the end of its stderr); or it did
        not accept a connection within ``timeout_s`` (it is then killed, with
        its process group).
    """
    import os
    import socket
    import subprocess
    import tempfile
    import time

    exe = executable or _viewer_executable()
    if exe is None:
        raise RuntimeError("the rerun viewer executable is not on PATH")
    port = _free_loopback_port() if port is None else port
    cmd = viewer_command(port, executable=exe, headless=headless)
    env = dict(os.environ, RERUN_APP_ONLY="true")  # as rerun's spawn: no analytics prompt
    with tempfile.TemporaryFile() as log:
        proc = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=log,
                                env=env, start_new_session=True)
        deadline = time.monotonic() + float(timeout_s)
        while True:
            try:
                with socket.create_connection((VIEWER_BIND_ADDRESS, port), timeout=0.5):
                    break
            except OSError:
                pass
            if proc.poll() is not None:
                log.seek(0)
                tail = log.read().decode("utf-8", "replace").strip().splitlines()[-3:]
                raise RuntimeError(f"the rerun viewer exited with status {proc.returncode} before "
                                   f"accepting connections on {VIEWER_BIND_ADDRESS}:{port}: "
                                   + " | ".join(tail))
            if time.monotonic() > deadline:
                _kill_group(proc)
                raise RuntimeError(f"the rerun viewer did not accept connections on "
                                   f"{VIEWER_BIND_ADDRESS}:{port} within {timeout_s} s")
            time.sleep(0.05)
    return proc, f"rerun+http://{VIEWER_BIND_ADDRESS}:{port}/proxy"


def viewer_unavailable_reason() -> str | None:
    """Why a live rerun viewer (``spawn=True``) cannot be started here, or None if it can be tried.

    Checked before a run starts (``vlab experiment --spawn``), so that a run
    is not done only to fail when the viewer is spawned: on Linux and other
    X11/Wayland systems a display (``DISPLAY`` or ``WAYLAND_DISPLAY``) is
    needed, and on every system the ``rerun`` viewer executable (on ``PATH``
    or beside the Python interpreter).

    Returns
    -------
    str or None
        A one-line reason, or None.
    """
    import os
    import sys

    if sys.platform.startswith(("linux", "freebsd", "openbsd", "netbsd")) and not (
            os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        return "no display: neither DISPLAY nor WAYLAND_DISPLAY is set"
    if _viewer_executable() is None:
        return "the rerun viewer executable is not on PATH"
    return None


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
        The entity paths written.

    Raises
    ------
    MeasurementError
        A name that is not a valid entity path, or a ``time_s`` / signal
        array that is not 1-D, not finite, or of another length than
        ``time_s`` (the message names the signal).
    """
    rr = _rr()
    t = _finite_1d(time_s, "time_s")
    units = dict(units or {})
    paths = []
    for name, values in signals.items():
        _check_name(name, "signal")
        y = _finite_1d(values, f"signal {name!r}", n=t.size)
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
        The entity paths written.

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
    rr = _rr()
    text = json.dumps(dict(metadata), indent=2, sort_keys=True, default=str)
    rec.log(entity, rr.TextDocument(f"```json\n{text}\n```", media_type=rr.MediaType.MARKDOWN),
            static=True)
    return entity


# -------------------------------------------------------------- structure ---


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
        From :func:`open_recording`.
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
    rr = _rr()
    ids, xy = _points_table(structure_points, None)
    rows = _member_rows(members, ids)
    xyz = np.column_stack([xy, np.zeros(len(ids))])
    rec.log("structure", rr.ViewCoordinates.RIGHT_HAND_Y_UP, static=True)
    rec.log(STRUCTURE_UNDEFORMED,
            rr.LineStrips3D([xyz[r] for r in rows], colors=[_UNDEFORMED_COLOR], radii=[_radius(xy) * 0.5]),
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
    dt_s = _positive(dt_s, "dt_s")
    fps = _positive(fps, "fps")
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
        From :func:`open_recording`.
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
    rr = _rr()
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
    s = auto_scale(xy, w) if scale is None else _positive(scale, "scale")
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
            rr.LineStrips3D.from_fields(colors=[_MEMBER_COLOR], radii=[radius],
                                        labels=[f"w x {s:.3g}"], show_labels=False),
            static=True)
    rec.send_columns(STRUCTURE_MEMBERS, indexes=index,
                     columns=rr.LineStrips3D.columns(strips=strips).partition([len(rows)] * n_kept))
    rec.log(STRUCTURE_POINTS,
            rr.Points3D.from_fields(colors=[_POINT_COLOR], radii=[2.5 * radius],
                                    labels=[str(p) for p in ids], show_labels=True),
            static=True)
    rec.send_columns(STRUCTURE_POINTS, indexes=index,
                     columns=rr.Points3D.columns(positions=pos.reshape(-1, 3)).partition([n_pts] * n_kept))
    return s


# -------------------------------------------------------------------- FRF ---


def _frf_arrays(name: str, frf: Any) -> tuple[np.ndarray, np.ndarray]:
    """(freq_hz, h) from a ``(freq_hz, h)`` pair or an object with ``freq_hz`` and ``h``."""
    if hasattr(frf, "freq_hz") and hasattr(frf, "h"):
        f, h = frf.freq_hz, frf.h
    elif isinstance(frf, (tuple, list)) and len(frf) == 2:
        f, h = frf
    else:
        raise MeasurementError(
            f"FRF {name!r}: expected a (freq_hz, h) pair or an object with freq_hz and h, "
            f"got {type(frf).__name__}")
    f = _finite_1d(f, f"FRF {name!r} freq_hz")
    h = np.asarray(h)
    if h.ndim != 1 or h.size != f.size:
        raise MeasurementError(f"FRF {name!r}: h has shape {h.shape}, freq_hz has shape {f.shape}")
    if not np.all(np.isfinite(h)):
        raise MeasurementError(f"FRF {name!r}: h has non-finite values")
    if f.size and f[0] < 0.0:
        raise MeasurementError(f"FRF {name!r}: negative frequency {f[0]} Hz")
    return f, h


def log_frfs(rec, frfs: Mapping[str, Any]) -> list[str]:
    """Log FRF magnitudes as ``log10 |H|`` scalars on the ``frequency_mhz`` timeline.

    Parameters
    ----------
    rec : rerun.RecordingStream
        From :func:`open_recording`.
    frfs : mapping of str to FRF
        Name -> ``(freq_hz, h)`` with ``freq_hz`` shape (n_freq,) [Hz],
        increasing, and ``h`` shape (n_freq,) complex or real (SI units,
        e.g. (m/s)/N), or any object with ``freq_hz`` and ``h`` attributes
        (:class:`vlab.io.frf.FRF`). Names become entity paths
        ``frf/<name>/magnitude``; use e.g. ``"experiment/vel4_force4"`` and
        ``"analysis/vel4_force4"``. Grids may differ between FRFs.

    Returns
    -------
    list of str
        The entity paths written.

    Raises
    ------
    MeasurementError
        Mismatched ``freq_hz``/``h`` shapes, non-finite values, negative
        frequencies, or frequencies not strictly increasing after rounding
        to 1 mHz (names the FRF); invalid names.
    """
    rr = _rr()
    paths = []
    for i, (name, frf) in enumerate(frfs.items()):
        _check_name(name, "FRF")
        f, h = _frf_arrays(name, frf)
        mhz = np.rint(f * 1000.0).astype(np.int64)
        if np.any(np.diff(mhz) <= 0):
            raise MeasurementError(
                f"FRF {name!r}: frequencies must be strictly increasing and at least 1 mHz apart "
                f"(timeline {FREQUENCY_TIMELINE!r})")
        mag = np.abs(h).astype(float)
        with np.errstate(divide="ignore"):
            logmag = np.where(mag > 0.0, np.log10(np.where(mag > 0.0, mag, 1.0)), np.nan)
        entity = f"{FRF_ROOT}/{name}/magnitude"
        rec.log(entity, rr.SeriesLines(names=f"{name} log10|H|", colors=[_PALETTE[i % len(_PALETTE)]]),
                static=True)
        rec.send_columns(entity, indexes=[rr.TimeColumn(FREQUENCY_TIMELINE, sequence=mhz)],
                         columns=rr.Scalars.columns(scalars=logmag))
        paths.append(entity)
    return paths


# ------------------------------------------------------------------ entry ---


def log_experiment(path: str | Path | None, *, recording=None,
                   structure_points: Mapping[int, Sequence[float]] | None = None,
                   members: Sequence[Any] | None = None, displacement: Any = None,
                   displacement_dt_s: float | None = None, point_ids: Sequence[int] | None = None,
                   frfs: Mapping[str, Any] | None = None, extra_signals: Mapping[str, Any] | None = None,
                   extra_units: Mapping[str, str] | None = None, metadata: Mapping[str, Any] | None = None,
                   fps: float = 50.0, scale: float | None = None, spawn: bool = False,
                   app_id: str = "vlab", recording_id: str | None = None) -> Path | None:
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
        See :func:`log_frfs` -> ``frf/<name>/magnitude``.
    extra_signals, extra_units : mapping, optional
        Series on the recording's time base that are not channels, e.g.
        controller commands ``{"u5": ...}`` [N] -> ``signals/u5``.
    metadata : mapping, optional
        Written to ``meta/run`` as JSON.
    fps : float
        Animation frames per simulated second.
    scale : float, optional
        Display factor on the displacement (default :func:`auto_scale`).
    spawn : bool
        Also open a live rerun viewer.
    app_id, recording_id : str
        rerun application / recording id.

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
        Displacement without geometry; unknown point ids in members.
    DataFileError
        Bad ``path``.
    """
    has_geom = structure_points is not None and members is not None
    if (structure_points is None) != (members is None):
        raise ModelError("structure_points and members must be given together")
    if displacement is not None:
        if not has_geom:
            raise ModelError("displacement needs structure_points and members to be drawn")
        if displacement_dt_s is None:
            if recording is None:
                raise MeasurementError("displacement needs displacement_dt_s (or a recording to take dt_s from)")
            displacement_dt_s = recording.dt_s
    if extra_signals and recording is None:
        raise MeasurementError("extra_signals need a recording for their time base")

    bp = default_blueprint(signals=recording is not None, structure=has_geom, frfs=bool(frfs))
    rec = open_recording(path, app_id=app_id, recording_id=recording_id, spawn=spawn, blueprint=bp)
    try:
        meta = {}
        if recording is not None:
            meta.update(recording.metadata)
        meta.update(metadata or {})
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
            log_frfs(rec, frfs)
    finally:
        close_recording(rec)
    return None if path is None else Path(path)


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
