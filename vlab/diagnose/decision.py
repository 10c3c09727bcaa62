"""The decision of the diagnosis after the fits: which mismatch test fired, whether the choice stands, the remainder.

Three steps, each from the decision policy (:class:`vlab.diagnose.policy.DecisionPolicy`, ``problem.policy``)
and each leaving a statement in the result, so that the verdict can never contradict its own numbers:

1. :func:`mismatch_tests` -- the tests of rule 1 of :mod:`vlab.diagnose.fit.rules` that the nominal lab
   fails, each with its statistic and limit (the verdict names them; a mismatch is declared only when one
   of them is listed).
2. :func:`apply_gates` -- a choice stands only if its validation does not make the fit worse (rule 7), it
   fits better than the nominal lab on its fit's footing (a likelihood-ratio test of the nested labs) and
   its validation lowers the misfit
   (rule 8), and it explains the larger part of the mismatch (rule 9); otherwise it is listed as rejected,
   with the reason.
3. :func:`remainder_of` -- what a choice that stands leaves (rule 10): beyond the mismatch test's own limits
   (the same covariance), it is reported with its size and where it is (modes, points, the largest line);
   a choice that leaves a remainder *and* that these data cannot tell from its look-alikes is not named
   (:func:`settle_remainder`): a fit biased by unexplained physics and not separated from other effects
   identifies nothing (Brynjarsdottir & O'Hagan, Inverse Problems 30, 2014).

Sources: as :mod:`vlab.diagnose.fit.rules` and :mod:`vlab.diagnose.policy`.
"""

from __future__ import annotations

import copy
import math

import numpy as np

from .data.measured import FrfData
from ..errors import ModelError, SpecError
from .effects.hypothesis import Combination
from .fit.locate import extra_resonances, locate, resonance_limit
from .fit.resonances import unpaired_peaks
from .fit.confirm import improves_on_nominal, remainder_resolved, worsens
from .fit.rules import NONLINEAR, explained_share, explains
from .fit.selection import located_from_fits
from .problem.nuisance import within_model_accuracy
from ..measure.instability import LINE_TO_FLOOR
from .problem.misfits import noise_misfit
from .problem.residuals import Problem
from .report.text import ratio_text
from .report.result import DiagnosisResult

#: Names of the mismatch tests (``test`` of an entry of :func:`mismatch_tests`).
TESTS = {"chi2": "the total chi-square", "line": "the largest single line",
         "model_form": "the moves of the nominal modes beyond their model-form uncertainty",
         "model_form_largest": "the largest move of one nominal mode's parameter beyond its model-form uncertainty",
         "change": "the change from the reference without the model-error floor",
         "oscillation": "a self-excited oscillation the nominal lab's replay does not make"}


def mismatch_tests(chi2: float, chi2_limit: float, peak: float, peak_limit: float, nuisance: dict | None,
                   change: dict | None = None, oscillation: dict | None = None) -> list[dict]:
    """The mismatch tests the nominal lab fails (rule 1), each as ``test``, ``statistic``, ``limit`` [1].

    Parameters
    ----------
    chi2, chi2_limit : float
        The nominal lab's chi-square and its limit (:meth:`Problem.noise_chi2`).
    peak, peak_limit : float
        Its largest squared residual of one line and channel and its limit (:meth:`Problem.peak_limit`).
    nuisance : dict or None
        :func:`vlab.diagnose.problem.nuisance.nuisance_test` (None: no model form profiled).
    change : dict or None
        The statistics of :func:`vlab.diagnose.fit.rules.changed_beyond_noise` when that test found a change
        (``chi2``, ``chi2_limit``, ``peak``, ``peak_limit``), else None.
    oscillation : dict or None
        The recording's instability check (:func:`vlab.measure.instability.find_instability`, as the result
        holds it) when it found a self-excited oscillation that the nominal lab's replay of the recorded
        force does not make (``in_replay`` False), else None: a mismatch of its own, whatever the FRFs of the
        lines the oscillation leaves usable say. Its statistic is the strongest line's power over the
        channel's incoherent floor, its limit the detector's :data:`vlab.measure.instability.LINE_TO_FLOOR`
        (a noise bin reaches even a tenth of it with a probability below 1e-30: the test takes no
        measurable share of the false-alarm rate).

    Returns
    -------
    list of dict
        Empty when the nominal lab passes every test (no mismatch).
    """
    out = []
    if chi2 > chi2_limit:
        out.append({"test": "chi2", "statistic": float(chi2), "limit": float(chi2_limit)})
    if peak > peak_limit:
        out.append({"test": "line", "statistic": float(peak), "limit": float(peak_limit)})
    if nuisance and nuisance["beyond"]:
        out.append({"test": "model_form", "statistic": float(nuisance["nuisance_chi2"]),
                    "limit": float(nuisance["nuisance_limit"]), "largest": nuisance["largest"],
                    "largest_sigmas": float(nuisance["largest_sigmas"])})
    if nuisance and nuisance.get("largest_beyond"):
        out.append({"test": "model_form_largest", "statistic": float(nuisance["largest_sigmas"]) ** 2,
                    "limit": float(nuisance["largest_limit"]), "largest": nuisance["largest"],
                    "largest_sigmas": float(nuisance["largest_sigmas"])})
    if change:
        out.append({"test": "change", "statistic": float(change["chi2"]), "limit": float(change["chi2_limit"]),
                    "peak": float(change["peak"]), "peak_limit": float(change["peak_limit"])})
    if oscillation and oscillation.get("unstable") and oscillation.get("in_replay") is False:
        strongest = oscillation["oscillations"][0]
        out.append({"test": "oscillation", "statistic": float(strongest["line_to_floor"]),
                    "limit": float(LINE_TO_FLOOR), "frequency_hz": float(strongest["frequency_hz"])})
    return out


def rejection(h, reason: str, before: float, after: float, noise: float | None, **more) -> dict:
    """The entry of ``res.rejected`` for the candidate ``h`` rejected for ``reason``: its FRF misfits
    [decades] ``before`` and ``after`` (validation rerun, else the linear model), the misfit an exact model
    leaves, ``noise`` [decades] (None when unknown), and any further numbers ``more`` (their keys carry their
    units)."""
    return {"effect": h.effect, "label": h.label, "misfit_before": before, "misfit_after": after,
            "noise_misfit": noise, **more, "reason": reason}


def drop_selection(res: DiagnosisResult, misfit_0: float, chi2_fit: float, *, outside: bool) -> None:
    """Unselect the candidate of ``res`` that a rule rejected: nothing selected, the nominal misfit
    ``misfit_0``, the location from the fits (``chi2_fit``); ``outside``: the mismatch lies outside the
    library (a library effect that does not fit is never the answer)."""
    res.selected, res.validation, res.alternatives, res.plant_refit = None, None, [], None
    res.misfit_selected = misfit_0
    if res.instability:  # an unselected cause is no cause
        res.instability.pop("cause", None)
    if outside:
        res.outside_library = True
    res.location.points, res.location.members = located_from_fits(res, chi2_fit)


def _misfits(res: DiagnosisResult, misfit_0: float) -> tuple[float, float, float | None]:
    v = res.validation
    return (v.misfit_before, v.misfit_after, v.noise_misfit) if v is not None else (misfit_0, res.misfit_selected,
                                                                                   None)


def apply_gates(res: DiagnosisResult, problem: Problem, *, chi2_fit: float, misfit_0: float, self_excited: bool,
                notes: list) -> None:
    """Rules 7-9 on the choice of ``res`` (modified in place: a rejected choice is unselected and listed in
    ``res.rejected`` with its reason, and ``notes`` says why).

    Parameters
    ----------
    res : DiagnosisResult
        With ``selected`` (or None: nothing to do), ``validation`` and ``chi2_nominal`` set.
    problem : Problem
        Its policy decides.
    chi2_fit : float
        The nominal lab's chi-square on the fitted hypotheses' footing (whitened model form) [1].
    misfit_0 : float
        The nominal lab's misfit on the linear model [decades].
    self_excited : bool
        The recording oscillates by itself and the nominal replay does not (its cause was searched).
    notes : list of str
    """
    policy = problem.policy
    if res.selected is not None and res.validation is not None and worsens(
            res.validation, self_excited=self_excited, k=res.selected.n_params, c_hat=res.overdispersion,
            policy=policy):
        v, h = res.validation, res.selected
        res.rejected.append(rejection(h, "its validation rerun makes the fit worse", v.misfit_before,
                                      v.misfit_after, v.noise_misfit, time_error_before=v.time_error_before,
                                      time_error_after=v.time_error_after, chi2_before=v.chi2_before,
                                      chi2_after=v.chi2_after))
        chi2_text = (f"chi2 on the fit's footing {v.chi2_before:.4g} -> {v.chi2_after:.4g}, a change beyond "
                     f"{policy.lr_limit(h.n_params, res.overdispersion):.4g} resolved; "
                     if np.isfinite(v.chi2_before) and np.isfinite(v.chi2_after) and not self_excited else "")
        notes.append(f"the best candidate, {h.label}, is rejected: its validation rerun ({v.plant}) makes the fit "
                     f"worse ({chi2_text}FRF misfit {v.misfit_before:.3g} -> {v.misfit_after:.3g} decades, "
                     f"{ratio_text(v.misfit_before, v.misfit_after)}; time-domain error {v.time_error_before:.3g} "
                     f"-> {v.time_error_after:.3g}, {ratio_text(v.time_error_before, v.time_error_after)}"
                     + (f"; an exact model leaves {v.noise_time_error:.3g}" if np.isfinite(v.noise_time_error) else "")
                     + "): "
                     "the library's best does not explain the mismatch, which lies outside the library; nothing "
                     "is selected")
        drop_selection(res, misfit_0, chi2_fit, outside=True)
    if res.selected is not None:
        h = res.selected
        ok, why = improves_on_nominal(h, chi2_fit, res.overdispersion, res.validation,
                                      policy, self_excited=self_excited)
        if not ok:
            before, after, noise = _misfits(res, misfit_0)
            res.rejected.append(rejection(h, "fits no better than the nominal lab", before, after, noise))
            notes.append(f"the best candidate, {h.label}, is rejected: {why}; no effect of the library fits the data "
                         "better than the nominal lab within its own uncertainty, and nothing is selected")
            drop_selection(res, misfit_0, chi2_fit, outside=False)
    if res.selected is not None and not self_excited and not explains(res, chi2_fit):
        h = res.selected
        before, after, noise = _misfits(res, misfit_0)
        res.rejected.append(rejection(h, "explains only part of the mismatch", before, after, noise))
        notes.append(f"the best candidate, {h.label}, removes only {100 * explained_share(res, chi2_fit)[0]:.0f} % "
                     "of the weighted misfit" + ("" if res.validation is None else
                                                 " and its rerun changes the FRF misfit only "
                                                 + ratio_text(res.validation.misfit_before,
                                                              res.validation.misfit_after))
                     + f", less than the {100 * policy.explained_share:.0f} % an explanation must account for: the "
                       "mismatch lies outside the library; nothing is selected")
        drop_selection(res, misfit_0, chi2_fit, outside=True)
    if res.selected is not None and not self_excited and res.location.extra:
        _keeps_new_resonance(res, problem, misfit_0, chi2_fit, notes)


def _keeps_new_resonance(res: DiagnosisResult, problem: Problem, misfit_0: float, chi2_fit: float,
                         notes: list) -> None:
    """Rule 9 for a resonance the nominal lab lacks (``res.location.extra``): the choice is *the* explanation
    only if its lab has that resonance too (:func:`vlab.diagnose.fit.locate.extra_resonances` of the chosen
    lab finds none left). The library's effects change the structure's masses, stiffnesses, damping and
    chain; they add no degree of freedom, so a measured resonance the chosen lab still lacks is physics
    outside the library, whatever share of the misfit the choice removes (a pair can absorb much of a
    tuned absorber's residual). The choice is then rejected and the resonance reported.

    Judged on the choice's validation rerun where it has one (:func:`~vlab.diagnose.fit.resonances.unpaired_peaks`
    of the FRFs the rerun was compared with against the rerun's): that is the chosen lab on the plant the
    recording is compared with, as recorded. Its linear lab is a weaker witness: referred to the recording
    through the nominal replay, it carries the FE model's change to the plant only to first order, which
    misplaces the peaks of a large change (an added mass and a soft joint that moved nine grid modes); and a
    nonlinear choice's (:data:`~vlab.diagnose.fit.rules.NONLINEAR`) is a describing function at one
    amplitude, without the peaks the nonlinearity itself puts into a measured FRF. Without a rerun, the
    linear lab (:func:`~vlab.diagnose.fit.locate.extra_resonances`)."""
    v = res.validation
    try:
        if v is not None and v.target is not None:
            d = problem.data
            left = unpaired_peaks(d.freq_hz, v.target, v.h_after, d.output_points, var=v.target_var,
                                  limit=resonance_limit(problem))
        else:
            left = extra_resonances(problem, res.selected_state())
    except (ModelError, SpecError):
        return
    if not left:
        return
    h = res.selected
    before, after, noise = _misfits(res, misfit_0)
    res.rejected.append(rejection(h, "leaves a resonance the model does not have", before, after, noise))
    where = ", ".join(f"{r['frequency_hz']:.4g} Hz at point {r['point']}" for r in left)
    notes.append(f"the best candidate, {h.label}, leaves a resonance its lab does not have ({where}): no effect "
                 "of the library adds a degree of freedom, so the mismatch lies outside the library; nothing is "
                 "selected")
    drop_selection(res, misfit_0, chi2_fit, outside=True)


def _largest_line(problem: Problem, r: np.ndarray) -> dict | None:
    """The line and channel of FRF data with the largest squared residual in ``r`` (shape (n_obs,))."""
    d = problem.data
    if not isinstance(d, FrfData):
        return None
    idx = np.argwhere(problem.mask)  # C order, as the residual's entries
    n = len(idx)
    r2 = r[:n] ** 2 + (r[n:2 * n] ** 2 if problem.use_phase and r.size >= 2 * n else 0.0)
    k = int(np.argmax(r2))
    line, ch = idx[k]
    return {"frequency_hz": float(d.freq_hz[line]), "point": int(d.output_points[ch]), "squared_residual": float(r2[k])}


def remainder_of(res: DiagnosisResult, problem: Problem, misfit_0: float) -> dict | None:
    """Rule 10: what the choice of ``res`` leaves, when it is beyond what the mismatch test allows.

    The same tests and covariance as the mismatch test (noise, floor and model form): the chosen lab --
    refitted on the MuJoCo plant's linearisation where it was, and judged there (:func:`_footing`) -- must
    leave the data within the total chi-square limit and the largest single line within its limit (with a
    model form carried: after its modes are moved within their model form, and those moves within their
    limit; :func:`vlab.diagnose.problem.nuisance.within_model_accuracy`); a lab that does not leaves a
    remainder. A test that declares the mismatch of the nominal lab judges the chosen lab too, so a choice
    that leaves one line beyond the limit the nominal lab was held to has not explained the data -- also
    where that line is the effect's own representation error (how a mass is attached: its offset and rotary
    inertia, at a lightly damped resonance), which is then reported for what it is: the model with the
    effect does not reproduce that line.
    Where a validation rerun was made, it must confirm the remainder on the same footing: its misfit resolved
    from what an exact model leaves (:func:`vlab.diagnose.fit.confirm.remainder_resolved`), or its largest
    line beyond the line limit (:func:`_rerun_remainder`). A choice with a nonlinear part is judged by its
    rerun alone -- its linear model is a describing function, whose error is not a remainder -- and what
    the rerun leaves beyond what an exact model leaves is reported with ``nonlinear_choice`` set: part of it
    may be the error of the choice's own value, fitted through that describing function, and part an
    effect the choice does not hold (a remainder is never dropped for being hard to attribute).

    Parameters
    ----------
    res : DiagnosisResult
        With a selected choice (else None is returned).
    problem : Problem
    misfit_0 : float
        The nominal lab's misfit on the linear model [decades].

    Returns
    -------
    dict or None
        ``misfit_decades`` (left by the choice: the rerun's, else the linear model's), ``noise_misfit_decades``
        (an exact model's; None when unknown), ``judged_on``, ``chi2`` and ``chi2_limit`` [1] and
        ``peak``/``peak_limit`` [1] of the chosen lab (of a nonlinear choice: its rerun's chi-square, no peak
        and no largest line; its modes and points placed by its describing-function model),
        ``rerun_peak``/``rerun_peak_limit`` [1] (the validation rerun's largest line and its limit; None
        without a rerun), ``modes`` (whose fit still disagrees), ``points``
        (where the sensitivity ranking puts the remainder), ``largest_line`` (``frequency_hz``, ``point``,
        ``squared_residual``), ``nonlinear_choice``; None when nothing is left beyond the limits.
    """
    if res.selected is None:
        return None
    v = res.validation
    nonlinear = any(p.effect in NONLINEAR for p in res.selected_parts)
    data_problem = problem  # the validation's statistics were computed on it
    problem, state = _footing(res, problem)
    r = problem.residual(state, test=True)
    if nonlinear:  # judged by its rerun alone (below): without one, nothing to judge
        inside = v is None
    else:  # the mismatch test's three tests, modes moved within their model form where it is carried
        inside = within_model_accuracy(problem, state)
    if inside:
        return None
    rerun_peak = None
    if v is not None:
        measure = _rerun_remainder(v, data_problem, nonlinear)
        if measure is None:
            return None
        after, noise, judged, rerun_peak = measure
    else:
        noise = None
        if isinstance(problem.data, FrfData):
            m = problem.mask
            noise = noise_misfit(problem.data.h[m], problem.data.var[m], problem.weight_mag[m])
        after, judged = res.misfit_selected, "the linear model"
    loc = locate(problem, state)
    # a nonlinear choice's statistics are its rerun's (chi-square on the fit's footing); its linear model, a
    # describing function, only places the remainder
    chi2, peak = (float(v.chi2_after), None) if nonlinear else (float(r @ r), problem.peak_of(r))
    return {"misfit_decades": float(after), "noise_misfit_decades": None if noise is None else float(noise),
            "misfit_nominal_decades": float(misfit_0), "judged_on": judged,
            "chi2": chi2, "chi2_limit": problem.noise_chi2(), "peak": peak,
            "peak_limit": problem.peak_limit(), "rerun_peak": rerun_peak,
            "rerun_peak_limit": None if rerun_peak is None else data_problem.peak_limit(),
            "modes": [m.mode for m in loc.modes if m.flagged],
            "points": list(loc.points), "largest_line": None if nonlinear else _largest_line(problem, r),
            "nonlinear_choice": nonlinear}


def _rerun_remainder(v, problem: Problem, nonlinear: bool) -> tuple[float, float | None, str, float | None] | None:
    """Whether a choice's validation rerun ``v`` confirms a remainder, on the data of ``problem`` (the
    problem the validation's statistics were computed on): the misfit it leaves [decades], the misfit an
    exact model leaves on the same measure [decades] (None where unknown), the words for it and the rerun's
    largest squared line residual [1] (None where not computed); None when the rerun confirms nothing.

    First the log magnitude's misfit, resolved from what an exact model leaves
    (:func:`vlab.diagnose.fit.confirm.remainder_resolved`). A choice judged by its rerun alone (``nonlinear``:
    its linear model is a describing function) on data fitted with their phase (``problem.use_phase``) is
    then judged on the phase too, the footing its fit used: a lag or a delay left out turns the phase more
    than the magnitude (:func:`vlab.diagnose.problem.misfits.complex_log_misfit`), against what an exact model
    leaves there, the noise's whole variance and the model form's in magnitude and phase
    (:func:`vlab.diagnose.problem.misfits.exact_phase_misfit`; ``sqrt(2)`` times the magnitude's where a
    validation does not carry it: for circular noise the log magnitude takes half the variance). Last the
    rerun's largest line (``v.peak_after``, the tests' relative-error form with the covariance of its
    chi-square) against the mismatch test's line limit (:meth:`Problem.peak_limit`): a remainder confined to
    a few lines adds little to a misfit over all of them, as a local mismatch adds little to the total
    chi-square (:meth:`Problem.peak`).
    """
    where = f"the validation rerun ({v.plant})"
    peak = getattr(v, "peak_after", float("nan"))
    peak = float(peak) if math.isfinite(peak) else None
    noise = float(v.noise_misfit) if math.isfinite(v.noise_misfit) else None
    if remainder_resolved(v.misfit_after, v.noise_misfit):
        return float(v.misfit_after), noise, where, peak
    if nonlinear and problem.use_phase and math.isfinite(v.phase_misfit_after):
        noise_phase = v.noise_phase_misfit
        noise_phase = noise_phase if math.isfinite(noise_phase) else math.sqrt(2.0) * v.noise_misfit
        if remainder_resolved(v.phase_misfit_after, noise_phase):
            return float(v.phase_misfit_after), float(noise_phase), where + ", magnitude and phase", peak
    if peak is not None and peak > problem.peak_limit():
        where += f", its largest line {peak:.3g} beyond the line limit {problem.peak_limit():.3g}"
        return float(v.misfit_after), noise, where, peak
    return None


def _footing(res: DiagnosisResult, problem: Problem) -> tuple[Problem, object]:
    """The problem and the lab on which the choice of ``res`` is judged: for a choice refitted on the MuJoCo
    plant's linearisation, that linearisation with the data referred to it (the footing of its refit's
    chi-square: the plant's value in the FE model carries the FE/plant difference of what the effect does);
    else ``problem`` and the chosen FE lab."""
    r = res.plant_refit
    if r is not None and r.plant_state is not None and r.plant_problem is not None:
        return r.plant_problem, r.plant_state
    return problem, (r.state if r is not None else res.selected_state())


def settle_remainder(res: DiagnosisResult, problem: Problem, *, chi2_fit: float, notes: list,
                     rerun=None) -> None:
    """Rule 10 on the choice of ``res`` (in place): test the remainder it leaves on the data of ``problem``
    (:func:`remainder_of`); keep it as ``res.remainder`` when the choice is identified (no look-alike within
    the policy's evidence) or nonlinear (its remainder may be its own value's error). A linear choice that
    leaves a remainder and has look-alikes gives way to the look-alike whose own validation rerun leaves none
    (:func:`separated_by_rerun`, with ``rerun``); failing that it is rejected -- the mismatch then lies outside
    the library -- and its look-alikes are named in ``notes``.

    Parameters
    ----------
    res : DiagnosisResult
    problem : Problem
    chi2_fit : float
        The nominal lab's chi-square on the fits' footing [1], for the location from the fits.
    notes : list of str
    rerun : callable ``(h) -> (Validation, PlantRefit or None) or None``, optional
        The validation rerun of a look-alike ``h`` on the plant the choice was validated on (its plant refit,
        where the choice has one); None: look-alikes are not rerun.
    """
    if res.selected is None:
        return
    rem = remainder_of(res, problem, res.misfit_nominal)
    if rem is None:
        return
    # a nonlinear choice's remainder may be its own value's error (fitted through a describing function): it is
    # reported, and does not by itself reject the choice
    if not res.alternatives or rem["nonlinear_choice"]:
        res.remainder = rem
        notes.append(_remainder_note(rem, problem))
        return
    if rerun is not None and res.validation is not None and separated_by_rerun(res, problem, rem, rerun, notes):
        return
    h = res.selected
    before, after, noise = _misfits(res, res.misfit_nominal)
    looks = [a.label for a in res.alternatives]
    res.rejected.append(rejection(h, "explains only part of the mismatch and is not separated from its look-alikes",
                                  before, after, noise, look_alikes=looks))
    notes.append(f"the best candidate, {h.label}, leaves a remainder ({_remainder_note(rem, problem)}) and these data "
                 f"cannot tell it from {len(looks)} look-alike(s) ({', '.join(looks[:4])}"
                 f"{', ...' if len(looks) > 4 else ''}): a fit biased by what is left and not separated from other "
                 "effects names nothing; the mismatch lies outside the library, nothing is selected")
    drop_selection(res, res.misfit_nominal, chi2_fit, outside=True)


def separated_by_rerun(res: DiagnosisResult, problem: Problem, rem: dict, rerun, notes: list) -> bool:
    """Rule 10's look-alikes by rerun: the choice of ``res`` leaves the remainder ``rem`` on its validation
    rerun; each linear single look-alike is rerun the same way (``rerun``, on the plant that made the
    recording, with its own refit there) and judged by the same test (:func:`remainder_of`). The linear fits
    could not tell these effects apart; the rerun carries what the linear models leave out (the plant's own
    shapes, discretisation and level dependence), so it may (it need not: a true effect refitted on the
    linearisation can leave a resolved rerun misfit of its own). Of the look-alikes that leave no remainder the one with the least
    rerun misfit replaces the choice (in place, ``True`` returned); the others that leave none stay its
    look-alikes (the rerun does not tell them apart either), those that leave a remainder are dropped. None
    leaves none: ``res`` is unchanged and ``False`` returned.

    Parameters
    ----------
    res : DiagnosisResult
        With a selected choice, its validation and look-alikes (``res.alternatives``).
    problem : Problem
    rem : dict
        The choice's remainder (:func:`remainder_of`).
    rerun : callable
        As in :func:`settle_remainder`; it may return None (no rerun possible for that effect).
    notes : list of str

    Returns
    -------
    bool
    """
    clean, tried = [], []
    for h in res.alternatives:
        if isinstance(h, Combination) or h.effect in NONLINEAR:
            continue
        out = rerun(h)
        if out is None:
            continue
        trial = copy.copy(res)
        trial.selected, trial.validation, trial.plant_refit, trial.misfit_selected = h, out[0], out[1], float(
            h.misfit_)
        tried.append(f"{h.label}: {out[0].misfit_after:.3g} decades")
        if remainder_of(trial, problem, res.misfit_nominal) is None:
            clean.append((out[0].misfit_after, h, out))
    if not tried:
        return False
    first = res.selected
    tail = (f"the best candidate, {first.label}, leaves a remainder on its validation rerun "
            f"({rem['misfit_decades']:.3g} decades, an exact model {rem['noise_misfit_decades'] or float('nan'):.3g});"
            f" its look-alikes rerun the same way leave {', '.join(tried)}")
    if not clean:
        notes.append(tail + ": each leaves a remainder too")
        return False
    clean.sort(key=lambda c: c[0])
    _, h, (v, refit) = clean[0]
    res.rejected.append(rejection(first, "leaves a remainder on its rerun that a look-alike does not leave",
                                  v.misfit_before, res.validation.misfit_after, res.validation.noise_misfit))
    res.selected, res.validation, res.plant_refit, res.misfit_selected = h, v, refit, float(h.misfit_)
    res.alternatives = [c[1] for c in clean[1:]]
    notes.append(tail + f": {h.label} leaves none and is selected"
                 + (f"; the rerun does not tell it from {', '.join(a.label for a in res.alternatives)}"
                    if res.alternatives else ""))
    return True


def _remainder_note(rem: dict, problem: Problem) -> str:
    """One sentence on a remainder (:func:`remainder_of`), in the data's misfit unit."""
    unit = "decades" if isinstance(problem.data, FrfData) else "(relative frequency error)"
    where = []
    if rem["modes"]:
        where.append("modes " + ", ".join(str(m) for m in rem["modes"]))
    if rem["points"]:
        where.append("points " + ", ".join(str(p) for p in rem["points"]))
    line = rem.get("largest_line")
    if line:
        where.append(f"largest at {line['frequency_hz']:.2f} Hz on the sensor at point {line['point']}")
    noise = rem["noise_misfit_decades"]
    exact = ""
    if noise is not None:  # resolved by the misfit, or only compared with it (a remainder on a few lines)
        resolved = remainder_resolved(rem["misfit_decades"], noise)
        exact = f"{', resolved from' if resolved else ' against'} the {noise:.3g} an exact model leaves"
    return (f"on {rem['judged_on']} the selected effect leaves a misfit of {rem['misfit_decades']:.3g} {unit}"
            + exact + (f" ({'; '.join(where)})" if where else "")
            + ("; the choice is nonlinear: part of this may be the error of its own value, fitted through a "
               "describing function" if rem.get("nonlinear_choice") else ""))
