"""Phase of the digital loop (ZOH + 1.35-period delay + 677 Hz RC) with a probe plant.

The probe plant returns a chosen sinusoid as its sensor velocity, whatever
force it gets, and records the force applied over each physics step. With a
pass-through controller (``u_k = y_k``) the forces are the chain's response
to the sampled sinusoid, and their phase is compared with a closed form
derived here, independent of vlab.

Exact phase of the step-averaged chain
--------------------------------------
Sensor ``y_k = Im e^{jw t_k}``, ``t_k = k T``. The zero-order-held staircase
of the samples, delayed by ``D T`` and passed through the RC filter
``1 / (1 + j w tau)``, ``tau = 1 / (2 pi f_c)``, is (complex form)::

    x(t) = sum_n X_n e^{j w_n t},   w_n = w + 2 pi n / T,
    X_n  = (1 - e^{-j w T}) / (j w_n T) * e^{-j w_n D T} / (1 + j w_n tau)

(the staircase of ``e^{j w t_k} = e^{j w_n t_k}`` has the hold's transfer
``(1 - e^{-j w_n T}) / (j w_n T)`` at every ``w_n``, and
``e^{-j w_n T} = e^{-j w T}``). The ``n = 0`` term is the fundamental; its
phase lag is exactly ``w T / 2 + D w T + atan(f / f_c)`` (the hold's
``(1 - e^{-jwT}) / (jwT) = e^{-jwT/2} sin(wT/2) / (wT/2)`` has phase
``-wT/2`` exactly for ``wT < 2 pi``).

A plant stepped at ``h = T / N`` sees the average of ``x`` over each step.
The average of ``e^{j w_n t}`` over ``[t_i, t_i + h]`` is
``e^{j w_n t_i} (e^{j w_n h} - 1) / (j w_n h)``; for ``n = m N`` it equals
``e^{j w t_i} (e^{j w h} - 1) / (j w_n h)``, i.e. the step average of
``e^{j w t}`` times ``w / w_n``: these images fold onto ``w``. The other
images are orthogonal to ``w`` over a window of whole cycles and whole
controller periods. A least-squares fit of the step averages of
``cos w t`` and ``sin w t`` to the forces therefore returns the complex
amplitude::

    C = sum_m X_{mN} * w / w_{mN}

whose phase lag ``-arg C`` is the reference here. Its ``m = 0`` term is the
formula above; the folded images (``m != 0``) change it by at most
0.0075 deg at ``N = 2`` and 1 to 200 Hz, but by 0.12 deg at 200 Hz for
``N = 1`` (``h = T``): there the step averages cannot carry the
fundamental's phase, whatever the loop does. Both are checked.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from vlab.lab.blocks import PC1000_DELAY_PERIODS, PC1000_PERIOD_S, RC_CORNER_HZ
from vlab.lab.engine import ControllerEngine
from vlab.lab.loop import HardwareChain, run_loop

T = PC1000_PERIOD_S
D = PC1000_DELAY_PERIODS
FC = RC_CORNER_HZ
#: Physics steps the plants use: MuJoCo BCC/grid (0.5 ms, 0.25 ms, T/17, T/20), linear plant T/2.
STEPS_S = (0.5e-3, 0.25e-3, 0.5e-3 / 17, 2.5e-5)
#: Test frequencies [Hz]: each period is a whole number of controller periods.
FREQS_HZ = (1.0, 4.0, 25.0, 62.5, 100.0, 200.0)


class ProbePlant:
    """Plant of the loop's protocol whose sensor reads ``sin(w t)`` and that records the applied forces."""

    def __init__(self, *, timestep_s: float, freq_hz: float, gain: float = 1.0):
        self.timestep_s = timestep_s
        self.actuator_points = (1,)
        self.w = 2 * math.pi * freq_hz
        self.gain = gain
        self.n = 0
        self._f = np.zeros(1)
        self.forces: list[float] = []

    def set_forces(self, forces):
        self._f = np.array(forces, dtype=float)

    def step(self):
        self.forces.append(float(self._f[0]))
        self.n += 1

    def velocities(self, points):
        return np.full(len(points), self.gain * math.sin(self.w * self.n * self.timestep_s))

    def displacements(self, points):
        return np.zeros(len(points))


def expected_lag_deg(f: float, n_sub: int, *, images: bool = True, m_max: int = 20000) -> float:
    """Phase lag [deg] of the least-squares fit to the step averages (module docstring)."""
    w = 2 * math.pi * f
    tau = 1 / (2 * math.pi * FC)
    m = np.arange(-m_max, m_max + 1) if images else np.array([0])
    wn = w + 2 * math.pi * m * n_sub / T
    x = (1 - np.exp(-1j * w * T)) / (1j * wn * T) * np.exp(-1j * wn * D * T) / (1 + 1j * wn * tau)
    return -math.degrees(np.angle(np.sum(x * w / wn)))


def simple_lag_deg(f: float) -> float:
    """``w T / 2 + D w T + atan(f / f_c)`` [deg]."""
    w = 2 * math.pi * f
    return math.degrees(w * T / 2 + D * w * T + math.atan(f / FC))


def measured_lag_deg(h: float, f: float) -> float:
    """Run the loop with the probe plant and fit the phase lag [deg] of the force behind the sensor."""
    plant = ProbePlant(timestep_s=h, freq_hz=f)
    eng = ControllerEngine(np.eye(1), period_s=T)  # u_k = y_k
    settle = 0.02
    dur = settle + max(1.0, 2.0 / f) if f < 10 else settle + 10.0 / f
    run_loop(plant, eng, feedback_points=(1,), measured_points=(), excitation_point=1,
             excitation=lambda t: np.zeros_like(t), duration_s=dur, shape_points=())
    frc = np.array(plant.forces)
    i0 = int(round(settle / h))
    n_win = int(round(math.floor((len(frc) * h - settle) * f + 1e-9) / f / h))
    t = (i0 + np.arange(n_win)) * h
    w = 2 * math.pi * f
    cbar = (np.sin(w * (t + h)) - np.sin(w * t)) / (w * h)     # step average of cos(w t)
    sbar = (np.cos(w * t) - np.cos(w * (t + h))) / (w * h)     # step average of sin(w t)
    (a, b), *_ = np.linalg.lstsq(np.column_stack([cbar, sbar]), frc[i0:i0 + n_win], rcond=None)
    # a cos + b sin = A sin(w t - phi): b = A cos phi, a = -A sin phi
    return math.degrees(math.atan2(-a, b))


def test_reference_is_the_fundamental_plus_folded_images():
    # the m = 0 term is the closed-form phase; the images matter only at h = T
    for f in FREQS_HZ:
        assert expected_lag_deg(f, 1, images=False) == pytest.approx(simple_lag_deg(f), abs=1e-9)
        assert abs(expected_lag_deg(f, 2) - simple_lag_deg(f)) < 0.0076
        for n in (17, 20):
            assert abs(expected_lag_deg(f, n) - simple_lag_deg(f)) < 1e-4
    assert expected_lag_deg(200.0, 1) - simple_lag_deg(200.0) > 0.1


@pytest.mark.parametrize("h", STEPS_S, ids=lambda h: f"h={h:.4g}")
def test_loop_phase_equals_hold_delay_and_rc_at_every_physics_step(h):
    n_sub = int(round(T / h))
    for f in FREQS_HZ:
        lag = measured_lag_deg(h, f)
        # the exact phase of the step averages (fundamental + folded images)
        assert lag == pytest.approx(expected_lag_deg(f, n_sub), abs=1e-6), f"f = {f} Hz"
        if n_sub > 1:
            # w T/2 + 1.35 w T + atan(f / 677 Hz) within 0.01 deg
            assert abs(lag - simple_lag_deg(f)) < 0.01, f"f = {f} Hz"


def test_loop_phase_at_25_hz_and_half_ms_step():
    # 25 Hz, h = T: 10.44 deg (8.93 deg when the RC's end-of-step value led by h/2)
    lag = measured_lag_deg(0.5e-3, 25.0)
    assert lag == pytest.approx(simple_lag_deg(25.0), abs=0.01)
    assert simple_lag_deg(25.0) == pytest.approx(10.44, abs=0.005)
