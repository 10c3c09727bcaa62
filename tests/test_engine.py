"""ControllerEngine (Eq. 5.1): initial state, update, output, use in a loop."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import linalg, signal

from vlab.errors import ModelError, SimulationError
from vlab.lab.blocks import PC1000_PERIOD_S, CurrentAmplifier, RCLowPass, SampleDelay
from vlab.lab.engine import ControllerEngine
from vlab.measure.decay import decay_damping

DT = PC1000_PERIOD_S


def _random_engine(seed=0, n_y=3, n_u=2, n_x=4):
    rng = np.random.default_rng(seed)
    F22 = rng.standard_normal((n_x, n_x))
    F22 *= 0.9 / max(abs(np.linalg.eigvals(F22)))       # stable estimator dynamics
    return (rng.standard_normal((n_u, n_y)), rng.standard_normal((n_u, n_x)),
            rng.standard_normal((n_x, n_y)), F22)


def test_initial_state_and_sizes():
    F11, F12, F21, F22 = _random_engine()
    eng = ControllerEngine(F11, F12, F21, F22, period_s=DT)
    assert (eng.n_inputs, eng.n_outputs, eng.n_states) == (3, 2, 4)
    np.testing.assert_array_equal(eng.state, np.zeros(4))
    assert eng.n_ticks == 0
    assert eng.sample_rate_hz == pytest.approx(2000.0)
    assert eng.coefficient_matrix.shape == (6, 7)
    assert eng.fits_pc1000()
    assert eng.spectral_radius() == pytest.approx(0.9)
    x0 = np.arange(4.0)
    eng2 = ControllerEngine(F11, F12, F21, F22, period_s=DT, initial_state=x0)
    np.testing.assert_array_equal(eng2.state, x0)


def test_output_and_update_follow_eq_5_1():
    F11, F12, F21, F22 = _random_engine(1)
    x0 = np.array([0.1, -0.2, 0.3, 0.4])
    eng = ControllerEngine(F11, F12, F21, F22, period_s=DT, initial_state=x0)
    y = np.array([1.0, 2.0, -1.0])
    u = eng.output(y)
    np.testing.assert_allclose(u, F11 @ y + F12 @ x0)
    np.testing.assert_array_equal(eng.state, x0)             # output() does not advance
    eng.update(y)
    np.testing.assert_allclose(eng.state, F21 @ y + F22 @ x0)
    assert eng.n_ticks == 1
    eng.reset()
    np.testing.assert_array_equal(eng.state, x0)
    assert eng.n_ticks == 0
    np.testing.assert_allclose(eng.step(y), u)
    np.testing.assert_allclose(eng.state, F21 @ y + F22 @ x0)


def test_engine_matches_direct_simulation_of_discrete_realization():
    """Engine vs scipy.signal.dlsim of x_{k+1} = F22 x + F21 y, u = F12 x + F11 y."""
    F11, F12, F21, F22 = _random_engine(2)
    Y = np.random.default_rng(3).standard_normal((300, 3))
    _, U_ref, X_ref = signal.dlsim((F22, F21, F12, F11, DT), Y)
    eng = ControllerEngine(F11, F12, F21, F22, period_s=DT)
    U_step = np.array([eng.step(y) for y in Y])
    np.testing.assert_allclose(U_step, U_ref, rtol=1e-10, atol=1e-12)
    eng.reset()
    np.testing.assert_allclose(eng.simulate(Y), U_ref, rtol=1e-10, atol=1e-12)
    # state after the last tick is x_300 = F21 y_299 + F22 x_299
    np.testing.assert_allclose(eng.state, F21 @ Y[-1] + F22 @ X_ref[-1], rtol=1e-10, atol=1e-12)


def test_from_gain_is_drf_with_negative_sign():
    D = np.array([[0.5, 0.1], [0.1, 0.4]])
    eng = ControllerEngine.from_gain(D, period_s=DT)
    assert eng.n_states == 0
    np.testing.assert_array_equal(eng.F11, -D)
    y = np.array([0.2, -0.1])
    np.testing.assert_allclose(eng.step(y), -D @ y)
    np.testing.assert_allclose(eng.simulate(np.tile(y, (3, 1))), np.tile(-D @ y, (3, 1)))


def test_shape_errors_name_the_matrix():
    F11, F12, F21, F22 = _random_engine()
    with pytest.raises(ModelError, match=r"F12: expected shape \(2, 4\), found \(2, 3\)"):
        ControllerEngine(F11, F12[:, :3], F21, F22, period_s=DT)
    with pytest.raises(ModelError, match=r"F21: expected shape \(4, 3\)"):
        ControllerEngine(F11, F12, F21.T, F22, period_s=DT)
    with pytest.raises(ModelError, match="F22: expected a square"):
        ControllerEngine(F11, F12, F21, F22[:3], period_s=DT)
    with pytest.raises(ModelError, match="missing F21"):
        ControllerEngine(F11, F12, None, F22, period_s=DT)
    with pytest.raises(ModelError, match="F11"):
        ControllerEngine(np.ones(3), period_s=DT)
    with pytest.raises(ModelError, match="period_s"):
        ControllerEngine(F11, period_s=-1.0)
    eng = ControllerEngine(F11, F12, F21, F22, period_s=DT)
    with pytest.raises(ModelError, match=r"y: expected shape \(3,\)"):
        eng.step(np.ones(2))
    with pytest.raises(SimulationError, match="non-finite"):
        eng.step(np.array([1.0, np.inf, 0.0]))


def test_drf_loop_adds_the_designed_damping():
    """SDOF + DRF at 2 kHz through DAC delay (1.35 dt), RC filter and amplifier.

    At 3 Hz the loop's lags are tiny, so the closed-loop damping is that of
    the continuous dashpot: zeta = zeta0 + d / (2 sqrt(k m)).
    """
    m, fn, zeta0, d = 2.0, 3.0, 0.005, 1.5
    k = m * (2 * math.pi * fn) ** 2
    c = 2 * zeta0 * math.sqrt(k * m)
    n_sub = 10
    h = DT / n_sub
    A = np.array([[0.0, 1.0], [-k / m, -c / m]])
    B = np.array([0.0, 1.0 / m])
    E = linalg.expm(np.block([[A, B[:, None]], [np.zeros((1, 3))]]) * h)
    Phi, Gam = E[:2, :2], E[:2, 2]

    eng = ControllerEngine.from_gain([[d]], period_s=DT)
    dac = SampleDelay(period_s=DT, delay_periods=1.35)
    rc = RCLowPass(step_s=h)
    amp = CurrentAmplifier(limit=100.0)
    z = np.array([0.0, 0.05])        # initial velocity 5 cm/s
    vel = []
    for kk in range(4000):           # 2 s
        vel.append(z[1])
        dac.update(eng.step(z[1:2]))
        for s in range(n_sub):
            f = amp.output(rc.output())[0]
            rc.update(dac.output_at(kk * DT + s * h))
            z = Phi @ z + Gam * f
    expected = zeta0 + d / (2 * math.sqrt(k * m))
    fit = decay_damping(np.array(vel), dt_s=DT)
    assert fit.damping_ratio == pytest.approx(expected, rel=0.02)
    assert fit.freq_hz == pytest.approx(fn, rel=0.01)
    assert amp.saturation_count == 0
