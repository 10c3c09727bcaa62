"""Loop blocks (vlab.lab.blocks): initial state, update, output, use in a loop."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vlab.errors import ModelError, SimulationError, VlabError
from vlab.lab.blocks import (PC1000_DELAY_PERIODS, PC1000_PERIOD_S, RC_CORNER_HZ,
                             CurrentAmplifier, RCLowPass, SampleDelay, SensorNoise,
                             ZeroOrderHold)

DT = PC1000_PERIOD_S


# --------------------------------------------------------------------------- ZeroOrderHold
def test_zoh_initial_state_and_output():
    zoh = ZeroOrderHold(period_s=DT, size=2, initial_value=[1.0, -2.0])
    np.testing.assert_array_equal(zoh.state, [1.0, -2.0])
    np.testing.assert_array_equal(zoh.output(), [1.0, -2.0])
    assert zoh.n_samples == 0
    assert zoh.sample_time(3) == pytest.approx(3 * DT)


def test_zoh_update_holds_value():
    zoh = ZeroOrderHold(period_s=DT)
    zoh.update([3.0])
    np.testing.assert_array_equal(zoh.output(), [3.0])
    np.testing.assert_array_equal(zoh.output(), [3.0])  # output does not change state
    zoh.update([4.0])
    np.testing.assert_array_equal(zoh.output(), [4.0])
    zoh.reset()
    np.testing.assert_array_equal(zoh.output(), [0.0])


def test_zoh_in_a_loop_is_stairstep_of_samples():
    """Physics substeps see u(t_k) for the whole period [t_k, t_k+1)."""
    n_sub = 10
    zoh = ZeroOrderHold(period_s=DT)
    seen = []
    for k in range(20):
        zoh.update([math.sin(2 * math.pi * 50 * k * DT)])
        seen.extend(zoh.output()[0] for _ in range(n_sub))
    expect = np.repeat(np.sin(2 * np.pi * 50 * np.arange(20) * DT), n_sub)
    np.testing.assert_array_equal(seen, expect)


def test_zoh_errors():
    with pytest.raises(ModelError, match="period_s"):
        ZeroOrderHold(period_s=0.0)
    zoh = ZeroOrderHold(period_s=DT, size=2, name="dac")
    with pytest.raises(ModelError, match=r"dac\.u: expected shape \(2,\)"):
        zoh.update([1.0])
    with pytest.raises(SimulationError, match="non-finite"):
        zoh.update([1.0, np.nan])
    assert issubclass(ModelError, ValueError) and issubclass(ModelError, VlabError)


# --------------------------------------------------------------------------- SampleDelay
def test_delay_initial_state():
    d = SampleDelay(period_s=DT, delay_periods=1.35, size=1, initial_value=0.5)
    assert d.state.shape == (3, 1)           # m + 2 = 3 samples buffered
    np.testing.assert_array_equal(d.output(), [0.5])
    np.testing.assert_array_equal(d.output_at(0.0), [0.5])
    assert d.delay_s == pytest.approx(1.35 * DT)


def test_delay_integer_is_shift_register():
    d = SampleDelay(period_s=DT, delay_periods=2)
    out = []
    for k in range(6):
        d.update([float(k + 1)])
        out.append(d.output()[0])
    assert out == [0.0, 0.0, 1.0, 2.0, 3.0, 4.0]


def test_delay_fractional_discrete_output_is_interpolation():
    """y[n] = (1-f) u[n-m] + f u[n-m-1], m=1, f=0.35: impulse response 0, 0.65, 0.35, 0."""
    d = SampleDelay(period_s=DT, delay_periods=PC1000_DELAY_PERIODS)
    out = []
    for k in range(5):
        d.update([1.0 if k == 0 else 0.0])
        out.append(d.output()[0])
    np.testing.assert_allclose(out, [0.0, 0.65, 0.35, 0.0, 0.0], atol=1e-15)


def test_delay_held_output_switches_1p35_periods_after_sample():
    """Step at sample 0: the DAC output changes exactly at t = 1.35 dt."""
    d = SampleDelay(period_s=DT, delay_periods=1.35)
    d.update([1.0])                    # sample 0 at t = 0
    for t in (0.0, 0.5 * DT, 0.99 * DT):
        assert d.output_at(t)[0] == 0.0
    d.update([1.0])                    # sample 1 at t = dt
    assert d.output_at(1.349 * DT)[0] == 0.0
    assert d.output_at(1.35 * DT)[0] == 1.0    # right-continuous at the switch
    assert d.output_at(1.9 * DT)[0] == 1.0


def test_delay_mean_over_is_exact_average():
    d = SampleDelay(period_s=DT, delay_periods=1.35)
    d.update([2.0])
    d.update([0.0])
    # over [dt, 2 dt): 0 for 0.35 dt (initial), then u0 = 2 for 0.65 dt
    assert d.mean_over(DT, 2 * DT)[0] == pytest.approx(0.65 * 2.0)
    assert d.mean_over(DT, 2 * DT)[0] == pytest.approx(d.output()[0])
    assert d.mean_over(1.2 * DT, 1.2 * DT)[0] == 0.0


def test_delay_refuses_future_and_forgotten_samples():
    d = SampleDelay(period_s=DT, delay_periods=0.35, name="dac")
    d.update([1.0])                    # sample 0
    with pytest.raises(SimulationError, match="dac: output at t"):
        d.output_at(1.5 * DT)          # needs sample 1
    for _ in range(5):
        d.update([1.0])
    with pytest.raises(SimulationError, match="left the buffer"):
        d.output_at(0.5 * DT)


def test_delay_in_a_loop_matches_closed_form_recursion():
    """Integrator plant x' = u_applied, u_k = -g x_k through the 1.35-period DAC.

    Piecewise-constant input inside each period gives exactly
    x_{k+1} = x_k + dt (0.35 u_{k-2} + 0.65 u_{k-1}).
    """
    g, n_per = 300.0, 60
    # (a) physics step dt/20: the switch (0.35 dt = 7 h) falls on a step boundary
    for n_sub, use_mean in ((20, False), (10, True)):
        h = DT / n_sub
        d = SampleDelay(period_s=DT, delay_periods=1.35)
        x, xs = 1.0, []
        for k in range(n_per):
            xs.append(x)
            d.update([-g * x])
            for s in range(n_sub):
                t = k * DT + s * h
                v = d.mean_over(t, t + h) if use_mean else d.output_at(t)
                x += h * v[0]
        ref = [1.0]
        for k in range(n_per - 1):
            u2 = -g * ref[k - 2] if k >= 2 else 0.0
            u1 = -g * ref[k - 1] if k >= 1 else 0.0
            ref.append(ref[k] + DT * (0.35 * u2 + 0.65 * u1))
        np.testing.assert_allclose(xs, ref, rtol=1e-12, atol=1e-14)


def test_delay_bad_config():
    with pytest.raises(ModelError, match="delay_periods"):
        SampleDelay(period_s=DT, delay_periods=-0.1)
    with pytest.raises(ModelError, match="initial_value"):
        SampleDelay(period_s=DT, delay_periods=1, size=2, initial_value=[1, 2, 3])


# --------------------------------------------------------------------------- RC low-pass
def test_rc_initial_state_and_coefficient():
    h = DT / 10
    rc = RCLowPass(step_s=h, initial_value=0.25)
    assert rc.corner_hz == RC_CORNER_HZ
    np.testing.assert_array_equal(rc.output(), [0.25])
    assert rc.a == pytest.approx(math.exp(-2 * math.pi * 677.0 * h))
    assert rc.time_constant_s == pytest.approx(1 / (2 * math.pi * 677.0))


def test_rc_step_response_matches_continuous_closed_form():
    h = DT / 10
    rc = RCLowPass(step_s=h)
    y = []
    for _ in range(200):
        rc.update([1.0])
        y.append(rc.output()[0])
    t = h * np.arange(1, 201)
    np.testing.assert_allclose(y, 1 - np.exp(-t / rc.time_constant_s), rtol=1e-12)


def test_rc_impulse_response_and_dc_gain():
    h = 1e-5
    rc = RCLowPass(step_s=h, corner_hz=100.0)
    rc.update([1.0])
    first = rc.output()[0]
    for _ in range(10):
        rc.update([0.0])
    assert rc.output()[0] == pytest.approx(first * rc.a**10)
    rc.reset()
    for _ in range(20000):
        rc.update([2.0])
    assert rc.output()[0] == pytest.approx(2.0, rel=1e-9)


def test_rc_in_the_dac_chain_smooths_the_stairstep():
    """Held DAC output through the 677 Hz filter: after a step it rises as 1 - exp(-t/tau)."""
    n_sub = 20
    h = DT / n_sub
    dac = SampleDelay(period_s=DT, delay_periods=1.35)
    rc = RCLowPass(step_s=h)
    ys = []
    for k in range(4):
        dac.update([1.0])
        for s in range(n_sub):
            ys.append(rc.output()[0])
            rc.update(dac.output_at(k * DT + s * h))
    ys = np.array(ys)
    t = np.arange(ys.size) * h
    expect = np.where(t > 1.35 * DT, 1 - np.exp(-(t - 1.35 * DT) / rc.time_constant_s), 0.0)
    np.testing.assert_allclose(ys, expect, atol=1e-12)


def test_rc_step_average_of_a_switched_input_matches_numerical_integration():
    """Step average over physics steps with a DAC switch inside (h = T / 17): quadrature of the continuous ODE."""
    import scipy.integrate

    n_sub = 17
    h = DT / n_sub
    dac = SampleDelay(period_s=DT, delay_periods=1.35)
    rc = RCLowPass(step_s=h)
    tau = rc.time_constant_s
    samples = [1.0, -0.5, 2.0, 0.3]
    means, ends = [], []
    for k, u in enumerate(samples):
        dac.update([u])
        for s in range(n_sub):
            t = k * DT + s * h
            segs = dac.segments_over(t, t + h)
            assert sum(d for d, _ in segs) == pytest.approx(h, rel=1e-12)
            rc.update_segments(segs)
            means.append(rc.mean()[0])
            ends.append(rc.output()[0])

    def u_of(t):  # the delayed staircase, written out here
        j = math.floor(t / DT - 1.35 + 1e-12)
        return samples[j] if j >= 0 else 0.0

    sol = scipy.integrate.solve_ivp(lambda t, y: [(u_of(t) - y[0]) / tau, y[0]], (0, len(samples) * DT), [0.0, 0.0],
                                    method="RK45", rtol=1e-11, atol=1e-14, max_step=h / 20,
                                    t_eval=h * np.arange(len(means) + 1))
    y, integral = sol.y
    np.testing.assert_allclose(ends, y[1:], atol=1e-8)
    np.testing.assert_allclose(means, np.diff(integral) / h, atol=1e-8)
    # the end-of-step value is not the step average (half a step ahead)
    assert np.max(np.abs(np.array(ends) - np.array(means))) > 0.05


def test_rc_update_sets_the_step_average_and_refuses_bad_pieces():
    h = DT / 10
    rc = RCLowPass(step_s=h, initial_value=0.25)
    rc.update([1.0])
    tau = rc.time_constant_s
    # int_0^h (1 - 0.75 exp(-t/tau)) dt / h
    assert rc.mean()[0] == pytest.approx(1 - 0.75 * tau * (1 - math.exp(-h / tau)) / h, rel=1e-12)
    with pytest.raises(ModelError, match="duration"):
        rc.update_segments([(-1e-6, [0.0])])
    with pytest.raises(ModelError, match="no duration"):
        rc.update_segments([(0.0, [0.0])])


# --------------------------------------------------------------------------- amplifier
def test_amplifier_gain_and_saturation():
    amp = CurrentAmplifier(gain=[2.0, 1.0], limit=3.0, size=2)
    assert amp.saturation_count == 0
    np.testing.assert_array_equal(amp.output([1.0, -1.0]), [2.0, -1.0])
    np.testing.assert_array_equal(amp.output([2.0, -5.0]), [3.0, -3.0])
    assert amp.saturation_count == 2
    amp.reset()
    assert amp.saturation_count == 0
    lin = CurrentAmplifier()
    np.testing.assert_array_equal(lin.output([1e6]), [1e6])
    with pytest.raises(ModelError, match="limit"):
        CurrentAmplifier(limit=0.0)


# --------------------------------------------------------------------------- sensor noise
def test_sensor_noise_is_seeded_and_has_sigma():
    a = SensorNoise(sigma_m_s=1e-3, seed=7, size=3)
    b = SensorNoise(sigma_m_s=1e-3, seed=7, size=3)
    ya = np.array([a.output(np.zeros(3)) for _ in range(4000)])
    yb = np.array([b.output(np.zeros(3)) for _ in range(4000)])
    np.testing.assert_array_equal(ya, yb)
    assert np.std(ya) == pytest.approx(1e-3, rel=0.03)
    assert abs(np.mean(ya)) < 1e-4
    a.reset()
    np.testing.assert_array_equal(a.output(np.zeros(3)), ya[0])
    c = SensorNoise(sigma_m_s=0.0, seed=1)
    np.testing.assert_array_equal(c.output([0.5]), [0.5])


def test_sensor_noise_requires_seed():
    with pytest.raises(ModelError, match="seed"):
        SensorNoise(sigma_m_s=1.0, seed=None)
    with pytest.raises(ModelError, match="sigma_m_s"):
        SensorNoise(sigma_m_s=-1.0, seed=1)
