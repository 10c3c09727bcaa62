"""vlab.diagnose.plantfit: a parameter refitted on another model's modes (the MuJoCo plant's linearisation)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from vlab.calibration import open_loop_ratios
from vlab.diagnose import specedit
from vlab.diagnose.data import FrfData
from vlab.diagnose.fit import fit_hypothesis
from vlab.diagnose.hypotheses import JointFlexibility, library
from vlab.diagnose.hypothesis import Combination
from vlab.diagnose.labmodel import LabState, PointModes, natural_frequencies, plant_frf, predict_frf
from vlab.diagnose.nominal import context_for
from vlab.diagnose.plantfit import plant_modes, refit_index, refit_on_plant
from vlab.diagnose.problem import Problem
from vlab.fe import build_fe_model, modal_analysis
from vlab.lab.experiment import TESTS
from vlab.lab.loop import HardwareChain
from vlab.models import nominal_fe_model

#: The "other model": the FE model with 2 % less mass everywhere (all frequencies 1 % higher).
MASS_FACTOR = 0.98


def other_model_modes(spec, points) -> PointModes:
    """Modes of a second model of ``spec`` whose frequencies are all 1 % above the FE model's."""
    fe = build_fe_model(spec)
    md = modal_analysis(MASS_FACTOR * fe.m, fe.k)
    rows = fe.dofs.indices(list(points), "w")
    return PointModes(md.omega, open_loop_ratios(spec, len(md.omega)), md.shapes[rows, :], tuple(points), "test")


@pytest.fixture(scope="module")
def joint_on_other_model():
    """FRFs of the *other* model of the grid with joint 18 softened to 6000 N m/rad, 1 % noise."""
    fe = nominal_fe_model("grid")
    nominal = LabState(fe.spec, fe, HardwareChain(), None)
    truth = nominal.with_spec(specedit.soften_joint(fe.spec, 18, 6000.0))
    test = TESTS["grid"]
    exc = fe.spec.instrumentation.excitation
    outs = tuple(test.measured_points)
    pts = tuple(dict.fromkeys(outs + nominal.actuators))
    freq = np.arange(4, 201) * 0.05
    h = predict_frf(replace(truth, point_modes=other_model_modes(truth.spec, pts)), freq,
                    excitation_point=exc, output_points=outs)
    data = FrfData("grid-joint18-other.uff", "frf", freq, h, (0.01 * np.abs(h)) ** 2, exc, outs)
    ctx = context_for(nominal, test.band_hz, data)
    return Problem(data, nominal, ctx)


def test_refit_on_the_other_model_recovers_the_drawn_stiffness(joint_on_other_model):
    """The FE fit absorbs the other model's 1 % frequency offset into the stiffness; the refit on that
    model's modes removes it."""
    problem = joint_on_other_model
    h = fit_hypothesis(JointFlexibility(point=18), problem)
    assert abs(h.params_[0] / 6000.0 - 1.0) > 0.02  # the FE value is biased (the test has something to fix)
    r = refit_on_plant(problem, h, modes_of=other_model_modes)
    assert r is not None and r.fe_value == h.params_[0]
    assert r.value == pytest.approx(6000.0, rel=0.005)
    assert r.chi2 < 0.01 * r.chi2_fe_value
    assert r.state.spec.sections != problem.base.spec.sections  # the lab to rerun carries the refitted joint
    assert r.params[0] == r.value


def test_refit_index_picks_the_one_mode_moving_parameter(joint_on_other_model):
    problem = joint_on_other_model
    pool = {h.label: h for h in library(problem.base, problem.ctx)}
    joint = pool["joint_flexibility(point=18)"]
    damping = next(h for lab, h in pool.items() if lab.startswith("damping(mode="))
    lag = next(h for lab, h in pool.items() if lab.startswith("actuator_lag"))
    assert refit_index(joint) == 0
    assert refit_index(damping) is None  # moves no mode
    assert refit_index(Combination(first=damping, second=joint)) == damping.n_params
    assert refit_index(Combination(first=joint, second=lag)) == 0  # the chain is in the MuJoCo rerun's loop
    dashpot = next(h for lab, h in pool.items() if lab.startswith("damping(point="))
    assert refit_index(Combination(first=dashpot, second=joint)) is None  # not spec-level: no MuJoCo rerun
    assert refit_index(Combination(first=joint, second=pool["joint_flexibility(point=9)"])) is None  # two movers


def test_with_spec_drops_the_other_models_modes(joint_on_other_model):
    base = joint_on_other_model.base
    st = replace(base, point_modes=other_model_modes(base.spec, base.actuators))
    assert st.with_spec(specedit.soften_joint(base.spec, 18, 6000.0)).point_modes is None


def test_mujoco_plant_modes_give_the_fe_receptance_between_resonances():
    """Mass-normalised MuJoCo shapes at the points: the receptance agrees with the FE model's within a few
    per cent away from the resonances (the two models' crosscheck, here through the FRF)."""
    pytest.importorskip("mujoco")
    fe = nominal_fe_model("bcc")
    st = LabState(fe.spec, fe, HardwareChain(), None)
    pts = st.actuators
    pm = plant_modes(fe.spec, pts)
    f, _, _ = natural_frequencies(st, 2)
    freq = np.array([0.5 * f[0], 0.5 * (f[0] + f[1])])
    a = plant_frf(st, freq, pts, pts)
    b = plant_frf(replace(st, point_modes=pm), freq, pts, pts)
    assert np.allclose(np.abs(b / a), 1.0, atol=0.03)
    with pytest.raises(Exception, match="not among the points"):
        plant_frf(replace(st, point_modes=pm), freq, (fe.spec.instrumentation.excitation, 999), pts)
