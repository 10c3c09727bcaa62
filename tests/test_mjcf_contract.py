"""An edited MJCF is measured as edited, or refused.

The plant's recorded velocities come from its own ``vel<ID>`` sensors, at the
sampling instant; edits vlab cannot honour are refused naming the file and the
element. References are independent of vlab's runtime: MuJoCo's own
``mj_forward`` / ``mj_objectVelocity`` on a copy of the state, ``np.clip``.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import mujoco
import numpy as np
import pytest

from vlab.errors import DataFileError, ModelError, SimulationError
from vlab.experiment.config import ExperimentConfig
from vlab.experiment.runner import make_plant
from vlab.sim import MujocoPlant, export_mjcf, load_plant_for_experiment

from _plants import structure_fixtures


spec, plant = structure_fixtures("bcc")


@pytest.fixture(scope="module")
def exported(plant, tmp_path_factory):
    return export_mjcf(plant, tmp_path_factory.mktemp("mjcf") / "bcc.xml")


def _edit(src: Path, dst: Path, edit) -> Path:
    """Copy the MJCF ``src`` to ``dst`` after ``edit(sensor_element, actuator_element)`` changes its tree."""
    tree = ET.parse(src)
    root = tree.getroot()
    edit(root.find("sensor"), root.find("actuator"))
    tree.write(dst)
    return dst


def _named(parent, name):
    return next(e for e in parent if e.get("name") == name)


def _state_copy_forward(sim: MujocoPlant) -> mujoco.MjData:
    """A fresh MjData with the plant's state, through MuJoCo's full mj_forward (the reference)."""
    d = mujoco.MjData(sim.model)
    d.qpos[:] = sim.data.qpos
    d.qvel[:] = sim.data.qvel
    d.ctrl[:] = sim.data.ctrl
    d.time = sim.data.time
    mujoco.mj_forward(sim.model, d)
    return d


def _site_vz(model, data, site: str) -> float:
    v = np.zeros(6)
    mujoco.mj_objectVelocity(model, data, mujoco.mjtObj.mjOBJ_SITE, model.site(site).id, v, 0)
    return float(v[5])


def _drive(sim: MujocoPlant, steps: int = 40) -> None:
    sim.set_forces(np.array([1.0, -0.5, 0.8])[: len(sim.actuator_points)])
    sim.step(steps)


def _rename_actuator(s, a):
    _named(a, "coil7").set("name", "shaker7")
    _named(s, "vel7").set("actuator", "shaker7")


def _delay_sensor(s, a):
    _named(s, "vel5").set("nsample", "4")
    _named(s, "vel5").set("delay", "0.001")


def _retype_sensor(s, a):
    _named(s, "vel6").tag = "framepos"


# (file name, edit, message pattern, error) of the edits vlab cannot honour: each is refused naming the file and
# the element. MuJoCo sensors have no gain: a gain attribute is refused when the file is read, naming it.
REFUSED_EDITS = [
    pytest.param("no_vel6.xml", lambda s, a: s.remove(_named(s, "vel6")), r"no_vel6\.xml.*sensor vel6 .*missing",
                 ModelError, id="removed_sensor"),
    pytest.param("renamed.xml", lambda s, a: _named(s, "vel6").set("name", "velocity6"),
                 r"renamed\.xml.*sensor vel6 .*missing.*velocity6", ModelError,
                 id="renamed_sensor_and_the_new_name_reported"),
    pytest.param("shaker.xml", _rename_actuator, r"shaker\.xml.*actuator coil7 .*missing.*shaker7", ModelError,
                 id="renamed_actuator"),
    pytest.param("noisy.xml", lambda s, a: _named(s, "vel6").set("noise", "0.1"),
                 r"noisy\.xml.*sensor vel6 has noise=\"0\.1\".*--noise", ModelError,
                 id="sensor_noise_naming_the_attribute_and_the_lab_option"),
    pytest.param("late.xml", _delay_sensor, r"late\.xml.*sensor vel5 has delay.*sensor vel5 has nsample", ModelError,
                 id="sensor_delay"),
    pytest.param("pos6.xml", _retype_sensor, r"pos6\.xml.*sensor vel6 has type mjSENS_FRAMEPOS", ModelError,
                 id="sensor_of_another_type"),
    pytest.param("gain.xml", lambda s, a: _named(s, "vel6").set("gain", "2"), r"gain\.xml", DataFileError,
                 id="sensor_gain_attribute"),
]


@pytest.mark.parametrize("name, edit, match, error", REFUSED_EDITS)
def test_an_edit_vlab_cannot_honour_is_refused(spec, exported, tmp_path, name, edit, match, error):
    path = _edit(exported, tmp_path / name, edit)
    with pytest.raises(error, match=match):
        load_plant_for_experiment(spec, mjcf=path)


def test_sensor_moved_to_another_site_measures_there(spec, exported, tmp_path):
    """vel6 redefined on site p3: the recording is p3's velocity at the sampling instant, not p6's."""
    path = _edit(exported, tmp_path / "moved.xml", lambda s, a: _named(s, "vel6").set("objname", "p3"))
    sim, _ = load_plant_for_experiment(spec, mjcf=path)
    _drive(sim)
    v6 = sim.velocities((6,))[0]
    ref = _state_copy_forward(sim)
    assert v6 == pytest.approx(_site_vz(sim.model, ref, "p3"), rel=1e-12, abs=1e-15)
    assert abs(v6 - _site_vz(sim.model, ref, "p6")) > 1e-3 * abs(v6)


def test_sensor_cutoff_is_honoured_as_a_clip(spec, exported, tmp_path):
    sim0, _ = load_plant_for_experiment(spec, mjcf=exported)
    _drive(sim0)
    ref = _site_vz(sim0.model, _state_copy_forward(sim0), "p6")
    cut = 0.5 * abs(ref)
    path = _edit(exported, tmp_path / "cut.xml", lambda s, a: _named(s, "vel6").set("cutoff", repr(cut)))
    sim, _ = load_plant_for_experiment(spec, mjcf=path)
    _drive(sim)
    assert sim.velocities((6,))[0] == pytest.approx(np.clip(ref, -cut, cut), rel=1e-12)
    assert sim.velocities((5,))[0] == pytest.approx(sim0.velocities((5,))[0], rel=1e-12)


def test_mjcf_plant_has_no_site_fallback(spec, exported):
    sim, _ = load_plant_for_experiment(spec, mjcf=exported)
    with pytest.raises(SimulationError, match="no velocity sensor vel3"):
        sim.velocities((3,))


@pytest.mark.parametrize("steps", [1, 7])
def test_readings_are_at_the_sampling_instant(plant, steps):
    """After step(), velocities and displacements are those of the current state (not one step late)."""
    sim = MujocoPlant(plant)
    _drive(sim, steps)
    ref = _state_copy_forward(sim)
    pts = (5, 6, 7, 9)
    rows = [sim.model.sensor(f"vel{p}").adr[0] + (2 if p == 6 else 0) for p in pts]
    np.testing.assert_allclose(sim.velocities(pts), ref.sensordata[rows], rtol=1e-12, atol=1e-16)
    np.testing.assert_allclose(sim.velocities(pts), [_site_vz(sim.model, ref, f"p{p}") for p in pts], rtol=1e-9)
    z0 = MujocoPlant(plant).displacements(pts)  # settled state: zero
    assert np.all(z0 == 0.0)
    settled = sim._ref.site_xpos[[sim.model.site(f"p{p}").id for p in pts], 2]
    np.testing.assert_allclose(sim.displacements(pts),
                               ref.site_xpos[[sim.model.site(f"p{p}").id for p in pts], 2] - settled,
                               rtol=1e-12, atol=1e-18)


def test_reading_does_not_change_the_trajectory(plant):
    a, b = MujocoPlant(plant), MujocoPlant(plant)
    f = np.array([1.0, -0.5, 0.8])
    for _ in range(50):
        a.set_forces(f)
        b.set_forces(f)
        a.velocities((5, 6, 7, 9))
        a.displacements((5, 6))
        a.step()
        b.step()
    assert np.array_equal(a.data.qpos, b.data.qpos) and np.array_equal(a.data.qvel, b.data.qvel)


def test_mjcf_with_the_linear_plant_is_refused(exported):
    cfg = ExperimentConfig(structure="bcc", plant="linear", mjcf=exported)
    with pytest.raises(ModelError, match=r"--mjcf .*bcc\.xml.*--plant linear"):
        make_plant(cfg, None, (5, 7, 9))


def test_experiment_plant_from_mjcf_checks_the_measured_points(exported, tmp_path):
    from vlab.models import nominal_fe_model

    fe = nominal_fe_model("bcc")
    sim, info = make_plant(ExperimentConfig(structure="bcc", mjcf=exported), fe, (5, 7, 9))
    assert sim.sensor_points == (5, 6, 7, 9) and info["source"] == str(exported)
    path = _edit(exported, tmp_path / "no_vel9.xml", lambda s, a: s.remove(_named(s, "vel9")))
    with pytest.raises(ModelError, match=r"no_vel9\.xml.*sensor vel9 .*missing"):
        make_plant(ExperimentConfig(structure="bcc", mjcf=path), fe, (5, 7, 9))


def test_export_header_names_the_structure_and_file_only(plant, spec, exported):
    text = exported.read_text()
    header = text[text.index("<!--"): text.index("-->")]
    assert "'Beam Cross-Cable' (bcc)" in header and "built from bcc.toml " in header
    assert str(Path(spec.path).parent) not in text and str(Path.home()) not in text
    assert "/" not in header and "\\" not in header
