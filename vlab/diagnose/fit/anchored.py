"""Fits with the model form anchored at the fitted lab's own modes.

The FRF model form (:class:`vlab.diagnose.model.modelform.FrfModelForm`) is the first-order effect on ``ln H``
of each mode's frequency, damping ratio and shape being uncertain; its sensitivities are peaked at the
mode's resonance, within a half-power bandwidth ``2 zeta f``. Computed at the nominal lab's modes, they cover
the nominal model's own errors. An effect that moves a lightly damped mode by more than that bandwidth (a
stiffened segment or an added mass at a few times its detection threshold moves a mode of damping ratio
0.001 by several bandwidths) carries that mode's model-form error to its new frequency, where the nominal
sensitivities are nearly zero: the covariance no longer covers it, the fit is pulled to a value that puts
the mode back under them, and a second effect is recruited to absorb the rest. The uncertainty of a mode
travels with the mode: for a lab with an effect, the same parameters with the same standard uncertainties,
their sensitivities taken with the modes at that lab's own frequencies and shapes
(:func:`vlab.diagnose.model.modelform.model_form_at`). The damping ratios do not travel: a sensitivity taken at a
more heavily damped peak is broader and larger, so a covariance that followed the fitted damping would
grow with it, and a fit that does not carry the covariance's determinant would run away towards ever
more damping.

The fit is then iterated: fit, re-anchor the covariance at the fitted lab, fit again from there, until the
value moves by less than a tenth of its own 95 % interval (iterated generalised least squares, the
covariance re-evaluated at each estimate: Carroll & Ruppert, *Transformation and Weighting in Regression*,
1988, Sec. 2.2; the covariance's dependence on the parameter is not differentiated, nor its determinant
carried: it changes little when a mode's sensitivities are only moved along the frequency axis). The
iteration need not converge -- each fit's chi-square is on its own anchor, and the iterates can cycle or
run away -- so the fit returned is the iterate whose lab the mismatch test's own statistic prefers: the
least ``|r|^2 + |x|^2`` with its modes moved within their model form
(:func:`vlab.diagnose.problem.nuisance.profiled_statistic`), one footing for all of them.

A pair is judged the same way (:func:`pair_on_anchor`): its second effect must be needed with the
covariance anchored at its better part alone -- the null hypothesis of that likelihood-ratio test is the
part alone, and the test's covariance is the null's. The null is the part's *best* fit alone: each part is
fitted from its own trials and from its value in the pair. Trials spread about the nominal value can leave a
local fit far from a value the data put near the other end of the parameter's range (a segment many times
softer than nominal); the pair, started elsewhere, finds that value, and with its other part near that
part's null value (a joint effectively rigid) beats the stranded fit by a margin the test would credit to
the other part -- a passenger. Started from the restriction of the pair's own fit, the part alone is, on the
footing it starts on, at least as good as the pair with its partner removed, to the fit's tolerance.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass

import numpy as np

from ...errors import VlabError
from ..data.measured import FrfData
from ..effects.hypotheses import Combination, Hypothesis
from ..model.labmodel import LabState
from ..model.modelform import model_form_at
from ..problem.nuisance import profiled, profiled_statistic, within_model_accuracy
from ..problem.residuals import Problem
from .estimate import fit_hypothesis
from .rules import NONLINEAR, evidence, passes_pair_rule

__all__ = ["ANCHOR_ITERATIONS", "anchored_problem", "fit_anchored", "PairOnAnchor", "pair_on_anchor"]

#: Most re-anchorings of one fit (each one model-form computation and one local refit).
ANCHOR_ITERATIONS = 5
#: The iteration stops when each parameter moves by less than this share of its 95 % interval's width.
ANCHOR_TOLERANCE = 0.1


def anchored_problem(problem: Problem, state: LabState) -> Problem:
    """``problem`` with its FRF model form anchored at ``state``'s own modes (module notes): the same data,
    weights, floor and policy, the model form's parameters and uncertainties, their sensitivities at
    ``state``'s modes. A problem without an FRF model form is returned as it is.

    Raises ModelError when ``state`` has no modes at the model form's points."""
    mff = problem.model_form_frf
    if mff is None or not isinstance(problem.data, FrfData):
        return problem
    d = problem.data
    at = model_form_at(mff, state, d.freq_hz, excitation_point=d.excitation_point, output_points=d.output_points)
    out = Problem(d, problem.base, problem.ctx, floor=problem.floor, use_phase=problem.use_phase,
                  model_form_frf=at, modal_model_form=problem.modal_model_form,
                  profile_nominal=problem.profile_nominal, policy=problem.policy, run=problem.run,
                  guard_s=problem.guard_s, replay_plant=problem.replay_plant, line_floor=problem.line_floor)
    out.model_form = problem.model_form
    return out


def fit_anchored(h: Hypothesis, problem: Problem, *, starts: np.ndarray | None = None,
                 iterations: int = ANCHOR_ITERATIONS) -> tuple[Hypothesis, Problem]:
    """Fit ``h`` with the model form anchored at its own fitted lab (module notes).

    Parameters
    ----------
    h : Hypothesis
        Fitted in place (as :func:`vlab.diagnose.fit.estimate.fit_hypothesis`), left at the last iterate; use
        the returned one.
    problem : Problem
        FRF data with their model form anchored at the nominal lab (without one, a plain fit).
    starts : ndarray, shape (n, k), optional
        Starting values [SI] of the first fit (default: the hypothesis's trials).
    iterations : int
        Most re-anchorings.

    Returns
    -------
    h : Hypothesis
        The iterate the mismatch test's statistic prefers (module notes): ``h`` itself or a fitted copy.
    anchored : Problem
        The footing of that iterate's ``chi2_``: ``problem`` anchored at the previous iterate's lab (``problem``
        itself for the first fit).

    Raises
    ------
    ModelError, SpecError
        As the fit, or a fitted lab without modes at the model form's points.
    """
    h = fit_hypothesis(h, problem, starts=starts)
    if problem.model_form_frf is None or not isinstance(problem.data, FrfData) or h.n_params == 0:
        return h, problem
    cur = problem
    iterates = [(_profiled_statistic(problem, h), copy.deepcopy(h), cur)]
    for _ in range(max(int(iterations), 0)):
        x = np.asarray(h.params_, dtype=float)
        cur = anchored_problem(problem, problem.state_for(h, x))
        h = fit_hypothesis(h, cur, starts=x[None, :])
        iterates.append((_profiled_statistic(problem, h), copy.deepcopy(h), cur))
        width = np.abs(np.diff(np.asarray(h.ci95_, dtype=float), axis=1))[:, 0]
        moved = np.abs(np.asarray(h.params_, dtype=float) - x)
        if np.all(np.isfinite(width)) and np.all(moved <= ANCHOR_TOLERANCE * width):
            break
    if not any(np.isfinite(t[0]) for t in iterates):  # no iterate could be profiled: the last, as fitted
        return h, cur
    _, best, footing = min(iterates, key=lambda t: t[0])
    return best, footing


def _profiled_statistic(problem: Problem, h: Hypothesis) -> float:
    """The mismatch test's statistic of ``h``'s fitted lab on ``problem``
    (:func:`vlab.diagnose.problem.nuisance.profiled_statistic`: its modes moved within their model form; the
    test's chi-square where the lab is not profiled) -- one footing for every iterate of :func:`fit_anchored`,
    whose own chi-squares are each on their own anchor; inf where the lab cannot be built."""
    try:
        st = problem.fitted_state(h)
        return profiled_statistic(problem, st) if profiled(problem, st) else float(problem.chi2(st, test=True))
    except (VlabError, ValueError, np.linalg.LinAlgError):
        return math.inf


def _alone_anchored(part: Hypothesis, x_in_pair: np.ndarray, problem: Problem) -> tuple[Hypothesis, Problem]:
    """``part`` (a copy) fitted alone with its own anchor (:func:`fit_anchored`) from its own trials and from its
    value ``x_in_pair`` [SI] in the pair, the better of the two by the mismatch test's own statistic (one
    footing for both: :func:`_profiled_statistic`; module notes: the likelihood-ratio test's null is the part's
    best fit alone)."""
    fits = [fit_anchored(copy.deepcopy(part), problem),
            fit_anchored(copy.deepcopy(part), problem, starts=np.asarray(x_in_pair, dtype=float)[None, :])]
    return min(fits, key=lambda t: _profiled_statistic(problem, t[0]))


@dataclass(frozen=True)
class PairOnAnchor:
    """A pair judged with the model form anchored at its better part alone (:func:`pair_on_anchor`).

    Attributes
    ----------
    keep : bool
        The second effect is needed there (the pair rule, :func:`vlab.diagnose.fit.rules.passes_pair_rule`,
        and the likelihood-ratio test).
    part : Hypothesis
        The better part, fitted alone with its own anchor (a copy).
    chi2_part, chi2_pair : float
        Their chi-squares on the part's anchored footing [1].
    evidence : float
        The pair's quasi-BIC evidence over the part there [1].
    """

    keep: bool
    part: Hypothesis
    chi2_part: float
    chi2_pair: float
    evidence: float

    def describe(self, pair_label: str) -> str:
        """One sentence for the diagnosis's notes about the pair labelled ``pair_label``."""
        verdict = "its second effect is needed there" if self.keep else \
            f"its second effect is not needed there: {self.part.label} alone is kept"
        return (f"{pair_label} judged with the model form anchored at {self.part.label}'s own modes (chi-square "
                f"{self.chi2_part:.4g} alone, {self.chi2_pair:.4g} with the second effect, quasi-BIC evidence "
                f"{self.evidence:.3g}): {verdict}")


def pair_on_anchor(pair: Combination, problem: Problem) -> PairOnAnchor:
    """Judge ``pair`` with the model form anchored at its better part alone (module notes).

    Each part is fitted alone with its own anchor (:func:`fit_anchored`), from its trials and from its value in
    the pair; the better one by the mismatch test's own statistic (:func:`_profiled_statistic`, one footing for
    all, where each chi-square is on its own anchor) is the null hypothesis; the pair is fitted
    on that footing from its own parameters, and kept when the part alone is not within the model's accuracy there
    (:func:`vlab.diagnose.problem.nuisance.within_model_accuracy`: its modes moved within their model form,
    the mismatch tests pass -- then a second effect has nothing to explain), and the pair passes the pair
    rule (a pair with a nonlinear part, or one that brings the data within the noise, is exempt from
    explaining the remainder) and the likelihood-ratio test.

    Parameters
    ----------
    pair : Combination
        The chosen pair, fitted (``params_`` set); not changed.
    problem : Problem
        FRF data with a model form anchored at the nominal lab.

    Returns
    -------
    PairOnAnchor

    Raises
    ------
    ModelError, SpecError
        As the fits.
    """
    fits = [_alone_anchored(p, x, problem) for p, x in zip(pair.parts, pair.split())]
    part, footing = min(fits, key=lambda t: _profiled_statistic(problem, t[0]))
    both = fit_hypothesis(copy.deepcopy(pair), footing, starts=np.asarray(pair.params_, dtype=float)[None, :])
    n = footing.n_obs
    c_hat = max(1.0, both.chi2_ / max(n - both.n_params, 1))
    chi2_0 = footing.chi2(footing.base)
    ev = evidence(both, part, chi2_0=chi2_0, n_obs=n, c_hat=c_hat)
    # the part alone within the model's accuracy (its modes moved within their model form, the mismatch
    # tests pass): a second effect has nothing to explain (as the search on the plant)
    alone = within_model_accuracy(footing, footing.fitted_state(part))
    # exempt from explaining the remainder: a nonlinear part (judged by rerun), or a pair that brings the data
    # within the noise where the part alone did not (as the pair rule on the plant)
    exempt = any(p.effect in NONLINEAR for p in pair.parts) or footing.within_noise(
        footing.fitted_state(both))
    keep = (not alone and passes_pair_rule(ev, (part.chi2_, both.chi2_), exempt, footing.policy)
            and footing.policy.needed(part.chi2_, both.chi2_, both.n_params - part.n_params, c_hat))
    return PairOnAnchor(bool(keep), part, float(part.chi2_), float(both.chi2_), float(ev))
