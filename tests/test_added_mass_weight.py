"""An added mass carries its weight into the plant's statics: the BCC hangs on its cross-cable, so a mass
attached to the beam raises the cable's tension by its weight (the closed form of a suspended structure),
and the plant's cable tendon is built with it. A body added to an exported MJCF file has no such weight
(docs/mjcf.md): MuJoCo moves the plant out of plane only, and the tendons' stiffnesses are numbers in
the file."""

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
