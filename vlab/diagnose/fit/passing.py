"""Rule 3's last step: the choice explains the data by the statistic that declared the mismatch.

The selection (:func:`vlab.diagnose.fit.rules.select`) ranks on the fit's footing, where the model form
enters to first order only; the mismatch may have been declared by a test on another footing -- the nominal
lab's modes profiled within their model form, which must move beyond it (most often one mode's damping
ratio, many standard uncertainties). A choice that leaves the data beyond any of the tests that declared
the mismatch (:func:`vlab.diagnose.problem.nuisance.within_model_accuracy`: the chi-square, the largest
line and the moves), or that does not fit the data significantly better than the nominal lab by their
statistic (:func:`vlab.diagnose.problem.nuisance.improves_on_nominal`), has not explained it, however
much chi-square it removes on the fit's footing: an effect that shifts every mode a little (a member's
rigidity) absorbs there a model error that the profiled test already allows.

The first of the ranked single effects that passes both is then the choice. Where none does, the first
ranked pair that passes both and needs both its parts -- each part alone, fitted, is beaten by the pair by
the likelihood-ratio test at the policy's false-alarm rate (:meth:`vlab.diagnose.policy.DecisionPolicy.
needed`), so that neither is a passenger -- is the choice: the selection's own pair rule asks a second
effect to remove the policy's ``explained_share`` of the chi-square its first leaves, which a mismatch
declared by the moves of a few modes, with a total chi-square near the noise's, cannot show -- the share of a
chi-square that is mostly noise says nothing of what a second effect explains. A pair replaces only a choice
that is no explanation by that definition either (:func:`passing_choice`).
"""

from __future__ import annotations

import copy
import math

import numpy as np

from ...errors import VlabError
from ..effects.hypotheses import Combination, Hypothesis
from ..problem.nuisance import improves_on_nominal, moves_left, profiled, within_model_accuracy
from ..problem.residuals import Problem
from .estimate import fit_hypothesis
from .rules import explains_remainder

__all__ = ["both_parts_needed", "parts_fitted", "passing_choice", "passing_single"]


def _passes(h: Hypothesis, problem: Problem) -> bool:
    """Whether ``h``'s fitted lab passes the tests that declared the mismatch and improves on the nominal lab
    by their statistic (a lab that cannot be built or profiled does not pass)."""
    try:
        st = problem.fitted_state(h)
        return within_model_accuracy(problem, st) and improves_on_nominal(problem, st, h.n_params)
    except (VlabError, ValueError, np.linalg.LinAlgError):
        return False


def _first_passing_single(chosen: Hypothesis, ranked: list[Hypothesis], problem: Problem,
                          most: int) -> Hypothesis | None:
    """The first of the ranked single effects (not of ``chosen``'s label) that passes, examined in the order of the moves
    they leave to first order where the nominal lab was profiled (:func:`moves_left`), else in their rank."""
    def left(h: Hypothesis) -> float:
        try:
            return moves_left(problem, problem.fitted_state(h))
        except (VlabError, ValueError, np.linalg.LinAlgError):
            return math.inf

    singles = [h for h in ranked if not isinstance(h, Combination) and h.label != chosen.label]
    if profiled(problem, problem.base):
        order = {id(h): left(h) for h in singles}
        singles = sorted(singles, key=lambda h: order[id(h)])
    return next((h for h in singles[:most] if _passes(h, problem)), None)


def passing_single(chosen: Hypothesis | None, ranked: list[Hypothesis], problem: Problem,
                   most: int) -> Hypothesis | None:
    """The single effect that explains the data where the choice does not (module notes).

    Parameters
    ----------
    chosen : Hypothesis or None
        The choice of :func:`vlab.diagnose.fit.rules.select` (a single effect or a pair), fitted.
    ranked : list of Hypothesis
        All fitted hypotheses, best first.
    problem : Problem
    most : int
        Ranked single effects examined at most (each costs a profile of its modes).

    Returns
    -------
    Hypothesis or None
        The passing single effect; None where ``chosen`` passes, is None, or no examined single effect passes.
    """
    if chosen is None or _passes(chosen, problem):
        return None
    return _first_passing_single(chosen, ranked, problem, most)


def parts_fitted(problem: Problem, pair: Combination, ranked: list[Hypothesis]) -> list[Hypothesis]:
    """The parts of ``pair``, each fitted alone: the better of the ranked single fit of the same label (else a
    new fit of a copy on ``problem`` from its trials) and a fit started from the part's value in the pair (the
    likelihood-ratio test's null is the part's best fit alone; :mod:`vlab.diagnose.fit.anchored`'s notes say
    why its trials alone do not suffice); a part that cannot be fitted is left out.

    Parameters
    ----------
    problem : Problem
    pair : Combination
        Fitted (``params_`` set).
    ranked : list of Hypothesis
        Fitted hypotheses (their single fits are reused).

    Returns
    -------
    list of Hypothesis
        Fitted, in the pair's order; shorter than ``pair.parts`` where a part could not be fitted.

    Raises
    ------
    AttributeError
        ``pair`` not fitted.
    """
    singles = {h.label: h for h in ranked if not isinstance(h, Combination)}
    out = []
    for part, x in zip(pair.parts, pair.split()):
        fits = [singles[part.label]] if part.label in singles else []
        for starts in ([] if fits else [None]) + [x[None, :]]:
            try:
                fits.append(fit_hypothesis(copy.copy(part), problem, starts=starts))
            except (VlabError, ValueError, np.linalg.LinAlgError):
                continue
        if fits:
            out.append(min(fits, key=lambda h: h.chi2_))
    return out


def both_parts_needed(pair: Combination, ranked: list[Hypothesis], problem: Problem) -> bool:
    """Whether each part of ``pair`` is needed beside the other: the pair beats each part alone
    (:func:`parts_fitted`) by the likelihood-ratio test of the policy, with the pair's overdispersion. A part
    that cannot be fitted alone counts as not needed (the pair is refused).

    Parameters
    ----------
    pair : Combination
        Fitted (``params_``, ``chi2_``).
    ranked : list of Hypothesis
        Fitted hypotheses (their single fits are reused).
    problem : Problem

    Returns
    -------
    bool
    """
    parts = parts_fitted(problem, pair, ranked)
    if len(parts) < len(pair.parts):
        return False
    c_hat = max(1.0, pair.chi2_ / max(problem.n_obs - pair.n_params, 1))
    return all(problem.policy.needed(alone.chi2_, pair.chi2_, pair.n_params - alone.n_params, c_hat)
               for alone in parts)


def passing_choice(chosen: Hypothesis | None, ranked: list[Hypothesis], problem: Problem,
                   most: int, chi2_0: float) -> Hypothesis | None:
    """Rule 3's last step (module notes): the single effect, else the pair, that explains the data by the
    statistic that declared the mismatch where ``chosen`` does not.

    A pair replaces only a choice that is no explanation by the selection's own definition either: one that
    removes less than the policy's ``explained_share`` of the nominal chi-square ``chi2_0``
    (:func:`vlab.diagnose.fit.rules.explains_remainder`); one that removes more stays, and what it leaves is
    reported as its remainder (rule 10) rather than given to a second effect.

    Parameters
    ----------
    chosen : Hypothesis or None
        The choice of :func:`vlab.diagnose.fit.rules.select`, fitted.
    ranked : list of Hypothesis
        All fitted hypotheses, best first.
    problem : Problem
    most : int
        Ranked single effects, and ranked pairs, examined at most (each costs a profile of its modes).
    chi2_0 : float
        The nominal lab's chi-square on the fits' footing [1].

    Returns
    -------
    Hypothesis or None
        The replacement; None where ``chosen`` passes, is None, or nothing examined passes.
    """
    if chosen is None or _passes(chosen, problem):
        return None
    single = _first_passing_single(chosen, ranked, problem, most)
    if single is not None or explains_remainder(chi2_0, chosen.chi2_, problem.policy):
        return single
    pairs = [h for h in ranked if isinstance(h, Combination) and h is not chosen][:most]
    return next((p for p in pairs if _passes(p, problem) and both_parts_needed(p, ranked, problem)), None)
