"""In-plane static analysis under gravity: the pre-stress of every element.

Sec. 2.2.1: "Gravity-induced in-plane forces, shear forces, and bending
moments have significant influence on the out-of-plane stiffnesses of the
thin aluminum grid members." This module solves the plane-frame problem
(DOFs ``u, v, theta_z`` per node, standard 2-D frame elements with EA and the
in-plane EI) loaded by the self-weight of members, lumped masses and
crosspieces, and by strings of given tension, and returns the end forces of
every element. Points of strings whose tension is "reaction" and supports
marked ``inplane = "pinned"`` (or ``true``) are pinned in the plane, ``"clamped"``
ones also fixed in in-plane rotation.

Results are memoised on everything the solution reads (:func:`_inputs`): a
model changed only out of its plane (a softened joint, a spring) reuses the
solution, which the mismatch diagnosis does thousands of times.

Source: Przemieniecki (1968) Ch. 5 (plane frame element); consistent nodal
loads of a uniformly distributed load.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ModelError
from ..spec import StructureSpec
from ..units import G_SI
from .mesh import Element, Mesh
from .size import check_model_size


@dataclass(frozen=True)
class ElementForces:
    """Gravity pre-stress of one element.

    Attributes
    ----------
    axial : (float, float)
        Axial force at ends a and b [N], tension positive.
    shear : (float, float)
        In-plane shear force at ends a and b [N], beam sign convention:
        ``V = dM/ds`` along the element axis ``s`` (a -> b); positive shear
        acts in local -y (``y = e_z x e_x``) on the cut face whose outward
        normal is +x.
    moment : (float, float)
        In-plane bending moment at ends a and b [N*m], beam sign convention:
        positive when the fibres on the local -y side are in tension (sagging
        for a member along +x with y up).
    """

    axial: tuple[float, float]
    shear: tuple[float, float]
    moment: tuple[float, float]


@dataclass(frozen=True)
class GravityState:
    """Result of :func:`solve_gravity`: element forces and string tensions [N].

    Attributes
    ----------
    element_forces : tuple of ElementForces
        In-plane pre-stress of every element, in the order of ``mesh.elements``.
    string_tensions : dict[str, float]
        String id -> tension [N]: the given value, or the reaction from
        equilibrium for a "reaction" string.
    displacements : dict[Node, (float, float, float)]
        Node (point id or generated label) -> in-plane displacement under
        gravity ``(u [m], v [m], theta_z [rad])``.
    """

    element_forces: tuple[ElementForces, ...]
    string_tensions: dict[str, float]
    displacements: dict[object, tuple[float, float, float]]


def _frame_local_stiffness(ea: float, ei: float, L: float) -> np.ndarray:
    k = np.zeros((6, 6))
    a = ea / L
    k[np.ix_([0, 3], [0, 3])] = a * np.array([[1, -1], [-1, 1]])
    b = ei / L**3
    idx = [1, 2, 4, 5]
    k[np.ix_(idx, idx)] = b * np.array(
        [[12, 6 * L, -12, 6 * L], [6 * L, 4 * L**2, -6 * L, 2 * L**2],
         [-12, -6 * L, 12, -6 * L], [6 * L, 2 * L**2, -6 * L, 4 * L**2]]
    )
    return k


def _rotation(e: tuple[float, float]) -> np.ndarray:
    c, s = e
    r = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
    t = np.zeros((6, 6))
    t[:3, :3] = r
    t[3:, 3:] = r
    return t


def _distributed_load_local(q_local: np.ndarray, L: float) -> np.ndarray:
    """Consistent nodal loads of a uniform load (qx, qy) [N/m] in local axes."""
    qx, qy = q_local
    return np.array([qx * L / 2, qy * L / 2, qy * L**2 / 12, qx * L / 2, qy * L / 2, -qy * L**2 / 12])


#: Memoised solutions, keyed by :func:`_inputs` (cleared when it holds more than _CACHE_SIZE).
_CACHE: dict = {}
_CACHE_SIZE = 256


def _inputs(spec: StructureSpec, mesh: Mesh) -> tuple:
    """Everything :func:`solve_gravity` reads, as a hashable key."""
    secs = spec.sections
    return (
        spec.name, tuple(spec.gravity_direction), tuple(mesh.nodes),
        tuple((el.a, el.b, el.length, tuple(el.direction), secs[el.section].ea, secs[el.section].ei_inplane,
               secs[el.section].rho_a) for el in mesh.elements),
        tuple((m.point, m.mass.si) for m in spec.masses),
        tuple((c.point, secs[c.section].rho_a, c.arm_length.si, c.tip_mass.si, c.clamp_mass.si)
              for c in spec.crosspieces),
        tuple((s.id, s.point, None if s.tension is None else s.tension.si, tuple(s.direction))
              for s in spec.strings),
        tuple((sup.point, sup.inplane) for sup in spec.supports),
    )


def solve_gravity(spec: StructureSpec, mesh: Mesh) -> GravityState:
    """Solve the in-plane frame under gravity and string tensions (memoised; treat the result as read-only).

    Parameters
    ----------
    spec : StructureSpec
        Loads (masses, sections' mass per length), strings and supports.
    mesh : Mesh
        The elements (from :func:`vlab.fe.mesh.build_mesh`).

    Returns
    -------
    GravityState
        Per element (same order as ``mesh.elements``) axial force, in-plane
        shear and moment at both ends; the tension of every string [N].

    Raises
    ------
    ModelError
        If the structure is not held in its plane (loads not in equilibrium with
        the supports: a rigid-body motion would be loaded).
    ResourceError
        A mesh beyond :data:`vlab.fe.size.MAX_DOFS` in-plane degrees of freedom
        (:func:`vlab.fe.size.check_model_size`).
    """
    check_model_size(spec, len(mesh.nodes), dofs_per_node=3, what="the in-plane gravity statics")
    key = _inputs(spec, mesh)
    hit = _CACHE.get(key)
    if hit is None:
        hit = _solve(spec, mesh)
        if len(_CACHE) >= _CACHE_SIZE:
            _CACHE.clear()
        _CACHE[key] = hit
    return hit


def _solve_symmetric(k: np.ndarray, f: np.ndarray) -> np.ndarray:
    """``k x = f`` for the in-plane stiffness: an LU solve of the equilibrated system ``(D k D) y = D f``,
    ``x = D y`` with ``D = |diag k|^(-1/2)`` (translations and rotations on one scale) where it is regular --
    its reciprocal condition number (LAPACK's ``dgecon`` estimate) above machine epsilon, the usual test of
    a matrix "singular to working precision" -- else the minimum-norm least-squares solution (a mechanism
    whose loads may still balance; the caller checks the residual)."""
    from scipy.linalg import lapack, lu_factor, lu_solve

    n = k.shape[0]
    diag = np.abs(np.diag(k))
    if n and np.all(diag > 0):
        d = 1.0 / np.sqrt(diag)
        ks = d[:, None] * k * d[None, :]
        lu, piv = lu_factor(ks, check_finite=False)
        rcond, info = lapack.dgecon(lu, float(np.linalg.norm(ks, 1)), norm="1")
        if info == 0 and rcond > np.finfo(float).eps:
            return d * lu_solve((lu, piv), d * f, check_finite=False)
    return np.linalg.lstsq(k, f, rcond=None)[0]


def _solve(spec: StructureSpec, mesh: Mesh) -> GravityState:
    nodes = list(mesh.nodes)
    pos = {n: i for i, n in enumerate(nodes)}
    ndof = 3 * len(nodes)
    k = np.zeros((ndof, ndof))
    f = np.zeros(ndof)
    g = G_SI * np.asarray(spec.gravity_direction)  # acceleration vector in plane

    fixed_eq: list[np.ndarray] = []
    for el in mesh.elements:
        sec = spec.sections[el.section]
        kl = _frame_local_stiffness(sec.ea, sec.ei_inplane, el.length)
        t = _rotation(el.direction)
        idx = [3 * pos[el.a] + j for j in range(3)] + [3 * pos[el.b] + j for j in range(3)]
        k[np.ix_(idx, idx)] += t.T @ kl @ t
        q_global = sec.rho_a * g
        q_local = t[:2, :2] @ q_global
        feq = _distributed_load_local(q_local, el.length)
        fixed_eq.append(feq)
        f[idx] += t.T @ feq

    def add_point_force(point: int, force: np.ndarray) -> None:
        f[3 * pos[point]: 3 * pos[point] + 2] += force

    for m in spec.masses:
        add_point_force(m.point, m.mass.si * g)
    for c in spec.crosspieces:
        arm_mass = spec.sections[c.section].rho_a * c.arm_length.si
        add_point_force(c.point, (2 * (arm_mass + c.tip_mass.si) + c.clamp_mass.si) * g)
    pinned: list[int] = []
    reaction_strings = []
    for s in spec.strings:
        if s.tension is None:
            pinned.append(s.point)
            reaction_strings.append(s)
        else:
            add_point_force(s.point, s.tension.si * np.asarray(s.direction))
    pinned += [sup.point for sup in spec.supports if sup.inplane in ("pinned", "clamped")]
    clamped = [sup.point for sup in spec.supports if sup.inplane == "clamped"]
    fixed = sorted({3 * pos[p] + j for p in pinned for j in (0, 1)} | {3 * pos[p] + 2 for p in clamped})
    free = np.setdiff1d(np.arange(ndof), fixed)
    if not fixed and np.any(f):
        raise ModelError(
            f"{spec.name}: nothing holds the structure in its plane: give a string with "
            "tension = \"reaction\" or a support with inplane = true"
        )
    kff = k[np.ix_(free, free)]
    u = np.zeros(ndof)
    sol = _solve_symmetric(kff, f[free])
    resid = np.linalg.norm(kff @ sol - f[free])
    if resid > 1e-6 * max(np.linalg.norm(f), 1.0):
        raise ModelError(
            f"{spec.name}: the in-plane gravity problem has no equilibrium "
            f"(residual {resid:.3g} N): the supports do not carry the weight"
        )
    u[free] = sol
    reactions = k @ u - f

    forces = []
    for el, feq in zip(mesh.elements, fixed_eq):
        sec = spec.sections[el.section]
        kl = _frame_local_stiffness(sec.ea, sec.ei_inplane, el.length)
        t = _rotation(el.direction)
        idx = [3 * pos[el.a] + j for j in range(3)] + [3 * pos[el.b] + j for j in range(3)]
        fe = kl @ (t @ u[idx]) - feq  # forces the nodes exert on the element, local axes
        forces.append(
            ElementForces(
                axial=(-fe[0], fe[3]),
                shear=(fe[1], -fe[4]),
                moment=(-fe[2], fe[5]),
            )
        )
    tensions = {}
    for s in spec.strings:
        if s.tension is None:
            r = reactions[3 * pos[s.point]: 3 * pos[s.point] + 2]
            # the string pulls the point towards its anchor: reaction force = T * direction
            tensions[s.id] = float(np.dot(r, s.direction))
            if tensions[s.id] <= 0.0:
                raise ModelError(
                    f"{spec.name}: string {s.id!r} would be in compression "
                    f"({tensions[s.id]:.3g} N): it cannot hold the structure"
                )
        else:
            tensions[s.id] = s.tension.si
    disp = {n: tuple(u[3 * pos[n]: 3 * pos[n] + 3]) for n in nodes}
    return GravityState(tuple(forces), tensions, disp)
