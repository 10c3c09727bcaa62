"""UFF files: reading and writing whole files, and the header checks shared by vlab's UFF readers.

Used by :mod:`vlab.io.uff_time` and :mod:`vlab.io.uff_frf` (datasets 58) and
:mod:`vlab.io.uff55` (dataset 55): existence and truncation checks, atomic writes, ID lines, and checks of
the integer fields (node, direction) and unit labels of a record.

Source: UFF dataset descriptions (SDRC/I-DEAS, https://www.ceas3.uc.edu/sdrluff/);
pyuff (Slavic et al., https://github.com/ladisk/pyuff).
"""

from __future__ import annotations

import json
import math
import os
import re
import uuid
from pathlib import Path

import pyuff

from ..errors import DataFileError
from .uff_units import check_units_records

#: vlab's ID line 5 of every record: ``record i of n`` (a truncated file is detected by it).
RECORD_RE = re.compile(r"^record (\d+) of (\d+)$")
#: Unit labels accepted for each quantity (compared case-insensitively; ``NONE`` or empty = not given).
_UNIT_LABELS = {"displacement": {"m"}, "velocity": {"m/s"}, "acceleration": {"m/s^2", "m/s2", "m/s**2"},
                "force": {"n"}}
#: UFF direction codes of a translation (1..3 = X, Y, Z; negative = opposite sense).
_TRANSLATIONS = (-3, -2, -1, 1, 2, 3)
#: SI unit of each quantity, as vlab labels it.
UNITS = {"displacement": "m", "velocity": "m/s", "acceleration": "m/s^2", "force": "N"}
#: UFF specific data type code of each quantity.
SPEC_DATA_TYPE = {"displacement": 8, "velocity": 11, "acceleration": 12, "force": 13}
#: Quantity of each specific data type code vlab reads (9 and 13: force).
CODE_QUANTITY = {8: "displacement", 11: "velocity", 12: "acceleration", 13: "force", 9: "force"}
#: (length exponent, force exponent) of each quantity's unit.
UNIT_EXPONENTS = {"displacement": (1, 0), "velocity": (1, 0), "acceleration": (1, 0), "force": (0, 1)}
#: A conventional channel name: quantity prefix and point id (``vel4``).
CONVENTIONAL_NAME_RE = re.compile(r"^(force|disp|vel|acc)\d+$")


# --------------------------------------------------------------------------- files
def sidecar_path(path: str | os.PathLike) -> Path:
    """Path of the JSON metadata sidecar of a UFF file: ``<path>.json``."""
    p = Path(path)
    return p.with_name(p.name + ".json")


def sidecar_text(side: Path, metadata) -> str:
    """The JSON text of a sidecar holding ``metadata`` (sorted keys, no NaN).

    Parameters
    ----------
    side : Path
        The sidecar's path (for the message).
    metadata : mapping
        JSON-serialisable values.

    Raises
    ------
    DataFileError
        A value that is not JSON-serialisable (names the keys).
    """
    try:
        return json.dumps(dict(metadata), sort_keys=True, indent=2, allow_nan=False) + "\n"
    except (TypeError, ValueError) as exc:
        bad = [k for k, v in dict(metadata).items() if not _jsonable(v)]
        raise DataFileError(f"{side}: metadata key(s) {bad} not JSON-serialisable: {exc}") from exc


def _jsonable(v) -> bool:
    try:
        json.dumps(v, allow_nan=False)
        return True
    except (TypeError, ValueError):
        return False


def read_sidecar(path: Path) -> dict:
    """The metadata of the JSON sidecar of the UFF file ``path`` (:func:`sidecar_path`), ``{}`` without one.

    Parameters
    ----------
    path : Path
        The UFF file.

    Raises
    ------
    DataFileError
        An unreadable sidecar or one that does not hold a JSON object.
    """
    side = sidecar_path(path)
    meta: dict = {}
    if side.is_file():
        try:
            meta = json.loads(side.read_text(encoding="utf-8"))
        except (OSError, ValueError) as exc:
            raise DataFileError(f"{side}: unreadable metadata sidecar: {exc}") from exc
        if not isinstance(meta, dict):
            raise DataFileError(f"{side}: metadata sidecar must hold a JSON object")
    return meta


def check_target(path: Path, overwrite: bool, *others: Path) -> None:
    """Refuse to write ``path`` (and its companion files ``others``) over existing files or into a missing folder.

    Parameters
    ----------
    path : Path
        The file to write.
    overwrite : bool
        Replace existing files.
    *others : Path
        Files written with it (a sidecar).

    Raises
    ------
    DataFileError
        A file exists and ``overwrite`` is False, or the folder does not exist.
    """
    for p in (path, *others):
        if p.exists() and not overwrite:
            raise DataFileError(f"{p}: file exists; pass overwrite=True to replace it")
    if not path.parent.is_dir():
        raise DataFileError(f"{path}: directory {path.parent} does not exist")


def _tmp_path(path: Path) -> str:
    """An unused name next to ``path`` for writing before the final move."""
    return str(path.with_name(f".{path.name}.{os.getpid()}.{uuid.uuid4().hex[:12]}.tmp"))


def write_uff(path: Path, dsets: list[dict]) -> None:
    """Write datasets to a fresh temporary file and move it to ``path``.

    pyuff's 'overwrite' mode truncates the header of a binary first record,
    so the records are always appended ('add') to the new temporary file.

    Parameters
    ----------
    path : Path
        Target file (replaced if it exists).
    dsets : list of dict
        pyuff datasets.

    Raises
    ------
    DataFileError
        pyuff failed to write.
    """
    tmp = _tmp_path(path)
    try:
        pyuff.UFF(tmp).write_sets(dsets, mode="add")
        os.replace(tmp, path)
    except Exception as exc:  # pyuff raises bare Exception
        raise DataFileError(f"{path}: writing UFF failed: {exc}") from exc
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def write_text(path: Path, text: str) -> None:
    """Write ``text`` (UTF-8) to a fresh temporary file and move it to ``path``.

    Parameters
    ----------
    path : Path
        Target file (replaced if it exists).
    text : str
        Content.
    """
    tmp = _tmp_path(path)
    try:
        with open(tmp, "x", encoding="utf-8") as fh:
            fh.write(text)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def read_uff(path: str | os.PathLike, *, si_only: bool = True) -> tuple[Path, list[dict]]:
    """All datasets of a UFF file, after checks for existence, truncation and units.

    Parameters
    ----------
    path : str or path-like
        UFF file.
    si_only : bool
        Refuse a units record that is not SI (vlab's own files); False: leave
        the units record to the caller (:func:`vlab.io.uff_units.units_system`).

    Returns
    -------
    (Path, list of dict)
        The path and its non-empty pyuff datasets.

    Raises
    ------
    DataFileError
        Missing, empty, truncated or malformed file; records missing by vlab's
        ID line 5; with ``si_only``, a units record that is not SI
        (:func:`vlab.io.uff_units.check_units_records`).
    """
    p = Path(path)
    if not p.is_file():
        raise DataFileError(f"{p}: no such file")
    with open(p, "rb") as fh:
        fh.seek(0, os.SEEK_END)
        size = fh.tell()
        fh.seek(max(0, size - 16))
        tail = fh.read()
    if size == 0:
        raise DataFileError(f"{p}: empty file")
    if not tail.rstrip().endswith(b"    -1"):  # every dataset closes with '%6i' % -1
        raise DataFileError(f"{p}: truncated or malformed UFF (does not end with the '-1' delimiter)")
    try:
        sets = pyuff.UFF(str(p)).read_sets()
    except Exception as exc:  # pyuff raises bare Exception
        raise DataFileError(f"{p}: malformed UFF: {exc}") from exc
    if isinstance(sets, dict):
        sets = [sets]
    sets = [s for s in sets if s]  # pyuff returns {} for unsupported datasets
    _check_record_count(p, [s for s in sets if s.get("type") == 58])
    if si_only:
        check_units_records(p, sets)
    return p, sets


def _check_record_count(path: Path, sets: list[dict]) -> None:
    """Use vlab's ``id5 = 'record i of n'`` to detect missing records."""
    counts = set()
    for s in sets:
        m = RECORD_RE.match(str(s.get("id5", "")).strip())
        if m:
            counts.add(int(m.group(2)))
    if counts and (len(counts) > 1 or counts.pop() != len(sets)):
        raise DataFileError(f"{path}: truncated UFF: {len(sets)} dataset-58 record(s) found, "
                            "the ID lines announce a different number")


def id_lines(name: str, kind: str, i: int, n: int, id3: str = "NONE", id4: str = "NONE") -> dict:
    """The five ID lines of record ``i`` of ``n``: name, kind, two free lines and ``record i of n``.

    Parameters
    ----------
    name : str
        ID line 1 (channel name or ``output/input``).
    kind : str
        ID line 2 (what wrote it).
    i, n : int
        Record number (1-based) and record count, for ID line 5.
    id3, id4 : str
        ID lines 3 and 4.

    Returns
    -------
    dict
        ``id1`` .. ``id5`` for a pyuff dataset.

    Raises
    ------
    DataFileError
        A line longer than the 80 characters UFF allows.
    """
    for line in (name, kind, id3, id4):
        if len(line) > 80:
            raise DataFileError(f"UFF ID line longer than 80 characters: {line!r}")
    return {"id1": name, "id2": kind, "id3": id3, "id4": id4, "id5": f"record {i} of {n}"}


def record_label(dset: dict, fallback: str) -> str:
    """ID line 1 of a record, or ``fallback`` where it is empty or ``NONE``.

    Parameters
    ----------
    dset : dict
        A pyuff dataset.
    fallback : str
        The label to use without one.

    Returns
    -------
    str
    """
    name = str(dset.get("id1", "")).strip()
    return name if name and name.upper() != "NONE" else fallback


def get_int(p: Path, s: dict, key: str, where: str) -> int:
    """Integer header field ``key`` of a record.

    Parameters
    ----------
    p : Path
        The file, for the message.
    s : dict
        The pyuff dataset.
    key : str
        Header field.
    where : str
        The record, for the message (``"record 2"``).

    Returns
    -------
    int

    Raises
    ------
    DataFileError
        The field is missing, not a number or not an integer.
    """
    if key not in s:
        raise DataFileError(f"{p}: {where}: header field {key!r} is missing")
    try:
        v = float(s[key])
    except (TypeError, ValueError):
        raise DataFileError(f"{p}: {where}: header field {key!r} is not a number: {s[key]!r}") from None
    if not math.isfinite(v) or v != int(v):
        raise DataFileError(f"{p}: {where}: header field {key!r} is not an integer: {s[key]!r}")
    return int(v)


def check_unit_label(p: Path, s: dict, quantity: str, where: str) -> None:
    """Refuse an ordinate unit label that contradicts the specific data type (``in/s`` on a velocity).

    Parameters
    ----------
    p, s, where
        As :func:`get_int`.
    quantity : str
        The record's quantity (from its specific data type).

    Raises
    ------
    DataFileError
        A label that is neither empty, ``NONE`` nor the quantity's SI unit.
    """
    lab = str(s.get("ordinate_axis_units_lab", "") or "").strip()
    if lab and lab.upper() != "NONE" and lab.lower() not in _UNIT_LABELS[quantity]:
        raise DataFileError(f"{p}: {where}: ordinate unit label {lab!r} does not match its data type "
                            f"{quantity} (SI {UNITS[quantity]!r} expected; vlab reads SI only)")


def check_direction(p: Path, s: dict, key: str, where: str) -> int:
    """A direction field (``rsp_dir``, ``ref_dir``) that must be a translation code (+-1..3).

    Parameters ``p``, ``s``, ``key``, ``where``: as :func:`get_int`.

    Returns
    -------
    int
        The direction code, one of +-1, +-2, +-3.

    Raises
    ------
    DataFileError
        Missing, not an integer, or not a translation.
    """
    d = get_int(p, s, key, where)
    if d not in _TRANSLATIONS:
        raise DataFileError(f"{p}: {where}: {key} = {d} is not a translation direction code "
                            f"(expected one of {list(_TRANSLATIONS)}; 3 = out of plane)")
    return d


def check_node(p: Path, s: dict, key: str, where: str) -> int:
    """A node field (``rsp_node``, ``ref_node``) that must be a point id (a positive integer).

    Parameters ``p``, ``s``, ``key``, ``where``: as :func:`get_int`.

    Returns
    -------
    int
        The point id.

    Raises
    ------
    DataFileError
        Missing, not an integer, or below 1.
    """
    n = get_int(p, s, key, where)
    if n < 1:
        raise DataFileError(f"{p}: {where}: {key} = {n} is not a point id (positive integers)")
    return n
