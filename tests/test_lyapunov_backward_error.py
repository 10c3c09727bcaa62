"""The cost's Lyapunov equation when LAPACK perturbs it (an eigenvalue pair summing to nearly zero against
the matrix's norm, as a slow, lightly damped pole beside fast modes): checked against the closed form of a
diagonal system, and no library warning reaches the user."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from controllers.errors import MatrixPropertyError
from controllers.performance import _solve_lyapunov, lyapunov_cost_matrix


def test_a_slow_pole_beside_fast_ones_is_solved_to_the_closed_form_silently():
    a = np.array([-1e-12, -3.0, -1e5])
    A, Q = np.diag(a), np.diag([1.0, 2.0, 3.0])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        raw = __import__("scipy.linalg").linalg.solve_continuous_lyapunov(A.T, -Q)
    assert caught, "LAPACK no longer perturbs this problem: the test does not reach the second route"
    assert abs(raw[0, 0] - 0.5e12) > 0.25e12                  # LAPACK's perturbed solution misses it
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        P = lyapunov_cost_matrix(A, Q)
    # A^T P + P A + Q = 0 with A diagonal: P_ii = Q_ii / (-2 a_i)
    assert np.allclose(np.diag(P), np.diag(Q) / (-2.0 * a), rtol=1e-9)


def test_a_loop_with_a_marginal_pole_pair_is_refused():
    """A pair on the imaginary axis to working precision: no finite cost solves the equation."""
    A = np.array([[0.0, 1.0], [-4.0, -1e-17]])
    with pytest.raises(MatrixPropertyError, match="working precision"):
        lyapunov_cost_matrix(A, np.eye(2))


def test_an_ordinary_loop_is_not_perturbed():
    A = np.array([[0.0, 1.0], [-4.0, -0.4]])
    _, res = _solve_lyapunov(A.T, -np.eye(2))
    assert res == 0.0
