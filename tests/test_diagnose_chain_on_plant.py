"""Recordings the MuJoCo plant made: a hidden lag of the hardware chain is named as a lag, at its corner
(vlab.diagnose.fit.plantfit.PlantModel's ``chain_refit``), and the detection threshold of the test such a
recording gets (vlab.diagnose.detectability, ``model_form="plant"``) holds on time-domain recordings; checked
against the values the lab ran with, not against an earlier output of the diagnosis."""

from __future__ import annotations

import pytest

from vlab.spec import load_spec

pytestmark = pytest.mark.slow


def test_a_hidden_actuator_lag_on_the_mujoco_plant_is_named_at_its_corner(tmp_path):
    pytest.importorskip("mujoco")
    import vlab
    from vlab.design import design_controller
    from vlab.experiment.config import ExperimentConfig, default_chain
    from vlab.experiment.runner import measure, slowest_decay_rate
    from vlab.fe import build_fe_model
    from vlab.io.uff import write_recording
    from vlab.sim import build_plant
    from vlab.sim.export import export_mjcf

    spec = load_spec("bcc")
    fe = build_fe_model(spec)
    lab = default_chain("lqdrf", noise_m_s=1e-6, channel_actuator_lag_hz={7: 139.2})  # hidden from the models
    design = design_controller(fe, "lqdrf", seed=0, period_s=lab.period_s)
    plant = export_mjcf(build_plant(spec), tmp_path / "plant.xml")
    cfg = ExperimentConfig(structure="bcc", controller="lqdrf", chain=lab, plant="mujoco", seed=3, mjcf=plant)
    m = measure(cfg, fe, design, decay_rate_1_s=slowest_decay_rate(fe, design))
    path = write_recording(tmp_path / "rec.uff", m.loop.recording, overwrite=False)
    d = vlab.diagnose(spec, path).as_dict()
    (sel,) = d["selected"]
    assert sel["effect"] == "actuator_lag" and sel["location"] == {"channel": 7}
    assert sel["parameters"]["corner_hz"] == pytest.approx(139.2, rel=0.003)
    assert d["value_reference"].startswith("the MuJoCo plant's linearisation")


def _mujoco_recording(tmp_path, spec, name: str, seed: int):
    """The open-loop test recorded on the MuJoCo plant built from ``spec`` (its metadata naming that plant)."""
    from vlab.experiment.config import ExperimentConfig, default_chain
    from vlab.experiment.runner import measure
    from vlab.fe import build_fe_model
    from vlab.io.uff import write_recording
    from vlab.sim import build_plant
    from vlab.sim.export import export_mjcf

    plant = export_mjcf(build_plant(spec), tmp_path / f"{name}.xml")
    cfg = ExperimentConfig(structure="bcc", controller="none", chain=default_chain("none", noise_m_s=1e-6),
                           plant="mujoco", seed=seed, mjcf=plant)
    rec = measure(cfg, build_fe_model(load_spec("bcc")), None).loop.recording
    return write_recording(tmp_path / f"{name}.uff", rec, overwrite=False)


def test_the_plant_tests_threshold_holds_on_recordings_of_the_plant(tmp_path):
    """The threshold of ``model_form="plant"`` (computed in the frequency domain on the linear FE plant's
    recording) against the diagnosis of time-domain recordings of the MuJoCo plant with a concealed mass at point
    6: at half the threshold no mismatch, at three times the mass named at its place within 10 %."""
    pytest.importorskip("mujoco")
    import vlab
    from vlab.diagnose.detectability import detectability
    from vlab.diagnose.effects import specedit

    spec = load_spec("bcc")
    (t,) = detectability(spec, "none", effects=("added_mass",), model_form="plant").of("added_mass", {"point": 6})
    half = vlab.diagnose(spec, _mujoco_recording(tmp_path, specedit.add_mass(spec, 6, t.scaled(0.5)), "half", 41))
    assert half.as_dict()["mismatch"] is False
    d = vlab.diagnose(spec, _mujoco_recording(tmp_path, specedit.add_mass(spec, 6, t.scaled(3.0)), "three", 42)).as_dict()
    (sel,) = d["selected"]
    assert sel["effect"] == "added_mass" and sel["location"] == {"point": 6}
    assert sel["parameters"]["mass_kg"] == pytest.approx(t.scaled(3.0), rel=0.1)
