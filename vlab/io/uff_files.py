"""UFF files: reading and writing whole files, and the header checks shared by vlab's UFF readers.

Used by :mod:`vlab.io.uff` (datasets 58) and :mod:`vlab.io.uff55` (dataset
55): existence and truncation checks, atomic writes, ID lines, and checks of
the integer fields (node, direction) and unit labels of a record.

Source: UFF dataset descriptions (SDRC/I-DEAS, https://www.ceas3.uc.edu/sdrluff/);
pyuff (Slavic et al., https://github.com/ladisk/pyuff).
"""

from __future__ import annotations

import math
import os
import re
import uuid
from pathlib import Path

import pyuff

from ..errors import DataFileError
from .uff_units import check_units_records

_RECORD_RE = re.compile(r"^record (\d+) of (\d+)$")
#: Unit labels accepted for each quantity (compared case-insensitively; ``NONE`` or empty = not given).
_UNIT_LABELS = {"displacement": {"m"}, "velocity": {"m/s"}, "acceleration": {"m/s^2", "m/s2", "m/s**2"},
                "force": {"n"}}
#: UFF direction codes of a translation (1..3 = X, Y, Z; negative = opposite sense).
_TRANSLATIONS = (-3, -2, -1, 1, 2, 3)
_UNITS = {"displacement": "m", "velocity": "m/s", "acceleration": "m/s^2", "force": "N"}


# --------------------------------------------------------------------------- files
def sidecar_path(path: str | os.PathLike) -> Path:
    """Path of the JSON metadata sidecar of a UFF file: ``<path>.json``."""
    p = Path(path)
    return p.with_name(p.name + ".json")


def _check_target(path: Path, overwrite: bool, *others: Path) -> None:
    for p in (path, *others):
        if p.exists() and not overwrite:
            raise DataFileError(f"{p}: file exists; pass overwrite=True to replace it")
    if not path.parent.is_dir():
        raise DataFileError(f"{path}: directory {path.parent} does not exist")


def _tmp_path(path: Path) -> str:
    """An unused name next to ``path`` for writing before the final move."""
    return str(path.with_name(f".{path.name}.{os.getpid()}.{uuid.uuid4().hex[:12]}.tmp"))


def _write_uff(path: Path, dsets: list[dict]) -> None:
    """Write datasets to a fresh temporary file and move it to ``path``.

    pyuff's 'overwrite' mode truncates the header of a binary first record,
    so the records are always appended ('add') to the new temporary file.
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


def _write_text(path: Path, text: str) -> None:
    tmp = _tmp_path(path)
    try:
        with open(tmp, "x", encoding="utf-8") as fh:
            fh.write(text)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def _read_uff(path: str | os.PathLike) -> tuple[Path, list[dict]]:
    """All datasets of a UFF file, after checks for existence and truncation."""
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
    check_units_records(p, sets)
    return p, sets


def _check_record_count(path: Path, sets: list[dict]) -> None:
    """Use vlab's ``id5 = 'record i of n'`` to detect missing records."""
    counts = set()
    for s in sets:
        m = _RECORD_RE.match(str(s.get("id5", "")).strip())
        if m:
            counts.add(int(m.group(2)))
    if counts and (len(counts) > 1 or counts.pop() != len(sets)):
        raise DataFileError(f"{path}: truncated UFF: {len(sets)} dataset-58 record(s) found, "
                            "the ID lines announce a different number")


def _ids(name: str, kind: str, i: int, n: int, id3: str = "NONE", id4: str = "NONE") -> dict:
    for line in (name, kind, id3, id4):
        if len(line) > 80:
            raise DataFileError(f"UFF ID line longer than 80 characters: {line!r}")
    return {"id1": name, "id2": kind, "id3": id3, "id4": id4, "id5": f"record {i} of {n}"}


def _label(dset: dict, fallback: str) -> str:
    name = str(dset.get("id1", "")).strip()
    return name if name and name.upper() != "NONE" else fallback


def _get_int(p: Path, s: dict, key: str, where: str) -> int:
    """Integer header field ``key`` of a record (``where`` names the record in the error)."""
    if key not in s:
        raise DataFileError(f"{p}: {where}: header field {key!r} is missing")
    try:
        v = float(s[key])
    except (TypeError, ValueError):
        raise DataFileError(f"{p}: {where}: header field {key!r} is not a number: {s[key]!r}") from None
    if not math.isfinite(v) or v != int(v):
        raise DataFileError(f"{p}: {where}: header field {key!r} is not an integer: {s[key]!r}")
    return int(v)


def _check_unit_label(p: Path, s: dict, quantity: str, where: str) -> None:
    """Refuse an ordinate unit label that contradicts the specific data type (``in/s`` on a velocity)."""
    lab = str(s.get("ordinate_axis_units_lab", "") or "").strip()
    if lab and lab.upper() != "NONE" and lab.lower() not in _UNIT_LABELS[quantity]:
        raise DataFileError(f"{p}: {where}: ordinate unit label {lab!r} does not match its data type "
                            f"{quantity} (SI {_UNITS[quantity]!r} expected; vlab reads SI only)")


def _check_direction(p: Path, s: dict, key: str, where: str) -> int:
    d = _get_int(p, s, key, where)
    if d not in _TRANSLATIONS:
        raise DataFileError(f"{p}: {where}: {key} = {d} is not a translation direction code "
                            f"(expected one of {list(_TRANSLATIONS)}; 3 = out of plane)")
    return d


def _check_node(p: Path, s: dict, key: str, where: str) -> int:
    n = _get_int(p, s, key, where)
    if n < 1:
        raise DataFileError(f"{p}: {where}: {key} = {n} is not a point id (positive integers)")
    return n
