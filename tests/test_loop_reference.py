"""The single loop (run_loop, on the shared chain of vlab.lab.batch_chain) against independent references.

run_loop runs the chain of Fig. 21 with :class:`vlab.lab.batch_chain.ChainRun`
(N = 1), as the batched loop does, and drives a MuJoCo plant through its
:meth:`vlab.sim.MujocoPlant.loop_io`. The references here do not share that
code:

- the loop written out with the block objects of :mod:`vlab.lab.blocks`
  (SampleDelay with absolute switch times, RCLowPass's exact piecewise
  average, CurrentAmplifier, SensorNoise), one block per channel, on the
  linear plant: agreement to rounding (see :func:`test_loop_equals_the_blocks_loop`
  for the tolerance);
- the sensor noise stream: one ``SensorNoise.output`` per tick, bit for bit;
- the MuJoCo plant seen only through the :class:`vlab.lab.loop.Plant`
  protocol (public ``velocities``/``set_forces``/``step``, ``mj_step``
  whole): bit for bit, also with two physics steps per period and when the
  loop diverges.

The batched loop on ``mujoco.batch`` (tests/test_batch.py) and the
sampled-data analysis (tests/test_loop.py) check run_loop from two more sides.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from vlab.fe.damping import modal_damping_matrix, open_loop_ratios
from vlab.design import design_controller
from vlab.errors import ModelError, SimulationError
from vlab.lab.blocks import CurrentAmplifier, RCLowPass, SampleDelay, SensorNoise
from vlab.lab.engine import ControllerEngine
from vlab.lab.linear_plant import LinearPlant
from vlab.lab.loop import HardwareChain, run_loop
from vlab.models import nominal_fe_model
from vlab.reference import bcc_gain
from vlab.sim import MujocoPlant, SimOptions, build_plant

T = 0.5e-3
ACTS = (5, 7, 9)
MEAS = (5, 7, 9, 6)


@pytest.fixture(scope="module")
def bcc():
    fe = nominal_fe_model("bcc")
    c = modal_damping_matrix(fe.m, fe.k, open_loop_ratios(fe.spec, fe.n))
    pidx = {p: fe.dofs.index(p, "w") for p in range(1, 10)}
    lqg = design_controller(fe, "lqg", period_s=T)
    return fe, c, pidx, lqg


def _engine(kind, lqg):
    if kind == "lqg":
        return ControllerEngine(lqg.f11, lqg.f12, lqg.f21, lqg.f22, period_s=T)
    return ControllerEngine.from_gain(bcc_gain("mfdrf"), period_s=T) if kind == "mfdrf" else None


def _pole(corner_hz, step_s):
    return math.exp(-2 * math.pi * corner_hz * step_s) if corner_hz else None


def _blocks_loop(plant, engine, chain, exc, seed):
    """Fig. 21 with the blocks of vlab.lab.blocks, channel by channel; (recorded MEAS signals, commands)."""
    h = plant.timestep_s
    n_sub = int(round(chain.period_s / h))
    sensors = ACTS + tuple(p for p in MEAS if p not in ACTS)
    dac = [SampleDelay(period_s=chain.period_s, delay_periods=chain.delay_of(p), name=f"DAC{p}") for p in ACTS]
    rc = [RCLowPass(step_s=h, corner_hz=chain.filter_hz, name=f"RC{p}") if chain.filter_hz else None for p in ACTS]
    amp = [CurrentAmplifier(gain=chain.amplifier_gain, limit=chain.limit_of(p), name=f"amp{p}") for p in ACTS]
    noise = SensorNoise(sigma_m_s=chain.noise_m_s, seed=seed, size=len(sensors)) if chain.noise_m_s else None
    a_act = [_pole(chain.actuator_lag_of(p), h) for p in ACTS]
    a_sen = [_pole(chain.sensor_lag_of(p), chain.period_s) for p in ACTS]
    lag_f, lag_y = [0.0] * len(ACTS), [0.0] * len(ACTS)
    ys, us = [], []
    for k, e in enumerate(exc):
        y = np.array(plant.velocities(sensors), dtype=float)
        for i, p in enumerate(ACTS):
            y[i] *= chain.sensor_gain.get(p, 1.0)
            if a_sen[i] is not None:
                lag_y[i] = a_sen[i] * lag_y[i] + (1 - a_sen[i]) * y[i]
                y[i] = lag_y[i]
        if noise is not None:
            y = noise.output(y)
        u = engine.step(y[:len(ACTS)]) if engine is not None else np.zeros(len(ACTS))
        ys.append(y)
        us.append(u)
        for i in range(len(ACTS)):
            dac[i].update(u[i:i + 1])
        for s in range(n_sub):
            t = k * chain.period_s + s * h
            f = np.zeros(len(ACTS))
            for i, p in enumerate(ACTS):
                if rc[i] is not None:
                    rc[i].update_segments(dac[i].segments_over(t, t + h))
                    x = rc[i].mean()
                else:
                    x = dac[i].mean_over(t, t + h)
                f[i] = amp[i].output(x + (e if p == 9 else 0.0))[0] * chain.actuator_gain.get(p, 1.0)
                if a_act[i] is not None:
                    # the coil's continuous lag tau y' = x - y with x held over the step: y(t) = x + (y0 - x)
                    # e^{-t / tau}; the plant holds its mean over the step, the state goes on from the step's end
                    tau = 1 / (2 * math.pi * chain.actuator_lag_of(p))
                    y0, x = lag_f[i], f[i]
                    f[i] = x + (y0 - x) * tau / h * (1 - math.exp(-h / tau))
                    lag_f[i] = x + (y0 - x) * math.exp(-h / tau)
            plant.set_forces(f)
            plant.step()
    return np.array(ys)[:, [sensors.index(p) for p in MEAS]], np.array(us)


CHAINS = {
    "pc1000": HardwareChain(),
    "noise": HardwareChain(noise_m_s=2e-6),
    "long delay, 300 Hz RC": HardwareChain(delay_periods=2.6, filter_hz=300.0),
    "integer delay, no RC, saturating": HardwareChain(delay_periods=1.0, filter_hz=None, amplifier_limit_n=0.3),
    "per channel": HardwareChain(channel_delay_periods={7: 2.2}, channel_actuator_lag_hz={5: 300.0},
                                 channel_sensor_lag_hz={9: 200.0}, channel_limit_n={9: 0.3},
                                 amplifier_gain=1.3, actuator_gain={7: 0.8}, sensor_gain={5: 1.2},
                                 actuator_lag_hz=500.0, sensor_lag_hz=700.0, noise_m_s=1e-6),
    "no delay": HardwareChain(delay_periods=0.0),
}


@pytest.mark.parametrize("n_sub", (1, 4, 20))
@pytest.mark.parametrize("name", list(CHAINS))
def test_loop_equals_the_blocks_loop(bcc, name, n_sub):
    """run_loop = the blocks' loop on the linear BCC, LQG, to 1e-11 of each signal.

    Why not bit for bit: the blocks recompute each held piece's duration from
    absolute times and its exponential every step; the shared chain computes
    them once per run (module notes of vlab.lab.batch_chain). The ~1e-16
    differences pass through the LQG estimator and the lightly damped
    structure; over 0.15 s they stay near 1e-12 of the largest command (the
    estimator's output is a small difference of larger state terms). A wrong
    piece duration or exponent, a filter applied half a step early, a lag at
    the wrong rate or a noise draw out of order differs by > 1e-4. With 20
    physics steps per period the 1.35-period switch falls on a step boundary
    (0.35 T = 7 h).
    """
    fe, c, pidx, lqg = bcc
    chain = CHAINS[name]
    exc = 0.5 * np.random.default_rng(5).standard_normal(300 if n_sub < 20 else 100)

    def plant():
        return LinearPlant(fe.m, c, fe.k, point_index=pidx, actuator_points=ACTS, timestep_s=T / n_sub)

    ref_y, ref_u = _blocks_loop(plant(), _engine("lqg", lqg), chain, exc, seed=4)
    r = run_loop(plant(), _engine("lqg", lqg), feedback_points=ACTS, measured_points=MEAS, excitation_point=9,
                 excitation=exc, duration_s=len(exc) * T, chain=chain, seed=4, shape_points=())
    got_y = np.column_stack([r.recording[f"vel{p}"] for p in MEAS])
    assert np.max(np.abs(got_y - ref_y)) <= 1e-11 * np.max(np.abs(ref_y))
    assert np.max(np.abs(r.commands - ref_u)) <= 1e-11 * np.max(np.abs(ref_u))
    np.testing.assert_array_equal(r.recording["force9"], exc)


def test_noise_is_one_sensor_noise_draw_per_tick_bit_for_bit():
    """Same seed -> the draws of SensorNoise.output, tick by tick, across the chain's blocks of 512 ticks."""

    class Still:
        timestep_s = T
        actuator_points = (1,)

        def set_forces(self, forces):
            pass

        def step(self):
            pass

        def velocities(self, points):
            return np.full(len(points), 1e-3)

        def displacements(self, points):
            return np.zeros(len(points))

    n, sigma = 1100, 3e-4
    r = run_loop(Still(), None, feedback_points=(1,), measured_points=(2, 1), excitation_point=1,
                 excitation=np.zeros(n), duration_s=n * T, chain=HardwareChain(noise_m_s=sigma), seed=17)
    ref = SensorNoise(sigma_m_s=sigma, seed=17, size=2)
    expect = np.array([ref.output(np.full(2, 1e-3)) for _ in range(n)])  # sensors: feedback 1, then 2
    np.testing.assert_array_equal(r.recording["vel1"], expect[:, 0])
    np.testing.assert_array_equal(r.recording["vel2"], expect[:, 1])


class ProtocolOnly:
    """A MuJoCo plant seen only through the Plant protocol's public methods (no ``loop_io``)."""

    def __init__(self, sim: MujocoPlant):
        self._sim = sim
        self.timestep_s = sim.timestep_s
        self.actuator_points = sim.actuator_points

    def set_forces(self, forces):
        self._sim.set_forces(forces)

    def step(self):
        self._sim.step()

    def velocities(self, points):
        return self._sim.velocities(points)

    def displacements(self, points):
        return self._sim.displacements(points)


@pytest.mark.parametrize("step_ms", (0.5, 0.25))
def test_mujoco_loop_io_equals_the_protocol_path_bit_for_bit(bcc, step_ms):
    """``MujocoPlant.loop_io`` (mj_step1 / mj_step2, one sensor stage per tick) = the public methods."""
    fe, _, _, lqg = bcc
    opts = SimOptions(timestep_s=step_ms * 1e-3) if step_ms != 0.5 else None
    sim = MujocoPlant(build_plant(fe.spec, opts))
    exc = np.random.default_rng(2).standard_normal(200)
    kw = dict(feedback_points=ACTS, measured_points=MEAS, excitation_point=9, excitation=exc, duration_s=0.1,
              chain=HardwareChain(noise_m_s=1e-6), seed=3, shape_points=(2, 6, 9))
    results, states = [], []
    for plant in (sim, ProtocolOnly(sim)):
        sim.reset()
        results.append(run_loop(plant, _engine("lqg", lqg), **kw))
        states.append(np.concatenate([sim.data.qpos, sim.data.qvel, [sim.data.time]]))
    fast, ref = results
    np.testing.assert_array_equal(fast.recording.as_array(), ref.recording.as_array())
    np.testing.assert_array_equal(fast.commands, ref.commands)
    np.testing.assert_array_equal(fast.displacements, ref.displacements)
    np.testing.assert_array_equal(states[0], states[1])
    # the plant's public reading after the fast run is the state's
    np.testing.assert_array_equal(sim.velocities(ACTS), ProtocolOnly(sim).velocities(ACTS))


def test_mujoco_divergence_stops_both_paths_at_the_same_tick(bcc):
    fe = bcc[0]
    sim = MujocoPlant(build_plant(fe.spec))
    eng = ControllerEngine.from_gain(-200 * np.eye(3), period_s=T)  # positive velocity feedback
    partial = []
    for plant in (sim, ProtocolOnly(sim)):
        sim.reset()
        with pytest.raises(SimulationError, match="diverged at t =") as info:
            run_loop(plant, eng, feedback_points=ACTS, measured_points=(6,), excitation_point=9,
                     excitation=lambda t: np.where(t < 0.01, 1.0, 0.0), duration_s=2.0)
        partial.append(info.value.partial)
    assert 0 < partial[0].recording.n_samples < 4000
    np.testing.assert_array_equal(partial[0].recording.as_array(), partial[1].recording.as_array())


def test_point_without_sensor_uses_the_public_reading(bcc):
    """A measured point with no ``vel<ID>`` sensor: loop_io declines, the loop reads the site (built plant)."""
    fe = bcc[0]
    sim = MujocoPlant(build_plant(fe.spec))
    free = next(p for p in range(1, 10) if p not in sim.sensor_points)
    assert sim.loop_io(ACTS + (free,), ()) is None
    r = run_loop(sim, None, feedback_points=ACTS, measured_points=(free,), excitation_point=9,
                 excitation=np.ones(40), duration_s=40 * T)
    assert np.any(r.recording[f"vel{free}"] != 0)


def test_non_finite_excitation_or_seed_refused_before_the_run():
    class Idle:
        timestep_s = T
        actuator_points = (1,)

    kw = dict(feedback_points=(1,), measured_points=(1,), excitation_point=1, duration_s=10 * T)
    with pytest.raises(ModelError, match="excitation is not finite at tick 3"):
        run_loop(Idle(), None, excitation=np.r_[np.zeros(3), np.nan, np.zeros(6)], **kw)
    with pytest.raises(ModelError, match="seed must be an int"):
        run_loop(Idle(), None, excitation=np.zeros(10), chain=HardwareChain(noise_m_s=1e-6), seed=1.5, **kw)
