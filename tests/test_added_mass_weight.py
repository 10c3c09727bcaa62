"""An added mass carries its weight into the plant's statics: the BCC hangs on its cross-cable, so a mass
attached to the beam raises the cable's tension by its weight (the closed form of a suspended structure),
and the plant's cable tendon is built with it. A body added to an exported MJCF file has no such weight in
MuJoCo (the plant moves out of plane only, and the tendons' stiffnesses are numbers in the file): loading
the file for an experiment carries it into the statics (vlab.sim.body_weights)."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from vlab.diagnose.effects import specedit
from vlab.sim import build_plant
from vlab.spec import load_spec
from vlab.units import G_SI


def _tensions(model: mujoco.MjModel) -> np.ndarray:
    """Tension [N] of each tendon at the settled (straight) state: stiffness x (length - spring length)."""
    d = mujoco.MjData(model)
    mujoco.mj_forward(model, d)
    return model.tendon_stiffness * (d.ten_length - model.tendon_lengthspring[:, 0])


def test_added_mass_adds_its_weight_to_the_cable_tension():
    spec = load_spec("bcc")
    m = 0.05
    before = _tensions(build_plant(spec).model)
    after = _tensions(build_plant(specedit.add_mass(spec, 5, m)).model)
    assert after.sum() - before.sum() == pytest.approx(m * G_SI, rel=1e-2)


def test_a_body_added_to_the_mjcf_does_not_change_the_cable(tmp_path):
    from vlab.sim.export import export_mjcf

    plant = build_plant(load_spec("bcc"))
    path = export_mjcf(plant, tmp_path / "bcc.xml")
    text = path.read_text()
    site = '<site name="p5" size="0.004" group="3"/>'
    assert site in text
    edited = text.replace(site, site + '<body name="mass5"><inertial pos="0 0 0" mass="0.05" '
                                        'diaginertia="1e-6 1e-6 1e-6"/></body>', 1)
    model = mujoco.MjModel.from_xml_string(edited)
    assert _tensions(model) == pytest.approx(_tensions(plant.model), rel=1e-5)  # the file's numbers (6 digits)


def _with_body(tmp_path, spec, site_point: int, mass: float, pos: str = "0 0 0"):
    from vlab.sim.export import export_mjcf

    plant = build_plant(spec)
    text = export_mjcf(plant, tmp_path / "plant.xml").read_text()
    site = f'<site name="p{site_point}" size="0.004" group="3"/>'
    assert site in text
    path = tmp_path / "edited.xml"
    path.write_text(text.replace(site, site + f'<body name="mass{site_point}" pos="{pos}"><inertial pos="0 0 0" '
                                              f'mass="{mass}" diaginertia="1e-6 1e-6 1e-6"/></body>', 1))
    return path


def test_loading_an_edited_mjcf_carries_the_added_mass_weight(tmp_path):
    """The loaded plant's statics are those of the structure with the mass: tensions as the plant built from
    the spec with it, to the file's six digits (and not those of the plant without it)."""
    from vlab.sim.runtime import load_plant_for_experiment

    spec = load_spec("bcc")
    plant, info = load_plant_for_experiment(spec, mjcf=_with_body(tmp_path, spec, 5, 0.05))
    assert "mass5 (0.05 kg at point 5)" in info["notes"][0]
    with_mass = _tensions(build_plant(specedit.add_mass(spec, 5, 0.05)).model)
    assert _tensions(plant.model) == pytest.approx(with_mass, rel=1e-5)  # the file's six digits
    assert _tensions(plant.model).sum() - _tensions(build_plant(spec).model).sum() == pytest.approx(0.05 * G_SI,
                                                                                                   rel=1e-2)


def test_an_added_body_off_every_site_is_refused_by_name(tmp_path):
    from vlab.errors import ModelError
    from vlab.sim.runtime import load_plant_for_experiment

    spec = load_spec("bcc")
    with pytest.raises(ModelError, match=r"edited.xml: body 'mass5' \(0.05 kg, no joint\) is at no structure point"):
        load_plant_for_experiment(spec, mjcf=_with_body(tmp_path, spec, 5, 0.05, pos="0.01 0 0"))


def test_without_in_plane_gravity_nothing_changes(tmp_path):
    """A structure whose gravity is out of plane (the beam template) has no in-plane statics: the body is the
    whole effect, and nothing is noted."""
    from vlab.sim.runtime import load_plant_for_experiment
    from vlab.templates import write_template

    spec = load_spec(str(write_template("beam", tmp_path / "beam.toml")))
    plant, info = load_plant_for_experiment(spec, mjcf=_with_body(tmp_path, spec, 5, 0.01))
    assert info["notes"] == []
