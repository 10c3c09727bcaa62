"""The crosspiece of the BCC as a single-DOF spring-mass (Sec. 2.1.1).

The dissertation models the crosspiece -- two aluminium cantilever arms with
tip masses, clamped to the beam -- as one spring-mass. vlab makes that model
exact for base excitation in the first clamped mode of the arms.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.integrate
import scipy.optimize


def cantilever_tip_mass_sdof(ei: float, length: float, arm_mass: float, tip_mass: float
                             ) -> tuple[float, float, float]:
    """Single-DOF model of a cantilever with a tip mass that is exact for base excitation.

    The first clamped mode (frequency ``omega_1`` from
    ``1 + cos b cosh b + (M/m) b (cos b sinh b - sin b cosh b) = 0``) with its
    effective modal mass for base motion ``m_1 = (int rho phi + M phi_L)^2 /
    (int rho phi^2 + M phi_L^2)``: spring ``k = omega_1^2 m_1`` carrying ``m_1``,
    the rest of the mass rigid with the base.

    Parameters
    ----------
    ei : float
        Flexural rigidity [N m^2].
    length : float
        Arm length [m].
    arm_mass : float
        Arm mass [kg].
    tip_mass : float
        Tip mass [kg].

    Returns
    -------
    k : float
        Spring [N/m].
    m_eff : float
        Mass on the spring [kg].
    m_rest : float
        Mass rigid with the base [kg].

    Source: Blevins, *Formulas for Natural Frequency and Mode Shape* (1979),
    Table 8-1 (cantilever with tip mass); effective modal mass, e.g. Chopra,
    *Dynamics of Structures*, Sec. 13.1.
    """
    m, M = arm_mass, tip_mass
    ratio = M / m

    def f(b):
        return 1 + math.cos(b) * math.cosh(b) + ratio * b * (math.cos(b) * math.sinh(b) - math.sin(b) * math.cosh(b))

    b = scipy.optimize.brentq(f, 1e-3, 1.8751041)
    omega = b**2 * math.sqrt(ei * length / (m * length**4))
    x = np.linspace(0.0, 1.0, 4001)
    s = (math.cosh(b) + math.cos(b)) / (math.sinh(b) + math.sin(b))  # phi''(L) = 0 (no tip moment)
    phi = (np.cosh(b * x) - np.cos(b * x)) - s * (np.sinh(b * x) - np.sin(b * x))
    phi = phi / phi[-1]
    gamma = m * scipy.integrate.trapezoid(phi, x) + M
    mm = m * scipy.integrate.trapezoid(phi**2, x) + M
    m1 = gamma**2 / mm
    return omega**2 * m1, m1, m + M - m1
