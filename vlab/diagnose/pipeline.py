"""``diagnose``: compare a recording with the nominal lab, locate the mismatch, explain it, validate.

Pipeline:

1. **Predict** the nominal lab for the same excitation and controller: the
   spec's FE model with its open-loop damping, the thesis controller
   (:func:`vlab.design.design_controller`, same seed as the experiment) and
   the nominal hardware chain, in the frequency domain
   (:func:`vlab.diagnose.model.labmodel.predict_frf`). A recording diagnosed
   against the MuJoCo plant is compared with the FE model meshed as that
   plant resolves the structure (:func:`vlab.diagnose.model.nominal.plant_resolution`),
   the controller staying the one designed on the spec's own mesh.
2. **Decide** whether there is a mismatch: the weighted chi-square of the
   nominal model against the data must exceed what the measured noise
   explains (:meth:`Problem.noise_chi2`), or one line of one channel must
   stand out of the noise (:meth:`Problem.peak_limit`: a local mismatch,
   such as one shifted resonance of a top-beam segment, that adds little
   to the total). With a baseline, data within those limits are tested once
   more without the model-error floor (:func:`vlab.diagnose.fit.rules.changed_beyond_noise`:
   the nominal model's residual is then the recorded change itself, which
   only the two recordings' noise can hide). Otherwise the answer is "no
   significant mismatch" and no effect is proposed.
3. **Locate** (:mod:`vlab.diagnose.fit.locate`): modes, sensors, band, loop and,
   by sensitivity-based localisation, points and members.
4. **Explain**: every hypothesis of the library that can show in these data
   is screened at a few sizes (a mode-moving one at a dozen, which also
   gives its smoothed error, :func:`vlab.diagnose.fit.estimate.trials_for`); the best
   by chi-square and the best mode-moving ones by smoothed error are fitted by least squares
   (:mod:`vlab.diagnose.fit.estimate`) and ranked by BIC; when the best single effect
   leaves more than noise, pairs are fitted too: a second effect on top of
   the best single one (forward selection), then each part of the best pair
   re-chosen with the other held (sequential replacement). An
   effect is selected only if it lowers the BIC by 10 or more (strong
   evidence), a pair only if it beats the best single effect by 10
   (every rule of the selection, in order: :mod:`vlab.diagnose.fit.rules`).
   Look-alikes only a rerun separates (a saturation and a gain, friction
   and a dashpot) are compared by the time-domain error of reruns, and a
   pair with a nonlinear part is kept only if its rerun beats that part's
   alone (:func:`vlab.diagnose.fit.selection.tie_break_by_rerun`; on the MuJoCo
   plant when the recording is diagnosed against it).
5. **Validate** (:mod:`vlab.diagnose.validate`): the recorded force is played
   back through the 2 kHz loop on the nominal and on the modified plant (the
   nominal MuJoCo rerun starts in a background process as soon as a
   mismatch is found, while the hypotheses are fitted); before a MuJoCo
   rerun, the parameter of a mode-moving effect is refitted on the plant's
   own linearisation (:mod:`vlab.diagnose.fit.plantfit`), since the FE fit
   absorbs the FE/MuJoCo frequency offsets (look-alikes the FE fit cannot
   tell apart, and fits it orders by less than the FE/plant difference
   measured on the chosen effect, are scored there too, and the best on the
   plant is chosen;
   a single effect that still leaves more than noise there gets a second
   effect searched on the data referred through it, :mod:`vlab.diagnose.fit.plantpair`);
   FRF and time-domain misfits before and after. An effect that removes
   less than half of the weighted misfit, whose rerun does not halve
   the FRF misfit either, and that does not bring the data within the
   noise (both tests of step 2; all without the model-error floor when the
   mismatch was found only without it), is not selected (the mismatch is reported
   as not explained by the library).
6. **Report** (:mod:`vlab.diagnose.report.markdown`).
"""

from __future__ import annotations

import importlib.util
import time
from pathlib import Path

import numpy as np

from ..errors import DataFileError, ModelError, OptionError, VlabError
from ..fe import build_fe_model
from ..lab.experiment import test_definition
from ..measure.instability import find_instability
from ..spec import StructureSpec, load_spec
from .data.measured import FrfData, detect_kind, read_data, read_modal_csv, read_uff_any, refer_to_model
from .data.reference import RERUN_SEED, recorded_chain, recorded_setup, replay_reference, shares_excitation_record
from .data.replay import start_background_rerun, stop_background
from .data.warmstart import GUARD_DECAY
from .effects.hypotheses import Combination, Hypothesis, library
from .detectability import frf_model_form_of, threshold_of
from .fit.estimate import fit_hypothesis, fit_pairs, rank, screen, trials_for
from .fit.locate import locate
from .fit.plantchoice import choose_on_plant, reduce_pair_on_plant
from .fit.plantfit import PlantModel
from .fit.plantpair import second_effect_on_plant
from .fit.rules import (beyond_noise, changed_beyond_noise, needs_pairs, needs_rerun_check, prune, select,
                        shortlisted, too_small_to_name)
from .fit.selection import CONTROLLER_PATH, data_has_signals, located_from_fits, rerun_key, tie_break_by_rerun
from .instability_cause import search_cause
from .model.labmodel import LabState, predict_frf
from .model.nominal import PLANT_RESOLUTION_ELEMENTS, nominal_design, plant_resolution, settling_time
from .problem.context import context_for
from .problem.residuals import Problem
from .report.result import DiagnosisResult
from .validate import validate
from .decision import apply_gates, mismatch_tests, remainder_of
from .policy import DecisionPolicy

__all__ = ["diagnose", "DiagnosisResult"]


def _refit_on_plant(res: DiagnosisResult, problem: Problem, chosen: Hypothesis, notes: list,
                    pool: list[Hypothesis]) -> Hypothesis:
    """Refit the chosen effect on the MuJoCo plant's linearisation (:mod:`vlab.diagnose.fit.plantfit`); a pair
    is first checked there (:func:`reduce_pair_on_plant`), a single effect is compared there with its
    look-alikes and the fits of ``res.ranked`` the FE model orders by less than its difference from the plant
    (:func:`choose_on_plant`) and, when it leaves more than noise there, a second effect from
    ``pool`` is searched next to it (:func:`vlab.diagnose.fit.plantpair.second_effect_on_plant`). Sets
    ``res.plant_refit`` (and ``res.alternatives``); returns the choice."""
    try:
        model = PlantModel(problem)
    except (VlabError, ImportError) as exc:
        notes.append(f"the MuJoCo plant could not be linearised for a refit: {exc}")
        return chosen
    if isinstance(chosen, Combination):
        reduced, res.plant_refit, note = reduce_pair_on_plant(model, chosen, res.ranked)
        if note is not None:
            notes.append(note)
            res.alternatives = [h for h in res.alternatives if h is not reduced]
        return reduced
    chosen, res.plant_refit, res.alternatives, note = choose_on_plant(model, chosen, res.alternatives, res.ranked)
    if note is not None:
        notes.append(note)
    single = chosen
    chosen, res.plant_refit, looks, note = second_effect_on_plant(model, chosen, res.plant_refit, pool)
    if note is not None:
        notes.append(note)
    if chosen is not single:
        res.alternatives = looks  # the pair's look-alikes on the plant, not those of the single effect
    return chosen


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


def _cause_of_oscillation(res: DiagnosisResult, problem: Problem, nominal: LabState, ranked: list, loops,
                          chi2_fit: float, validate_run: bool, on_plant: bool, notes: list, timing: dict, say):
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
    cause = search_cause(problem, nominal, ranked, f0, loops, chi2_0=chi2_fit, c_hat=res.overdispersion,
                         plant="mujoco" if on_plant else "linear", seed=RERUN_SEED, on_plant=on_plant)
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


def _beyond_measurement(problem: Problem, nominal: LabState) -> bool:
    """Whether the nominal model differs from the data beyond the measurement's uncertainty alone (no floor,
    no model-form uncertainty): the data are then within the model's accuracy, not within the noise."""
    if isinstance(problem.data, FrfData):
        bare = Problem(problem.data, nominal, problem.ctx, floor=0.0, use_phase=problem.use_phase,
                       policy=problem.policy)
    else:
        bare = Problem(problem.data, nominal, problem.ctx, modal_model_form=False, policy=problem.policy)
    return beyond_noise(bare.chi2(nominal), bare.noise_chi2(), bare.peak(nominal), bare.peak_limit())


def _remainder_note(rem: dict) -> str:
    """One sentence on the remainder a selected effect leaves (:func:`vlab.diagnose.decision.remainder_of`)."""
    where = []
    if rem["modes"]:
        where.append("modes " + ", ".join(str(m) for m in rem["modes"]))
    if rem["points"]:
        where.append("points " + ", ".join(str(p) for p in rem["points"]))
    line = rem.get("largest_line")
    if line:
        where.append(f"largest at {line['frequency_hz']:.2f} Hz on the sensor at point {line['point']}")
    noise = rem["noise_misfit_decades"]
    return (f"the selected effect explains part of the mismatch: on {rem['judged_on']} it leaves a misfit of "
            f"{rem['misfit_decades']:.3g} decades"
            + (f", resolved from the {noise:.3g} an exact model leaves" if noise is not None else "")
            + (f" ({'; '.join(where)})" if where else "")
            + ": a remainder outside the selected effect, not named by the library")


def diagnose(structure: str | StructureSpec, recording_path: str | Path, *, controller: str | None = None,
             out_dir: str | Path | None = None, plant: str = "auto", resolution_hz: float | None = None,
             seed: int | None = None, effects: tuple[str, ...] | None = None, floor: float = 0.005,
             shortlist: int = 10, pairs: bool = True, validate_run: bool = True, overwrite: bool = True,
             progress=None, baseline: str | Path | None = None, replay: bool = True,
             force: bool = False, mjcf: str | Path | None = None,
             reference_column: str | None = None, model_form: str = "auto",
             false_alarm_rate: float = 0.01) -> DiagnosisResult:
    """Diagnose a recording against the nominal laboratory (``vlab diagnose``).

    Parameters
    ----------
    structure : {"bcc", "grid"} or StructureSpec
        The structure (a spec for tests and benchmarks).
    recording_path : str or Path
        UFF 58 time histories (force + velocities, as ``vlab experiment``
        writes them), UFF 58 FRFs, or a CSV modal table (``.csv``).
    controller : {"none", "mfdrf", "lqdrf", "lqdrf-diag", "lqg"}, optional
        The nominal controller that was running; default: the recording's
        metadata, else "none" (:func:`vlab.diagnose.data.reference.recorded_setup`).
    out_dir : str or Path, optional
        Folder for ``diagnosis.md``, ``diagnosis.json`` and figures.
    plant : {"auto", "linear", "mujoco"}
        Plant of the replay and the validation rerun; ``"auto"``: the plant
        the recording's metadata names, else MuJoCo (for effects a spec can
        carry, falling back to the linear plant, saying so). An explicit
        plant that contradicts the metadata needs ``force``.
    resolution_hz : float, optional
        Frequency resolution = 1 / excitation period [Hz]; default: the
        recording's metadata, else the structure's test resolution
        (:data:`vlab.lab.experiment.TESTS`).
    seed : int, optional
        Seed of the controller design's multi-start; default the recording's
        metadata seed, else 0. Replays and reruns carry no sensor noise
        (nothing of the recording's noise realisation is reused).
    effects : tuple of str, optional
        Restrict the library to these effect names.
    floor : float
        Relative model error allowed on FRFs (0.5 %).
    shortlist : int
        Number of screened hypotheses fitted in full (plus the best of each effect).
    pairs : bool
        Consider pairs of effects when no single one explains the data.
    validate_run : bool
        Rerun the experiment for validation (time-history input only).
    overwrite : bool
        Replace existing report files in ``out_dir``.
    progress : callable, optional
        Called with a short string at each stage.
    baseline : str or Path, optional
        A recording (UFF 58 time histories or FRFs) of the same test on the
        structure before the change: the data are referred to the model
        through it (:func:`vlab.diagnose.data.measured.refer_to_model`), so that the
        model's own offsets against this plant, present in both, are not
        diagnosed as an effect. Without it, a time-history recording is
        referred to the model through the *replay* of its recorded force on
        the nominal plant (``replay``).
    replay : bool
        Compare a time-history recording with the nominal plant's replay of
        its force (:func:`vlab.diagnose.data.reference.replay_reference`) when no
        baseline is given. False: with the FE model alone.
    force : bool
        Use ``controller``, ``seed`` and ``plant`` even where the recording's
        metadata says otherwise.
    mjcf : str or Path, optional
        The nominal MuJoCo plant as an MJCF file (``vlab export-mjcf``,
        edited; it must keep the naming contract): the recorded force is
        replayed on it, and the validation reruns of effects it can carry
        (controller-path effects) run on it; an effect that edits the
        structure is validated on the plant built from the spec, its nominal
        rerun too. Needs the MuJoCo plant (not ``plant="linear"``).
    reference_column : str, optional
        Modal tables: a column of reference-model frequencies (e.g.
        ``analytical_hz``, the published analysis): the table is compared with
        it, vlab's model predicting what an effect changes (the reference's
        own difference from vlab's model cancels, as through a baseline).
    model_form : {"auto", "derived", "none"}
        The model's own uncertainty (:mod:`vlab.diagnose.model.modelform`) in the decision and the
        intervals. "derived": from the structure's calibration residual and discretisation (a modal table
        always; a recording compared through the replay or with the FE model). "none": the data are known
        to come from the model itself. "auto": "none" for a recording whose metadata names the vlab plant
        that made it (a simulation of this model), and for a measured baseline (the structure before the
        change: its own model-form difference cancels); "derived" otherwise.
    false_alarm_rate : float
        The probability [1], in (0, 0.5), of reporting a mismatch on data of the nominal structure; every
        threshold of the decision follows from it (:class:`vlab.diagnose.policy.DecisionPolicy`).

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
        ``controller``, ``seed`` or ``plant`` contradicts the recording's metadata (without ``force``);
        ``mjcf`` with the linear plant; ``false_alarm_rate`` outside (0, 0.5).
    SpecError
        Unknown structure.
    """
    t_start = time.perf_counter()
    policy = DecisionPolicy(false_alarm_rate=false_alarm_rate)  # checked before any work
    timing: dict = {}
    say = progress or (lambda s: None)
    spec = load_spec(structure) if isinstance(structure, str) else structure
    fe = build_fe_model(spec)
    test = test_definition(spec)
    band = test.band_hz
    path = Path(recording_path)
    notes: list = []
    if plant not in ("auto", "linear", "mujoco"):
        raise ModelError(f"unknown plant {plant!r}; use 'auto', 'linear' or 'mujoco'")
    if mjcf is not None and plant == "linear":
        raise OptionError(f"--mjcf {mjcf} names a MuJoCo plant: it cannot be used with --plant linear")
    if model_form not in ("auto", "derived", "none"):
        raise OptionError(f"model form {model_form!r}: use 'auto', 'derived' or 'none'")
    if reference_column is not None and detect_kind(path) != "modal":
        raise OptionError(f"reference column {reference_column!r}: only a modal table (.csv) has columns; for a "
                          "recording give a measured baseline")
    if detect_kind(path) == "modal" and controller not in (None, "none"):
        notes.append(f"a modal table holds open-loop modes: compared with the open-loop model (controller "
                     f"{controller!r} ignored)")
        controller = "none"
    from ..design import thesis_period_s

    say("reading data")
    if detect_kind(path) == "modal":
        what, obj = "modal", read_modal_csv(path, spec, reference_column=reference_column)
    else:
        what, obj = read_uff_any(path)
    meta = dict(obj.metadata) if what == "recording" else {}
    setup = recorded_setup(meta, str(path), controller=controller, seed=seed,
                           plant=None if plant == "auto" else plant, force=force)
    notes.extend(setup.notes)
    controller, design_seed = setup.controller, setup.seed
    has_mujoco = importlib.util.find_spec("mujoco") is not None
    # the plant that made the recording: replayed as the reference and rerun for validation
    replay_plant = setup.plant or ("mujoco" if has_mujoco else "linear")
    if plant == "auto" and setup.plant == "linear":
        plant = "linear"  # a recording of the linear FE plant is rerun there

    # the controller's sampling period: a recording's own sample interval (it was sampled at the controller
    # rate), else the thesis's period for the controller (Sec. 5.3)
    period_box = {"s": thesis_period_s(controller)}
    state_box: dict = {}

    def nominal_state() -> LabState:
        if "s" not in state_box:  # the controller that ran: designed on the spec's own mesh, at its period
            chain = recorded_chain(setup, period_box["s"])
            design = nominal_design(fe, controller, design_seed, period_s=chain.period_s, reduction=setup.reduction)
            state_box["s"] = LabState(model_spec, fe_model, chain, design, mjcf=None if mjcf is None else str(mjcf))
        return state_box["s"]

    def settle() -> float:
        return settling_time(nominal_state(), band)

    if what == "recording":
        period_box["s"] = float(obj.dt_s)
    if controller != "none":
        src = ("the recording's sample interval" if what == "recording" else
               f"the thesis's period for {controller} (Sec. 5.3): FRF files do not say at which period the "
               "controller ran")
        if what == "recording" and abs(period_box["s"] - thesis_period_s(controller)) > 1e-9 * period_box["s"]:
            src += (f"; the thesis ran {controller} at {thesis_period_s(controller) * 1e3:g} ms: a recording "
                    "sampled by an acquisition system faster than the controller gives the wrong period here")
        notes.append(f"the {controller} controller is realised at a {period_box['s'] * 1e3:g} ms sampling period "
                     f"({src})")
    # a MuJoCo validation rerun will follow: the effect is refitted on its plant, and the model compared with
    # the data is meshed as that plant resolves the structure
    replaying = replay and baseline is None and what == "recording"
    on_plant = (validate_run or replaying) and what == "recording" and plant != "linear" and has_mujoco \
        and replay_plant == "mujoco"
    model_spec = plant_resolution(spec) if on_plant else spec
    fe_model = fe if model_spec is spec else build_fe_model(model_spec)
    if model_spec is not spec:
        notes.append("compared with the MuJoCo plant: the FE model meshed as that plant resolves the structure "
                     f"({PLANT_RESOLUTION_ELEMENTS} elements per segment of a shear-flexible member, "
                     f"{fe_model.n} DOF instead of {fe.n}); the controller is the one designed on the spec's own "
                     "mesh")
    data = read_data(spec, fe, path, what, obj, resolution_hz=resolution_hz, band_hz=band, settle_of=settle)
    if mjcf is not None:
        if what != "recording" or not has_mujoco or (setup.plant or "mujoco") != "mujoco":
            raise OptionError(f"--mjcf {mjcf}: a nominal MJCF plant is replayed and rerun, which needs time "
                              "histories of a MuJoCo-plant recording and the mujoco package")
        from ..sim.runtime import load_plant_for_experiment

        load_plant_for_experiment(spec, mjcf=mjcf, sensors=tuple(data.output_points))  # the contract, checked now
        notes.append(f"the nominal plant is {mjcf}: the recorded force is replayed there; effects that edit the "
                     "structure are validated on the plant built from the spec, and refitted on its linearisation")
    loops = tuple(spec.instrumentation.actuators) if controller != "none" else ()
    # only a loop can make the lab's structure oscillate by itself: an open-loop recording is not searched (its
    # lightly damped modes, still settling after a period, would look like growing lines)
    unstable = find_instability(obj, feedback_points=loops) if what == "recording" and loops else None
    if unstable is not None and unstable.unstable:
        say("the recording shows a self-excited oscillation")
    nominal = nominal_state()
    replayed = None  # the nominal plant's replay of the recorded force (the reference by default)
    same_record = False  # whether the reference was excited by the recording's own force record
    # reruns start warm, this long before the analysed part: the slowest mode's decay by GUARD_DECAY
    guard_s = settling_time(nominal, band, decay=GUARD_DECAY) if what == "recording" else None
    if baseline is not None:
        if not isinstance(data, FrfData):
            raise DataFileError(f"{path}: a baseline needs FRF data (time histories or FRFs), not a modal table")
        bwhat, bobj = read_uff_any(Path(baseline))
        base = read_data(spec, fe, Path(baseline), bwhat, bobj, resolution_hz=resolution_hz, band_hz=band,
                         settle_of=settle)
        h_nom = predict_frf(nominal, data.freq_hz, excitation_point=data.excitation_point,
                            output_points=data.output_points)
        data = refer_to_model(data, base, h_nom)
        reference = f"the measured baseline {baseline}"
        same_record = shares_excitation_record(data, bobj if bwhat == "recording" else None)
        if not same_record:
            notes.append(f"the baseline {baseline} was not excited by the recording's own force record: the two "
                         "are compared within the model-error floor only (differences that depend on the "
                         "excitation's realisation, such as nonlinear distortion, are not in the period-to-period "
                         "noise)")
    elif replaying and isinstance(data, FrfData) and data.recording is not None:
        say(f"replaying the recorded force on the nominal {replay_plant} plant")
        t = time.perf_counter()
        try:
            base, replayed, kind = replay_reference(data, nominal, replay_plant, guard_s=guard_s)
        except (VlabError, ImportError) as exc:
            notes.append(f"the recorded force could not be replayed on the nominal {replay_plant} plant ({exc}): "
                         "the recording is compared with the FE model alone")
            reference = "the FE model (the replay failed)"
        else:
            h_nom = predict_frf(nominal, data.freq_hz, excitation_point=data.excitation_point,
                                output_points=data.output_points)
            data = refer_to_model(data, base, h_nom)
            reference = f"the nominal {kind}'s replay of the recorded force"
            same_record = True
        timing["replay"] = time.perf_counter() - t
    elif what == "modal" and reference_column is not None:
        reference = (f"the table's column {reference_column!r} (a reference model's frequencies; vlab's FE model "
                     "predicts what an effect changes)")
    else:
        reference = "the FE model"
    notes = list(getattr(data, "notes", [])) + notes
    timing["read"] = time.perf_counter() - t_start

    ctx = context_for(nominal, band, data)
    mf_mode = model_form
    made_by_vlab = isinstance(meta.get("plant"), str) and meta.get("plant") != ""  # the recording says so
    if model_form == "auto":
        mf_mode = "none" if (made_by_vlab or baseline is not None) else "derived"
    mf, mf_frf = None, None
    if isinstance(data, FrfData) and mf_mode == "derived":
        mf, mf_frf = frf_model_form_of(nominal, data, replay_plant if replayed is not None else None, notes)
        notes.append(f"compared within the model's own uncertainty: {mf.describe()}")
    elif isinstance(data, FrfData):
        why = ("the recording's metadata names the vlab plant that made it" if made_by_vlab and
               model_form == "auto" else "a measured baseline of the same structure" if model_form == "auto"
               else "as asked")
        notes.append(f"no model-form uncertainty ({why}): only the noise and the {100 * floor:g} % floor")
    problem = Problem(data, nominal, ctx, floor=floor, model_form_frf=mf_frf, modal_model_form=mf_mode != "none",
                      profile_nominal=True, policy=policy)
    problem.model_form = problem.model_form if mf is None else mf
    problem.guard_s = guard_s
    problem.replay_plant = replay_plant if replayed is not None else None  # the plant the reference was replayed on
    if replayed is not None:  # the validation's nominal rerun is the replay
        problem.__dict__.setdefault("_reruns", {})[("nominal", replay_plant, RERUN_SEED)] = replayed
    chi2_0, peak_0 = problem.chi2(nominal), problem.peak(nominal)
    # the hypotheses are scored on the linearly whitened residuals: the nominal model is compared with them on
    # the same footing (its profiled chi-square, chi2_0, decides whether there is a mismatch at all)
    r_lin = problem.residual(nominal)
    chi2_fit = float(r_lin @ r_lin) if problem.model_form_frf is not None else chi2_0
    limit, peak_limit = problem.noise_chi2(), problem.peak_limit()
    misfit_0 = problem.misfit(nominal)
    on_plant = on_plant and isinstance(data, FrfData) and data.recording is not None
    try:
        say("locating")
        t = time.perf_counter()
        location = locate(problem, nominal)
        timing["locate"] = time.perf_counter() - t
        nuisance = problem.nuisance_test()
        tests = mismatch_tests(chi2_0, limit, peak_0, peak_limit, nuisance)
        mismatch = bool(tests)
        if nuisance and nuisance["beyond"]:
            notes.append(f"the nominal model's modes must move beyond their model-form uncertainty to fit the data "
                         f"(chi-square of the moves {nuisance['nuisance_chi2']:.4g}, limit "
                         f"{nuisance['nuisance_limit']:.4g}; most: {nuisance['largest']} by "
                         f"{nuisance['largest_sigmas']:+.3g} sigma)")
        noise_only = None
        if not mismatch and same_record:  # within the floor; within the noise?
            mismatch, stats = changed_beyond_noise(problem, nominal)
            if mismatch:
                noise_only = stats
                tests = mismatch_tests(chi2_0, limit, peak_0, peak_limit, nuisance, stats)
                notes.append(f"the recording differs from its reference beyond the noise (chi-square "
                             f"{stats['chi2']:.4g}, limit {stats['chi2_limit']:.4g}; largest line {stats['peak']:.3g}, "
                             f"limit {stats['peak_limit']:.3g}), though within the model-error floor of "
                             f"{100 * problem.floor:g} % a line: a small change")
        res = DiagnosisResult(spec.name, controller, data, problem, nominal, mismatch, chi2_0, limit, location,
                              None, notes=notes, chi2_fit=chi2_fit, misfit_nominal=misfit_0, misfit_selected=misfit_0,
                              peak_nominal=peak_0, peak_limit=peak_limit, noise_only=noise_only, reference=reference,
                              instability=_instability(unstable, replayed, loops), mismatch_tests=tests)
        osc = res.instability or {}
        self_excited = bool(osc.get("unstable") and osc.get("in_replay") is False)  # part of the mismatch
        if not mismatch:
            res.location.points, res.location.members = [], []
            res.within_model_accuracy = _beyond_measurement(problem, nominal)
            notes.append("the nominal model agrees with the data within the model's own accuracy, though not "
                         "within the measurement's noise alone: no effect is proposed" if res.within_model_accuracy
                         else "the nominal model agrees with the data within the measured noise: no effect is "
                              "proposed")
        else:
            if on_plant and replayed is None:
                start_background_rerun(problem, nominal, "nominal", "mujoco", seed=RERUN_SEED)  # on the other core
            say("screening hypotheses")
            t = time.perf_counter()
            hyps = prune(library(nominal, ctx, effects=effects), location.sensitivity)
            scored = []
            for h in hyps:
                try:
                    trials = trials_for(h, problem)
                    est = getattr(h, "estimate_", None)
                    if est is not None and np.isfinite(est):
                        trials = np.vstack([trials, [[est]], [[est * 0.7]], [[est * 1.4]]])
                    scored.append((screen(h, problem, trials)[0][0], h))
                except (VlabError, ValueError, np.linalg.LinAlgError):
                    continue
            scored.sort(key=lambda s: s[0])
            keep = shortlisted(scored, shortlist)
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
            best = ranked[0] if ranked else None
            if pairs and needs_pairs(best, problem):
                say("fitting pairs")
                t = time.perf_counter()
                ranked = rank(ranked + fit_pairs(ranked, problem, [h for _, h in scored]))
                timing["pairs"] = time.perf_counter() - t
            res.ranked = ranked
            chosen, c_hat, alts = select(ranked, chi2_fit, problem.n_obs, policy)
            res.overdispersion = c_hat
            if self_excited:  # the cause of the oscillation decides, not the FRF fit
                chosen, alts = _cause_of_oscillation(res, problem, nominal, ranked, loops, chi2_fit, validate_run,
                                                     on_plant, notes, timing, say), []
            elif chosen is not None and validate_run and data_has_signals(data) and \
                    any(needs_rerun_check(h) for h in [chosen] + alts):
                say("separating look-alikes by rerun")
                t = time.perf_counter()
                chosen, alts = tie_break_by_rerun(problem, chosen, alts, ranked, notes,
                                                  plant="mujoco" if on_plant else "linear", seed=RERUN_SEED)
                timing["tie_break"] = time.perf_counter() - t
            res.alternatives = alts
            if chosen is not None and on_plant and chosen.spec_level and not self_excited:
                say("refitting on the MuJoCo plant's linearisation")
                t = time.perf_counter()
                chosen = _refit_on_plant(res, problem, chosen, notes, library(nominal, ctx, effects=effects))
                timing["plant_refit"] = time.perf_counter() - t
            if too_small_to_name(chosen, noise_only):
                # beyond the noise, within the model's accuracy: located, not named
                res.too_small, res.too_small_candidates = True, [chosen] + list(alts)
                cands = [h.label for h in [chosen] + list(alts)][:4]
                notes.append("the change is beyond the noise but within the model-error floor of "
                             f"{100 * problem.floor:g} % a line: too small to name (the FE surrogate's own errors "
                             "of that size could mimic any of the candidates); best candidates: " + ", ".join(cands))
                chosen = None
            if chosen is not None:
                res.selected = chosen
                res.misfit_selected = float(chosen.misfit_)
                t = time.perf_counter()
                thr = threshold_of(problem, nominal, ctx, chosen)
                timing["threshold"] = time.perf_counter() - t
                res.threshold = None if thr is None else thr.as_dict()
                parts = res.selected_parts
                if not ctx.closed_loop:
                    res.loop = "open"
                else:
                    res.loop = "closed" if all(p.effect in CONTROLLER_PATH for p in parts) else "both"
            else:
                res.loop = "open" if not ctx.closed_loop else "both"
                if not res.too_small and not self_excited:  # the cause search wrote its own note
                    notes.append("no hypothesis of the library explains the mismatch (quasi-BIC not lowered by 10)")
        if mismatch:
            res.location.points, res.location.members = located_from_fits(res, chi2_fit)
        # validation
        if res.selected is not None and validate_run and isinstance(data, FrfData) and data.recording is not None \
                and res.validation is None:
            modified, key = res.selected_state(), rerun_key(res.selected)
            if res.plant_refit is not None:
                modified, key = res.plant_refit.state, key + "@plant"
            say("validating")
            t = time.perf_counter()
            try:
                res.validation = validate(problem, nominal, modified, plant=plant,
                                          spec_level=res.selected.spec_level, seed=RERUN_SEED, key=key)
                if res.plant_refit is not None and not res.validation.plant.startswith("MuJoCo"):
                    # the plant's value belongs to the plant: a linear rerun takes the FE value
                    res.plant_refit = None
                    res.validation = validate(problem, nominal, res.selected_state(), plant="linear",
                                              spec_level=False, seed=RERUN_SEED, key=rerun_key(res.selected))
            except (VlabError, ImportError) as exc:
                notes.append(f"validation rerun not possible: {exc}")
            timing["validate"] = time.perf_counter() - t
        apply_gates(res, problem, chi2_fit=chi2_fit, misfit_0=misfit_0, self_excited=self_excited, notes=notes)
        if res.selected is not None and not self_excited:
            say("testing the remainder")
            t = time.perf_counter()
            res.remainder = remainder_of(res, problem, misfit_0)
            timing["remainder"] = time.perf_counter() - t
            if res.remainder is not None:
                notes.append(_remainder_note(res.remainder))
    finally:
        stop_background(problem)  # a background rerun never asked for
    timing["total"] = time.perf_counter() - t_start
    res.timing_s = timing
    if out_dir is not None:
        from .report.figures import figures_for
        from .report.markdown import write_report

        say("writing the report")
        res.files = write_report(out_dir, res.as_dict(), figures_for(res), overwrite=overwrite)
    return res
