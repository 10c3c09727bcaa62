"""The stability boundary of a fitted chain candidate: the value nearest its fit at which the loop grows on the
recorded mode (:func:`destabilising_value`), the band of that mode (:func:`recorded_mode_band`) and the candidate
moved there (:func:`moved_to`), used by :mod:`vlab.diagnose.instability_cause`.

A fit to a limit cycle's FRFs lands near the stability boundary, on either side of it; the search walks from
the fitted value towards each bound of the parameter's range on a grid, then bisects the first step that
crosses into the unstable loop.

Source: the describing-function view of a limit cycle (Gelb & Vander Velde, *Multiple-Input Describing
Functions*, 1968, ch. 2).
"""

from __future__ import annotations

import copy
import math

import numpy as np

from ..effects.hypothesis import Hypothesis
from .identity import plausible_branches, plausible_modes
from .rules import evidence

#: Grid points from a candidate's fitted value to each bound of its range, searched for the stability
#: boundary, and the bisections that then narrow it (:func:`destabilising_value`).
BOUNDARY_STEPS = 12
BOUNDARY_BISECTIONS = 6


def destabilising_value(h: Hypothesis, problem, unstable_at) -> float | None:
    """The value of ``h``'s one parameter nearest its fit at which the loop is unstable, or None.

    From the fitted value toward each bound of the parameter's range (:meth:`Hypothesis.space`),
    :data:`BOUNDARY_STEPS` values (geometric for a log-scale parameter) are checked with ``unstable_at(x)``;
    the first unstable one and the stable one before it are bisected :data:`BOUNDARY_BISECTIONS` times and the
    unstable end kept. Of the two sides, the one whose value fits the FRFs better (chi-square) is returned.

    Parameters
    ----------
    h : Hypothesis
        Fitted, one parameter.
    problem : Problem
        Its data (the chi-square of the moved value).
    unstable_at : callable ``float -> bool``
        Whether the lab with ``h`` of that size has an unstable loop (one that grows at least at the
        recorded rate, :func:`recorded_growth_rate`).

    Returns
    -------
    float or None
        [SI], None when no value in the range makes the loop unstable.
    """
    if h.n_params != 1:
        return None
    _trials, lo, hi = h.space(problem.base, problem.ctx)
    x0, log = float(h.params_[0]), bool(h.log_scale[0])
    found = []
    for bound in (float(hi[0]), float(lo[0])):
        if not math.isfinite(bound) or bound == x0 or (log and not (bound > 0 and x0 > 0)):
            continue
        grid = (np.geomspace if log else np.linspace)(x0, bound, BOUNDARY_STEPS + 1)[1:]
        stable = x0
        for x in grid:
            if unstable_at(float(x)):
                a, b = stable, float(x)
                for _ in range(BOUNDARY_BISECTIONS):
                    m = math.sqrt(a * b) if log else 0.5 * (a + b)
                    a, b = (a, m) if unstable_at(m) else (m, b)
                found.append(b)
                break
            stable = float(x)
    if not found:
        return None
    return min(found, key=lambda x: _chi2(problem, h, x))


def recorded_mode_band(frequency_hz: float, natural_hz, same_mode: bool, nyquist_hz: float, *,
                       sigma_rel=None, z: float = 0.0) -> tuple[float, float]:
    """The frequencies [Hz] on which a loop pole counts as the recorded oscillation's (:func:`search_cause`):
    with ``same_mode`` (above the measured band) the intervals of the natural frequencies that may be nearest
    ``frequency_hz`` (:func:`~vlab.diagnose.fit.identity.plausible_modes`), each up to half-way to its
    neighbours, else the branches it may lie on (:func:`~vlab.diagnose.fit.identity.plausible_branches`); from
    the lowest to the highest, within ``(0, nyquist_hz]``; ``natural_hz`` the structure's natural frequencies
    [Hz], ``sigma_rel`` their relative model-form uncertainty [1] and ``z`` the intervals' half-width in standard
    uncertainties (none: the nearest mode or the branch alone). The same criterion by which a rerun reproduces
    it (:func:`~vlab.diagnose.fit.identity.reproduces_oscillation`)."""
    modes = plausible_modes(frequency_hz, natural_hz, sigma_rel, z)  # checks sigma_rel, drops unusable values
    if same_mode and modes.size:
        f = np.asarray(natural_hz, dtype=float).ravel()
        fs = np.sort(f[np.isfinite(f) & (f > 0)])
        spans = []
        for m in modes:
            below, above = fs[fs < m], fs[fs > m]
            spans.append((0.5 * (m + below[-1]) if below.size else 0.0,
                          0.5 * (m + above[0]) if above.size else nyquist_hz))
    else:
        spans = plausible_branches(frequency_hz, natural_hz, sigma_rel, z) or [(0.0, math.inf)]
    lo, hi = min(a for a, _b in spans), max(b for _a, b in spans)
    return float(max(lo, 0.0)), float(min(hi, nyquist_hz))


def _chi2(problem, h: Hypothesis, x: float) -> float:
    """Chi-square of ``h`` of size ``x`` on the fit's footing (the linearly whitened residuals)."""
    r = problem.residual(problem.state_for(h, np.array([x])))
    return float(r @ r)


def moved_to(h: Hypothesis, problem, x: float, chi2_0: float, c_hat: float) -> Hypothesis | None:
    """A copy of ``h`` at ``x`` [SI] with its chi-square, information criteria and misfit there, if the FRFs
    still support it over the nominal lab (quasi-BIC evidence at least the policy's ``evidence`` over the
    nominal chi-square ``chi2_0``, overdispersion ``c_hat``, both on ``problem``'s data, a
    :class:`~vlab.diagnose.problem.residuals.Problem`); None otherwise. Its interval is one-sided: what is known
    is the side of the stability boundary."""
    g = copy.copy(h)
    g.params_ = np.array([x])
    g.chi2_ = _chi2(problem, h, x)
    g.aic_, g.bic_ = problem.information(g.chi2_, g.n_params)
    g.misfit_ = problem.misfit(problem.state_for(h, g.params_))
    g.moved_from_ = float(h.params_[0])
    # the FRF fit's interval no longer holds the value: what is known is the side of the stability boundary
    g.ci95_ = np.array([[x, np.nan]]) if x > g.moved_from_ else np.array([[np.nan, x]])
    return g if evidence(g, None, chi2_0=chi2_0, n_obs=problem.n_obs, c_hat=c_hat) >= problem.policy.evidence else None
