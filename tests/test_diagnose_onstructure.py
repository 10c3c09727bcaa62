"""The value of an effect on the structure's own model (vlab.diagnose.fit.onstructure), on closed-form modal FRFs
of the BCC: data of the structure with an added mass, referred to the model through a replay plant whose modes
lie 0.3 % above the structure's (a discretisation's offset), and through the structure's own replay."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from vlab.diagnose.data.measured import FrfData, refer_to_model
from vlab.diagnose.effects.structural import AddedMass
from vlab.diagnose.fit.estimate import fit_hypothesis
from vlab.diagnose.fit.onstructure import fit_on_structure, spanning
from vlab.diagnose.model.labmodel import LabState, point_modes_of, predict_frf
from vlab.diagnose.problem.context import context_for
from vlab.diagnose.problem.residuals import Problem
from vlab.lab.loop import HardwareChain
from vlab.models import nominal_fe_model

KW = {"excitation_point": 9, "output_points": (3, 6)}
PTS = (3, 5, 6, 7, 9)  # the outputs and the actuators
MASS, POINT, OFFSET = 0.02, 6, 3e-3  # an added mass of 20 g; the replay plant's modes 0.3 % high


def _referred(offset: float) -> tuple[Problem, LabState]:
    """The structure with the mass, 0.1 % noise, referred through a replay whose modes are ``offset`` high."""
    fe = nominal_fe_model("bcc")
    lab = LabState(fe.spec, fe, HardwareChain(noise_m_s=0.0), None)
    f = np.arange(40, 500) * 0.05
    ctx = context_for(lab, (2.0, 25.0), None)
    h = predict_frf(AddedMass(point=POINT).apply(lab, np.array([MASS]), ctx), f, **KW)
    data = FrfData("closed-form.uff", "frf", f, h, (1e-3 * np.abs(h)) ** 2, 9, (3, 6))
    pm = point_modes_of(lab, PTS)
    plant = replace(lab, point_modes=replace(pm, omega=pm.omega * (1.0 + offset)))
    h_replay = predict_frf(plant, f, **KW)
    base = FrfData("replay", "frf", f, h_replay, np.zeros_like(data.var), 9, (3, 6))
    referred = refer_to_model(data, base, predict_frf(lab, f, **KW))
    return Problem(referred, lab, context_for(lab, (2.0, 25.0), referred), floor=0.0), lab


def test_a_replay_plants_frequency_offset_enters_the_mass_and_the_structures_own_replay_does_not():
    """Referred through a plant 0.3 % stiff-looking, the data's resonances sit 0.3 % low: the fitted mass takes
    the offset (more than 20 % high for 20 g, as the module's first-order argument says); through the
    structure's own replay the referral is exact and the mass is the truth."""
    biased, _ = _referred(OFFSET)
    fitted = fit_hypothesis(AddedMass(point=POINT), biased).params_[0]
    assert fitted / MASS - 1 > 0.2
    own, _ = _referred(0.0)
    chosen = AddedMass(point=POINT)
    chosen.params_ = np.array([fitted])
    sf = fit_on_structure(own, chosen, "its own replay")
    assert sf is not None and sf.params[0] == pytest.approx(MASS, rel=1e-3)
    assert chosen.params_[0] == fitted  # the chosen hypothesis itself is left as it was
    assert sf.reference == "its own replay" and sf.ci95.shape == (1, 2)
    assert sf.likelihood.startswith("normal")  # noise-free residuals: no tail for the t likelihood to weigh


def test_an_effect_without_parameters_has_no_structure_value():
    class NoParams(AddedMass):
        param_names = ()

    own, _ = _referred(0.0)
    assert fit_on_structure(own, NoParams(point=POINT), "its own replay") is None


def test_spanning_widens_each_interval_to_hold_the_other_values_and_keeps_an_undetermined_one():
    ci = np.array([[1.0, 2.0], [np.nan, np.nan], [5.0, 6.0]])
    out = spanning(ci, np.array([2.5, 3.0, 5.5]), np.array([0.5, 1.0, 5.2]))
    assert out[0].tolist() == [0.5, 2.5]
    assert np.isnan(out[1]).all()
    assert out[2].tolist() == [5.0, 6.0]
    assert ci[0].tolist() == [1.0, 2.0]  # the input is not changed


@pytest.mark.parametrize("metadata, on_plant, fitted", [
    ({"plant": "mujoco"}, True, False),   # a recording the MuJoCo plant made: the plant's value is the answer
    ({}, False, False),                   # not compared through the MuJoCo replay: no plant value to replace
    ({}, True, True),                     # a recording from elsewhere, referred through the MuJoCo replay
    ({"plant": ""}, True, True),
])
def test_the_structures_value_is_fitted_only_for_a_recording_of_unknown_source_referred_through_the_plant(
        metadata, on_plant, fitted, monkeypatch):
    from types import SimpleNamespace

    import vlab.diagnose.pipeline as pipeline

    calls = []
    monkeypatch.setattr(pipeline, "referred_through_replay", lambda *a, **k: calls.append(a) or (_ for _ in ()).throw(
        pipeline.VlabError("stop here")))
    res = SimpleNamespace(selected=AddedMass(point=POINT), structure_fit=None)
    _, lab = _referred(0.0)
    inp = SimpleNamespace(metadata=metadata, on_plant=on_plant, unreferred=object(), nominal=lab, spec=lab.spec,
                          fe=lab.fe, guard_s=None)
    notes = []
    problem = SimpleNamespace(model_form=None, model_form_frf=None)
    assert pipeline._structure_problem(res, inp, problem, notes, {}, lambda s: None) is None
    assert bool(calls) == fitted
    assert res.structure_fit is None
    assert any("could not be referred to the structure's own model (stop here)" in n for n in notes) == fitted
