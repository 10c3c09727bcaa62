"""The passenger check of rule 3 (vlab.diagnose.fit.rules.part_alone): a pair's part that alone passes the
mismatch tests makes the other a passenger. Closed-form modal FRFs of the BCC: a true damping change of one mode, and the structure's
frequency of another mode off the model by a third of a standard uncertainty of its model form (within the
model's accuracy) or by twelve (a second real change)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from vlab.diagnose.data.measured import FrfData
from vlab.diagnose.effects.structural import AddedMass, ModalDamping
from vlab.diagnose.fit.estimate import fit_hypothesis
from vlab.diagnose.effects.hypotheses import Combination
from vlab.diagnose.fit.passing import both_parts_needed, passing_choice, passing_single
from vlab.diagnose.fit.rules import part_alone
from vlab.diagnose.model.labmodel import LabState, point_modes_of, predict_frf
from vlab.diagnose.model.modelform import ModelFormUncertainty, frf_model_form, perturbed_modes
from vlab.diagnose.problem.context import context_for
from vlab.diagnose.problem.residuals import Problem
from vlab.lab.loop import HardwareChain
from vlab.models import nominal_fe_model

MODE, OTHER, SIGMA = 3, 5, 2e-3  # damping of mode 3 changed; mode 5 (14.4 Hz, zeta 0.003) uncertain by 0.2 %
KW = {"excitation_point": 9, "output_points": (3, 6)}
PTS = (3, 5, 6, 7, 9)  # the outputs and the actuators


def _problem(offset_sigmas: float) -> Problem:
    """Data: the lab with mode 3's damping doubled and mode 5's frequency ``offset_sigmas`` standard
    uncertainties high, 0.1 % noise; the model form: mode 5's frequency only."""
    fe = nominal_fe_model("bcc")
    lab = LabState(fe.spec, fe, HardwareChain(noise_m_s=0.0), None)
    f = np.arange(40, 500) * 0.05
    ctx = context_for(lab, (2.0, 25.0), None)
    changed = ModalDamping(mode=MODE).apply(lab, np.array([0.008]), ctx)
    pm = point_modes_of(changed, PTS)
    h = predict_frf(replace(changed, point_modes=perturbed_modes(pm, "f", OTHER - 1, None, offset_sigmas * SIGMA)),
                    f, **KW)
    data = FrfData("closed-form.uff", "frf", f, h, (1e-2 * np.abs(h)) ** 2, 9, (3, 6))
    n = len(pm.omega)
    unc = ModelFormUncertainty(np.where(np.arange(n) == OTHER - 1, SIGMA, 0.0), np.full(n, np.inf), {}, {})
    mf = frf_model_form(lab, f, uncertainty=unc, **KW)
    return Problem(data, lab, context_for(lab, (2.0, 25.0), data), floor=0.0, model_form_frf=mf,
                   profile_nominal=True)  # as the diagnosis's problem: its mismatch test profiles the modes


def _parts(problem: Problem) -> list:
    return [fit_hypothesis(ModalDamping(mode=MODE), problem), fit_hypothesis(AddedMass(point=6), problem)]


def test_a_part_that_explains_the_data_within_the_model_form_makes_the_other_a_passenger():
    problem = _problem(0.3)
    damping, mass = _parts(problem)
    assert abs(damping.params_[0] / 0.008 - 1) < 0.02
    assert part_alone([damping, mass], problem) is damping
    assert part_alone([mass, damping], problem) is damping


def test_no_part_alone_when_the_second_change_lies_beyond_the_model_form():
    problem = _problem(12.0)
    assert part_alone(_parts(problem), problem) is None


def test_a_choice_that_fails_the_mismatch_tests_gives_way_to_a_single_effect_that_passes_them():
    """Rule 3's last step (vlab.diagnose.fit.passing.passing_single): the mass, ranked first, cannot make mode
    3's damping; the damping change passes every test that declared the mismatch and is the choice."""
    problem = _problem(0.3)
    damping, mass = _parts(problem)
    assert passing_single(mass, [mass, damping], problem, 5) is damping
    assert passing_single(damping, [damping, mass], problem, 5) is None  # the choice passes: kept
    assert passing_single(mass, [mass, damping], problem, 0) is None  # none examined
    assert passing_single(None, [mass, damping], problem, 5) is None


def _two_changes() -> Problem:
    """Data: mode 3's damping raised to 0.008 and 20 g added at point 6, 1 % noise; every mode's frequency
    uncertain by 0.2 % (the model form)."""
    fe = nominal_fe_model("bcc")
    lab = LabState(fe.spec, fe, HardwareChain(noise_m_s=0.0), None)
    f = np.arange(40, 500) * 0.05
    ctx = context_for(lab, (2.0, 25.0), None)
    changed = AddedMass(point=6).apply(ModalDamping(mode=MODE).apply(lab, np.array([0.008]), ctx),
                                       np.array([0.02]), ctx)
    h = predict_frf(changed, f, **KW)
    data = FrfData("closed-form.uff", "frf", f, h, (1e-2 * np.abs(h)) ** 2, 9, (3, 6))
    n = len(point_modes_of(lab, PTS).omega)
    unc = ModelFormUncertainty(np.full(n, SIGMA), np.full(n, np.inf), {}, {})
    mf = frf_model_form(lab, f, uncertainty=unc, **KW)
    return Problem(data, lab, context_for(lab, (2.0, 25.0), data), floor=0.0, model_form_frf=mf,
                   profile_nominal=True)


def test_where_no_single_effect_passes_the_pair_that_does_and_needs_both_parts_is_the_choice():
    """Rule 3's last step for pairs (vlab.diagnose.fit.passing.passing_choice): neither change alone passes the
    tests that declared the mismatch; the pair of both does, each part needed beside the other by the
    likelihood-ratio test, and replaces a single choice that explains less than half of the chi-square."""
    problem = _two_changes()
    damping = fit_hypothesis(ModalDamping(mode=MODE), problem)
    mass = fit_hypothesis(AddedMass(point=6), problem)
    pair = fit_hypothesis(Combination(first=ModalDamping(mode=MODE), second=AddedMass(point=6)), problem)
    assert np.allclose(pair.params_, [0.008, 0.02], rtol=0.02)
    assert passing_single(damping, [damping, mass, pair], problem, 5) is None  # no single effect passes
    assert both_parts_needed(pair, [damping, mass, pair], problem)
    chi2_0 = problem.chi2(problem.base)
    assert damping.chi2_ > 0.5 * chi2_0  # the damping change alone removes less than half: no explanation
    assert passing_choice(damping, [damping, mass, pair], problem, 5, chi2_0) is pair
    assert passing_choice(pair, [pair, damping, mass], problem, 5, chi2_0) is None  # the choice passes: kept
    assert passing_choice(damping, [damping, mass, pair], problem, 0, chi2_0) is None  # none examined
    # a single choice that removes more than half of the chi-square stays (its remainder is reported)
    assert passing_choice(damping, [damping, mass, pair], problem, 5, 2.5 * damping.chi2_) is None


def test_a_ranked_part_stranded_by_its_trials_does_not_make_the_other_part_needed():
    """The likelihood-ratio test's null is each part's best fit alone: where the ranked fit of the damping change
    stopped in a local minimum (here: its result replaced by the chi-square at a quarter of the true value, as
    a stranded local fit returns it), the part is fitted again from its value in the pair, and the added mass
    beside it, with nothing to explain, is not needed."""
    import copy

    problem = _problem(0.3)
    damping, mass = _parts(problem)
    stranded = copy.copy(damping)
    stranded.params_ = np.array([0.002])
    stranded.chi2_ = problem.chi2(stranded.apply(problem.base, stranded.params_, problem.ctx))
    assert stranded.chi2_ > 2 * damping.chi2_
    pair = fit_hypothesis(Combination(first=ModalDamping(mode=MODE), second=AddedMass(point=6)), problem,
                          starts=np.array([[0.008, 1e-4]]))
    assert not both_parts_needed(pair, [stranded, mass, pair], problem)
    assert not both_parts_needed(pair, [damping, mass, pair], problem)
