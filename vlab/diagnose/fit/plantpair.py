"""A second effect searched next to the selected one once the FE/plant model-form error of the first is removed.

The pair search of :mod:`vlab.diagnose.fit.estimate` runs on the FE model. When the
selected effect moves modes far (the grid's joint 8 softened almost to a
hinge moves six modes by 1-7 %), the FE model and the MuJoCo plant move them
differently, and what that difference leaves in the residual hides a
smaller second effect: on the MuJoCo grid with joint 8 at 7.2 N m/rad and
a 23 kN/m spring at point 15 the FE model fits the true
pair *worse* than the joint alone (chi-square 20.5e3 against 16.2e3), while
on the plant's linearisation the joint alone leaves one line 2.5x over the
noise limit (peak 145, limit 58) and the true pair does not (17).

So, when the selected single effect, refitted on the plant's linearisation
(:mod:`vlab.diagnose.fit.plantfit`), still leaves the data out of the noise
there (:meth:`~vlab.diagnose.problem.residuals.Problem.within_noise`), the data are
referred back to the FE model through that effect: with ``h`` the selected
effect at its FE value ``x_FE`` and at its plant value ``x_P``,

    d' = d * H_FE(h, x_FE) / H_plant(h, x_P),   var' = var * |H_FE / H_plant|^2

(the reference-state referral of :func:`vlab.diagnose.data.measured.refer_to_model`,
with the modified model as the reference), so that on ``d'`` the FE model
with ``h`` at ``x_FE`` leaves exactly the residual the plant leaves on
``d``. A second effect is then searched on ``d'`` by the forward step of
:func:`vlab.diagnose.fit.estimate.fit_pairs` (``h`` held while screening), and the
best pairs are refitted on the plant's linearisation and judged there by
the selection's own pair rule against the single effect (quasi-BIC evidence
of 10, and the second effect explaining at least the policy's share of what
the first leaves, or a residual brought into the noise). Only
a pair that passes there replaces the single effect.

A nonlinear selected effect (:data:`vlab.diagnose.fit.rules.NONLINEAR`: saturation,
friction) is left alone: its linear model is a describing function, so
what its linearisation leaves on the plant is mostly the nonlinearity's
own distortion, which no linear second effect explains and which
:meth:`~vlab.diagnose.problem.residuals.Problem.within_noise` cannot judge (MuJoCo
grid, a saturation: chi-square 5.5e5 against a
noise limit of 3.1e3, and the best pair's quasi-BIC evidence 1.7; the
search failed on every recording with a nonlinear single effect, at
20-35 s each). Pairs with a nonlinear part are judged by rerun instead
(:func:`vlab.diagnose.fit.selection.tie_break_by_rerun`).

The pair's ``parameters`` in the answer are its fit on ``d'`` (the FE model
with the first effect's FE/plant difference removed); the values the rerun
used are its refit on the plant (``validated.parameters``).

Source: forward selection (Miller, *Subset Selection in Regression*, 2002,
Sec. 3.2) on data referred through a reference model (Friswell &
Mottershead, *Finite Element Model Updating in Structural Dynamics*, 1995,
ch. 1).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ...errors import ModelError, SpecError, VlabError
from ..effects.hypothesis import Combination, Hypothesis
from ..problem.nuisance import within_model_accuracy
from ..problem.residuals import Problem
from .estimate import fit_pairs, rank
from .plantfit import PlantModel, PlantRefit, PlantScore, map_on_plant, refit_index, refit_parts
from .rules import NONLINEAR, evidence, passes_pair_rule

#: What a pair's plant refit starts from (``PlantRefit.start``): the second effect's value fitted on the referred data.
REFERRED_FIT = "fit on the data referred through the first effect"
#: ... or, for a pair of the FE model's fits (:func:`fe_pairs`), its values fitted on the FE model.
FE_FIT = "fit on the FE model"


def referred_through(model: PlantModel, h: Hypothesis, x_fe, x_plant) -> Problem:
    """The FE problem of ``model`` with its data referred through ``h``: ``d' = d H_FE(h, x_fe) / H_plant(h, x_plant)``.

    Parameters
    ----------
    model : PlantModel
    h : Hypothesis
        The selected effect.
    x_fe, x_plant : array_like, shape (k,)
        Its FE-fitted value and its value refitted on the plant [SI].

    Returns
    -------
    Problem
        On the FE model (``model.fe_problem``'s nominal lab and context), data
        ``(n_f, n_o)`` and variance scaled by the ratio.

    Raises
    ------
    ModelError, SpecError
        The effect cannot be built on either model.
    """
    fe = model.fe_problem
    ratio = fe.predict(fe.state_for(h, np.asarray(x_fe, dtype=float))) / \
        model.problem.predict(model.state(h, np.asarray(x_plant, dtype=float)))
    data = model.problem.data
    return Problem(replace(data, h=data.h * ratio, var=data.var * np.abs(ratio) ** 2), fe.base, fe.ctx,
                   floor=fe.floor, use_phase=fe.use_phase, model_form_frf=fe.model_form_frf,
                   policy=fe.policy, line_floor=model.problem.line_floor)


#: Pairs fitted on the referred data and scored on the plant at those values; the best
#: :data:`PAIRS_REFITTED` of them are refitted on the plant. Chosen, not fitted: on the grid
#: with a hinge-like joint the top-beam springs at 14-21 all fit the referred data alike (chi-square
#: 763-793), and the true one ranked 5th there; a pair's plant chi-square at its referred fit can sit
#: 80 above its refitted one (a 23 kN/m spring at 17 with 1.5 kg at 15: 903 at the referred fit, 827 with
#: both parts refitted), more than the spread of the three best at the referred fit (842-903) there.
N_FIT = 6
PAIRS_REFITTED = 3

#: Half-width in ``ln p`` of the plant refit of the second effect (a factor 2 each way: the referred FE
#: fit of a spring next to a hinge-like joint came out half the drawn value) and its scan points.
SECOND_HALF_WIDTH = math.log(2.0)
SECOND_POINTS = 7


def refit_pair(model: PlantModel, pair: Combination, x, chi2_at_x: float) -> PlantRefit | None:
    """Refit a pair found on the referred data on the plant: its second effect's mode-moving parameter
    (``+-SECOND_HALF_WIDTH`` around ``x``), then the first effect's with the second in the model and,
    where that lowered the chi-square, the second's once more (:func:`vlab.diagnose.fit.plantfit.refit_parts`).

    Parameters
    ----------
    model : PlantModel
    pair : Combination
        The first effect and a second one.
    x : ndarray, shape (pair.n_params,)
        Start [SI]: the first effect at its plant value, the second at its referred fit.
    chi2_at_x : float
        The plant chi-square at ``x`` (kept for a second effect with nothing to refit, a chain effect).

    Returns
    -------
    PlantRefit or None
        ``start`` :data:`REFERRED_FIT`; None when nothing could be evaluated on the plant.
    """
    k = pair.parts[0].n_params
    i = refit_index(pair, pair.parts[1])
    r = None if i is None else model.refit(pair, x, i, half_width=SECOND_HALF_WIDTH, points=SECOND_POINTS)
    if r is None and math.isfinite(chi2_at_x):  # nothing to refit (a chain effect): its fitted value
        r = PlantRefit(pair.param_names[k], float(x[k]), float(x[k]), x, pair.apply(model.base, x, model.ctx),
                       chi2_at_x, chi2_at_x, 0, 0.0)
    if r is None:
        return None
    r = replace(r, start=REFERRED_FIT)
    moved = refit_parts(model, pair, r, pair.parts[:1])
    # the second again only where the first moved (else it was just refitted with the first where it is)
    return r if moved is r else refit_parts(model, pair, moved, pair.parts[1:])


def second_effect_on_plant(model: PlantModel, chosen: Hypothesis, refit: PlantRefit | None,
                           pool: list[Hypothesis], *, n_fit: int = N_FIT, refit_best: int = PAIRS_REFITTED,
                           max_nfev: int = 40, ranked: list | None = None
                           ) -> tuple[Hypothesis, PlantRefit | None, list, str | None]:
    """Search a second effect next to the selected single ``chosen`` when the plant leaves more than noise.

    The data are referred through ``chosen`` (:func:`referred_through`); every
    hypothesis of ``pool`` that the plant can carry is screened as the
    second effect with ``chosen`` held at its FE value, and the ``n_fit``
    best pairs are fitted jointly (the forward step of
    :func:`vlab.diagnose.fit.estimate.fit_pairs`). Each is scored on the plant's
    linearisation with ``chosen`` at its plant value and the second effect at
    its referred fit; the ``refit_best`` best are refitted there in full
    (:func:`refit_pair`; in parallel processes,
    :func:`vlab.diagnose.fit.plantfit.map_on_plant`), so that they are compared
    at the same level of refit; the best of them replaces ``chosen`` only if it beats it there by
    the policy's ``evidence`` in quasi-BIC and either leaves
    the data within the noise (:meth:`~vlab.diagnose.problem.residuals.Problem.within_noise`:
    chi-square and largest single residual; with a model form carried, or within the model's accuracy,
    :func:`vlab.diagnose.problem.nuisance.within_model_accuracy`), which ``chosen`` alone did not,
    or explains what ``chosen`` leaves there (the policy's ``explained_share`` of its chi-square: the pair
    rule of :func:`vlab.diagnose.fit.rules.select`, :func:`vlab.diagnose.fit.rules.explains_remainder`). Data compared within the model's own
    uncertainty (``model_form_frf``) are not searched when ``chosen`` leaves only what its modes'
    model form allows (:func:`vlab.diagnose.problem.nuisance.within_model_accuracy`: a large effect moves
    lightly damped modes, and the plant it is modelled on moves them a little differently from the
    real structure, a difference a second effect would otherwise absorb).

    A nonlinear ``chosen`` (:data:`vlab.diagnose.fit.rules.NONLINEAR`) is left alone (module docstring).

    Parameters
    ----------
    model : PlantModel
    chosen : Hypothesis
        The selected single effect (FE-fitted, ``params_`` set).
    refit : PlantRefit or None
        Its refit on the plant (None: the FE value is used there).
    pool : list of Hypothesis
        Candidates for the second effect (the library; effects the MuJoCo
        plant cannot carry, ``spec_level`` false, are skipped).
    n_fit : int
        Pairs fitted jointly on the referred data (default :data:`N_FIT`).
    refit_best : int
        Of those, the best (plant chi-square at the referred fit) refitted on the plant in full
        (default :data:`PAIRS_REFITTED`).
    max_nfev : int
        Evaluation budget of each joint fit on the referred data.
    ranked : list of Hypothesis, optional
        The fits on the FE model (:func:`vlab.diagnose.fit.estimate.rank`): its ``refit_best`` best pairs that
        fit better than ``chosen`` there and do not extend it (:func:`fe_pairs`) are refitted on the plant from
        their own values and judged beside the extensions. A single that fails on the plant leaves the choice
        open among the FE model's better explanations, not only among its own extensions: the FE model may have
        preferred the single by a margin no larger than its difference from the plant.

    Returns
    -------
    chosen : Hypothesis
        The pair (its ``params_`` the fit on the referred data), or ``chosen``.
    refit : PlantRefit or None
        The pair's refit on the plant (its ``params`` the values the rerun uses), or ``refit`` unchanged.
    lookalikes : list of Combination
        With a pair selected: the other pairs whose plant chi-square (refitted, else at the referred fit)
        is within the policy's ``evidence`` of the selected one's (the data cannot tell them apart: a spring at
        the grid's top-beam point 14 or 15 next to a hinge-like joint 8); else empty.
    note : str or None
        What was tried and decided, or why nothing was searched next to a nonlinear effect (None when nothing
        was searched otherwise: ``chosen`` is a pair or not spec-level, or the plant already left only noise;
        or when nothing could be fitted).

    Raises
    ------
    Exception
        Only errors that are not a model, spec or fit failure (those end the search and keep
        ``chosen``), e.g. a bug in a worker process of :func:`~vlab.diagnose.fit.plantfit.map_on_plant`.
    """
    if isinstance(chosen, Combination) or not chosen.spec_level:
        return chosen, refit, [], None
    if chosen.effect in NONLINEAR:
        return chosen, refit, [], (f"no second effect searched on the MuJoCo plant's linearisation next to "
                                   f"{chosen.label}: its linear model is a describing function, and what it leaves "
                                   "there is the nonlinearity's own distortion (pairs with it are judged by rerun)")
    x_plant = refit.params if refit is not None else np.asarray(chosen.params_, dtype=float)
    found, note = _single_on_plant(model, chosen, x_plant)
    if found is None:
        return chosen, refit, [], note
    single, single_chi2, single_test, referred = found
    pairs = _pairs_on_referred(chosen, referred, pool, n_fit, max_nfev)
    k = chosen.n_params
    starts = {c.label: np.concatenate([x_plant, np.asarray(c.params_[k:], dtype=float)]) for c in pairs}
    others = fe_pairs(chosen, ranked or [], set(starts), refit_best)
    starts.update({c.label: np.asarray(c.params_, dtype=float) for c in others})
    pairs = pairs + others
    if not pairs:
        return chosen, refit, [], None
    refits, plant_chi2 = _refit_on_plant(model, pairs, starts, refit_best, len(others))
    for c in others:
        if c.label in refits:
            refits[c.label] = (c, replace(refits[c.label][1], start=FE_FIT))
    return _judge_pair(model, chosen, refit, pairs, refits, plant_chi2, single, single_chi2, single_test,
                       beside=bool(others))


def fe_pairs(chosen: Hypothesis, ranked: list, known: set, n: int) -> list:
    """The ``n`` best pairs of ``ranked`` (FE chi-square, ``chi2_``) that fit better than ``chosen`` on the FE
    model, are not among ``known`` (labels) and do not extend ``chosen``, that the plant can carry (every part
    spec-level) and whose parts are linear (a nonlinear part is judged by rerun,
    :func:`vlab.diagnose.fit.selection.tie_break_by_rerun`).

    Parameters
    ----------
    chosen : Hypothesis
        The selected single effect (``chi2_`` set).
    ranked : list of Hypothesis
        Fits on the FE model.
    known : set of str
        Labels already searched.
    n : int
        How many at most.

    Returns
    -------
    list of Combination
        Best first; a fit without a finite ``chi2_`` is left out (no error is raised for it).
    """
    c0 = getattr(chosen, "chi2_", math.inf)
    out = [c for c in ranked if isinstance(c, Combination) and c.spec_level and c.label not in known
           and c.parts[0].label != chosen.label and not any(p.effect in NONLINEAR for p in c.parts)
           and math.isfinite(getattr(c, "chi2_", math.inf)) and c.chi2_ < c0]
    return sorted(out, key=lambda c: c.chi2_)[:max(int(n), 0)]


def _single_on_plant(model: PlantModel, chosen: Hypothesis, x_plant: np.ndarray) -> tuple[tuple | None, str | None]:
    """The single effect on the plant and the data referred through it: ``((state, chi-square, largest
    residual, referred problem), None)``; or ``(None, note)`` when no second effect is searched (the plant
    already left only noise, or only what the modes' model form allows, or the plant cannot carry it)."""
    plant = model.problem
    try:
        single = model.state(chosen, x_plant)
        single_chi2 = plant.chi2(single)  # on the fits' footing, as the pairs'; the test's statistics for the note
        single_test = (plant.chi2(single, test=True), plant.peak(single, test=True))
        if plant.within_noise(single):
            return None, None
        if plant.model_form_frf is not None and within_model_accuracy(plant, single):
            return None, (f"{chosen.label} leaves on the MuJoCo plant's linearisation only what its "
                          "modes' own model-form uncertainty allows (their frequencies, damping and "
                          "shapes moved within it): no second effect searched")
        referred = referred_through(model, chosen, chosen.params_, x_plant)
    except (ModelError, SpecError):
        return None, None
    return (single, single_chi2, single_test, referred), None


def _pairs_on_referred(chosen: Hypothesis, referred: Problem, pool: list[Hypothesis], n_fit: int,
                       max_nfev: int) -> list:
    """The ``n_fit`` best pairs of ``chosen`` and a spec-level second effect of ``pool``, fitted jointly on the
    referred data and ranked (empty when none could be fitted)."""
    cands = [h for h in pool if h.spec_level and h.label != chosen.label]
    try:
        # the first effect is the one the data were referred through, at its FE value: no basin step
        pairs = rank(fit_pairs([chosen], referred, cands, n_second=n_fit, max_nfev=max_nfev, rounds=0,
                                n_basin=0))
    except (VlabError, ValueError, np.linalg.LinAlgError):
        pairs = []
    return pairs


def _refit_on_plant(model: PlantModel, pairs: list, starts: dict, refit_best: int, extra: int = 0) -> tuple:
    """Score every pair on the plant at its start (``starts``: label -> values [SI]; an extension of the
    chosen effect: that effect at its plant value, the second at its referred fit) and refit the
    ``refit_best + extra`` best there: ``(label -> (pair, PlantRefit), label -> plant chi-square, refitted where
    it was)``."""
    at_fit = {c.label: model.chi2(c, starts[c.label]) for c in pairs}
    best_at_fit = sorted(pairs, key=lambda c: at_fit[c.label])[:refit_best + extra]
    done = map_on_plant(refit_pair, model, [(c, starts[c.label], at_fit[c.label]) for c in best_at_fit])
    refits = {c.label: (c, r) for c, r in zip(best_at_fit, done) if r is not None}
    plant_chi2 = {c.label: refits[c.label][1].chi2 if c.label in refits else at_fit[c.label] for c in pairs}
    return refits, plant_chi2


def _judge_pair(model: PlantModel, chosen: Hypothesis, refit: PlantRefit | None, pairs: list, refits: dict,
                plant_chi2: dict, single, single_chi2: float, single_test: tuple[float, float],
                beside: bool = False) -> tuple[Hypothesis, PlantRefit | None, list, str | None]:
    """The best refitted pair against the single effect on the plant by the pair rule; the answer of
    :func:`second_effect_on_plant` with its note (``beside``: the FE model's better pairs were among them)."""
    plant = model.problem
    k = chosen.n_params
    head = (f"{chosen.label} leaves more than the noise on the MuJoCo plant's linearisation (chi-square "
            f"{single_test[0]:.4g}, largest residual {single_test[1]:.3g}, limits "
            f"{plant.noise_chi2():.4g} and {plant.peak_limit():.3g}): a second effect searched on the data "
            "referred through it" + (", beside the FE model's better pairs" if beside else "") + "; on the plant: "
            + ", ".join(f"{c.parts[1].label if c.parts[0].label == chosen.label else c.label}: "
                        f"{plant_chi2[c.label]:.4g}" for c in pairs))
    if not refits:
        return chosen, refit, [], head + "; none could be refitted there, the single effect stays"
    best, r = min(refits.values(), key=lambda t: t[1].chi2)
    n_obs = plant.n_obs
    c_hat = max(1.0, single_chi2 / max(n_obs - k, 1))
    ev = evidence(PlantScore(r.chi2, best.n_params), PlantScore(single_chi2, k), chi2_0=math.inf, n_obs=n_obs,
                  c_hat=c_hat)
    pair_state = model.state(best, r.params)
    # within the noise -- or, for data compared within the model's own uncertainty, within that too
    inside = plant.within_noise(pair_state) or (plant.model_form_frf is not None
                                                and within_model_accuracy(plant, pair_state))
    share = 1.0 - r.chi2 / single_chi2 if single_chi2 > 0 else float("nan")
    policy = plant.policy
    if passes_pair_rule(ev, (single_chi2, r.chi2), inside, policy):
        looks = [c for c in pairs if c is not best and plant_chi2[c.label] - r.chi2 < policy.evidence]
        return best, r, looks, head + (f"; {best.label} (chi-square {r.chi2:.4g} refitted"
                                       + (", within the noise" if inside else "") + f", quasi-BIC evidence {ev:.3g}, "
                                       f"{100 * share:.0f} % of the single effect's chi-square removed) passes the pair rule and is "
                                       "selected")
    why = (f"quasi-BIC evidence {ev:.3g} < {policy.evidence:g}" if ev < policy.evidence else
           f"its second effect removes {100 * share:.0f} % of the single effect's chi-square {single_chi2:.4g}, "
           f"less than the {100 * policy.explained_share:.0f} % an explanation accounts for, and the data not "
           "within the noise"
           + (" nor the model's accuracy" if plant.model_form_frf is not None else ""))
    return chosen, refit, [], (head + f"; the best, {best.label} (chi-square {r.chi2:.4g} refitted), fails the "
                               f"pair rule ({why}): the single effect stays")
