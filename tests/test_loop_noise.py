"""Sensor noise in the recorded channels.

A velocity sensor's noise is in what is recorded; at a collocated sensor the
recorded channel and the controller's input are the same numbers. The
noise-free signal is known independently: the probe plant's sensor reads
``sin(w t)`` whatever force it gets, and for the linear plant open loop the
noise does not reach the structure, so a noise-free run of the same plant is
the reference. The sample standard deviation of ``n`` Gaussian draws has a
relative sampling error of ``1 / sqrt(2 n)``; bounds are 5 of those.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from vlab.fe.damping import modal_damping_matrix, open_loop_ratios
from vlab.lab.engine import ControllerEngine
from vlab.lab.linear_plant import LinearPlant
from vlab.lab.loop import HardwareChain, run_loop
from vlab.models import nominal_fe_model

T = 0.5e-3
F_HZ = 25.0
SIGMA = 1e-3


class ProbePlant:
    """Sensor reads ``sin(w t)`` at every point, whatever the forces (loop's Plant protocol)."""

    def __init__(self, *, timestep_s: float = T / 2, actuator_points=(1,)):
        self.timestep_s = timestep_s
        self.actuator_points = tuple(actuator_points)
        self.n = 0
        self._f = np.zeros(len(self.actuator_points))

    def set_forces(self, forces):
        self._f = np.array(forces, dtype=float)

    def step(self):
        self.n += 1

    def velocities(self, points):
        return np.full(len(points), math.sin(2 * math.pi * F_HZ * self.n * self.timestep_s))

    def displacements(self, points):
        return np.zeros(len(points))


class RecordingEngine(ControllerEngine):
    """Eq. (5.1) engine that keeps every input it was given."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.inputs: list[np.ndarray] = []

    def step(self, y):
        self.inputs.append(np.array(y, dtype=float))
        return super().step(y)


def _run(plant, engine, chain, *, measured=(1, 2), seed=3, duration_s=2.0):
    return run_loop(plant, engine, feedback_points=(1,), measured_points=measured, excitation_point=1,
                    excitation=lambda t: np.zeros_like(t), duration_s=duration_s, chain=chain, seed=seed,
                    shape_points=())


def _std_ok(x, sigma):
    n = x.size
    return abs(np.std(x) / sigma - 1) < 5 / math.sqrt(2 * n) and abs(np.mean(x)) < 5 * sigma / math.sqrt(n)


@pytest.mark.parametrize("closed", [True, False], ids=["closed", "open"])
def test_recorded_channels_carry_the_sensor_noise(closed):
    eng = RecordingEngine(0.1 * np.eye(1), period_s=T) if closed else None
    r = _run(ProbePlant(), eng, HardwareChain(noise_m_s=SIGMA))
    t = np.arange(r.recording["vel1"].size) * T
    clean = np.sin(2 * np.pi * F_HZ * t)
    e1 = r.recording["vel1"] - clean
    e2 = r.recording["vel2"] - clean
    assert _std_ok(e1, SIGMA) and _std_ok(e2, SIGMA)
    # the measured point without a feedback sensor has its own, independent noise
    assert abs(np.corrcoef(e1, e2)[0, 1]) < 5 / math.sqrt(e1.size)
    if closed:
        # collocated sensor: the recorded channel is the controller's input, the same numbers
        np.testing.assert_array_equal(r.recording["vel1"], np.array(eng.inputs)[:, 0])


def test_recorded_collocated_channel_has_sensor_gain_and_lag():
    gain, lag_hz = 2.0, 150.0
    eng = RecordingEngine(0.1 * np.eye(1), period_s=T)
    r = _run(ProbePlant(), eng, HardwareChain(sensor_gain={1: gain}, sensor_lag_hz=lag_hz), duration_s=0.2)
    t = np.arange(r.recording["vel1"].size) * T
    # first-order lag, once per period, written out here
    a = math.exp(-2 * math.pi * lag_hz * T)
    expect, state = [], 0.0
    for v in gain * np.sin(2 * np.pi * F_HZ * t):
        state = a * state + (1 - a) * v
        expect.append(state)
    np.testing.assert_allclose(r.recording["vel1"], expect, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(r.recording["vel1"], np.array(eng.inputs)[:, 0])
    # a measured point without a feedback sensor: plain velocity
    np.testing.assert_allclose(r.recording["vel2"], np.sin(2 * np.pi * F_HZ * t), atol=1e-12)


def test_open_loop_linear_plant_recording_minus_noise_free_run_has_sigma():
    fe = nominal_fe_model("bcc")
    c = modal_damping_matrix(fe.m, fe.k, open_loop_ratios(fe.spec, fe.n))
    pidx = {p: fe.dofs.index(p, "w") for p in range(1, 10)}

    def plant():
        return LinearPlant(fe.m, c, fe.k, point_index=pidx, actuator_points=(5, 7, 9), timestep_s=T / 2)

    def run(noise, seed=1):
        return run_loop(plant(), None, feedback_points=(5, 7, 9), measured_points=(6, 9), excitation_point=9,
                        excitation=lambda t: 0.5 * np.sin(2 * np.pi * 3.0 * t), duration_s=1.0,
                        chain=HardwareChain(noise_m_s=noise), seed=seed, shape_points=()).recording

    clean, noisy = run(0.0), run(SIGMA)
    for ch in ("vel6", "vel9"):
        assert _std_ok(noisy[ch] - clean[ch], SIGMA), ch
    assert np.std(clean["vel6"]) > 10 * SIGMA  # the signal is there, the noise on top
    # reproducible from the seed
    np.testing.assert_array_equal(run(SIGMA)["vel6"], noisy["vel6"])
    assert not np.array_equal(run(SIGMA, seed=2)["vel6"], noisy["vel6"])


def test_lab_model_predicts_the_sensor_gain_and_lag_on_recorded_sensor_channels():
    """The diagnosis's FRF model records a sensor point through the sensor, as the loop now does (open loop)."""
    from vlab.diagnose.model.labmodel import LabState, predict_frf

    fe = nominal_fe_model("bcc")
    f = np.array([2.0, 7.5, 30.0])
    nominal = LabState(fe.spec, fe, HardwareChain(), None)
    gain, lag_hz = 1.7, 120.0
    faulty = LabState(fe.spec, fe, HardwareChain(sensor_gain={9: gain}, sensor_lag_hz=lag_hz), None)
    h0 = predict_frf(nominal, f, excitation_point=9, output_points=(6, 9))
    h1 = predict_frf(faulty, f, excitation_point=9, output_points=(6, 9))
    a = math.exp(-2 * math.pi * lag_hz * T)
    lag = (1 - a) / (1 - a * np.exp(-2j * np.pi * f * T))  # y_k = a y_{k-1} + (1 - a) v_k
    np.testing.assert_allclose(h1[:, 1] / h0[:, 1], gain * lag, rtol=1e-12)
    np.testing.assert_allclose(h1[:, 0], h0[:, 0], rtol=1e-12)  # point 6 has no feedback sensor
