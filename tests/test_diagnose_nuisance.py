"""The model-form parameters profiled out of a lab state (vlab.diagnose.problem.nuisance), on exact modal FRFs of
the BCC (open loop): a mode moved by a known number of its standard uncertainties is found back by the profile,
and the state counts as within the model's accuracy only while that number is plausible."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from vlab.diagnose.data.measured import FrfData
from vlab.diagnose.model.labmodel import LabState, PointModes, natural_frequencies, predict_frf
from vlab.diagnose.model.modelform import ModelFormUncertainty, frf_model_form, perturbed_modes
from vlab.diagnose.problem.context import context_for
from vlab.diagnose.policy import DEFAULT_POLICY
from vlab.diagnose.problem.nuisance import parameters, profile, within_model_accuracy
from vlab.diagnose.problem.residuals import Problem
from vlab.lab.loop import HardwareChain
from vlab.models import nominal_fe_model

R, SIGMA = 2, 2e-3  # mode 3's frequency, 0.2 % standard uncertainty


def _problem(moved_sigmas: float):
    """FRFs of the lab with mode 3 moved by ``moved_sigmas`` x SIGMA, 0.1 % noise, against the lab's point modes."""
    fe = nominal_fe_model("bcc")
    st = LabState(fe.spec, fe, HardwareChain(noise_m_s=0.0), None)
    fr, zeta, phi = natural_frequencies(st)
    pts = (5, 6, 7, 9)  # the output and the actuators
    pm = PointModes(2 * np.pi * fr, np.asarray(zeta, dtype=float), phi[fe.dofs.indices(pts, "w"), :], pts, "FE")
    st = replace(st, point_modes=pm)
    f = np.arange(20, 241) * 0.05
    h = predict_frf(replace(st, point_modes=perturbed_modes(pm, "f", R, None, moved_sigmas * SIGMA)), f,
                    excitation_point=9, output_points=(6,))
    data = FrfData("moved.uff", "frf", f, h, (1e-3 * np.abs(h)) ** 2, 9, (6,))
    n = len(fr)
    unc = ModelFormUncertainty(np.where(np.arange(n) == R, SIGMA, 0.0), np.full(n, np.inf), {}, {})
    mf = frf_model_form(st, f, excitation_point=9, output_points=(6,), uncertainty=unc, modes=pm)
    return Problem(data, st, context_for(st, (1.0, 12.0), data), floor=0.0, model_form_frf=mf), st


def test_the_profile_finds_the_move_back():
    problem, st = _problem(2.0)
    assert [p for p in parameters(problem.model_form_frf, st.point_modes)] == [("f", R, None)]
    r, x = profile(problem, st, st.point_modes)
    assert x[0] == pytest.approx(2.0, rel=1e-3)  # the move itself, in standard uncertainties
    assert float(r @ r) < 1e-3 * problem.n_obs  # exact data: nothing left
    assert not problem.within_noise(st)  # a 0.4 % shift of a 0.4 %-damped mode is far beyond 0.1 % noise
    assert within_model_accuracy(problem, st)


def test_a_move_beyond_the_uncertainty_is_not_within_the_models_accuracy():
    problem, st = _problem(10.0)
    _r, x = profile(problem, st, st.point_modes)
    assert x[0] ** 2 > DEFAULT_POLICY.nuisance_limit(1)  # 10 sigma: the limit is 1.2 x 8.6 = 10.4
    assert not within_model_accuracy(problem, st)


def test_without_a_model_form_it_is_the_noise_test():
    problem, st = _problem(2.0)
    problem.model_form_frf = None
    assert within_model_accuracy(problem, st) is problem.within_noise(st) is False


def test_the_policy_limits_follow_from_the_false_alarm_rate():
    """Šidák: four tests at 1 - (1 - alpha)^(1/4) keep alpha together; chi-square with one degree of freedom
    is a squared standard normal, so its upper quantile is the normal's at half the rate (an identity checked
    against a second distribution, not the same function)."""
    import scipy.stats

    from vlab.diagnose.policy import DecisionPolicy

    p = DecisionPolicy(false_alarm_rate=0.01)
    assert (1 - p.test_rate) ** 4 == pytest.approx(0.99, rel=1e-12)
    # the largest of k standard normal moves: P(max |x| > L) = the test's rate (exact for independent normals)
    k = 70
    assert 1 - (1 - 2 * scipy.stats.norm.sf(np.sqrt(p.move_limit(k)))) ** k == pytest.approx(p.test_rate, rel=1e-9)
    assert p.move_limit(1) == pytest.approx(p.nuisance_limit(1), rel=1e-12)
    assert p.nuisance_limit(1) == pytest.approx(scipy.stats.norm.isf(p.test_rate / 2) ** 2, rel=1e-9)
    assert p.lr_limit(1) == pytest.approx(scipy.stats.norm.isf(0.005) ** 2, rel=1e-9)  # 6.635, tabulated
    assert p.lr_limit(1, c_hat=3.0) == pytest.approx(3 * p.lr_limit(1))
    # a lower false-alarm rate raises every limit
    q = DecisionPolicy(false_alarm_rate=0.001)
    assert q.chi2_limit(500) > p.chi2_limit(500) and q.line_limit(500, 2) > p.line_limit(500, 2)
    # the limit of the largest of n lines: P(max of n chi2(2) > L) = the test's rate (exact for chi2(2): exp(-L/2))
    n = 1000
    assert 1 - (1 - np.exp(-p.line_limit(n, 2) / 2)) ** n == pytest.approx(p.test_rate, rel=1e-9)
    with pytest.raises(Exception, match="false-alarm rate"):
        DecisionPolicy(false_alarm_rate=0.7)


@pytest.mark.parametrize("moved, inside", [(2.0, True), (10.0, False)])
def test_a_lab_without_its_own_modes_is_judged_as_the_mismatch_test_judged_the_nominal(moved, inside):
    """A chosen lab that carries no modes of its own (a chain effect on the FE model) is compared within the
    model form when the mismatch test profiled the nominal lab (``profile_nominal``): the moves are found back
    on the modes the model form was derived on, and a move of 10 standard uncertainties is beyond it."""
    from vlab.diagnose.problem.nuisance import profile_state, profiled

    problem, st = _problem(moved)
    bare = replace(st, point_modes=None)
    assert not profiled(problem, bare)  # a problem that did not profile the nominal: the noise test alone
    assert within_model_accuracy(problem, bare) is problem.within_noise(bare) is False
    problem.profile_nominal = True
    assert profiled(problem, bare)
    _r, x, k = profile_state(problem, bare)
    assert k == 1 and x[0] == pytest.approx(moved, rel=0.02)
    assert within_model_accuracy(problem, bare) is inside


def test_a_lab_improves_on_the_nominal_only_where_the_profiled_statistic_falls_beyond_the_lr_limit():
    """Data with mode 3 moved 10 sigma: the nominal lab is profiled (its modes moved within the model form);
    the lab with the move itself fits them (the statistic falls far beyond chi2_1's 1 % point), the nominal
    lab itself does not improve on itself, and a lab moved the other way fits them worse."""
    from vlab.diagnose.problem.nuisance import improves_on_nominal

    problem, st = _problem(10.0)
    problem.profile_nominal = True
    nominal = st
    pm = st.point_modes
    right = replace(st, point_modes=perturbed_modes(pm, "f", R, None, 10.0 * SIGMA))
    wrong = replace(st, point_modes=perturbed_modes(pm, "f", R, None, -10.0 * SIGMA))
    assert improves_on_nominal(problem, right)
    assert not improves_on_nominal(problem, nominal)
    assert not improves_on_nominal(problem, wrong)
    problem.model_form_frf = None  # no model form to profile: the fit's footing decides, not this test
    assert improves_on_nominal(problem, wrong)
