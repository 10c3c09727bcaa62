"""Look-alikes by prediction: fitted hypotheses that no data of this noise and model accuracy can tell apart.

Two hypotheses fitted to the same data are compared by their chi-squares; the difference is evidence for
one of them only if the residual model (noise, the model-error floor and the model form) describes what
the data leave. Where it does not, a small difference between the two *predictions* can be multiplied by
a large systematic residual: ``chi2_a - chi2_b = (r_a - r_b) . (r_a + r_b)``. The distance between the two
fitted predictions on the fits' footing,

    D = || r_a - r_b ||^2    (r: the whitened residual vector of :meth:`Problem.residual`),

is what an exact model would let the data resolve: if ``b`` were true, ``a``'s excess chi-square would be
at most a noncentral chi-square of noncentrality ``D``. When ``D`` is below the policy's one-parameter
limit (:meth:`vlab.diagnose.policy.DecisionPolicy.separable`), a test at the false-alarm rate has no better
than even power to separate them, whatever their chi-squares say: they are reported as look-alikes
of each other.

Screening is exact: by the triangle inequality ``|sqrt(chi2_a) - sqrt(chi2_b)| <= sqrt(D)``, so only the
fits whose root chi-square lies within ``sqrt(limit)`` of the chosen one's need their distance computed
(one prediction each).

Source: the detection-threshold argument of :mod:`vlab.diagnose.detectability` (Kay, *Fundamentals of
Statistical Signal Processing*, Vol. II, Sec. 7.3), applied to a pair of hypotheses instead of a
hypothesis and the nominal model.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable

from ..model.labmodel import LabState
from ..problem.residuals import Problem
from ..effects.hypotheses import Hypothesis

__all__ = ["prediction_distance", "inseparable", "separation_note"]


def prediction_distance(problem: Problem, a: LabState, b: LabState) -> float:
    """Chi-square distance [1] between the predictions of the labs ``a`` and ``b`` on ``problem``'s footing:
    ``||r_a - r_b||^2`` of their whitened residual vectors (shape (n_obs,) each, :meth:`Problem.residual`),
    the chi-square ``a`` would leave if ``b``'s prediction were the data. A lab that cannot be built gives
    the residual's penalty (a large distance)."""
    ra, rb = problem.residual(a), problem.residual(b)
    d = ra - rb
    return float(d @ d)


def inseparable(chosen: Hypothesis, chi2_chosen: float, others: Iterable[tuple[Hypothesis, float]],
                problem: Problem, state_of: Callable[[Hypothesis], LabState],
                c_hat: float = 1.0) -> list[tuple[Hypothesis, float]]:
    """The fitted hypotheses of ``others`` that data of this noise and model accuracy cannot tell from
    ``chosen`` (module notes).

    Parameters
    ----------
    chosen : Hypothesis
        The selected hypothesis (fitted).
    chi2_chosen : float
        Its chi-square on ``problem`` [1].
    others : iterable of (Hypothesis, float)
        Candidates with their chi-squares on ``problem`` [1]; those with another number of parameters than
        ``chosen``, or ``chosen``'s label, are passed over.
    problem : Problem
        FRF data and their residual model (:class:`vlab.diagnose.problem.residuals.Problem`).
    state_of : callable
        Hypothesis -> the lab at its fitted value (:meth:`Problem.state_for` or a plant model's state).
    c_hat : float
        Overdispersion [1] (>= 1), scaling the limit as in :meth:`DecisionPolicy.lr_limit`.

    Returns
    -------
    list of (Hypothesis, float)
        Each inseparable candidate with its distance ``D`` [1], closest first.
    """
    limit = problem.policy.lr_limit(1, c_hat)
    if not math.isfinite(chi2_chosen):
        return []
    root = math.sqrt(max(chi2_chosen, 0.0))
    near = [h for h, c in others if h.label != chosen.label and h.n_params == chosen.n_params
            and math.isfinite(c) and abs(math.sqrt(max(c, 0.0)) - root) <= math.sqrt(limit)]
    if not near:
        return []
    base = state_of(chosen)
    out = []
    for h in near:
        d = prediction_distance(problem, state_of(h), base)
        if not problem.policy.separable(d, c_hat):
            out.append((h, d))
    return sorted(out, key=lambda t: t[1])


def separation_note(chosen: Hypothesis, found: list[tuple[Hypothesis, float]], problem: Problem,
                    c_hat: float = 1.0) -> str:
    """A sentence for the diagnosis's notes naming the look-alikes ``found`` of ``chosen``.

    Parameters
    ----------
    chosen : Hypothesis
        The selected hypothesis.
    found : list of (Hypothesis, float)
        What :func:`inseparable` returned: each look-alike and its distance [1].
    problem : Problem
        The problem they were compared on (its policy gives the limit and the false-alarm rate).
    c_hat : float
        Overdispersion [1], as given to :func:`inseparable`.

    Returns
    -------
    str
    """
    limit = problem.policy.lr_limit(1, c_hat)
    items = ", ".join(f"{h.label} ({d:.3g})" for h, d in found)
    return (f"look-alikes by prediction: {items}: each one's fitted prediction lies within chi-square "
            f"{limit:.4g} of {chosen.label}'s (the limit of a one-parameter test at the false-alarm rate "
            f"{problem.policy.false_alarm_rate:g}), so no data of this noise and model accuracy can tell them "
            "apart; a difference of their chi-squares beyond that comes from what the model leaves, not from "
            "the effect")
