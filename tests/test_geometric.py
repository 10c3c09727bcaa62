"""Geometric stiffness of thin members under in-plane pre-stress (vlab.fe.geometric).

Closed forms: lateral-torsional buckling of a narrow rectangular strip
(Timoshenko & Gere, *Theory of Elastic Stability*, 1961, Sec. 6.2-6.5;
Trahair 1993, Ch. 6) and the gravity energy of a rigid swing.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

from vlab.errors import ModelError
from vlab.fe import build_fe_model
from vlab.fe.elements import axial_geometric_stiffness, beam_matrices, local_to_global
from vlab.fe.geometric import geometric_stiffness, polar_radius_sq
from vlab.spec import load_spec, spec_from_dict
from vlab.units import G_SI

EI, GJ, L = 2.0, 3.0, 1.0  # N m^2, N m^2, m


def q(value, unit, source="test"):
    return {"value": value, "unit": unit, "source": source}


def critical_load(n_el, forces, fixed):
    """Smallest |lambda| making K + lambda K_G singular for a straight strip on [0, L].

    ``forces(s_a, s_b)`` returns (axial, shear, moment) end pairs of the element
    for a unit load (ElementForces convention); DOFs per node [w, b, t].
    """
    le = L / n_el
    n = 3 * (n_el + 1)
    k = np.zeros((n, n))
    kg = np.zeros((n, n))
    for e in range(n_el):
        ke, _ = beam_matrices(ei=EI, gj=GJ, rho_a=1.0, rho_ip=1.0, length=le)
        ax, sh, mo = forces(e * le, (e + 1) * le)
        ge = geometric_stiffness(length=le, axial=ax, shear=sh, moment=mo)
        idx = list(range(3 * e, 3 * e + 6))
        k[np.ix_(idx, idx)] += ke
        kg[np.ix_(idx, idx)] += ge
    free = [i for i in range(n) if i not in fixed]
    lam = scipy.linalg.eigvals(k[np.ix_(free, free)], -kg[np.ix_(free, free)])
    lam = lam[np.isfinite(lam)].real
    return np.min(np.abs(lam))


def fork_ends(n_el):
    """w and twist fixed at both ends (simply supported, fork supports)."""
    return [0, 2, 3 * n_el, 3 * n_el + 2]


def test_reduces_to_axial_geometric_stiffness_without_shear_moment_and_wagner():
    kg = geometric_stiffness(length=0.3, axial=(120.0, 80.0))
    ib = [0, 1, 3, 4]
    np.testing.assert_allclose(kg[np.ix_(ib, ib)], axial_geometric_stiffness(120.0, 80.0, 0.3), rtol=1e-13, atol=1e-12)
    assert np.all(kg[:, [2, 5]] == 0.0)


def test_symmetric_and_linear_in_the_prestress():
    args = dict(length=0.4, axial=(10.0, 12.0), shear=(3.0, -2.0), moment=(0.5, 0.7), polar_radius_sq=1e-3)
    kg = geometric_stiffness(**args)
    np.testing.assert_allclose(kg, kg.T, atol=1e-14)
    double = dict(args, axial=(20.0, 24.0), shear=(6.0, -4.0), moment=(1.0, 1.4))
    np.testing.assert_allclose(geometric_stiffness(**double), 2 * kg, rtol=1e-12)


def test_wagner_term_stiffens_twist_by_N_r0_squared():
    n, r0sq, le = 50.0, polar_radius_sq(0.05, 0.003), 0.2
    kg = geometric_stiffness(length=le, axial=(n, n), polar_radius_sq=r0sq)
    np.testing.assert_allclose(kg[np.ix_([2, 5], [2, 5])], n * r0sq / le * np.array([[1, -1], [-1, 1]]))
    assert r0sq == pytest.approx((0.05**2 + 0.003**2) / 12)


def test_lateral_torsional_buckling_uniform_moment_within_1_percent_with_8_elements():
    """M_cr = (pi/L) sqrt(EI_y GJ) (Timoshenko & Gere Eq. 6-18)."""
    m_cr = critical_load(8, lambda a, b: ((0, 0), (0, 0), (1.0, 1.0)), fork_ends(8))
    exact = np.pi / L * np.sqrt(EI * GJ)
    assert abs(m_cr / exact - 1) < 0.01


def test_lateral_torsional_buckling_central_point_load():
    """Simply supported strip, point load at midspan at the centroid: P_cr = 16.94 sqrt(EI GJ)/L^2.

    Shear and moment enter together here (M triangular, V = +-P/2): a sign slip
    between them moves the result by 90 %.
    """
    def forces(a, b):
        m = lambda s: 0.5 * s if s <= L / 2 + 1e-12 else 0.5 * (L - s)
        v = 0.5 if b <= L / 2 + 1e-12 else -0.5
        return (0, 0), (v, v), (m(a), m(b))

    p_cr = critical_load(16, forces, fork_ends(16))
    assert abs(p_cr / (16.94 * np.sqrt(EI * GJ) / L**2) - 1) < 0.01


def test_lateral_torsional_buckling_cantilever_tip_load():
    """Cantilever, end load at the centroid: P_cr = 4.013 sqrt(EI GJ)/L^2 (Timoshenko & Gere Sec. 6.5)."""
    p_cr = critical_load(16, lambda a, b: ((0, 0), (1.0, 1.0), (-(L - a), -(L - b))), [0, 1, 2])
    assert abs(p_cr / (4.013 * np.sqrt(EI * GJ) / L**2) - 1) < 0.01


def swing_doc():
    """An irregular frame hanging from two bearings on the x axis, loaded by its weight and two masses."""
    bar = {"width": q(0.05, "m"), "thickness": q(0.01, "m"), "density": q(2700.0, "kg/m^3"),
           "modulus": q(70e9, "Pa"), "shear_modulus": q(26e9, "Pa")}
    return {
        "structure": {"name": "swing", "title": "rigid swing", "source": "test", "dofs": ["w", "rx", "ry"],
                      "gravity": [0.0, -1.0]},
        "points": {"unit": "m", "source": "test",
                   "coordinates": {"1": [-1, 0], "2": [1, 0], "3": [-1, -1], "4": [1, -1.2], "5": [0.2, -2]}},
        "sections": {"bar": bar},
        "members": [
            {"id": "a", "points": [1, 3, 5, 4, 2], "section": "bar"},
            {"id": "b", "points": [3, 4], "section": "bar"},
            {"id": "c", "points": [1, 4], "section": "bar", "elements_per_segment": 3},
        ],
        "masses": [{"id": "m5", "point": 5, "mass": q(3.0, "kg")}, {"id": "m4", "point": 4, "mass": q(1.5, "kg")}],
        "supports": [{"point": 1, "fixed": ["w"], "inplane": "pinned"}, {"point": 2, "fixed": ["w"], "inplane": "pinned"}],
    }


def test_rigid_swing_energy_equals_gravity_energy():
    """Rotating the frame rigidly by theta about the bearing axis stores (sum m g depth) theta^2 / 2.

    The elastic stiffness does no work in a rigid motion, so ``u' k u`` is the
    second-order gravity energy: axial, shear and moment pre-stress (an
    indeterminate frame carries all three) and the joint terms must add up
    to the exact value.
    """
    fe = build_fe_model(spec_from_dict(swing_doc()))
    u = np.array([fe.mesh.nodes[node][1] if d == "w" else (1.0 if d == "rx" else 0.0) for node, d in fe.dofs.labels])
    sec = fe.spec.sections["bar"]
    exact = sum(sec.rho_a * G_SI * el.length * -(fe.mesh.nodes[el.a][1] + fe.mesh.nodes[el.b][1]) / 2
                for el in fe.mesh.elements)
    exact += sum(m.mass.si * G_SI * -fe.spec.points[m.point][1] for m in fe.spec.masses)
    moments = np.abs([f.moment for f in fe.gravity.element_forces]).max()
    assert moments > 1.0  # the frame really carries in-plane bending
    assert u @ fe.k @ u == pytest.approx(exact, rel=1e-9)


def test_bcc_unchanged_by_shear_moment_and_wagner_terms():
    """The BCC's members carry only axial force: the full geometric stiffness acts like the axial one."""
    fe = build_fe_model(load_spec("bcc"))
    active = [0, 1, 3, 4]  # the BCC beam is vertical: w and rx (= slope); twist ry inactive
    for el, f in zip(fe.mesh.elements, fe.gravity.element_forces):
        sec = fe.spec.sections[el.section]
        t = local_to_global(*el.direction)
        full = t.T @ geometric_stiffness(length=el.flexible_length, axial=f.axial, shear=f.shear, moment=f.moment,
                                         polar_radius_sq=polar_radius_sq(sec.width.si, sec.thickness.si)) @ t
        axial = np.zeros((6, 6))
        axial[np.ix_([0, 1, 3, 4], [0, 1, 3, 4])] = axial_geometric_stiffness(*f.axial, el.flexible_length)
        axial = t.T @ axial @ t
        scale = np.abs(axial).max()
        np.testing.assert_allclose(full[np.ix_(active, active)], axial[np.ix_(active, active)], atol=1e-9 * scale)


@pytest.mark.parametrize(
    "kwargs",
    [dict(length=0.0, axial=(1.0, 1.0)), dict(length=1.0, axial=(np.nan, 1.0)),
     dict(length=1.0, axial=(1.0, 1.0), polar_radius_sq=-1.0)],
)
def test_bad_input_raises(kwargs):
    with pytest.raises(ModelError):
        geometric_stiffness(**kwargs)


def test_polar_radius_rejects_non_positive_dimensions():
    with pytest.raises(ModelError, match="thickness"):
        polar_radius_sq(0.05, 0.0)
