"""A hidden lag of the hardware chain in a recording the MuJoCo plant made is named as a lag, at its corner
(vlab.diagnose.fit.plantfit.PlantModel's ``chain_refit``): checked against the value the lab ran with, not
against an earlier output of the diagnosis."""

from __future__ import annotations

import pytest

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
    from vlab.spec import load_spec

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
