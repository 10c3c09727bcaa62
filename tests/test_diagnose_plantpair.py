"""vlab.diagnose.fit.plantpair: a second effect searched on the data referred through the first one's plant refit."""

from __future__ import annotations

import numpy as np
import pytest

from test_diagnose_plantfit import _referred_problem, other_model_modes
from vlab.diagnose.effects import specedit
from vlab.diagnose.effects.chain import Saturation
from vlab.diagnose.effects.hypotheses import JointFlexibility, library
from vlab.diagnose.effects.hypothesis import Combination
from vlab.diagnose.fit.estimate import fit_hypothesis
from vlab.diagnose.fit.plantfit import PlantModel
from vlab.diagnose.fit.plantpair import REFERRED_FIT, referred_through, second_effect_on_plant

#: Candidates for the second effect in these tests (the drawn one and neighbours), to keep them fast.
POOL = ("added_mass(point=3)", "added_mass(point=4)", "added_mass(point=7)", "support_stiffness(point=3, dof=w)",
        "joint_flexibility(point=9)")


def _pool(problem):
    return [h for h in library(problem.base, problem.ctx) if h.label in POOL]


def _joint_and_refit(problem):
    model = PlantModel(problem, modes_of=other_model_modes)
    joint = fit_hypothesis(JointFlexibility(point=18), problem)
    return model, joint, model.refit(joint, joint.params_)


@pytest.fixture(scope="module")
def joint_and_mass():
    """Joint 18 at 6000 N m/rad and 0.5 kg at point 3 in the other model's data, referred through a baseline."""
    return _referred_problem(lambda spec: specedit.add_mass(specedit.soften_joint(spec, 18, 6000.0), 3, 0.5),
                             "grid-joint18-mass3-other.uff")


def test_referred_data_leave_on_the_fe_model_what_the_plant_leaves(joint_and_mass):
    """d' = d H_FE(h, x_FE) / H_plant(h, x_P): the FE model with h at x_FE has on d' the residual the plant
    with h at x_P has on d (the same chi-square to rounding), and the scaled variance keeps the weights."""
    model, joint, r = _joint_and_refit(joint_and_mass)
    referred = referred_through(model, joint, joint.params_, r.params)
    fe_chi2 = referred.chi2(referred.state_for(joint, joint.params_))
    assert fe_chi2 == pytest.approx(model.problem.chi2(model.state(joint, r.params)), rel=1e-9)
    assert fe_chi2 > referred.noise_chi2()  # the mass is left: the search has something to find


def test_a_second_effect_is_added_when_the_plant_leaves_more_than_noise(joint_and_mass):
    model, joint, r = _joint_and_refit(joint_and_mass)
    chosen, refit, looks, note = second_effect_on_plant(model, joint, r, _pool(joint_and_mass))
    assert isinstance(chosen, Combination) and chosen.parts[1].label == "added_mass(point=3)"
    assert "is selected" in note and looks == []
    assert model.problem.within_noise(model.state(chosen, refit.params))
    assert refit.params[0] == pytest.approx(6000.0, rel=0.02)  # the joint at its plant value
    assert refit.params[1] == pytest.approx(0.5, rel=0.05)  # the mass refitted on the plant
    assert refit.state.spec.masses != joint_and_mass.base.spec.masses  # the rerun's lab carries both
    assert refit.start == REFERRED_FIT and refit.as_dict()["start"] == REFERRED_FIT  # the report's label


def test_no_second_effect_when_the_plant_leaves_only_noise():
    """Joint 18 alone in the data: its refit on the other model leaves only noise, nothing is searched."""
    problem = _referred_problem(lambda spec: specedit.soften_joint(spec, 18, 6000.0), "grid-joint18-other.uff")
    model, joint, r = _joint_and_refit(problem)
    chosen, refit, looks, note = second_effect_on_plant(model, joint, r, _pool(problem))
    assert chosen is joint and refit is r and looks == [] and note is None


def test_a_pair_that_does_not_reach_the_noise_is_not_selected(joint_and_mass):
    """Without the drawn mass among the candidates, no pair brings the residual into the noise: the single
    effect stays, and the note says why."""
    model, joint, r = _joint_and_refit(joint_and_mass)
    pool = [h for h in _pool(joint_and_mass) if h.label != "added_mass(point=3)"]
    chosen, refit, looks, note = second_effect_on_plant(model, joint, r, pool)
    assert chosen is joint and refit is r and looks == []
    assert note is not None and "the single effect stays" in note
    assert np.isfinite(model.problem.chi2(model.state(joint, r.params)))


def test_a_nonlinear_effect_gets_no_second_effect_search(joint_and_mass):
    """A saturation's linear model is a describing function: what it leaves on the plant is not judged by the
    noise limits, so no second effect is searched next to it (pairs with it are judged by rerun)."""
    model, _, _ = _joint_and_refit(joint_and_mass)
    sat = Saturation()
    sat.params_ = np.array([5.0])
    chosen, refit, looks, note = second_effect_on_plant(model, sat, None, _pool(joint_and_mass))
    assert chosen is sat and refit is None and looks == []
    assert "no second effect searched" in note and sat.label in note  # the report says why


def _pair_choice(problem, first, second):
    """A fitted pair of the joint at point ``first`` and the effect ``second``, the FE model's choice, with the
    singles the screening would also have fitted; the located places around the joints."""
    from types import SimpleNamespace

    joints = [fit_hypothesis(JointFlexibility(point=p), problem) for p in (17, 18)]
    pair = fit_hypothesis(Combination(first=JointFlexibility(point=first), second=second), problem)
    res = SimpleNamespace(ranked=[pair] + joints, location=SimpleNamespace(places=frozenset({16, 17, 18, 19})),
                          plant_refit=None, alternatives=[])
    return pair, res


def test_a_pair_gives_way_to_a_single_effect_that_explains_the_data_on_the_plant():
    """Joint 18 alone in the other model's data; on the FE model a joint at 17 with a dashpot was chosen (the
    dashpot cannot be carried by the plant, so no pair rule judges it there). Compared on the plant with the
    same physics at the located places, joint 18 refitted there leaves only noise: it is the choice, near the
    drawn 6000 N m/rad."""
    from vlab.diagnose.explain import _single_on_plant

    problem = _referred_problem(lambda spec: specedit.soften_joint(spec, 18, 6000.0), "grid-joint18-other.uff")
    model = PlantModel(problem, modes_of=other_model_modes)
    from vlab.diagnose.effects.hypotheses import PointDamping

    pair, res = _pair_choice(problem, 17, PointDamping(point=18))
    notes = []
    single = _single_on_plant(res, model, pair, notes)
    assert single is not None and single.label == "joint_flexibility(point=18)"
    assert res.plant_refit.params[0] == pytest.approx(6000.0, rel=0.02)
    assert "alone, refitted there, leaves the data within the mismatch test's limits" in notes[-1]


def test_a_pair_stays_where_its_second_effect_is_needed_on_the_plant(joint_and_mass):
    """Joint 18 and 0.5 kg at point 3 in the data, that pair chosen on the FE model: joint 18 alone leaves the
    mass on the plant too, and the pair passes the pair rule against it there."""
    from vlab.diagnose.effects.hypotheses import AddedMass
    from vlab.diagnose.explain import _single_on_plant

    model = PlantModel(joint_and_mass, modes_of=other_model_modes)
    pair, res = _pair_choice(joint_and_mass, 18, AddedMass(point=3))
    assert _single_on_plant(res, model, pair, []) is None and res.plant_refit is None


def test_a_single_that_fails_on_the_plant_meets_the_fe_models_better_pairs_there(joint_and_mass):
    """Joint 18 and 0.5 kg at point 3 in the data; the single chosen is the wrong joint (17), and the candidates
    for a second effect lack the mass, so no extension of it explains the data. The FE model's better pair (joint
    18 + mass 3, fitted there) is refitted on the plant from its own values and selected by the same pair rule
    (93 % of the single's chi-square removed); without the FE model's fits the wrong single stays."""
    from vlab.diagnose.fit.plantpair import FE_FIT, fe_pairs

    problem = joint_and_mass
    model = PlantModel(problem, modes_of=other_model_modes)
    wrong = fit_hypothesis(JointFlexibility(point=17), problem)
    r = model.refit(wrong, wrong.params_)
    (mass,) = [h for h in library(problem.base, problem.ctx) if h.label == "added_mass(point=3)"]
    truth = fit_hypothesis(Combination(first=JointFlexibility(point=18), second=mass), problem)
    assert truth.chi2_ < wrong.chi2_  # the FE model prefers the pair too
    pool = [h for h in _pool(problem) if h.label != "added_mass(point=3)"]
    assert fe_pairs(wrong, [truth, wrong], set(), 3) == [truth]
    assert fe_pairs(wrong, [truth, wrong], {truth.label}, 3) == []  # already searched
    stays, _, _, note = second_effect_on_plant(model, wrong, r, pool)
    assert stays is wrong and "the single effect stays" in note
    chosen, refit, _looks, note = second_effect_on_plant(model, wrong, r, pool, ranked=[truth, wrong])
    assert chosen is truth and "is selected" in note and "beside the FE model's better pairs" in note
    assert refit.start == FE_FIT
    # refitted from the FE model's values within the plant refit's window (this test's other model differs from
    # the FE model far more than a plant does: the FE pair puts the joint at 3.4e4 N m/rad), never worse there
    assert refit.chi2 <= model.chi2(truth, truth.params_)
    assert refit.params[1] == pytest.approx(0.5, rel=0.05)
