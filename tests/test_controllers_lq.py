"""controllers.lq: LQR (Eqs. 4.4-4.7), alpha-shifted Kalman filter (4.8-4.10), LQG (4.11-4.22),
reduced controller on the full model (4.23-4.29) and spillover."""

from __future__ import annotations

from _controller_systems import chain

import numpy as np
import pytest
import scipy.linalg
from scipy.integrate import solve_ivp

from controllers.errors import MatrixPropertyError, ShapeError, StabilizabilityError
from controllers.lq import kalman_filter, lqg, lqr, lqr_weight_for_damping, reduced_on_full
from controllers.statespace import modal_initial_states, state_space


def symmetric_chain(n=5, zeta=0.0):
    """Fixed-fixed chain of equal masses/springs: the middle mass is a node of the even modes."""
    m = np.eye(n)
    k = 2 * np.eye(n) - np.eye(n, k=1) - np.eye(n, k=-1)
    w2, phi = scipy.linalg.eigh(k, m)
    c = phi @ np.diag(2 * zeta * np.sqrt(w2)) @ phi.T
    U = np.zeros((n, 1))
    U[n // 2, 0] = 1.0
    return m, c, k, U


def simulated_cost(A_cl, Q_cl, z0):
    sigma = -np.max(scipy.linalg.eigvals(A_cl).real)
    n = A_cl.shape[0]

    def f(t, y):
        return np.concatenate([A_cl @ y[:n], [y[:n] @ Q_cl @ y[:n]]])

    sol = solve_ivp(f, (0.0, 12.0 / sigma), np.concatenate([z0, [0.0]]), method="DOP853",
                    rtol=1e-11, atol=1e-12)
    assert sol.success
    return sol.y[-1, -1]


@pytest.fixture(scope="module")
def plant():
    m, c, k, U = chain(5, zeta=0.01)
    return m, k, state_space(m, c, k, U)


def test_lqr_riccati_residual_and_gain(plant):
    _, _, ss = plant
    Q, R = np.eye(10), 0.3 * np.eye(3)
    d = lqr(ss.A, ss.B, Q, R)
    assert d.riccati_residual < 1e-9
    S = d.riccati
    res = ss.A.T @ S + S @ ss.A - S @ ss.B @ np.linalg.solve(R, ss.B.T) @ S + Q
    scale = sum(np.linalg.norm(x) for x in (ss.A.T @ S, S @ ss.A, Q))
    assert np.linalg.norm(res) / scale < 1e-9
    np.testing.assert_allclose(d.gain, np.linalg.solve(R, ss.B.T @ S), rtol=1e-12)
    assert np.all(d.eigenvalues.real < 0)
    assert np.all(np.diff(d.frequencies_hz) >= 0)
    with pytest.raises(ValueError):
        d.gain[0, 0] = 1.0  # results are immutable


def test_lqr_performance_index_is_x0_S_x0_and_simulated_cost(plant):
    m, k, ss = plant
    Q, R = np.eye(10), 0.3 * np.eye(3)
    d = lqr(ss.A, ss.B, Q, R)
    X0 = modal_initial_states(m, k, 2)
    J = d.performance_index(X0)
    F = d.gain
    Jsim = simulated_cost(ss.A - ss.B @ F, Q + F.T @ R @ F, X0[:, 0])
    assert J[0] == pytest.approx(Jsim, rel=1e-4)


def test_lqr_weight_for_damping_hits_zeta_L(plant):
    _, _, ss = plant
    res = lqr_weight_for_damping(ss.A, ss.B, np.eye(10), zeta_min=0.05, n_modes=4)
    assert res.converged, res.message
    zeta = res.design.damping_ratios[:4]
    assert zeta.min() == pytest.approx(0.05, abs=1e-7)
    assert zeta.min() >= 0.05 - 1e-9
    # a slightly more expensive control no longer meets it: r is (locally) the largest one
    d2 = lqr(ss.A, ss.B, np.eye(10), 1.01 * res.r * np.eye(3))
    assert d2.damping_ratios[:4].min() < 0.05


def test_lqr_weight_search_reports_unreachable(plant):
    _, _, ss = plant
    res = lqr_weight_for_damping(ss.A, ss.B, np.eye(10), zeta_min=0.05, n_modes=4,
                                 r_bounds=(1e3, 1e6))
    assert not res.converged
    assert "not reached" in res.message


def test_kalman_alpha_shift_and_residual(plant):
    _, _, ss = plant
    for alpha in (0.0, 0.05, 0.2):
        kf = kalman_filter(ss.A, ss.C, 1e-6 * np.eye(10), 5e-4 * np.eye(3), alpha=alpha)
        assert kf.riccati_residual < 1e-9
        assert np.max(kf.eigenvalues.real) < -alpha
        np.testing.assert_allclose(kf.gain, kf.riccati @ ss.C.T / 5e-4, rtol=1e-12)


def test_lqg_closed_loop_is_union_of_regulator_and_filter_poles(plant):
    _, _, ss = plant
    g = lqg(ss.A, ss.B, ss.C, np.eye(10), 0.3 * np.eye(3), 1e-6 * np.eye(10), 5e-4 * np.eye(3),
            alpha=0.1)
    F, K = g.regulator.gain, g.estimator.gain
    want = np.concatenate([scipy.linalg.eigvals(ss.A - ss.B @ F),
                           scipy.linalg.eigvals(ss.A - K @ ss.C)])
    got = scipy.linalg.eigvals(g.closed_loop_matrix)
    np.testing.assert_allclose(np.sort_complex(got), np.sort_complex(want), rtol=1e-8, atol=1e-10)
    assert g.closed_loop_matrix.shape == (20, 20)


def test_lqg_performance_index_equals_simulated_cost(plant):
    """Eqs. (4.18)-(4.22) vs. simulating plant + estimator from x_est(0) = 0."""
    m, k, ss = plant
    R = 0.3 * np.eye(3)
    g = lqg(ss.A, ss.B, ss.C, np.eye(10), R, 1e-6 * np.eye(10), 5e-4 * np.eye(3), alpha=0.1)
    X0 = modal_initial_states(m, k, 1)
    J = g.performance_index(X0)
    F, K = g.regulator.gain, g.estimator.gain
    # states [x; x_est]: x' = A x - B F x_est, x_est' = K C x + (A - B F - K C) x_est
    Acl = np.block([[ss.A, -ss.B @ F], [K @ ss.C, g.controller_matrix]])
    Qcl = scipy.linalg.block_diag(np.eye(10), F.T @ R @ F)
    Jsim = simulated_cost(Acl, Qcl, np.concatenate([X0[:, 0], np.zeros(10)]))
    assert J[0] == pytest.approx(Jsim, rel=1e-4)
    assert J[0] > g.regulator.performance_index(X0)[0]  # the observer costs performance


def test_reduced_on_full_with_full_model_reproduces_lqg(plant):
    """With A_R = A the matrix A_E of Eq. (4.24) is similar to Abar and J_E = J_LQG."""
    m, k, ss = plant
    g = lqg(ss.A, ss.B, ss.C, np.eye(10), 0.3 * np.eye(3), 1e-6 * np.eye(10), 5e-4 * np.eye(3),
            alpha=0.1)
    rof = reduced_on_full(ss.A, ss.B, ss.C, np.eye(10), g)
    np.testing.assert_allclose(np.sort_complex(scipy.linalg.eigvals(rof.closed_loop_matrix)),
                               np.sort_complex(scipy.linalg.eigvals(g.closed_loop_matrix)),
                               rtol=1e-7, atol=1e-9)
    X0 = modal_initial_states(m, k, 3)
    np.testing.assert_allclose(rof.performance_index(X0), g.performance_index(X0), rtol=1e-8)
    assert rof.spillover.lowered == ()


def _modal_truncation(m, k, zeta, n_r, U, Cv):
    w2, phi = scipy.linalg.eigh(k, m)
    w = np.sqrt(w2[:n_r])
    P = phi[:, :n_r]
    A_R = np.block([[-np.diag(2 * zeta * w), -np.diag(w**2)], [np.eye(n_r), np.zeros((n_r, n_r))]])
    B_R = np.vstack([P.T @ U, np.zeros((n_r, U.shape[1]))])
    C_R = np.hstack([Cv @ P, np.zeros((Cv.shape[0], n_r))])
    return A_R, B_R, C_R


def test_reduced_controller_spillover_on_full_model():
    """Non-collocated reduced LQG destabilises residual modes (Sec. 6.2.1 phenomenon)."""
    m, c, k, U = chain(10, zeta=0.01, act=(0, 4, 9))
    sensors = (1, 3, 8)
    ss = state_space(m, c, k, U, sensor_dofs=sensors)
    A_R, B_R, C_R = _modal_truncation(m, k, 0.01, 4, U, np.eye(10)[list(sensors)])
    gR = lqg(A_R, B_R, C_R, np.eye(8), np.eye(3), 1e-6 * np.eye(8), 1e-4 * np.eye(3), alpha=0.1)
    rof = reduced_on_full(ss.A, ss.B, ss.C, np.eye(20), gR)
    rep = rof.spillover
    assert rof.closed_loop_matrix.shape == (28, 28)
    # the controlled modes gain damping, some residual modes lose it
    assert np.all(rep.closed_loop_damping[:4] > rep.open_loop_damping[:4])
    assert len(rep.destabilised) > 0 and set(rep.destabilised) <= set(rep.lowered)
    assert all(j > 4 for j in rep.lowered)
    assert np.max(scipy.linalg.eigvals(rof.closed_loop_matrix).real) > 0
    eig_E = scipy.linalg.eigvals(rof.closed_loop_matrix)
    for lam in rep.closed_loop_eigenvalues:
        assert np.min(np.abs(eig_E - lam)) < 1e-9 * max(1.0, abs(lam))
    X0 = modal_initial_states(m, k, 2)
    assert np.all(np.isinf(rof.performance_index(X0)))


def test_reduced_on_full_performance_matches_simulation():
    m, c, k, U = chain(8, zeta=0.02, act=(0, 4, 7))
    ss = state_space(m, c, k, U)
    A_R, B_R, C_R = _modal_truncation(m, k, 0.02, 4, U, U.T)
    R = 0.5 * np.eye(3)
    gR = lqg(A_R, B_R, C_R, np.eye(8), R, 1e-6 * np.eye(8), 1e-3 * np.eye(3), alpha=0.1)
    rof = reduced_on_full(ss.A, ss.B, ss.C, np.eye(16), gR)
    assert rof.spillover.destabilised == ()
    X0 = modal_initial_states(m, k, 1)
    J = rof.performance_index(X0)
    Jsim = simulated_cost(rof.closed_loop_matrix, rof.closed_loop_weight,
                          np.concatenate([X0[:, 0], np.zeros(8)]))
    assert J[0] == pytest.approx(Jsim, rel=1e-4)


def test_unstabilisable_pair_names_the_eigenvalue():
    m, c, k, U = symmetric_chain(5, zeta=0.0)
    ss = state_space(m, c, k, U)
    with pytest.raises(StabilizabilityError, match=r"eigenvalue .*PBH"):
        lqr(ss.A, ss.B, np.eye(10), np.eye(1))
    # with light damping the uncontrollable modes are stable: stabilisable, design works
    m, c, k, U = symmetric_chain(5, zeta=0.01)
    ss = state_space(m, c, k, U)
    assert lqr(ss.A, ss.B, np.eye(10), np.eye(1)).riccati_residual < 1e-9


def test_undetectable_for_alpha_shift():
    m, c, k, U = symmetric_chain(5, zeta=0.01)
    ss = state_space(m, c, k, U)
    kalman_filter(ss.A, ss.C, 1e-6 * np.eye(10), np.eye(1), alpha=0.0)  # detectable
    with pytest.raises(StabilizabilityError, match=r"alpha"):
        kalman_filter(ss.A, ss.C, 1e-6 * np.eye(10), np.eye(1), alpha=0.1)


def test_weights_checked(plant):
    _, _, ss = plant
    with pytest.raises(MatrixPropertyError, match="R: expected a positive definite"):
        lqr(ss.A, ss.B, np.eye(10), np.diag([1.0, 0.0, 1.0]))
    with pytest.raises(MatrixPropertyError, match="Q: expected a positive semi-definite"):
        lqr(ss.A, ss.B, -np.eye(10), np.eye(3))
    with pytest.raises(ShapeError, match=r"R: expected shape \(n_c, n_c\) = \(3, 3\), found \(2, 2\)"):
        lqr(ss.A, ss.B, np.eye(10), np.eye(2))
    with pytest.raises(MatrixPropertyError, match="V2"):
        kalman_filter(ss.A, ss.C, np.eye(10), np.zeros((3, 3)))
