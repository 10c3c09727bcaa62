"""Public edits of a :class:`~vlab.spec.StructureSpec` used by the diagnosis hypotheses.

A physics hypothesis is applied by building a modified spec (the spec is the one
definition every model is built from): these functions return a new spec and never change the one
given. The FE model (:func:`vlab.fe.build_fe_model`) and the MuJoCo plant
(:func:`vlab.sim.build_plant`) built from the result both contain the effect.

Every added element carries ``source = "diagnosis: <effect>"`` so that a
report or an exported model shows where it came from.

A physical change keeps the structure's damping matrix: the edited spec names
the structure before the first change as its damping basis
(:attr:`vlab.spec.Damping.basis`, :mod:`vlab.fe.damping`), so that its modal
damping ratios move with its modes as a fixed damping matrix makes them move
(an added mass lowers a mode's ratio with its frequency).

Errors: :class:`vlab.errors.SpecError` naming the point, DOF or member.
"""

from __future__ import annotations

import dataclasses

from ...errors import SpecError
from ...spec import Damping, LumpedMass, Member, Quantity, Spring, StructureSpec, Support
from ...spec.changes import piece_id, unique_id

_SOURCE = "diagnosis: {}"


def _keeps_damping(before: StructureSpec, after: StructureSpec) -> StructureSpec:
    """``after`` (a physical change of ``before``) with the damping matrix of the structure before any change:
    its damping basis is ``before``'s basis, or ``before`` itself."""
    d = after.damping
    if d is None:
        return after
    basis = before.damping.basis if before.damping is not None and before.damping.basis is not None else before
    return after.replace(damping=dataclasses.replace(d, basis=basis))


def add_mass(spec: StructureSpec, point: int, mass_kg: float, *, effect: str = "added_mass") -> StructureSpec:
    """Return ``spec`` with a lumped mass ``mass_kg`` [kg] added at ``point`` (out-of-plane inertia).

    ``effect`` names the new mass (id and source ``"diagnosis: <effect>"``).

    Raises
    ------
    SpecError
        Unknown point or a negative mass.
    """
    spec.check_point(point, f"{effect} at point {point}")
    if not mass_kg >= 0.0:
        raise SpecError(f"{effect}: mass must be >= 0 kg, got {mass_kg!r}")
    ident = unique_id({m.id for m in spec.masses}, f"{effect}_{point}")
    lm = LumpedMass(ident, point, Quantity(float(mass_kg), _SOURCE.format(effect)))
    return _keeps_damping(spec, spec.replace(masses=spec.masses + (lm,)))


def add_spring(spec: StructureSpec, point: int, dof: str, stiffness_si: float, *,
               effect: str = "support_stiffness") -> StructureSpec:
    """Return ``spec`` with a grounded spring on ``dof`` of ``point``.

    If the DOF is fixed by a support, the support is released on that DOF and
    the spring replaces it (a support of finite stiffness); otherwise the
    spring is added to the free DOF (an attachment to ground, e.g. a wire).

    Parameters
    ----------
    spec : StructureSpec
    point : int
    dof : {"w", "rx", "ry"}
        Must be active in the spec.
    stiffness_si : float
        [N/m] for ``w``, [N*m/rad] for rotations; >= 0.
    effect : str
        Name written into the spring's id and source.

    Raises
    ------
    SpecError
        Unknown point, inactive DOF or negative stiffness.
    """
    spec.check_point(point, f"{effect} at point {point}")
    if dof not in spec.active_dofs:
        raise SpecError(f"{effect}: DOF {dof!r} is not active in {spec.name} (active: {spec.active_dofs})")
    if not stiffness_si >= 0.0:
        raise SpecError(f"{effect}: stiffness must be >= 0, got {stiffness_si!r}")
    supports = []
    for s in spec.supports:
        if s.point == point and dof in s.fixed:
            s = Support(s.point, tuple(d for d in s.fixed if d != dof), s.inplane)
        supports.append(s)
    ident = unique_id({s.id for s in spec.springs}, f"{effect}_{point}_{dof}")
    sp = Spring(ident, point, dof, Quantity(float(stiffness_si), _SOURCE.format(effect)))
    return _keeps_damping(spec, spec.replace(springs=spec.springs + (sp,), supports=tuple(supports)))


def is_fixed(spec: StructureSpec, point: int, dof: str) -> bool:
    """True if a support of ``spec`` fixes ``dof`` at ``point``."""
    return any(s.point == point and dof in s.fixed for s in spec.supports)


def _scaled_section(spec: StructureSpec, sections: dict, name: str, factor: float, tag: str) -> str:
    sec = spec.sections[name]
    new = unique_id(set(sections), f"{name}@{tag}")
    sections[new] = dataclasses.replace(
        sec,
        name=new,
        ei=Quantity(sec.ei.si * factor, _SOURCE.format(tag)),
        gj=Quantity(sec.gj.si * factor, _SOURCE.format(tag)),
    )
    return new


def _piece(member: Member, a: int, b: int, ident: str, section: str) -> Member:
    pts = member.points[a:b + 1]
    inserts = tuple(ri for ri in member.rigid_inserts if ri.point in pts)
    return Member(ident, pts, section, member.elements_per_segment, inserts)


def scale_segments(spec: StructureSpec, factors: dict[tuple[int, int], float], *,
                   effect: str = "member_stiffness") -> StructureSpec:
    """Return ``spec`` with the bending and torsional rigidity of some member segments scaled.

    Parameters
    ----------
    spec : StructureSpec
    factors : dict
        ``(point a, point b) -> factor`` (> 0) for segments between consecutive
        points of a member (either order). A member is cut into pieces at the
        changed segments (same points, rigid inserts and subdivision); each
        changed segment gets its own copy of the section with ``EI`` and
        ``GJ`` multiplied by the factor, so the FE model changes in those
        rigidities only. Applying twice compounds the factors.
    effect : str
        Tag of the new sections and pieces.

    Returns
    -------
    StructureSpec

    Raises
    ------
    SpecError
        A pair of points that is no member segment, a non-positive factor.
    """
    wanted = {}
    for (pa, pb), f in factors.items():
        if not f > 0.0:
            raise SpecError(f"{effect}: stiffness factor of segment {pa}-{pb} must be > 0, got {f!r}")
        wanted[frozenset((pa, pb))] = float(f)
    found: set[frozenset] = set()
    sections = dict(spec.sections)
    used = {m.id for m in spec.members}
    members: list[Member] = []
    for m in spec.members:
        segs = {i: wanted[frozenset(ab)] for i, ab in enumerate(zip(m.points[:-1], m.points[1:]))
                if frozenset(ab) in wanted}
        if not segs:
            members.append(m)
            continue
        found |= {frozenset(m.points[i:i + 2]) for i in segs}
        nseg = len(m.points) - 1
        edges = sorted({0, nseg, *segs, *(i + 1 for i in segs)})
        for a, b in zip(edges[:-1], edges[1:]):
            tag = piece_id(m.id, m.points[a], m.points[b])
            if b == a + 1 and a in segs:
                sec = _scaled_section(spec, sections, m.section, segs[a], f"{effect}:{tag}")
            else:
                sec = m.section
            ident = unique_id(used, tag)
            used.add(ident)
            members.append(_piece(m, a, b, ident, sec))
    missing = [tuple(sorted(k)) for k in wanted if k not in found]
    if missing:
        raise SpecError(f"{effect}: no member segment between points {missing[0]} in {spec.name}")
    return _keeps_damping(spec, spec.replace(members=tuple(members), sections=sections))


def member_segment_points(spec: StructureSpec, member: str) -> list[tuple[int, int]]:
    """Segments ``(point a, point b)`` of ``member`` in ``spec``.

    Raises
    ------
    SpecError
        Unknown member.
    """
    mem = [m for m in spec.members if m.id == member]
    if not mem:
        raise SpecError(f"unknown member {member!r}; members are {[m.id for m in spec.members]}")
    return list(zip(mem[0].points[:-1], mem[0].points[1:]))


def scale_member(spec: StructureSpec, member: str, factor: float, *, effect: str = "member_stiffness") -> StructureSpec:
    """Return ``spec`` with ``EI`` and ``GJ`` of every segment of ``member`` multiplied by ``factor``
    (new sections tagged with ``effect``).

    Raises
    ------
    SpecError
        Unknown member or non-positive factor.
    """
    return scale_segments(spec, {ab: factor for ab in member_segment_points(spec, member)}, effect=effect)


def joint_segments(spec: StructureSpec, point: int) -> list[tuple[int, int, float, float]]:
    """Segments of ``spec`` ending at ``point``: ``(point a, point b, length [m], EI [N*m^2])``."""
    out = []
    for m in spec.members:
        ei = spec.sections[m.section].ei.si
        for a, b in zip(m.points[:-1], m.points[1:]):
            if point in (a, b):
                (xa, ya), (xb, yb) = spec.points[a], spec.points[b]
                out.append((a, b, float(((xb - xa) ** 2 + (yb - ya) ** 2) ** 0.5), ei))
    return out


def soften_joint(spec: StructureSpec, point: int, rotational_stiffness: float, *,
                 effect: str = "joint_flexibility") -> StructureSpec:
    """Return ``spec`` with a flexible connection of rotational stiffness ``k_j`` at ``point``.

    The joint's compliance ``1 / k_j`` [rad/(N*m)] is spread over every
    segment ending at the point: a segment of length ``L`` and rigidity ``EI``
    gets ``EI' = EI / (1 + EI / (k_j L))``, so that its end rotation under a
    uniform moment equals that of the rigid segment plus the joint spring
    (``L / EI' = L / EI + 1 / k_j``). ``GJ`` is scaled by the same factor.

    Parameters
    ----------
    spec : StructureSpec
    point : int
        A point where at least one member segment ends.
    rotational_stiffness : float
        ``k_j`` [N*m/rad], > 0.
    effect : str
        Tag of the new sections.

    Raises
    ------
    SpecError
        Unknown point, no segment at the point, non-positive stiffness.

    Notes
    -----
    Source: the semi-rigid connection model of frame analysis (a rotational
    spring in series with the member end), e.g. Chen & Lui, *Stability
    Design of Steel Frames*, 1991, ch. 5, here smeared over the adjacent
    element so that the FE mesh and the MuJoCo hinge chain need no new DOF.
    """
    spec.check_point(point, f"{effect} at point {point}")
    if not rotational_stiffness > 0.0:
        raise SpecError(f"{effect}: rotational stiffness must be > 0, got {rotational_stiffness!r}")
    segs = joint_segments(spec, point)
    if not segs:
        raise SpecError(f"{effect}: no member segment ends at point {point}")
    factors = {(a, b): 1.0 / (1.0 + ei / (rotational_stiffness * length)) for a, b, length, ei in segs}
    return scale_segments(spec, factors, effect=f"{effect}@{point}")


def set_modal_damping(spec: StructureSpec, mode: int, ratio: float, *, n_modes: int | None = None) -> StructureSpec:
    """Return ``spec`` with the open-loop damping ratio of ``mode`` (1-based) set to ``ratio``.

    Modes beyond the listed ratios get the default ratio up to ``mode``;
    ``n_modes`` is accepted for symmetry with :func:`vlab.fe.damping.open_loop_ratios`
    and unused. A changed structure's modes are numbered as those of its damping basis.

    Raises
    ------
    SpecError
        Mode < 1, ratio outside [0, 1).
    """
    if mode < 1:
        raise SpecError(f"damping: mode numbers start at 1, got {mode}")
    if not 0.0 <= ratio < 1.0:
        raise SpecError(f"damping: ratio of mode {mode} must be in [0, 1), got {ratio!r}")
    d = spec.damping or Damping((), 0.0, "none")
    z = list(d.modal_ratios)
    while len(z) < mode:
        z.append(d.default_ratio)
    z[mode - 1] = float(ratio)
    return spec.replace(damping=Damping(tuple(z), d.default_ratio, d.source + f"; diagnosis: mode {mode}", d.basis))


def without_gravity(spec: StructureSpec) -> StructureSpec:
    """Return ``spec`` without gravity (no in-plane pre-stress; for the geometric-stiffness split)."""
    return spec.replace(gravity_direction=(0.0, 0.0))
