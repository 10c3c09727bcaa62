"""Identifying and changing a loaded structure: :func:`vlab.spec.structure_identity`, :func:`vlab.spec.with_quantity`."""

from __future__ import annotations

import dataclasses
import hashlib
import json
from typing import Any

from ..errors import SpecError
from .structure import Quantity, StructureSpec

_COLLECTIONS = ("strings", "masses", "crosspieces", "springs")


def structure_identity(spec: StructureSpec) -> str:
    """SHA-256 (hex) of the structure's definition: its parsed document in a canonical form.

    Comments, layout and the order of keys do not count; every value, unit and source does. A spec
    built in code (no document) is identified by its ``repr``. A diagnosis stores it
    (``structure_sha256``) so that ``vlab update`` refuses to apply it to another structure.

    Parameters
    ----------
    spec : StructureSpec

    Returns
    -------
    str
        64 hex digits.
    """
    text = json.dumps(spec.raw, sort_keys=True, default=str) if spec.raw else repr(spec)
    return hashlib.sha256(text.encode()).hexdigest()


def with_quantity(spec: StructureSpec, path: str, value_si: float, source: str | None = None) -> StructureSpec:
    """Return a copy of ``spec`` with one quantity changed.

    Parameters
    ----------
    spec : StructureSpec
    path : str
        ``"<collection>.<id>.<field>"`` with collection one of strings, masses,
        crosspieces, springs (e.g. ``"strings.bottom_cables.tension"``), or
        ``"sections.<name>.<field>"`` for ``ei``, ``gj``, ``shear_stiffness``.
    value_si : float
        New value in SI.
    source : str, optional
        New provenance; defaults to the old one.

    Returns
    -------
    StructureSpec
        A new spec; ``spec`` is unchanged.

    Raises
    ------
    SpecError
        If the path names no quantity of the spec.
    """
    parts = path.split(".")
    if len(parts) != 3:
        raise SpecError(f"{spec._file()}: quantity path {path!r} must be '<collection>.<id>.<field>'")
    coll, ident, fld = parts

    def new_q(old: Any) -> Quantity:
        if not isinstance(old, Quantity):
            raise SpecError(f"{spec._file()}: {path!r} is not a quantity")
        return Quantity(float(value_si), source if source is not None else old.source)

    if coll == "sections":
        if ident not in spec.sections:
            raise SpecError(f"{spec._file()}: {path!r}: unknown section {ident!r}")
        sec = spec.sections[ident]
        if fld not in ("ei", "gj", "shear_stiffness"):
            raise SpecError(f"{spec._file()}: {path!r}: only ei, gj, shear_stiffness can be changed")
        old = getattr(sec, fld)
        q = new_q(old) if old is not None else Quantity(float(value_si), source or "modified")
        secs = dict(spec.sections)
        secs[ident] = dataclasses.replace(sec, **{fld: q})
        return spec.replace(sections=secs)
    if coll not in _COLLECTIONS:
        raise SpecError(f"{spec._file()}: {path!r}: unknown collection {coll!r}; use {_COLLECTIONS + ('sections',)}")
    items = list(getattr(spec, coll))
    for i, item in enumerate(items):
        if item.id == ident:
            if not hasattr(item, fld):
                raise SpecError(f"{spec._file()}: {path!r}: {coll} have no field {fld!r}")
            items[i] = dataclasses.replace(item, **{fld: new_q(getattr(item, fld))})
            return spec.replace(**{coll: tuple(items)})
    raise SpecError(f"{spec._file()}: {path!r}: no {coll} with id {ident!r}")
