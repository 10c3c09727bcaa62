"""MuJoCo hinge chains against closed forms (vlab.sim.builder, vlab.sim.linearize).

* Cantilever, Euler-Bernoulli: ``f_n = (beta_n L)^2 / (2 pi L^2) sqrt(EI / rho A)``
  with ``beta_n L = 1.8751, 4.6941, 7.8548`` (Blevins 1979, Table 8-1).
* Hanging chain (uniform, pinned at the top, no bending stiffness):
  ``omega_n = (z_n / 2) sqrt(g / L)``, ``z_n`` the zeros of ``J_0``
  (Bernoulli/Euler; e.g. Meirovitch, *Analytical Methods in Vibrations*, Sec. 5.9).
* Static flexibility of the Gauss hinge layout (:func:`vlab.sim.hinge_layout`).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.special

from vlab.errors import SimulationError
from vlab.sim import SimOptions, build_plant, hinge_layout, modes
from vlab.spec import spec_from_dict
from vlab.units import G_SI


def q(value, unit):
    return {"value": value, "unit": unit, "source": "test"}


def cantilever_spec(n_points: int = 5, length: float = 0.5):
    pts = {str(i + 1): [length * i / (n_points - 1), 0.0] for i in range(n_points)}
    return spec_from_dict({
        "structure": {"name": "cantilever", "title": "steel strip", "source": "test", "dofs": ["w", "ry"],
                      "gravity": [0.0, -1.0]},
        "points": {"unit": "m", "source": "test", "coordinates": pts},
        "sections": {"bar": {"width": q(0.05, "m"), "thickness": q(0.005, "m"), "density": q(7800.0, "kg/m^3"),
                             "modulus": q(2e11, "Pa"), "shear_modulus": q(8e10, "Pa")}},
        "members": [{"id": "bar", "points": list(range(1, n_points + 1)), "section": "bar"}],
        "supports": [{"point": 1, "fixed": ["w", "ry"], "inplane": "clamped"}],
    })


def chain_spec(n_points: int = 21, length: float = 1.0):
    pts = {str(i + 1): [0.0, length * (1 - i / (n_points - 1))] for i in range(n_points)}
    return spec_from_dict({
        "structure": {"name": "chain", "title": "hanging chain", "source": "test", "dofs": ["w", "rx"],
                      "gravity": [0.0, -1.0]},
        "points": {"unit": "m", "source": "test", "coordinates": pts},
        "sections": {"c": {"width": q(0.01, "m"), "thickness": q(0.001, "m"), "density": q(1000.0, "kg/m^3"),
                           "modulus": q(2e11, "Pa"), "shear_modulus": q(8e10, "Pa"), "ei": q(1e-7, "N*m^2")}},
        "members": [{"id": "chain", "points": list(range(1, n_points + 1)), "section": "c"}],
        "supports": [{"point": 1, "fixed": ["w"], "inplane": "pinned"}],
    })


def test_cantilever_matches_euler_bernoulli():
    spec = cantilever_spec()
    sec = spec.sections["bar"]
    beta_l = np.array([1.87510407, 4.69409113, 7.85475744])
    exact = beta_l**2 / (2 * math.pi * 0.5**2) * math.sqrt(sec.ei.si / sec.rho_a)
    plant = build_plant(spec, SimOptions(segments_per_element=2))
    f = modes(plant.model, sorted(spec.points), 3).frequencies_hz
    err = np.abs(f / exact - 1)
    assert err[0] < 0.001 and err[1] < 0.003 and err[2] < 0.01, 100 * (f / exact - 1)


def test_cantilever_converges_with_links():
    spec = cantilever_spec()
    sec = spec.sections["bar"]
    exact = 4.69409113**2 / (2 * math.pi * 0.25) * math.sqrt(sec.ei.si / sec.rho_a)
    errs = [abs(modes(build_plant(spec, SimOptions(segments_per_element=n)).model, [5], 2).frequencies_hz[1]
                / exact - 1) for n in (1, 2, 3)]
    assert errs[0] > errs[1] > errs[2]


def test_hanging_chain_matches_bessel_zeros():
    spec = chain_spec()
    z = scipy.special.jn_zeros(0, 3)
    exact = z / 2 * math.sqrt(G_SI / 1.0) / (2 * math.pi)
    plant = build_plant(spec, SimOptions(segments_per_element=2))
    f = modes(plant.model, sorted(spec.points), 3).frequencies_hz
    np.testing.assert_allclose(f, exact, rtol=0.005)


def test_hanging_chain_stiffness_comes_from_gravity():
    """Without gravity the chain (EI ~ 0) has no stiffness left: all its modes drop to ~0 Hz."""
    spec = chain_spec(n_points=6)
    plant = build_plant(spec, SimOptions(segments_per_element=1, gravity=False))
    f = modes(plant.model, sorted(spec.points), 2).frequencies_hz
    assert np.all(f < 0.05)


@pytest.mark.parametrize("n", [2, 3, 4])
def test_gauss_layout_static_flexibility_is_exact(n):
    """Chain of n hinges, compliances c_k L/EI at s_k: tip deflection under a tip load = L^3/(3EI)."""
    s, c = hinge_layout(n, "gauss")
    assert math.isclose(c.sum(), 1.0)
    tip = np.sum(c * (1 - s) ** 2)  # (M = P (L - s)) * lever (L - s), L = EI = P = 1
    assert math.isclose(tip, 1 / 3, rel_tol=1e-12)
    sway = np.sum(c * (s - 0.5) ** 2)  # linear moment about the middle (double curvature)
    assert math.isclose(sway, 1 / 12, rel_tol=1e-12)


def test_uniform_layout_midpoint_error():
    s, c = hinge_layout(4, "uniform")
    assert math.isclose(np.sum(c * (1 - s) ** 2), (1 - 1 / 64) / 3, rel_tol=1e-12)


def test_hinge_layout_rejects_bad_input():
    with pytest.raises(SimulationError, match="layout"):
        hinge_layout(2, "chebyshev")
    with pytest.raises(SimulationError, match=">= 1"):
        hinge_layout(0)


# A crosspiece arm: a cantilever with a tip mass (the BCC's 15-in aluminium arms, SI).
ARM = dict(length=0.381, ei=7.6913, rho_a=0.43752, tip_mass=0.10247)


def test_tip_mass_cantilever_closed_form_limits():
    """mu = 0: lambda = 1.87510 (the bare cantilever); a heavy tip: Rayleigh's spring-mass
    ``sqrt(3 EI / (L^3 (M + 33/140 m)))`` (Blevins 1979, Ch. 8), to 0.1 % at M = 20 m."""
    from vlab.sim.hinges import tip_mass_cantilever_omega

    L, ei, ra = 0.5, 10.0, 0.3
    assert tip_mass_cantilever_omega(L, ei, ra, 0.0) == pytest.approx(1.8751041 ** 2 * math.sqrt(ei / (ra * L ** 4)),
                                                                    rel=1e-6)
    m_tip = 20 * ra * L
    rayleigh = math.sqrt(3 * ei / (L ** 3 * (m_tip + 33 / 140 * ra * L)))
    assert tip_mass_cantilever_omega(L, ei, ra, m_tip) == pytest.approx(rayleigh, rel=1e-3)
    with pytest.raises(SimulationError, match="tip mass"):
        tip_mass_cantilever_omega(L, ei, ra, -1.0)


def test_hinge_chain_of_a_tip_loaded_arm_converges_to_the_closed_form():
    """The chain's frequency error falls with the hinges; two Gauss hinges leave the BCC's arm
    0.3 % low (an in-band resonator several tenths of its half-bandwidth away), three within 1e-4;
    the chain as the plant builds it has the same frequency (MuJoCo's clamped-arm mode)."""
    from vlab.sim.hinges import ARM_LINKS_MAX, arm_links, hinge_chain_cantilever_omega, tip_mass_cantilever_omega

    exact = tip_mass_cantilever_omega(**ARM)
    err = [abs(hinge_chain_cantilever_omega(n, **ARM) / exact - 1) for n in (1, 2, 3, 4, 8)]
    assert err[1] > 1e-3 and err[2] < 1e-4 and err[4] < err[2] and err[0] > err[1]
    assert arm_links(**ARM, tolerance=1e-4) == 3
    assert arm_links(**ARM, tolerance=1e-2) == 2
    assert arm_links(**ARM, tolerance=1e-12) == ARM_LINKS_MAX
    with pytest.raises(SimulationError, match="tolerance"):
        arm_links(**ARM, tolerance=0.0)


def test_plant_arm_mode_is_the_clamped_arm_resonance():
    """The BCC plant's anti-symmetric arm mode (the clamp does not move) sits at the closed-form
    tip-mass cantilever frequency of its arm to 0.1 %, with the automatic (3) hinges per arm."""
    from vlab.sim.hinges import tip_mass_cantilever_omega
    from vlab.spec import load_spec

    spec = load_spec("bcc")
    c = spec.crosspieces[0]
    sec = spec.sections[c.section]
    plant = build_plant(spec, SimOptions())
    f = modes(plant.model, sorted(spec.points), 8).frequencies_hz
    exact = tip_mass_cantilever_omega(c.arm_length.si, sec.ei.si, sec.rho_a, c.tip_mass.si) / (2 * math.pi)
    assert np.min(np.abs(f / exact - 1)) < 1e-3
    assert plant.info.links[c.id] == 3


def test_a_damping_change_leaves_the_arms_hinges_and_the_step():
    """The arms' hinges follow their geometry and masses, not the damping ratios: a mode made nearly undamped
    (a diagnosis's hypothesis) builds the same joints at the same time step."""
    from vlab.diagnose.effects import specedit
    from vlab.spec import load_spec

    spec = load_spec("bcc")
    p0 = build_plant(spec, SimOptions())
    p1 = build_plant(specedit.set_modal_damping(spec, 6, 1e-6), SimOptions())
    assert p1.info.links == p0.info.links and p1.model.nv == p0.model.nv
    assert p1.timestep_s == p0.timestep_s
