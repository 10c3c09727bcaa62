"""Assembly of the out-of-plane FE model of a structure from its spec.

The model is Eq. (3.1) of the dissertation without damping and control:
``m q'' + k q = U u`` with ``q`` the free out-of-plane DOFs (``w``, ``rx``,
``ry`` per node, as the spec activates them). Contents:

- grillage beam elements (bending + torsion, optional shear flexibility, rigid
  inserts) with the full out-of-plane geometric stiffness of the in-plane
  gravity pre-stress (axial force with Wagner term, in-plane shear and moment:
  :mod:`vlab.fe.geometric`, from :mod:`vlab.fe.statics`), Sec. 2.1.1 and 2.2.1;
- strings in tension to ground (Sec. 2.1.1);
- lumped masses and rotary inertias; grounded springs (the plates' W*Y,
  Sec. 2.2.1); the crosspiece as a single-DOF spring-mass (Sec. 2.1.1);
- supports removing DOFs.

An element's global matrices are memoised on its inputs (section, length,
pre-stress, inserts, direction; :func:`_element_matrices`), so a model that
differs from the last ones in a few elements is assembled from the rest.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from ..errors import ModelError
from ..spec import StructureSpec
from .dofmap import DofMap, Node
from .crosspiece import cantilever_tip_mass_sdof
from .elements import beam_matrices, local_to_global, rigid_offset
from .geometric import geometric_stiffness, polar_radius_sq
from .mesh import Mesh, build_mesh
from .size import check_model_size
from ..units import G_SI
from .statics import GravityState, solve_gravity



@dataclass(frozen=True)
class FEModel:
    """An assembled out-of-plane FE model, SI.

    Attributes
    ----------
    spec : StructureSpec
        The definition it was built from.
    m, k : ndarray, shape (n, n)
        Mass [kg, kg*m, kg*m^2] and stiffness [N/m, N, N*m/rad] matrices, symmetric.
    dofs : DofMap
        Labels of the n free DOFs.
    mesh : Mesh
        Nodes and elements.
    gravity : GravityState
        In-plane pre-stress used for the geometric stiffness.
    """

    spec: StructureSpec
    m: np.ndarray
    k: np.ndarray
    dofs: DofMap
    mesh: Mesh
    gravity: GravityState

    @property
    def n(self) -> int:
        """Number of free DOFs."""
        return self.m.shape[0]

    def force_input(self, points: list[int] | tuple[int, ...]) -> np.ndarray:
        """Load distribution matrix U of Eq. (3.1) for out-of-plane forces at ``points``.

        Parameters
        ----------
        points : list or tuple of int
            Point ids of the force inputs, in column order.

        Returns
        -------
        ndarray, shape (n, len(points))
            ``U[i, j] = 1`` where DOF ``i`` is ``w`` at ``points[j]``.

        Raises
        ------
        ModelError
            For an unknown point id or a point whose ``w`` is constrained.
        """
        u = np.zeros((self.n, len(points)))
        for j, p in enumerate(points):
            u[self.dofs.index(p, "w"), j] = 1.0
        return u


@functools.lru_cache(maxsize=4096)
def _element_matrices(ei: float, gj: float, rho_a: float, rho_ip: float, length: float, shear_stiffness,
                      axial: tuple, shear: tuple, moment: tuple, r2: float, offsets: tuple,
                      direction: tuple) -> tuple[np.ndarray, np.ndarray]:
    """Global stiffness (with the gravity geometric stiffness) and mass of one grillage element, 6x6
    each (read-only, memoised): DOFs ``w, rx, ry`` at ends a and b [SI]."""
    kl, ml = beam_matrices(ei=ei, gj=gj, rho_a=rho_a, rho_ip=rho_ip, length=length, shear_stiffness=shear_stiffness)
    kl = kl + geometric_stiffness(length=length, axial=axial, shear=shear, moment=moment, polar_radius_sq=r2)
    a1, a2 = offsets
    # a rigid insert of length a under axial force N: rotational geometric stiffness N a
    kl[1, 1] += axial[0] * a1
    kl[4, 4] += axial[1] * a2
    # The flexible part's matrices act on the element-end DOFs: carried to the
    # node DOFs across the inserts, then rotated. The inserts' own mass is
    # already on the node DOFs (:func:`_insert_mass`): rotated only, so that it
    # is not carried across the offset a second time.
    off = rigid_offset(a1, a2)
    rot = local_to_global(*direction)
    t = off @ rot
    ke = t.T @ kl @ t
    me = t.T @ ml @ t + rot.T @ _insert_mass(rho_a, rho_ip, a1, a2) @ rot
    ke.setflags(write=False)
    me.setflags(write=False)
    return ke, me


def check_bending_dofs(spec: StructureSpec) -> None:
    """Refuse a member whose bending rotation the structure's ``dofs`` leave out.

    A member along the in-plane unit vector ``e = (e_x, e_y)`` bends (slope
    dw/ds) about the in-plane axis ``(e_y, -e_x)``: about x (``rx``) for a
    member along y, about y (``ry``) for a member along x, about both for an
    oblique one. Without that rotation the element's nodes cannot turn and
    the beam is clamped at every node: its modes would be meaningless.

    Parameters
    ----------
    spec : StructureSpec

    Raises
    ------
    ModelError
        Naming the file, the member, its two points, the rotation it needs, the
        field ``structure.dofs`` and its value.

    Source: the beam element's DOFs (``w``, ``rx``, ``ry``; :mod:`vlab.fe.elements`).
    """
    active = spec.active_dofs
    for m in spec.members:
        for pa, pb in zip(m.points[:-1], m.points[1:]):
            (xa, ya), (xb, yb) = spec.points[pa], spec.points[pb]
            length = float(np.hypot(xb - xa, yb - ya))
            if length == 0.0:
                continue  # coincident points: refused by the mesh, with its own message
            need = [d for d, c in (("rx", (yb - ya) / length), ("ry", (xb - xa) / length)) if abs(c) > 1e-9]
            missing = [d for d in need if d not in active]
            if missing:
                way = "along y" if need == ["rx"] else "along x" if need == ["ry"] else "oblique"
                raise ModelError(
                    f"{spec._file()}: field 'structure.dofs': member {m.id!r} ({pa}-{pb}) runs {way}, so it bends "
                    f"with {' and '.join(repr(d) for d in need)}, which dofs = {list(active)} leave out; add "
                    f"{' and '.join(repr(d) for d in missing)} (dofs = {['w', *need]} is bending alone; a member "
                    f"along y bends with 'rx', one along x with 'ry', and the other rotation is its torsion)")


def build_fe_model(spec: StructureSpec) -> FEModel:
    """Assemble the FE model of ``spec``.

    Parameters
    ----------
    spec : StructureSpec
        The structure definition (SI).

    Returns
    -------
    FEModel

    Raises
    ------
    ModelError
        For a member whose bending rotation is not among the active DOFs
        (:func:`check_bending_dofs`), a support on an unknown DOF, a rigid insert longer than its element,
        a structure not held in its plane, or an assembled matrix that is not
        symmetric positive (semi)definite.
    ResourceError
        A model beyond :data:`vlab.fe.size.MAX_DOFS` degrees of freedom (:func:`vlab.fe.size.check_model_size`).
    """
    check_bending_dofs(spec)
    mesh = build_mesh(spec)
    check_model_size(spec, len(mesh.nodes))
    gravity = solve_gravity(spec, mesh)
    active = spec.active_dofs
    fixed = {(s.point, d) for s in spec.supports for d in s.fixed}
    for p, d in fixed:
        if d not in active:
            raise ModelError(f"{spec.name}: support at point {p} fixes inactive DOF {d!r}")
    labels: list[tuple[Node, str]] = []
    for node in mesh.nodes:
        for d in ("w", "rx", "ry"):
            if d in active and (node, d) not in fixed:
                labels.append((node, d))
    for c in spec.crosspieces:
        labels.append((c.id, "w"))
    dofs = DofMap(tuple(labels))
    n = len(dofs)
    m = np.zeros((n, n))
    k = np.zeros((n, n))

    def gidx(node: Node) -> list[int | None]:
        out: list[int | None] = []
        for d in ("w", "rx", "ry"):
            out.append(dofs.index(node, d) if (node, d) in dofs else None)
        return out

    def scatter(target: np.ndarray, local: np.ndarray, idx: list[int | None]) -> None:
        keep = np.array([i for i, g in enumerate(idx) if g is not None])
        g = np.array([idx[i] for i in keep])
        target[g[:, None], g[None, :]] += local[keep[:, None], keep[None, :]]

    for el, forces in zip(mesh.elements, gravity.element_forces):
        sec = spec.sections[el.section]
        ke, me = _element_matrices(
            sec.ei.si, sec.gj.si, sec.rho_a, sec.rho_ip, el.flexible_length,
            sec.shear_stiffness.si if sec.shear_stiffness else None,
            tuple(forces.axial), tuple(forces.shear), tuple(forces.moment),
            polar_radius_sq(sec.width.si, sec.thickness.si), tuple(el.offsets), tuple(el.direction))
        idx = gidx(el.a) + gidx(el.b)
        scatter(k, ke, idx)
        scatter(m, me, idx)

    for s in spec.strings:
        if (s.point, "w") not in dofs:
            continue  # the string ends on a support: its stiffness and mass go to ground
        i = dofs.index(s.point, "w")
        tension = gravity.string_tensions[s.id]
        k[i, i] += tension / s.length.si
        m[i, i] += s.rho_a.si * s.length.si / 3.0
    for lm in spec.masses:
        if (lm.point, "w") in dofs:
            m[dofs.index(lm.point, "w"), dofs.index(lm.point, "w")] += lm.mass.si
        for d, inertia in (("rx", lm.inertia_rx), ("ry", lm.inertia_ry)):
            if inertia is not None and (lm.point, d) in dofs:
                i = dofs.index(lm.point, d)
                m[i, i] += inertia.si
    for sp in spec.springs:
        i = dofs.index(sp.point, sp.dof)
        k[i, i] += sp.stiffness.si
    _add_crosspieces(spec, dofs, m, k)
    m = 0.5 * (m + m.T)
    k = 0.5 * (k + k.T)
    _check_definite(spec.name, dofs, m, k)
    return FEModel(spec, m, k, dofs, mesh, gravity)


def _add_crosspieces(spec: StructureSpec, dofs: DofMap, m: np.ndarray, k: np.ndarray) -> None:
    """Add each crosspiece's single-DOF equivalent (:func:`crosspiece_sdof`) and the gravity stiffness of its
    deflected arm mass to ``m`` and ``k`` (in place)."""
    for c in spec.crosspieces:
        kc, m_eff, m_rest = crosspiece_sdof(spec, c)
        i, j = dofs.index(c.point, "w"), dofs.index(c.id, "w")
        k[np.ix_([i, j], [i, j])] += kc * np.array([[1.0, -1.0], [-1.0, 1.0]])
        m[j, j] += m_eff
        m[i, i] += m_rest
        # Gravity on the arms' deflected mass: with the point rotated by (rx, ry)
        # the relative deflection d = w_j - w_i of the participating mass m_eff is
        # carried in the plane by (ry*d, -rx*d), so V = m_eff*g*d*(gy*rx - gx*ry)
        # (exact for the single-mode model: m_eff = gamma^2/mm, d = q*mm/gamma).
        # The MuJoCo plant's flexible arms have this from their kinematics; left
        # out, the close pair 3/4 of the BCC is 0.2 % apart from the plant's.
        gx, gy = spec.gravity_direction
        for d, coef in (("rx", gy), ("ry", -gx)):
            if coef != 0.0 and (c.point, d) in dofs:
                r = dofs.index(c.point, d)
                kg = m_eff * G_SI * coef
                k[np.ix_([r], [j, i])] += [[kg, -kg]]
                k[np.ix_([j, i], [r])] += [[kg], [-kg]]


def crosspiece_sdof(spec: StructureSpec, c) -> tuple[float, float, float]:
    """Single-DOF equivalent of a crosspiece (Sec. 2.1.1).

    Two cantilever arms of length L and rigidity EI with tip masses, each
    replaced by the spring-mass that is exact for base motion in the arm's
    first clamped mode (:func:`vlab.fe.crosspiece.cantilever_tip_mass_sdof`);
    the rest of the arm mass and the clamp mass ride with the attachment point.

    Parameters
    ----------
    spec : StructureSpec
        The structure; supplies the arms' section (EI [N*m^2], mass per
        length [kg/m]) named by ``c.section``.
    c : Crosspiece
        The crosspiece (arm length [m], tip mass [kg] per arm, clamp mass [kg]).

    Returns
    -------
    (k, m_eff, m_rest) : tuple of float
        Spring [N/m] and mass on it [kg] for both arms; mass at the point [kg].

    Raises
    ------
    KeyError
        If ``c.section`` is not a section of ``spec`` (a spec from
        :func:`vlab.spec.load_spec` has been checked for this).
    """
    sec = spec.sections[c.section]
    L = c.arm_length.si
    k1, m1, rest1 = cantilever_tip_mass_sdof(sec.ei.si, L, sec.rho_a * L, c.tip_mass.si)
    return 2.0 * k1, 2.0 * m1, 2.0 * rest1 + c.clamp_mass.si


def _insert_mass(rho_a: float, rho_ip: float, a1: float, a2: float) -> np.ndarray:
    """Mass of the beam over rigid inserts, as rigid bars on the nodes' (w, b).

    The insert at node 1 spans ``s = 0 .. a1`` from the node, so its deflection
    is ``w1 + s*b1``; the one at node 2 spans ``s = -a2 .. 0``, ``w2 + s*b2``.
    Integrating ``rho_a*(w + s*b)**2 / 2`` gives the (w, b) blocks; the
    insert twists with its node, adding ``rho_ip*a`` on the twist DOF.

    Parameters
    ----------
    rho_a : float
        Mass per length [kg/m].
    rho_ip : float
        Polar mass moment of inertia per length [kg*m].
    a1, a2 : float
        Insert lengths [m] at node 1 and node 2 (0 for none).

    Returns
    -------
    ndarray, shape (6, 6)
        Mass [kg, kg*m, kg*m^2] on the *node* local DOFs
        ``[w1, b1, t1, w2, b2, t2]`` (not the element-end DOFs of
        :func:`vlab.fe.elements.rigid_offset`): it must be rotated to global
        DOFs but not carried across the offset again.
    """
    ml = np.zeros((6, 6))
    for a, (iw, ib, it), sign in ((a1, (0, 1, 2), 1.0), (a2, (3, 4, 5), -1.0)):
        if a > 0.0:
            mass = rho_a * a
            ml[np.ix_([iw, ib], [iw, ib])] += mass * np.array(
                [[1.0, sign * a / 2.0], [sign * a / 2.0, a**2 / 3.0]]
            )
            ml[it, it] += rho_ip * a
    return ml


def _check_definite(name: str, dofs: DofMap, m: np.ndarray, k: np.ndarray) -> None:
    wm = np.linalg.eigvalsh(m)
    if wm.min() <= 1e-12 * max(wm.max(), 1e-300):
        i = int(np.argmin(np.abs(np.diag(m))))
        raise ModelError(
            f"{name}: mass matrix is singular (e.g. no mass on DOF {dofs.name(i)}): "
            "every free DOF needs inertia"
        )
    wk = np.linalg.eigvalsh(k)
    if wk.min() < -1e-9 * wk.max():
        raise ModelError(
            f"{name}: stiffness matrix is not positive semidefinite (min eigenvalue "
            f"{wk.min():.3g}): a member is in compression beyond buckling or a spring is negative"
        )
