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
from vlab.diagnose.problem.nuisance import nuisance_limit, parameters, profile, within_model_accuracy
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
    assert x[0] ** 2 > nuisance_limit(1)  # 10 sigma: chi2(1) at 0.999 x 1.2 is 13.0
    assert not within_model_accuracy(problem, st)


def test_without_a_model_form_it_is_the_noise_test():
    problem, st = _problem(2.0)
    problem.model_form_frf = None
    assert within_model_accuracy(problem, st) is problem.within_noise(st) is False
    assert nuisance_limit(1) == pytest.approx(1.2 * 10.827566, rel=1e-6)  # chi2.ppf(0.999, 1), tabulated
