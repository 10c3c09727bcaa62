"""The mismatch limits hold their false-alarm rate when the noise variance is estimated from the data.

A periodic recording's noise is estimated per line from the scatter of its periods and pooled by a
running median over neighbouring lines (:mod:`vlab.diagnose.data.frfestimate`); the decision's limits
(:mod:`vlab.diagnose.policy`) take that estimate's degrees of freedom into account. Checked here by
simulation, independently of the formulas: complex Gaussian noise on every period of a multi-channel FRF,
the variance estimated and pooled exactly as the estimator does, and the squared residuals of the true FRF
(exactly Gaussian over the estimated variance) summed and maximised as the tests do.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.stats

from vlab.diagnose.data.frfestimate import POOL_WIDTH, _pooled_variance, pooled_dof
from vlab.diagnose.policy import DecisionPolicy


def _trials(m: int, n_trials: int, n_lines: int = 300, n_channels: int = 2, seed: int = 5):
    """Total chi-square and largest line of ``n_trials`` noise-only data sets (m periods each)."""
    rng = np.random.default_rng(seed)
    f = np.linspace(1.0, 25.0, n_lines)
    sigma = (1.0 + 0.5 * np.sin(f / 3.0))[:, None] * np.ones(n_channels)  # a smooth noise spectrum
    dof = 2 * (m - 1)
    chi2, peak = np.empty(n_trials), np.empty(n_trials)
    for t in range(n_trials):
        noise = (rng.standard_normal((m, n_lines, n_channels)) + 1j * rng.standard_normal((m, n_lines, n_channels)))
        hp = sigma * np.sqrt(m / 2.0) * noise  # each period's error; their mean has variance sigma^2
        h = hp.mean(axis=0)
        own = np.sum(np.abs(hp - h) ** 2, axis=0) / (m - 1) / m
        var = np.maximum(_pooled_variance(own, dof), own)
        r2 = np.abs(h) ** 2 / (var / 2.0)  # re^2 + im^2, each part over its standard deviation
        chi2[t], peak[t] = r2.sum(), r2.max()
    return chi2, peak, n_lines * n_channels


def test_pooled_median_degrees_of_freedom_match_the_simulated_scatter():
    """The running median of 21 per-line estimates from two periods scatters as a chi-square estimate with
    2 * 21 * ln(2)^2 = 20.2 degrees of freedom (the sample median's asymptotic variance), not with the
    normal-theory (2/pi) * 21 * 2 = 26.7."""
    rng = np.random.default_rng(2)
    own = rng.chisquare(2, (20000, 1)) / 2.0
    pooled = _pooled_variance(own, 2)[POOL_WIDTH:-POOL_WIDTH, 0]
    # neighbouring medians share lines: the relative variance of one is the scatter over all of them
    nu_sim = 2.0 / np.var(pooled)
    assert pooled_dof(2) == pytest.approx(2 * POOL_WIDTH * np.log(2) ** 2, rel=1e-9)
    assert nu_sim == pytest.approx(pooled_dof(2), rel=0.1)
    assert pooled_dof(200) == pytest.approx(2 / np.pi * POOL_WIDTH * 200, rel=0.01)  # the normal limit


def test_the_band_edges_pool_real_neighbours():
    """At the first and last lines the pool holds neighbouring lines (mirrored), not copies of the edge
    line's own two-degree-of-freedom estimate: the squared residual of an edge line stays within the
    F law of the pooled estimate."""
    rng = np.random.default_rng(4)
    n_trials, n_lines = 20000, 40
    h = (rng.standard_normal((n_trials, n_lines)) + 1j * rng.standard_normal((n_trials, n_lines))) / np.sqrt(2)
    d = (rng.standard_normal((n_trials, n_lines)) + 1j * rng.standard_normal((n_trials, n_lines))) / np.sqrt(2)
    own = np.abs(d) ** 2  # the two periods' difference: independent of their mean, 2 degrees of freedom
    pooled = np.stack([_pooled_variance(o[:, None], 2)[:, 0] for o in own])
    r2 = np.abs(h[:, 0]) ** 2 / (np.maximum(pooled[:, 0], own[:, 0]) / 2.0)
    q = 1 - 1e-3
    assert np.quantile(r2, q) < 1.1 * 2 * scipy.stats.f.ppf(q, 2, pooled_dof(2))


@pytest.mark.parametrize("m", [2, 3])
def test_limits_hold_the_rate_with_an_estimated_variance(m):
    """The total chi-square and largest-line limits with the estimate's degrees of freedom are exceeded at
    most at the test's rate (within the simulation's scatter); the limits that take the variance as known
    are exceeded several times more often (so the test can fail)."""
    p = DecisionPolicy(false_alarm_rate=0.05)
    n_trials = 3000
    chi2, peak, n_lines = _trials(m, n_trials)
    nu = pooled_dof(2 * (m - 1))
    allowance = p.test_rate + 3 * np.sqrt(p.test_rate / n_trials)
    assert np.mean(chi2 > p.chi2_limit(2 * n_lines, nu, 2 * POOL_WIDTH)) <= allowance
    assert np.mean(peak > p.line_limit(n_lines, 2, nu)) <= allowance
    assert np.mean(peak > p.line_limit(n_lines, 2)) > 3 * p.test_rate


def test_satterthwaite_limit_reduces_to_chi_square_for_a_known_variance():
    p = DecisionPolicy()
    assert p.chi2_limit(500, 1e9, 42) == pytest.approx(p.chi2_limit(500), rel=1e-3)
    assert p.chi2_limit(500, 30.0, 42) > p.chi2_limit(500, 30.0, 2) > p.chi2_limit(500)
    assert p.nuisance_limit(5, 30.0) > p.nuisance_limit(5)
    with pytest.raises(ValueError, match="nu > 4"):
        p.chi2_limit(500, 4.0, 42)


def test_simulated_limit_agrees_with_satterthwaite_and_covers_a_band_of_a_few_lines():
    """The simulated quantile of the sum of g F(g, nu) agrees with the Satterthwaite form where both apply
    (a second computation of the same law), and gives a finite limit where only it applies: two periods
    pooled over a band of three lines (nu = 2.9), above the known-variance limit."""
    p = DecisionPolicy()
    assert p.chi2_limit_simulated(840, 20.2, 42) == pytest.approx(p.chi2_limit(840, 20.2, 42), rel=0.03)
    nu = pooled_dof(2, 3)
    assert nu < 4
    lim = p.chi2_limit_simulated(6, nu, 6)
    assert np.isfinite(lim) and lim > p.chi2_limit(6)
    assert lim == p.chi2_limit_simulated(6, nu, 6)  # seeded: the same limit every run


def test_relative_error_holds_the_line_rate_where_the_log_ratio_does_not():
    """At low signal-to-noise ratios (median relative noise 0.15, lines up to the 0.5 cut) the largest line of
    the relative error ``H/h - 1`` (the tests' form, :mod:`vlab.diagnose.problem.forms`) stays within the F
    law of the pooled estimate, while the log ratio's heavier tail (``ln(1 + e)`` as ``e`` nears -1)
    exceeds the same limit far more often. The data are the true FRF plus noise over two periods, the
    variance estimated and pooled as the estimator does, lines beyond the 0.5 cut left out as the
    Problem does."""
    from vlab.diagnose.data.measured import MAX_RELATIVE_NOISE
    from vlab.diagnose.problem.forms import line_residual

    rng = np.random.default_rng(11)
    p = DecisionPolicy(false_alarm_rate=0.05)
    m, n_lines, n_trials = 2, 300, 1000
    f = np.linspace(1.0, 25.0, n_lines)
    h_true = (1.0 + 0.8 * np.cos(f)) * np.exp(1j * f / 4.0)  # unit-level FRF with shallow dips
    sigma = 0.15 * (1.0 + 0.6 * np.sin(f / 2.0))  # absolute noise level of the averaged FRF
    nu = pooled_dof(2 * (m - 1))
    hits = {"relative": 0, "log": 0}
    for _ in range(n_trials):
        noise = rng.standard_normal((m, n_lines)) + 1j * rng.standard_normal((m, n_lines))
        hp = h_true + sigma * np.sqrt(m / 2.0) * noise
        h = hp.mean(axis=0)
        own = np.sum(np.abs(hp - h) ** 2, axis=0) / (m - 1) / m
        var = np.maximum(_pooled_variance(own[:, None], 2 * (m - 1))[:, 0], own)
        srel = np.sqrt(var) / np.abs(h)
        used = srel <= MAX_RELATIVE_NOISE
        ps = srel[used] / np.sqrt(2.0)
        limit = p.line_limit(int(used.sum()), 2, nu)
        for name in ("relative", "log"):
            r = line_residual(h_true[used], h[used], ps, form=name)
            k = r.size // 2
            hits[name] += bool(np.max(r[:k] ** 2 + r[k:] ** 2) > limit)
    allowance = p.test_rate + 3 * np.sqrt(p.test_rate / n_trials)
    assert hits["relative"] / n_trials <= allowance
    assert hits["log"] / n_trials > 3 * p.test_rate
