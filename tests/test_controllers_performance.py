"""controllers.performance: modes, Lyapunov performance index vs. simulated cost, spillover logic."""

from __future__ import annotations

from _controller_systems import chain

import numpy as np
import pytest
import scipy.linalg
from scipy.integrate import solve_ivp

from controllers.errors import ShapeError
from controllers.performance import (
    feedback_performance,
    modes,
    pair_modes,
    performance_index,
    select_modes,
    spillover,
)
from controllers.statespace import modal_initial_states, state_space


def simulated_cost(A_cl, Q_cl, z0):
    """int_0^T z^T Q_cl z dt with z' = A_cl z, T long enough for exp(-2 sigma T) ~ 4e-11."""
    sigma = -np.max(scipy.linalg.eigvals(A_cl).real)
    T = 12.0 / sigma
    n = A_cl.shape[0]

    def f(t, y):
        z = y[:n]
        return np.concatenate([A_cl @ z, [z @ Q_cl @ z]])

    sol = solve_ivp(f, (0.0, T), np.concatenate([z0, [0.0]]), method="DOP853",
                    rtol=1e-11, atol=1e-12 * max(1.0, float(np.max(np.abs(z0)))))
    assert sol.success
    return sol.y[-1, -1]


def test_sdof_damping_ratio_and_frequency():
    zeta, w = 0.05, 2 * np.pi * 3.0
    A = np.array([[-2 * zeta * w, -(w**2)], [1.0, 0.0]])
    md = modes(A)
    assert md.eigenvalues.shape == (1,)
    assert md.damping_ratios[0] == pytest.approx(zeta, rel=1e-12)
    assert md.frequencies_hz[0] == pytest.approx(3.0, rel=1e-12)
    # same model in centiseconds: same Hz once the unit is given
    md_cs = modes(0.01 * A, time_unit_s=0.01)
    assert md_cs.frequencies_hz[0] == pytest.approx(3.0, rel=1e-12)


def test_modes_sorted_by_frequency_and_real_eigenvalues_count_half():
    lam = np.array([-1.0 + 5j, -1.0 - 5j, -0.1 + 1j, -0.1 - 1j, -2.0, -8.0, -0.2 + 3j, -0.2 - 3j])
    idx = select_modes(lam)
    np.testing.assert_allclose(np.abs(lam[idx]), np.sort(np.abs(lam[idx])))
    assert np.all(lam[idx].imag >= 0)
    # n_modes=2: 1j-mode (1), real -2 (1/2), 3j-mode (1): stops after the third entry
    sel = lam[select_modes(lam, 2)]
    np.testing.assert_allclose(sel, [-0.1 + 1j, -2.0, -0.2 + 3j])


def test_lyapunov_index_equals_simulated_cost_for_rate_feedback():
    """Eqs. (4.33)-(4.36) vs. the time integral of x^T Q x + u^T R u (solve_ivp)."""
    m, c, k, U = chain(4, zeta=0.02)
    ss = state_space(m, c, k, U)
    D = np.array([[0.6, 0.1, 0.0], [0.1, 0.4, -0.05], [0.0, -0.05, 0.5]])
    F = D @ ss.C
    Q = np.diag(np.linspace(1.0, 2.0, 8))
    R = np.diag([0.5, 1.0, 2.0])
    X0 = modal_initial_states(m, k, 2)
    J = feedback_performance(ss.A, ss.B, F, Q, R, X0)
    Acl = ss.A - ss.B @ F
    Qcl = Q + F.T @ R @ F
    for i in range(2):
        Jsim = simulated_cost(Acl, Qcl, X0[:, i])
        assert J[i] == pytest.approx(Jsim, rel=1e-4)


def test_unstable_loop_has_infinite_index():
    A = np.array([[0.1, -1.0], [1.0, 0.0]])
    J = performance_index(A, np.eye(2), np.eye(2))
    assert np.all(np.isinf(J))


def test_performance_index_shape_error():
    with pytest.raises(ShapeError, match=r"initial_states: expected shape \(N, n_f\) = \(2, any\)"):
        performance_index(-np.eye(2), np.eye(2), np.ones((3, 1)))


def test_pair_modes_identity_and_permutation():
    m, c, k, U = chain(4)
    ss = state_space(m, c, k, U)
    lam, V = scipy.linalg.eig(ss.A)
    idx = select_modes(lam)
    perm = np.array([2, 0, 3, 1])
    # closed = open with columns permuted and an extra (controller) eigenvalue appended
    lc = np.concatenate([lam[idx][perm], [-5.0]])
    Vc = np.hstack([V[:, idx][:, perm], np.zeros((8, 1))])
    Vc = np.vstack([Vc, np.eye(1, 5, 4)])  # controller state row
    got = pair_modes(lam[idx], V[:, idx], lc, Vc)
    np.testing.assert_array_equal(perm[got], np.arange(4))


def test_spillover_flags_exactly_the_modes_whose_damping_drops():
    m, c, k, U = chain(5, zeta=0.02)
    w2, phi = scipy.linalg.eigh(k, m)
    ss = state_space(m, c, k, U)
    # a "closed loop" that lowers mode 2 to 0.5 % and makes mode 4 unstable, raises mode 1
    z = np.full(5, 0.02)
    z[0], z[1], z[3] = 0.1, 0.005, -0.01
    c2 = m @ phi @ np.diag(2 * z * np.sqrt(w2)) @ phi.T @ m
    ss2 = state_space(m, c2, k, U)
    rep = spillover(ss.A, ss2.A)
    np.testing.assert_allclose(rep.open_loop_damping, 0.02, rtol=1e-9)
    np.testing.assert_allclose(rep.closed_loop_damping, z, atol=1e-9)
    assert rep.lowered == (2, 4)
    assert rep.destabilised == (4,)
    np.testing.assert_allclose(rep.frequencies_hz, np.sqrt(w2) / (2 * np.pi), rtol=1e-9)
