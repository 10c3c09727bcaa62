"""Out-of-plane geometric stiffness of a thin member from its in-plane pre-stress.

Sec. 2.2.1 of the dissertation: "Gravity-induced in-plane forces, shear
forces, and bending moments have significant influence on the out-of-plane
stiffnesses of the thin aluminum grid members. This influence is represented
by element geometric stiffness matrices (Ref. 54)." This module gives that
matrix for a member of a plane frame whose in-plane pre-stress (axial force
``N``, in-plane shear ``V`` and in-plane, i.e. strong-axis, bending moment
``M``) comes from :func:`vlab.fe.statics.solve_gravity`.

Derivation (the second-order strain energy of the initial stresses, as in
Yang & McGuire, *J. Struct. Eng.* 112(4), 1986; Trahair, *Flexural-Torsional
Buckling of Structures*, 1993, Ch. 3 and 6; Chen & Lui, *Structural
Stability*, 1987, Ch. 5). In the member's local frame -- ``x`` along the
member, ``y = e_z x e_x`` in the plane, ``z`` out of the plane -- a doubly
symmetric section (centroid = shear centre) with out-of-plane deflection
``w(x)`` and twist ``phi(x)`` rotates by the vector ``theta = (phi, -w', 0)``;
its points at ``r = (0, y, z)`` move by ``u = theta x r + 1/2 theta x (theta
x r)`` to second order (the rigid joints rotate the same way, so the field is
compatible at the joints). With the initial stresses
``sigma_xx = N/A + M y / I_z`` and ``tau_xy`` (resultant ``V``) the second-order
energy ``integral sigma_0 : (eps_NL(u_1) + eps_L(u_2)) dV`` is

    U_G = 1/2 integral_0^L [ N w'^2 + N r0^2 phi'^2
                             + M (w' phi' - w'' phi) + V w' phi ] dx

where ``r0^2 = (I_y + I_z)/A`` (the Wagner term of the axial force; for a
rectangle ``(b^2 + t^2)/12``), ``M = integral sigma_xx y dA`` and
``V = integral tau_xy dA`` on the face whose outward normal is ``+x``, so that
``dM/dx = V``. Integrating by parts, the moment and shear terms equal
``-integral M w'' phi`` plus the end terms ``1/2 [M w' phi]``: in the interior
of a member this is the familiar lateral-torsional buckling term (Trahair
Eq. 6.6); the end terms are the second-order rotation of the joints
("semitangential" end moments, Yang & McGuire 1986). With them the
second-order energy of a rigid swing of a frame hanging from a horizontal
axis equals its exact gravity energy (``tests/test_geometric.py``); without
them it does not. The term ``N (I_y/A) w''^2`` is neglected (``t^2/12``
against ``L^2``).

Interpolation: ``w`` cubic Hermite and ``phi`` linear (the element's own
shape functions, Sec. 2.2.1); ``N`` and ``V`` vary linearly and ``M``
quadratically along the element (uniform self-weight), so a 3-point Gauss
rule integrates every term exactly.

Sign convention of the inputs: :class:`vlab.fe.statics.ElementForces`, i.e.
axial force tension positive; in-plane moment and shear in the beam
convention of that class (sagging positive with ``y`` up, ``dM/ds = V``),
which are the negatives of ``M`` and ``V`` above.
"""

from __future__ import annotations

import numpy as np

from ..errors import ModelError
from .elements import hermite_slopes

# 3-point Gauss-Legendre rule on [0, 1]: exact to degree 5.
_GAUSS_X = 0.5 + 0.5 * np.array([-np.sqrt(3.0 / 5.0), 0.0, np.sqrt(3.0 / 5.0)])
_GAUSS_W = 0.5 * np.array([5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0])

#: Positions of w/b (bending) and t (twist) in the local DOF vector
#: ``[w1, b1, t1, w2, b2, t2]`` of :mod:`vlab.fe.elements`.
_BEND = (0, 1, 3, 4)
_TWIST = (2, 5)


def polar_radius_sq(width: float, thickness: float) -> float:
    """Squared polar radius of gyration ``r0^2 = (I_y + I_z)/A`` of a rectangle.

    Parameters
    ----------
    width, thickness : float
        In-plane width ``b`` and out-of-plane thickness ``t`` [m].

    Returns
    -------
    float
        ``(b^2 + t^2)/12`` [m^2].

    Raises
    ------
    ModelError
        If a dimension is not positive.

    Source: Trahair (1993) Eq. (3.37) (Wagner term ``N r0^2 phi'^2``).
    """
    for name, v in (("section width", width), ("section thickness", thickness)):
        if not np.isfinite(v) or v <= 0.0:
            raise ModelError(f"{name} must be a positive finite number, got {v!r}")
    return (width**2 + thickness**2) / 12.0


def _curvatures(xi: float, length: float) -> np.ndarray:
    """d2w/ds2 of the cubic Hermite functions at ``s = xi L`` on ``[w1, b1, w2, b2]``."""
    L = length
    return np.array(
        [
            (-6.0 + 12.0 * xi) / L**2,
            (-4.0 + 6.0 * xi) / L,
            (6.0 - 12.0 * xi) / L**2,
            (-2.0 + 6.0 * xi) / L,
        ]
    )


def geometric_stiffness(
    *,
    length: float,
    axial: tuple[float, float],
    shear: tuple[float, float] = (0.0, 0.0),
    moment: tuple[float, float] = (0.0, 0.0),
    polar_radius_sq: float = 0.0,
) -> np.ndarray:
    """Geometric stiffness of a thin plane-frame member for out-of-plane motion.

    Parameters
    ----------
    length : float
        Element length ``L`` [m] (the flexible length between rigid inserts).
    axial : (float, float)
        Axial force at ends a and b [N], tension positive; linear in between.
    shear : (float, float)
        In-plane shear force at ends a and b [N], beam convention of
        :class:`vlab.fe.statics.ElementForces`; linear in between.
    moment : (float, float)
        In-plane (strong-axis) bending moment at ends a and b [N*m], beam
        convention of :class:`vlab.fe.statics.ElementForces` (sagging positive,
        ``dM/ds = V``). Between the ends ``M`` is the quadratic with these end
        values and ``d^2M/ds^2 = (V_b - V_a)/L`` (uniform distributed load).
    polar_radius_sq : float
        ``r0^2 = (I_y + I_z)/A`` [m^2] for the Wagner term ``N r0^2 phi'^2``; 0
        leaves it out.

    Returns
    -------
    ndarray, shape (6, 6)
        Symmetric matrix for the local DOFs ``[w1, b1, t1, w2, b2, t2]``
        (deflection [m], bending slope and twist [rad]) of
        :mod:`vlab.fe.elements`; units N/m, N, N*m/rad. It is added to the
        elastic stiffness: tension stiffens, compression softens, and the
        moment couples out-of-plane bending with twist.

    Raises
    ------
    ModelError
        If the length is not positive, a force is not finite, or
        ``polar_radius_sq`` is negative.

    Notes
    -----
    ``K_G = integral_0^L [N g g^T + N r0^2 h' h'^T
    + M/2 (g h'^T + h' g^T - c h^T - h c^T) + V/2 (g h^T + h g^T)] ds`` with
    ``g`` and ``c`` the slopes and curvatures of the Hermite functions, ``h``
    the linear twist functions and ``M``, ``V`` in the sign convention of the
    module docstring (the negatives of the inputs). For ``shear = moment = 0`` and
    ``polar_radius_sq = 0`` the result equals
    :func:`vlab.fe.elements.axial_geometric_stiffness`.

    Sources: Yang & McGuire (1986); Trahair (1993) Eq. (6.6); Chen & Lui
    (1987) Sec. 5.6; Ref. 54 of the dissertation.
    """
    if not np.isfinite(length) or length <= 0.0:
        raise ModelError(f"element length must be a positive finite number, got {length!r}")
    vals = (*axial, *shear, *moment, polar_radius_sq)
    if not all(np.isfinite(v) for v in vals):
        raise ModelError(f"pre-stress must be finite, got axial={axial}, shear={shear}, moment={moment}")
    if polar_radius_sq < 0.0:
        raise ModelError(f"polar_radius_sq must be >= 0, got {polar_radius_sq!r}")
    L = length
    n1, n2 = axial
    # convert the beam convention of ElementForces to M = int sigma y dA, V = int tau dA
    v1, v2 = -shear[0], -shear[1]
    m1, m2 = -moment[0], -moment[1]
    # M(xi) = m1 + (m2 - m1) xi + c xi (xi - 1) with M'' = (v2 - v1)/L  ->  c = (v2 - v1) L / 2
    curv = 0.5 * (v2 - v1) * L
    hp = np.array([-1.0 / L, 1.0 / L])  # d(phi)/ds on [t1, t2]
    kbb = np.zeros((4, 4))
    kbt = np.zeros((4, 2))
    ktt = polar_radius_sq * 0.5 * (n1 + n2) * L * np.outer(hp, hp)
    for xi, wt in zip(_GAUSS_X, _GAUSS_W):
        g = hermite_slopes(xi, L)
        c = _curvatures(xi, L)
        h = np.array([1.0 - xi, xi])
        n = n1 + (n2 - n1) * xi
        v = v1 + (v2 - v1) * xi
        m = m1 + (m2 - m1) * xi + curv * xi * (xi - 1.0)
        kbb += wt * L * n * np.outer(g, g)
        # 1/2 [M (w' phi' - w'' phi) + V w' phi] -> half of each product in each off-diagonal block
        kbt += wt * L * 0.5 * (m * (np.outer(g, hp) - np.outer(c, h)) + v * np.outer(g, h))
    kg = np.zeros((6, 6))
    kg[np.ix_(_BEND, _BEND)] = kbb
    kg[np.ix_(_BEND, _TWIST)] = kbt
    kg[np.ix_(_TWIST, _BEND)] = kbt.T
    kg[np.ix_(_TWIST, _TWIST)] = ktt
    return kg
