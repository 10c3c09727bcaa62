"""Choosing among fitted hypotheses: look-alikes separated by rerun, located places.

Complements :mod:`vlab.diagnose.fit.estimate` (information criteria) with the
decisions that need the whole diagnosis: which of two look-alike effects a
rerun of the experiment prefers, and where the mismatch is once effects are
fitted. Which local hypotheses are worth fitting (those the sensitivity-based
localisation points at), when a rerun is needed and how much a pair's rerun
must gain are rules of :mod:`vlab.diagnose.fit.rules`.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ...errors import ModelError, VlabError
from ..data.measured import FrfData
from ..data.replay import time_error
from ..data.rerun_jobs import last_reruns_note, reruns
from ..effects.hypotheses import Combination, Friction, Hypothesis, PointDamping
from ..problem.misfits import exact_errors_of
from ..problem.residuals import Problem
from .locate import located_places
from ..policy import DecisionPolicy
from .rules import NONLINEAR

#: Effects that act only in the controller path (seen closed loop only).
CONTROLLER_PATH = ("loop_delay", "sensor_lag", "sensor_gain")

#: Look-alikes compared again on the MuJoCo plant (the best by the linear reruns' time error) when the
#: recording came from it (:func:`tie_break_by_rerun`). Chosen for the cost: two reruns run side by side on
#: the two cores, and the winner's is the validation's rerun too (cached under the same key).
MUJOCO_LOOKALIKES = 2


def rerun_key(h: Hypothesis) -> str:
    """Cache key of the rerun of hypothesis ``h`` at its fitted parameters."""
    return f"{h.label}:{np.asarray(h.params_).tobytes().hex()}"


def _rerun_jobs(problem: Problem, hyps) -> list:
    """``(lab state, cache key)`` of each fitted hypothesis of ``hyps``, for
    :func:`vlab.diagnose.data.rerun_jobs.reruns`."""
    return [(problem.fitted_state(h), rerun_key(h)) for h in hyps]


def data_has_signals(data) -> bool:
    """True when ``data`` holds time histories (a rerun is possible)."""
    return isinstance(data, FrfData) and data.recording is not None


def _swap(h: Hypothesis, problem: Problem) -> Hypothesis | None:
    """The look-alike of a fitted single ``damping`` at a point (``friction`` there, and back), same linear model."""
    ctx, base = problem.ctx, problem.base
    if isinstance(h, PointDamping) or isinstance(h, Friction):
        try:
            if isinstance(h, PointDamping):
                c = float(h.params_[0])
                sigma = ctx.velocity_rms_of(replace(base, dashpots=base.dashpots + ((h.point, c),)), h.point)
                to_f = sigma * math.sqrt(math.pi / 2)  # F = c sigma sqrt(pi / 2)  (Caughey)
                new, scale = Friction(point=h.point), to_f
            else:
                c = h.equivalent_damping(base, float(h.params_[0]), ctx)
                new, scale = PointDamping(point=h.point), c / float(h.params_[0])
        except VlabError:
            return None
        if not np.isfinite(scale) or scale <= 0:
            return None
        new.params_ = np.asarray(h.params_) * scale
        new.ci95_ = np.asarray(h.ci95_) * scale
        for a in ("chi2_", "aic_", "bic_", "misfit_", "success_"):
            setattr(new, a, getattr(h, a))
        new.n_evaluations_ = 0
        return new
    return None


def lookalikes(h: Hypothesis, problem: Problem) -> list[Hypothesis]:
    """Fitted variants of ``h`` that are the same linear model: ``damping`` at a point swapped for
    ``friction`` there (and back), in a single effect or in either part of a pair; the velocity level
    for the exact mapping ``F = c sigma_v sqrt(pi / 2)`` comes from ``problem``."""
    if not isinstance(h, Combination):
        v = _swap(h, problem)
        return [v] if v is not None else []
    out = []
    a, b = h.parts
    k = a.n_params
    x_parts = (np.asarray(h.params_[:k], dtype=float), np.asarray(h.params_[k:], dtype=float))
    swaps = []
    for part, xp in zip((a, b), x_parts):
        probe = type(part).__new__(type(part))
        probe.__dict__.update(part.__dict__)
        probe.params_, probe.ci95_ = xp, np.column_stack([xp, xp])
        for at in ("chi2_", "aic_", "bic_", "misfit_", "success_"):
            setattr(probe, at, getattr(h, at))
        swaps.append(_swap(probe, problem))
    for use in ((True, False), (False, True), (True, True)):  # swap the first, the second, both
        if any(u and sw is None for u, sw in zip(use, swaps)):
            continue
        parts = [sw if u else p for u, sw, p in zip(use, swaps, (a, b))]
        x = np.concatenate([sw.params_ if u else xp for u, sw, xp in zip(use, swaps, x_parts)])
        ratio = x / np.where(h.params_ != 0, h.params_, 1.0)
        c = Combination(first=parts[0], second=parts[1])
        c.params_, c.ci95_ = x, np.asarray(h.ci95_) * ratio[:, None]
        for at in ("chi2_", "aic_", "bic_", "misfit_", "success_"):
            setattr(c, at, getattr(h, at))
        c.n_evaluations_ = 0
        out.append(c)
    return out


def _parts_alone(h: Hypothesis, ranked: list, problem: Problem) -> list[Hypothesis]:
    """The fitted single effects that are the parts of the pair ``h`` (friction fitted as a dashpot swapped
    back), for the parsimony check of :func:`tie_break_by_rerun`; empty if ``h`` is not a pair with a
    nonlinear part (whose second effect the linear fits cannot judge)."""
    if not isinstance(h, Combination) or not any(p.effect in NONLINEAR for p in h.parts):
        return []
    singles = [g for g in ranked if not isinstance(g, Combination)]
    out = []
    for part in h.parts:
        single = next((g for g in singles if g.label == part.label), None)
        if single is None and part.effect in NONLINEAR:
            swapped = [_swap(g, problem) for g in singles
                       if isinstance(g, (PointDamping, Friction)) and g.location == part.location]
            single = next((s for s in swapped if s is not None and s.effect == part.effect), None)
        if single is not None:
            out.append(single)
    return out


def tie_break_by_rerun(problem: Problem, chosen: Hypothesis, alts: list, ranked: list,
                       notes: list, *, max_candidates: int = 4, plant: str = "linear",
                       seed: int = 0) -> tuple[Hypothesis, list]:
    """Choose among look-alike effects by the time-domain error of a rerun.

    A saturating amplifier and a lower channel gain give nearly the same FRF
    (the saturation's describing function is a gain), and so do Coulomb
    friction and a dashpot at one point; the rerun through the loop
    reproduces the clipping or the friction force itself, so the time
    histories separate them. With ``plant="mujoco"`` the
    :data:`MUJOCO_LOOKALIKES` best of them (when all can be carried by the
    MuJoCo plant) are compared again on reruns of that plant: the linear
    plant's time error holds the FE/MuJoCo model-form error, which no
    candidate removes and which can leave look-alikes tied (MuJoCo grid:
    an actuator gain of 0.65 on channel 2 and
    a saturation of that channel both at 0.162 on the linear plant, and the
    saturation named). When the winner is a pair with such a
    nonlinear part, its linear misfit cannot judge the second effect: the
    pair is kept only if its rerun resolves a fall of the time-domain error
    below the better of its parts alone, by the validation's quadrature rule
    on the plant that made the recording (as any pair must beat its better
    part; the linear part's fit cannot judge the nonlinear one). With ``plant="mujoco"`` (a
    recording diagnosed against the MuJoCo plant) that check is made on
    reruns of the MuJoCo plant, when both can be carried by it: the linear
    plant's time error holds the FE/MuJoCo model-form error (about 0.25 of
    the signal on the grid), which the pair cannot lower and which hides
    its gain (MuJoCo grid: a lag next to a
    saturation, 0.275 against 0.328 on the linear plant).

    The reruns (the recorded force played back,
    :func:`vlab.diagnose.data.rerun_jobs.reruns`: the linear plant, and the MuJoCo
    plant for the parsimony check with ``plant="mujoco"``) run in parallel
    processes; three or more MuJoCo reruns of candidates whose plants differ
    only in values (stiffness, damping, gains; not an added mass, a geom of
    its own) run as one ``mujoco.batch``, the same recordings (the note says
    which way; :data:`vlab.diagnose.data.rerun_jobs.BATCH_MIN_RERUNS`). A
    MuJoCo rerun that fails leaves the check to the linear reruns, and the
    note says why.

    Parameters
    ----------
    problem : Problem
    chosen : Hypothesis
        The selected hypothesis.
    alts : list of Hypothesis
        Hypotheses the data cannot tell from it; those with as many parameters are compared.
    ranked : list of Hypothesis
        All fitted hypotheses (for the single nonlinear effect of a pair).
    notes : list of str
        Receives a line with the time errors.
    max_candidates : int
        Most hypotheses rerun.
    plant : {"linear", "mujoco"}
        Plant of the recording: with ``"mujoco"`` the best look-alikes and the parsimony check are rerun on
        the MuJoCo plant too (the look-alikes are first compared on the linear plant).
    seed : int
        Seed of the reruns' sensor noise (as :func:`vlab.diagnose.data.rerun_jobs.reruns`).

    Returns
    -------
    (Hypothesis, list of Hypothesis)
        The winner and the others.

    Raises
    ------
    ModelError
        ``plant`` is neither ``"linear"`` nor ``"mujoco"``.
    """
    if plant not in ("linear", "mujoco"):
        raise ModelError(f"unknown plant {plant!r} for the rerun check; use 'linear' or 'mujoco'")
    cands = _rerun_candidates(problem, chosen, alts, max_candidates)
    singles = {h.label: g for h in cands if (g := _parts_alone(h, ranked, problem))}
    # rerun the candidates when there is a choice, and pairs with a nonlinear part and each part alone
    todo: dict = {}
    for h in [h for h in cands if len(cands) > 1 or h.label in singles] + [g for gs in singles.values() for g in gs]:
        todo.setdefault(h.label, h)
    runs = reruns(problem, _rerun_jobs(problem, todo.values()), "linear", seed=seed)
    errors = {label: (float("inf") if isinstance(r, VlabError) else time_error(r, problem.data))
              for label, r in zip(todo, runs)}
    errs = [errors[h.label] for h in cands] if len(cands) > 1 else [float("nan")]
    j = int(np.nanargmin(errs)) if len(cands) > 1 else 0
    best = cands[j]
    if len(cands) > 1:
        notes.append("look-alikes compared by rerun (time-domain error): "
                     + ", ".join(f"{h.label}: {e:.3g}" for h, e in zip(cands, errs)))
        if plant == "mujoco" and all(h.spec_level for h in cands):
            best = _best_on_mujoco(problem, cands, errors, best, notes, seed)
    alone = singles.get(best.label)
    if not alone and (pair := pair_beside(best, ranked, problem)) is not None:
        # a nonlinear single effect: the linear fits cannot judge a second effect beside it, its rerun can -- the
        # pair against the better of its parts, the linear one's single fit among them where there is one
        alone = [best] + [g for g in ranked if not isinstance(g, Combination) and g.label != best.label
                          and any(p.label == g.label for p in pair.parts)][:1]
        for h in alone + [pair]:  # the linear reruns' errors, where the MuJoCo plant cannot carry the two
            if h.label not in errors:
                errors[h.label] = _linear_time_error(problem, h, seed)
        best = pair
    if alone:
        best = _pair_or_its_better_part(problem, best, alone, errors, notes, plant=plant, seed=seed)
    return best, [h for h in [chosen] + alts if h is not best]


def pair_beside(single: Hypothesis, ranked: list, problem: Problem) -> Hypothesis | None:
    """The best-fitting pair (lowest chi-square in ``ranked``) of the nonlinear single effect ``single`` with
    a linear effect, when its chi-square falls below the single's by the likelihood-ratio limit of one added
    parameter at the single's overdispersion (:meth:`vlab.diagnose.policy.DecisionPolicy.lr_limit`); None
    otherwise, and for a linear ``single``.

    A nonlinear effect's linear model is a describing function at one amplitude: the fits' chi-square carries
    its error (an overdispersion of hundreds on a saturating loop), which the evidence of a pair over the single
    divides out, so a linear effect beside it that the data need is not selected by the fits. The rerun judges
    it (:func:`_pair_or_its_better_part`), as it judges every pair with a nonlinear part.

    Parameters
    ----------
    single : Hypothesis
        The chosen effect.
    ranked : list of Hypothesis
        The fitted hypotheses, pairs among them (:class:`Combination`).
    problem : Problem
        For the number of residuals and the policy.

    Returns
    -------
    Combination or None
    """
    if isinstance(single, Combination) or single.effect not in NONLINEAR:
        return None
    pairs = [g for g in ranked if isinstance(g, Combination) and math.isfinite(g.chi2_)
             and any(p.label == single.label for p in g.parts)
             and all(p.effect not in NONLINEAR for p in g.parts if p.label != single.label)]
    if not pairs:
        return None
    pair = min(pairs, key=lambda g: g.chi2_)
    c_hat = max(1.0, single.chi2_ / max(problem.n_obs - single.n_params, 1))
    needed = problem.policy.needed(single.chi2_, pair.chi2_, pair.n_params - single.n_params, c_hat)
    return pair if needed else None


def _linear_time_error(problem: Problem, h: Hypothesis, seed: int) -> float:
    """The time-domain error of ``h``'s rerun on the linear plant (inf when it fails)."""
    run, = reruns(problem, _rerun_jobs(problem, [h]), "linear", seed=seed)
    return float("inf") if isinstance(run, VlabError) else time_error(run, problem.data)


def _rerun_candidates(problem: Problem, chosen: Hypothesis, alts: list, max_candidates: int) -> list:
    """``chosen``, its look-alikes of the same linear model and the alternatives with as many parameters, once
    each, the first ``max_candidates``."""
    cands, seen = [], set()
    for h in [chosen] + lookalikes(chosen, problem) + [h for h in alts if h.n_params == chosen.n_params]:
        if h.label not in seen:
            seen.add(h.label)
            cands.append(h)
    return cands[:max_candidates]


def _best_on_mujoco(problem: Problem, cands: list, errors: dict, best: Hypothesis, notes: list,
                    seed: int) -> Hypothesis:
    """The best of the :data:`MUJOCO_LOOKALIKES` best look-alikes (by the linear reruns' time ``errors``) on
    reruns of the MuJoCo plant; ``best`` when a MuJoCo rerun fails. Completes the last line of ``notes``."""
    top = sorted(cands, key=lambda h: errors[h.label])[:MUJOCO_LOOKALIKES]
    runs = reruns(problem, _rerun_jobs(problem, top), "mujoco", seed=seed)
    failed = [r for r in runs if isinstance(r, VlabError)]
    if failed:
        notes[-1] += f" (linear FE plant; the MuJoCo rerun failed: {failed[0]})"
        return best
    on_plant = {h.label: time_error(r, problem.data) for h, r in zip(top, runs)}
    best = min(top, key=lambda h: on_plant[h.label])
    how = last_reruns_note(problem)  # one mujoco.batch, or processes (and why)
    notes[-1] += (" on the linear FE plant; on the MuJoCo plant, which recorded the data"
                  + (f" ({how})" if how else "") + ": "
                  + ", ".join(f"{h.label}: {on_plant[h.label]:.3g}" for h in top))
    return best


def _pair_or_its_better_part(problem: Problem, best: Hypothesis, alone: list, errors: dict, notes: list, *,
                             plant: str, seed: int) -> Hypothesis:
    """The pair ``best`` if its rerun resolves a fall of the time-domain error below the better of its parts
    ``alone``, else that part: as every pair, it must beat its better part; on the MuJoCo plant where it can
    carry them (:func:`tie_break_by_rerun`), each part rerun there too, so that the better part is the better
    one on the plant that judges (a pair that beats only its worse part holds a passenger). Appends a line
    to ``notes``.

    The quadrature rule of the validation (:meth:`vlab.diagnose.policy.DecisionPolicy.resolved`): the pair is
    kept when ``e_single^2 - e_pair^2`` exceeds the square of the time-domain error an exact model leaves
    (:func:`rerun_resolution`), and -- the pair rule's definition of *the* explanation, applied to what the
    better part leaves beyond an exact model -- when it is at least the policy's ``explained_share`` of
    ``e_single^2 - e_exact^2`` (a second part that lowers the error by a resolvable 0.2 % of what the first
    leaves absorbs a part of the remainder; it does not explain it). That resolution holds only for reruns on
    the plant that made the recording (``plant``); on another plant (the linear FE plant against a MuJoCo recording) the two plants' own
    difference is in both errors and no resolution is known: the simpler model, the better part, is kept."""
    single = min(alone, key=lambda g: errors[g.label])
    e_pair, e_single = errors[best.label], errors[single.label]
    where, on_recordings_plant = "linear FE plant", plant == "linear"
    parts = [g for g in alone if g.spec_level]  # the parts the MuJoCo plant can carry
    others: list = []  # the other parts' errors, where they were rerun on the plant
    if plant == "mujoco" and best.spec_level and single.spec_level:
        # every part the plant carries is rerun there: the better part is the better one on that plant, the
        # footing of the judgement (the linear plant's ranking of the parts need not be the recording plant's)
        runs = reruns(problem, _rerun_jobs(problem, (best, *parts)), "mujoco", seed=seed)
        failed = [r for r in runs if isinstance(r, VlabError)]
        if failed:
            where += f" (the MuJoCo rerun failed: {failed[0]})"
        else:
            e_pair, *e_parts = (time_error(r, problem.data) for r in runs)
            single, e_single = min(zip(parts, e_parts), key=lambda ge: ge[1])
            how = last_reruns_note(problem)
            where, on_recordings_plant = "MuJoCo plant" + (f" ({how})" if how else ""), True
            others = [f"{g.label} alone: {e:.3g}" for g, e in zip(parts, e_parts) if g is not single]
    resolution = rerun_resolution(problem) if on_recordings_plant else float("nan")
    fall, left = e_single**2 - e_pair**2, e_single**2 - resolution**2
    share = problem.policy.explained_share
    keep = (math.isfinite(resolution) and DecisionPolicy.resolved(e_single, e_pair, resolution)
            and fall >= share * left)
    if not math.isfinite(resolution):
        why = ("no resolution on a plant other than the recording's or for a non-periodic excitation: the better "
               "part alone is kept")
    else:
        removed = f"{100 * fall / left:.3g} %" if left > 0 else "all"
        why = (f"an exact model leaves {resolution:.3g}; the pair removes {removed} of what the part leaves beyond "
               f"that: {'the pair is kept' if keep else 'the part alone is kept'} (a resolved fall of at least "
               f"{100 * share:g} % explains the remainder)")
    notes.append(f"pair with a nonlinear effect checked by rerun on the {where}: {best.label}: {e_pair:.3g}, "
                 f"{single.label} alone: {e_single:.3g}" + "".join(f", {o}" for o in others) + f" ({why})")
    return best if keep else single


def rerun_resolution(problem: Problem) -> float:
    """The time-domain error [1] an exact model leaves against the problem's recording: its noise and the
    model form carried (:func:`vlab.diagnose.problem.misfits.exact_errors_of` on the recorded FRFs); NaN
    for a non-periodic excitation or data without force amplitudes."""
    data = problem.data
    target, var = ((data.h_recorded, data.var_recorded) if data.h_recorded is not None and data.var_recorded
                   is not None else (data.h, data.var))
    return exact_errors_of(problem, target, var)[1]


def located_from_fits(res, chi2_0: float, *, share: float = 0.9) -> tuple[list, list]:
    """Points and members where the mismatch is, from the fitted local hypotheses of ``res`` (nonlinear best
    subset; ``chi2_0`` is the nominal chi-square).

    The first-order sensitivity ranking (:func:`vlab.diagnose.fit.locate.sensitivity_localisation`)
    chose which local hypotheses were fitted; here each fitted local effect
    counts by the share of the nominal chi-square it removes: the selected
    effect's places, and every local effect removing at least ``share`` of
    what the best local effect removes (places the data cannot tell apart,
    e.g. mirror points). Without a selected local effect, the places the
    sensitivity ranking points at are returned when there is an unexplained
    mismatch.
    """
    parts = res.selected_parts
    local = [h for h in res.ranked if not isinstance(h, Combination)
             and ("point" in h.location or "points" in h.location or "member" in h.location)]
    pts: list = []
    mems: list = []

    def add(h: Hypothesis) -> None:
        loc = h.location
        for p in ([loc["point"]] if "point" in loc else loc.get("points", [])):
            if p not in pts:
                pts.append(p)
        if "member" in loc:
            name = loc["member"] if "segment" not in loc else f"{loc['member']}[{loc['segment'][0]}-{loc['segment'][1]}]"
            if name not in mems:
                mems.append(name)

    for h in parts:
        add(h)
    sel_local = [h for h in parts if "point" in h.location or "points" in h.location or "member" in h.location]
    if sel_local and local:
        gain = max(chi2_0 - h.chi2_ for h in local)
        for h in local:
            if chi2_0 - h.chi2_ >= share * gain and h.effect in {p.effect for p in sel_local}:
                add(h)
    if res.selected is None and res.mismatch:
        if getattr(res, "too_small", False) and res.too_small_candidates:
            # a change too small to name: the places of the candidates the data cannot tell apart
            for h in res.too_small_candidates:
                for part in (h.parts if isinstance(h, Combination) else [h]):
                    add(part)
            return pts, mems
        return located_places(res.location.sensitivity)
    return pts, mems
