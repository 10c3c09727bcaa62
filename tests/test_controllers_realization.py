"""controllers.realization: the engine coefficients of Eq. (5.1), Eqs. (5.2)-(5.13)."""

from __future__ import annotations

from _controller_systems import chain

import numpy as np
import pytest
import scipy.linalg

from controllers.errors import MatrixPropertyError, ShapeError
from controllers.lq import lqg
from controllers.realization import (
    block_diagonal_transform,
    estimator_realization,
    output_feedback_realization,
    pole_mapping_error,
    z_to_s,
)
from controllers.statespace import state_space


DT = 0.0005  # [s], 2000 samples per second (Sec. 5.3)


@pytest.fixture(scope="module")
def design():
    """LQG on a 5-DOF chain designed in centiseconds (time unit 0.01 s), as in the thesis."""
    m, c, k, U = chain(5, zeta=0.01)
    # stiffen so the structure has Hz-range modes: k in [force/length], m in [force s^2/length]
    ss = state_space(m, c * 30, k * 900, U, time_unit_s=0.01)
    return lqg(ss.A, ss.B, ss.C, np.eye(10), 0.3 * np.eye(3), 1e-6 * np.eye(10),
               5e-4 * np.eye(3), alpha=0.2, time_unit_s=0.01)


def test_rate_feedback_engine_sign_and_time_unit():
    """u = -D y: F11 = -D; a gain in cs units becomes -T D for y in length/s."""
    D = np.array([[2.0, -0.5], [-0.5, 1.0]])
    r = output_feedback_realization(D, DT)
    np.testing.assert_array_equal(r.F11, -D)
    u, x = r.step([1.0, 0.0], r.initial_state())
    np.testing.assert_array_equal(u, [-2.0, 0.5])
    assert x.shape == (0,) and r.nonzero_count() == 4
    r_cs = output_feedback_realization(D, DT, time_unit_s=0.01)
    np.testing.assert_allclose(r_cs.F11, -0.01 * D)


def test_lqg_engine_poles_map_back_to_the_continuous_controller(design):
    r = design.realize(DT)
    A_s = design.controller_matrix / 0.01  # [1/s]
    assert r.pole_mapping_error() < 1e-9
    s = np.sort_complex(r.s_plane_poles())
    lam = np.sort_complex(scipy.linalg.eigvals(A_s))
    np.testing.assert_allclose(s, lam, rtol=1e-9)
    # nothing above Nyquist, so the principal log is the right branch
    assert np.max(np.abs(lam.imag)) * DT < np.pi


def test_F21_equals_thesis_formula_when_invertible(design):
    """Eq. (5.3): F21 = (e^{A~ dt} - I) A~^-1 K (here via the augmented exponential)."""
    r = design.realize(DT)
    A_s = design.controller_matrix / 0.01
    F22 = scipy.linalg.expm(A_s * DT)
    np.testing.assert_allclose(r.F22, F22, rtol=1e-12, atol=1e-14)
    F21 = (F22 - np.eye(10)) @ np.linalg.solve(A_s, design.estimator.gain)
    np.testing.assert_allclose(r.F21, F21, rtol=1e-7, atol=1e-12 * np.abs(F21).max())
    np.testing.assert_array_equal(r.F12, -design.regulator.gain)
    np.testing.assert_array_equal(r.F11, 0.0)


def test_singular_controller_matrix_is_fine():
    """The augmented exponential needs no inverse: A~ = 0 gives F21 = dt K."""
    K = np.array([[1.0], [2.0]])
    r = estimator_realization(np.zeros((2, 2)), K, np.ones((1, 2)), DT)
    np.testing.assert_allclose(r.F21, DT * K)
    np.testing.assert_allclose(r.F22, np.eye(2))


def test_dc_gain_in_seconds(design):
    """Constant y: u_ss = T F A~^-1 K y (continuous, y per second) = engine's steady state."""
    r = design.realize(DT)
    F, K, At = design.regulator.gain, design.estimator.gain, design.controller_matrix
    dc_engine = r.F12 @ np.linalg.solve(np.eye(10) - r.F22, r.F21)
    dc_cont = 0.01 * F @ np.linalg.solve(At, K)
    np.testing.assert_allclose(dc_engine, dc_cont, rtol=1e-6)


def test_block_diagonal_form_gives_the_same_controller(design):
    """Eqs. (5.6)-(5.12) with F12 = -F_R T: same input-output behaviour, fewer coefficients."""
    rp = design.realize(DT)
    rb = design.realize(DT, block_diagonal=True)
    T = rb.transform
    assert rb.F12.shape == (3, 10)
    np.testing.assert_allclose(rb.F12, -design.regulator.gain @ T)
    assert rb.pole_mapping_error() < 1e-9
    y = np.random.default_rng(0).normal(size=(400, 3))
    xp, xb = rp.initial_state(), rb.initial_state()
    up, ub = [], []
    for yk in y:
        u1, xp = rp.step(yk, xp)
        u2, xb = rb.step(yk, xb)
        up.append(u1)
        ub.append(u2)
    up, ub = np.array(up), np.array(ub)
    np.testing.assert_allclose(ub, up, atol=1e-9 * np.abs(up).max())
    # F22 block diagonal: 2x2 per complex pair, 1x1 per real eigenvalue
    lam = scipy.linalg.eigvals(design.controller_matrix)
    n_pairs = int(np.sum(lam.imag > 0))
    n_real = int(np.sum(lam.imag == 0))
    assert np.count_nonzero(rb.F22) == 4 * n_pairs + n_real
    assert rb.nonzero_count() == 3 * 10 + 10 * 3 + 4 * n_pairs + n_real
    assert rp.nonzero_count() == 3 * 10 + 10 * 3 + 100


def test_grid_sized_count():
    """Grid-sized case (5 sensors, 5 actuators, 24 states): 816 coefficients plain (as Sec. 5.3)."""
    m, c, k, U = chain(12, zeta=0.01, act=(0, 2, 5, 8, 11))
    ss = state_space(m, c, k, U)
    g = lqg(ss.A, ss.B, ss.C, np.eye(24), 0.1 * np.eye(5), 1e-6 * np.eye(24), 5e-4 * np.eye(5),
            alpha=0.05)
    rp, rb = g.realize(DT), g.realize(DT, block_diagonal=True)
    assert rp.nonzero_count() == 816
    lam = scipy.linalg.eigvals(g.controller_matrix)
    n_pairs, n_real = int(np.sum(lam.imag > 0)), int(np.sum(lam.imag == 0))
    assert rb.nonzero_count() == 240 + 4 * n_pairs + n_real  # 288 when all 12 are pairs


def test_block_diagonal_transform_properties():
    A = np.array([[-0.1, 2.0, 0.0], [-2.0, -0.1, 0.0], [0.0, 0.0, -3.0]])
    A = A + 0.3 * np.triu(np.ones((3, 3)), 1)
    T, L = block_diagonal_transform(A)
    np.testing.assert_allclose(A @ T, T @ L, atol=1e-12)
    assert L[2, 0] == 0 and L[2, 1] == 0 and L[0, 2] == 0
    with pytest.raises(MatrixPropertyError, match="defective"):
        block_diagonal_transform(np.array([[0.0, 1.0], [0.0, 0.0]]))


def test_z_to_s_inverts_z_equals_exp_s_dt():
    s = np.array([-1.0 + 30.0j, -5.0, -0.2 - 100.0j])
    np.testing.assert_allclose(z_to_s(np.exp(s * DT), DT), s, rtol=1e-12)
    assert pole_mapping_error(np.diag(np.exp([-1.0, -2.0]) ), np.diag([-1.0, -2.0]) / DT, DT) < 1e-12


def test_realization_shape_errors():
    with pytest.raises(ShapeError, match=r"K: expected shape \(2n_R, n_s\) = \(2, any\)"):
        estimator_realization(np.zeros((2, 2)), np.ones((3, 1)), np.ones((1, 2)), DT)
    with pytest.raises(MatrixPropertyError, match="dt_s"):
        output_feedback_realization(np.eye(2), 0.0)
