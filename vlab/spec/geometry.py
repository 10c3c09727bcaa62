"""Reading the tables of a structure file that describe the structure itself.

``[structure]`` (name, active DOFs, gravity), ``[points]``, ``[sections]``,
``[[members]]``, ``[[strings]]``, ``[[masses]]``, ``[[crosspieces]]``,
``[[springs]]`` and ``[[supports]]``: one reader function per table, each
returning the dataclasses of :mod:`vlab.spec.structure` in SI and raising
:class:`vlab.errors.SpecError` naming the file and the dotted field.
"""

from __future__ import annotations

import math

from .. import units
from .reader import TableReader, is_number, read_direction, read_dof, read_point
from .structure import (Crosspiece, LumpedMass, Member, Quantity, RigidInsert, Section, Spring, StringElement,
                        Support)

#: Most finite elements per member segment (the shipped structures use 1-4).
MAX_ELEMENTS_PER_SEGMENT = 200

#: Largest coordinate magnitude of a point [m].
MAX_COORDINATE_M = 1000.0


def read_structure(s: TableReader) -> tuple[str, str, tuple[str, ...], tuple[float, float]]:
    """The ``[structure]`` table: name, title, active DOFs (containing ``w``), gravity direction.

    Parameters
    ----------
    s : TableReader
        Reader of the ``[structure]`` table.

    Returns
    -------
    name, title : str
    active_dofs : tuple of str
    gravity_direction : (float, float)
        Unit vector, or (0, 0) for no gravity.

    Raises
    ------
    SpecError
        A missing, unknown or mistyped field, an unknown DOF, no ``w``, a bad gravity vector.
    """
    name = s.str("name")
    title = s.str("title")
    s.str("source")
    active = tuple(read_dof(s, "dofs", d) for d in s.raw("dofs", types=(list,)))
    if "w" not in active:
        s.fail("dofs", "the out-of-plane translation 'w' must be active")
    grav = read_direction(s, "gravity")
    s.done()
    return name, title, active, grav


def read_points(p: TableReader) -> dict[int, tuple[float, float]]:
    """The ``[points]`` table: point id -> (x, y) [m], from the coordinates in the table's ``unit``.

    Parameters
    ----------
    p : TableReader
        Reader of the ``[points]`` table.

    Returns
    -------
    dict[int, (float, float)]

    Raises
    ------
    SpecError
        An unknown unit, a non-integer id, a coordinate pair that is not two numbers, not finite or
        beyond :data:`vlab.spec.MAX_COORDINATE_M`, an id given twice.
    """
    unit = p.str("unit")
    scale = units.factor(unit, where=f"{p.file}: field 'points.unit'")
    p.str("source")
    coords = p.sub("coordinates")
    points: dict[int, tuple[float, float]] = {}
    for key in list(coords.table):
        xy = coords.raw(key, types=(list,))
        if not key.isdigit():
            coords.fail(key, "point ids must be positive integers")
        if len(xy) != 2 or not all(is_number(x) for x in xy):
            coords.fail(key, f"expected [x, y], got {xy!r}")
        xy_m = (xy[0] * scale, xy[1] * scale)
        if not all(math.isfinite(x) and abs(x) <= MAX_COORDINATE_M for x in xy_m):
            coords.fail(key, f"coordinates {xy!r} {unit} must be finite and within {MAX_COORDINATE_M:g} m")
        if int(key) in points:
            coords.fail(key, f"point {int(key)} is given twice")
        points[int(key)] = xy_m
    p.done()
    return points


def read_section(r: TableReader, name: str) -> Section:
    """One section of ``[sections]``: a rectangular bar, its rigidities derived where not given.

    ``EI = E b t^3 / 12`` and ``GJ = G b t^3 / 3 (1 - 0.63 t / b)`` (St-Venant, thin rectangle) unless
    ``ei`` / ``gj`` are given.

    Parameters
    ----------
    r : TableReader
        Reader of the section's table.
    name : str
        Its key in ``[sections]``.

    Returns
    -------
    Section

    Raises
    ------
    SpecError
        A missing or bad value, a thickness larger than the width.
    """
    b = r.quantity("width", "length")
    t = r.quantity("thickness", "length")
    rho = r.quantity("density", "density")
    e = r.quantity("modulus", "modulus")
    g = r.quantity("shear_modulus", "modulus")
    ei = r.quantity("ei", "rigidity", optional=True)
    gj = r.quantity("gj", "rigidity", optional=True)
    kga = r.quantity("shear_stiffness", "shear_force", optional=True)
    r.done()
    bw, tk = b.si, t.si
    if tk > bw:
        r.fail("thickness", "thickness larger than width: the out-of-plane axis is the thin one")
    area = bw * tk
    ei_calc = e.si * bw * tk**3 / 12.0
    gj_calc = g.si * bw * tk**3 / 3.0 * (1.0 - 0.63 * tk / bw)
    if ei is None:
        ei = Quantity(ei_calc, f"E*b*t^3/12 ({e.source})")
    if gj is None:
        gj = Quantity(gj_calc, f"G*b*t^3/3*(1-0.63 t/b) ({g.source})")
    return Section(name=name, width=b, thickness=t, ei=ei, ei_inplane=e.si * tk * bw**3 / 12.0, gj=gj,
                   ea=e.si * area, rho_a=rho.si * area, rho_ip=rho.si * area * (bw**2 + tk**2) / 12.0,
                   shear_stiffness=kga)


def read_sections(sec_tab: TableReader) -> dict[str, Section]:
    """The ``[sections]`` table: name -> :class:`vlab.spec.Section` (see :func:`read_section`).

    Parameters
    ----------
    sec_tab : TableReader
        Reader of the ``[sections]`` table.

    Returns
    -------
    dict[str, Section]
    """
    sections = {}
    for key in list(sec_tab.table):
        sections[key] = read_section(sec_tab.sub(key), key)
    sec_tab.done()
    return sections


def _section_name(r: TableReader, sections: dict) -> str:
    sec = r.str("section")
    if sec not in sections:
        r.fail("section", f"unknown section {sec!r}; sections are {sorted(sections)}")
    return sec


def read_members(top: TableReader, points: dict, sections: dict) -> list[Member]:
    """The ``[[members]]`` array: polylines of beam elements with their section and rigid inserts.

    Parameters
    ----------
    top : TableReader
        Reader of the whole document.
    points : dict
        Point id -> (x, y) [m].
    sections : dict
        Section name -> :class:`vlab.spec.Section`.

    Returns
    -------
    list of Member

    Raises
    ------
    SpecError
        Fewer than two points, an unknown point or section, coinciding consecutive points,
        ``elements_per_segment`` outside [1, :data:`vlab.spec.MAX_ELEMENTS_PER_SEGMENT`], an insert off the member.
    """
    members = []
    for _, r in top.entries("members"):
        pts = r.raw("points", types=(list,))
        if len(pts) < 2:
            r.fail("points", "a member needs at least two points")
        for pid in pts:
            if not isinstance(pid, int) or isinstance(pid, bool) or pid not in points:
                r.fail("points", f"unknown point id {pid!r}; points are {sorted(points)}")
        for a, b in zip(pts, pts[1:]):
            if points[a] == points[b]:
                r.fail("points", f"points {a} and {b} coincide: a segment of zero length")
        sec = _section_name(r, sections)
        n = r.int("elements_per_segment", 1)
        if not 1 <= n <= MAX_ELEMENTS_PER_SEGMENT:
            r.fail("elements_per_segment", f"must be between 1 and {MAX_ELEMENTS_PER_SEGMENT}, got {n}")
        inserts = []
        for _, ri in r.entries("rigid_inserts", []):
            pid = read_point(ri, "point", points)
            if pid not in pts:
                ri.fail("point", f"point {pid} is not on this member")
            inserts.append(RigidInsert(pid, ri.quantity("length", "length")))
        members.append(Member(r.str("id"), tuple(pts), sec, n, tuple(inserts)))
    return members


def _mass_per_length(r: TableReader) -> Quantity:
    """Mass per length of a string from its diameter and density (SI)."""
    d = r.quantity("diameter", "length")
    rho = r.quantity("density", "density")
    count = r.int("count", 1)
    if count < 1:
        r.fail("count", f"must be >= 1, got {count}")
    return Quantity(
        count * rho.si * math.pi * d.si**2 / 4.0,
        f"{count} x pi d^2/4 x density ({d.source}; {rho.source})",
    )


def read_strings(top: TableReader, points: dict) -> list[StringElement]:
    """The ``[[strings]]`` array: strings in tension to ground (``tension = "reaction"``: from the statics).

    Parameters ``top``, ``points``: as :func:`read_members`.

    Returns
    -------
    list of StringElement
        Mass per length ``count * density * pi d^2 / 4``.
    """
    strings = []
    for _, r in top.entries("strings", []):
        tension = None
        if r.has("tension") and r.table["tension"] == "reaction":
            r.raw("tension")
        else:
            tension = r.quantity("tension", "force")
        strings.append(StringElement(id=r.str("id"), point=read_point(r, "point", points),
                                     direction=read_direction(r, "direction"), length=r.quantity("length", "length"),
                                     tension=tension, rho_a=_mass_per_length(r)))
    return strings


def read_masses(top: TableReader, points: dict) -> tuple[list[LumpedMass], set[int]]:
    """The ``[[masses]]`` array, and the indices of those marked ``added = true``.

    Parameters ``top``, ``points``: as :func:`read_members`.

    Returns
    -------
    masses : list of LumpedMass
    added : set of int
        Indices of the entries marked ``added`` (elements a diagnosis attached).
    """
    masses, added = [], set()
    for i, r in top.entries("masses", []):
        if r.raw("added", False, types=(bool,)):
            added.add(i)
        masses.append(LumpedMass(id=r.str("id"), point=read_point(r, "point", points), mass=r.quantity("mass", "mass"),
                                 inertia_rx=r.quantity("inertia_rx", "inertia", optional=True),
                                 inertia_ry=r.quantity("inertia_ry", "inertia", optional=True)))
    return masses, added


def read_crosspieces(top: TableReader, points: dict, sections: dict) -> list[Crosspiece]:
    """The ``[[crosspieces]]`` array: symmetric cantilever arms with tip masses (BCC, Sec. 2.1).

    Parameters ``top``, ``points``, ``sections``: as :func:`read_members`.

    Returns
    -------
    list of Crosspiece
    """
    crosspieces = []
    for _, r in top.entries("crosspieces", []):
        sec = _section_name(r, sections)
        crosspieces.append(Crosspiece(id=r.str("id"), point=read_point(r, "point", points),
                                      arm_length=r.quantity("arm_length", "length"), section=sec,
                                      tip_mass=r.quantity("tip_mass", "mass"),
                                      clamp_mass=r.quantity("clamp_mass", "mass", positive=False)))
    return crosspieces


def read_springs(top: TableReader, points: dict) -> tuple[list[Spring], set[int], list]:
    """The ``[[springs]]`` array, the indices marked ``added``, and the supports they replace.

    Parameters ``top``, ``points``: as :func:`read_members`.

    Returns
    -------
    springs : list of Spring
        Stiffness in N/m on ``w``, N*m/rad on a rotation.
    added : set of int
        Indices of the entries marked ``added = true``.
    released : list of (int, (int, str))
        ``(index, (point, dof))`` of the entries marked ``replaces_support = true``.
    """
    springs, added, released = [], set(), []
    for i, r in top.entries("springs", []):
        if r.raw("added", False, types=(bool,)):
            added.add(i)
        dof = read_dof(r, "dof", r.str("dof"))
        kind = "stiffness" if dof == "w" else "rot_stiffness"
        springs.append(Spring(r.str("id"), read_point(r, "point", points), dof, r.quantity("stiffness", kind)))
        if r.raw("replaces_support", False, types=(bool,)):
            released.append((i, (springs[-1].point, dof)))
    return springs, added, released


def read_supports(top: TableReader, points: dict) -> tuple[Support, ...]:
    """The ``[[supports]]`` array: fixed out-of-plane DOFs and the in-plane restraint of a point.

    Parameters ``top``, ``points``: as :func:`read_members`.

    Returns
    -------
    tuple of Support
        ``inplane`` true/false read as ``"pinned"``/``"free"``.
    """
    supports = []
    for _, r in top.entries("supports", []):
        fixed = tuple(read_dof(r, "fixed", d) for d in r.raw("fixed", types=(list,)))
        inplane = r.raw("inplane", "free", types=(bool, str))
        inplane = {True: "pinned", False: "free"}.get(inplane, inplane)
        if inplane not in ("free", "pinned", "clamped"):
            r.fail("inplane", f"expected true/false or 'free', 'pinned', 'clamped', got {inplane!r}")
        supports.append(Support(read_point(r, "point", points), fixed, inplane))
    return tuple(supports)
