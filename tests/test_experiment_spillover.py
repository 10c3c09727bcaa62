"""The beam template's LQDRF-diag self-excites on the MuJoCo plant at ~258 Hz, and the experiment says why.

The loop's phase lag (1.35-period delay, hold, 677 Hz RC filter: ~107 deg at 258 Hz) turns the collocated
velocity feedback into negative damping at mode 4 (262 Hz). On the FE model that mode keeps the spec's
default ratio 0.01 and the sampled-data loop is stable (channel 5: gain margin 4.4 dB at 268.6 Hz); the
MuJoCo plant damps only the modes up to 1.25x the highest listed modal ratio (mode 3, 147 Hz), so its mode
4 keeps the hinge damping alone (zeta 0.0036) and the loop on its linearisation has an unstable pair.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from vlab.diagnose.fit.plantfit import plant_modes
from vlab.diagnose.model.labmodel import LabState
from vlab.diagnose.model.nominal import nominal_design
from vlab.diagnose.model.nyquist import loop_stability
from vlab.diagnose.instability_cause import oscillation_cause
from vlab.experiment.checks import oscillation_above_band
from vlab.fe import build_fe_model
from vlab.lab.loop import HardwareChain
from vlab.spec import load_spec
from vlab.templates import write_template


@pytest.fixture(scope="module")
def beam(tmp_path_factory):
    path = write_template("beam", tmp_path_factory.mktemp("beam") / "b.toml")
    fe = build_fe_model(load_spec(path))
    return path, fe, nominal_design(fe, "lqdrf-diag", 0)


def test_the_fe_loop_is_stable_and_the_mujoco_plants_is_not(beam):
    _path, fe, design = beam
    state = LabState(fe.spec, fe, HardwareChain(noise_m_s=0.0), design)
    assert loop_stability(state).unstable_poles == 0
    pm = plant_modes(fe.spec, tuple(fe.spec.instrumentation.actuators))
    f = pm.omega / (2 * np.pi)
    assert f[3] == pytest.approx(262.3, abs=0.5) and pm.zeta[3] < 0.005  # hinge damping alone
    assert loop_stability(replace(state, point_modes=pm)).unstable_poles == 2
    # growth between 2 and 4 1/s (shifted contours)
    assert loop_stability(replace(state, point_modes=pm), sigma_1_s=2.0).unstable_poles == 2
    assert loop_stability(replace(state, point_modes=pm), sigma_1_s=4.0).unstable_poles == 0
    # the plant's mode 4 with the FE model's ratio: stable again -- the damping, not the frequency, decides
    zeta = np.array(pm.zeta, dtype=float)
    zeta[3] = 0.01
    assert loop_stability(replace(state, point_modes=replace(pm, zeta=zeta))).unstable_poles == 0


def test_the_cause_names_the_mode_and_its_damping(beam):
    _path, fe, design = beam
    text = oscillation_cause(fe, design, HardwareChain(), 258.5, mujoco_plant=True)
    assert "on the FE model finds 0 unstable" in text
    assert "linearisation 2: its mode 4 at 262.3 Hz has damping ratio 0.0036" in text
    assert "FE model's mode 4 at 262.7 Hz 0.0100" in text and "modal_ratios" in text
    only_fe = oscillation_cause(fe, design, HardwareChain(), 258.5, mujoco_plant=False)
    assert "0 unstable" in only_fe and "MuJoCo" not in only_fe


def test_a_fourth_modal_ratio_damps_the_plants_mode_4(beam, tmp_path):
    path, _fe, design = beam
    text = path.read_text().replace("modal_ratios = [0.01, 0.01, 0.01]", "modal_ratios = [0.01, 0.01, 0.01, 0.01]")
    p4 = tmp_path / "b4.toml"
    p4.write_text(text)
    fe4 = build_fe_model(load_spec(p4))
    pm = plant_modes(fe4.spec, tuple(fe4.spec.instrumentation.actuators))
    assert pm.zeta[3] == pytest.approx(0.01, rel=0.01)
    state = LabState(fe4.spec, fe4, HardwareChain(noise_m_s=0.0), design, point_modes=pm)
    assert loop_stability(state).unstable_poles == 0


def test_oscillation_above_band():
    t = np.arange(20000) * 0.5e-3
    v = 0.01 * np.sin(2 * np.pi * 5 * t)
    assert oscillation_above_band(v, 0.5e-3, band_hz=(1, 100)) is None
    f, share = oscillation_above_band(v + 0.1 * np.sin(2 * np.pi * 258.5 * t), 0.5e-3, band_hz=(1, 100))
    assert f == pytest.approx(258.5, abs=0.1) and share > 0.9


@pytest.mark.long
def test_the_experiment_says_why_and_exits_1(beam, tmp_path):
    from typer.testing import CliRunner

    from vlab.cli import app

    path, _fe, _design = beam
    res = CliRunner().invoke(app, ["experiment", str(path), "--controller", "lqdrf-diag", "--out",
                                   str(tmp_path / "out")])
    assert res.exit_code == 1
    out = " ".join(res.output.split())
    assert "self-excited oscillation at 258" in out and "mode 4 at 262.3 Hz" in out
