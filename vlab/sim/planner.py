"""Plan the bodies, joints and constraints of a structure's MuJoCo plant (before any MjSpec exists).

:func:`plan_structure` turns a :class:`~vlab.spec.StructureSpec` into a
:class:`_Plan` -- bodies (parent before child) with their joints, inertia,
sites and visuals, the strings, the loop-closing welds, the support
equalities and the in-plane pre-stress loads -- that
:func:`vlab.sim.builder.build_mjspec` emits into an :class:`mujoco.MjSpec`.
The discretisation of each member (Gauss-placed hinges, :func:`hinge_layout`)
is described in :mod:`vlab.sim.builder`.

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
(DESIGN.md). Other supports are ``connect`` (w fixed) or ``weld`` (all fixed)
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
linear equalities on w and the active rotations (:attr:`_Plan.closures`:
fixed tendons with the first-order coefficients at the flat state, held at
zero length, :func:`vlab.sim.builder.build_mjspec`): each couples one chain
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

Sources: DESIGN.md ("MuJoCo facts"); Sec. 2.1, 2.1.1, 2.2, 2.2.1 of the
dissertation.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import ModelError, SimulationError
from ..spec import StructureSpec
from ..units import G_SI

if TYPE_CHECKING:
    from .builder import SimOptions

#: Mass [kg] of an in-plane release body (:meth:`_Planner._inplane_release`), light enough to move no
#: out-of-plane mode, and the in-plane inertia of its joints (armature: slides [kg], rotation [kg m^2]),
#: which only in-plane motion sees, heavy enough for a well-conditioned mass matrix.
RELEASE_MASS = 1e-6
RELEASE_ARMATURE = (0.1, 1e-4)

#: Automatic discretisation: at least MIN_LINKS hinges per member segment, and no link (on average)
#: longer than LINK_LENGTH_M -- two Gauss hinges per 10-in element of the BCC, three on the grid's bars,
#: two to four on the grid's top beam. MIN_LINKS = 2 holds for shear-flexible members too: a segment
#: loaded at its ends carries a linear bending moment and a constant shear, and two Gauss hinges (exact to
#: degree 2n - 2 = 2, :func:`hinge_layout`) give both end flexibilities exactly, where one mid-segment hinge
#: loses the double-curvature bending ``L^3 / (12 EI)``, a share ``1 / (1 + phi)`` of the segment's
#: end-shear flexibility (``phi = 12 EI / (kGA L^2)``). One link also turns the segment's shear
#: deformation into a step at its middle, so that each half of the segment's mass moves with its end: for
#: equal and opposite end deflections three times the kinetic energy of the linear shear field
#: (``m w^2`` against ``m w^2 / 3``). The grid's top beam (phi = 31-124 on its 0.37-0.75 m segments) had one
#: link per segment: its mode 12 lay 3.0 % below the FE model meshed at the plant's resolution (MAC 0.90);
#: with two or more, +0.03 % (MAC 0.9998) and all of the first 12 modes within 0.18 % (README: grid
#: cross-check).
MIN_LINKS = 2
LINK_LENGTH_M = 0.2

#: A shear-flexible segment with ``phi = 12 EI / (kGA L_f^2)`` above this is short against its section's
#: shear length ``sqrt(12 EI / kGA)`` (L_f < 3 % of it): one link loses less than 0.1 % of its end
#: flexibility, and the mass that one link lumps at the segment's ends is that of a short piece, so it gets
#: one link (the grid's four 22 mm top-beam segments at the bearings, phi = 34 000: 12 DOF and about a
#: sixth of the step time saved, the first 12 modes unchanged to 0.02 %).
SHEAR_SHORT_PHI = 1000.0


_AXIS = {"rx": np.array([1.0, 0.0, 0.0]), "ry": np.array([0.0, 1.0, 0.0])}
_Z = np.array([0.0, 0.0, 1.0])


# --------------------------------------------------------------------- plan ---


@dataclass
class _Item:
    """A rigid mass item, world coordinates: mass [kg], centre [m], inertia about the centre [kg m^2]."""

    mass: float
    com: np.ndarray
    inertia: np.ndarray


@dataclass
class _Joint:
    name: str
    kind: str  # "hinge" | "slide"
    axis: np.ndarray
    pos: np.ndarray  # world
    stiffness: float = 0.0
    elastic: bool = False  # a hinge spring of the discretisation (gets beta damping)
    info: str = ""
    armature: float = 0.0  # inertia added along the joint only [kg or kg m^2]


@dataclass
class _Visual:
    kind: str  # "box" | "sphere"
    pos: np.ndarray
    size: tuple[float, ...]
    angle: float = 0.0  # rotation about z [rad]
    rgba: tuple[float, float, float, float] = (0.6, 0.6, 0.65, 1.0)


@dataclass
class _Body:
    name: str
    origin: np.ndarray  # world position of the body frame (axes = world axes)
    parent: str | None  # None = world
    info: str
    joints: list[_Joint] = field(default_factory=list)
    items: list[_Item] = field(default_factory=list)
    sites: list[tuple[str, np.ndarray, str]] = field(default_factory=list)
    visuals: list[_Visual] = field(default_factory=list)


@dataclass
class _Plan:
    """What :func:`vlab.sim.builder.build_mjspec` emits (see the module notes on the topologies)."""

    bodies: dict[str, _Body]
    junction: dict[int, str]  # point -> body name
    world_sites: list[tuple[str, np.ndarray, str]]
    strings: list[tuple[str, str, str, float, float, str]]  # name, world site, body site, k, tension, info
    welds: list[tuple[str, str, str, str]]  # name, site1, site2, info
    connects: list[tuple[str, str, str, str]]  # name, site1, site2 (world), info
    prestress: list[tuple[str, str, str, np.ndarray, str]]  # name, site, refsite, wrench (6), info
    n_loops: int
    #: linear closures (forest topology): name, site on the stub, site on the junction, DOFs to equate, info
    closures: list[tuple[str, str, str, tuple[str, ...], str]] = field(default_factory=list)
    topology: str = "tree"


def _p3(xy: tuple[float, float]) -> np.ndarray:
    return np.array([xy[0], xy[1], 0.0])


def _rod(p0: np.ndarray, p1: np.ndarray, rho_a: float, rho_ip: float, width: float, thick: float) -> _Item:
    """Mass item of a straight bar piece from p0 to p1 (section width in plane, thickness out of plane)."""
    d = p1 - p0
    length = float(np.linalg.norm(d))
    e = d / length
    n = np.array([-e[1], e[0], 0.0])
    m = rho_a * length
    local = np.diag([rho_ip * length, m * (length**2 + thick**2) / 12.0, m * (length**2 + width**2) / 12.0])
    r = np.column_stack([e, n, _Z])
    return _Item(m, 0.5 * (p0 + p1), r @ local @ r.T)


def _point_mass(p: np.ndarray, mass: float, irx: float = 0.0, iry: float = 0.0) -> _Item:
    return _Item(mass, p.copy(), np.diag([irx, iry, irx + iry]))


def _combine(items: list[_Item], origin: np.ndarray, name: str) -> tuple[float, np.ndarray, np.ndarray]:
    """Total mass, centre relative to ``origin`` and inertia about the centre of a list of items."""
    mass = sum(it.mass for it in items)
    if not mass > 0.0:
        raise SimulationError(f"body {name!r} has no mass: every moving body needs inertia")
    com = sum(it.mass * it.com for it in items) / mass
    inertia = np.zeros((3, 3))
    for it in items:
        r = it.com - com
        inertia += it.inertia + it.mass * (np.dot(r, r) * np.eye(3) - np.outer(r, r))
    # keep strictly positive definite (a point mass alone has zero inertia)
    floor = 1e-12 + 1e-9 * max(np.trace(inertia), 0.0)
    inertia += floor * np.eye(3)
    return mass, com - origin, inertia


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
        if _held_inplane(s):
            return s.point
    for s in spec.strings:
        if s.tension is None:
            return s.point
    raise SimulationError(
        f"{spec._file()}: nothing holds the structure in its plane (no support with inplane = true "
        "and no string with tension = \"reaction\"): the MuJoCo tree has no root"
    )


def auto_links(flexible_length: float) -> int:
    """Default number of hinges of a segment of ``flexible_length`` [m].

    Parameters
    ----------
    flexible_length : float
        Flexible length of the member segment [m].

    Returns
    -------
    int
        ``max(MIN_LINKS, ceil(flexible_length / LINK_LENGTH_M))``; chosen by the
        convergence study (README): Gauss hinges with links up to 0.2 m keep the
        BCC's first 6 and the grid's first 12 modes within 1-1.5 % of the FE model.
    """
    return max(MIN_LINKS, math.ceil(flexible_length / LINK_LENGTH_M - 1e-9))


def hinge_layout(n: int, layout: str = "gauss") -> tuple[np.ndarray, np.ndarray]:
    """Positions and compliance shares of the ``n`` hinges of one flexible length.

    Parameters
    ----------
    n : int
        Hinges (links) per flexible length, >= 1.
    layout : {"gauss", "uniform"}
        ``"gauss"``: hinges at the n-point Gauss-Legendre abscissae, each with the
        compliance share of its Gauss weight -- the chain's end flexibility is then
        exact for moments (and shears) varying as polynomials of degree up to
        ``2n - 2`` (end loads, uniform loads for n >= 2). ``"uniform"``: hinges at
        the link midpoints ``(k + 1/2)/n`` with equal shares (end-load flexibility
        off by ``-1/(4 n^2)`` for a cantilever, ``-1/n^2`` in double curvature).

    Returns
    -------
    positions : ndarray, shape (n,)
        Hinge positions as fractions of the flexible length, increasing.
    shares : ndarray, shape (n,)
        Compliance shares ``c_k`` (sum 1): hinge stiffness ``EI / (c_k L)``,
        ``GJ / (c_k L)``, ``kGA / (c_k L)``.

    Raises
    ------
    SimulationError
        For ``n < 1`` or an unknown layout.

    Source: Gauss-Legendre quadrature of the complementary energy
    ``int M^2 / (2 EI) ds`` (Abramowitz & Stegun 25.4.29).
    """
    if n < 1:
        raise SimulationError(f"hinges per flexible length must be >= 1, got {n}")
    if layout == "gauss":
        x, w = np.polynomial.legendre.leggauss(n)
        return 0.5 * (1.0 + x), 0.5 * w
    if layout == "uniform":
        return (np.arange(n) + 0.5) / n, np.full(n, 1.0 / n)
    raise SimulationError(f"unknown hinge layout {layout!r}; use 'gauss' or 'uniform'")


def _held_inplane(support) -> bool:
    """True for a support pinned or clamped in the plane (``inplane`` "pinned"/"clamped"/true)."""
    return support.inplane in ("pinned", "clamped", True)


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


class _Planner:
    """Turns a StructureSpec into a plan of bodies, joints and constraints."""

    def __init__(self, spec: StructureSpec, opts: SimOptions, gravity_state, mesh):
        self.spec = spec
        self.opts = opts
        self.gs = gravity_state
        self.mesh = mesh
        self.bodies: dict[str, _Body] = {}
        self.junction: dict[int, str] = {}
        self.world_sites: list[tuple[str, np.ndarray, str]] = []
        self.strings: list = []
        self.welds: list = []
        self.connects: list = []
        self.prestress: list = []
        self.pending_sites: list = []  # sites on junctions, added once all junctions exist
        self.pending_springs: list = []  # grounded springs realised as fixed tendons after compiling
        self.cuts: list = []  # (edge, point, stub body) of every loop closure
        self.closures: list = []  # linear closures of the forest topology (see _Plan.closures)
        self.roots: set[int] = set()  # points whose junction hangs from the world by its own joints
        self.chain_roots: set[int] = set()  # points whose junction roots a member chain
        self.forest = False
        self.n_loops = 0
        self.links: dict[str, int] = {}  # member/crosspiece id -> links per segment
        self.active = spec.active_dofs

    # -- helpers
    def _add(self, body: _Body) -> _Body:
        if body.name in self.bodies:
            raise SimulationError(f"duplicate body name {body.name!r} (two members with the same id?)")
        self.bodies[body.name] = body
        return body

    def _section(self, name: str):
        return self.spec.sections[name]

    def _bar_visual(self, body: _Body, p0: np.ndarray, p1: np.ndarray, sec, rgba=(0.6, 0.6, 0.65, 1.0)) -> None:
        d = p1 - p0
        length = float(np.linalg.norm(d))
        if length <= 0:
            return
        body.visuals.append(
            _Visual("box", 0.5 * (p0 + p1), (length / 2, sec.width.si / 2, sec.thickness.si / 2),
                    math.atan2(d[1], d[0]), rgba)
        )

    # -- the plan
    def plan(self) -> _Plan:
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
            b.sites.append((f"p{p}", _p3(spec.points[p]), f"spec: point {p}"))
        for q, name, pos, info in self.pending_sites:
            self.bodies[self.junction[q]].sites.append((name, pos, info))
        return _Plan(self.bodies, self.junction, self.world_sites, self.strings, self.welds,
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

    def _root_joints(self, root: int) -> list[_Joint]:
        fixed = {d for s in self.spec.supports if s.point == root for d in s.fixed}
        pos = _p3(self.spec.points[root])
        joints = []
        if "w" not in fixed:
            joints.append(_Joint(f"root{root}.w", "slide", _Z, pos, info=f"spec: point {root} out-of-plane translation w (root)"))
        for d in ("rx", "ry"):
            if d in self.active and d not in fixed:
                joints.append(_Joint(f"root{root}.{d}", "hinge", _AXIS[d], pos,
                                     info=f"spec: point {root} rotation {d} (root)"))
        return joints

    def _junction(self, p: int, parent: str | None, joints: list[_Joint]) -> _Body:
        b = self._add(_Body(f"J{p}", _p3(self.spec.points[p]), parent, f"spec: point {p} (junction)", joints))
        self.junction[p] = b.name
        return b

    def _edge(self, e: _Edge, p: int, q: int, tree: bool) -> None:
        """Chain of links from junction p to q (a new junction in the chain, or a stub closed at q)."""
        spec, m = self.spec, e.member
        sec = self._section(m.section)
        ins = _inserts(m)
        pp, pq = _p3(spec.points[p]), _p3(spec.points[q])
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
        jp.items.append(_rod(pp, end_p, sec.rho_a, sec.rho_ip, sec.width.si, sec.thickness.si))
        self._bar_visual(jp, pp, end_p, sec)
        parent = jp.name
        for k in range(n):
            h = hinges[k]
            joints = []
            if k_shear is not None:
                joints.append(_Joint(f"{tag}.h{k + 1}.shear", "slide", _Z, h, k_shear[k], True,
                                     f"spec: member {m.id} segment {p}-{q} hinge {k + 1}/{n}: shear kGA/(c L) = {k_shear[k]:.6g} N/m"))
            joints.append(_Joint(f"{tag}.h{k + 1}.bend", "hinge", bend_axis, h, k_bend[k], True,
                                 f"spec: member {m.id} segment {p}-{q} hinge {k + 1}/{n}: bending EI/(c L) = {k_bend[k]:.6g} N*m/rad"))
            if twist and k in twist_at:
                joints.append(_Joint(f"{tag}.h{k + 1}.twist", "hinge", ev.copy(), h, k_twist[k], True,
                                     f"spec: member {m.id} segment {p}-{q} hinge {k + 1}/{n}: torsion {twist_label} = {k_twist[k]:.6g} N*m/rad"))
            if k < n - 1:
                b = self._add(_Body(f"{tag}.link{k + 1}", h, parent,
                                    f"spec: member {m.id} segment {p}-{q} link {k + 1}/{n - 1}", joints))
                b.items.append(_rod(h, hinges[k + 1], sec.rho_a, sec.rho_ip, sec.width.si, sec.thickness.si))
                self._bar_visual(b, h, hinges[k + 1], sec)
                parent = b.name
            else:
                if tree:
                    b = self._junction(q, parent, joints)
                else:
                    how = "held to J{q} by linear equalities" if self.forest else "welded to J{q} (loop)"
                    b = self._add(_Body(f"{tag}.stub{q}", h, parent,
                                        f"spec: member {m.id} segment {p}-{q}: end at point {q} " + how.format(q=q),
                                        joints))
                b.items.append(_rod(h, pq, sec.rho_a, sec.rho_ip, sec.width.si, sec.thickness.si))
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

    def _inplane_release(self, name: str, parent: str, at: np.ndarray, info: str) -> _Body:
        """A light body on ``parent`` free to slide in the plane and turn about z (RELEASE_MASS).

        The tree has no in-plane DOFs, so a weld or connect that closes a loop
        (or holds a point to the ground) would otherwise enforce the in-plane
        compatibility of the deflected shape -- its foreshortening, second order
        in the deflection -- as a rigid constraint: a hardening the linear FE
        model does not have (README: plant linearity). The release takes up
        those in-plane motions; at the flat state they carry no force anyway.
        """
        joints = [_Joint(f"{name}.x", "slide", np.array([1.0, 0.0, 0.0]), at, info=f"{info} (x)",
                         armature=RELEASE_ARMATURE[0]),
                  _Joint(f"{name}.y", "slide", np.array([0.0, 1.0, 0.0]), at, info=f"{info} (y)",
                         armature=RELEASE_ARMATURE[0]),
                  _Joint(f"{name}.rz", "hinge", _Z.copy(), at, info=f"{info} (rotation about z)",
                         armature=RELEASE_ARMATURE[1])]
        b = self._add(_Body(name, at.copy(), parent, info, joints))
        b.items.append(_point_mass(at, RELEASE_MASS))
        return b

    def _segments(self, member_id: str, flexible_length: float) -> int:
        """Links (hinges) of one segment of ``member_id``: explicit, else from its length."""
        per = self.spec.mujoco.get("segments", {})
        if not isinstance(per, dict):
            raise SimulationError(f"{self.spec._file()}: [mujoco] segments must be a table {{ <member id> = <int> }}")
        if self.opts.member_segments and member_id in self.opts.member_segments:
            n = self.opts.member_segments[member_id]
        elif member_id in per:
            n = per[member_id]
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

    def _crosspiece(self, c) -> None:
        spec = self.spec
        sec = self._section(c.section)
        pj = _p3(spec.points[c.point])
        jb = self.bodies[self.junction[c.point]]
        # member direction through the point -> arms perpendicular in the plane
        ev = None
        for m in spec.members:
            if c.point in m.points:
                i = m.points.index(c.point)
                a, b = (m.points[i - 1], m.points[i]) if i > 0 else (m.points[0], m.points[1])
                d = _p3(spec.points[b]) - _p3(spec.points[a])
                ev = d / np.linalg.norm(d)
                break
        if ev is None:
            raise SimulationError(f"{spec._file()}: crosspiece {c.id!r}: no member passes through point {c.point}")
        perp = np.array([-ev[1], ev[0], 0.0])
        off_default = max([ri.length.si for m in spec.members for ri in m.rigid_inserts if ri.point == c.point] or [0.0])
        offset = spec.mujoco.get("crosspiece_root_offset", off_default)
        if isinstance(offset, bool) or not isinstance(offset, (int, float)) or not 0.0 <= offset < 1.0:
            raise SimulationError(f"{spec._file()}: [mujoco] crosspiece_root_offset = {offset!r}: expected a "
                                  "length in metres, 0 <= offset < 1")
        offset = float(offset)
        L = c.arm_length.si
        n = self.opts.crosspiece_segments or auto_links(L)
        self.links[c.id] = n
        frac, comp = hinge_layout(n, self.opts.hinge_layout)
        k_bend = [sec.ei.si / (cf * L) for cf in comp]
        jb.items.append(_point_mass(pj, c.clamp_mass.si))
        for sign, label in ((1.0, "a"), (-1.0, "b")):
            d = sign * perp
            axis = np.array([d[1], -d[0], 0.0])
            root = pj + offset * d
            hinges = [root + f * L * d for f in frac]
            jb.items.append(_rod(root, hinges[0], sec.rho_a, sec.rho_ip, sec.width.si, sec.thickness.si))
            self._bar_visual(jb, pj, hinges[0], sec, (0.75, 0.75, 0.8, 1.0))
            parent = jb.name
            for k in range(n):
                h = hinges[k]
                joint = _Joint(f"{c.id}.arm{label}.h{k + 1}.bend", "hinge", axis, h, k_bend[k], True,
                               f"spec: crosspiece {c.id} arm {label} hinge {k + 1}/{n}: bending EI/(c L) = {k_bend[k]:.6g} N*m/rad")
                end = hinges[k + 1] if k < n - 1 else root + L * d
                b = self._add(_Body(f"{c.id}.arm{label}.link{k + 1}", h, parent,
                                    f"spec: crosspiece {c.id} arm {label} link {k + 1}/{n}", [joint]))
                b.items.append(_rod(h, end, sec.rho_a, sec.rho_ip, sec.width.si, sec.thickness.si))
                self._bar_visual(b, h, end, sec, (0.75, 0.75, 0.8, 1.0))
                if k == n - 1:
                    b.items.append(_point_mass(end, c.tip_mass.si))
                    b.visuals.append(_Visual("sphere", end, (0.012,), rgba=(0.8, 0.3, 0.2, 1.0)))
                    b.sites.append((f"{c.id}.tip{label}", end, f"spec: crosspiece {c.id} tip {label}"))
                parent = b.name

    def _masses(self) -> None:
        for lm in self.spec.masses:
            b = self.bodies[self.junction[lm.point]]
            if lm.id in set(self._plates().values()):
                continue  # realised as a pendulum plate in _springs
            p = _p3(self.spec.points[lm.point])
            b.items.append(_point_mass(p, lm.mass.si, lm.inertia_rx.si if lm.inertia_rx else 0.0,
                                       lm.inertia_ry.si if lm.inertia_ry else 0.0))
            b.visuals.append(_Visual("sphere", p, (0.008,), rgba=(0.2, 0.3, 0.8, 1.0)))

    def _strings(self) -> None:
        for s in self.spec.strings:
            tension = float(self.gs.string_tensions[s.id])
            L = s.length.si
            p = _p3(self.spec.points[s.point])
            anchor = p + L * np.array([s.direction[0], s.direction[1], 0.0])
            b = self.bodies[self.junction[s.point]]
            ws, bs = f"{s.id}.anchor", f"{s.id}.end"
            self.world_sites.append((ws, anchor, f"spec: string {s.id} ground anchor"))
            b.sites.append((bs, p, f"spec: string {s.id} attachment"))
            b.items.append(_point_mass(p, s.rho_a.si * L / 3.0))  # as the FE string element
            self.strings.append((f"string.{s.id}", ws, bs, tension / L, tension,
                                 f"spec: string {s.id}: T = {tension:.6g} N, L = {L:.6g} m, T/L = {tension / L:.6g} N/m"))

    def _supports(self) -> None:
        for s in self.spec.supports:
            if s.point in self.roots:
                continue  # its fixed DOFs are left out of the junction's joints (_root_joints)
            fixed = set(s.fixed)
            rot_active = {d for d in ("rx", "ry") if d in self.active}
            b = self.bodies[self.junction[s.point]]
            p = _p3(self.spec.points[s.point])
            if self.forest:  # a junction inside a chain: its fixed DOFs held to the ground, to first order
                dofs = tuple(d for d in ("w", "rx", "ry") if d in fixed and (d == "w" or d in rot_active))
                if dofs:
                    s1, s2 = f"support{s.point}", f"support{s.point}.ground"
                    b.sites.append((s1, p, f"spec: support at point {s.point}"))
                    self.world_sites.append((s2, p, f"spec: support at point {s.point} (ground)"))
                    self.closures.append((f"support{s.point}", s1, s2, dofs,
                                          f"spec: support at point {s.point} fixes {sorted(fixed)}"))
                continue
            if fixed == {"w"}:
                kind = "connect"
            elif fixed == {"w"} | rot_active:
                kind = "weld"
            elif not fixed:
                continue
            else:
                raise SimulationError(
                    f"{self.spec._file()}: support at point {s.point} fixes {sorted(fixed)}: the MuJoCo plant "
                    "can fix w alone (connect) or w with all active rotations (weld) at a non-root point"
                )
            s1, s2 = f"support{s.point}", f"support{s.point}.ground"
            cut = self._inplane_release(f"J{s.point}.release", b.name, p,
                                        f"support at point {s.point}: in-plane release of its {kind}")
            cut.sites.append((s1, p, f"spec: support at point {s.point}"))
            self.world_sites.append((s2, p, f"spec: support at point {s.point} (ground)"))
            (self.connects if kind == "connect" else self.welds).append(
                (f"support{s.point}", s1, s2, f"spec: support at point {s.point} fixes {sorted(fixed)}"))

    def _plates(self) -> dict[str, str]:
        """Spring id -> mass id of the pendulum plates.

        ``[mujoco] pendulum_plates`` may give the table explicitly, or ``false`` to
        disable plates. By default a grounded rotational spring about an axis
        perpendicular to gravity becomes a pendulum plate when exactly one lumped
        mass at its point has a rotary inertia about that axis of at least
        ``m Y^2`` with ``Y = k / (m g)`` (the plate's own inertia cannot be
        negative), as for the grid's plates (Sec. 2.2.1: ``W Y`` springs).
        """
        if hasattr(self, "_plates_cache"):
            return self._plates_cache
        spec = self.spec
        plates = spec.mujoco.get("pendulum_plates", None)
        if plates is False:
            plates = {}
        elif plates is None:
            plates = {}
            g = np.array([*spec.gravity_direction, 0.0])
            for sp in spec.springs:
                if sp.dof not in ("rx", "ry") or abs(np.dot(_AXIS[sp.dof], g)) > 1e-9:
                    continue
                cands = []
                for lm in spec.masses:
                    if lm.point != sp.point:
                        continue
                    irot = lm.inertia_rx if sp.dof == "rx" else lm.inertia_ry
                    ecc = sp.stiffness.si / (lm.mass.si * G_SI)
                    if irot is not None and irot.si >= lm.mass.si * ecc**2 * (1 - 1e-9):
                        cands.append(lm.id)
                if len(cands) == 1:
                    plates[sp.id] = cands[0]
        elif not isinstance(plates, dict):
            raise SimulationError(f"{spec._file()}: [mujoco] pendulum_plates must be a table "
                                  "{ <spring id> = \"<mass id>\" } or false")
        self._plates_cache = dict(plates)
        return self._plates_cache

    def _springs(self) -> None:
        spec = self.spec
        plates = self._plates()
        masses = {m.id: m for m in spec.masses}
        for sp in spec.springs:
            p = _p3(spec.points[sp.point])
            b = self.bodies[self.junction[sp.point]]
            if sp.id in plates:
                mid = plates[sp.id]
                if mid not in masses or masses[mid].point != sp.point:
                    raise SimulationError(f"{spec._file()}: [mujoco] pendulum_plates.{sp.id} = {mid!r}: "
                                          f"no mass of that id at point {sp.point}")
                if sp.dof not in ("rx", "ry"):
                    raise SimulationError(f"{spec._file()}: pendulum plate for spring {sp.id!r} on DOF {sp.dof!r}: "
                                          "only a rotation can be a pendulum")
                lm = masses[mid]
                g = np.array([*spec.gravity_direction, 0.0])
                axis = _AXIS[sp.dof]
                if abs(np.dot(axis, g)) > 1e-9:
                    raise SimulationError(f"{spec._file()}: spring {sp.id!r}: a pendulum about {sp.dof} needs "
                                          "gravity perpendicular to that axis")
                ecc = sp.stiffness.si / (lm.mass.si * G_SI)  # W * Y = k  ->  Y = k / W
                irot = lm.inertia_rx if sp.dof == "rx" else lm.inertia_ry
                i_axis = irot.si if irot is not None else lm.mass.si * ecc**2
                i_own = i_axis - lm.mass.si * ecc**2
                if i_own < -1e-12 * max(i_axis, 1e-30):
                    raise SimulationError(
                        f"{spec._file()}: pendulum plate {mid!r}: its inertia about the axis ({i_axis:.4g} kg*m^2) "
                        f"is less than m*Y^2 = {lm.mass.si * ecc**2:.4g} with Y = k/W = {ecc:.4g} m"
                    )
                c = p + ecc * g
                iother = lm.inertia_ry if sp.dof == "rx" else lm.inertia_rx
                own = max(i_own, 0.0)
                other = iother.si if iother is not None else 0.0
                diag = [own, other, own] if sp.dof == "rx" else [other, own, own]
                b.items.append(_Item(lm.mass.si, c, np.diag(diag)))
                b.visuals.append(_Visual("box", c, (0.05, 0.05, 0.009), rgba=(0.7, 0.7, 0.3, 1.0)))
                b.sites.append((f"{sp.id}.plate", c, f"spec: spring {sp.id} as pendulum plate {mid}: "
                                f"W = {lm.mass.si * G_SI:.5g} N at Y = {ecc:.5g} m"))
                continue
            if sp.point in self.roots:
                name = f"root{sp.point}.{sp.dof}"
                for j in b.joints:
                    if j.name == name:
                        j.stiffness += sp.stiffness.si
                        j.info += f"; spring {sp.id} {sp.stiffness.si:.6g}"
                        break
                else:
                    raise SimulationError(f"{spec._file()}: spring {sp.id!r} acts on DOF {sp.dof!r} of point "
                                          f"{sp.point}, which is fixed or inactive")
                continue
            self.pending_springs.append(sp)

    def _instrumentation(self) -> None:
        ins = self.spec.instrumentation
        if ins is None:
            return
        for p in ins.actuators:
            b = self.bodies[self.junction[p]]
            pos = _p3(self.spec.points[p])
            b.sites.append((f"coil{p}", pos, f"spec: voice-coil actuator at point {p}"))
            self.world_sites.append((f"coil{p}_ref", pos, f"spec: voice-coil magnet (ground) at point {p}"))

    def _redundants(self) -> None:
        """Constant in-plane loads that reproduce the FE statics' redundant forces."""
        spec, gs, mesh = self.spec, self.gs, self.mesh
        el_index = {}
        for i, el in enumerate(mesh.elements):
            el_index.setdefault((el.member, el.a), []).append(i)
            el_index.setdefault((el.member, el.b), []).append(i)

        def end_force(member, seg, a, b, at):
            """Force [N] and moment [N m] (world) that node ``at`` exerts on the member segment a-b."""
            for i in el_index.get((member.id, at), []):
                el = mesh.elements[i]
                other = el.b if el.a == at else el.a
                inner = isinstance(other, str) and other.startswith(f"{member.id}.{seg}.")
                if not (inner or other in (a, b)):
                    continue
                f = gs.element_forces[i]
                ex, ey = el.direction
                if el.a == at:
                    fx, fy, mz = -f.axial[0], f.shear[0], -f.moment[0]
                else:
                    fx, fy, mz = f.axial[1], -f.shear[1], f.moment[1]
                force = fx * np.array([ex, ey, 0.0]) + fy * np.array([-ey, ex, 0.0])
                return force, mz
            raise SimulationError(f"internal: no FE element of member {member.id} at point {at}")

        scale = max(1.0, sum(it.mass for b in self.bodies.values() for it in b.items) * G_SI)
        for e, q, stub in self.cuts:
            force, mz = end_force(e.member, e.seg, e.a, e.b, q)
            pos = _p3(spec.points[q])
            tag = f"{e.member.id}.{min(e.a, e.b)}-{max(e.a, e.b)}"
            self._dead_load(f"prestress.{tag}.{q}", stub, pos, force, mz, scale,
                            f"FE statics: in-plane force and moment of point {q} on member {e.member.id} "
                            f"at its loop cut (reaction on J{q})", ref_body=self.junction[q])
        # a junction hung from the world (the tree's root, the forest's hung junctions) is held in the plane
        # there: the reaction of its support needs no load
        for s in spec.supports:
            if _held_inplane(s) and s.point not in self.roots:
                r, mr = self._reaction(s.point, end_force)
                if s.inplane != "clamped":
                    mr = 0.0
                self._dead_load(f"prestress.support{s.point}", self.junction[s.point], _p3(spec.points[s.point]),
                                r, mr, scale, f"FE statics: in-plane reaction of the support at point {s.point}")

    def _reaction(self, point: int, end_force) -> np.ndarray:
        spec = self.spec
        total = np.zeros(3)
        moment = 0.0
        for m in spec.members:
            for i, (a, b) in enumerate(zip(m.points[:-1], m.points[1:])):
                if point in (a, b):
                    f, mz = end_force(m, i, a, b, point)
                    total += f
                    moment += mz
        g = G_SI * np.array([*spec.gravity_direction, 0.0])
        ext = np.zeros(3)
        for lm in spec.masses:
            if lm.point == point:
                ext += lm.mass.si * g
        for c in spec.crosspieces:
            if c.point == point:
                arm = spec.sections[c.section].rho_a * c.arm_length.si
                ext += (2 * (arm + c.tip_mass.si) + c.clamp_mass.si) * g
        for s in spec.strings:
            if s.point == point and s.tension is not None:
                ext += s.tension.si * np.array([*s.direction, 0.0])
        return total - ext, moment

    def _dead_load(self, name, body, pos, force, moment, scale, info, ref_body: str | None = None) -> None:
        """A constant force [N] and moment about z [N m] on ``body`` at ``pos``.

        With ``ref_body`` the load is a pair: the equal and opposite load acts on
        ``ref_body`` (the actuator's refsite is on it), else the reaction goes to
        the world (a world-fixed refsite: a dead load).
        """
        tol = 1e-9 * scale
        wrench = np.array([force[0], force[1], 0.0, 0.0, 0.0, moment])
        if np.linalg.norm(wrench) <= tol:
            return
        b = self.bodies[body]
        site, ref = name, f"{name}_ref"
        b.sites.append((site, pos, info))
        if ref_body is None:
            self.world_sites.append((ref, pos, info + " (ground frame)"))
        else:
            self.pending_sites.append((int(ref_body[1:]), ref, pos, info + " (reaction side)"))
        self.prestress.append((name, site, ref, wrench,
                               info + f": F = ({force[0]:.6g}, {force[1]:.6g}) N, M = {moment:.6g} N*m"))


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


def plan_structure(spec: StructureSpec, opts: SimOptions) -> tuple[_Plan, Any]:
    """Plan the bodies, joints and constraints of ``spec`` (before any MjSpec exists).

    Parameters
    ----------
    spec : StructureSpec
    opts : SimOptions
        Resolved options (segments, layout, redundants).

    Returns
    -------
    plan : _Plan
        Bodies (parent before child), world sites, strings, welds, connects, prestress loads.
    planner : _Planner
        Holds the FE gravity state and the grounded springs left for fixed tendons.

    Raises
    ------
    SimulationError
        For a spec the plant cannot represent, or failing in-plane statics.
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
    return plan, pl
