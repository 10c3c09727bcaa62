"""The setup of the test that made a recording, from a ``test.toml``: what a recording without vlab's sidecar needs.

A recording from an acquisition system carries its channels (node, direction,
quantity, unit) but not the test around them: which structure, which
controller ran with which hardware chain, where the force acted, the
excitation's period, and how the system's node numbers map to the
structure's points. ``vlab init test`` writes a commented ``test.toml``
(:func:`setup_text`); ``vlab diagnose --test test.toml --recording FILE``
reads it (:func:`read_setup`). Its fields are the metadata fields of the
JSON sidecar ``vlab experiment`` writes next to a recording (``controller``,
``reduction``, ``seed``, ``plant``, ``resolution_hz``, ``chain``): a sidecar
is one such setup, and :func:`setup_text` writes a ``test.toml`` from a
sidecar's metadata.

Fields (all optional but ``structure``)::

    structure = "bcc"          # a shipped structure, or a structure file (path relative to test.toml)
    controller = "none"        # the controller that ran
    reduction = "exact"        # its design model
    seed = 0                   # its design's multi-start seed
    plant = "mujoco"           # only for a recording vlab made: "mujoco" or "linear"
    [excitation]  point = 9, resolution_hz = 0.05
    [sensors]     quantity = "acceleration", points = [1, 2, 3]
    [nodes]       101 = 1      # the file's node -> the structure's point
    [chain]       delay_periods, filter_hz, amplifier_gain, amplifier_limit_n

A wrong field raises :class:`vlab.errors.SpecError` naming the file and the
field (:class:`vlab.spec.reader.TableReader`); an unknown field too (a typo is
never ignored).
"""

from __future__ import annotations

import json
import math
import os
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import DataFileError, SpecError
from ..spec.reader import TableReader, read_number
from .recording import Channel, Recording
from .uff_acquired import acquired_channel_name

#: What a sensor may measure (``[sensors] quantity``).
SENSOR_QUANTITIES = ("displacement", "velocity", "acceleration")

#: The plants vlab records on (``plant``) -> the label its sidecar writes.
PLANT_LABELS = {"mujoco": "MuJoCo plant", "linear": "linear FE model"}

#: The hardware-chain fields (``[chain]``; SI, the delay in controller periods), as a sidecar's ``chain``.
CHAIN_KEYS = ("delay_periods", "filter_hz", "amplifier_gain", "amplifier_limit_n")


@dataclass(frozen=True)
class RecordingSetup:
    """The test that made a recording (:func:`read_setup`).

    Attributes
    ----------
    path : Path
        The ``test.toml``.
    structure : str
        A shipped structure's name, or a structure file's path (resolved against the test file's folder).
    metadata : dict
        The fields a sidecar holds (``controller``, ``reduction``, ``seed``, ``plant`` as its label,
        ``resolution_hz`` [Hz], ``chain``); only those given.
    excitation_point : int or None
        The structure point the excitation force acted at.
    sensor_quantity : str or None
        What every motion channel measures (one of :data:`SENSOR_QUANTITIES`).
    sensor_points : tuple of int
        The points whose motion channels are used (empty: all).
    nodes : dict
        The file's node number -> the structure's point id.
    """

    path: Path
    structure: str
    metadata: dict = field(default_factory=dict)
    excitation_point: int | None = None
    sensor_quantity: str | None = None
    sensor_points: tuple[int, ...] = ()
    nodes: dict = field(default_factory=dict)


def _point_id(r: TableReader, key: str, v: Any) -> int:
    """A positive integer point or node id (SpecError naming the field)."""
    if isinstance(v, bool) or not isinstance(v, int) or v < 1:
        r.fail(key, f"expected a positive integer point id, got {v!r}")
    return int(v)


def _structure(r: TableReader, path: Path) -> str:
    """``structure``: a name, or a ``.toml`` path resolved against the test file's folder."""
    s = r.str("structure").strip()
    if not s:
        r.fail("structure", "empty: name a shipped structure (bcc, grid) or a structure file")
    if s.endswith(".toml"):
        p = Path(s).expanduser()
        p = p if p.is_absolute() else (path.parent / p)
        if not p.is_file():
            r.fail("structure", f"structure file {p} not found (a path is read relative to the test setup's folder)")
        return str(p)
    return s


def _top_metadata(r: TableReader) -> dict:
    """``controller``, ``reduction``, ``seed`` and ``plant`` as a sidecar's metadata."""
    meta: dict = {}
    for key in ("controller", "reduction"):
        v = r.raw(key, None, types=(str,))
        if v is not None:
            meta[key] = v.strip().lower()
    seed = r.raw("seed", None, types=(int,))
    if seed is not None:
        if isinstance(seed, bool) or seed < 0:
            r.fail("seed", f"expected a non-negative integer, got {seed!r}")
        meta["seed"] = int(seed)
    plant = r.raw("plant", None, types=(str,))
    if plant is not None:
        if plant not in PLANT_LABELS:
            r.fail("plant", f"{plant!r}: one of {', '.join(PLANT_LABELS)} (the vlab plant that made the recording; "
                            "omit it for a recording of a real structure)")
        meta["plant"] = PLANT_LABELS[plant]
    return meta


def _chain(r: TableReader | None) -> dict:
    """``[chain]``: non-negative numbers, a positive filter corner."""
    if r is None:
        return {}
    chain = {}
    for key in CHAIN_KEYS:
        if r.has(key):
            chain[key] = read_number(r, key, low=0.0, low_open=key == "filter_hz")
    r.done()
    return chain


def _sensors(r: TableReader | None) -> tuple[str | None, tuple[int, ...]]:
    """``[sensors]``: the motion quantity and the points used."""
    if r is None:
        return None, ()
    q = r.raw("quantity", None, types=(str,))
    if q is not None and q not in SENSOR_QUANTITIES:
        r.fail("quantity", f"{q!r}: one of {', '.join(SENSOR_QUANTITIES)}")
    pts = r.raw("points", [], types=(list,))
    points = tuple(_point_id(r, "points", v) for v in pts)
    if len(set(points)) != len(points):
        r.fail("points", f"repeated point ids in {list(points)}")
    r.done()
    return q, points


def _nodes(r: TableReader | None) -> dict:
    """``[nodes]``: the file's node -> the structure's point, one point per node."""
    if r is None:
        return {}
    nodes = {}
    for key in list(r.table):
        try:
            node = int(key)
        except ValueError:
            r.fail(key, "expected a node number as the key (101 = 1)")
        nodes[_point_id(r, key, node)] = _point_id(r, key, r.raw(key))
    twice = sorted({p for p in nodes.values() if list(nodes.values()).count(p) > 1})
    if twice:
        r.fail("", f"point(s) {twice} given to more than one node")
    return nodes


def read_setup(path: str | os.PathLike) -> RecordingSetup:
    """Read a ``test.toml``: the setup of the test that made a recording.

    Parameters
    ----------
    path : str or path-like
        The file (format in the module docstring).

    Returns
    -------
    RecordingSetup

    Raises
    ------
    DataFileError
        A missing or unreadable file, or text that is not TOML (names the file and the parser's line).
    SpecError
        A missing ``structure`` (or a structure file that does not exist), a field of the wrong type or range,
        an unknown field or table (names the file and the field).
    """
    p = Path(path)
    try:
        doc = tomllib.loads(p.read_text(encoding="utf-8"))
    except OSError as exc:
        raise DataFileError(f"{p}: cannot read the test setup: {exc.strerror or exc}") from exc
    except (UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise DataFileError(f"{p}: not a TOML test setup: {exc}") from exc
    top = TableReader(str(p), doc, "")
    structure = _structure(top, p)
    meta = _top_metadata(top)
    exc_r = top.sub("excitation", None)
    point = None
    if exc_r is not None:
        if exc_r.has("point"):
            point = _point_id(exc_r, "point", exc_r.raw("point"))
        if exc_r.has("resolution_hz"):
            meta["resolution_hz"] = read_number(exc_r, "resolution_hz")
        exc_r.done()
    chain = _chain(top.sub("chain", None))
    if chain:
        meta["chain"] = chain
    quantity, points = _sensors(top.sub("sensors", None))
    nodes = _nodes(top.sub("nodes", None))
    top.done()
    return RecordingSetup(p, structure, meta, point, quantity, points, nodes)


def _renumbered(rec: Recording, nodes: dict, notes: list) -> list[Channel]:
    """The channels with their nodes mapped to points (``nodes``), renamed as vlab names them."""
    out = []
    for c in rec.channels:
        p = nodes.get(c.point_id, c.point_id)
        name = acquired_channel_name(c.quantity, p, c.direction) if p != c.point_id else c.name
        out.append(Channel(name=name, point_id=p, quantity=c.quantity, samples=c.samples, direction=c.direction))
    moved = [f"{c.name}->{o.name}" for c, o in zip(rec.channels, out) if c.name != o.name]
    if moved:
        notes.append(f"nodes mapped to the structure's points: {', '.join(moved)}")
    return out


def _force_at(chans: list[Channel], point: int, source: str, notes: list) -> list[Channel]:
    """Keep, of the out-of-plane force channels, the one at the excitation ``point``."""
    forces = [c for c in chans if c.quantity == "force" and abs(c.direction) == 3]
    hit = [c for c in forces if c.point_id == point]
    if not hit:
        raise DataFileError(f"{source}: no out-of-plane force channel at the excitation point {point} of the test "
                            f"setup (force channels: {[c.name for c in forces] or 'none'})")
    other = [c for c in forces if c.point_id != point]
    if other:
        notes.append(f"force channels other than the excitation at point {point} left out: "
                     f"{', '.join(c.name for c in other)}")
    return [c for c in chans if all(c is not o for o in other)]


def _sensors_of(chans: list[Channel], setup: RecordingSetup, source: str, notes: list) -> list[Channel]:
    """Check the motion channels' quantity; keep those at the setup's sensor points."""
    motion = [c for c in chans if c.quantity != "force"]
    if setup.sensor_quantity is not None:
        bad = [c.name for c in motion if c.quantity != setup.sensor_quantity]
        if bad:
            raise DataFileError(f"{source}: channel(s) {bad} do not measure {setup.sensor_quantity} as the test setup "
                                f"{setup.path} says (the file's headers say {sorted({c.quantity for c in motion})})")
    if not setup.sensor_points:
        return chans
    missing = sorted(set(setup.sensor_points) - {c.point_id for c in motion})
    if missing:
        raise DataFileError(f"{source}: no motion channel at the sensor point(s) {missing} of the test setup "
                            f"{setup.path} (motion channels: {[c.name for c in motion]})")
    left = [c for c in motion if c.point_id not in setup.sensor_points]
    if left:
        notes.append(f"motion channels at points the test setup does not list left out: "
                     f"{', '.join(c.name for c in left)}")
    return [c for c in chans if all(c is not o for o in left)]


def apply_setup(rec: Recording, setup: RecordingSetup, source: str) -> tuple[Recording, tuple[str, ...]]:
    """A recording seen through its test setup: nodes mapped to points, the excitation's force channel and the
    sensors' channels kept.

    Parameters
    ----------
    rec : Recording
        As read (any rate and quantity).
    setup : RecordingSetup
    source : str
        The recording's file (for messages).

    Returns
    -------
    recording : Recording
        The same samples and metadata; channels renumbered (``acc101`` -> ``acc1`` for ``101 = 1``),
        force channels other than the excitation's and motion channels at unlisted points removed.
    notes : tuple of str
        What was mapped or left out.

    Raises
    ------
    DataFileError
        No force channel at the excitation point; a motion channel of another quantity than the setup's
        sensors; a sensor point without a channel; two channels of one name after the mapping.
    """
    notes: list[str] = []
    chans = _renumbered(rec, setup.nodes, notes)
    names = [c.name for c in chans]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise DataFileError(f"{source}: the node map of {setup.path} gives two channels the name(s) {dup}")
    if setup.excitation_point is not None:
        chans = _force_at(chans, setup.excitation_point, source, notes)
    chans = _sensors_of(chans, setup, source, notes)
    return Recording(rec.dt_s, tuple(chans), dict(rec.metadata)), tuple(notes)


def _value(v: Any) -> str:
    """A TOML value: a string as a basic string (JSON's escapes are TOML's), a float in full precision."""
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, float) and math.isfinite(v):
        return repr(v)
    return str(v)


def setup_text(structure: str, metadata: dict | None = None, *, excitation_point: int | None = None) -> str:
    """The commented text of a ``test.toml`` (``vlab init test``), its values from a sidecar's metadata if given.

    Parameters
    ----------
    structure : str
        A shipped structure's name or a structure file's path.
    metadata : dict, optional
        A recording's sidecar metadata (``controller``, ``reduction``, ``seed``, ``plant``, ``resolution_hz``,
        ``chain``): the fields it has are written as values, the others as commented examples.
    excitation_point : int, optional
        The structure's excitation point (written as ``[excitation] point``).

    Returns
    -------
    str
        TOML text that :func:`read_setup` reads.

    Raises
    ------
    SpecError
        A metadata ``plant`` that is not one of vlab's plants' labels.
    """
    meta = dict(metadata or {})
    plant = meta.get("plant")
    kinds = {label: kind for kind, label in PLANT_LABELS.items()} | {"MuJoCo plant (MJCF)": "mujoco"}
    if plant is not None and plant not in kinds:
        raise SpecError(f"metadata plant {plant!r}: not one of vlab's plants ({', '.join(kinds)})")

    def line(key: str, value: Any, example: str, comment: str) -> str:
        text = f"{key} = {_value(value)}" if value is not None else f"# {key} = {example}"
        return f"{text:<32}# {comment}\n"

    chain = dict(meta.get("chain") or {})
    return (
        "# The test that made a recording: `vlab diagnose --test THIS_FILE --recording FILE`.\n"
        "# It says what a recording without vlab's sidecar cannot: the structure, the controller that ran, the\n"
        "# hardware chain, where the force acted and the excitation's period. Omitted fields: the structure's\n"
        "# nominal values (its [instrumentation] and [test] tables, the Sec. 5.3 chain).\n\n"
        + line("structure", structure, '"bcc"', "a shipped structure, or a structure file (relative to this file)")
        + line("controller", meta.get("controller", "none"), '"none"', "none, mfdrf, lqdrf, lqdrf-diag or lqg")
        + line("reduction", meta.get("reduction"), '"exact"', "the controller's design model (default: the design's)")
        + line("seed", meta.get("seed"), "0", "the seed of the controller design's multi-start")
        + line("plant", kinds.get(plant) if plant else None, '"mujoco"',
               "only for a recording vlab made (mujoco or linear); omit it for a real structure")
        + "\n[excitation]\n"
        + line("point", excitation_point, "9", "the structure point the excitation force acted at (a coil)")
        + line("resolution_hz", meta.get("resolution_hz"), "0.05",
               "a periodic excitation's line spacing = 1 / its period [Hz]")
        + "\n[sensors]\n"
        + line("quantity", None, '"acceleration"', "what the motion channels measure (checked against the file)")
        + line("points", None, "[1, 2, 3]", "the points whose channels are used (default: all)")
        + "\n[nodes]                         # the file's node -> the structure's point, where they differ\n"
        + line("101", None, "1", "node 101 of the file is point 1")
        + "\n[chain]                         # the digital loop's hardware (Sec. 5.3)\n"
        + line("delay_periods", chain.get("delay_periods"), "1.35", "computation delay [controller periods]")
        + line("filter_hz", chain.get("filter_hz"), "677.0", "the RC output filter's corner [Hz]")
        + line("amplifier_gain", chain.get("amplifier_gain"), "1.0", "power amplifier gain [N/N]")
        + line("amplifier_limit_n", chain.get("amplifier_limit_n"), "10.0", "the amplifier's saturation [N]"))
