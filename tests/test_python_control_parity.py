"""The design module against python-control: the same Riccati, Kalman, Lyapunov and zero-order-hold results
to 1e-9, and its designs handed over as ``control.StateSpace`` whose loops have the design's own poles.

python-control (0.10) is an independent implementation of the same equations (its ``lqr``/``lqe`` call
scipy's or slycot's solvers through their own set-up; its ``c2d`` uses scipy.signal); the closed loop is
built by ``control.feedback``, not by the design module's own ``Abar`` (Eq. 4.16).
"""

from __future__ import annotations

import control
import numpy as np
import pytest

from controllers import pycontrol
from controllers.lq import kalman_filter, lqg, lqr
from controllers.performance import lyapunov_cost_matrix
from controllers.realization import estimator_realization, output_feedback_realization
from controllers.statespace import state_space

T = 0.01  # the dissertation's time unit, 1 cs [s]


def _chain(n=4, seed=3):
    """A chain of ``n`` masses on springs with light classical damping, two actuators, SI."""
    rng = np.random.default_rng(seed)
    m = np.diag(rng.uniform(0.5, 2.0, n))
    kk = rng.uniform(500.0, 2000.0, n)
    k = np.diag(kk + np.r_[kk[1:], 0.0]) - np.diag(kk[1:], 1) - np.diag(kk[1:], -1)
    c = 1e-3 * k + 0.05 * m
    u = np.zeros((n, 2))
    u[0, 0], u[n - 1, 1] = 1.0, 1.0
    return m, c, k, u


@pytest.fixture(scope="module")
def model():
    m, c, k, u = _chain()
    return state_space(m, c, k, u, time_unit_s=T)


def _rel(a, b):
    return float(np.max(np.abs(np.asarray(a) - np.asarray(b))) / np.max(np.abs(b)))


def test_lqr_equals_python_control(model):
    A, B = model.A, model.B
    Q, R = np.eye(A.shape[0]) * 0.01, np.eye(B.shape[1]) * 0.84
    d = lqr(A, B, Q, R, time_unit_s=T)
    K, S, E = control.lqr(A, B, Q, R)
    assert _rel(d.gain, K) < 1e-9 and _rel(d.riccati, S) < 1e-9
    assert np.allclose(np.sort_complex(np.linalg.eigvals(A - B @ d.gain)), np.sort_complex(E), rtol=1e-9)


@pytest.mark.parametrize("alpha", [0.0, 0.05])
def test_kalman_filter_equals_python_control(model, alpha):
    A, C = model.A, model.C
    V1, V2 = np.eye(A.shape[0]), np.eye(C.shape[0]) * 1e-2
    d = kalman_filter(A, C, V1, V2, alpha=alpha, time_unit_s=T)
    # the alpha-shifted filter is the Kalman filter of A + alpha I (Eqs. 4.8-4.10)
    L, P, _E = control.lqe(A + alpha * np.eye(A.shape[0]), np.eye(A.shape[0]), C, V1, V2)
    assert _rel(d.gain, L) < 1e-9
    assert np.all(np.linalg.eigvals(A - d.gain @ C).real < -alpha)


def test_lyapunov_cost_equals_python_control(model):
    A, B = model.A, model.B
    d = lqr(A, B, np.eye(A.shape[0]), np.eye(B.shape[1]), time_unit_s=T)
    a_cl = A - B @ d.gain
    q_cl = np.eye(A.shape[0]) + d.gain.T @ d.gain
    assert _rel(lyapunov_cost_matrix(a_cl, q_cl), control.lyap(a_cl.T, q_cl)) < 1e-9


def test_zero_order_hold_equals_python_control(model):
    A, B, C = model.A, model.B, model.C
    g = lqg(A, B, C, np.eye(A.shape[0]), np.eye(B.shape[1]), np.eye(A.shape[0]), np.eye(C.shape[0]), time_unit_s=T)
    r = estimator_realization(g.controller_matrix, g.estimator.gain, g.regulator.gain, 5e-4, time_unit_s=T)
    sysd = control.c2d(pycontrol.lqg_controller(g), 5e-4, method="zoh")
    assert _rel(r.F22, sysd.A) < 1e-9 and _rel(r.F21, sysd.B) < 1e-9
    k = pycontrol.discrete_controller(r.F11, r.F12, r.F21, r.F22, r.dt_s)
    assert k.dt == 5e-4 and _rel(k.C, sysd.C) < 1e-12 and _rel(k.A, r.F22) == 0.0


def test_the_lqg_loop_built_by_python_control_has_the_design_poles(model):
    """Separation principle: the poles of plant + controller joined by control.feedback are those of
    A - B F and A - K C (Eq. 4.16), in seconds (the design's eigenvalues per time unit / T)."""
    A, B, C = model.A, model.B, model.C
    g = lqg(A, B, C, np.eye(A.shape[0]) * 0.01, np.eye(B.shape[1]) * 0.84, np.eye(A.shape[0]),
            np.eye(C.shape[0]) * 0.1, alpha=0.02, time_unit_s=T)
    loop = pycontrol.closed_loop(pycontrol.plant(A, B, C, time_unit_s=T), pycontrol.lqg_controller(g))
    want = np.concatenate([np.linalg.eigvals(A - B @ g.regulator.gain),
                           np.linalg.eigvals(A - g.estimator.gain @ C)]) / T
    got = loop.poles()
    assert got.size == want.size
    assert _rel(np.sort_complex(got), np.sort_complex(want)) < 1e-7


def test_rate_feedback_in_seconds_matches_its_discrete_engine(model):
    """The static ``u = -D y`` in seconds is the realisation's direct feedthrough ``F11`` (Eq. 5.1)."""
    D = np.array([[0.4, 0.1], [0.1, 0.3]])
    k = pycontrol.output_feedback(D, time_unit_s=T)
    r = output_feedback_realization(D, 5e-4, time_unit_s=T)
    assert _rel(k.D, r.F11) < 1e-12
    assert pycontrol.discrete_controller(r.F11, r.F12, r.F21, r.F22, r.dt_s).nstates == 0
    p = pycontrol.plant(model.A, model.B, model.C, time_unit_s=T)
    # collocated rate feedback with D > 0 only dissipates: every pole of the loop is stable (Sec. 4.2.1)
    assert np.all(pycontrol.closed_loop(p, k).poles().real < 0)


def test_bad_input_is_refused():
    from controllers.errors import MatrixPropertyError

    with pytest.raises(MatrixPropertyError):
        pycontrol.output_feedback(np.eye(2), time_unit_s=0.0)
    with pytest.raises(MatrixPropertyError):
        pycontrol.plant(np.eye(2), np.ones((2, 1)), np.ones((1, 2)), time_unit_s=-1.0)
    with pytest.raises(MatrixPropertyError):
        pycontrol.discrete_controller(np.eye(2), np.zeros((2, 0)), np.zeros((0, 2)), np.zeros((0, 0)), 0.0)
