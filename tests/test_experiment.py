"""The experiment pipeline end to end on the linear BCC plant (fast)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from vlab.cli import app
from vlab.errors import MeasurementError, ModelError
from vlab.experiment.results import write_outputs
from vlab.io.uff import read_frfs, read_recording
from vlab.experiment.config import ExperimentConfig, default_chain
from vlab.experiment.runner import run_experiment
from vlab.lab.loop import HardwareChain
from vlab.models import nominal_fe_model
from vlab.viz.rerun_log import rrd_entity_paths


def test_default_chain_takes_exactly_the_hardware_chain_settings():
    """Every HardwareChain field by name, nothing else: a misspelt setting is a TypeError, not ignored."""
    import dataclasses
    import inspect

    fields = {f.name for f in dataclasses.fields(HardwareChain)}
    assert set(inspect.signature(default_chain).parameters) - {"controller"} == fields
    assert default_chain("lqg") == HardwareChain(period_s=1e-3)  # the thesis's LQG period (Sec. 5.3)
    assert default_chain("mfdrf", noise_m_s=1e-6) == HardwareChain(period_s=0.5e-3, noise_m_s=1e-6)
    assert default_chain("lqg", period_s=0.5e-3, channel_limit_n={5: 2.0}).channel_limit_n == {5: 2.0}
    with pytest.raises(TypeError):
        default_chain("mfdrf", noise=1e-6)
    with pytest.raises(ModelError, match="unknown controller"):
        default_chain("nope", period_s=1e-3)


@pytest.fixture(scope="module")
def fe():
    return nominal_fe_model("bcc")


@pytest.fixture(scope="module")
def mfdrf_run(fe):
    return run_experiment(ExperimentConfig(plant="linear", resolution_hz=0.1, periods=2), fe)


def test_open_loop_measured_frequencies_match_fe_model(fe):
    from vlab.fe import modal_analysis

    r = run_experiment(ExperimentConfig(controller="none", plant="linear", resolution_hz=0.05, periods=3), fe)
    f_fe = modal_analysis(fe.m, fe.k, 6).frequencies_hz
    f_meas = np.array([m.frequency_measured_hz for m in r.modes])
    np.testing.assert_allclose(f_meas, f_fe, rtol=2e-3)


def test_mfdrf_measured_matches_sampled_data_analysis(mfdrf_run):
    for m in mfdrf_run.modes:
        assert m.frequency_measured_hz == pytest.approx(m.frequency_predicted_hz, rel=0.01)
        assert m.damping_measured == pytest.approx(m.damping_predicted, rel=0.10)
        assert 0.9 < m.peak_level_ratio < 1.1
    assert mfdrf_run.avg_peak_error < 0.05


def test_outputs_reload(mfdrf_run, fe, tmp_path):
    files = write_outputs(mfdrf_run, fe.spec, tmp_path)
    rec = read_recording(files["recording"])
    assert set(rec.names) >= {"force9", "vel6", "vel5", "vel7", "vel9"}
    assert rec.dt_s == pytest.approx(0.5e-3)
    frfs = read_frfs(files["frf"])
    assert any(f.output_point == 6 for f in frfs)
    res = json.loads(files["results"].read_text())
    for key in ("structure", "controller", "modes", "avg_peak_error"):
        assert key in res
    assert len(res["modes"]) == 6
    paths = rrd_entity_paths(files["rerun"])
    assert "signals/vel6" in paths and "structure/members" in paths
    assert any(p.startswith("frf/") for p in paths)
    assert files["figure"].stat().st_size > 10_000


def test_bad_requests_are_clear(fe):
    with pytest.raises(ModelError, match="LQR needs"):
        run_experiment(ExperimentConfig(controller="lqr", plant="linear"), fe)
    with pytest.raises(MeasurementError, match="too short"):
        run_experiment(ExperimentConfig(plant="linear", duration_s=5.0), fe)


def test_cli_unknown_controller():
    res = CliRunner().invoke(app, ["experiment", "bcc", "--controller", "pid"])
    assert res.exit_code != 0 and "pid" in res.output


def test_self_excited_oscillation_is_flagged():
    from vlab.experiment.checks import self_excited_oscillation

    t = np.arange(40000) * 0.5e-3
    quiet = 0.01 * np.sin(2 * np.pi * 5 * t)
    assert self_excited_oscillation(quiet, 0.5e-3, band_hz=(0.5, 25)) == []
    loud = quiet + 0.1 * np.sin(2 * np.pi * 65.6 * t)
    msg = self_excited_oscillation(loud, 0.5e-3, band_hz=(0.5, 25))
    assert msg and "65.6 Hz" in msg[0]


def test_mfdrf_on_the_mujoco_plant_meets_the_issue_targets(fe):
    """BCC MFDRF on the MuJoCo plant: frequencies within 1 %, peak level ratios 0.9-1.1."""
    r = run_experiment(ExperimentConfig(plant="mujoco", resolution_hz=0.1, periods=2), fe)
    assert not r.warnings
    for m in r.modes:
        assert m.frequency_measured_hz == pytest.approx(m.frequency_predicted_hz, rel=0.01)
        assert 0.9 < m.peak_level_ratio < 1.1
    assert r.avg_peak_error < 0.08  # the 1990 hardware reached 0.08 (Table 10)
