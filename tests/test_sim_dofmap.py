"""The DOFs of a changed structure's plant matched to the unchanged one's by place, and its damping carried.

Checks: two hand-written MJCF chains (the same joints at the same places, once as a chain, once hung from
the world) are told apart by the kinematic check; a softened joint and a scaled segment (the member cut
into renamed pieces) keep the unchanged plant's damping matrix, so that the plant's modal damping ratios
move as the FE model's fixed damping matrix makes them move (:func:`vlab.fe.damping.structural_damping`,
an independent model of the same structure).
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from vlab.diagnose.effects import specedit
from vlab.fe import build_fe_model, modal_analysis
from vlab.fe.damping import structural_damping
from vlab.sim import build_plant, modes
from vlab.sim.dofmap import dof_permutation
from vlab.spec import load_spec

CHAIN = """<mujoco><worldbody>
  <body name="a"><joint name="{ja}" type="hinge" axis="0 1 0" pos="0 0 0"/>
    <geom type="capsule" fromto="0 0 0 1 0 0" size="0.01" mass="1"/>
    <body name="b"><joint name="{jb}" type="hinge" axis="0 1 0" pos="1 0 0"/>
      <geom type="capsule" fromto="1 0 0 2 0 0" size="0.01" mass="1"/></body></body>
</worldbody></mujoco>"""

PARALLEL = """<mujoco><worldbody>
  <body name="a"><joint name="ja" type="hinge" axis="0 1 0" pos="0 0 0"/>
    <geom type="capsule" fromto="0 0 0 1 0 0" size="0.01" mass="1"/></body>
  <body name="b"><joint name="jb" type="hinge" axis="0 1 0" pos="1 0 0"/>
    <geom type="capsule" fromto="1 0 0 2 0 0" size="0.01" mass="1"/></body>
</worldbody></mujoco>"""


def test_renamed_joints_pair_and_different_coordinates_do_not():
    base = mujoco.MjModel.from_xml_string(CHAIN.format(ja="ja", jb="jb"))
    renamed = mujoco.MjModel.from_xml_string(CHAIN.format(ja="x1", jb="x2"))
    assert list(dof_permutation(base, renamed)) == [0, 1]
    # the same anchors and axes, but jb's coordinate is absolute here and relative in the chain
    assert dof_permutation(base, mujoco.MjModel.from_xml_string(PARALLEL)) is None


def _joint_names(model):
    return [model.joint(i).name for i in range(model.njnt)]


def _fe_ratios(spec, n):
    fe = build_fe_model(spec)
    m = modal_analysis(fe.m, fe.k, n)
    w = 2 * np.pi * m.frequencies_hz
    return np.einsum("ir,ij,jr->r", m.shapes, structural_damping(fe, spec), m.shapes) / (2 * w)


@pytest.mark.parametrize("change", ["joint", "segment"])
def test_a_cut_member_keeps_the_damping_matrix_as_the_fe_model_does(change):
    nominal = load_spec("bcc")
    spec = (specedit.soften_joint(nominal, 6, 300.0) if change == "joint"
            else specedit.scale_segments(nominal, {(6, 7): 0.5}))
    p0, p1 = build_plant(nominal), build_plant(spec)
    assert _joint_names(p0.model) != _joint_names(p1.model)  # the member was cut into renamed pieces
    assert dof_permutation(p0.model, p1.model) is not None
    fe = _fe_ratios(spec, 6)
    sim = modes(p1.model, sorted(spec.points), 7)
    z = np.delete(sim.damping_ratios, 2)  # plant mode 3: the arms' anti-symmetric bending (no FE partner)
    nominal_z = np.array(nominal.damping.modal_ratios)
    moved = np.abs(fe / nominal_z - 1)
    assert moved.max() > 0.01  # the fixed matrix moves the ratios: a test that can fail
    assert np.allclose(z, fe, rtol=0.03, atol=0)
