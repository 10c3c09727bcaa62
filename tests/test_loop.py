"""The digital loop on the linear BCC plant against the sampled-data analysis."""

from __future__ import annotations

import numpy as np
import pytest

from vlab.analysis import closed_loop_frf, sampled_data_controller_frf, velocity_frf
from vlab.fe.damping import modal_damping_matrix, open_loop_ratios
from vlab.errors import SimulationError
from vlab.lab.engine import ControllerEngine
from vlab.lab.excitation import pseudo_random
from vlab.lab.linear_plant import LinearPlant
from vlab.lab.loop import HardwareChain, run_loop
from vlab.measure.frf import h1
from vlab.models import nominal_fe_model
from vlab.reference import bcc_gain

ACTS = (5, 7, 9)


@pytest.fixture(scope="module")
def bcc():
    fe = nominal_fe_model("bcc")
    c = modal_damping_matrix(fe.m, fe.k, open_loop_ratios(fe.spec, fe.n))
    pidx = {p: fe.dofs.index(p, "w") for p in range(1, 10)}
    return fe, c, pidx


def test_closed_loop_frf_matches_sampled_data_analysis(bcc):
    fe, c, pidx = bcc
    plant = LinearPlant(fe.m, c, fe.k, point_index=pidx, actuator_points=ACTS, timestep_s=0.25e-3)
    d = bcc_gain("mfdrf")
    eng = ControllerEngine.from_gain(d, period_s=0.5e-3)
    res_hz, dur = 0.1, 20.0
    r = run_loop(
        plant, eng, feedback_points=ACTS, measured_points=(6,), excitation_point=9,
        excitation=lambda t: pseudo_random(t, band_hz=(0.2, 25), resolution_hz=res_hz, rms_n=0.5, seed=1),
        duration_s=dur,
    )
    skip = int(10 / 0.5e-3)  # one period of transient
    frf = h1(r.recording["force9"][skip:], r.recording["vel6"][skip:], dt_s=0.5e-3,
             resolution_hz=res_hz, window="boxcar", f_max_hz=30)
    f = frf.freq_hz
    sel = (f > 1) & (f < 25)
    g = velocity_frf(fe.m, c, fe.k, fe.force_input(ACTS), fe.force_input(ACTS + (6,)).T, f[sel])
    k = sampled_data_controller_frf(f[sel], -d, np.zeros((3, 0)), np.zeros((0, 3)), np.zeros((0, 0)), 0.5e-3)
    h = closed_loop_frf(g[:, :3, :], g[:, 3:, :], k, excitation=2)[:, 0]
    # magnitudes: the excitation is held over each tick, a half-tick phase lag the analysis leaves out
    err = np.abs(np.abs(frf.h[sel]) / np.abs(h) - 1)
    assert np.median(err) < 0.01
    assert np.max(err[np.abs(h) > 0.3 * np.abs(h).max()]) < 0.02


def test_unstable_loop_stops_with_message_and_partial_recording(bcc):
    fe, c, pidx = bcc
    plant = LinearPlant(fe.m, c, fe.k, point_index=pidx, actuator_points=ACTS, timestep_s=0.5e-3)
    eng = ControllerEngine.from_gain(-50 * np.eye(3), period_s=0.5e-3)  # positive velocity feedback
    with pytest.raises(SimulationError, match="diverged at t =") as info:
        run_loop(plant, eng, feedback_points=ACTS, measured_points=(6,), excitation_point=9,
                 excitation=lambda t: np.where(t < 0.01, 1.0, 0.0), duration_s=30.0)
    partial = info.value.partial
    assert 0 < partial.recording.n_samples < 60000


def test_open_loop_without_engine_and_bad_step():
    fe = nominal_fe_model("bcc")
    pidx = {p: fe.dofs.index(p, "w") for p in range(1, 10)}
    plant = LinearPlant(fe.m, 0 * fe.m, fe.k, point_index=pidx, actuator_points=ACTS, timestep_s=0.3e-3)
    with pytest.raises(Exception, match="divide"):
        run_loop(plant, None, feedback_points=ACTS, measured_points=(6,), excitation_point=9,
                 excitation=lambda t: 0 * t, duration_s=1.0, chain=HardwareChain())
