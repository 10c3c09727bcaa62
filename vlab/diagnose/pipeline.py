"""``diagnose``: compare a recording with the nominal lab, locate the mismatch, explain it, validate.

The diagnosis runs in stages, each a function with its own input and output; every decision is made by
one policy (:class:`vlab.diagnose.policy.DecisionPolicy`, from the user's false-alarm rate):

1. **Reference** (:func:`vlab.diagnose.reading.read_inputs`): the data, the recording's own setup, the
   nominal lab (the spec's FE model with its open-loop damping, the controller that ran and the hardware
   chain; meshed as the MuJoCo plant resolves the structure when compared with it), and the reference the
   data are referred to the model through: a measured baseline, the nominal plant's replay of the recorded
   force, or the FE model alone.
2. **Problem** (:func:`_problem_of`): residuals of log FRFs (or modal parameters) with one covariance:
   the measured noise, the model-error floor and, for data of a real structure, the model's own
   uncertainty (:mod:`vlab.diagnose.model.modelform`).
3. **Mismatch test** (:func:`vlab.diagnose.decision.mismatch_tests`): the total chi-square, the largest
   line and the nominal modes' moves against the policy's limits (with a baseline of the same force
   record, once more without the floor); locate (:mod:`vlab.diagnose.fit.locate`). No test fails: "no
   significant mismatch" (or "within the model's accuracy"), nothing is fitted.
4. **Screen, fit, select, plant check** (:func:`vlab.diagnose.explain.explain`): the library screened,
   fitted and ranked by BIC, pairs where one effect leaves more than noise, the choice by evidence and
   the likelihood-ratio test, look-alikes by rerun, the cause of a self-excited oscillation, and a
   spec-level choice refitted on the MuJoCo plant's linearisation.
5. **Validate** (:func:`_validated`, :mod:`vlab.diagnose.validate`): the recorded force played back
   through the 2 kHz loop on the nominal and the modified plant; FRF and time-domain misfits.
   **5b. Value** (:func:`_on_structure`, :mod:`vlab.diagnose.fit.onstructure`; after the gates of 6): for a
   recording that names no vlab plant, the choice's value fitted again on the structure's own model, the data
   referred through its linear replay (the MuJoCo replay puts the plant's discretisation into a mode-moving
   parameter).
6. **Decide** (:func:`vlab.diagnose.decision.apply_gates`, :func:`vlab.diagnose.decision.remainder_of`):
   the choice stands only if its validation does not make the fit worse, it beats the nominal lab on its
   fit's footing (likelihood-ratio test) and explains the larger part of the mismatch; what it leaves beyond
   the mismatch test's limits is reported as a remainder.
7. **Report** (:mod:`vlab.diagnose.report.markdown`): the verdict is written from the result's own
   statistics, so that its numbers are the JSON's.
"""

from __future__ import annotations

import copy
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from ..errors import VlabError
from ..io.setup_file import read_setup
from ..measure.instability import find_instability
from ..spec import StructureSpec
from .data.measured import FrfData
from .data.reference import RERUN_SEED, referred_through_replay, with_level_dependence, with_replay_distortion
from .data.replay import LOW_LEVEL
from .data.run import DiagnosisRun, one_blas_thread
from .data.rerun_jobs import stop_background
from .decision import apply_gates, mismatch_tests, settle_remainder
from .detectability import frf_model_form_of, threshold_of
from .effects.hypotheses import Combination
from .explain import Search, explain
from .fit.locate import locate
from .fit.anchored import pair_on_anchor
from .fit.estimate import fit_hypothesis
from .fit.onstructure import converged_lab, fit_on_structure
from .fit.passing import parts_fitted
from .fit.plantfit import PlantModel
from .fit.rules import NONLINEAR, beyond_noise, changed_beyond_noise
from .fit.selection import CONTROLLER_PATH, located_from_fits, rerun_key
from .instability_cause import plant_own_oscillation
from .model.labmodel import LabState
from .policy import DecisionPolicy
from .problem.context import context_for
from .problem.nuisance import nuisance_test
from .problem.residuals import Problem
from .reading import Inputs, Options, read_inputs
from .report.result import DiagnosisResult
from .validate import validate

__all__ = ["diagnose", "DiagnosisResult"]


def _instability(check, replayed, loops) -> dict | None:
    """The recording's instability check for the result: its dict, whether the nominal
    plant's replay of the recorded force oscillates too (None without a replay; a nominal lab that is itself
    unstable with this controller is not a mismatch of the structure), and a one-sentence summary."""
    if check is None:
        return None
    out = check.as_dict()
    out["in_replay"] = None
    text = check.summary()
    if check.unstable and replayed is not None:
        again = find_instability(replayed, feedback_points=loops)
        f0 = check.frequency_hz
        out["in_replay"] = bool(again.unstable and any(abs(o.frequency_hz - f0) <= max(0.02 * f0, 2 * again.resolution_hz)
                                                      for o in again.oscillations))
        text += ("; the nominal plant's replay of the recorded force oscillates there too: the nominal lab is "
                 "unstable with this controller and chain" if out["in_replay"] else
                 "; the nominal plant's replay does not: the instability is part of the mismatch")
    out["summary"] = text
    return out


def _beyond_measurement(problem: Problem, nominal: LabState) -> bool:
    """Whether the nominal model differs from the data beyond the measurement's uncertainty alone (no floor,
    no model-form uncertainty): the data are then within the model's accuracy, not within the noise."""
    if isinstance(problem.data, FrfData):
        bare = Problem(problem.data, nominal, problem.ctx, floor=0.0, use_phase=problem.use_phase,
                       policy=problem.policy)
    else:
        bare = Problem(problem.data, nominal, problem.ctx, modal_model_form=False, policy=problem.policy)
    return beyond_noise(bare.chi2(nominal, test=True), bare.noise_chi2(), bare.peak(nominal, test=True),
                        bare.peak_limit())


def _problem_of(inp: Inputs, *, floor: float, model_form: str, baseline, policy: DecisionPolicy,
                notes: list) -> Problem:
    """Stage 2: the residuals of ``inp``'s data against its nominal lab, with one covariance (noise, floor and,
    where asked or where the data are of a real structure, the model form; ``model_form`` "auto": none for a
    recording whose metadata names the vlab plant that made it, when it is compared with that plant -- replayed
    there, or the linear FE plant's compared with the FE model -- and for a measured baseline; FRFs of the MuJoCo
    plant compared with the FE model carry the plant's model-form difference)."""
    data, nominal = inp.data, inp.nominal
    ctx = context_for(nominal, inp.band_hz, data)
    made_by_vlab = _made_by_vlab(inp)
    mf_mode = model_form
    if model_form == "auto":
        mf_mode = "none" if (made_by_vlab or baseline is not None) else "derived"
    mf, mf_frf, low_replay = None, None, None
    if isinstance(data, FrfData) and mf_mode == "derived" and inp.replayed is not None \
            and inp.replay_plant == "mujoco":
        data, low_replay = _with_plant_distortion(inp, notes)
    if isinstance(data, FrfData) and mf_mode == "derived":
        mf, mf_frf = frf_model_form_of(nominal, data, inp.replay_plant if inp.replayed is not None else None, notes)
        used = [x for lab, x in zip(mf_frf.labels, mf_frf.sigma) if lab.startswith("f")]  # the modes the FRFs feel
        notes.append(f"compared within the model's own uncertainty: {mf.describe(used)}")
    elif isinstance(data, FrfData):
        why = ("the recording's metadata names the vlab plant that made it" if made_by_vlab and
               model_form == "auto" else "a measured baseline of the same structure" if model_form == "auto"
               else "as asked")
        notes.append(f"no model-form uncertainty ({why}): only the noise and the {100 * floor:g} % floor")
    run = DiagnosisRun()
    if inp.replayed is not None:  # the validation's nominal reruns are the replays
        run.reruns[("nominal", inp.replay_plant, RERUN_SEED)] = inp.replayed
        if low_replay is not None:
            run.reruns[("nominal@level", inp.replay_plant, RERUN_SEED)] = low_replay
    problem = Problem(data, nominal, ctx, floor=floor, model_form_frf=mf_frf, modal_model_form=mf_mode != "none",
                      profile_nominal=True, policy=policy, run=run, guard_s=inp.guard_s,
                      replay_plant=inp.replay_plant if inp.replayed is not None else None)
    if mf is not None:
        problem.model_form = mf
    return problem


def _with_plant_distortion(inp: Inputs, notes: list) -> tuple[FrfData, object]:
    """``inp.data`` with the MuJoCo replay's own level dependence in its variance
    (:func:`vlab.diagnose.data.reference.with_replay_distortion`), and the replay at the low level (None, with
    the data unchanged and a note, where that replay fails)."""
    try:
        data, largest, low = with_replay_distortion(inp.data, inp.nominal, inp.replay_plant, guard_s=inp.guard_s)
    except (VlabError, ImportError) as exc:
        notes.append(f"the replay at {LOW_LEVEL:g} x the level failed ({exc}): the replay's own level dependence "
                     "is not in the comparison's variance")
        return inp.data, None
    notes.append(f"the replay plant's own level dependence (its FRFs at the recorded level against "
                 f"{LOW_LEVEL:g} x it: a relative change up to {largest:.2g}) counted as the reference's "
                 "uncertainty, since whether the structure shares it is not known")
    return data, low


def _validated(res: DiagnosisResult, problem: Problem, plant: str, notes: list, timing: dict, say,
               loops=()) -> None:
    """Stage 5: rerun the recorded force through the loop on the lab with the choice of ``res`` (its plant refit
    on the MuJoCo plant; a linear rerun takes the FE value) and set ``res.validation``; a rerun that cannot
    be made is noted. A MuJoCo rerun that oscillates by itself above the data's band where the recording
    does not and the choice's linear loop is stable
    (:func:`vlab.diagnose.instability_cause.plant_own_oscillation`) is made again on the linear FE plant, and
    the note says why."""
    modified, key = res.selected_state(), rerun_key(res.selected)
    if res.plant_refit is not None:
        modified, key = res.plant_refit.state, key + "@plant"
    say("validating")
    t = time.perf_counter()

    def on_linear_plant() -> None:  # the plant's value belongs to the plant: a linear rerun takes the FE value
        res.plant_refit = None
        res.validation = validate(problem, res.nominal, res.selected_state(), plant="linear", spec_level=False,
                                  seed=RERUN_SEED, key=rerun_key(res.selected))

    try:
        res.validation = validate(problem, res.nominal, modified, plant=plant, spec_level=res.selected.spec_level,
                                  seed=RERUN_SEED, key=key)
        if res.plant_refit is not None and not res.validation.plant.startswith("MuJoCo"):
            on_linear_plant()
        data = problem.data
        f_own = None if (res.instability or {}).get("unstable") or not res.validation.plant.startswith("MuJoCo") \
            else plant_own_oscillation(res.validation, data.recording, data.excitation_point, loops,
                                       res.selected_state(), float(max(data.freq_hz)))
        if f_own is not None:
            notes.append(f"the MuJoCo rerun with {res.selected.label} oscillates by itself at {f_own:.4g} Hz, the "
                         "recording does not, and the effect's linear loop is stable: the plant's own modes (above "
                         "the band it keeps only their light hinge damping) are what the effect destabilises "
                         "there; validated on the linear FE plant instead")
            on_linear_plant()
    except (VlabError, ImportError) as exc:
        notes.append(f"validation rerun not possible: {exc}")
    timing["validate"] = time.perf_counter() - t


def _lookalike_rerun(res: DiagnosisResult, problem: Problem, plant: str, chain: bool, notes: list):
    """The validation rerun of a look-alike ``h`` of the choice of ``res``, as :func:`_validated` made the
    choice's: on the plant its validation ran on, refitted first on the MuJoCo plant's linearisation where the
    choice was (``chain``: a chain effect is refitted there too). Returns ``rerun(h) -> (Validation, PlantRefit
    or None) or None`` (None: no refit or no rerun possible for ``h``; the reason is noted)."""
    on = plant if res.validation is None or res.validation.plant.startswith("MuJoCo") else "linear"
    model = []

    def rerun(h):
        try:
            refit = None
            if res.plant_refit is not None and on != "linear":
                if not model:
                    model.append(PlantModel(problem, chain_refit=chain))
                refit = model[0].refit(h, h.params_)
                if refit is None:
                    return None
            state = refit.state if refit is not None else problem.fitted_state(h)
            key = rerun_key(h) + ("@plant" if refit is not None else "")
            return validate(problem, res.nominal, state, plant=on, spec_level=h.spec_level, seed=RERUN_SEED,
                            key=key), refit
        except (VlabError, ImportError) as exc:
            notes.append(f"the look-alike {h.label} could not be rerun: {exc}")
            return None
    return rerun


def _source_named(inp: Inputs) -> bool:
    """The recording's metadata names the vlab plant that made it."""
    return isinstance(inp.metadata.get("plant"), str) and inp.metadata.get("plant") != ""


def _made_by_vlab(inp: Inputs) -> bool:
    """The recording names the vlab plant that made it and is compared with that plant (replayed there, or
    the linear FE plant's compared with the FE model, or FRFs referred through the plant's linearisation)."""
    return _source_named(inp) and (inp.replayed is not None or inp.replay_plant == "linear"
                                   or inp.on_recording_plant)


def _structure_problem(res: DiagnosisResult, inp: Inputs, problem: Problem, notes: list, timing: dict,
                       say) -> tuple[Problem, str] | None:
    """The structure's own problem for stage 5a/5b: for a recording that names no vlab plant and was referred
    through the MuJoCo plant's replay, its data referred through the FE model's own linear replay, the mesh
    converged (:func:`vlab.diagnose.fit.onstructure.converged_lab`), with the MuJoCo replay's level dependence
    in their variance as on the plant's footing; the model form the diagnosis used, taken
    for that model's modes (:mod:`vlab.diagnose.fit.onstructure`: the MuJoCo referral puts the plant's
    discretisation into every mode-moving parameter), with what the data were referred through, in words.
    None when there is no choice or no such recording, or it cannot be built (a note says why)."""
    if res.selected is None or not inp.on_plant or inp.unreferred is None or _source_named(inp):
        return None
    say("referring the recording to the structure's own model")
    t = time.perf_counter()
    raw = inp.unreferred
    lab = replace(inp.nominal, spec=inp.spec, fe=inp.fe, point_modes=None)  # the structure file's own spec
    try:
        # the referral H_model / H_replay corrects the loop's and the estimator's effects, which the file's
        # mesh carries as well as a finer one (and replays many times faster): it is taken there
        data, _replay, kind = referred_through_replay(raw, lab, "linear", guard_s=inp.guard_s)
        rel = problem.data.var_distortion if isinstance(problem.data, FrfData) else None
        if rel is not None and np.shape(rel) == data.h.shape:
            # whether the structure shares the plant's level dependence is not known: the variance the plant's
            # footing gives it is counted here too, though this replay is linear
            data = with_level_dependence(data, rel, on_baseline=False)
        sigma = float(np.min(problem.model_form.frequency_rel)) if problem.model_form is not None else 0.0
        lab, factor, change = converged_lab(lab, inp.band_hz, sigma) if sigma > 0 else (lab, 1, float("nan"))
        mf, mf_frf = frf_model_form_of(lab, data, "linear") if problem.model_form_frf is not None else (None, None)
        on_fe = Problem(data, lab, context_for(lab, inp.band_hz, data), floor=problem.floor, model_form_frf=mf_frf,
                        modal_model_form=problem.modal_model_form, profile_nominal=True, policy=problem.policy)
    except (VlabError, ImportError, ValueError, np.linalg.LinAlgError) as exc:
        notes.append(f"the recording could not be referred to the structure's own model ({exc}): the value is the "
                     "one fitted through the MuJoCo plant's replay")
        return None
    on_fe.model_form = mf
    if factor > 1:
        notes.append(f"the structure's own model: its mesh refined {factor} x (the modes in the band then move by "
                     f"{100 * change:.2g} % at most from one refinement to the next)")
    timing["structure_problem"] = time.perf_counter() - t
    return on_fe, f"its own replay of the recorded force ({kind})"


def _pair_on_structure(res: DiagnosisResult, problem: Problem, on_fe: Problem, on_plant: bool, notes: list,
                       timing: dict, say) -> None:
    """Stage 5a: a chosen pair judged on the structure's own problem ``on_fe`` with the model form anchored at
    its better part (:func:`vlab.diagnose.fit.anchored.pair_on_anchor`; not a pair with a nonlinear part, which
    the reruns judge); where its second effect is not needed
    there, that part alone is the choice (its fit on ``problem``, refitted on the MuJoCo plant where it
    edits the spec): a second effect needed only where one mode's model-form error has moved away from the
    nominal covariance, or only on the plant's discretisation, is a passenger."""
    pair = res.selected
    say("judging the pair on the structure's own model")
    t = time.perf_counter()
    try:
        judged = pair_on_anchor(pair, on_fe)
    except (VlabError, ValueError, np.linalg.LinAlgError) as exc:
        notes.append(f"the pair could not be judged on the structure's own model ({exc})")
        return
    notes.append(judged.describe(pair.label) + " (on the structure's own model)")
    timing["pair_on_structure"] = time.perf_counter() - t
    if judged.keep:
        return
    # the part's best fit alone on ``problem`` (from its trials and from its value in the pair, as judged)
    part = next((h for h in parts_fitted(problem, pair, res.ranked) if h.label == judged.part.label), None)
    if part is None:
        part = fit_hypothesis(copy.deepcopy(judged.part), problem)
    _reselect(res, problem, part, notes, refit_on_plant=on_plant)


def _reselect(res: DiagnosisResult, problem: Problem, h, notes: list, *, refit_on_plant: bool) -> None:
    """Make the fitted hypothesis ``h`` the choice of ``res`` after stage 5 (in place): no look-alikes, its
    misfit, the loop a chain effect sits in, its plant refit (a spec-level single effect refitted on the MuJoCo
    plant's linearisation with ``refit_on_plant``, else none) and its detection threshold."""
    res.selected, res.alternatives, res.misfit_selected = h, [], float(h.misfit_)
    if res.loop == "both" and h.effect in CONTROLLER_PATH:  # as the choice's loop is set in stage 4
        res.loop = "closed"
    res.plant_refit = None
    if refit_on_plant and h.spec_level and not isinstance(h, Combination):
        try:
            res.plant_refit = PlantModel(problem).refit(h, h.params_)
        except (VlabError, ImportError) as exc:
            notes.append(f"{h.label} could not be refitted on the MuJoCo plant's linearisation: {exc}")
    thr = threshold_of(problem, res.nominal, problem.ctx, h)
    res.threshold = None if thr is None else thr.as_dict()


def _plant_override_on_structure(res: DiagnosisResult, problem: Problem, on_fe: Problem, notes: list) -> None:
    """Rule 5 on a recording no vlab plant made: the MuJoCo plant's linearisation replaced the FE model's choice
    (``res.fe_choice``), but that plant is a model of the structure too, with its own discretisation (a hinge
    chain cannot make a segment fifty times softer). Both choices are fitted on the structure's own problem
    ``on_fe``; the FE model's is restored where it passes the mismatch test's total chi-square there and the
    plant's does not -- the data reject the plant's choice on the structure's own model
    (:class:`vlab.diagnose.fit.onstructure.StructureFit`'s adequacy, for the kind and place). Sets
    ``res.selected`` (its alternatives cleared, the plant refit dropped) and a note."""
    plant_choice, fe_choice = res.selected, res.fe_choice
    if plant_choice is None or fe_choice is None:
        return
    try:
        fits = [fit_hypothesis(copy.deepcopy(h), on_fe) for h in (plant_choice, fe_choice)]
    except (VlabError, ValueError, np.linalg.LinAlgError) as exc:
        notes.append(f"the plant's choice could not be checked on the structure's own model ({exc})")
        return
    limit = on_fe.noise_chi2()
    (c_plant, c_fe) = (float(g.chi2_) for g in fits)
    if not (c_fe <= limit < c_plant):
        return
    notes.append(f"on the structure's own model {fe_choice.label}, the FE model's choice, leaves chi-square "
                 f"{c_fe:.4g}, within the mismatch test's limit {limit:.4g}, and {plant_choice.label}, which the MuJoCo "
                 f"plant's linearisation preferred, {c_plant:.4g}: the recording is not the plant's, whose "
                 f"discretisation decided there; {fe_choice.label} is restored")
    res.fe_choice = None
    _reselect(res, problem, fe_choice, notes, refit_on_plant=False)


def _on_structure(res: DiagnosisResult, structure: tuple[Problem, str] | None, notes: list, timing: dict,
                  say) -> None:
    """Stage 5b: the choice's value fitted again on the structure's own problem and set as
    ``res.structure_fit`` (``structure``: what :func:`_structure_problem` returned)."""
    if res.selected is None or structure is None:
        return
    say("fitting the value on the structure's own model")
    t = time.perf_counter()
    res.structure_fit = fit_on_structure(structure[0], res.selected, structure[1])
    if res.structure_fit is not None and res.structure_value_stands():
        notes.append("the recording names no vlab plant: the value is fitted on the structure's own model (the FE "
                     "model of the structure file, its mesh converged, the data referred through its own linear "
                     "replay, the model form anchored at the fitted lab's modes), where no simulator's "
                     "discretisation enters it; its 95 % interval spans the value fitted through the MuJoCo "
                     f"plant's replay (plant_fit); the value maximises the {res.structure_fit.likelihood}")
    elif res.structure_fit is not None:
        sf, refit = res.structure_fit, res.plant_refit
        least = sf.chi2 if sf.chi2_least is None else min(sf.chi2, sf.chi2_least)
        notes.append(f"the recording names no vlab plant, and the structure's own model, fitted to it, leaves "
                     f"chi-square {least:.4g}, beyond the mismatch test's limit {sf.chi2_limit:.4g} there, where the "
                     f"MuJoCo plant's linearisation with its refitted value leaves {refit.chi2:.4g}, within "
                     f"{refit.plant_problem.noise_chi2():.4g}: the data reject the structure's model, so the answer "
                     "is the plant's value, its interval widened to hold the structure's (structure_fit)")
    else:
        notes.append("the value could not be fitted on the structure's own model (the fit failed or did not beat "
                     "the nominal model there): it is the one fitted through the MuJoCo plant's replay")
    timing["structure_fit"] = time.perf_counter() - t


def _tested(inp: Inputs, problem: Problem, notes: list, timing: dict, say) -> DiagnosisResult:
    """Stage 3: the mismatch tests and the location; the result with what they found."""
    nominal = inp.nominal
    chi2_0, peak_0 = problem.chi2(nominal, test=True), problem.peak(nominal, test=True)
    # the hypotheses are scored on the fits' footing (the log ratio, linearly whitened): the nominal model is
    # compared with them on it; its test statistic (chi2_0: the relative error, profiled) decides whether there
    # is a mismatch at all
    chi2_fit = problem.chi2(nominal)
    limit, peak_limit = problem.noise_chi2(), problem.peak_limit()
    misfit_0 = problem.misfit(nominal)
    say("locating")
    t = time.perf_counter()
    location = locate(problem, nominal)
    timing["locate"] = time.perf_counter() - t
    nuisance = nuisance_test(problem)
    osc = _instability(inp.instability, inp.replayed, inp.loops)
    tests = mismatch_tests(chi2_0, limit, peak_0, peak_limit, nuisance, oscillation=osc)
    noise_only = None
    if not tests and inp.same_record:  # within the floor; within the noise?
        changed, stats = changed_beyond_noise(problem, nominal)
        if changed:
            noise_only = stats
            tests = mismatch_tests(chi2_0, limit, peak_0, peak_limit, nuisance, stats, oscillation=osc)
            notes.append(f"the recording differs from its reference beyond the noise (chi-square "
                         f"{stats['chi2']:.4g}, limit {stats['chi2_limit']:.4g}; largest line {stats['peak']:.3g}, "
                         f"limit {stats['peak_limit']:.3g}), though within the model-error floor of "
                         f"{100 * problem.floor:g} % a line: a small change")
    res = DiagnosisResult(inp.spec.name, inp.controller, inp.data, problem, nominal, bool(tests), chi2_0, limit,
                          location, None, notes=notes, chi2_fit=chi2_fit, misfit_nominal=misfit_0,
                          misfit_selected=misfit_0, peak_nominal=peak_0, peak_limit=peak_limit,
                          noise_only=noise_only, reference=inp.reference,
                          instability=osc, mismatch_tests=tests)
    if not res.mismatch:
        res.location.points, res.location.members = [], []
        res.within_model_accuracy = _beyond_measurement(problem, nominal)
        notes.append("the nominal model agrees with the data within the model's own accuracy, though not "
                     "within the measurement's noise alone: no effect is proposed" if res.within_model_accuracy
                     else "the nominal model agrees with the data within the measured noise: no effect is "
                          "proposed")
    return res


def diagnose(structure: str | StructureSpec | None, recording_path: str | Path, *, controller: str | None = None,
             out_dir: str | Path | None = None, plant: str = "auto", resolution_hz: float | None = None,
             seed: int | None = None, effects: tuple[str, ...] | None = None, floor: float = 0.005,
             shortlist: int = 10, pairs: bool = True, validate_run: bool = True, overwrite: bool = True,
             progress=None, baseline: str | Path | None = None, replay: bool = True,
             force: bool = False, mjcf: str | Path | None = None,
             reference_column: str | None = None, model_form: str = "auto",
             false_alarm_rate: float = 0.01, confirm=None, test=None, estimator: str = "auto",
             log_freq: bool = False, design: str | Path | None = None) -> DiagnosisResult:
    """Diagnose a recording against the nominal laboratory (``vlab diagnose``).

    Parameters
    ----------
    structure : str, StructureSpec or None
        The structure: a shipped one's name, a structure file, or a spec (tests and benchmarks); None: the
        structure ``test`` names.
    recording_path : str or Path
        UFF 58 time histories (force + velocities, as ``vlab experiment``
        writes them, or from an acquisition system), CSV time histories, UFF 58 FRFs, or a CSV modal table.
    estimator : {"auto", "periodic", "h1", "transient"}
        How the FRFs of time histories are estimated (:func:`vlab.diagnose.data.frfestimate.choose_estimator`:
        "transient" for an impact hammer or burst random, one record per event).
    test : str, Path or RecordingSetup, optional
        The test that made the recording, a ``test.toml`` (:func:`vlab.io.setup_file.read_setup`): what a
        recording without vlab's sidecar leaves unsaid (controller, chain, excitation point and period, node
        map, sensors); see :class:`~vlab.diagnose.reading.Options`.
    controller, plant, resolution_hz, seed, baseline, replay, force, mjcf, reference_column, model_form, validate_run, design
        What was recorded, what it is compared with and whether it is rerun: each as the attribute of the
        same name of :class:`~vlab.diagnose.reading.Options` (defaults as there).
    out_dir : str or Path, optional
        Folder for ``diagnosis.md``, ``diagnosis.json`` and figures.
    effects : tuple of str, optional
        Restrict the library to these effect names.
    floor : float
        Relative model error allowed on FRFs (0.5 %).
    shortlist : int
        Number of screened hypotheses fitted in full (plus the best of each effect).
    pairs : bool
        Consider pairs of effects when no single one explains the data.
    overwrite : bool
        Replace existing report files in ``out_dir``.
    log_freq : bool
        Draw the report's FRF overlays on a logarithmic frequency axis (default linear).
    progress : callable, optional
        Called with a short string at each stage.
    false_alarm_rate : float
        The probability [1], in (0, 0.5), of reporting a mismatch on data of the nominal structure; every
        threshold of the decision follows from it (:class:`vlab.diagnose.policy.DecisionPolicy`).
    confirm : callable, optional
        Called with the run's estimate (:func:`vlab.diagnose.cost.estimate_diagnosis`) once the data are read,
        before the first simulation; what it raises stops the run (see :class:`~vlab.diagnose.reading.Options`).

    Returns
    -------
    DiagnosisResult

    Raises
    ------
    DataFileError
        Missing, malformed or truncated file; unknown point ids; a recording
        of another structure; mismatched sample rates or lengths (names the
        file and channel).
    MeasurementError
        NaN, clipped or dead channels; a record too short for the resolution.
    ModelError
        Unknown controller or effect name.
    OptionError
        ``controller``, ``seed`` or ``plant`` contradicts the recording's metadata (without ``force``), or the
        test setup does; ``structure`` contradicts the test setup's, or neither names one; ``mjcf`` with the
        linear plant; ``false_alarm_rate`` outside (0, 0.5).
    SpecError
        Unknown structure; a test setup's field of the wrong type or an unknown one (names the file and field).
    """
    policy = DecisionPolicy(false_alarm_rate=false_alarm_rate)  # checked before any work
    opt = Options(controller=controller, plant=plant, resolution_hz=resolution_hz, seed=seed, baseline=baseline,
                  replay=replay, force=force, mjcf=mjcf, reference_column=reference_column, model_form=model_form,
                  validate_run=validate_run, confirm=confirm,
                  test=read_setup(test) if isinstance(test, (str, Path)) else test, estimator=estimator,
                  design=design)
    search = Search(effects, shortlist, pairs, validate_run, False, False, ())
    with one_blas_thread():
        res = _run(structure, recording_path, opt, search, floor=floor, policy=policy, progress=progress)
    if out_dir is not None:
        from .report.figures import figures_for
        from .report.markdown import write_report

        (progress or (lambda s: None))("writing the report")
        res.files = write_report(out_dir, res.as_dict(), figures_for(res, log_freq=log_freq), overwrite=overwrite)
    return res


def _run(structure, recording_path, opt: Options, how: Search, *, floor: float, policy: DecisionPolicy,
         progress) -> DiagnosisResult:
    """Stages 1-6 of :func:`diagnose` (``how``: the search options; its plant, oscillation and loops are set
    here from the inputs)."""
    t_start = time.perf_counter()
    say = progress or (lambda s: None)
    model_form, baseline, validate_run = opt.model_form, opt.baseline, opt.validate_run
    inp = read_inputs(structure, recording_path, opt, say)
    timing = dict(inp.timing_s)
    notes = list(inp.notes)
    problem = _problem_of(inp, floor=floor, model_form=model_form, baseline=baseline, policy=policy, notes=notes)
    if isinstance(inp.data, FrfData):  # its variance may carry the replay plant's level dependence (a modal
        inp = replace(inp, data=problem.data)  # table's problem holds it referred; the report keeps it as read)
    try:
        res = _tested(inp, problem, notes, timing, say)
        osc = res.instability or {}
        self_excited = bool(osc.get("unstable") and osc.get("in_replay") is False)  # part of the mismatch
        if res.mismatch:
            search = replace(how, on_plant=inp.on_plant, self_excited=self_excited, loops=inp.loops,
                             plant_made=inp.on_plant and _made_by_vlab(inp))
            explain(res, problem, problem.ctx, search, chi2_fit=res.chi2_fit, noise_only=res.noise_only, notes=notes,
                    timing=timing, say=say)
            res.location.points, res.location.members = located_from_fits(res, res.chi2_fit)
            # no candidate reproduced the oscillation: the FRF choice is judged as any other, the oscillation left
            self_excited = self_excited and not osc.get("unexplained")
        structure = None if self_excited else _structure_problem(res, inp, problem, notes, timing, say)
        if structure is not None and res.fe_choice is not None:
            _plant_override_on_structure(res, problem, structure[0], notes)
        if structure is not None and isinstance(res.selected, Combination) and \
                not any(p.effect in NONLINEAR for p in res.selected.parts):  # a nonlinear pair: judged by rerun
            _pair_on_structure(res, problem, structure[0], inp.on_plant, notes, timing, say)
        if res.selected is not None and validate_run and isinstance(inp.data, FrfData) \
                and inp.data.recording is not None and res.validation is None:
            _validated(res, problem, inp.plant, notes, timing, say, inp.loops)
        apply_gates(res, problem, chi2_fit=res.chi2_fit, misfit_0=res.misfit_nominal, self_excited=self_excited,
                    notes=notes)
        if res.selected is not None and not self_excited:
            say("testing the remainder")
            t = time.perf_counter()
            first = res.selected
            settle_remainder(res, problem, chi2_fit=res.chi2_fit, notes=notes,
                             rerun=_lookalike_rerun(res, problem, inp.plant, inp.on_plant and _made_by_vlab(inp),
                                                    notes))
            if res.selected is not None and res.selected is not first:  # a look-alike separated by its rerun
                thr = threshold_of(problem, res.nominal, problem.ctx, res.selected)
                res.threshold = None if thr is None else thr.as_dict()
                if problem.ctx.closed_loop:
                    res.loop = "closed" if all(p.effect in CONTROLLER_PATH for p in res.selected_parts) else "both"
            timing["remainder"] = time.perf_counter() - t
            _on_structure(res, structure, notes, timing, say)
    finally:
        stop_background(problem)  # a background rerun never asked for
    timing["total"] = time.perf_counter() - t_start
    res.timing_s = timing
    return res
