"""controllers.statespace: Eqs. (3.1)-(3.3), time scaling, modal initial states, input errors."""

from __future__ import annotations

from _controller_systems import chain

import numpy as np
import pytest
import scipy.linalg

from controllers.errors import MatrixPropertyError, ShapeError
from controllers.statespace import (
    StateSpace,
    modal_initial_states,
    rescale_time,
    state_space,
    structural_modes,
    time_scaling_matrix,

)


def test_blocks_follow_eq_3_3():
    m, c, k, U = chain(4)
    ss = state_space(m, c, k, U)
    n = 4
    assert ss.A.shape == (8, 8) and ss.B.shape == (8, 3) and ss.C.shape == (3, 8)
    np.testing.assert_allclose(ss.A[:n, :n], -np.linalg.solve(m, c))
    np.testing.assert_allclose(ss.A[:n, n:], -np.linalg.solve(m, k))
    np.testing.assert_array_equal(ss.A[n:, :n], np.eye(n))
    np.testing.assert_array_equal(ss.A[n:, n:], 0.0)
    np.testing.assert_allclose(ss.B[:n], np.linalg.solve(m, U))
    np.testing.assert_array_equal(ss.B[n:], 0.0)
    # collocated velocity sensors by default: C = [U^T, 0]
    np.testing.assert_array_equal(ss.C, np.hstack([U.T, np.zeros((3, n))]))


def test_sensor_selection_and_general_cv():
    m, c, k, U = chain(4)
    ss = state_space(m, c, k, U, sensor_dofs=[1, 3])
    np.testing.assert_array_equal(ss.C[:, :4], np.eye(4)[[1, 3]])
    Cv = np.array([[0.5, 0.5, 0.0, 0.0]])
    ss2 = state_space(m, c, k, U, Cv=Cv)
    np.testing.assert_array_equal(ss2.C, np.hstack([Cv, np.zeros((1, 4))]))


def test_damping_ratios_of_modal_damping_model():
    m, c, k, U = chain(5, zeta=0.02)
    ss = state_space(m, c, k, U)
    lam = scipy.linalg.eigvals(ss.A)
    lam = lam[lam.imag > 0]
    np.testing.assert_allclose(-lam.real / np.abs(lam), 0.02, rtol=1e-9)


def test_rescale_time_is_exact_and_invertible():
    m, c, k, U = chain(4)
    ss = state_space(m, c, k, U)
    T = 0.01
    A2, B2, C2 = rescale_time(ss.A, ss.B, ss.C, factor=T)
    n = 4
    # closed forms of the docstring
    np.testing.assert_allclose(A2[:n, :n], -T * np.linalg.solve(m, c))
    np.testing.assert_allclose(A2[:n, n:], -T**2 * np.linalg.solve(m, k))
    np.testing.assert_array_equal(A2[n:, :n], np.eye(n))
    np.testing.assert_allclose(B2[:n], T**2 * np.linalg.solve(m, U))
    np.testing.assert_array_equal(C2, ss.C)
    # eigenvalues scale by T, damping unchanged
    l1 = np.sort_complex(scipy.linalg.eigvals(ss.A))
    l2 = np.sort_complex(scipy.linalg.eigvals(A2))
    np.testing.assert_allclose(l2, T * l1, rtol=1e-10)
    # similarity with S: A2 = T S A S^-1
    S = time_scaling_matrix(n, T)
    np.testing.assert_allclose(A2, T * S @ ss.A @ np.linalg.inv(S), atol=1e-14)
    # round trip
    A3, B3, C3 = rescale_time(A2, B2, C2, factor=1 / T)
    np.testing.assert_allclose(A3, ss.A, atol=1e-12)
    np.testing.assert_allclose(B3, ss.B, atol=1e-12)
    # the builder's time unit equals rescaling afterwards
    ss_cs = state_space(m, c, k, U, time_unit_s=T)
    np.testing.assert_allclose(ss_cs.A, A2, atol=1e-15)
    assert ss_cs.time_unit_s == T
    np.testing.assert_allclose(ss_cs.rescaled(1.0).A, ss.A, atol=1e-12)


def test_velocity_feedback_gain_converts_with_T():
    """u = -D' y' in the new unit equals u = -(T D') y in the old one."""
    m, c, k, U = chain(4)
    ss = state_space(m, c, k, U)
    T = 0.01
    cs = ss.rescaled(T)
    Dp = np.diag([30.0, 20.0, 10.0])
    l_new = np.sort_complex(scipy.linalg.eigvals(cs.A - cs.B @ Dp @ cs.C))
    l_old = np.sort_complex(scipy.linalg.eigvals(ss.A - ss.B @ (T * Dp) @ ss.C))
    np.testing.assert_allclose(l_new, T * l_old, rtol=1e-9)


def test_modal_initial_states_normalised_to_unit_max_deflection():
    m, c, k, U = chain(5)
    X0 = modal_initial_states(m, k, 3)
    assert X0.shape == (10, 3)
    np.testing.assert_array_equal(X0[:5], 0.0)
    np.testing.assert_allclose(np.max(np.abs(X0[5:]), axis=0), 1.0)
    np.testing.assert_allclose(np.max(X0[5:], axis=0), 1.0)  # deterministic sign
    _, phi = structural_modes(m, k)
    for i in range(3):
        cosang = abs(phi[:, i] @ X0[5:, i]) / np.linalg.norm(phi[:, i]) / np.linalg.norm(X0[5:, i])
        assert cosang == pytest.approx(1.0, abs=1e-12)
    # normalisation over a subset of DOFs (e.g. translations only)
    X1 = modal_initial_states(m, k, 2, length_dofs=[0, 1])
    np.testing.assert_allclose(np.max(np.abs(X1[5:][[0, 1]]), axis=0), 1.0)


def _nonsym(a):
    a = a.copy()
    a[0, 1] += 0.1
    return a


def _set(a, i, v):
    a = a.copy()
    a[i, i] = v
    return a


@pytest.mark.parametrize(
    "key, make, exc, words",
    [
        ("m", lambda a: np.ones((3, 2)), ShapeError, ["m: expected shape (n_dof, n_dof)", "(3, 2)"]),
        ("k", _nonsym, MatrixPropertyError, ["k: expected a symmetric matrix"]),
        ("m", lambda a: _set(a, 0, -1.0), MatrixPropertyError, ["m: expected a positive definite"]),
        ("U", lambda a: np.ones((3, 2)), ShapeError,
         ["U: expected shape (n_dof, n_c) = (4, any)", "(3, 2)"]),
        ("c", lambda a: np.ones((4, 3)), ShapeError, ["c: expected shape (n_dof, n_dof) = (4, 4)"]),
        ("time_unit_s", lambda a: 0.0, MatrixPropertyError, ["time_unit_s"]),
        ("sensor_dofs", lambda a: [7], ShapeError, ["sensor_dofs"]),
        ("m", lambda a: _set(a, 1, np.nan), MatrixPropertyError, ["m: contains non-finite"]),
    ],
)
def test_bad_input_errors_name_the_matrix(key, make, exc, words):
    m, c, k, U = chain(4)
    args = dict(m=m, c=c, k=k, U=U)
    kw = {}
    if key in args:
        args[key] = make(args[key])
    else:
        kw[key] = make(None)
    with pytest.raises(exc) as info:
        state_space(args["m"], args["c"], args["k"], args["U"], **kw)
    assert isinstance(info.value, ValueError)
    for w in words:
        assert w in str(info.value)


def test_both_sensor_specs_rejected_and_complex_rejected():
    m, c, k, U = chain(4)
    with pytest.raises(MatrixPropertyError):
        state_space(m, c, k, U, sensor_dofs=[0], Cv=np.ones((1, 4)))
    with pytest.raises(MatrixPropertyError, match="complex"):
        state_space(m.astype(complex), c, k, U)


def test_statespace_is_immutable():
    m, c, k, U = chain(3, act=(0,))
    ss = state_space(m, c, k, U)
    with pytest.raises(ValueError):
        ss.A[0, 0] = 1.0
    with pytest.raises(AttributeError):
        ss.n_dof = 4  # type: ignore[misc]
    with pytest.raises(ShapeError, match=r"B: expected shape \(2n, n_c\)"):
        StateSpace(ss.A, ss.B[:3], ss.C, 3)
