"""The diagnosis's FRF misfit and its noise floor (vlab.diagnose.problem.residuals): checked against closed forms and a
Monte Carlo simulation of circular complex noise."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

from vlab.diagnose.problem.misfits import log_misfit, noise_misfit


def test_log_misfit_of_a_uniform_gain_is_its_log():
    rng = np.random.default_rng(0)
    h = rng.standard_normal(50) + 1j * rng.standard_normal(50)
    w = rng.uniform(0.5, 2.0, 50)
    assert log_misfit(1.2 * h, h, w) == pytest.approx(np.log10(1.2), rel=1e-12)
    assert np.isnan(log_misfit(h[:0], h[:0], w[:0]))


def test_noise_misfit_matches_a_monte_carlo_of_circular_noise():
    """E[misfit^2] of an exact model against noisy measurements equals noise_misfit^2 (small noise)."""
    rng = np.random.default_rng(1)
    n, trials = 400, 400
    h = (rng.standard_normal(n) + 1j * rng.standard_normal(n)) * rng.uniform(0.1, 10.0, n)
    s_rel = rng.uniform(0.002, 0.02, n)                     # relative noise, 0.2-2 %
    var = (s_rel * np.abs(h)) ** 2                           # E|noise|^2
    w = 1.0 / (s_rel**2 + 0.005**2)                          # the diagnosis's weights, floor 0.5 %
    sq = []
    for _ in range(trials):
        noise = np.sqrt(var / 2) * (rng.standard_normal(n) + 1j * rng.standard_normal(n))
        sq.append(log_misfit(h, h + noise, w) ** 2)
    assert np.sqrt(np.mean(sq)) == pytest.approx(noise_misfit(h, var, w), rel=0.02)


def _problem(n_lines: int, var_dof):
    from vlab.diagnose.data.measured import FrfData
    from vlab.diagnose.problem.residuals import Problem

    f = np.arange(1, n_lines + 1) * 0.05
    ones = np.ones((n_lines, 1))
    data = FrfData("synthetic", "frf", f, ones.astype(complex), 1e-4 * ones, 4, (4,), var_dof=var_dof)
    return Problem(data, None, None, floor=0.0)


def test_peak_limit_holds_the_false_alarm_rate_when_the_noise_is_estimated():
    """Residuals scaled by a noise variance estimated with nu degrees of freedom (each line its own estimate,
    the worst case) exceed the F-based peak limit in about the test's rate of noise-only records; the
    chi-square limit, which takes the variance as known, is exceeded far more often."""
    from vlab.diagnose.data.frfestimate import pooled_dof

    n, nu, trials = 1000, pooled_dof(2), 2000
    rng = np.random.default_rng(7)
    z2 = rng.chisquare(2, (trials, n))                  # |e|^2 / (sigma^2 / 2) with the true sigma
    est = rng.chisquare(nu, (trials, n)) / nu           # estimated sigma^2 / true sigma^2
    peak = np.max(z2 / est, axis=1)
    from vlab.diagnose.policy import DecisionPolicy

    exact = DecisionPolicy()
    p_f, p_chi = _problem(n, nu), _problem(n, None)
    p_f.policy = p_chi.policy = exact
    f_limit, chi_limit = p_f.peak_limit(), p_chi.peak_limit()
    assert f_limit > 1.5 * chi_limit
    assert np.mean(peak > f_limit) < 2 * exact.test_rate  # the test's rate nominal
    assert np.mean(peak > chi_limit) > 0.05


def test_a_problem_pickles_without_its_background_reruns():
    """Worker processes get the problem; its run context's background rerun processes and rerun cache stay
    here (the copy gets an empty context)."""
    problem = _problem(4, None)
    problem.run.background[("nominal", "mujoco", 0)] = (lambda: None, None)  # not picklable
    problem.run.reruns[("nominal", "mujoco", 0)] = "a recording"
    problem.run.note = "2 MuJoCo reruns as one mujoco.batch"
    back = pickle.loads(pickle.dumps(problem))
    assert back.run.background == {} and back.run.reruns == {} and back.run.note == ""
    assert np.array_equal(back.data.h, problem.data.h) and back.n_obs == problem.n_obs
    assert ("nominal", "mujoco", 0) in problem.run.background  # the original keeps them


def test_exact_time_error_is_the_time_domain_error_of_a_model_off_by_its_uncertainty():
    """exact_time_error against a synthesis in the time domain: a multisine through an FRF, the model's FRF off
    by a circular complex relative error of a known variance per line, the relative RMS of the two periodic
    responses' difference averaged over draws (Parseval over whole periods)."""
    from vlab.diagnose.problem.misfits import exact_time_error

    rng = np.random.default_rng(8)
    n, lines = 4096, np.arange(3, 200)
    f = lines / 20.0
    h = 1.0 / (1.0 - (f / 4.0) ** 2 + 0.02j * f / 4.0)
    amp = rng.uniform(0.5, 1.5, lines.size)
    s2 = rng.uniform(0.0, 0.01, lines.size)  # relative variance per line
    spec = np.zeros(n // 2 + 1, complex)
    spec[lines] = amp * h * np.exp(2j * np.pi * rng.random(lines.size))
    y = np.fft.irfft(spec, n)
    errs = []
    for _ in range(400):
        e = np.sqrt(s2 / 2) * (rng.standard_normal(lines.size) + 1j * rng.standard_normal(lines.size))
        spec_m = spec.copy()
        spec_m[lines] *= 1 + e
        errs.append(np.sum((np.fft.irfft(spec_m, n) - y) ** 2) / np.sum(y**2))
    assert exact_time_error(h, s2, amp) == pytest.approx(np.sqrt(np.mean(errs)), rel=0.03)
    assert np.isnan(exact_time_error(h, s2, np.zeros_like(amp)))
