"""controllers.drf: MFDRF (Eqs. 4.30-4.32) and LQDRF (Eqs. 4.37-4.38) with analytic gradients."""

from __future__ import annotations

from _controller_systems import chain

import numpy as np
import pytest
import scipy.linalg
from hypothesis import given, settings
from hypothesis import strategies as st

from controllers.drf import lqdrf, mfdrf
from controllers.errors import InfeasibleDampingError, ShapeError
from controllers.lq import lqr
from controllers.performance import closed_loop_damping, performance_gradient
from controllers.statespace import modal_initial_states, state_space


ZL = 0.05
NM = 5
DT_S = 0.0005  # [s], 2 kHz engine


@pytest.fixture(scope="module")
def plant():
    m, c, k, U = chain(6, zeta=0.005, act=(0, 2, 5))
    return m, k, state_space(m, c, k, U)


@pytest.fixture(scope="module")
def weights(plant):
    m, k, ss = plant
    return np.eye(12), np.eye(3), modal_initial_states(m, k, 4)


def assert_feasible(design, ss, zeta_min=ZL, n_modes=NM):
    """Every constraint of Eqs. (4.32)/(4.38), checked independently of the optimiser."""
    D = design.gain
    np.testing.assert_array_equal(D, D.T)
    assert np.linalg.eigvalsh(D)[0] > 0
    zeta, _ = closed_loop_damping(ss.A, ss.B, ss.C, D, n_modes=n_modes)
    assert zeta.min() >= zeta_min - 1e-6
    lam = scipy.linalg.eigvals(ss.A - ss.B @ D @ ss.C)
    assert lam.real.max() < 0
    assert np.all(np.sum(np.abs(D), axis=1) <= design.gamma + 1e-12)


# --------------------------------------------------------------------------- gradients
def test_damping_gradient_matches_finite_differences(plant):
    _, _, ss = plant
    D = np.array([[0.5, 0.1, -0.05], [0.1, 0.3, 0.02], [-0.05, 0.02, 0.4]])
    E = np.random.default_rng(3).normal(size=(3, 3))
    z, g = closed_loop_damping(ss.A, ss.B, ss.C, D, n_modes=NM)
    h = 1e-6
    zp, _ = closed_loop_damping(ss.A, ss.B, ss.C, D + h * E, n_modes=NM)
    zm, _ = closed_loop_damping(ss.A, ss.B, ss.C, D - h * E, n_modes=NM)
    np.testing.assert_allclose(np.einsum("kij,ij->k", g, E), (zp - zm) / (2 * h), rtol=1e-5,
                               atol=1e-9)


def test_performance_gradient_matches_finite_differences(plant, weights):
    _, _, ss = plant
    Q, R, X0 = weights
    D = np.array([[0.5, 0.1, -0.05], [0.1, 0.3, 0.02], [-0.05, 0.02, 0.4]])
    E = np.random.default_rng(4).normal(size=(3, 3))
    J, g = performance_gradient(ss.A, ss.B, ss.C, D, Q, 2 * R, X0)
    h = 1e-6
    Jp, _ = performance_gradient(ss.A, ss.B, ss.C, D + h * E, Q, 2 * R, X0)
    Jm, _ = performance_gradient(ss.A, ss.B, ss.C, D - h * E, Q, 2 * R, X0)
    np.testing.assert_allclose(np.einsum("kij,ij->k", g, E), (Jp - Jm) / (2 * h), rtol=1e-5)


# --------------------------------------------------------------------------- MFDRF
@pytest.fixture(scope="module")
def mf(plant):
    _, _, ss = plant
    return mfdrf(ss.A, ss.B, ss.C, zeta_min=ZL, n_modes=NM, n_starts=3, seed=1)


def test_mfdrf_satisfies_every_constraint(mf, plant):
    _, _, ss = plant
    assert mf.converged, mf.message
    assert mf.kind == "MFDRF"
    assert_feasible(mf, ss)
    assert mf.objective == pytest.approx(mf.gamma)
    assert np.max(mf.row_sums) == pytest.approx(mf.gamma)
    # at the minimum some damping constraint and the max-force constraint must be active
    assert any(a.startswith("zeta[") for a in mf.active_constraints)
    assert any(a.startswith("row[") for a in mf.active_constraints)
    assert len(mf.starts) == 3 and mf.iterations > 0
    assert mf.constrained_damping.shape == (NM,)


def test_mfdrf_is_locally_optimal(mf, plant):
    """Scaling the optimum down by 1 % violates the damping bound (gamma cannot shrink that way)."""
    _, _, ss = plant
    z, _ = closed_loop_damping(ss.A, ss.B, ss.C, 0.99 * mf.gain, n_modes=NM)
    assert z.min() < ZL


def test_mfdrf_is_reproducible(plant, mf):
    _, _, ss = plant
    again = mfdrf(ss.A, ss.B, ss.C, zeta_min=ZL, n_modes=NM, n_starts=3, seed=1)
    np.testing.assert_array_equal(again.gain, mf.gain)


@pytest.mark.parametrize("design", ["mfdrf", "lqdrf"])
def test_a_degenerate_optimum_gives_the_least_norm_gain_for_any_seed(design):
    """Two uncoupled oscillators (1 and 3 Hz, zeta 0.001), a collocated actuator and sensor on each, both modes
    to zeta_L = 0.02: gamma is set by the 3 Hz row alone, so every d11 from 2 w1 (zeta_L - zeta_0) up to gamma
    is optimal (a face of optima). The least-norm stage returns the closed form D = diag(2 w_i (zeta_L -
    zeta_0)) (zeta = d / (2 m w) for an uncoupled mode) whatever the random starts."""
    w = 2 * np.pi * np.array([1.0, 3.0])
    z0, zl = 0.001, 0.02
    m, k = np.eye(2), np.diag(w**2)
    ss = state_space(m, np.diag(2 * z0 * w), k, np.eye(2))
    expected = np.diag(2 * w * (zl - z0))
    gains = []
    for seed in (0, 1, 2):
        if design == "mfdrf":
            d = mfdrf(ss.A, ss.B, ss.C, zeta_min=zl, n_modes=2, n_starts=6, seed=seed)
            assert d.gamma == pytest.approx(expected[1, 1], rel=1e-5)
        else:
            # LQDRF with the first mode's initial condition only: J does not depend on d22 (the modes are
            # uncoupled), so every d22 meeting the 3 Hz mode's damping bound is optimal -- a face in d22
            x0 = modal_initial_states(m, k, 2)
            d = lqdrf(ss.A, ss.B, ss.C, zeta_min=zl, n_modes=2, n_starts=6, seed=seed, Q=np.eye(4),
                      R=np.eye(2), initial_states=x0[:, :1])
        assert d.converged and "least-norm gain" in d.message
        gains.append(d.gain)
    if design == "mfdrf":
        np.testing.assert_allclose(gains[0], expected, atol=1e-4 * expected[1, 1])
    else:  # the face's least-norm end: d22 at its damping bound, no coupling
        assert gains[0][1, 1] == pytest.approx(expected[1, 1], rel=1e-3)
        assert abs(gains[0][0, 1]) < 1e-3 * expected[1, 1]
    for g in gains[1:]:
        np.testing.assert_allclose(g, gains[0], atol=1e-4 * np.abs(gains[0]).max())


def test_mfdrf_time_unit_invariance():
    """Designing in centiseconds gives the same physical gain (D_s = T D_cs) and damping."""
    m, c, k, U = chain(5, zeta=0.005, act=(1, 4))
    s = state_space(m, c, k, U)
    cs = state_space(m, c, k, U, time_unit_s=0.01)
    d_s = mfdrf(s.A, s.B, s.C, zeta_min=0.025, n_modes=4, n_starts=2)
    d_cs = mfdrf(cs.A, cs.B, cs.C, zeta_min=0.025, n_modes=4, n_starts=2, time_unit_s=0.01)
    assert d_s.converged and d_cs.converged
    assert d_cs.gamma * 0.01 == pytest.approx(d_s.gamma, rel=1e-5)
    np.testing.assert_allclose(d_cs.frequencies_hz, d_s.frequencies_hz, rtol=1e-8)
    np.testing.assert_allclose(d_cs.gain_per_s, d_s.gain_per_s, rtol=1e-4, atol=1e-6 * d_s.gamma)


def test_unreachable_damping_level_is_reported_not_returned_silently():
    """Two dampers cannot give mode 3 of this chain 4 % (the best is about 3.2 %)."""
    m, c, k, U = chain(5, zeta=0.005, act=(1, 4))
    s = state_space(m, c, k, U)
    d = mfdrf(s.A, s.B, s.C, zeta_min=0.04, n_modes=4, n_starts=2)
    assert not d.converged
    assert "mode 3" in d.message and "infeasible" in d.message
    assert d.constrained_damping[2] < 0.04


def test_mfdrf_reports_performance_when_weights_given(plant, weights):
    _, _, ss = plant
    Q, R, X0 = weights
    d = mfdrf(ss.A, ss.B, ss.C, zeta_min=ZL, n_modes=NM, n_starts=1, Q=Q, R=R, initial_states=X0)
    assert d.performance_index.shape == (4,)
    J, _ = performance_gradient(ss.A, ss.B, ss.C, d.gain, Q, R, X0)
    np.testing.assert_allclose(d.performance_index, J)


def test_mfdrf_not_converged_is_reported(plant):
    _, _, ss = plant
    d = mfdrf(ss.A, ss.B, ss.C, zeta_min=ZL, n_modes=NM, n_starts=1, maxiter=1)
    assert not d.converged
    assert "limit" in d.message.lower()


def test_unreachable_mode_raises_and_names_it():
    """Middle actuator of a symmetric fixed-fixed chain: mode 2 has a node there."""
    n = 5
    m = np.eye(n)
    k = 2 * np.eye(n) - np.eye(n, k=1) - np.eye(n, k=-1)
    w2, phi = scipy.linalg.eigh(k, m)
    c = phi @ np.diag(0.02 * np.sqrt(w2)) @ phi.T
    U = np.zeros((n, 1))
    U[2, 0] = 1.0
    ss = state_space(m, c, k, U)
    with pytest.raises(InfeasibleDampingError, match=r"mode 2 .*actuator"):
        mfdrf(ss.A, ss.B, ss.C, zeta_min=0.03, n_modes=3)
    # asking only for mode 1 is fine
    d = mfdrf(ss.A, ss.B, ss.C, zeta_min=0.03, n_modes=1, n_starts=1)
    assert d.converged and d.constrained_damping[0] >= 0.03 - 1e-6


def test_non_square_gain_rejected(plant):
    _, _, ss = plant
    with pytest.raises(ShapeError, match=r"C: expected shape \(n_c, 2n\) = \(3, 12\)"):
        mfdrf(ss.A, ss.B, ss.C[:2], zeta_min=ZL, n_modes=NM)


# --------------------------------------------------------------------------- LQDRF
@pytest.mark.parametrize(
    "diagonal, normalised",
    [(False, False), (True, False), (False, True), (True, True)],
)
def test_lqdrf_variants_satisfy_constraints(plant, weights, diagonal, normalised):
    _, _, ss = plant
    Q, R, X0 = weights
    d = lqdrf(ss.A, ss.B, ss.C, Q, R, X0, zeta_min=ZL, n_modes=NM, diagonal=diagonal,
              lqr_normalised=normalised, n_starts=2, seed=0)
    assert d.converged, d.message
    assert_feasible(d, ss)
    if diagonal:
        np.testing.assert_array_equal(d.gain, np.diag(np.diag(d.gain)))
    J, _ = performance_gradient(ss.A, ss.B, ss.C, d.gain, Q, R, X0)
    np.testing.assert_allclose(d.performance_index, J)
    if normalised:
        ref = lqr(ss.A, ss.B, Q, R).performance_index(X0)
        np.testing.assert_allclose(d.performance_ratio, J / ref)
        assert d.beta == pytest.approx(np.max(J / ref))
        assert d.beta >= 1.0 - 1e-9  # LQR is the best possible
    else:
        assert d.beta == pytest.approx(np.max(J))
    assert any(a.startswith("J[") for a in d.active_constraints)


def test_lqdrf_beats_mfdrf_on_its_own_objective(plant, weights, mf):
    _, _, ss = plant
    Q, R, X0 = weights
    d = lqdrf(ss.A, ss.B, ss.C, Q, R, X0, zeta_min=ZL, n_modes=NM, n_starts=2)
    J_mf, _ = performance_gradient(ss.A, ss.B, ss.C, mf.gain, Q, R, X0)
    assert d.beta <= np.max(J_mf) * (1 + 1e-8)
    dd = lqdrf(ss.A, ss.B, ss.C, Q, R, X0, zeta_min=ZL, n_modes=NM, diagonal=True, n_starts=2)
    assert d.beta <= dd.beta * (1 + 1e-6)  # coupled D can do at least as well as diagonal


def test_drf_realization_is_minus_T_D(mf):
    r = mf.realize(0.0005)
    np.testing.assert_array_equal(r.F11, -mf.gain)
    assert r.n_states == 0 and r.dt_s == 0.0005


# --------------------------------------------------------------------------- property
_SMALL = chain(4, zeta=0.002, act=(0, 1, 3))
_SS = state_space(*_SMALL)


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.floats(-3.0, 3.0, allow_nan=False), min_size=9, max_size=9),
    st.floats(1e-3, 1.0),
)
def test_any_spd_gain_gives_a_stable_loop(entries, shift):
    """Collocated rate feedback with D = L L^T + s I > 0 only dissipates: stable (Sec. 4.2.1)."""
    L = np.array(entries).reshape(3, 3)
    D = L @ L.T + shift * np.eye(3)
    lam = scipy.linalg.eigvals(_SS.A - _SS.B @ D @ _SS.C)
    assert lam.real.max() < 0


# --------------------------------------------------------------------------- a hand-built beam
def cantilever(n_el=10, length_in=60.0, EI=1e4, rho_a=1e-4, zeta=0.005, act_nodes=(10, 7, 4)):
    """Fixed-free Euler-Bernoulli beam (Hermite elements), inch/lbf/s; DOFs (w, theta) per node.

    Returns m, c, k, U and the indices of the translational DOFs.
    """
    le = length_in / n_el
    ke = EI / le**3 * np.array([[12, 6 * le, -12, 6 * le], [6 * le, 4 * le**2, -6 * le, 2 * le**2],
                                [-12, -6 * le, 12, -6 * le], [6 * le, 2 * le**2, -6 * le, 4 * le**2]])
    me = rho_a * le / 420 * np.array([[156, 22 * le, 54, -13 * le],
                                      [22 * le, 4 * le**2, 13 * le, -3 * le**2],
                                      [54, 13 * le, 156, -22 * le],
                                      [-13 * le, -3 * le**2, -22 * le, 4 * le**2]])
    N = 2 * (n_el + 1)
    K = np.zeros((N, N))
    M = np.zeros((N, N))
    for e in range(n_el):
        K[2 * e:2 * e + 4, 2 * e:2 * e + 4] += ke
        M[2 * e:2 * e + 4, 2 * e:2 * e + 4] += me
    K, M = K[2:, 2:], M[2:, 2:]
    w2, phi = scipy.linalg.eigh(K, M)
    C = M @ phi @ np.diag(2 * zeta * np.sqrt(w2)) @ phi.T @ M
    U = np.zeros((N - 2, len(act_nodes)))
    for j, a in enumerate(act_nodes):
        U[2 * (a - 1), j] = 1.0
    return M, C, K, U, np.arange(0, N - 2, 2)


@pytest.fixture(scope="module")
def beam_cs():
    m, c, k, U, trans = cantilever()
    return m, k, trans, state_space(m, c, k, U, time_unit_s=0.01)


def test_beam_in_centiseconds_mfdrf_and_lqdrf(beam_cs):
    """The thesis' BCC-like setting: three collocated pairs, zeta_L = 3 % on six modes, cs units."""
    m, k, trans, ss = beam_cs
    mf6 = mfdrf(ss.A, ss.B, ss.C, zeta_min=0.03, n_modes=6, n_starts=2, time_unit_s=0.01)
    assert mf6.converged, mf6.message
    assert_feasible(mf6, ss, zeta_min=0.03, n_modes=6)
    # the gain in per-second units is what the engine applies to velocities in in/s
    np.testing.assert_allclose(mf6.realize(DT_S).F11, -mf6.gain_per_s)
    np.testing.assert_allclose(mf6.gain_per_s, 0.01 * mf6.gain)
    X0 = modal_initial_states(m, k, 6, length_dofs=trans)
    n2 = ss.A.shape[0]
    lq6 = lqdrf(ss.A, ss.B, ss.C, np.eye(n2), 0.22 * np.eye(3), X0, zeta_min=0.03, n_modes=6,
                n_starts=2, time_unit_s=0.01)
    assert lq6.converged, lq6.message
    assert_feasible(lq6, ss, zeta_min=0.03, n_modes=6)


@pytest.mark.long
def test_beam_diagonal_lqr_normalised_over_twelve_modes():
    """Sec. 6.2.1: diagonal LQDRF with J_i / J_i^LQR <= beta over 12 modes (Q = 0.01 I, R = 0.84 I)."""
    m, c, k, U, trans = cantilever(n_el=12, act_nodes=(12, 8, 5), zeta=0.01)
    ss = state_space(m, c, k, U, time_unit_s=0.01)
    X0 = modal_initial_states(m, k, 12, length_dofs=trans)
    n2 = ss.A.shape[0]
    d = lqdrf(ss.A, ss.B, ss.C, 0.01 * np.eye(n2), 0.84 * np.eye(3), X0, zeta_min=0.03,
              n_modes=5, diagonal=True, lqr_normalised=True, time_unit_s=0.01)
    assert d.converged, d.message
    assert_feasible(d, ss, zeta_min=0.03, n_modes=5)
    assert d.performance_ratio.shape == (12,)
    assert np.all(d.performance_ratio >= 1.0 - 1e-9)
    assert d.beta == pytest.approx(d.performance_ratio.max())
