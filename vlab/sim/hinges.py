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
