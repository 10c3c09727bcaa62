"""vlab.diagnose.fit.rules.changed_beyond_noise: with a baseline, a change is judged against the noise alone."""

from __future__ import annotations

import numpy as np
import pytest

from vlab.diagnose.data.measured import FrfData, refer_to_model
from vlab.diagnose.effects import specedit
from vlab.diagnose.fit.rules import changed_beyond_noise
from vlab.diagnose.model.labmodel import LabState, predict_frf
from vlab.diagnose.problem.context import context_for
from vlab.diagnose.problem.residuals import Problem
from vlab.errors import ModelError
from vlab.experiment.config import TESTS
from vlab.lab.loop import HardwareChain
from vlab.models import nominal_fe_model

#: Relative noise of each recorded line (what two periods of a clean periodic test give at a resonance).
NOISE = 2e-4

#: A mass at point 5 that moves the BCC's lightly damped resonances by less than the 0.5 % floor allows [kg].
MASS_KG = 5e-5


@pytest.fixture(scope="module")
def bcc():
    fe = nominal_fe_model("bcc")
    nominal = LabState(fe.spec, fe, HardwareChain(), None)
    test = TESTS["bcc"]
    freq = np.arange(int(test.band_hz[0] / 0.05) + 1, int(test.band_hz[1] / 0.05) + 1) * 0.05
    return nominal, test, freq


def _recorded(st: LabState, freq, test, seed: int, source: str, noise: float = NOISE) -> FrfData:
    exc, outs = st.spec.instrumentation.excitation, tuple(test.measured_points)
    h = predict_frf(st, freq, excitation_point=exc, output_points=outs)
    rng = np.random.default_rng(seed)
    sigma = noise * np.abs(h)
    h = h + sigma / np.sqrt(2) * (rng.standard_normal(h.shape) + 1j * rng.standard_normal(h.shape))
    return FrfData(source, "frf", freq, h, sigma**2, exc, outs)


def _problem(bcc, truth: LabState, seed: int, noise: float = NOISE, base_noise: float | None = None,
             plant=lambda spec: spec) -> Problem:
    """``truth`` recorded against a baseline of the unchanged structure, both on a plant ``plant(spec)`` (the
    model-form error the referral removes), with relative noise ``noise`` (the baseline's ``base_noise``)."""
    nominal, test, freq = bcc
    on_plant = lambda st: st.with_spec(plant(st.spec))  # noqa: E731
    base_noise = noise if base_noise is None else base_noise
    data = refer_to_model(_recorded(on_plant(truth), freq, test, seed, "rec.uff", noise),
                          _recorded(on_plant(nominal), freq, test, seed + 1, "base.uff", base_noise),
                          predict_frf(nominal, freq, excitation_point=nominal.spec.instrumentation.excitation,
                                      output_points=tuple(test.measured_points)))
    return Problem(data, nominal, context_for(nominal, test.band_hz, data))


def test_a_change_within_the_floor_but_far_out_of_the_noise_is_found(bcc):
    nominal = bcc[0]
    problem = _problem(bcc, nominal.with_spec(specedit.add_mass(nominal.spec, 5, MASS_KG)), seed=1)
    assert problem.within_noise(nominal)  # the 0.5 % floor takes the change for model error
    changed, stats = changed_beyond_noise(problem, nominal)
    assert changed and stats["peak"] > stats["peak_limit"]
    # the statistic is the recorded change itself, H_baseline / H_recorded, whatever the model: recomputed here
    # from the two recordings (the same seeds), the variance of refer_to_model's docstring (both noises plus
    # model-form error x change), each part of the relative complex change with half of it
    _, test, freq = bcc
    exc, outs = nominal.spec.instrumentation.excitation, tuple(test.measured_points)
    rec = _recorded(nominal.with_spec(specedit.add_mass(nominal.spec, 5, MASS_KG)), freq, test, 1, "r")
    base = _recorded(nominal, freq, test, 2, "b")
    h_model = predict_frf(nominal, freq, excitation_point=exc, output_points=outs)
    rel = rec.var / np.abs(rec.h) ** 2 + base.var / np.abs(base.h) ** 2 \
        + (np.abs(np.log(h_model / base.h)) * np.abs(np.log(rec.h / base.h))) ** 2
    e = (base.h / rec.h - 1.0)[problem.mask]  # the tests' form: the relative error (problem.forms)
    chi2 = float(np.sum(np.abs(e) ** 2 / (rel[problem.mask] / 2)))
    assert stats["chi2"] == pytest.approx(chi2, rel=1e-9)


def test_two_recordings_of_the_same_structure_do_not_differ(bcc):
    nominal = bcc[0]
    for seed in (3, 5, 7):
        changed, stats = changed_beyond_noise(_problem(bcc, nominal, seed=seed), nominal)
        assert not changed and stats["chi2"] <= stats["chi2_limit"]


def test_lines_without_a_noise_estimate_leave_the_floor_alone(bcc):
    """Without the noise of either recording, the referral's own term (model-form error x change) would be the
    only weight, and it weighs a change of any size alike: a plant 1 g off the model at point 3 and a change of
    1e-9 kg must not count."""
    nominal = bcc[0]
    truth = nominal.with_spec(specedit.add_mass(nominal.spec, 5, 1e-9))
    offset = lambda spec: specedit.add_mass(spec, 3, 1e-3)  # noqa: E731
    for noise, base_noise in ((0.0, 0.0), (NOISE, 0.0), (0.0, NOISE)):
        problem = _problem(bcc, truth, seed=1, noise=noise, base_noise=base_noise, plant=offset)
        assert changed_beyond_noise(problem, nominal) == (False, {})
    # the same plant with both noises measured: a 1e-9 kg change stays within them
    changed, stats = changed_beyond_noise(_problem(bcc, truth, seed=1, plant=offset), nominal)
    assert not changed and stats  # tested, and within the noise


def test_data_not_referred_through_a_baseline_is_refused(bcc):
    nominal, test, freq = bcc
    data = _recorded(nominal, freq, test, 0, "plain.uff")
    problem = Problem(data, nominal, context_for(nominal, test.band_hz, data))
    with pytest.raises(ModelError, match="plain.uff"):
        changed_beyond_noise(problem, nominal)


def test_a_change_found_only_without_the_floor_is_explained_only_without_it(bcc):
    """With the floor the nominal model is already within the noise, so any effect would leave the data within
    it: the selected effect is judged without the floor then (``pipeline.explained_share``). The drawn mass
    removes the change; a mass of 1e-9 kg at point 1 removes none of it and is refused (with the floor's test
    it passed)."""
    from types import SimpleNamespace

    from vlab.diagnose.fit.rules import explained_share, explains

    nominal = bcc[0]
    problem = _problem(bcc, nominal.with_spec(specedit.add_mass(nominal.spec, 5, MASS_KG)), seed=1)
    chi2_0 = problem.chi2(nominal)
    changed, stats = changed_beyond_noise(problem, nominal)
    assert changed and problem.within_noise(nominal)  # found only without the floor

    def selected(point: int, kg: float) -> SimpleNamespace:
        st = nominal.with_spec(specedit.add_mass(nominal.spec, point, kg))
        return SimpleNamespace(selected=SimpleNamespace(chi2_=problem.chi2(st)), problem=problem, noise_only=stats,
                               validation=None, selected_state=lambda: st)

    right, wrong = selected(5, MASS_KG), selected(1, 1e-9)
    assert explains(right, chi2_0) and explained_share(right, chi2_0)[0] > 0.9
    assert problem.within_noise(wrong.selected_state())  # the floor's test passes any effect here
    assert not explains(wrong, chi2_0) and explained_share(wrong, chi2_0)[0] < 0.01
    wrong.noise_only = None  # a mismatch found with the floor: judged with it (as before)
    assert explains(wrong, chi2_0)
