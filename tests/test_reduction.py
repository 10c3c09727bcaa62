"""Tests of vlab.reduction: Guyan and exact reduction (Eqs. 3.5-3.16).

Structures are built here: a grounded spring-mass chain and a small
Euler-Bernoulli cantilever (Hermite elements, DOFs (node, "w") [m] and
(node, "ry") [rad]).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import scipy.linalg as sla

from _modal_systems import spring_mass_chain
from vlab.errors import ModelError, ReductionError
from vlab.reduction import (
    ExactReduction,
    GuyanReduction,
    ReducedModel,
    exact_reduction_form,
    modal_damping,
    natural_frequencies_hz,
)

# --------------------------------------------------------------------------- #
# Structures
# --------------------------------------------------------------------------- #


def chain(masses, springs):
    """:func:`spring_mass_chain` with the DOF labels ``(i + 1, "w")``: (m, k, labels)."""
    m, k = spring_mass_chain(masses, springs)
    return m, k, [(i + 1, "w") for i in range(len(masses))]


CHAIN = chain([1.0, 2.0, 1.5, 1.0, 3.0, 1.0, 0.8, 1.2], [100.0, 200.0, 150.0, 300.0, 120.0, 80.0, 250.0, 90.0])

EI = 12.0  # N m^2
RHO_A = 0.6  # kg/m
LENGTH = 1.2  # m
N_EL = 12


def cantilever(n_el=N_EL, lumped=False):
    """Clamped-free beam; node 0 clamped. DOFs [w1, ry1, w2, ry2, ...]."""
    le = LENGTH / n_el
    ke = EI / le**3 * np.array(
        [[12, 6 * le, -12, 6 * le], [6 * le, 4 * le**2, -6 * le, 2 * le**2],
         [-12, -6 * le, 12, -6 * le], [6 * le, 2 * le**2, -6 * le, 4 * le**2]]
    )
    if lumped:
        me = RHO_A * le / 2 * np.diag([1.0, 0.0, 1.0, 0.0])
    else:
        me = RHO_A * le / 420 * np.array(
            [[156, 22 * le, 54, -13 * le], [22 * le, 4 * le**2, 13 * le, -3 * le**2],
             [54, 13 * le, 156, -22 * le], [-13 * le, -3 * le**2, -22 * le, 4 * le**2]]
        )
    n = 2 * (n_el + 1)
    k = np.zeros((n, n))
    m = np.zeros((n, n))
    for e in range(n_el):
        idx = np.arange(2 * e, 2 * e + 4)
        k[np.ix_(idx, idx)] += ke
        m[np.ix_(idx, idx)] += me
    labels = [(node, d) for node in range(n_el + 1) for d in ("w", "ry")]
    return m[2:, 2:], k[2:, 2:], labels[2:]


def w_dof(node):
    """Index of the translation of a beam node (node >= 1) in the clamped model."""
    return 2 * (node - 1)


BEAM = cantilever()


# --------------------------------------------------------------------------- #
# Guyan
# --------------------------------------------------------------------------- #


def test_guyan_basis_equals_closed_form_3dof():
    m1, m2, m3 = 1.0, 2.0, 3.0
    k1, k2, k3 = 10.0, 20.0, 30.0
    m, k, labels = chain([m1, m2, m3], [k1, k2, k3])
    red = GuyanReduction(m, k, [0, 2], labels=labels)
    a, b = k2 / (k2 + k3), k3 / (k2 + k3)
    t_expected = np.array([[1.0, 0.0], [a, b], [0.0, 1.0]])
    np.testing.assert_allclose(red.basis, t_expected, rtol=1e-14)
    rm = red.reduce()
    ks = k2 * k3 / (k2 + k3)  # springs 2 and 3 in series
    np.testing.assert_allclose(rm.k, [[k1 + ks, -ks], [-ks, ks]], rtol=1e-13)
    np.testing.assert_allclose(rm.m, np.diag([m1, m3]) + m2 * np.outer([a, b], [a, b]), rtol=1e-14)
    assert rm.master == (0, 2) and rm.labels == ((1, "w"), (3, "w")) and rm.method == "guyan"


def test_guyan_master_order_is_kept():
    m, k, _ = CHAIN
    r1 = GuyanReduction(m, k, [1, 5, 3]).reduce()
    r2 = GuyanReduction(m, k, [1, 3, 5]).reduce()
    p = [0, 2, 1]
    np.testing.assert_allclose(r1.k, r2.k[np.ix_(p, p)], rtol=1e-12)
    np.testing.assert_allclose(r1.T, r2.T[:, p], rtol=1e-12)


@pytest.mark.parametrize("structure, master", [(CHAIN, [1, 4, 7]), (BEAM, [w_dof(4), w_dof(8), w_dof(12), 23])])
def test_guyan_static_flexibility_at_masters_is_exact(structure, master):
    m, k, labels = structure
    rm = GuyanReduction(m, k, master, labels=labels).reduce()
    flex = np.linalg.inv(k)[np.ix_(master, master)]
    np.testing.assert_allclose(np.linalg.inv(rm.k), flex, rtol=1e-10)
    # A static load at the masters is reproduced at every DOF by reconstruct().
    f_r = np.linspace(1.0, 2.0, len(master))
    f = np.zeros(k.shape[0])
    f[master] = f_r
    q_full = np.linalg.solve(k, f)
    np.testing.assert_allclose(rm.reconstruct(np.linalg.solve(rm.k, f_r)), q_full, rtol=1e-9, atol=1e-14)


def test_guyan_frequencies_are_upper_bounds_and_lowest_close():
    m, k, labels = BEAM
    master = [w_dof(j) for j in (2, 4, 6, 8, 10, 12)]
    f_g = GuyanReduction(m, k, master, labels=labels).reduce().natural_frequencies_hz()
    f_full = natural_frequencies_hz(m, k)
    assert np.all(f_g >= f_full[: len(master)] * (1 - 1e-12))
    assert abs(f_g[0] / f_full[0] - 1) < 1e-4
    # FE model sanity: first cantilever frequency 1.8751^2 / (2 pi) sqrt(EI / (rho A L^4)).
    f1 = 1.875104069**2 / (2 * np.pi) * np.sqrt(EI / (RHO_A * LENGTH**4))
    assert abs(f_full[0] / f1 - 1) < 1e-5
    # The chain as well (5 of 8 masses kept; lumped masses make Guyan cruder).
    m, k, _ = CHAIN
    f_g = GuyanReduction(m, k, [0, 2, 4, 6, 7]).reduce().natural_frequencies_hz()
    f_full = natural_frequencies_hz(m, k)
    assert np.all(f_g >= f_full[:5] * (1 - 1e-12))
    assert abs(f_g[0] / f_full[0] - 1) < 3e-3


def test_guyan_is_exact_with_massless_slaves():
    m, k, labels = cantilever(lumped=True)  # rotations carry no mass: m is singular
    master = [w_dof(j) for j in range(1, N_EL + 1)]
    f_g = GuyanReduction(m, k, master, labels=labels).reduce().natural_frequencies_hz()
    lam = sla.eigvals(k, m)
    lam = np.sort(lam[np.isfinite(lam)].real)
    np.testing.assert_allclose(f_g, np.sqrt(lam) / (2 * np.pi), rtol=1e-9)
    with pytest.raises(ModelError, match="not positive definite"):
        ExactReduction(m, k, master[:3], labels=labels).reduce()


def test_guyan_reduces_damping_and_identity_at_masters():
    m, k, _ = CHAIN
    c = 0.01 * k + 0.2 * m
    red = GuyanReduction(m, k, [0, 3, 6], c=c)
    rm = red.reduce()
    t = red.basis
    np.testing.assert_array_equal(t[[0, 3, 6], :], np.eye(3))
    np.testing.assert_allclose(rm.c, t.T @ c @ t, rtol=1e-14)
    for a in (rm.m, rm.k, rm.c):
        np.testing.assert_array_equal(a, a.T)


def test_no_slaves_gives_identity():
    m, k, _ = CHAIN
    rm = GuyanReduction(m, k, list(range(8))).reduce()
    np.testing.assert_array_equal(rm.T, np.eye(8))
    np.testing.assert_allclose(rm.k, k)


# --------------------------------------------------------------------------- #
# Exact reduction (SEREP with n_R modes)
# --------------------------------------------------------------------------- #


@pytest.mark.parametrize(
    "structure, master",
    [(CHAIN, [1, 4, 7]), (CHAIN, [0, 2, 3, 5, 7]), (BEAM, [w_dof(3), w_dof(6), w_dof(9), w_dof(12), 23])],
)
def test_exact_reproduces_first_frequencies_and_shapes(structure, master):
    m, k, labels = structure
    red = ExactReduction(m, k, master, labels=labels)
    rm = red.reduce()
    n_r = len(master)
    f_full = natural_frequencies_hz(m, k)[:n_r]
    np.testing.assert_allclose(rm.natural_frequencies_hz(), f_full, rtol=1e-10)
    # Reduced mode shapes are the full ones at the masters; reconstruct() gives the full shapes.
    lam, v = sla.eigh(rm.k, rm.m)
    _, phi = red.modes
    for i in range(n_r):
        a, b = v[:, i], phi[master, i]
        mac = (a @ b) ** 2 / ((a @ a) * (b @ b))
        assert mac > 1 - 1e-10
    np.testing.assert_allclose(red.reconstruct(red.phi_R), phi, atol=1e-10 * np.max(np.abs(phi)))


def test_exact_agrees_with_dissertation_form_eqs_3_6_to_3_8():
    m, k, labels = BEAM
    master = [w_dof(4), w_dof(8), w_dof(12), 23]
    n_r = len(master)
    # Shapes with an arbitrary (non-mass) normalisation, passed as an FE modal analysis would.
    lam, phi = sla.eigh(k, m)
    scale = np.array([2.0, -0.5, 3.0, 0.1, 1.0, 7.0])
    shapes = phi[:, :6] * scale
    freq = np.sqrt(lam[:6]) / (2 * np.pi)
    zeta = np.array([0.01, 0.02, 0.015, 0.03])
    red = ExactReduction(m, k, master, freq_hz=freq, shapes=shapes, zeta=zeta, labels=labels)
    rm = red.reduce()
    phi_r = shapes[master, :n_r]
    mi = np.einsum("ij,ik,kj->j", shapes[:, :n_r], m, shapes[:, :n_r])
    np.testing.assert_allclose(mi, scale[:n_r] ** 2, rtol=1e-10)
    form = exact_reduction_form(phi_r, freq[:n_r], mi, zeta)
    minv = np.linalg.inv(rm.m)
    ref = lambda a: np.max(np.abs(a))  # noqa: E731
    np.testing.assert_allclose(minv @ rm.k, form.minv_k, atol=1e-9 * ref(form.minv_k))  # Eq. 3.7
    np.testing.assert_allclose(minv, form.minv, atol=1e-9 * ref(form.minv))  # Eq. 3.8 (U_R = I)
    np.testing.assert_allclose(minv @ rm.c, form.minv_c, atol=1e-9 * ref(form.minv_c))  # Eq. 3.6
    np.testing.assert_allclose(form.minv_c, modal_damping(phi_r, freq[:n_r], zeta), rtol=1e-12)
    # c_R gives each retained mode its damping ratio.
    w = 2 * np.pi * freq[:n_r]
    ev = np.linalg.eigvals(np.block([[np.zeros((n_r, n_r)), np.eye(n_r)], [-minv @ rm.k, -minv @ rm.c]]))
    ev = ev[ev.imag > 0]
    ev = ev[np.argsort(np.abs(ev))]
    np.testing.assert_allclose(np.abs(ev), w, rtol=1e-8)
    np.testing.assert_allclose(-ev.real / np.abs(ev), zeta, rtol=1e-7)
    # Same model as from the computed modes.
    rm2 = ExactReduction(m, k, master, zeta=zeta).reduce()
    np.testing.assert_allclose(rm2.k, rm.k, rtol=1e-8, atol=1e-10 * ref(rm.k))
    np.testing.assert_allclose(rm2.m, rm.m, rtol=1e-8, atol=1e-10 * ref(rm.m))
    for a in (rm.m, rm.k, rm.c):
        np.testing.assert_array_equal(a, a.T)


def test_exact_damping_from_full_matrix_or_zeta_not_both():
    m, k, _ = CHAIN
    rm = ExactReduction(m, k, [1, 4, 7], c=0.01 * k).reduce()
    assert rm.c is not None and rm.method == "exact"
    with pytest.raises(ReductionError, match="not both"):
        ExactReduction(m, k, [1, 4, 7], c=0.01 * k, zeta=0.02)
    with pytest.raises(ModelError, match="together"):
        ExactReduction(m, k, [1, 4, 7], freq_hz=[1.0, 2.0, 3.0])


def test_reduced_model_is_immutable():
    m, k, _ = CHAIN
    rm = GuyanReduction(m, k, [1, 4, 7]).reduce()
    with pytest.raises(dataclasses.FrozenInstanceError):
        rm.m = np.eye(3)
    with pytest.raises(ValueError):
        rm.k[0, 0] = 1.0
    rm2 = rm.with_(k=2 * rm.k)
    assert isinstance(rm2, ReducedModel) and rm2 is not rm
    np.testing.assert_allclose(rm2.natural_frequencies_hz(), np.sqrt(2) * rm.natural_frequencies_hz())
    assert rm.n_R == 3 and rm.n == 8
    with pytest.raises(ModelError, match="q_R has shape"):
        rm.reconstruct(np.zeros(4))
    assert rm.reconstruct(np.zeros((3, 5))).shape == (8, 5)


# --------------------------------------------------------------------------- #
# Errors
# --------------------------------------------------------------------------- #


@pytest.mark.parametrize("cls", [GuyanReduction, ExactReduction])
def test_bad_master_lists(cls):
    m, k, labels = CHAIN
    with pytest.raises(ReductionError, match=r"more than once: DOF 3 \(4, 'w'\)"):
        cls(m, k, [1, 3, 3], labels=labels)
    with pytest.raises(ReductionError, match=r"\[-1, 8\] are out of range"):
        cls(m, k, [-1, 2, 8], labels=labels)
    with pytest.raises(ReductionError, match="integer"):
        cls(m, k, [1.0, 2.0])
    with pytest.raises(ReductionError, match="integer"):
        cls(m, k, [True, False])
    with pytest.raises(ReductionError, match="empty"):
        cls(m, k, [])
    with pytest.raises(ModelError, match="labels has 3 entries"):
        cls(m, k, [1], labels=labels[:3])


def test_bad_matrices():
    m, k, _ = CHAIN
    k_bad = k.copy()
    k_bad[0, 1] += 1.0
    with pytest.raises(ModelError, match=r"k must be symmetric: k\[0, 1\]"):
        GuyanReduction(m, k_bad, [1])
    with pytest.raises(ModelError, match=r"k has shape \(7, 7\), expected \(8, 8\)"):
        GuyanReduction(m, k[:7, :7], [1])
    with pytest.raises(ModelError, match="NaN"):
        GuyanReduction(m * np.nan, k, [1])
    assert issubclass(ReductionError, ValueError) and issubclass(ModelError, ValueError)


def test_guyan_singular_k22_names_slave_dofs():
    # Spring 5 (between masses 5 and 6, 1-based) missing: with masters at
    # masses 1-4 the slaves 6-8 float; the null space of K22 is their rigid
    # translation.
    m, k, labels = chain([1.0] * 8, [100.0, 100.0, 100.0, 100.0, 100.0, 0.0, 100.0, 100.0])
    with pytest.raises(ReductionError) as err:
        GuyanReduction(m, k, [0, 1, 2, 3], labels=labels).reduce()
    msg = str(err.value)
    assert "K22 is singular" in msg
    for name in ("DOF 5 (6, 'w')", "DOF 6 (7, 'w')", "DOF 7 (8, 'w')"):
        assert name in msg
    assert "DOF 4 " not in msg  # DOF 4 is held by its spring to the masters
    # A master among the floating DOFs removes the singularity.
    GuyanReduction(m, k, [0, 1, 2, 6], labels=labels).reduce()


def test_guyan_zero_stiffness_slave_is_named():
    m, k, labels = CHAIN
    k = k.copy()
    k = np.pad(k, ((0, 1), (0, 1)))  # an extra DOF with no stiffness at all
    m = np.pad(m, ((0, 1), (0, 1)))
    m[-1, -1] = 1.0
    labels = labels + [(99, "rx")]
    with pytest.raises(ReductionError, match=r"DOF 8 \(99, 'rx'\)"):
        GuyanReduction(m, k, [0, 3], labels=labels).reduce()


def branched():
    """Axis a0 - a1 with two identical soft branches b, c hanging on a1.

    DOFs [a0, a1, b, c]; the anti-symmetric mode (0, 0, 1, -1) is the lowest
    and does not move a0 or a1.
    """
    m = np.diag([1.0, 1.0, 0.5, 0.5])
    ka, kb = 1000.0, 5.0
    k = np.zeros((4, 4))
    k[0, 0] += ka
    k[np.ix_([0, 1], [0, 1])] += ka * np.array([[1, -1], [-1, 1]])
    for j in (2, 3):
        k[np.ix_([1, j], [1, j])] += kb * np.array([[1, -1], [-1, 1]])
    return m, k, [("a", 0), ("a", 1), ("b", 1), ("c", 1)]


def test_exact_unobservable_mode_names_masters_and_mode():
    m, k, labels = branched()
    with pytest.raises(ReductionError) as err:
        ExactReduction(m, k, [0, 1], labels=labels).reduce()
    msg = str(err.value)
    assert "DOF 0 ('a', 0)" in msg and "DOF 1 ('a', 1)" in msg
    f = natural_frequencies_hz(m, k)
    lam, v = sla.eigh(k, m)
    anti = int(np.argmax(np.abs(v[2] + v[3]) < 1e-9 * np.abs(v[2])))  # the anti-symmetric mode
    assert f"mode {anti + 1} ({f[anti]:.6g} Hz)" in msg and "not observable" in msg
    # Observed at a branch DOF, it reduces fine.
    ExactReduction(m, k, [1, 2], labels=labels).reduce()


def test_exact_master_that_no_mode_moves_is_named():
    # Uncoupled DOFs: mode i moves DOF i only. Masters 0 and 2 see modes 1 and 3,
    # but the exact reduction to 2 masters keeps modes 1 and 2.
    with pytest.raises(ReductionError) as err:
        ExactReduction(np.eye(3), np.diag([1.0, 2.0, 3.0]), [0, 2], labels=["x", "y", "z"]).reduce()
    msg = str(err.value)
    assert "mode 2 (" in msg and "is zero at every master DOF" in msg
    assert "DOF 2 'z' does not move in any of the first 2 modes" in msg


def test_exact_unobservable_combination_is_named():
    # M = I, K = Q diag(w^2) Q' with Q orthogonal; DOFs 0 and 1 move identically
    # in modes 1 and 2 (q1 = (1, 1, 1)/sqrt 3, q2 = (1, 1, -2)/sqrt 6), so each
    # mode is seen at the masters but a combination of them is not.
    q = np.column_stack([np.ones(3) / np.sqrt(3), np.array([1, 1, -2]) / np.sqrt(6), np.array([1, -1, 0]) / np.sqrt(2)])
    k = q @ np.diag([1.0, 4.0, 9.0]) @ q.T
    labels = [(7, "w"), (8, "w"), (9, "w")]
    with pytest.raises(ReductionError, match=r"condition number .* > 1e\+10") as err:
        ExactReduction(np.eye(3), k, [0, 1], labels=labels).reduce()
    msg = str(err.value)
    assert "a combination of mode 1" in msg and "mode 2" in msg
    assert "DOF 0 (7, 'w'), DOF 1 (8, 'w')" in msg
    # A perturbation of 1e-12 leaves it ill-conditioned; a threshold of 1e14 accepts it.
    k2 = k + 1e-12 * np.diag([1.0, 0.0, 0.0])
    with pytest.raises(ReductionError, match="ill-conditioned"):
        ExactReduction(np.eye(3), k2, [0, 1]).reduce()
    ExactReduction(np.eye(3), k2, [0, 2]).reduce()


def test_exact_repeated_frequency_at_cut_is_rejected():
    m = np.eye(4)
    k = np.diag([1.0, 4.0, 4.0, 9.0])
    with pytest.raises(ReductionError, match="modes 2 and 3 have the same frequency"):
        ExactReduction(m, k, [0, 1]).reduce()
    ExactReduction(m, k, [0, 1, 2]).reduce()


def test_modal_damping_errors():
    with pytest.raises(ModelError, match="square"):
        modal_damping(np.ones((3, 2)), [1.0, 2.0], 0.01)
    with pytest.raises(ModelError, match="singular"):
        modal_damping(np.ones((2, 2)), [1.0, 2.0], 0.01)
    with pytest.raises(ModelError, match="zeta"):
        modal_damping(np.eye(2), [1.0, 2.0], [-0.01, 0.01])
    with pytest.raises(ModelError, match=r"freq_hz has shape"):
        modal_damping(np.eye(2), [1.0, 2.0, 3.0], 0.01)
