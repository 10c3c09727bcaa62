"""Per-channel controller-path settings of the hardware chain.

A delay, a lag corner or a force limit on one channel only. The references
are independent of the loop's code:

- phase: the probe plant of ``test_loop_phase`` (its sensors read
  ``sin(w t)`` whatever force they get) with a pass-through controller; an
  extra delay ``tau`` on one channel adds exactly ``w tau`` to that channel's
  phase lag (a pure delay of the held staircase, before the RC filter,
  delays every harmonic image alike), and the other channel is the run
  without any per-channel entry;
- a first-order lag ``y_i = c y_{i-1} + (1 - c) x_i`` applied to a sequence
  adds the phase of ``(1 - c) / (1 - c e^{-j w h})`` at the sequence's step
  ``h`` (images fold onto ``w`` at that step, so they all see the same factor);
- the force limit: a clipped channel never exceeds it, the other channel is
  unchanged;
- the frequency-domain model (:func:`vlab.diagnose.model.labmodel.predict_frf`)
  against FRFs measured on the 2 kHz loop (BCC, MFDRF, linear plant) with a
  per-channel delay of 1.5 samples and a per-channel lag.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from vlab.errors import ModelError
from vlab.lab.blocks import PC1000_PERIOD_S
from vlab.lab.engine import ControllerEngine
from vlab.lab.loop import HardwareChain, run_loop

T = PC1000_PERIOD_S
H = T / 2
SETTLE_S = 0.02


class TwoChannelProbe:
    """Two coils (points 1, 2), both sensors read ``sin(w t)``; records the forces applied at each physics step."""

    def __init__(self, freq_hz: float, timestep_s: float = H):
        self.timestep_s = timestep_s
        self.actuator_points = (1, 2)
        self.w = 2 * math.pi * freq_hz
        self.n = 0
        self._f = np.zeros(2)
        self.forces: list[np.ndarray] = []

    def set_forces(self, forces):
        self._f = np.array(forces, dtype=float)

    def step(self):
        self.forces.append(self._f.copy())
        self.n += 1

    def velocities(self, points):
        return np.full(len(points), math.sin(self.w * self.n * self.timestep_s))

    def displacements(self, points):
        return np.zeros(len(points))


def _run(chain: HardwareChain, f: float) -> np.ndarray:
    plant = TwoChannelProbe(f)
    eng = ControllerEngine(np.eye(2), period_s=T)  # u_k = y_k on each channel
    dur = SETTLE_S + max(0.5, 10.0 / f)
    run_loop(plant, eng, feedback_points=(1, 2), measured_points=(), excitation_point=1,
             excitation=lambda t: np.zeros_like(t), duration_s=dur, chain=chain, shape_points=())
    return np.array(plant.forces)


def _lag_deg(frc: np.ndarray, f: float, h: float = H) -> float:
    """Phase lag [deg] of a force sequence (one column) behind ``sin(w t)``, fitted on step averages."""
    i0 = int(round(SETTLE_S / h))
    n_win = int(round(math.floor((len(frc) * h - SETTLE_S) * f + 1e-9) / f / h))
    t = (i0 + np.arange(n_win)) * h
    w = 2 * math.pi * f
    cbar = (np.sin(w * (t + h)) - np.sin(w * t)) / (w * h)
    sbar = (np.cos(w * t) - np.cos(w * (t + h))) / (w * h)
    (a, b), *_ = np.linalg.lstsq(np.column_stack([cbar, sbar]), frc[i0:i0 + n_win], rcond=None)
    return math.degrees(math.atan2(-a, b))


def _lag_factor(corner_hz: float, f: float, step_s: float) -> complex:
    c = math.exp(-2 * math.pi * corner_hz * step_s)
    return (1 - c) / (1 - c * np.exp(-2j * np.pi * f * step_s))


def _held_lag_mean(corner_hz: float, f: float, step_s: float) -> complex:
    """A continuous lag ``tau y' = u - y`` driven by an input held over each step, averaged over the step,
    derived here: ``y(t) = u + (y0 - u) e^{-t/tau}`` in the step, so the average is ``u + (y0 - u) g`` with
    ``g = (tau / h)(1 - c)``, and ``y0`` the previous step's end ``c y0' + (1 - c) u'``."""
    tau, z = 1 / (2 * math.pi * corner_hz), np.exp(2j * np.pi * f * step_s)
    c = math.exp(-step_s / tau)
    g = tau / step_s * (1 - c)
    y_end = (1 - c) / (1 - c / z)  # end-of-step value per unit held input
    return 1 + g * (y_end / z - 1)


@pytest.mark.parametrize("f", (4.0, 25.0, 100.0))
def test_per_channel_delay_adds_w_tau_on_its_channel_only(f):
    extra = 1.5
    nominal = _run(HardwareChain(), f)
    chain = HardwareChain(channel_delay_periods={2: HardwareChain().delay_periods + extra})
    frc = _run(chain, f)
    # channel 1 is the run without per-channel entries
    np.testing.assert_allclose(frc[:, 0], nominal[:, 0], rtol=0, atol=1e-13)
    expected = math.degrees(2 * math.pi * f * extra * T)
    got = _lag_deg(frc[:, 1], f) - _lag_deg(nominal[:, 1], f)
    assert got == pytest.approx(expected, abs=1e-6)
    assert expected > 1.0  # the check is not trivial


@pytest.mark.parametrize("f", (4.0, 25.0, 100.0))
def test_per_channel_actuator_and_sensor_lags_add_their_discrete_phase(f):
    nominal = _run(HardwareChain(), f)
    fa, fs = 150.0, 90.0
    frc = _run(HardwareChain(channel_actuator_lag_hz={2: fa}, channel_sensor_lag_hz={1: fs}), f)
    # coil 2: a continuous lag averaged over each physics step; sensor 1: a recursion at the controller period
    exp_2 = -math.degrees(np.angle(_held_lag_mean(fa, f, H)))
    # the step average is the continuous lag to second order in the step (the end-of-step recursion leads it by
    # h / 2): nearer the continuous lag's phase than the recursion's
    cont = math.degrees(math.atan(f / fa))
    assert abs(exp_2 - cont) < 0.1 * abs(-math.degrees(np.angle(_lag_factor(fa, f, H))) - cont)
    exp_1 = -math.degrees(np.angle(_lag_factor(fs, f, T)))
    assert _lag_deg(frc[:, 1], f) - _lag_deg(nominal[:, 1], f) == pytest.approx(exp_2, abs=1e-6)
    # (the sensor lag's start transient, c^40 = 1e-5 of it after the 20 ms settling, leaves ~1e-5 deg)
    assert _lag_deg(frc[:, 0], f) - _lag_deg(nominal[:, 0], f) == pytest.approx(exp_1, abs=1e-4)
    # a per-channel None switches off the global lag on that channel only
    both = _run(HardwareChain(actuator_lag_hz=fa, channel_actuator_lag_hz={1: None}), f)
    np.testing.assert_allclose(both[:, 0], nominal[:, 0], rtol=0, atol=1e-13)
    assert _lag_deg(both[:, 1], f) - _lag_deg(nominal[:, 1], f) == pytest.approx(exp_2, abs=1e-6)


def test_per_channel_force_limit_clips_its_channel_only():
    nominal = _run(HardwareChain(), 25.0)
    frc = _run(HardwareChain(channel_limit_n={2: 0.4}), 25.0)
    assert np.max(np.abs(frc[:, 1])) == pytest.approx(0.4, abs=1e-12)
    assert np.max(np.abs(nominal[:, 1])) > 0.9
    np.testing.assert_array_equal(frc[:, 0], nominal[:, 0])


@pytest.mark.parametrize("field, value", [("channel_delay_periods", -1.0), ("channel_actuator_lag_hz", 0.0),
                                          ("channel_sensor_lag_hz", float("nan")), ("channel_limit_n", -2.0),
                                          ("channel_delay_periods", None)])
def test_bad_per_channel_entries_are_refused_naming_field_and_key(field, value):
    with pytest.raises(ModelError, match=rf"{field}\[7\]"):
        HardwareChain(**{field: {7: value}})


def test_per_channel_entry_at_a_point_without_actuator_is_refused():
    with pytest.raises(ModelError, match="channel_delay_periods names point"):
        _run(HardwareChain(channel_delay_periods={3: 2.0}), 25.0)
    with pytest.raises(ModelError, match="channel_sensor_lag_hz names point"):
        _run(HardwareChain(channel_sensor_lag_hz={3: 50.0}), 25.0)


def _measured_frf(state, lines_hz, f0, exc, outs):
    """FRF (v / x) of the 2 kHz loop on the linear plant, from a periodic multisine (period 1 / f0)."""
    from vlab.diagnose.data.replay import rerun

    n_per = int(round(1 / (f0 * T)))
    n_periods = 4
    t = np.arange(n_periods * n_per) * T
    rng = np.random.default_rng(3)
    x = sum(0.3 * np.sin(2 * np.pi * fl * t + rng.uniform(0, 2 * np.pi)) for fl in lines_hz)
    rec, _ = rerun(state, x, excitation_point=exc, measured_points=outs, plant="linear")
    k = np.round(np.asarray(lines_hz) / f0).astype(int)
    X = np.fft.rfft(x[-n_per:])[k]
    return np.column_stack([np.fft.rfft(np.asarray(rec[f"vel{p}"])[-n_per:])[k] / X for p in outs])


@pytest.fixture(scope="module")
def bcc_lab():
    from vlab.diagnose.model.labmodel import LabState
    from vlab.diagnose.model.nominal import nominal_design
    from vlab.experiment.config import default_chain
    from vlab.models import nominal_fe_model

    fe = nominal_fe_model("bcc")
    return LabState(fe.spec, fe, default_chain("mfdrf"), nominal_design(fe, "mfdrf", 0))


def test_model_matches_the_loop_with_a_per_channel_delay_and_lag(bcc_lab):
    from vlab.diagnose.model.labmodel import natural_frequencies, predict_frf

    st0 = bcc_lab
    acts = st0.actuators
    exc, outs = acts[-1], (6,) + acts
    ch = acts[0]  # the channel changed: not the excited one, so the change reaches the data only through the loop
    chain = replace(st0.chain, channel_delay_periods={ch: st0.chain.delay_periods + 1.5},
                    channel_sensor_lag_hz={acts[1]: 60.0})
    st1 = replace(st0, chain=chain)
    fn, _, _ = natural_frequencies(st0)
    f0 = 0.5
    lines = np.unique(np.round(np.r_[fn[(fn > 1) & (fn < 25)], 3.0, 11.0, 19.0] / f0) * f0)
    meas0 = _measured_frf(st0, lines, f0, exc, outs)
    meas1 = _measured_frf(st1, lines, f0, exc, outs)
    model0 = predict_frf(st0, lines, excitation_point=exc, output_points=outs)
    model1 = predict_frf(st1, lines, excitation_point=exc, output_points=outs)
    # the change is visible in the loop's data ...
    change = np.max(np.abs(np.log(meas1 / meas0)))
    assert change > 0.05
    # ... and the model predicts it: the measured change against the predicted one
    err = np.abs(np.log((meas1 / meas0) / (model1 / model0)))
    assert np.max(err) < 0.1 * change
    np.testing.assert_allclose(meas1, model1, rtol=0.05)
