"""Look-alikes by prediction (vlab.diagnose.fit.separation): the screen and the limit against closed forms, and
on the BCC's 2 kHz MFDRF loop the actuator gain at coil 5 against a dashpot there. MFDRF's row for coil 5 is
nearly diagonal, so a gain change there adds a force ``(g - 1) d_55`` times the coil's velocity, delayed by
the loop: a dashpot seen through the loop's 1.35-period delay, hold and filter. For a 2 % gain change, within
the model's accuracy (a 0.5 % model-error floor and the FE modes' model-form uncertainty) no data tell the two
apart; with the noise alone (an exact model) they do."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.stats

from vlab.diagnose.data.measured import FrfData
from vlab.diagnose.detectability import frf_model_form_of
from vlab.diagnose.effects import hypotheses as H
from vlab.diagnose.fit.estimate import fit_hypothesis
from vlab.diagnose.fit.separation import inseparable, prediction_distance, separation_note
from vlab.diagnose.model.labmodel import LabState, predict_frf
from vlab.diagnose.model.nominal import nominal_design
from vlab.diagnose.policy import DecisionPolicy
from vlab.diagnose.problem.context import context_for
from vlab.diagnose.problem.residuals import Problem
from vlab.lab.loop import HardwareChain
from vlab.models import nominal_fe_model


def test_the_limit_is_the_one_parameter_quantile_and_gives_about_even_power():
    pol = DecisionPolicy(false_alarm_rate=0.01)
    limit = scipy.stats.chi2.isf(0.01, 1)
    assert pol.lr_limit(1) == pytest.approx(limit)
    assert not pol.separable(0.999 * limit) and pol.separable(1.001 * limit)
    assert not pol.separable(float("nan")) and not pol.separable(float("inf"))
    # a noncentral chi-square of one degree of freedom with noncentrality at the limit exceeds it about half the time
    assert scipy.stats.ncx2.sf(limit, 1, limit) == pytest.approx(0.5, abs=0.01)
    assert scipy.stats.ncx2.sf(limit, 1, 0.5 * limit) < 0.5


class _Hyp:
    def __init__(self, label: str, r, n_params: int = 1):
        self.label, self.r, self.n_params = label, np.asarray(r, dtype=float), n_params


class _Problem:
    """Residual vectors given directly: the lab is the hypothesis."""

    policy = DecisionPolicy()

    def residual(self, state):
        return state.r


def test_inseparable_keeps_the_close_ones_and_its_screen_drops_none_of_them():
    rng = np.random.default_rng(3)
    pr = _Problem()
    limit = pr.policy.lr_limit(1)
    base = rng.normal(size=400) * 2.0
    chosen = _Hyp("chosen", base)
    others = [_Hyp(f"h{i}", base + rng.normal(size=400) * s) for i, s in enumerate(np.linspace(0.02, 0.3, 40))]
    others.append(_Hyp("two-parameter", base, n_params=2))
    found = inseparable(chosen, float(base @ base), [(h, float(h.r @ h.r)) for h in others], pr, lambda h: h)
    expected = {h.label for h in others if h.n_params == 1 and (h.r - base) @ (h.r - base) <= limit}
    assert {h.label for h, _ in found} == expected and 0 < len(expected) < 40
    dists = [d for _, d in found]
    assert dists == sorted(dists)
    assert all(d == pytest.approx(float((h.r - base) @ (h.r - base))) for h, d in found)
    assert "two-parameter" not in {h.label for h, _ in found}  # another number of parameters is not compared
    assert inseparable(chosen, float("inf"), [(h, 1.0) for h in others], pr, lambda h: h) == []


@pytest.fixture(scope="module")
def coil5():
    """MFDRF closed-loop FRFs of the BCC with the gain of coil 5 at 1.02, noise 0.05 % of each line."""
    fe = nominal_fe_model("bcc")
    lab = LabState(fe.spec, fe, HardwareChain(noise_m_s=0.0), nominal_design(fe, "mfdrf", 0))
    f = np.arange(20, 500) * 0.05
    ctx = context_for(lab, (1.0, 25.0), None)
    ctx.closed_loop, ctx.excitation_point = True, fe.spec.instrumentation.excitation
    ctx.freq_hz, ctx.force_amplitude = f, np.full(f.size, 0.05)
    kw = {"excitation_point": ctx.excitation_point, "output_points": (5, 7, 9)}
    h = predict_frf(H.ActuatorGain(channel=5).apply(lab, np.array([1.02]), ctx), f, **kw)
    data = FrfData("closed-form.uff", "frf", f, h, (5e-4 * np.abs(h)) ** 2, ctx.excitation_point, (5, 7, 9))
    return lab, ctx, data


def _fits(lab, ctx, data, exact: bool):
    """The gain, the dashpot and a mass at 5 fitted on the model's accuracy or, ``exact``, on the noise alone."""
    mff = None if exact else frf_model_form_of(lab, data, None)[1]
    pr = Problem(data, lab, ctx, floor=0.0 if exact else 0.005, model_form_frf=mff)
    hyps = [fit_hypothesis(h, pr) for h in (H.ActuatorGain(channel=5), H.PointDamping(point=5),
                                             H.AddedMass(point=5))]
    return pr, hyps


def test_a_gain_at_a_rate_feedback_coil_and_a_dashpot_there_are_look_alikes_within_the_model_floor(coil5):
    lab, ctx, data = coil5
    pr, (gain, dashpot, mass) = _fits(lab, ctx, data, exact=False)
    d55 = float(np.asarray(lab.design.gain)[0, 0])  # coil 5 is the first actuator
    assert dashpot.params_[0] == pytest.approx(0.02 * d55, rel=0.05)  # the dashpot the gain change adds
    state = lambda h: pr.state_for(h, h.params_)  # noqa: E731
    found = dict(inseparable(gain, gain.chi2_, [(h, h.chi2_) for h in (dashpot, mass)], pr, state))
    assert list(found) == [dashpot]
    assert found[dashpot] == pytest.approx(prediction_distance(pr, state(dashpot), state(gain)))
    note = separation_note(gain, list(found.items()), pr)
    assert "damping(point=5)" in note and f"{pr.policy.lr_limit(1):.4g}" in note


def test_with_the_noise_alone_the_same_gain_and_dashpot_are_told_apart(coil5):
    lab, ctx, data = coil5
    pr, (gain, dashpot, _) = _fits(lab, ctx, data, exact=True)
    d = prediction_distance(pr, pr.state_for(dashpot, dashpot.params_), pr.state_for(gain, gain.params_))
    assert pr.policy.separable(d)
    assert gain.chi2_ < dashpot.chi2_
