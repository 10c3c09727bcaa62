"""Element matrices for out-of-plane (grillage) models of plane frames.

Every member lies in the structure's plane (x, y). Each node carries the
out-of-plane translation ``w`` [m] and the two in-plane rotations ``rx``,
``ry`` [rad]. In a member's local frame (unit axis ``e = (ex, ey)``) the
element DOFs are ordered

    ``[w1, b1, t1, w2, b2, t2]``

with ``b = dw/ds = ey*rx - ex*ry`` the bending slope along the member and
``t = ex*rx + ey*ry`` the twist about it (from ``u = theta x r`` for small
rotations). :func:`local_to_global` returns the matrix that maps the global
node DOFs ``[w1, rx1, ry1, w2, rx2, ry2]`` to these local ones.

Sources: bending with Euler-Bernoulli cubic shape functions and torsion with
linear shape functions, as Sec. 2.2.1 of the dissertation states ("Ref. 53",
Przemieniecki, *Theory of Matrix Structural Analysis*, 1968); shear-flexible
bending (Timoshenko stiffness, Przemieniecki Sec. 5.6) for the grid's top
beam; geometric stiffness from a linearly varying axial force by exact
Gauss quadrature of the cubic slopes (Ref. 54 of the dissertation; Cook et
al., *Concepts and Applications of FEA*, Sec. 18.2).
"""

from __future__ import annotations

import numpy as np

from ..errors import ModelError

# 3-point Gauss-Legendre rule on [0, 1]: exact to degree 5 (slope^2 * linear N).
_GAUSS_X = 0.5 + 0.5 * np.array([-np.sqrt(3.0 / 5.0), 0.0, np.sqrt(3.0 / 5.0)])
_GAUSS_W = 0.5 * np.array([5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0])


def _check_positive(name: str, value: float) -> None:
    if not np.isfinite(value) or value <= 0.0:
        raise ModelError(f"{name} must be a positive finite number, got {value!r}")


def bending_stiffness(ei: float, length: float, shear_stiffness: float | None = None) -> np.ndarray:
    """Stiffness of a beam in out-of-plane bending.

    Parameters
    ----------
    ei : float
        Flexural rigidity EI [N*m^2].
    length : float
        Element length L [m].
    shear_stiffness : float, optional
        Shear rigidity kGA [N]. ``None`` gives Euler-Bernoulli; a value gives the
        shear-flexible (Timoshenko) stiffness with ``phi = 12 EI / (kGA L^2)``.

    Returns
    -------
    ndarray, shape (4, 4)
        Stiffness for DOFs ``[w1, b1, w2, b2]`` [N/m, N, N*m/rad].

    Raises
    ------
    ModelError
        If a parameter is not positive.

    Source: Przemieniecki (1968) Eq. (5.116) (Ref. 53 of the dissertation);
    shear flexibility per Sec. 2.2.1.
    """
    _check_positive("EI", ei)
    _check_positive("element length", length)
    phi = 0.0
    if shear_stiffness is not None:
        _check_positive("shear stiffness kGA", shear_stiffness)
        phi = 12.0 * ei / (shear_stiffness * length**2)
    L = length
    c = ei / (L**3 * (1.0 + phi))
    return c * np.array(
        [
            [12.0, 6.0 * L, -12.0, 6.0 * L],
            [6.0 * L, (4.0 + phi) * L**2, -6.0 * L, (2.0 - phi) * L**2],
            [-12.0, -6.0 * L, 12.0, -6.0 * L],
            [6.0 * L, (2.0 - phi) * L**2, -6.0 * L, (4.0 + phi) * L**2],
        ]
    )


def bending_mass(rho_a: float, length: float) -> np.ndarray:
    """Consistent mass of a beam in out-of-plane bending.

    Parameters
    ----------
    rho_a : float
        Mass per unit length [kg/m].
    length : float
        Element length [m].

    Returns
    -------
    ndarray, shape (4, 4)
        Mass for DOFs ``[w1, b1, w2, b2]`` [kg, kg*m, kg*m^2].

    Source: Przemieniecki (1968) Eq. (11.42), cubic Hermite shape functions.
    """
    _check_positive("mass per length", rho_a)
    _check_positive("element length", length)
    L = length
    return rho_a * L / 420.0 * np.array(
        [
            [156.0, 22.0 * L, 54.0, -13.0 * L],
            [22.0 * L, 4.0 * L**2, 13.0 * L, -3.0 * L**2],
            [54.0, 13.0 * L, 156.0, -22.0 * L],
            [-13.0 * L, -3.0 * L**2, -22.0 * L, 4.0 * L**2],
        ]
    )


def torsion_stiffness(gj: float, length: float) -> np.ndarray:
    """St-Venant torsion stiffness ``GJ/L [[1, -1], [-1, 1]]``, shape (2, 2) [N*m/rad].

    Parameters
    ----------
    gj : float
        Torsional rigidity GJ [N*m^2].
    length : float
        Element length L [m].

    Returns
    -------
    ndarray, shape (2, 2)
        Stiffness for the twist DOFs ``[t1, t2]`` [N*m/rad].

    Raises
    ------
    ModelError
        If ``gj`` or ``length`` is not a positive finite number.

    Source: linear shape functions, Sec. 2.2.1 (Ref. 53, Przemieniecki 1968).
    """
    _check_positive("GJ", gj)
    _check_positive("element length", length)
    return gj / length * np.array([[1.0, -1.0], [-1.0, 1.0]])


def torsion_mass(rho_ip: float, length: float) -> np.ndarray:
    """Consistent torsional inertia ``rho*Ip*L/6 [[2, 1], [1, 2]]``, shape (2, 2) [kg*m^2].

    Parameters
    ----------
    rho_ip : float
        Polar mass moment of inertia per unit length rho*Ip [kg*m].
    length : float
        Element length L [m].

    Returns
    -------
    ndarray, shape (2, 2)
        Inertia for the twist DOFs ``[t1, t2]`` [kg*m^2].

    Raises
    ------
    ModelError
        If ``rho_ip`` or ``length`` is not a positive finite number.

    Source: consistent mass of the linear shape functions of :func:`torsion_stiffness`.
    """
    _check_positive("polar inertia per length", rho_ip)
    _check_positive("element length", length)
    return rho_ip * length / 6.0 * np.array([[2.0, 1.0], [1.0, 2.0]])


def hermite_slopes(xi: float, length: float) -> np.ndarray:
    """dw/ds of the cubic Hermite shape functions on ``[w1, b1, w2, b2]`` at ``s = xi L``.

    Parameters
    ----------
    xi : float
        Position along the element as a fraction of its length, in [0, 1].
    length : float
        Element length ``L`` [m].

    Returns
    -------
    ndarray, shape (4,)
        Slopes [1/m on ``w1``, ``w2``; 1 on ``b1``, ``b2``].
    """
    L = length
    return np.array(
        [
            (-6.0 * xi + 6.0 * xi**2) / L,
            1.0 - 4.0 * xi + 3.0 * xi**2,
            (6.0 * xi - 6.0 * xi**2) / L,
            -2.0 * xi + 3.0 * xi**2,
        ]
    )


def axial_geometric_stiffness(n1: float, n2: float, length: float) -> np.ndarray:
    """Geometric stiffness of out-of-plane bending from an axial force.

    ``Kg = integral_0^L N(s) dN_w/ds^T dN_w/ds ds`` with the axial force varying
    linearly from ``n1`` at node 1 to ``n2`` at node 2 (tension positive), as
    in a hanging member loaded by its own weight. For ``n1 == n2 = N`` this is
    the classical ``N/(30L) [[36, 3L, -36, 3L], ...]``.

    Parameters
    ----------
    n1, n2 : float
        Axial force at the two ends [N], tension positive.
    length : float
        Element length [m].

    Returns
    -------
    ndarray, shape (4, 4)
        For DOFs ``[w1, b1, w2, b2]``.

    Raises
    ------
    ModelError
        If the length is not positive.

    Source: Ref. 54 of the dissertation; Cook et al. (2002) Eq. (18.2-6).
    """
    _check_positive("element length", length)
    kg = np.zeros((4, 4))
    for xi, wt in zip(_GAUSS_X, _GAUSS_W):
        g = hermite_slopes(xi, length)
        force = n1 + (n2 - n1) * xi
        kg += wt * length * force * np.outer(g, g)
    return kg


def string_matrices(tension: float, length: float, rho_a: float) -> tuple[np.ndarray, np.ndarray]:
    """String-in-tension element between two out-of-plane translations.

    Parameters
    ----------
    tension : float
        String tension T [N].
    length : float
        String length L [m].
    rho_a : float
        Mass per unit length [kg/m] (0 allowed: a massless string).

    Returns
    -------
    k, m : ndarray, shape (2, 2)
        ``k = T/L [[1, -1], [-1, 1]]`` [N/m]; ``m = rho*A*L/6 [[2, 1], [1, 2]]`` [kg].

    Raises
    ------
    ModelError
        If tension or length is not positive or ``rho_a`` is negative.

    Source: linear shape functions for a taut string (Sec. 2.1.1: "two
    string-in-tension elements for the four cables").
    """
    _check_positive("string tension", tension)
    _check_positive("string length", length)
    if not np.isfinite(rho_a) or rho_a < 0.0:
        raise ModelError(f"string mass per length must be >= 0, got {rho_a!r}")
    k = tension / length * np.array([[1.0, -1.0], [-1.0, 1.0]])
    m = rho_a * length / 6.0 * np.array([[2.0, 1.0], [1.0, 2.0]])
    return k, m


def local_to_global(ex: float, ey: float) -> np.ndarray:
    """Map global node DOFs to the local DOFs of a member along ``(ex, ey)``.

    Parameters
    ----------
    ex, ey : float
        Components of the member's unit axis ``e`` in the plane (x, y) [-],
        from node 1 to node 2.

    Returns
    -------
    ndarray, shape (6, 6)
        ``T`` with ``[w1, b1, t1, w2, b2, t2] = T @ [w1, rx1, ry1, w2, rx2, ry2]``;
        ``b = ey*rx - ex*ry`` (bending slope), ``t = ex*rx + ey*ry`` (twist).
    """
    r = np.array([[1.0, 0.0, 0.0], [0.0, ey, -ex], [0.0, ex, ey]])
    t = np.zeros((6, 6))
    t[:3, :3] = r
    t[3:, 3:] = r
    return t


def rigid_offset(offset1: float, offset2: float) -> np.ndarray:
    """Map node local DOFs to element-end local DOFs across rigid inserts.

    A rigid insert of length ``a1`` at node 1 (and ``a2`` at node 2) joins the
    node to the flexible part of the member: ``w_end1 = w1 + a1*b1`` and
    ``w_end2 = w2 - a2*b2``; slopes and twists are unchanged.

    Parameters
    ----------
    offset1 : float
        Length ``a1`` of the rigid insert at node 1 [m] (0 for none).
    offset2 : float
        Length ``a2`` of the rigid insert at node 2 [m] (0 for none).

    Returns
    -------
    ndarray, shape (6, 6)
        Acting on ``[w1, b1, t1, w2, b2, t2]``.

    Source: Sec. 2.1.1 ("two one inch rigid inserts").
    """
    t = np.eye(6)
    t[0, 1] = offset1
    t[3, 4] = -offset2
    return t


def beam_matrices(
    *,
    ei: float,
    gj: float,
    rho_a: float,
    rho_ip: float,
    length: float,
    shear_stiffness: float | None = None,
    axial_force: tuple[float, float] = (0.0, 0.0),
) -> tuple[np.ndarray, np.ndarray]:
    """Stiffness and mass of a grillage beam element in local DOFs.

    Parameters
    ----------
    ei, gj : float
        Out-of-plane flexural rigidity and torsional rigidity [N*m^2].
    rho_a : float
        Mass per length [kg/m].
    rho_ip : float
        Polar mass moment of inertia per length [kg*m].
    length : float
        Flexible length [m].
    shear_stiffness : float, optional
        kGA [N] for a shear-flexible member.
    axial_force : (float, float)
        Axial force at the two ends [N], tension positive (geometric stiffness).

    Returns
    -------
    k, m : ndarray, shape (6, 6)
        For local DOFs ``[w1, b1, t1, w2, b2, t2]``.

    Raises
    ------
    ModelError
        If a rigidity, inertia or length is not positive.
    """
    kb = bending_stiffness(ei, length, shear_stiffness) + axial_geometric_stiffness(*axial_force, length)
    mb = bending_mass(rho_a, length)
    kt = torsion_stiffness(gj, length)
    mt = torsion_mass(rho_ip, length)
    ib = [0, 1, 3, 4]
    it = [2, 5]
    k = np.zeros((6, 6))
    m = np.zeros((6, 6))
    k[np.ix_(ib, ib)] = kb
    m[np.ix_(ib, ib)] = mb
    k[np.ix_(it, it)] = kt
    m[np.ix_(it, it)] = mt
    return k, m
