"""The decision rules of the diagnosis, in the order they are applied: what is fitted, what is selected, what is not.

Every threshold comes from the decision policy (:class:`vlab.diagnose.policy.DecisionPolicy`, carried by the
problem as ``problem.policy``): chi-square and single-line limits at the user's false-alarm rate, the
likelihood-ratio test of whether parameters are needed, the Kass-Raftery evidence that orders candidates,
and the quadrature rule by which a validation resolves a change of misfit. The searches and fits that feed
the rules live elsewhere (:mod:`vlab.diagnose.fit.estimate`, :mod:`vlab.diagnose.fit.selection`,
:mod:`vlab.diagnose.fit.plantfit`, :mod:`vlab.diagnose.fit.plantchoice`, :mod:`vlab.diagnose.fit.plantpair`,
:mod:`vlab.diagnose.validate`); :func:`vlab.diagnose.pipeline.diagnose` applies them in this order:

1. **Is there a mismatch?** The nominal lab's chi-square exceeds its limit, one line of one channel stands
   out, or the nominal lab's modes must move beyond their model-form uncertainty (:func:`beyond_noise`, with
   :meth:`~vlab.diagnose.problem.residuals.Problem.noise_chi2`,
   :meth:`~vlab.diagnose.problem.residuals.Problem.peak_limit` and
   :func:`~vlab.diagnose.problem.nuisance.nuisance_test`: three tests sharing the false-alarm rate).
   Data within those limits whose reference was excited by the recording's own force record are tested once
   more without the model-error floor (:func:`changed_beyond_noise`); a mismatch found only there is kept for
   rule 6. No mismatch: nothing is fitted or selected.
2. **What is fitted.** Every hypothesis of the library is screened (:func:`prune` gives the ones the
   sensitivity ranking points at its first-order size as an extra trial); the best by chi-square, the best
   mode-moving ones by smoothed error, the best of every family and every local structural one at the
   located places are fitted (:func:`shortlisted`); pairs are fitted when the best single effect still fails
   a test of the mismatch (:func:`needs_pairs`; :func:`vlab.diagnose.fit.estimate.fit_pairs`). A dashpot or
   friction at a point is fitted up to the critical dashpot of the mode it damps most
   (:func:`vlab.diagnose.effects.beyond_spec.critical_dashpot`).
3. **Selection on the FE model** (:func:`select`): the best single effect by
   BIC, or a pair that beats it by the policy's evidence, whose second part
   the likelihood-ratio test finds needed and that explains what the single
   effect leaves (the policy's ``explained_share`` of its chi-square,
   :func:`explains_remainder`; not asked of a pair with a :data:`NONLINEAR` part); the choice must beat the nominal model by the
   evidence and the likelihood-ratio test, else nothing is selected. The
   hypotheses within the evidence of it are its look-alikes. A selected pair
   one of whose parts, fitted alone, passes the mismatch tests with its
   modes profiled within their model form is replaced by that part: the
   other is a passenger (:func:`part_alone`). A choice that still fails a test of the mismatch gives way to
   the best-ranked single effect that passes them all, else to the best-ranked pair that does and needs
   both its parts (:func:`vlab.diagnose.fit.passing.passing_choice`): the statistic that declared the
   mismatch judges what explains it.
4. **Look-alikes by rerun**, when the choice or a look-alike is one only a
   rerun separates (:func:`needs_rerun_check`) and the data are time
   histories: the least time-domain error of a rerun wins, and a pair with a
   nonlinear part is kept only if its rerun resolves a fall of the time-domain
   error below the better of its parts alone (the validation's quadrature
   rule, on the plant that made the recording)
   (:func:`vlab.diagnose.fit.selection.tie_break_by_rerun`).
5. **On the MuJoCo plant's linearisation**, for a spec-level choice on a
   recording of the MuJoCo plant: a pair gives way to its mode-moving, spec-level part -- compared there
   with its look-alikes and the same physics at the located places -- when that single effect, refitted
   there, leaves the data within the mismatch test's limits
   (:func:`vlab.diagnose.fit.plantchoice.explains_on_plant`) or the pair, scored there, does not pass the
   pair rule against it (:func:`vlab.diagnose.fit.plantchoice.pair_needed_on_plant`; also for a pair whose
   other part the plant cannot carry); else a pair must pass the pair rule again
   there (:func:`passes_pair_rule` in
   :func:`vlab.diagnose.fit.plantchoice.reduce_pair_on_plant`), else the
   better of its parts is chosen; a single effect is compared there with its
   look-alikes (:func:`vlab.diagnose.fit.plantchoice.choose_on_plant`); a
   single effect that leaves more than noise there is replaced by a pair
   only if the pair passes the pair rule there
   (:func:`vlab.diagnose.fit.plantpair.second_effect_on_plant`).
6. **Too small to name** (:func:`too_small_to_name`): a choice made on a mismatch found only without the
   floor (rule 1) is located, not named.
7. **Rejected by its validation** (:func:`vlab.diagnose.fit.confirm.worsens`): a choice whose validation rerun makes the fit worse
   beyond what it resolves is not selected.
8. **Better than nothing, on the same footing** (:func:`vlab.diagnose.fit.confirm.improves_on_nominal`): the choice's chi-square must
   fall below the nominal lab's -- the lower of its chi-square with the model form whitened and with its
   modes profiled within their model form, the statistic that declared the mismatch -- by the
   likelihood-ratio limit; and its validation rerun's chi-square, on the same covariance, must fall by that
   limit too (a choice that passes the mismatch test's competitor only on another footing is not an
   explanation).
9. **Not explained** (:func:`explains`): a choice that removes less than the policy's ``explained_share`` of
   the nominal chi-square, leaves the data out of the noise and whose rerun does not lower the FRF misfit by
   as much is not selected: the mismatch lies outside the library.
10. **The remainder** (:func:`vlab.diagnose.decision.remainder_of`): what a selected choice leaves is judged
    by the mismatch test's own tests (total chi-square, largest line, the modes' moves) and, on its
    validation rerun, against what an exact model leaves (:func:`vlab.diagnose.fit.confirm.remainder_resolved`)
    or by the rerun's largest line; a remainder is reported with its size and place (the choice explains part
    of the mismatch), never dropped. A linear choice with look-alikes that leaves a remainder on its rerun
    gives way to a look-alike whose own rerun leaves none, else nothing is named
    (:func:`vlab.diagnose.decision.settle_remainder`).
11. **The oscillation reproduced** (:func:`vlab.diagnose.fit.identity.reproduces_oscillation`): when the
    recording holds a self-excited oscillation that the nominal replay does not
    (:mod:`vlab.measure.instability`), a choice is selected only if its validation rerun's own oscillation --
    its strongest self-excited line at its loop point, the recording's by the same definition -- lies at the
    same frequency (within the policy's ``oscillation_tolerance``) or on a branch (between two natural
    frequencies) or, above the band, nearest a mode that the recording's may have within the model's
    frequency uncertainty (:mod:`vlab.diagnose.fit.identity`). The candidates tried are those whose linear
    loop is unstable (:mod:`vlab.diagnose.instability_cause`).

Where the mismatch is reported once effects are fitted is
:func:`vlab.diagnose.fit.selection.located_from_fits`; which parameter of a
choice is refitted on the plant, :func:`vlab.diagnose.fit.plantfit.refit_index`.

Sources: Kass & Raftery, J. Am. Stat. Assoc. 90 (1995) 773-795 (a BIC difference of 10 is "very strong"
evidence); quasi-BIC with the overdispersion of the best fit (Burnham & Anderson, *Model Selection and
Multimodel Inference*, 2nd ed., 2002, Sec. 6.2); the likelihood-ratio test (Wilks, Ann. Math. Stat. 9
(1938) 60-62).
"""

from __future__ import annotations

import math

import numpy as np

from ...errors import ModelError
from ..data.measured import FrfData
from ..effects.hypotheses import Combination, Hypothesis, PointDamping
from ..model.labmodel import LabState
from ..policy import DEFAULT_POLICY, DecisionPolicy
from ..problem.derived import without_floor
from ..problem.residuals import Problem
from ..problem.nuisance import within_model_accuracy
from .locate import at_places


#: Effects whose frequency-domain model is a describing function: their FRF
#: misfit understates what they explain, so pairs with them skip the gain test.
NONLINEAR = ("saturation", "friction")

#: Local structural effects: the ones the sensitivity ranking can point at (:func:`prune`).
STRUCTURAL = ("added_mass", "support_stiffness", "joint_flexibility", "member_stiffness")


def beyond_noise(chi2: float, chi2_limit: float, peak: float, peak_limit: float) -> bool:
    """Rule 1: whether the nominal lab leaves more than the noise: its chi-square ``chi2`` exceeds
    ``chi2_limit`` (:meth:`~vlab.diagnose.problem.residuals.Problem.noise_chi2`) or its largest single
    residual ``peak`` exceeds ``peak_limit`` (:meth:`~vlab.diagnose.problem.residuals.Problem.peak_limit`)."""
    return chi2 > chi2_limit or peak > peak_limit


def changed_beyond_noise(problem: Problem, nominal: LabState) -> tuple[bool, dict]:
    """Whether FRF data referred to the model through a baseline changed since that baseline beyond the noise
    of the two recordings, with no model-error floor.

    On referred data (:func:`vlab.diagnose.data.measured.refer_to_model`) the nominal
    model's residual is ``ln(H_baseline / H_recorded)`` whatever the model:
    the floor, an allowance for what the model cannot represent, has nothing
    to allow for in the question whether anything changed: with it, a change
    of 1.3 % at one line, far beyond the two recordings' noise, would pass as
    model error. The same tests as :meth:`Problem.within_noise`
    (total chi-square and largest line), on weights ``1 / sigma_rel^2``: the
    two recordings' relative noise variances plus the referral's own
    second-order term (model-form error x change), which
    :func:`~vlab.diagnose.data.measured.refer_to_model` adds to ``var``.

    Parameters
    ----------
    problem : Problem
        With FRF data referred through a baseline (``h_recorded`` set).
    nominal : LabState
        The nominal lab the data were referred to.

    Returns
    -------
    (bool, dict)
        Whether the data changed beyond the noise, and the statistics of the
        test without the floor: ``chi2``, ``chi2_limit``, ``peak``,
        ``peak_limit`` (empty when it cannot be made). False when a used line
        of the recording or of the baseline has no noise estimate (FRF files
        without coherence): the floor then stays the only weight, since the
        referral's term alone would weigh a change of any size as about
        ``1 / |ln(H_model / H_baseline)|``. False too against the nominal plant's
        replay: its variance is zero, or only the replay plant's own level dependence
        (:func:`vlab.diagnose.data.reference.with_replay_distortion`), not a noise; the recording's noise
        alone, estimated from two or three periods, made a clean linear recording's
        band-edge line stand out (squared residual 70, limit 53), so the replay
        is compared within the model-error floor only.

    Raises
    ------
    ModelError
        Data not referred through a baseline (modal data, or FRFs without ``h_recorded``).
    """
    data = problem.data
    if not isinstance(data, FrfData) or data.h_recorded is None:
        raise ModelError(f"{getattr(data, 'source', 'data')}: only data referred through a baseline can be tested "
                         "for a change without the model-error floor")
    m = problem.mask
    noise = (data.var_recorded, data.var_baseline)
    if problem.replay_plant is not None or any(v is None or not np.all(v[m] > 0) for v in noise):
        return False, {}
    raw = without_floor(problem, nominal)
    stats = {"chi2": raw.chi2(nominal, test=True), "chi2_limit": raw.noise_chi2(),
             "peak": raw.peak(nominal, test=True), "peak_limit": raw.peak_limit()}
    return stats["chi2"] > stats["chi2_limit"] or stats["peak"] > stats["peak_limit"], stats


def prune(hyps: list[Hypothesis], sensitivity: list[dict], *, share: float = 0.25, per_family: int = 6,
          min_explained: float = 0.5) -> list[Hypothesis]:
    """Rule 2: give the local structural hypotheses of ``hyps`` that the ``sensitivity`` ranking points at its
    first-order size as an extra trial value (``estimate_``); none is left out.

    When the best single local parameter explains at least ``min_explained`` of
    the frequency errors, a local structural hypothesis (added mass, spring at a
    free DOF, joint flexibility, member rigidity) whose sensitivity candidate
    explains at least ``share`` of the best one or is among the ``per_family``
    best of its effect gets ``estimate_``. None is left out of the screening:
    the ranking is first order in the frequency errors of modes paired by
    nearest frequency, and the changes it misjudges are the large ones (a
    joint softened enough to move several modes by a few per cent, a shift
    the linearisation cannot follow and the pairing by frequency confuses).
    Screening them all costs about 50 more hypotheses on the grid, 3-4 s.
    """
    if not sensitivity or sensitivity[0]["explained"] < min_explained:
        return hyps
    best = sensitivity[0]["explained"]
    by_key = {}
    rank_in_family: dict = {}
    for d in sensitivity:
        key = (d["effect"], tuple(sorted((k, tuple(v) if isinstance(v, list) else v)
                                         for k, v in d["location"].items())))
        rank_in_family[d["effect"]] = rank_in_family.get(d["effect"], 0) + 1
        by_key[key] = (d, rank_in_family[d["effect"]])
    for h in hyps:
        if h.effect not in STRUCTURAL:
            continue
        key = (h.effect, tuple(sorted((k, tuple(v) if isinstance(v, list) else v) for k, v in h.location.items())))
        hit = by_key.get(key)
        if hit is None:
            continue  # not a local frequency parameter (e.g. a released support)
        d, r = hit
        if d["explained"] >= share * best or r <= per_family:
            h.estimate_ = d["estimate"]
    return list(hyps)


def shortlisted(scored: list, shortlist: int, places=frozenset()) -> list[Hypothesis]:
    """Rule 2: the screened hypotheses fitted in full.

    Parameters
    ----------
    scored : list of (float, Hypothesis)
        The screened hypotheses with their best screening chi-square, sorted by it (best first).
    shortlist : int
        Number fitted by chi-square (half as many are added by smoothed error).
    places : frozenset of int
        The located points (:attr:`vlab.diagnose.fit.locate.Location.places`).

    Returns
    -------
    list of Hypothesis
        The ``shortlist`` best by chi-square, the ``shortlist // 2`` one-parameter mode-moving ones with
        the least smoothed error (``coarse_error_``) not among them, the best of every family not yet in
        (an effect and the kind of its place: a mode's damping and a point dashpot are two families, a
        chain effect on one channel and on all channels too), and every local structural hypothesis at
        ``places``: located from the measured frequency errors, while the FE fit's model-form error at one
        place can rank the right one far down.
    """
    keep: list[Hypothesis] = [h for _, h in scored[:shortlist]]
    # a mode-moving effect whose chi-square well the trials missed still shows in the smoothed error
    broad = sorted((h for _, h in scored if h.moves_modes and h.n_params == 1), key=lambda h: h.coarse_error_)
    keep += [h for h in broad[:shortlist // 2] if h not in keep]
    # a family: an effect and the kind of place (a mode's damping and a dashpot at a point are two)
    def family(h: Hypothesis) -> tuple:
        where = tuple(sorted(h.location))
        return h.effect, where + (("all",) if h.location.get("channel") == "all" else ())

    seen = {family(h) for h in keep}
    for _, h in scored:
        if family(h) not in seen:
            keep.append(h)
            seen.add(family(h))
    keep += [h for _, h in scored if h.effect in STRUCTURAL and at_places(h.location, places) and h not in keep]
    return keep


def needs_pairs(best: Hypothesis | None, problem: Problem) -> bool:
    """Rule 2: whether pairs are fitted: the best single effect ``best`` (fitted) leaves the data of
    ``problem`` beyond the tests that declared the mismatch -- the noise, and where the nominal lab's modes
    were profiled the model form too (:func:`vlab.diagnose.problem.nuisance.within_model_accuracy`)."""
    return best is not None and not within_model_accuracy(problem, problem.fitted_state(best))


def part_alone(parts: list[Hypothesis], problem: Problem) -> Hypothesis | None:
    """Rule 3, its last step: the part of a selected pair that explains the data by itself, or None.

    A pair's second effect is needed only where the first alone leaves the data beyond the tests that
    declared the mismatch. The pair is chosen on the fit's footing, where the model form enters to first
    order only (its correlated part whitened); a model error within that form but beyond the linear range
    (a lightly damped mode whose frequency is off by a fraction of its half-power bandwidth) still carries
    chi-square there, and a second effect that moves every mode a little absorbs it. So each part, fitted
    alone, is put to the mismatch tests themselves -- its modes profiled within the model form
    (:func:`vlab.diagnose.problem.nuisance.within_model_accuracy`) -- and a part that passes them makes the
    other a passenger.

    Parameters
    ----------
    parts : list of Hypothesis
        The pair's parts, each fitted alone (``params_`` and ``chi2_`` set).
    problem : Problem

    Returns
    -------
    Hypothesis or None
        The passing part with the lower chi-square; None when each part alone leaves a mismatch.
    """
    ok = [h for h in parts if within_model_accuracy(problem, problem.fitted_state(h))]
    return min(ok, key=lambda h: h.chi2_) if ok else None


def evidence(better: Hypothesis | None, worse: Hypothesis | None, *, chi2_0: float, n_obs: int,
             c_hat: float = 1.0) -> float:
    """Quasi-BIC evidence for ``better`` over ``worse`` (None = the nominal model, chi2 ``chi2_0``, k = 0),
    with ``n_obs`` residuals and overdispersion ``c_hat``.

    ``(chi2_w - chi2_b) / c_hat - (k_b - k_w) ln N``: the BIC difference with
    the chi-squares divided by the overdispersion ``c_hat`` (the reduced
    chi-square of the best fit when it exceeds 1: misfit the model cannot
    explain, e.g. nonlinear distortion, must not make small improvements
    look significant; QAIC/QBIC of Burnham & Anderson, *Model Selection and
    Multimodel Inference*, 2nd ed., 2002, Sec. 6.2).
    """
    cb, kb = (chi2_0, 0) if better is None else (better.chi2_, better.n_params)
    cw, kw = (chi2_0, 0) if worse is None else (worse.chi2_, worse.n_params)
    return (cw - cb) / c_hat - (kb - kw) * math.log(n_obs)


def select(ranked: list[Hypothesis], chi2_0: float, n_obs: int,
           policy: DecisionPolicy = DEFAULT_POLICY) -> tuple[Hypothesis | None, float, list]:
    """Choose the explaining effect among the fitted hypotheses ``ranked``.

    ``chi2_0`` is the nominal model's chi-square, ``n_obs`` the number of residuals.

    The best single effect (lowest BIC) is chosen unless a pair beats it by the
    policy's ``evidence`` in quasi-BIC (overdispersion from the best single
    fit), its second part is needed by the likelihood-ratio test
    (:meth:`~vlab.diagnose.policy.DecisionPolicy.needed`) and it explains what the single effect leaves
    (:func:`explains_remainder`; not asked of pairs with a :data:`NONLINEAR` effect, which the rerun judges);
    the choice must beat the nominal model by ``evidence`` and be needed by the likelihood-ratio test
    too, else nothing is selected.

    Returns
    -------
    selected : Hypothesis or None
    c_hat : float
        Overdispersion ``max(1, chi2 / (N - k))`` of the selected (or best) fit.
    alternatives : list of Hypothesis
        Other hypotheses within the policy's ``evidence`` of the selected one.
    """
    singles = [h for h in ranked if not isinstance(h, Combination)]
    combos = [h for h in ranked if isinstance(h, Combination)]
    if not singles:
        return None, 1.0, []
    best = min(singles, key=lambda h: (h.bic_, h.n_params, h.order))
    c_hat = max(1.0, best.chi2_ / max(n_obs - best.n_params, 1))
    if combos:
        pair = min(combos, key=lambda h: h.bic_)
        nonlinear = any(h.effect in NONLINEAR for h in pair.parts)
        c_pair = max(1.0, pair.chi2_ / max(n_obs - pair.n_params, 1))
        if (evidence(pair, best, chi2_0=chi2_0, n_obs=n_obs, c_hat=c_hat) >= policy.evidence
                and policy.needed(best.chi2_, pair.chi2_, pair.n_params - best.n_params, c_pair)
                and (nonlinear or explains_remainder(best.chi2_, pair.chi2_, policy))):
            best = pair
            c_hat = c_pair
    if (evidence(best, None, chi2_0=chi2_0, n_obs=n_obs, c_hat=c_hat) < policy.evidence
            or not policy.needed(chi2_0, best.chi2_, best.n_params, c_hat)):
        return None, c_hat, []
    alts = [h for h in ranked if h is not best and h.n_params <= best.n_params
            and evidence(best, h, chi2_0=chi2_0, n_obs=n_obs, c_hat=c_hat) < policy.evidence]
    return best, c_hat, alts


def needs_rerun_check(h: Hypothesis) -> bool:
    """True when ``h`` (or a part of it) has look-alikes only a rerun separates (saturation, friction,
    damping at a point)."""
    parts = h.parts if isinstance(h, Combination) else (h,)
    return any(p.effect in NONLINEAR or isinstance(p, PointDamping) for p in parts)


def explains_remainder(chi2_single: float, chi2_pair: float, policy: DecisionPolicy = DEFAULT_POLICY) -> bool:
    """Whether a pair's second effect explains what its first leaves: from ``chi2_single`` to ``chi2_pair`` it
    removes at least the ``policy``'s ``explained_share`` of the chi-square (the definition of *the* explanation,
    :func:`explains`, applied to the remainder; one that removes less absorbs a part of the remainder, which
    is reported instead). A chi-square that is not finite leaves the decision to the evidence (True)."""
    ok = math.isfinite(chi2_single) and math.isfinite(chi2_pair) and chi2_single > 0
    return not ok or bool(1.0 - chi2_pair / chi2_single >= policy.explained_share)


def passes_pair_rule(ev: float, chi2s: tuple, exempt: bool, policy: DecisionPolicy = DEFAULT_POLICY) -> bool:
    """Rule 5: the pair rule of the selection applied on the plant's linearisation: the pair's quasi-BIC
    evidence ``ev`` over the single effect (:func:`evidence`) is at least the policy's ``evidence``, and it
    explains what the single effect leaves, ``chi2s = (single, pair)`` (:func:`explains_remainder`), unless
    ``exempt`` (a pair with a :data:`NONLINEAR` part, or one that brings the data within the noise)."""
    return ev >= policy.evidence and (exempt or explains_remainder(chi2s[0], chi2s[1], policy))


def too_small_to_name(chosen: Hypothesis | None, noise_only: dict | None) -> bool:
    """Rule 6: whether a choice is too small to name: ``chosen`` explains a mismatch found only without
    the model-error floor (``noise_only``, the statistics of :func:`changed_beyond_noise`; None when the
    mismatch was found with the floor). Beyond the noise, within the model's accuracy: the FE surrogate's
    own errors of that size could mimic any of the candidates, so the change is located, not named."""
    return chosen is not None and noise_only is not None


def explained_share(res, chi2_0: float) -> tuple[float, bool]:
    """What the selected effect of ``res`` explains on the linear model (the test of :func:`explains`).

    A mismatch found only without the model-error floor (``res.noise_only``,
    :func:`changed_beyond_noise`) is judged without it too
    (:func:`vlab.diagnose.problem.derived.without_floor`): with the floor the nominal
    model is already within the noise, and any effect would pass.

    Parameters
    ----------
    res : DiagnosisResult
        With a selected effect (``res.selected`` fitted; ``res.selected_state()`` its lab).
    chi2_0 : float
        The nominal model's chi-square with the floor (used when ``res.noise_only`` is None).

    Returns
    -------
    share : float
        ``1 - chi2 / chi2_nominal`` (dimensionless; negative when the effect fits worse than nothing),
        without the floor against ``res.noise_only["chi2"]`` when the mismatch was found only there.
    within : bool
        Whether the effect leaves the data within the tests that declared the mismatch, on the same
        weights: the noise's (:meth:`Problem.within_noise`: total chi-square and largest line), with the
        lab's modes profiled within their model form where the mismatch test profiled the nominal lab's
        (:func:`vlab.diagnose.problem.nuisance.within_model_accuracy`: the moves' tests too). A mismatch
        declared by the model form alone (the nominal chi-square within its limit) leaves no share of the
        chi-square to remove; the question is then whether the effect passes the test that failed.

    Raises
    ------
    ModelError, SpecError
        The selected effect's lab cannot be built (as :meth:`Problem.chi2`).
    """
    state = res.selected_state()
    if res.noise_only:
        raw = without_floor(res.problem)
        return 1.0 - raw.chi2(state, test=True) / res.noise_only["chi2"], raw.within_noise(state)
    return 1.0 - res.selected.chi2_ / chi2_0, within_model_accuracy(res.problem, state)


def explains(res, chi2_0: float) -> bool:
    """Whether the selected effect of ``res`` explains the mismatch: it removes at least the policy's
    ``explained_share`` (``res.problem.policy``) of the nominal chi-square ``chi2_0`` (linear model), or it leaves the data within the
    tests that declared the mismatch (:func:`explained_share`: a local mismatch removed), both without the model-error floor when the
    mismatch was found only without it (:func:`explained_share`), or its validation rerun lowers the FRF
    misfit by at least ``1 / (1 - share)`` (effects whose linear model is only a describing function:
    friction, saturation)."""
    if res.selected is None:
        return False
    share = res.problem.policy.explained_share
    removed, within = explained_share(res, chi2_0)
    if removed >= share or within:
        return True
    v = res.validation
    return v is not None and v.misfit_after <= (1.0 - share) * v.misfit_before
