"""Changes of a structure written as entries of its structure file: member rigidity, joint flexibility, the
damping ratio of one mode, a spring that replaces a support.

A structure file describes the structure as built; ``vlab update`` appends what a diagnosis found as
ordinary entries that the loader (:func:`vlab.spec.spec_from_dict`) applies after reading the rest, so
that the FE model (:mod:`vlab.fe`), the MuJoCo plant (:mod:`vlab.sim`) and the controller design all
read the changed structure. The tables (each an array of tables, every value with its source):

``[[member_stiffness]]``
    ``member`` (id), optional ``segment = [a, b]`` (two consecutive points of the member; default every
    segment), ``ei = { value, unit = "N*m^2", source }``: the new out-of-plane flexural rigidity of
    those segments. ``GJ`` scales with ``EI``.
``[[joint_flexibility]]``
    ``point``, ``rotational_stiffness = { value, unit = "N*m/rad", source }``: a semi-rigid connection
    of stiffness ``k_j`` at a point where members meet; each segment ending there gets
    ``EI' = EI / (1 + EI / (k_j L))`` (and ``GJ`` by the same factor).
``[[mode_damping]]``
    ``mode`` (1-based, in frequency order), ``ratio`` in [0, 1), ``source``: the open-loop damping ratio
    of that mode, replacing the ``[damping]`` table's entry.
``[[springs]]`` with ``replaces_support = true``
    The spring's DOF is released from the support at its point (a support of finite stiffness).
``[[masses]]`` and ``[[springs]]`` with ``added = true``
    An element attached to the structure the rest of the file describes.

A physical change (an added element, a member's rigidity, a joint) leaves the structure's damping matrix
as it was: the spec names the structure without them as its damping basis (:attr:`vlab.spec.Damping.basis`,
:func:`vlab.fe.damping.structural_damping`), so that its modal damping ratios move with its modes as a
fixed damping matrix makes them move -- as a diagnosis models the change
(:mod:`vlab.diagnose.effects.specedit`). ``[[mode_damping]]`` changes the ratios themselves (of the
basis's modes, numbered in frequency order).

A member is cut into pieces at the changed segments (same points, rigid inserts and subdivision; a run
of consecutive segments given the same rigidity stays one piece, a wholly changed member keeps its id);
each changed piece gets its own copy of the section (named ``<section>@<piece>``), so that the FE model
and the MuJoCo hinge chain change in those rigidities only.

Errors: :class:`vlab.errors.SpecError` naming the file and the field.
"""

from __future__ import annotations

import dataclasses
import math
import re
from typing import Any, Callable

from ..errors import SpecError
from .reader import read_damping_ratio
from .structure import Damping, Member, Quantity

#: The change tables this module reads, in the order they are applied.
CHANGE_TABLES = ("member_stiffness", "joint_flexibility", "mode_damping")


#: A member piece's id: the member it was cut from and its end points, ``beam[4-5]``.
_PIECE_ID = re.compile(r"^(?P<member>.+)\[(?P<a>-?\d+)-(?P<b>-?\d+)\](?:_\d+)?$")


def piece_id(member_id: str, a: int, b: int) -> str:
    """The id of the piece of member ``member_id`` from point ``a`` to point ``b`` (``beam[4-5]``), given to the
    members an edit of some segments' rigidity splits a member into.

    Parameters
    ----------
    member_id : str
    a, b : int
        Point ids of the piece's ends.

    Returns
    -------
    str
    """
    return f"{member_id}[{a}-{b}]"


def piece_ends(member_id: str) -> tuple[str, int, int] | None:
    """The member a piece was cut from and the piece's end points (the inverse of :func:`piece_id`, also with
    the ``_2`` suffix :func:`unique_id` may add), else None.

    Parameters
    ----------
    member_id : str

    Returns
    -------
    (str, int, int) or None
        ``(member, a, b)``.
    """
    m = _PIECE_ID.match(member_id)
    return None if m is None else (m["member"], int(m["a"]), int(m["b"]))


def cut_from(member_id: str) -> str | None:
    """The id of the member a piece was cut from (:func:`piece_ends`), else None.

    Parameters
    ----------
    member_id : str

    Returns
    -------
    str or None
    """
    ends = piece_ends(member_id)
    return None if ends is None else ends[0]


def unique_id(existing: set[str], base: str) -> str:
    """``base``, or ``base_2``, ``base_3``, ... : the first that is not in ``existing``.

    Parameters
    ----------
    existing : set of str
        Names already taken.
    base : str
        The name wanted.

    Returns
    -------
    str
    """
    name, i = base, 1
    while name in existing:
        i += 1
        name = f"{base}_{i}"
    return name


def _segment_length(points: dict, a: int, b: int) -> float:
    (xa, ya), (xb, yb) = points[a], points[b]
    return math.hypot(xb - xa, yb - ya)


def split_segments(spec, rigidity: dict[frozenset, float], source: str):
    """``spec`` with the listed member segments given their own section of out-of-plane rigidity ``EI``.

    Parameters
    ----------
    spec : StructureSpec
    rigidity : dict
        ``frozenset({a, b}) -> EI`` [N*m^2] of the segment between consecutive member points a and b;
        ``GJ`` is scaled by the same ratio to the segment's current ``EI``.
    source : str
        Provenance written into the new sections' ``ei`` and ``gj``.

    Returns
    -------
    StructureSpec
        New members (the changed member cut into pieces at the changed segments) and sections.

    Raises
    ------
    SpecError
        A pair of points that is no member segment.
    """
    sections, used, members, found = dict(spec.sections), {m.id for m in spec.members}, [], set()
    for m in spec.members:
        ei = [rigidity.get(frozenset(ab)) for ab in zip(m.points[:-1], m.points[1:])]
        if all(e is None for e in ei):
            members.append(m)
            continue
        used.discard(m.id)
        found |= {frozenset(m.points[i:i + 2]) for i, e in enumerate(ei) if e is not None}
        # pieces: runs of consecutive segments with the same new rigidity (or none)
        edges = [0] + [i for i in range(1, len(ei)) if ei[i] != ei[i - 1]] + [len(ei)]
        for a, b in zip(edges[:-1], edges[1:]):
            tag = piece_id(m.id, m.points[a], m.points[b]) if len(edges) > 2 else m.id
            sec_name = m.section
            if ei[a] is not None:
                old = spec.sections[m.section]
                sec_name = unique_id(set(sections), f"{m.section}@{tag}")
                sections[sec_name] = dataclasses.replace(old, name=sec_name, ei=Quantity(ei[a], source),
                                                         gj=Quantity(old.gj.si * ei[a] / old.ei.si, source))
            ident = unique_id(used, tag)
            used.add(ident)
            pts = m.points[a:b + 1]
            members.append(Member(ident, pts, sec_name, m.elements_per_segment,
                                  tuple(ri for ri in m.rigid_inserts if ri.point in pts)))
    missing = [sorted(k) for k in rigidity if k not in found]
    if missing:
        raise SpecError(f"{spec._file()}: no member segment between points {missing[0]}")
    return spec.replace(members=tuple(members), sections=sections)


def _segment_ei(spec) -> dict[frozenset, tuple[float, float]]:
    """Every member segment: ``frozenset({a, b}) -> (length [m], EI [N*m^2])``."""
    out = {}
    for m in spec.members:
        ei = spec.sections[m.section].ei.si
        for a, b in zip(m.points[:-1], m.points[1:]):
            out[frozenset((a, b))] = (_segment_length(spec.points, a, b), ei)
    return out


def _member_stiffness(spec, r) -> Any:
    """Apply one ``[[member_stiffness]]`` entry (reader ``r``)."""
    ident = r.str("member")
    mem = next((m for m in spec.members if m.id == ident), None)
    if mem is None:
        r.fail("member", f"unknown member {ident!r}; members are {[m.id for m in spec.members]}")
    segs = [frozenset(ab) for ab in zip(mem.points[:-1], mem.points[1:])]
    if r.has("segment"):
        seg = r.raw("segment", types=(list,))
        if len(seg) != 2 or frozenset(seg) not in segs:
            r.fail("segment", f"{seg!r} is not a segment of member {ident!r} (consecutive points of "
                              f"{list(mem.points)})")
        segs = [frozenset(seg)]
    ei = r.quantity("ei", "rigidity")
    r.done()
    return split_segments(spec, {s: ei.si for s in segs}, ei.source)


def _joint_flexibility(spec, r) -> Any:
    """Apply one ``[[joint_flexibility]]`` entry (reader ``r``)."""
    point = r.int("point")
    if point not in spec.points:
        r.fail("point", f"unknown point id {point}; points are {sorted(spec.points)}")
    kj = r.quantity("rotational_stiffness", "rot_stiffness")
    r.done()
    segs = {k: (length, ei) for k, (length, ei) in _segment_ei(spec).items() if point in k}
    if not segs:
        r.fail("point", f"no member segment ends at point {point}")
    return split_segments(spec, {k: ei / (1.0 + ei / (kj.si * length)) for k, (length, ei) in segs.items()},
                          kj.source)


def _mode_damping(spec, r) -> Any:
    """Apply one ``[[mode_damping]]`` entry (reader ``r``)."""
    mode = r.int("mode")
    if mode < 1:
        r.fail("mode", f"mode numbers start at 1, got {mode}")
    ratio = read_damping_ratio(r, "ratio")
    source = r.str("source")
    r.done()
    d = spec.damping
    if d is None:
        r.fail("mode", "needs a [damping] table (the ratios of the other modes)")
    z = list(d.modal_ratios) + [d.default_ratio] * max(0, mode - len(d.modal_ratios))
    z[mode - 1] = float(ratio)
    return spec.replace(damping=Damping(tuple(z), d.default_ratio, f"{d.source}; mode {mode}: {source}", d.basis))


_APPLY: dict[str, Callable] = {"member_stiffness": _member_stiffness, "joint_flexibility": _joint_flexibility,
                               "mode_damping": _mode_damping}


def apply_change_tables(spec, tables: dict[str, list], reader: Callable) -> Any:
    """``spec`` with the change tables of its document applied (:data:`vlab.spec.CHANGE_TABLES`, in that order).

    Parameters
    ----------
    spec : StructureSpec
        The structure as read from the rest of the document.
    tables : dict
        Table name -> its list of entries (dicts), as parsed.
    reader : callable
        ``reader(entry, path) -> vlab.spec.reader.TableReader`` of one entry (``path`` such as ``"mode_damping[0]"``).

    Returns
    -------
    StructureSpec
        The structure after the changes.

    Raises
    ------
    SpecError
        A bad entry, naming the file and field (``member_stiffness[0].segment``).
    """
    for name in CHANGE_TABLES:
        for i, t in enumerate(tables.get(name) or []):
            spec = _APPLY[name](spec, reader(t, f"{name}[{i}]"))
    return spec


def release_supports(supports: tuple, released: list, fail: Callable) -> tuple:
    """``supports`` with the DOFs of springs marked ``replaces_support`` removed from the fixed DOFs.

    Parameters
    ----------
    supports : tuple of vlab.spec.Support
    released : list of (int, (int, str))
        ``(index of the [[springs]] entry, (point, dof))``.
    fail : callable
        ``fail(index, message)`` raises the SpecError of the ``[[springs]]`` entry ``index``.

    Returns
    -------
    tuple of vlab.spec.Support

    Raises
    ------
    SpecError
        Through ``fail``: no support fixes the spring's DOF at its point.
    """
    out = list(supports)
    for i, (point, dof) in released:
        j = next((j for j, s in enumerate(out) if s.point == point and dof in s.fixed), None)
        if j is None:
            fail(i, f"replaces_support: no support fixes DOF {dof!r} at point {point}")
        s = out[j]
        out[j] = dataclasses.replace(s, fixed=tuple(d for d in s.fixed if d != dof))
    return tuple(out)


def damping_of(spec, base):
    """``spec`` whose damping names ``base`` (the structure before the changes) as its basis; ``spec`` itself
    when ``base`` is None or there is no ``[damping]`` table.

    Parameters
    ----------
    spec, base : StructureSpec or None

    Returns
    -------
    StructureSpec
    """
    if base is None or spec.damping is None:
        return spec
    return spec.replace(damping=dataclasses.replace(spec.damping, basis=base))
