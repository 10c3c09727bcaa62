"""Warm-started reruns (vlab.diagnose.data.warmstart): the periodic steady state replaces the settling periods.

Each check compares a rerun started in the steady state with the same rerun
started from rest and run through the settling periods (the reference, made
by the unchanged loop), over the periods a diagnosis analyses.
"""

from __future__ import annotations

import numpy as np
import pytest

from vlab.diagnose.data.measured import FrfData
from vlab.diagnose.data.replay import frf_of, rerun, time_error
from vlab.diagnose.data.warmstart import GUARD_PERIODS, RERUN_PERIODS, excitation_lines, rerun_window, start_tick
from vlab.diagnose.model.labmodel import LabState
from vlab.diagnose.model.nominal import nominal_design
from vlab.diagnose.validate import _on_recording_axis
from vlab.errors import ModelError
from vlab.lab.excitation import pseudo_random
from vlab.experiment.config import TESTS, default_chain
from vlab.io.recording import Recording
from vlab.models import nominal_fe_model

RES_HZ = 0.5  # 2 s periods
PERIODS = 6


def _lab(structure: str, controller: str) -> LabState:
    fe = nominal_fe_model(structure)
    return LabState(fe.spec, fe, default_chain(controller, noise_m_s=0.0), nominal_design(fe, controller, 0))


def _force(state: LabState) -> tuple[np.ndarray, int]:
    dt = state.chain.period_s
    n_per = int(round(1 / (RES_HZ * dt)))
    t = np.arange(PERIODS * n_per) * dt
    test = TESTS[state.spec.name]
    return pseudo_random(t, band_hz=test.band_hz, resolution_hz=RES_HZ, rms_n=test.rms_n, seed=3), n_per


def _last_period_difference(state: LabState, plant: str, start_periods: int) -> float:
    """Relative difference, over the last period, of a rerun warm-started ``start_periods`` periods in and
    one from rest."""
    force, n_per = _force(state)
    exc = state.spec.instrumentation.excitation
    pts = state.actuators
    cold, _ = rerun(state, force, excitation_point=exc, measured_points=pts, plant=plant)
    warm, _ = rerun(state, force, excitation_point=exc, measured_points=pts, plant=plant,
                    start=start_periods * n_per, period=n_per)
    assert warm.metadata["start_s"] == pytest.approx(start_periods * n_per * state.chain.period_s)
    assert warm.n_samples == cold.n_samples - start_periods * n_per
    a = np.column_stack([np.asarray(cold[f"vel{p}"])[-n_per:] for p in pts])
    b = np.column_stack([np.asarray(warm[f"vel{p}"])[-n_per:] for p in pts])
    return float(np.linalg.norm(b - a) / np.linalg.norm(a))


@pytest.mark.parametrize("controller", ["mfdrf", "lqg"])
def test_warm_start_on_the_linear_plant_is_the_settled_run(controller):
    """Linear BCC plant, closed loop (LQG: the controller's state is started too): a period after the warm
    start it agrees with the run from rest to 0.01 %."""
    assert _last_period_difference(_lab("bcc", controller), "linear", PERIODS - 2) < 1e-4


def test_warm_start_is_periodic_on_the_slow_grid():
    """The grid's mode 1 decays with tau = 7 s, longer than this whole run, so there is no settled reference:
    two warm starts, four periods apart, must give the same last period (a wrong start would still ring)."""
    lab = _lab("grid", "none")
    force, n_per = _force(lab)
    exc = lab.spec.instrumentation.excitation
    runs = [rerun(lab, force, excitation_point=exc, measured_points=lab.actuators, plant="linear", start=k * n_per,
                  period=n_per)[0] for k in (1, PERIODS - 1)]
    a, b = (np.column_stack([np.asarray(r[f"vel{p}"])[-n_per:] for p in lab.actuators]) for r in runs)
    assert np.linalg.norm(b - a) / np.linalg.norm(a) < 1e-3


def test_warm_start_on_the_mujoco_plant_is_the_settled_run():
    """MuJoCo BCC with MFDRF: started in its own modes' steady state, one period later it agrees with the
    run from rest to 0.5 % (modes above the modal model and the plant's small nonlinearity decay)."""
    pytest.importorskip("mujoco")
    assert _last_period_difference(_lab("bcc", "mfdrf"), "mujoco", PERIODS - 2) < 5e-3


def test_rerun_window_is_one_guard_period_before_the_analysed_part():
    dt = 5e-4
    lines = np.arange(1, 21) * RES_HZ
    rec = Recording.from_signals(dt, {"force9": np.zeros(10), "vel9": np.zeros(10)})
    n_per = int(round(1 / (RES_HZ * dt)))
    data = FrfData("x", "recording", lines, np.ones((20, 1)), np.ones((20, 1)), 9, (9,), recording=rec,
                   analysed_from_s=3 * n_per * dt)
    assert start_tick(data, dt) == (3 - GUARD_PERIODS) * n_per
    assert rerun_window(data, dt) == ((3 - GUARD_PERIODS) * n_per, n_per, (3 + RERUN_PERIODS) * n_per)
    assert rerun_window(data, dt, None) == ((3 - GUARD_PERIODS) * n_per, n_per, None)  # to the end
    one = FrfData("x", "recording", lines, np.ones((20, 1)), np.ones((20, 1)), 9, (9,), recording=rec,
                  analysed_from_s=GUARD_PERIODS * n_per * dt)
    assert rerun_window(one, dt) == (0, 0, None)  # nothing to skip: from rest, through every analysed period
    h1 = FrfData("x", "recording", lines, np.ones((20, 1)), np.ones((20, 1)), 9, (9,), recording=rec,
                 analysed_from_s=3 * n_per * dt, periodic=False)
    assert rerun_window(h1, dt) == (0, 0, None)  # H1 with a window over the whole record: from rest


def test_excitation_lines_rebuild_the_period():
    dt = 5e-4
    n = 4000
    t = np.arange(n) * dt
    x = 0.3 * np.cos(2 * np.pi * 1.5 * t + 0.4) + 0.1 * np.sin(2 * np.pi * 7.0 * t)
    f, ph = excitation_lines(x, dt)
    np.testing.assert_allclose(f, [1.5, 7.0])
    back = np.real(ph[None, :] * np.exp(2j * np.pi * f[None, :] * t[:, None])).sum(axis=1)
    np.testing.assert_allclose(back, x, atol=1e-12)


def test_frf_and_time_error_align_a_warm_started_rerun():
    """A rerun that begins later (metadata ``start_s``) is compared with the recording on the same samples."""
    lab = _lab("bcc", "mfdrf")
    force, n_per = _force(lab)
    exc = lab.spec.instrumentation.excitation
    pts = lab.actuators
    cold, _ = rerun(lab, force, excitation_point=exc, measured_points=pts, plant="linear")
    warm, _ = rerun(lab, force, excitation_point=exc, measured_points=pts, plant="linear", start=2 * n_per,
                    period=n_per)
    lines = np.arange(1, 30) * RES_HZ
    data = FrfData("x", "recording", lines, np.ones((lines.size, len(pts))), np.ones((lines.size, len(pts))), exc,
                   pts, recording=cold, analysed_from_s=4 * n_per * lab.chain.period_s)
    np.testing.assert_allclose(frf_of(warm, data), frf_of(cold, data), rtol=1e-3)
    assert time_error(cold, data) == 0.0
    assert time_error(warm, data) < 1e-3
    short, _ = rerun(lab, force, excitation_point=exc, measured_points=pts, plant="linear", start=3 * n_per,
                     period=n_per, stop=5 * n_per)  # one of the two analysed periods
    assert short.n_samples == 2 * n_per and time_error(short, data) < 1e-3
    v = _on_recording_axis(warm, pts[0], cold)
    assert v.shape == (cold.n_samples,) and np.all(np.isnan(v[: 2 * n_per])) and np.all(np.isfinite(v[2 * n_per:]))


def test_warm_start_needs_a_whole_period_of_force():
    lab = _lab("bcc", "mfdrf")
    force, n_per = _force(lab)
    with pytest.raises(ModelError, match="needs a period"):
        rerun(lab, force, excitation_point=lab.spec.instrumentation.excitation, measured_points=lab.actuators,
              start=(PERIODS - 1) * n_per + 1, period=n_per)


def test_warm_start_with_friction_starts_from_its_describing_function():
    """Coulomb friction decays a wrong start only slowly (linearly in time), so the warm start puts the
    friction plant in the steady state of its describing function: the same state as a linear plant with
    the equivalent dashpot at that point (on benchmark case 8 of seed 1 the rerun's time error went from
    0.028, friction left out of the start, to 0.014; 0.015 from rest)."""
    from dataclasses import replace

    from vlab.diagnose.data import replay as vmod

    lab = _lab("bcc", "none")
    c_eq = 0.4
    fric = vmod.linear_plant(replace(lab, frictions=((6, 0.01, c_eq),)))
    dash = vmod.linear_plant(replace(lab, dashpots=((6, c_eq),)))
    f = np.array([1.5, 4.8, 9.0])
    forces = np.zeros((3, len(lab.actuators)), dtype=complex)
    forces[:, 0] = [0.1, 0.05j, 0.02]
    fric.set_periodic_state(f, forces)
    dash.set_periodic_state(f, forces)
    np.testing.assert_allclose(fric.inner.x, dash.x, rtol=1e-9, atol=1e-15)
    fric0 = vmod.linear_plant(replace(lab, frictions=((6, 0.01, 0.0),)))
    fric0.set_periodic_state(f, forces)
    assert np.linalg.norm(fric0.inner.x - dash.x) > 1e-3 * np.linalg.norm(dash.x)  # the dashpot matters here


def test_extra_damping_at_an_unknown_point_or_negative_is_refused():
    from dataclasses import replace

    from vlab.diagnose.data import replay as vmod

    lab = _lab("bcc", "none")
    plant = vmod.linear_plant(replace(lab, dashpots=((6, 0.4),)))
    f, forces = np.array([1.5]), np.full((1, len(lab.actuators)), 0.1, dtype=complex)
    with pytest.raises(ModelError, match="damped point 999 has no DOF"):
        plant.set_periodic_state(f, forces, extra_damping={999: 0.4})
    with pytest.raises(ModelError, match="dashpot at point 6 must be finite and >= 0"):
        plant.set_periodic_state(f, forces, extra_damping={6: -1.0})
