"""The discretisation of a member into a hinge chain: how many links, where its hinges sit.

Each member segment of flexible length ``L_f`` gets ``n`` hinges
(:func:`auto_links` by default); hinge ``k`` sits at ``s_k L_f`` with the
compliance share ``c_k`` (:func:`hinge_layout`: Gauss-Legendre abscissae
and weights by default). :mod:`vlab.sim.builder` describes the chain's
stiffnesses and inertias, :mod:`vlab.sim.planner` places its bodies.

Source: Gauss-Legendre quadrature of the complementary energy (Abramowitz &
Stegun 25.4.29); the convergence study (README).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.linalg import eigh
from scipy.optimize import brentq

from ..errors import SimulationError

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


#: A crosspiece arm is a resonator of its own: a cantilever carrying a tip mass whose first bending
#: frequency may lie inside the structure's band (the BCC's 15-in arms: 8.62 Hz, between modes 3 and 4).
#: Its hinge chain must place that resonance within a tenth of the half-power half-bandwidth ``zeta f`` of
#: a lightly damped mode (a resonator detuned by ``0.1 zeta`` reads its peak receptance
#: ``1 / sqrt(1 + 0.1^2)``: within 0.5 %), with ``zeta`` = 0.001, the lightest damping ratio measured on
#: either laboratory structure (BCC mode 6, Table 1). A fixed number and not the spec's own ratios, so that
#: a damping change (a diagnosis's hypothesis, a ``[[mode_damping]]`` entry) never changes the plant's
#: joints or its time step. ARM_LINKS_MAX bounds the search; a tolerance not met by then takes
#: ARM_LINKS_MAX links.
ARM_FREQUENCY_TOL = 1e-4
ARM_LINKS_MAX = 16


def tip_mass_cantilever_omega(length: float, ei: float, rho_a: float, tip_mass: float) -> float:
    """First bending natural frequency [rad/s] of a uniform Euler-Bernoulli cantilever with a tip point mass.

    Parameters
    ----------
    length : float
        Cantilever length L [m], > 0.
    ei : float
        Bending stiffness EI [N m^2], > 0.
    rho_a : float
        Mass per length [kg/m], > 0.
    tip_mass : float
        Point mass at the free end [kg], >= 0 (no rotary inertia).

    Returns
    -------
    float
        ``lambda^2 sqrt(EI / (rho_a L^4))`` with ``lambda`` the first root of
        ``1 + cos(l) cosh(l) + mu l (cos(l) sinh(l) - sin(l) cosh(l)) = 0``, ``mu = tip_mass / (rho_a L)``.

    Raises
    ------
    SimulationError
        For a non-positive length, stiffness or mass per length, or a negative tip mass.

    Source: the frequency equation of a cantilever with a tip mass (Blevins, Formulas for Natural
    Frequency and Mode Shape, 1979, Ch. 8; mu = 0 gives lambda = 1.8751).
    """
    if not (length > 0 and ei > 0 and rho_a > 0 and tip_mass >= 0):
        raise SimulationError(f"cantilever: length {length!r} m, EI {ei!r} N*m^2 and mass per length {rho_a!r} kg/m "
                              f"must be > 0 and the tip mass {tip_mass!r} kg >= 0")
    mu = tip_mass / (rho_a * length)

    def residual(lam: float) -> float:
        return (1.0 + math.cos(lam) * math.cosh(lam)
                + mu * lam * (math.cos(lam) * math.sinh(lam) - math.sin(lam) * math.cosh(lam)))

    lam = brentq(residual, 1e-6, 1.9)  # one root below 1.9: 1.8751 at mu = 0, falling towards 0 as mu grows
    return lam ** 2 * math.sqrt(ei / (rho_a * length ** 4))


def hinge_chain_cantilever_omega(n: int, length: float, ei: float, rho_a: float, tip_mass: float,
                                 layout: str = "gauss") -> float:
    """First natural frequency [rad/s] of the plant's hinge chain of a cantilever with a tip mass.

    The chain as the planner builds a crosspiece arm: a rigid root piece, ``n`` rigid links joined by
    hinges at :func:`hinge_layout`'s positions with stiffness ``EI / (c_k L)``, the mass distributed
    along the links (rotary inertia of the thin links left out, as in the closed form), the point mass
    at the tip. Small-rotation Lagrangian: ``w(s) = sum_k theta_k (s - s_k)`` for ``s > s_k``.

    Parameters
    ----------
    n : int
        Hinges, >= 1.
    length, ei, rho_a, tip_mass : float
        As :func:`tip_mass_cantilever_omega`.
    layout : {"gauss", "uniform"}
        Hinge layout.

    Returns
    -------
    float
        Lowest natural frequency of the chain [rad/s].

    Raises
    ------
    SimulationError
        As :func:`hinge_layout`.
    """
    frac, share = hinge_layout(n, layout)
    s_k = frac * length
    gx, gw = np.polynomial.legendre.leggauss(8)  # exact: the integrand is quadratic on each piece
    mass = tip_mass * np.outer(length - s_k, length - s_k)
    edges = np.concatenate([[0.0], s_k, [length]])
    for a, b in zip(edges[:-1], edges[1:]):
        s = a + 0.5 * (b - a) * (gx + 1.0)
        phi = np.clip(s[None, :] - s_k[:, None], 0.0, None)
        mass += rho_a * (phi * (0.5 * (b - a) * gw)) @ phi.T
    stiff = np.diag(ei / (share * length))
    return float(math.sqrt(eigh(stiff, mass, eigvals_only=True, subset_by_index=[0, 0])[0]))


def arm_links(length: float, ei: float, rho_a: float, tip_mass: float, tolerance: float,
              layout: str = "gauss") -> int:
    """Fewest hinges (at least MIN_LINKS) that place a tip-loaded arm's first bending frequency within ``tolerance``.

    Parameters
    ----------
    length, ei, rho_a, tip_mass : float
        As :func:`tip_mass_cantilever_omega`.
    tolerance : float
        Largest relative frequency error of the chain [-], > 0 (the planner passes
        :data:`ARM_FREQUENCY_TOL`).
    layout : {"gauss", "uniform"}
        Hinge layout.

    Returns
    -------
    int
        The smallest ``n`` in ``MIN_LINKS .. ARM_LINKS_MAX`` with
        ``|omega_chain(n) / omega_exact - 1| <= tolerance``; ARM_LINKS_MAX if none.

    Raises
    ------
    SimulationError
        For a tolerance that is not positive, and as :func:`tip_mass_cantilever_omega`.
    """
    if not tolerance > 0:
        raise SimulationError(f"arm frequency tolerance must be > 0, got {tolerance!r}")
    exact = tip_mass_cantilever_omega(length, ei, rho_a, tip_mass)
    for n in range(MIN_LINKS, ARM_LINKS_MAX + 1):
        if abs(hinge_chain_cantilever_omega(n, length, ei, rho_a, tip_mass, layout) / exact - 1.0) <= tolerance:
            return n
    return ARM_LINKS_MAX
