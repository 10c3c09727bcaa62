"""Stages 3-5 of the diagnosis: screen and fit the library, select, and check the choice on the MuJoCo plant.

Every hypothesis of the library (:func:`vlab.diagnose.effects.hypotheses.library`) is screened at a few
sizes, the most promising are fitted by least squares and ranked by BIC, pairs are fitted when the best
single effect leaves more than noise (:mod:`vlab.diagnose.fit.estimate`), and the choice follows the rules
of :mod:`vlab.diagnose.fit.rules` under the problem's decision policy: selection by evidence and the
likelihood-ratio test, look-alikes separated by rerun, the cause of a self-excited oscillation by its
physics (:mod:`vlab.diagnose.instability_cause`), and a spec-level choice refitted and compared with its
look-alikes on the MuJoCo plant's linearisation (:mod:`vlab.diagnose.fit.plantfit`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np

from ..errors import VlabError
from .data.measured import FrfData
from .data.reference import RERUN_SEED
from .data.rerun_jobs import start_background_rerun, window_for
from .detectability import threshold_of
from .effects.hypotheses import Combination, Hypothesis, library
from .fit.estimate import fit_hypothesis, fit_pairs, rank, screen, trials_for
from .fit.locate import located_point_ids
from .fit.passing import parts_fitted, passing_choice
from .fit.plantchoice import choose_on_plant, explains_on_plant, pair_needed_on_plant, reduce_pair_on_plant
from .fit.plantfit import PlantModel
from .fit.plantpair import second_effect_on_plant
from .fit.rules import (needs_pairs, needs_rerun_check, part_alone, prune, select, shortlisted,
                        too_small_to_name)
from .fit.selection import CONTROLLER_PATH, data_has_signals, tie_break_by_rerun
from .fit.separation import inseparable, separation_note
from .instability_cause import recorded_growth_rate, search_cause
from .model.labmodel import LabState
from .problem.residuals import Problem
from .report.result import DiagnosisResult


@dataclass(frozen=True)
class Search:
    """How the explanation is searched (see :func:`vlab.diagnose.diagnose`).

    Attributes
    ----------
    effects : tuple of str or None
        The library's effects to try (None: all).
    shortlist : int
        Screened hypotheses fitted in full.
    pairs : bool
        Fit pairs when no single effect explains the data.
    validate_run : bool
        Reruns allowed (look-alikes by rerun, the cause of an oscillation, the validation).
    on_plant : bool
        The comparison is with the MuJoCo plant (refit on its linearisation, reruns there).
    self_excited : bool
        The recording oscillates by itself and the nominal replay does not.
    loops : tuple of int
        Feedback points.
    plant_made : bool
        The recording names the MuJoCo plant that made it and is compared with that plant: a chosen single
        effect of the hardware chain is refitted and compared with its look-alikes there too
        (:class:`vlab.diagnose.fit.plantfit.PlantModel`'s ``chain_refit``).
    """

    effects: tuple | None
    shortlist: int
    pairs: bool
    validate_run: bool
    on_plant: bool
    self_excited: bool
    loops: tuple
    plant_made: bool = False


def _refit_on_plant(res: DiagnosisResult, problem: Problem, chosen: Hypothesis, notes: list,
                    pool: list[Hypothesis], chain: bool = False, reran: bool = False) -> Hypothesis:
    """Refit the chosen effect on the MuJoCo plant's linearisation (:mod:`vlab.diagnose.fit.plantfit`); a pair
    gives way to a single effect that explains the data there (:func:`_single_on_plant`), else a pair the
    plant can carry is checked there (:func:`reduce_pair_on_plant`), a single effect is compared there with its
    look-alikes and the fits of ``res.ranked`` the FE model orders by less than its difference from the plant
    (:func:`choose_on_plant`) and, when it leaves more than noise there, a second effect from
    ``pool`` is searched next to it (:func:`vlab.diagnose.fit.plantpair.second_effect_on_plant`). Sets
    ``res.plant_refit`` (and ``res.alternatives``); returns the choice. ``chain``: a chain effect is refitted
    and compared there too (:attr:`Search.plant_made`). ``reran``: look-alikes and pairs with a nonlinear part
    were judged by rerun (:func:`tie_break_by_rerun` ran), which a pair with a nonlinear part then stands by."""
    try:
        model = PlantModel(problem, chain_refit=chain)
    except (VlabError, ImportError) as exc:
        notes.append(f"the MuJoCo plant could not be linearised for a refit: {exc}")
        return chosen
    if isinstance(chosen, Combination):
        single = _single_on_plant(res, model, chosen, notes)
        if single is not None:
            return single
        if not chosen.spec_level:  # the plant cannot carry the pair: its rerun and value stay the FE model's
            return chosen
        reduced, res.plant_refit, note = reduce_pair_on_plant(model, chosen, res.ranked, judged_by_rerun=reran)
        if note is not None:
            notes.append(note)
            res.alternatives = [h for h in res.alternatives if h is not reduced]
        return reduced
    chosen, res.plant_refit, res.alternatives, note = choose_on_plant(model, chosen, res.alternatives, res.ranked,
                                                                      places=res.location.places)
    if note is not None:
        notes.append(note)
    single = chosen
    chosen, res.plant_refit, looks, note = second_effect_on_plant(model, chosen, res.plant_refit, pool,
                                                                  ranked=res.ranked)
    if note is not None:
        notes.append(note)
    if chosen is not single:
        res.alternatives = looks  # the pair's look-alikes on the plant, not those of the single effect
    return chosen


def _on_plant_checked(h: Hypothesis) -> bool:
    """Whether rule 5 (the MuJoCo plant's linearisation) applies to the choice ``h``: a spec-level effect, or
    a pair with a spec-level part that moves modes (its other part may be one the plant cannot carry)."""
    return h.spec_level or (isinstance(h, Combination) and any(p.spec_level and p.moves_modes for p in h.parts))


def _single_on_plant(res: DiagnosisResult, model: PlantModel, pair: Combination, notes: list) -> Hypothesis | None:
    """A single effect that replaces the FE model's pair on the plant's linearisation, or None.

    The FE model orders candidates by no more than its difference from the plant (:func:`choose_on_plant`),
    and a second effect fitted on the FE model can absorb that difference (rule 5 of
    :mod:`vlab.diagnose.fit.rules`); a pair whose other part cannot be rerun on the plant (a dashpot or
    friction at a point) is not reduced by :func:`reduce_pair_on_plant`'s pair rule, which asks nothing of a
    nonlinear second part. So the pair's mode-moving, spec-level part is compared on the plant with its
    look-alikes and the same physics at the located places, as a single choice is; where the winner,
    refitted there, leaves the data within the mismatch test's limits (:func:`explains_on_plant`), or the
    pair scored there does not pass the pair rule against it (:func:`pair_needed_on_plant`), no second
    effect is needed and it is the choice (``res.plant_refit`` and ``res.alternatives`` set, a note
    added)."""
    part = next((p for p in pair.parts if p.spec_level and p.moves_modes), None)
    own = None if part is None else next(
        (h for h in res.ranked if not isinstance(h, Combination) and h.label == part.label), None)
    if own is None:
        return None
    best, refit, alts, note = choose_on_plant(model, own, [], res.ranked, places=res.location.places)
    if refit is None:
        return None
    limit = model.problem.noise_chi2()
    if explains_on_plant(model, best, refit):
        why = f"leaves the data within the mismatch test's limits (chi-square {refit.chi2:.4g}, limit {limit:.4g})"
    elif not pair_needed_on_plant(model, pair, part, best, refit):
        why = (f"leaves chi-square {refit.chi2:.4g} (limit {limit:.4g}), and the pair scored there does not pass "
               "the pair rule against it")
    else:
        return None
    res.plant_refit, res.alternatives = refit, alts
    if note is not None:
        notes.append(note)
    notes.append(f"on the MuJoCo plant's linearisation {best.label} alone, refitted there, {why}: the second "
                 f"effect of the FE model's pair {pair.label} absorbed the FE/plant difference; {best.label} is "
                 "selected")
    return best


def _by_prediction(res: DiagnosisResult, problem: Problem, chosen: Hypothesis, ranked: list, alts: list,
                   c_hat: float, notes: list) -> list[Hypothesis]:
    """The fits of ``ranked`` not in ``alts`` whose predictions the data cannot tell from ``chosen``'s
    (:func:`vlab.diagnose.fit.separation.inseparable`), kept in ``res.separation`` with a line in ``notes``
    when there are any."""
    known = {h.label for h in alts}
    state_of = lambda h: problem.fitted_state(h)  # noqa: E731 -- the fitted lab, on the FE model
    chi2 = problem.chi2(state_of(chosen))  # on this footing even where the plant refitted the choice
    found = [(h, d) for h, d in inseparable(chosen, chi2, ((h, h.chi2_) for h in ranked), problem, state_of, c_hat)
             if h.label not in known]
    if found:
        notes.append(separation_note(chosen, found, problem, c_hat))
        res.separation = {"limit_chi2": problem.policy.lr_limit(1, c_hat),
                          "distance_chi2": {h.label: d for h, d in found}}
    return [h for h, _ in found]


def _cause_of_oscillation(res: DiagnosisResult, problem: Problem, nominal: LabState, ranked: list, loops,
                          chi2_fit: float, validate_run: bool, on_plant: bool, notes: list, timing: dict, say,
                          plant_made: bool = False):
    """The choice of a recording that oscillates by itself (rule 9, :mod:`vlab.diagnose.instability_cause`):
    the best-fitting candidate whose linear loop is unstable and whose rerun reproduces the oscillation, with
    that rerun as ``res.validation``; the candidates rerun in vain are listed as rejected. None when nothing
    reproduces it or no rerun can be made."""
    f0 = res.instability["frequency_hz"]
    if not (validate_run and data_has_signals(res.data)):
        notes.append(f"without a validation rerun no candidate can be shown to cause the oscillation at {f0:.2f} Hz "
                     "(a fit to the FRFs of a self-excited recording can look good without the cause); nothing is "
                     "selected")
        return None
    say("searching the cause of the oscillation")
    t = time.perf_counter()
    growth = recorded_growth_rate(res.instability, problem.data.recording.duration_s)
    cause = search_cause(problem, nominal, ranked, f0, loops, chi2_0=chi2_fit, c_hat=res.overdispersion,
                         plant="mujoco" if on_plant else "linear", seed=RERUN_SEED, on_plant=on_plant,
                         growth_1_s=growth, plant_made=plant_made, recorded=res.instability)
    timing["instability_cause"] = time.perf_counter() - t
    notes.append(cause.note(f0))
    for tr in cause.tried:
        if not tr["reproduced"]:
            res.rejected.append({"effect": tr["effect"], "label": tr["label"],
                                 "reason": f"does not reproduce the self-excited oscillation at {f0:.2f} Hz"})
    res.validation = cause.validation
    if cause.chosen is not None:
        (tried,) = [t for t in cause.tried if t["reproduced"]]
        res.instability["cause"] = {"label": tried["label"], "rerun_frequencies_hz": tried["rerun_frequencies_hz"]}
    return cause.chosen


def screen_and_fit(problem: Problem, nominal: LabState, ctx, sensitivity: list, search: Search, timing: dict,
                   say) -> list:
    """Screen every hypothesis of the library of the lab ``nominal`` (context ``ctx``) on the data of
    ``problem``, fit the shortlist and, where needed, pairs (as ``search`` says); returns them ranked by BIC
    (best first). ``sensitivity``: the localisation's ranking (:func:`vlab.diagnose.fit.rules.prune`);
    ``timing``: stage -> seconds, filled in; ``say``: progress. A hypothesis that cannot be built or fitted
    is left out."""
    say("screening hypotheses")
    t = time.perf_counter()
    scored = []
    for h in prune(library(nominal, ctx, effects=search.effects), sensitivity):
        try:
            trials = trials_for(h, problem)
            est = getattr(h, "estimate_", None)
            if est is not None and np.isfinite(est):
                trials = np.vstack([trials, [[est]], [[est * 0.7]], [[est * 1.4]]])
            scored.append((screen(h, problem, trials)[0][0], h))
        except (VlabError, ValueError, np.linalg.LinAlgError):
            continue
    scored.sort(key=lambda s: s[0])
    keep = shortlisted(scored, search.shortlist, located_point_ids(sensitivity))
    timing["screen"] = time.perf_counter() - t
    say("fitting")
    t = time.perf_counter()
    fitted = []
    for h in keep:
        try:
            fitted.append(fit_hypothesis(h, problem))
        except (VlabError, ValueError, np.linalg.LinAlgError):
            continue
    ranked = rank(fitted)
    timing["fit"] = time.perf_counter() - t
    if search.pairs and needs_pairs(ranked[0] if ranked else None, problem):
        say("fitting pairs")
        t = time.perf_counter()
        ranked = rank(ranked + fit_pairs(ranked, problem, [h for _, h in scored]))
        timing["pairs"] = time.perf_counter() - t
    return ranked


def _frf_choice(res: DiagnosisResult, problem: Problem, chosen, alts: list, ranked: list, search: Search,
                chi2_fit: float, notes: list, timing: dict, say) -> tuple:
    """The choice by the FRFs (rules 5-6 and the look-alikes' rerun): a pair gives way to a part that explains
    the data alone, a choice that leaves a mismatch test failing to a single effect that passes them, and
    look-alikes that the data cannot separate are rerun where the choice's kind needs it. Returns
    ``(chosen, alternatives)``."""
    if isinstance(chosen, Combination):
        alone = part_alone(parts_fitted(problem, chosen, ranked), problem)
        if alone is not None:
            notes.append(f"{chosen.label}: {alone.label} alone explains the data within the model's accuracy "
                         "(the mismatch tests pass after its modes are moved within their model form); the "
                         "other part is not needed and is not selected")
            chosen, alts = alone, []
    passing = passing_choice(chosen, ranked, problem, search.shortlist, chi2_fit)
    if passing is not None:
        notes.append(f"{chosen.label} does not explain the data by the statistic that declared the mismatch (with "
                     "its modes moved within their model form it leaves them beyond a test, or fits them no "
                     f"better than the nominal lab); {passing.label} does"
                     + (", no single effect does, and each of its parts is needed beside the other"
                        if isinstance(passing, Combination) else "") + ", and is the choice")
        chosen, alts = passing, []
    if chosen is not None and search.validate_run and data_has_signals(res.data) and \
            any(needs_rerun_check(h) for h in [chosen] + alts):
        say("separating look-alikes by rerun")
        t = time.perf_counter()
        chosen, alts = tie_break_by_rerun(problem, chosen, alts, ranked, notes,
                                          plant="mujoco" if search.on_plant else "linear", seed=RERUN_SEED)
        timing["tie_break"] = time.perf_counter() - t
    return chosen, alts


def _oscillation_left_unexplained(res: DiagnosisResult, chosen, notes: list) -> bool:
    """Whether the search for the cause of a self-excited oscillation, having rerun candidates in vain, leaves
    the oscillation as an unexplained remainder of an FRF choice (True: ``res.instability["unexplained"]`` is
    set and the note says so) rather than leaving nothing selected; the choice's own rejection for the
    oscillation is withdrawn.

    The oscillation is one property of the recording that a candidate must reproduce; a candidate the FRFs
    select that does not is an explanation in part, like one that leaves a remainder on the FRFs (rule 10),
    and is judged by the same rules -- the oscillation is then stated as what is left. Without reruns, or
    without an FRF choice, nothing is selected.
    """
    tried = [r for r in res.rejected if str(r.get("reason", "")).startswith("does not reproduce the self-excited")]
    if chosen is None or not tried:
        return False
    f0 = res.instability["frequency_hz"]
    res.instability["unexplained"] = True
    # the FRF choice is judged below by the FRF rules; the others stay rejected for the oscillation
    res.rejected = [r for r in res.rejected if not (r in tried and r["label"] == chosen.label)]
    notes.append(f"no candidate's rerun reproduces the self-excited oscillation at {f0:.2f} Hz "
                 f"({', '.join(r['label'] for r in tried)}): the FRFs are explained as far as the library allows "
                 "and the oscillation is left as an unexplained remainder")
    return True


def explain(res: DiagnosisResult, problem: Problem, ctx, search: Search, *, chi2_fit: float, noise_only: dict | None,
            notes: list, timing: dict, say) -> None:
    """Stages 3-5 on a mismatch: fill ``res.ranked``, ``res.selected`` (or None, with the reason in ``notes``),
    ``res.alternatives``, ``res.overdispersion``, ``res.plant_refit``, ``res.threshold`` and ``res.loop``.

    Parameters
    ----------
    res : DiagnosisResult
        With ``mismatch`` True and its location.
    problem : Problem
    ctx : Context
    search : Search
    chi2_fit : float
        The nominal lab's chi-square on the fitted hypotheses' footing [1].
    noise_only : dict or None
        The statistics of a mismatch found only without the model-error floor.
    notes : list of str
    timing : dict
    say : callable
    """
    nominal = res.nominal
    if search.on_plant and problem.replay_plant is None:
        window, suffix = window_for(problem, (nominal,))  # the validation's window where the nominal lab sets it
        start_background_rerun(problem, nominal, f"nominal{suffix}", "mujoco", seed=RERUN_SEED, window=window)
    ranked = res.ranked = screen_and_fit(problem, nominal, ctx, res.location.sensitivity, search, timing, say)
    chosen, c_hat, alts = select(ranked, chi2_fit, problem.n_obs, problem.policy)
    res.overdispersion = c_hat
    if search.self_excited:  # the cause of the oscillation decides, not the FRF fit
        cause = _cause_of_oscillation(res, problem, nominal, ranked, search.loops, chi2_fit, search.validate_run,
                                      search.on_plant, notes, timing, say, search.plant_made)
        if cause is not None or not _oscillation_left_unexplained(res, chosen, notes):
            chosen, alts = cause, []
        else:  # the FRFs explained as far as the library allows; the oscillation is reported as the remainder
            search = replace(search, self_excited=False)
    if not search.self_excited:
        chosen, alts = _frf_choice(res, problem, chosen, alts, ranked, search, chi2_fit, notes, timing, say)
    res.alternatives = alts
    chain = search.plant_made and chosen is not None and chosen.in_chain  # a single chain effect (not a pair)
    if chosen is not None and search.on_plant and _on_plant_checked(chosen) and not search.self_excited:
        say("refitting on the MuJoCo plant's linearisation")
        t = time.perf_counter()
        fe_choice = chosen
        chosen = _refit_on_plant(res, problem, chosen, notes, library(nominal, ctx, effects=search.effects), chain,
                                 reran=search.validate_run and data_has_signals(res.data))
        res.fe_choice = fe_choice if chosen is not fe_choice else None
        timing["plant_refit"] = time.perf_counter() - t
    if too_small_to_name(chosen, noise_only):  # beyond the noise, within the model's accuracy: located, not named
        res.too_small, res.too_small_candidates = True, [chosen] + list(alts)
        cands = [h.label for h in [chosen] + list(alts)][:4]
        notes.append("the change is beyond the noise but within the model-error floor of "
                     f"{100 * problem.floor:g} % a line: too small to name (the FE surrogate's own errors "
                     "of that size could mimic any of the candidates); best candidates: " + ", ".join(cands))
        chosen = None
    if chosen is None:
        res.loop = "open" if not ctx.closed_loop else "both"
        if not res.too_small and not search.self_excited:  # the cause search wrote its own note
            notes.append("no hypothesis of the library explains the mismatch (quasi-BIC not lowered by "
                         f"{problem.policy.evidence:g} with the likelihood-ratio test passed)")
        return
    res.selected = chosen
    if not search.self_excited and isinstance(problem.data, FrfData):
        res.alternatives = list(res.alternatives) + _by_prediction(res, problem, chosen, ranked, res.alternatives,
                                                                   c_hat, notes)
    res.misfit_selected = float(chosen.misfit_)
    t = time.perf_counter()
    thr = threshold_of(problem, nominal, ctx, chosen)
    timing["threshold"] = time.perf_counter() - t
    res.threshold = None if thr is None else thr.as_dict()
    if not ctx.closed_loop:
        res.loop = "open"
    else:
        res.loop = "closed" if all(p.effect in CONTROLLER_PATH for p in res.selected_parts) else "both"
