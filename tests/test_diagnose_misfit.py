"""The diagnosis's FRF misfit and its noise floor (vlab.diagnose.problem): checked against closed forms and a
Monte Carlo simulation of circular complex noise."""

from __future__ import annotations

import numpy as np
import pytest

from vlab.diagnose.problem import log_misfit, noise_misfit


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
