"""Decisions made on the MuJoCo plant's linearisation: a selected pair against its parts, a selected single
effect against its look-alikes.

The FE fit selects (:func:`vlab.diagnose.fit.rules.select`); the refit on the
plant's linearisation (:mod:`vlab.diagnose.fit.plantfit`) is the model that is
rerun, and the FE/plant model-form difference can change the decision.

A selected *pair* is first checked on the plant's linearisation
(:func:`reduce_pair_on_plant`): the selection's pair rule is applied again
there (the main part's mode-moving parameter refitted; in a kept pair the
other part's too, :func:`vlab.diagnose.fit.plantfit.refit_parts`), since a second
effect can pass it on the FE model only by absorbing the same model-form
difference. A selected *single* effect is compared there with its
look-alikes (:func:`choose_on_plant`: effects the FE fit cannot tell from
it, and those the FE fit orders by less than the FE/plant difference
measured on the chosen effect, each scored on the plant; the least
chi-square wins), since the FE/plant difference can order look-alikes
wrongly (the stiffness of one end segment of the grid's top beam against
its mirror; a mass at the grid's hanger point 20 against point 21, 22 mm
away).

Source: model updating with a reference model (Friswell & Mottershead,
*Finite Element Model Updating in Structural Dynamics*, 1995, ch. 1): a
parameter is only meaningful for the model it was fitted on.
"""

from __future__ import annotations

import copy
import math

import numpy as np

from ...errors import ModelError, SpecError
from ..effects.hypothesis import Combination, Hypothesis
from ..problem.nuisance import within_model_accuracy
from .estimate import fit_hypothesis
from .locate import at_places
from .plantfit import PlantModel, PlantRefit, PlantScore, map_on_plant, refit_index, refit_parts
from .rules import NONLINEAR, evidence, passes_pair_rule


def reduce_pair_on_plant(model: PlantModel, pair: Combination, ranked: list, *,
                         judged_by_rerun: bool = False) -> tuple[Hypothesis, PlantRefit | None, str | None]:
    """Apply the pair rule of the selection again on the plant's linearisation.

    The FE fit selects a pair only if it beats the best single effect by
    the policy's ``evidence`` in quasi-BIC and explains what the single effect
    leaves (:func:`vlab.diagnose.fit.rules.select`,
    :func:`vlab.diagnose.fit.rules.explains_remainder`). A second effect can pass that rule by
    absorbing the FE/plant model-form difference left next to a mode-moving
    effect (grid joint 11 with a spurious added mass at 18). Here the pair
    and each of its parts alone (at its value in the pair) are scored on the
    plant's linearisation, and the same rule decides -- except for a pair with a nonlinear part that its
    rerun judged (``judged_by_rerun``: rule 4, :func:`vlab.diagnose.fit.selection.tie_break_by_rerun`), kept
    here (refitted): its linearisation is a describing function. A part alone that
    moves modes is refitted there (:meth:`PlantModel.refit`); in the pair,
    the part with the better BIC alone is refitted and the other held at its
    FE value for the decision; a pair that is kept then has its other part
    refitted too, when it moves modes, and the main part again
    (:func:`refit_parts`: coordinate descent, not a two-parameter search).
    Data compared within the model's own uncertainty: as for a second effect
    searched on the plant (:func:`vlab.diagnose.fit.plantpair.second_effect_on_plant`),
    the pair is reduced whenever its better part alone leaves only what its
    modes' model form allows (:func:`vlab.diagnose.problem.nuisance.within_model_accuracy`),
    whatever the pair rule says: a second effect is then not needed (the
    likelihood-ratio question of the policy answered by the model form); and a pair that
    leaves only that where its better part alone does not is exempt from the rule's share of the
    remainder (the statistic that declared the mismatch judges, :mod:`vlab.diagnose.fit.passing`).

    Parameters
    ----------
    model : PlantModel
    pair : Combination
        The selected pair (fitted).
    ranked : list of Hypothesis
        The fitted hypotheses: a part's own FE fit there decides which part
        is refitted in the pair and is returned when the pair is reduced to
        it (a part without one is fitted on the FE model then).
    judged_by_rerun : bool
        Pairs with a nonlinear part were judged by rerun (the data hold time histories and reruns ran).

    Returns
    -------
    chosen : Hypothesis
        ``pair`` or one of the single fits of ``ranked``.
    refit : PlantRefit or None
        The chosen one's refit on the plant, started from its own FE fit
        (None where nothing moves modes).
    note : str or None
        What was decided and why, when the pair was reduced.
    """

    # each part alone keeps its value in the pair; the part that explains more alone (its own FE fit, where
    # ``ranked`` has one) is the one refitted in the pair, the other held at its FE value
    k0 = pair.parts[0].n_params
    values = (pair.params_[:k0], pair.params_[k0:])
    own = [next((h for h in ranked if not isinstance(h, Combination) and h.label == p.label), None)
           for p in pair.parts]
    main = pair.parts[int(np.argmin([h.bic_ if h is not None else math.inf for h in own]))]

    jobs = [(pair, pair.params_, main)] + [(part, x, main) for part, x in zip(pair.parts, values)]
    scores = [out if out is not None else (PlantScore(math.inf, h.n_params), math.inf, None)  # no plant: inf
              for (h, _x, _m), out in zip(jobs, map_on_plant(_scored, model, jobs))]
    s_pair, m_pair, r_pair = scores[0]
    alone = [(i, *t) for i, t in enumerate(scores[1:])]
    i1, s1, m1, r1 = min(alone, key=lambda t: t[1].chi2_ + t[1].n_params * math.log(model.problem.n_obs))
    n_obs = model.problem.n_obs
    c_hat = max(1.0, s1.chi2_ / max(n_obs - s1.n_params, 1))
    ev = evidence(s_pair, s1, chi2_0=math.inf, n_obs=n_obs, c_hat=c_hat)
    nonlinear = any(p.effect in NONLINEAR for p in pair.parts)
    # as for a second effect searched on the plant (vlab.diagnose.fit.plantpair): no pair where one part alone
    # leaves only what its modes' own model form allows (a second part would absorb that difference)
    inside = not nonlinear and _within_model_accuracy(model, pair.parts[i1], values[i1] if r1 is None else r1.params)
    policy = model.problem.policy
    # exempt from explaining the remainder's share: a pair with a nonlinear part (judged by rerun), or one that
    # passes the tests that declared the mismatch where its better part alone does not (as on the FE model,
    # vlab.diagnose.fit.passing: a mismatch declared by its modes' moves, with a chi-square near the noise's)
    exempt = nonlinear or (not inside and _within_model_accuracy(
        model, pair, pair.params_ if r_pair is None else r_pair.params))
    # a pair with a nonlinear part that its rerun judged (rule 4): its linearisation here is a describing
    # function, whose error dominates the chi-square and leaves the evidence nothing to judge the second part by
    reran = nonlinear and judged_by_rerun
    if not inside and (reran or passes_pair_rule(ev, (s1.chi2_, s_pair.chi2_), exempt, policy)):
        others = [p for p in pair.parts if p is not main and refit_index(pair, p) is not None]
        if r_pair is not None and others:  # the other part moves modes too: refit it, then the main one again
            r_pair = refit_parts(model, pair, r_pair, others + [main])
        return pair, r_pair, None
    h1 = own[i1]
    if h1 is None:  # no FE fit of its own among the ranked: fit it now (the answer's parameters are FE fits)
        h1 = fit_hypothesis(copy.copy(pair.parts[i1]), model.fe_problem)
    if r1 is not None:  # refit again from its own FE value, which the report quotes as the start
        r1 = model.refit(h1, h1.params_)
    return h1, r1, _reduced_note(h1.label, pair.label, inside, ev, (s1.chi2_, s_pair.chi2_), policy)


def _reduced_note(single: str, pair: str, inside: bool, ev: float, chi2s: tuple, policy) -> str:
    """The note of :func:`reduce_pair_on_plant` when the pair (label ``pair``) gives way to ``single``: its part
    alone leaves only the model form's allowance (``inside``), or the pair fails the pair rule there (``ev``, the
    evidence for it; ``chi2s``, the single's and the pair's chi-square)."""
    if inside:
        return (f"on the MuJoCo plant's linearisation {single} alone leaves only what its modes' own model-form "
                f"uncertainty allows (their frequencies, damping and shapes moved within it): the second effect of "
                f"the pair {pair} absorbed the model's own error; {single} is selected")
    return (f"on the MuJoCo plant's linearisation {single} alone fits as well as the pair {pair} "
            f"(quasi-BIC evidence for the pair {ev:.3g} < {policy.evidence:g}, or its second effect removes "
            f"{100 * (1 - chi2s[1] / chi2s[0]):.0f} % of the chi-square {chi2s[0]:.4g} the first leaves, "
            f"less than the {100 * policy.explained_share:.0f} % an explanation accounts for): the second "
            f"effect absorbed the FE/plant model-form difference; {single} is selected")


def _within_model_accuracy(model: PlantModel, h: Hypothesis, x) -> bool:
    """Whether ``h`` at ``x`` on the plant's linearisation explains the data within the noise and the model's
    own uncertainty (:func:`vlab.diagnose.problem.nuisance.within_model_accuracy`); False without a model
    form carried or where the state cannot be built."""
    if model.problem.model_form_frf is None:
        return False
    try:
        return within_model_accuracy(model.problem, model.state(h, np.asarray(x, dtype=float)))
    except (ModelError, SpecError, np.linalg.LinAlgError, ValueError):
        return False


def explains_on_plant(model: PlantModel, h: Hypothesis, refit: PlantRefit) -> bool:
    """Whether ``h``, refitted on the plant's linearisation (``refit``), leaves the data there within the
    limits of the tests that declared the mismatch, as the remainder of a choice is judged
    (:func:`vlab.diagnose.decision.remainder_of`): its modes within their model form where one is carried
    (:func:`vlab.diagnose.problem.nuisance.within_model_accuracy`), else the total chi-square and the
    largest line within their limits (:meth:`~vlab.diagnose.problem.residuals.Problem.within_noise`).

    Parameters
    ----------
    model : PlantModel
    h : Hypothesis
        A single effect (fitted).
    refit : PlantRefit
        Its refit on the plant.

    Returns
    -------
    bool
    """
    if model.problem.model_form_frf is not None:
        return _within_model_accuracy(model, h, refit.params)
    try:
        state = refit.plant_state
        state = model.state(h, np.asarray(refit.params, dtype=float)) if state is None else state
        return model.problem.within_noise(state)
    except (ModelError, SpecError, np.linalg.LinAlgError, ValueError):
        return False


def pair_needed_on_plant(model: PlantModel, pair: Combination, main: Hypothesis, single: Hypothesis,
                         single_refit: PlantRefit) -> bool:
    """Whether the FE model's ``pair`` is still needed on the plant's linearisation beside the best single
    effect found there (``single``, refitted there as ``single_refit``): the pair scored there as
    :func:`reduce_pair_on_plant` scores it (its part ``main`` refitted), and the pair rule of the selection
    (:func:`vlab.diagnose.fit.rules.passes_pair_rule`) applied with that single effect as the one the pair
    must beat -- the quasi-BIC evidence and, for a pair without a nonlinear part that does not bring the
    data within the noise, the share of the single effect's chi-square its second effect explains.

    Parameters
    ----------
    model : PlantModel
    pair : Combination
        Fitted on the FE model.
    main : Hypothesis
        Its part refitted on the plant (one that moves modes).
    single : Hypothesis
    single_refit : PlantRefit

    Returns
    -------
    bool
        False also where the pair cannot be scored on the plant.
    """
    try:
        out = _scored(model, pair, pair.params_, main)
    except (ModelError, SpecError, np.linalg.LinAlgError, ValueError):
        return False
    if not math.isfinite(out[0].chi2_):
        return False
    s_pair, s1 = out[0], PlantScore(single_refit.chi2, single.n_params)
    n_obs = model.problem.n_obs
    c_hat = max(1.0, s1.chi2_ / max(n_obs - s1.n_params, 1))
    ev = evidence(s_pair, s1, chi2_0=math.inf, n_obs=n_obs, c_hat=c_hat)
    exempt = any(p.effect in NONLINEAR for p in pair.parts) or s_pair.chi2_ <= model.problem.noise_chi2()
    return passes_pair_rule(ev, (s1.chi2_, s_pair.chi2_), exempt, model.problem.policy)


#: Search effort on the plant, not decision thresholds (a candidate not compared there keeps its FE
#: ranking): most look-alikes of a selected single effect scored on the plant by :func:`choose_on_plant`,
#: how many of the best of them (with the selected one) are refitted there (a refit takes ~11
#: linearisations, ~3.5 s on the grid; a score at the FE value one), and how many of the best fits of the
#: selected effect's own kind at other places are scored there however far behind on the FE model (the
#: neighbours of the chosen place on each side, where the FE model's local shapes differ most from the
#: plant's).
MAX_LOOKALIKES = 6
LOOKALIKES_REFITTED = 2
SAME_KIND_COMPARED = 3


def _scored(model: PlantModel, h: Hypothesis, x0, main: Hypothesis):
    """``h`` (a pair or one part of it) refitted on the plant from ``x0`` (in a pair: the parameter of its
    part ``main``), as ``(PlantScore, misfit, PlantRefit or None)`` (a job of :func:`map_on_plant`)."""
    r = model.refit(h, x0, refit_index(h, main if isinstance(h, Combination) else None))
    x = x0 if r is None else r.params
    chi2 = model.chi2(h, x) if r is None else r.chi2
    misfit = model.problem.misfit(model.state(h, x)) if math.isfinite(chi2) else math.inf
    return PlantScore(chi2, h.n_params), misfit, r


def _refit_own(model: PlantModel, h: Hypothesis) -> PlantRefit | None:
    """``h`` refitted on the plant from its own FE fit (a job of :func:`map_on_plant`)."""
    return model.refit(h, h.params_)


#: A member's local bending stiffness, parameterised two ways: a joint's rotational flexibility at a point and
#: a segment's rigidity beside it. Where the FE model and the plant resolve a member differently, one can
#: stand for the other on the FE model (the grid's top-beam joints and segments).
BENDING = ("joint_flexibility", "member_stiffness")


def _same_physics(h: Hypothesis, chosen: Hypothesis) -> bool:
    """Whether ``h`` changes what ``chosen`` changes: the same effect, or both a member's bending (:data:`BENDING`)."""
    return h.effect == chosen.effect or (h.effect in BENDING and chosen.effect in BENDING)


def _to_compare(model: PlantModel, chosen: Hypothesis, alternatives: list, ranked, delta: float,
                max_lookalikes: int, places) -> list:
    """The fits :func:`choose_on_plant` compares with ``chosen`` on the plant: its look-alikes, the fits within
    ``delta`` of it in FE chi-square and the best of its kind elsewhere (up to ``max_lookalikes``), then every
    fit of the same physics at the located ``places``; each single and refittable there."""
    chain = model.chain_refit

    def refittable(h: Hypothesis) -> bool:
        return h.label != chosen.label and not isinstance(h, Combination) and refit_index(h, chain=chain) is not None

    near = sorted((h for h in ranked if abs(h.chi2_ - chosen.chi2_) < delta), key=lambda h: h.chi2_)
    kind = sorted((h for h in ranked if type(h) is type(chosen) and h.label != chosen.label), key=lambda h: h.chi2_)
    looks = list({h.label: h for h in list(alternatives) + near + kind[:SAME_KIND_COMPARED]
                  if refittable(h)}.values())[:max_lookalikes]
    return looks + [h for h in ranked if refittable(h) and _same_physics(h, chosen) and at_places(h.location, places)
                    and h.label not in {x.label for x in looks}]


def choose_on_plant(model: PlantModel, chosen: Hypothesis, alternatives: list, ranked: list = (), *,
                    max_lookalikes: int = MAX_LOOKALIKES, refit_best: int = LOOKALIKES_REFITTED,
                    places=frozenset()) -> tuple[Hypothesis, PlantRefit | None, list, str | None]:
    """Choose among a selected single effect and its look-alikes by their fit on the plant's linearisation.

    The FE model cannot tell apart effects the data cannot (within
    the policy's ``evidence`` in BIC): the stiffness of one
    end segment of the grid's top beam or of its mirror. The FE/plant
    model-form difference can also order them wrongly, and the plant is the
    model that is rerun. Here the selected effect and up to
    ``max_lookalikes`` of its single, refittable alternatives
    (:func:`refit_index`) are scored on the plant's linearisation at their
    FE values, the ``refit_best`` best of them and the selected one are refitted there
    (:meth:`PlantModel.refit`, from their own FE fits; in parallel processes,
    :func:`map_on_plant`), and the least refitted plant
    chi-square wins. The alternatives left are those whose plant chi-square
    (refitted, else at the FE value) is within the policy's ``evidence`` of the
    winner's, and those not scored.

    How far the FE ordering can be trusted is measured on the chosen effect
    itself: its chi-square at its FE value on the FE model and on the
    plant's linearisation differ by the model-form difference in what the
    effect does, ``delta``. A single, refittable fit of ``ranked`` whose FE
    chi-square is within ``delta`` of the chosen one's is ordered by that
    difference as much as by the data, and is compared on the plant too
    (after the look-alikes, best FE fit first; up to ``max_lookalikes`` in
    all).

    That difference belongs to each effect and place, not to the chosen one
    alone: where the FE model's local shapes differ from the plant's, the
    same kind of effect at a neighbouring place can gain or lose far more.
    So the :data:`SAME_KIND_COMPARED` best fits of the chosen effect's own
    kind at other places (the place is what the model-form error confounds;
    the kind, what the data decide first) are scored on the plant as well,
    however far behind on the FE model; and so are the fits of the same physics (:data:`BENDING`) at every
    place the first-order localisation points at (``places``,
    :attr:`vlab.diagnose.fit.locate.Location.places`: it reads the measured frequency errors, not the FE
    fit), beyond ``max_lookalikes``.

    Parameters
    ----------
    model : PlantModel
    chosen : Hypothesis
        The selected single effect (fitted).
    alternatives : list of Hypothesis
        Its look-alikes on the FE model (:func:`vlab.diagnose.fit.rules.select`).
    ranked : list of Hypothesis, optional
        All fitted hypotheses (FE fits); those within ``delta`` are compared too.
    max_lookalikes, refit_best : int
    places : frozenset of int
        The located points.

    Returns
    -------
    chosen : Hypothesis
        The winner (``chosen``, one of ``alternatives`` or one of the fits of ``ranked`` within ``delta``).
    refit : PlantRefit or None
        Its refit (None when ``chosen`` has no refittable parameter; nothing is compared then).
    alternatives : list of Hypothesis
        Those compared (or of ``alternatives``) that the plant does not tell from the winner.
    note : str or None
        The plant chi-squares, when look-alikes were compared.
    """
    if refit_index(chosen, chain=model.chain_refit) is None:
        return chosen, model.refit(chosen, chosen.params_), alternatives, None
    known = {chosen.label: model.chi2(chosen, chosen.params_)}  # at the FE values: one linearisation each
    delta = abs(known[chosen.label] - chosen.chi2_) if math.isfinite(known[chosen.label]) else 0.0
    looks = _to_compare(model, chosen, alternatives, ranked, delta, max_lookalikes, places)
    if not looks:
        return chosen, model.refit(chosen, chosen.params_), alternatives, None
    cands = [chosen] + looks
    known.update({h.label: model.chi2(h, h.params_) for h in looks})
    refits = {}
    # the chosen effect is always refitted: scored at its FE value it would be judged off its own best, against
    # challengers refitted to theirs (a change the plant resolves differently moves the plant's value far)
    best_known = list({h.label: h for h in [chosen] + sorted(cands, key=lambda h: known[h.label])[:refit_best]
                       }.values())
    for h, r in zip(best_known, map_on_plant(_refit_own, model, [(h,) for h in best_known])):
        if r is not None:
            refits[h.label] = r
            known[h.label] = min(known[h.label], r.chi2)
    best = min((h for h in cands if h.label in refits), key=lambda h: refits[h.label].chi2, default=None)
    if best is None:
        return chosen, None, alternatives, None
    c_best = refits[best.label].chi2
    pool = {h.label: h for h in [chosen] + list(alternatives) + looks}.values()
    alts = [h for h in pool if h is not best and (h.label not in known or known[h.label] - c_best < model.problem.policy.evidence)]
    note = (f"look-alikes (the fits within {delta:.3g} in FE chi-square, the FE/plant difference on "
            f"{chosen.label}, the best of its kind elsewhere and at the located places) compared on the MuJoCo plant's linearisation "
            f"(chi-square, refitted for the best "
            f"{len(refits)}): " + ", ".join(f"{h.label}: {known[h.label]:.4g}" for h in cands)
            + f"; {best.label} is selected")
    return best, refits[best.label], alts, note
