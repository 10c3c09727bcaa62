"""Plan the bodies, joints and constraints of a structure's MuJoCo plant (before any MjSpec exists).

:func:`plan_structure` turns a :class:`~vlab.spec.StructureSpec` into a
:class:`~vlab.sim.plan.Plan` -- bodies (parent before child) with their joints, inertia,
sites and visuals, the strings, the loop-closing welds, the support
equalities and the in-plane pre-stress loads -- that
:func:`vlab.sim.emit.build_mjspec` emits into an :class:`mujoco.MjSpec`.
The discretisation of each member (Gauss-placed hinges,
:func:`vlab.sim.hinges.hinge_layout`) is described in :mod:`vlab.sim.builder`;
the attachments (crosspieces, masses, strings, supports, springs, coils) are
planned by :mod:`vlab.sim.attachments`, the in-plane loads by
:mod:`vlab.sim.prestress`.

Topology
--------
Two topologies (:attr:`vlab.sim.SimOptions.topology`): the *tree*, the
default of structures without loops (the BCC), and the *forest*, the default
of structures with loops (the grid).

Tree. The kinematic tree is rooted at the point held in the plane (a support with
``inplane = "pinned"``/``"clamped"`` or the point of a string with
``tension = "reaction"``);
its free out-of-plane DOFs become a slide (w) and hinges (rx, ry). The tree is
grown breadth first; a member segment whose far end is already in the tree
closes a loop: its last link ("stub") is welded to the junction with
``solref = (2 dt, 1)``, ``solimp = (0.9999, 0.9999, 0.001, 0.5, 2)``
(docs/plants.md). Other supports are ``connect`` (w fixed) or ``weld`` (all fixed)
equalities to the world.

Each of these equalities holds an *in-plane release* body (slides x, y and a
hinge about z, with a small in-plane armature), not the member end or the
junction itself. A deflected out-of-plane shape moves its points in the plane
at second order (the foreshortening ``~ w^2 / L`` and a rotation about z),
and a weld between two tree branches that have no in-plane DOFs would enforce
that in-plane compatibility rigidly: a hardening nonlinearity that the linear
FE model does not have. It made the grid's forced response at the test force
(0.2 N rms) depend on the amplitude by a factor of two. The release takes up
those motions; in the flat state the in-plane rows carry no force either way,
so the linearised modes are the same to 0.01 % (README: plant linearity).

Because the tree has no in-plane DOFs, MuJoCo cannot decide how a statically
indeterminate structure shares its in-plane loads: the in-plane rows of the
loop-closing welds have a zero Jacobian in the flat state and carry no force,
so all of the weight would flow down the spanning tree. The geometric
stiffness depends on that load path (the grid's frequencies are off by up to
13 % without this), so the in-plane *redundant* forces of the FE gravity
statics (:func:`vlab.fe.statics.solve_gravity`: the internal force and moment
at each loop cut, the reaction at each further in-plane support) are applied
as constant loads by ``prestress*`` actuators with a constant bias force: at
a loop cut a pair (site on the member end, refsite on the junction), at a
support a dead load (world refsite). The tree then carries the frame's
in-plane forces, and gravity does the rest: the second-order work of every
load, including in-plane shear and moment, comes from exact rigid-body
kinematics. Statically determinate structures (the BCC) need none.

Forest (:meth:`_Planner._forest`). A loop weld couples every joint around its
loop, so MuJoCo's Newton solver factorised a nearly dense Hessian of the
grid's 208 DOFs at every step (about 70 % of the step time). In the
forest, junctions hang from the world by their own joints (w and the active
rotations, less what a support fixes), every member is a chain of links
between them, and a member end that reaches a junction is held to it by
linear equalities on w and the active rotations (:attr:`Plan.closures`:
fixed tendons with the first-order coefficients at the flat state, held at
zero length, :func:`vlab.sim.emit.build_mjspec`): each couples one chain
and two junctions, and the Hessian stays sparse. In the flat state these
rows carry no force, so their curvature adds no stiffness, and they leave the
in-plane gap between member end and junction free, as the in-plane release
does for a weld: no release bodies are needed. A junction is held in the plane
by its joints, so every member end held by equalities gets the FE statics'
end force and moment as a ``prestress*`` pair (member end, junction), and the
tree of each junction carries those in-plane loads as in the tree topology.
A member with inner points stays one continuous chain: a closure inside a
stiff member is soft (MuJoCo's constraint regularisation, ``d <= 0.9999``):
closing the grid's top beam at every point put modes 7, 8 and 12 2-13 % low.

Sources: docs/plants.md (how the plants are built); Sec. 2.1, 2.1.1, 2.2, 2.2.1 of the
dissertation.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import ModelError, ResourceError, SimulationError
from ..spec import StructureSpec
from ..spec.changes import cut_from
from .attachments import AttachmentPlanner
from .hinges import SHEAR_SHORT_PHI, auto_links, hinge_layout
from .plan import AXIS, Z_AXIS, Body, Joint, Plan, Visual, p3, point_mass, rod
from .prestress import PrestressPlanner, held_inplane

if TYPE_CHECKING:
    from .options import SimOptions

#: Mass [kg] of an in-plane release body (:meth:`_Planner._inplane_release`), light enough to move no
#: out-of-plane mode, and the in-plane inertia of its joints (armature: slides [kg], rotation [kg m^2]),
#: which only in-plane motion sees, heavy enough for a well-conditioned mass matrix.
RELEASE_MASS = 1e-6
RELEASE_ARMATURE = (0.1, 1e-4)


@dataclass(frozen=True)
class _Edge:
    member: Any
    seg: int
    a: int
    b: int


def _inserts(member) -> dict[int, float]:
    return {ri.point: ri.length.si for ri in member.rigid_inserts}


def _choose_root(spec: StructureSpec) -> int:
    for s in spec.supports:
        if held_inplane(s):
            return s.point
    for s in spec.strings:
        if s.tension is None:
            return s.point
    raise SimulationError(
        f"{spec._file()}: nothing holds the structure in its plane (no support with inplane = true "
        "and no string with tension = \"reaction\"): the MuJoCo tree has no root"
    )


def _representable(axis: np.ndarray, active: tuple[str, ...], tol: float = 1e-9) -> bool:
    """True when a rotation about the in-plane ``axis`` only involves active rotations."""
    return (abs(axis[0]) < tol or "rx" in active) and (abs(axis[1]) < tol or "ry" in active)


def _orient(edges: list[_Edge], points: list[int], hung: set[int]) -> list[tuple[_Edge, int, int]]:
    """Each segment as ``(edge, root end, far end)`` of its chain in the forest topology.

    Each of ``points`` roots the chain of one of its segments where the graph
    allows it: a matching of points to incident segments by augmenting paths
    (Kuhn's algorithm). A junction rooting no chain would carry only its lumped
    mass: its rotations would have almost no inertia and the mass matrix would
    be ill-conditioned. The other segments are rooted at their end in ``hung``
    (a junction hung from the world, not one inside a member's chain: the
    chain's joints then have fewer ancestors), else at their first point.
    """
    incident = {p: [i for i, e in enumerate(edges) if p in (e.a, e.b)] for p in points}
    owner: dict[int, int] = {}  # segment index -> the point rooting its chain

    def augment(p: int, seen: set[int]) -> bool:
        for i in incident[p]:
            if i not in seen:
                seen.add(i)
                if i not in owner or augment(owner[i], seen):
                    owner[i] = p
                    return True
        return False

    for p in points:
        augment(p, set())
    out = []
    for i, e in enumerate(edges):
        p = owner.get(i, e.b if e.b in hung and e.a not in hung else e.a)
        out.append((e, p, e.b if p == e.a else e.a))
    return out


class _Planner(AttachmentPlanner, PrestressPlanner):
    """Turns a StructureSpec into a plan of bodies, joints and constraints (the attachments and the
    in-plane loads in :mod:`vlab.sim.attachments` and :mod:`vlab.sim.prestress`)."""

    def __init__(self, spec: StructureSpec, opts: SimOptions, gravity_state, mesh):
        self.spec = spec
        self.opts = opts
        self.gs = gravity_state
        self.mesh = mesh
        self.bodies: dict[str, Body] = {}
        self.junction: dict[int, str] = {}
        self.world_sites: list[tuple[str, np.ndarray, str]] = []
        self.strings: list = []
        self.welds: list = []
        self.connects: list = []
        self.prestress: list = []
        self.pending_sites: list = []  # sites on junctions, added once all junctions exist
        self.pending_springs: list = []  # grounded springs realised as fixed tendons after compiling
        self.cuts: list = []  # (edge, point, stub body) of every loop closure
        self.closures: list = []  # linear closures of the forest topology (see Plan.closures)
        self.roots: set[int] = set()  # points whose junction hangs from the world by its own joints
        self.chain_roots: set[int] = set()  # points whose junction roots a member chain
        self.forest = False
        self.n_loops = 0
        self.links: dict[str, int] = {}  # member/crosspiece id -> links per segment
        self.active = spec.active_dofs

    # -- helpers
    def _add(self, body: Body) -> Body:
        if body.name in self.bodies:
            raise SimulationError(f"duplicate body name {body.name!r} (two members with the same id?)")
        self.bodies[body.name] = body
        return body

    def _section(self, name: str):
        return self.spec.sections[name]

    def _bar_visual(self, body: Body, p0: np.ndarray, p1: np.ndarray, sec, rgba=(0.6, 0.6, 0.65, 1.0)) -> None:
        d = p1 - p0
        length = float(np.linalg.norm(d))
        if length <= 0:
            return
        body.visuals.append(
            Visual("box", 0.5 * (p0 + p1), (length / 2, sec.width.si / 2, sec.thickness.si / 2),
                    math.atan2(d[1], d[0]), rgba)
        )

    # -- the plan
    def plan(self) -> Plan:
        spec = self.spec
        root = _choose_root(spec)
        self.root = root
        edges = [
            _Edge(m, i, pa, pb)
            for m in spec.members
            for i, (pa, pb) in enumerate(zip(m.points[:-1], m.points[1:]))
        ]
        incident: dict[int, list[_Edge]] = {p: [] for p in spec.points}
        for e in edges:
            incident[e.a].append(e)
            incident[e.b].append(e)
        # breadth-first spanning tree; an edge reaching a visited point closes a loop
        order: list[tuple[_Edge, int, int, bool]] = []  # edge, from, to, is_tree
        visited = {root}
        queue = deque([root])
        done: set[int] = set()
        while queue:
            p = queue.popleft()
            for e in incident[p]:
                if id(e) in done:
                    continue
                done.add(id(e))
                q = e.b if e.a == p else e.a
                tree = q not in visited
                if tree:
                    visited.add(q)
                    queue.append(q)
                order.append((e, p, q, tree))
        used = {p for e in edges for p in (e.a, e.b)} | {root}
        unreached = sorted(used - visited)
        if unreached:
            raise SimulationError(
                f"{spec._file()}: points {unreached} are not connected to the root point {root} by members"
            )
        needed = {m.point for m in spec.masses} | {c.point for c in spec.crosspieces} | {
            s.point for s in spec.strings} | {s.point for s in spec.springs}
        if spec.instrumentation:
            needed |= set(spec.instrumentation.actuators) | set(spec.instrumentation.sensors)
        for p in sorted(needed - visited):
            raise SimulationError(f"{spec._file()}: point {p} carries a mass, string, spring or sensor "
                                  "but no member reaches it")
        self.n_loops = sum(not tree for *_, tree in order)
        topology = self.opts.topology
        self.forest = topology == "forest" or (topology == "auto" and self.n_loops > 0)
        if self.forest:
            self._forest(edges, visited)
        else:
            self.roots.add(root)
            self._junction(root, parent=None, joints=self._root_joints(root))
            for e, p, q, tree in order:
                self._edge(e, p, q, tree)
        for c in spec.crosspieces:
            self._crosspiece(c)
        self._masses()
        self._strings()
        self._supports()
        self._springs()
        self._instrumentation()
        if self.opts.inplane_redundants and self.opts.gravity:
            self._redundants()
        # every point gets its p<ID> site
        for p in sorted(visited):
            b = self.bodies[self.junction[p]]
            b.sites.append((f"p{p}", p3(spec.points[p]), f"spec: point {p}"))
        for q, name, pos, info in self.pending_sites:
            self.bodies[self.junction[q]].sites.append((name, pos, info))
        return Plan(self.bodies, self.junction, self.world_sites, self.strings, self.welds,
                     self.connects, self.prestress, self.n_loops, self.closures,
                     "forest" if self.forest else "tree")

    def _forest(self, edges: list[_Edge], visited: set[int]) -> None:
        """The forest topology: members as chains from junctions hung from the world.

        A member with inner points is one continuous chain: hung from the world
        (:meth:`_hang`) at its point nearest the middle of its length (the tree
        is half as deep as from an end) and grown from there to both ends, its
        points junctions inside the chain. A linear closure inside a stiff
        member would be soft: closing the grid's top beam at every point put its
        modes 7, 8 and 12 -2.1, -1.6 and -12.8 % off the FE model, and further
        off (mode 8 -12.5 %) with the constraints' impedance ``d`` lowered from
        0.9999 (MuJoCo's largest) to 0.999: MuJoCo's regularisation
        ``(1 - d)/d`` leaves each row a compliance against the stiff member. A
        member whose points already have junctions grows from the one nearest
        its middle. Every point still without a junction is then hung from the
        world, and each member of one segment is a chain from one end, closed at
        the other, oriented so that every hung junction roots a chain where the
        graph allows (:func:`_orient`). A segment that reaches a point with a
        junction is closed there by linear equalities.
        """
        by_member: dict[str, list[_Edge]] = {}
        for e in edges:
            by_member.setdefault(e.member.id, []).append(e)
        for m in self.spec.members:
            if len(m.points) < 3:
                continue
            xy = np.array([self.spec.points[p] for p in m.points], dtype=float)
            s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))])
            have = [i for i, p in enumerate(m.points) if p in self.junction]
            start = min(have or range(len(m.points)), key=lambda i: abs(s[i] - s[-1] / 2))
            if not have:
                self._hang(m.points[start])
            segs = by_member[m.id]
            for e in segs[start:]:
                self._edge(e, e.a, e.b, tree=e.b not in self.junction)
            for e in reversed(segs[:start]):
                self._edge(e, e.b, e.a, tree=e.a not in self.junction)
        # the others in breadth-first order from the chains (from the root if there are none): the bodies
        # (and DOFs) nearest the chains first, so that MuJoCo's Cholesky factorisation, which eliminates the
        # last DOF first, works from the far junctions towards the chains (on the grid 50 000 multiply-adds
        # per factorisation, 144 000 in the reverse order, 1.4x the step time)
        neighbours: dict[int, set[int]] = {}
        for e in edges:
            neighbours.setdefault(e.a, set()).add(e.b)
            neighbours.setdefault(e.b, set()).add(e.a)
        queue = deque(sorted(self.junction) or [self.root])
        seen = set(queue)
        while queue:
            p = queue.popleft()
            if p not in self.junction:
                self._hang(p)
            for q in sorted(neighbours.get(p, ())):
                if q not in seen:
                    seen.add(q)
                    queue.append(q)
        for p in sorted(visited - set(self.junction)):  # not reached through members (none in a valid spec)
            self._hang(p)
        single = [e for e in edges if len(e.member.points) == 2]
        bare = [p for p in sorted(self.roots) if p not in self.chain_roots]
        for e, p, q in _orient(single, bare, self.roots):
            self._edge(e, p, q, tree=False)

    def _hang(self, p: int) -> None:
        """A junction at point ``p`` hung from the world by its own joints."""
        self.roots.add(p)
        self._junction(p, parent=None, joints=self._root_joints(p))

    def _root_joints(self, root: int) -> list[Joint]:
        fixed = {d for s in self.spec.supports if s.point == root for d in s.fixed}
        pos = p3(self.spec.points[root])
        joints = []
        if "w" not in fixed:
            joints.append(Joint(f"root{root}.w", "slide", Z_AXIS, pos, info=f"spec: point {root} out-of-plane translation w (root)"))
        for d in ("rx", "ry"):
            if d in self.active and d not in fixed:
                joints.append(Joint(f"root{root}.{d}", "hinge", AXIS[d], pos,
                                     info=f"spec: point {root} rotation {d} (root)"))
        return joints

    def _junction(self, p: int, parent: str | None, joints: list[Joint]) -> Body:
        b = self._add(Body(f"J{p}", p3(self.spec.points[p]), parent, f"spec: point {p} (junction)", joints))
        self.junction[p] = b.name
        return b

    def _edge(self, e: _Edge, p: int, q: int, tree: bool) -> None:
        """Chain of links from junction p to q (a new junction in the chain, or a stub closed at q)."""
        spec, m = self.spec, e.member
        sec = self._section(m.section)
        ins = _inserts(m)
        pp, pq = p3(spec.points[p]), p3(spec.points[q])
        length = float(np.linalg.norm(pq - pp))
        if length == 0.0:
            raise SimulationError(f"{spec._file()}: member {m.id!r}: points {p} and {q} coincide")
        ev = (pq - pp) / length
        ap, aq = ins.get(p, 0.0), ins.get(q, 0.0)
        lf = length - ap - aq
        if lf <= 0.0:
            raise SimulationError(f"{spec._file()}: member {m.id!r}: rigid inserts leave no flexible length "
                                  f"between points {p} and {q}")
        n = self._segments(m.id, lf)
        frac, comp = hinge_layout(n, self.opts.hinge_layout)
        bend_axis = np.array([ev[1], -ev[0], 0.0])
        if not _representable(bend_axis, self.active):
            raise SimulationError(
                f"{spec._file()}: member {m.id!r} ({p}-{q}) bends about {bend_axis[:2].round(3).tolist()}, "
                f"which needs a rotation DOF the spec does not activate (dofs = {list(self.active)})"
            )
        twist = _representable(ev, self.active) and sec.gj is not None
        tag = f"{m.id}.{min(p, q)}-{max(p, q)}"
        k_bend = [sec.ei.si / (c * lf) for c in comp]
        k_twist = [sec.gj.si / (c * lf) for c in comp]
        twist_at, twist_label = range(n), "GJ/(c L)"
        if self.opts.torsion_hinges == "middle":  # the segment's whole torsion compliance on one hinge
            twist_at, twist_label = [n // 2], "GJ/L"
            k_twist = [sec.gj.si / lf] * n
        k_shear = [sec.shear_stiffness.si / (c * lf) for c in comp] if sec.shear_stiffness is not None else None
        hinges = [pp + (ap + f * lf) * ev for f in frac]
        # the junction p owns its end piece
        self.chain_roots.add(p)
        jp = self.bodies[self.junction[p]]
        end_p = hinges[0]
        jp.items.append(rod(pp, end_p, sec.rho_a, sec.rho_ip, sec.width.si, sec.thickness.si))
        self._bar_visual(jp, pp, end_p, sec)
        parent = jp.name
        for k in range(n):
            h = hinges[k]
            joints = []
            if k_shear is not None:
                joints.append(Joint(f"{tag}.h{k + 1}.shear", "slide", Z_AXIS, h, k_shear[k], True,
                                     f"spec: member {m.id} segment {p}-{q} hinge {k + 1}/{n}: shear kGA/(c L) = {k_shear[k]:.6g} N/m"))
            joints.append(Joint(f"{tag}.h{k + 1}.bend", "hinge", bend_axis, h, k_bend[k], True,
                                 f"spec: member {m.id} segment {p}-{q} hinge {k + 1}/{n}: bending EI/(c L) = {k_bend[k]:.6g} N*m/rad"))
            if twist and k in twist_at:
                joints.append(Joint(f"{tag}.h{k + 1}.twist", "hinge", ev.copy(), h, k_twist[k], True,
                                     f"spec: member {m.id} segment {p}-{q} hinge {k + 1}/{n}: torsion {twist_label} = {k_twist[k]:.6g} N*m/rad"))
            if k < n - 1:
                b = self._add(Body(f"{tag}.link{k + 1}", h, parent,
                                    f"spec: member {m.id} segment {p}-{q} link {k + 1}/{n - 1}", joints))
                b.items.append(rod(h, hinges[k + 1], sec.rho_a, sec.rho_ip, sec.width.si, sec.thickness.si))
                self._bar_visual(b, h, hinges[k + 1], sec)
                parent = b.name
            else:
                if tree:
                    b = self._junction(q, parent, joints)
                else:
                    how = "held to J{q} by linear equalities" if self.forest else "welded to J{q} (loop)"
                    b = self._add(Body(f"{tag}.stub{q}", h, parent,
                                        f"spec: member {m.id} segment {p}-{q}: end at point {q} " + how.format(q=q),
                                        joints))
                b.items.append(rod(h, pq, sec.rho_a, sec.rho_ip, sec.width.si, sec.thickness.si))
                self._bar_visual(b, h, pq, sec)
                if not tree and self.forest:
                    s1, s2 = f"{tag}.stub{q}.end", f"J{q}.end.{tag}"
                    where = f"end of member {m.id} segment {p}-{q} at point {q}"
                    b.sites.append((s1, pq, where))
                    self.pending_sites.append((q, s2, pq, where + " (junction side)"))
                    dofs = tuple(d for d in ("w", "rx", "ry") if d == "w" or d in self.active)
                    self.closures.append((f"close.{tag}.{q}", s1, s2, dofs,
                                          f"spec: member {m.id} segment {p}-{q} held to point {q}"))
                    self.cuts.append((e, q, b.name))
                elif not tree:
                    s1, s2 = f"{tag}.stub{q}.weld", f"J{q}.weld.{tag}"
                    cut = self._inplane_release(f"{tag}.cut{q}", b.name, pq,
                                                f"member {m.id} segment {p}-{q}: in-plane release of its loop closure at point {q}")
                    cut.sites.append((s1, pq, f"loop closure of member {m.id} at point {q}"))
                    self.pending_sites.append((q, s2, pq, f"loop closure of member {m.id} at point {q}"))
                    self.welds.append((f"weld.{tag}.{q}", s1, s2, f"spec: member {m.id} segment {p}-{q} closes a loop at point {q}"))
                    self.cuts.append((e, q, b.name))

    def _inplane_release(self, name: str, parent: str, at: np.ndarray, info: str) -> Body:
        """A light body on ``parent`` free to slide in the plane and turn about z (RELEASE_MASS).

        The tree has no in-plane DOFs, so a weld or connect that closes a loop
        (or holds a point to the ground) would otherwise enforce the in-plane
        compatibility of the deflected shape -- its foreshortening, second order
        in the deflection -- as a rigid constraint: a hardening the linear FE
        model does not have (README: plant linearity). The release takes up
        those in-plane motions; at the flat state they carry no force anyway.
        """
        joints = [Joint(f"{name}.x", "slide", np.array([1.0, 0.0, 0.0]), at, info=f"{info} (x)",
                         armature=RELEASE_ARMATURE[0]),
                  Joint(f"{name}.y", "slide", np.array([0.0, 1.0, 0.0]), at, info=f"{info} (y)",
                         armature=RELEASE_ARMATURE[0]),
                  Joint(f"{name}.rz", "hinge", Z_AXIS.copy(), at, info=f"{info} (rotation about z)",
                         armature=RELEASE_ARMATURE[1])]
        b = self._add(Body(name, at.copy(), parent, info, joints))
        b.items.append(point_mass(at, RELEASE_MASS))
        return b

    def _segments(self, member_id: str, flexible_length: float) -> int:
        """Links (hinges) of one segment of ``member_id``: explicit, else from its length. A piece an edit cut
        from a member (:func:`vlab.spec.changes.piece_id`) has its member's explicit setting unless it has
        its own, so that an edited member keeps the resolution its settings give the whole member."""
        per = self.spec.mujoco.get("segments", {})
        if not isinstance(per, dict):
            raise SimulationError(f"{self.spec._file()}: [mujoco] segments must be a table {{ <member id> = <int> }}")
        given = self.opts.member_segments or {}
        parent = cut_from(member_id)
        if member_id in given:
            n = given[member_id]
        elif member_id in per:
            n = per[member_id]
        elif parent is not None and parent in given:
            n = given[parent]
        elif parent is not None and parent in per:
            n = per[parent]
        else:
            n = self.opts.segments_per_element or auto_links(flexible_length)
            member = next(m for m in self.spec.members if m.id == member_id)
            sec = self.spec.sections[member.section]
            if not self.opts.segments_per_element and sec.shear_stiffness is not None:
                phi = 12.0 * sec.ei.si / (sec.shear_stiffness.si * flexible_length**2)
                if phi > SHEAR_SHORT_PHI:
                    n = 1  # shear carries all of its flexibility; its mass is negligible (SHEAR_SHORT_PHI)
        if isinstance(n, bool) or not isinstance(n, int) or n < 1:
            raise SimulationError(f"{self.spec._file()}: segments for member {member_id!r} must be an integer >= 1, "
                                  f"got {n!r}")
        self.links[member_id] = max(self.links.get(member_id, 0), n)
        return n


def _validate(spec: StructureSpec) -> None:
    """Refuse what the plant cannot represent, before any statics is solved."""
    _choose_root(spec)
    for m in spec.members:
        for pa, pb in zip(m.points[:-1], m.points[1:]):
            (xa, ya), (xb, yb) = spec.points[pa], spec.points[pb]
            length = math.hypot(xb - xa, yb - ya)
            if length == 0.0:
                raise SimulationError(f"{spec._file()}: member {m.id!r}: points {pa} and {pb} coincide")
            axis = np.array([(yb - ya) / length, -(xb - xa) / length, 0.0])
            if not _representable(axis, spec.active_dofs):
                raise SimulationError(
                    f"{spec._file()}: member {m.id!r} ({pa}-{pb}) bends about {axis[:2].round(3).tolist()}, "
                    f"which needs a rotation DOF the spec does not activate (dofs = {list(spec.active_dofs)})"
                )


def plan_structure(spec: StructureSpec, opts: SimOptions) -> tuple[Plan, Any]:
    """Plan the bodies, joints and constraints of ``spec`` (before any MjSpec exists).

    Parameters
    ----------
    spec : StructureSpec
    opts : SimOptions
        Resolved options (segments, layout, redundants).

    Returns
    -------
    plan : Plan
        Bodies (parent before child), world sites, strings, welds, connects, prestress loads.
    planner : _Planner
        Holds the FE gravity state and the grounded springs left for fixed tendons.

    Raises
    ------
    SimulationError
        For a spec the plant cannot represent, or failing in-plane statics.
    ResourceError
        A plant too deep or too large (:func:`check_plant_size`), or a mesh too large for the statics.
    """
    from ..fe.mesh import build_mesh
    from ..fe.statics import solve_gravity

    _validate(spec)
    try:
        mesh = build_mesh(spec)
        gs = solve_gravity(spec, mesh)
    except ModelError as exc:
        raise SimulationError(f"{spec._file()}: the in-plane gravity statics failed: {exc}") from exc
    pl = _Planner(spec, opts, gs, mesh)
    plan = pl.plan()
    check_plant_size(spec, plan)
    return plan, pl


#: Deepest kinematic tree MuJoCo compiles: measured with mujoco 4.0, a chain of 1023 bodies compiles and one
#: of 1024 fails ("depth limit exceeded in signature computation").
MAX_TREE_DEPTH = 1023


def check_plant_size(spec: StructureSpec, plan: Plan) -> None:
    """Refuse a planned plant MuJoCo cannot compile or vlab cannot linearise, before the MjSpec is built.

    Parameters
    ----------
    spec : StructureSpec
        The structure (its name in the message).
    plan : Plan
        The planned bodies and joints.

    Raises
    ------
    ResourceError
        A kinematic tree deeper than :data:`MAX_TREE_DEPTH` bodies, or a linearisation (two states per joint
        DOF) beyond :data:`vlab.fe.size.MAX_DOFS` (:func:`vlab.fe.size.check_dense_size`).
    """
    from ..fe.size import check_dense_size

    hint = "use fewer points or a smaller segments_per_element ([mujoco] table or --segments)"
    depth: dict[str, int] = {}
    for name, body in plan.bodies.items():  # parents are planned before their children
        depth[name] = 1 + (depth[body.parent] if body.parent in depth else 0)
    deepest = max(depth.values(), default=0)
    if deepest > MAX_TREE_DEPTH:
        raise ResourceError(f"{spec.name}: the MuJoCo plant's kinematic tree would be {deepest} bodies deep, more "
                            f"than MuJoCo compiles ({MAX_TREE_DEPTH}); {hint}")
    n_joints = sum(len(b.joints) for b in plan.bodies.values())
    check_dense_size(spec.name, 2 * n_joints, f"{len(plan.bodies)} bodies, {n_joints} joint DOFs x 2 states",
                     what="the MuJoCo plant's linearisation", hint=hint)
