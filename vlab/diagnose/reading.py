"""Stage 1 of the diagnosis: the data, the nominal lab they are compared with, and the reference.

From a recording (UFF 58 time histories or FRFs) or a modal table, and the options of ``vlab diagnose``:
the recording's own setup (controller, seed, plant and chain from its metadata,
:func:`vlab.diagnose.data.reference.recorded_setup`), the nominal lab (the controller that ran, designed on
the spec's own mesh at the recording's sample interval; the FE model meshed as the MuJoCo plant resolves
the structure when the comparison is with that plant), the FRFs, and the reference they are referred to
the model through (:func:`vlab.diagnose.data.measured.refer_to_model`): a measured baseline, or the
nominal plant's replay of the recorded force (:func:`vlab.diagnose.data.reference.replay_reference`), or
the FE model alone. The result is one immutable :class:`Inputs`.
"""

from __future__ import annotations

import importlib.util
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from ..errors import DataFileError, ModelError, OptionError, VlabError
from ..design.gains_file import design_from_file, read_gains_file
from ..fe import FEModel, build_fe_model
from ..io.setup_file import RecordingSetup, apply_setup
from ..io.recording import Recording
from ..io.uff_files import read_sidecar
from ..experiment.config import test_definition, with_hardware
from ..measure.instability import find_instability
from ..spec import StructureSpec, load_spec
from .data.measured import FrfData, ModalData, refer_to_model
from .data.modalcsv import read_modal_csv
from .data.acquired import is_lab_recording
from .data.readers import detect_kind, read_data, read_uff_any
from .data.reference import (recorded_chain, recorded_setup, referred_through_replay, shares_excitation_record,
                             with_test_setup)
from .data.replay import plant_step_s
from .data.warmstart import GUARD_DECAY
from .model.labmodel import LabState, predict_frf
from .model.nominal import PLANT_RESOLUTION_ELEMENTS, nominal_design, plant_resolution, settling_time


@dataclass(frozen=True)
class Options:
    """The options of a diagnosis that decide what is read and compared (parameters of
    :func:`vlab.diagnose.diagnose` of the same names).

    Attributes
    ----------
    controller : {"none", "mfdrf", "lqdrf", "lqdrf-diag", "lqg"}, optional
        The nominal controller that was running; default: the recording's
        metadata, else "none" (:func:`vlab.diagnose.data.reference.recorded_setup`).
    plant : {"auto", "linear", "mujoco"}
        Plant of the replay and the validation rerun; ``"auto"``: the plant
        the recording's metadata names, else MuJoCo (for effects a spec can
        carry, falling back to the linear plant, saying so). An explicit
        plant that contradicts the metadata needs ``force``.
    resolution_hz : float, optional
        Frequency resolution = 1 / excitation period [Hz]; default: the
        recording's metadata, else the structure's test resolution
        (:data:`vlab.experiment.config.TESTS`).
    seed : int, optional
        Seed of the controller design's multi-start; default the recording's
        metadata seed, else 0. Replays and reruns carry no sensor noise
        (nothing of the recording's noise realisation is reused).
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
    validate_run : bool
        Rerun the experiment for validation (time-history input only).
    confirm : callable, optional
        Called once the data are read and before the first simulation with the run's estimate
        (:func:`vlab.diagnose.cost.estimate_diagnosis`'s dict); it may raise to stop the run there (the command
        line refuses a long run without ``--yes``).
    test : RecordingSetup, optional
        The test that made the recording (a ``test.toml``, :func:`vlab.io.setup_file.read_setup`): its fields
        complete the recording's metadata (:func:`vlab.diagnose.data.reference.with_test_setup`; a field both
        give differently is refused unless ``force``), its node map, excitation point and sensors select the
        channels of time histories, the baseline's too (:func:`vlab.io.setup_file.apply_setup`).
    estimator : {"auto", "periodic", "h1", "transient"}
        How the FRFs of time histories are estimated, the baseline's too
        (:func:`vlab.diagnose.data.frfestimate.choose_estimator`; ``auto`` chooses by the force).
    design : str or Path, optional
        The gains the controller ran with, a design file (:mod:`vlab.design.gains_file`: the JSON of
        ``vlab design --json``, or a laboratory's own gains): the nominal lab's controller is that gain, not
        a redesign (which would give another where the design has changed, or where the lab's gains were
        not vlab's). A direct rate feedback only.
    """

    controller: str | None = None
    plant: str = "auto"
    resolution_hz: float | None = None
    seed: int | None = None
    baseline: str | Path | None = None
    replay: bool = True
    force: bool = False
    mjcf: str | Path | None = None
    reference_column: str | None = None
    model_form: str = "auto"
    validate_run: bool = True
    confirm: Callable[[dict], None] | None = None
    test: RecordingSetup | None = None
    estimator: str = "auto"
    design: str | Path | None = None


@dataclass(frozen=True)
class Inputs:
    """What a diagnosis compares (immutable).

    Attributes
    ----------
    spec : StructureSpec
    fe : FEModel
        The FE model of ``spec`` (the controller's mesh).
    band_hz : tuple of float
        The structure's test band [Hz].
    path : Path
        The recording.
    what : {"recording", "frf", "modal"}
    recording : object
        What the reader returned (a Recording, FRFs or a modal table).
    metadata : dict
        The recording's metadata (empty for FRFs and tables).
    controller : str
        The controller that ran.
    plant : {"auto", "linear", "mujoco"}
        The plant of the validation reruns.
    replay_plant : {"linear", "mujoco"}
        The plant the recording names (or MuJoCo), replayed as the reference.
    on_plant : bool
        The comparison is with the MuJoCo plant: the effect is refitted on its linearisation.
    nominal : LabState
    data : FrfData or ModalData
        Referred to the model through the reference.
    replayed : object or None
        The nominal plant's replay of the recorded force (a Recording), when it is the reference.
    on_recording_plant : bool
        The data are compared with the vlab plant that made them (replayed there, referred through its
        linearisation, or the linear FE plant's compared with the FE model): no model-form difference.
    same_record : bool
        The reference was excited by the recording's own force record.
    reference : str
        What the data were compared with, in words.
    instability : object or None
        :func:`vlab.measure.instability.find_instability` of a closed-loop recording.
    loops : tuple of int
        Feedback points (empty in open loop).
    guard_s : float or None
        How long before the analysed part reruns start warm [s].
    unreferred : FrfData or None
        The recording's FRFs before their referral through a replay (None without a replay).
    notes : tuple of str
    timing_s : dict
        Stage -> seconds.
    """

    spec: StructureSpec
    fe: FEModel
    band_hz: tuple
    path: Path
    what: str
    recording: object
    metadata: dict
    controller: str
    plant: str
    replay_plant: str
    on_plant: bool
    nominal: LabState
    data: FrfData | ModalData
    replayed: object
    same_record: bool
    reference: str
    instability: object
    loops: tuple
    guard_s: float | None
    notes: tuple = ()
    timing_s: dict = field(default_factory=dict)
    on_recording_plant: bool = False
    unreferred: FrfData | None = None


def _check_options(opt: Options, path: Path) -> None:
    """Refuse contradicting options before any work (ModelError, OptionError)."""
    if opt.plant not in ("auto", "linear", "mujoco"):
        raise ModelError(f"unknown plant {opt.plant!r}; use 'auto', 'linear' or 'mujoco'")
    if opt.mjcf is not None and opt.plant == "linear":
        raise OptionError(f"--mjcf {opt.mjcf} names a MuJoCo plant: it cannot be used with --plant linear")
    if opt.model_form not in ("auto", "derived", "none"):
        raise OptionError(f"model form {opt.model_form!r}: use 'auto', 'derived' or 'none'")
    if opt.reference_column is not None and detect_kind(path) != "modal":
        raise OptionError(f"reference column {opt.reference_column!r}: only a modal table (.csv) has columns; for a "
                          "recording give a measured baseline")


def _period_note(controller: str, what: str, period_s: float, thesis_s: float) -> str:
    src = ("the recording's sample interval" if what == "recording" else
           f"the thesis's period for {controller} (Sec. 5.3): an acquisition system's recording does not say at "
           "which period the controller ran" if what == "acquired" else
           f"the thesis's period for {controller} (Sec. 5.3): FRF files do not say at which period the "
           "controller ran")
    if what == "recording" and abs(period_s - thesis_s) > 1e-9 * period_s:
        src += (f"; the thesis ran {controller} at {thesis_s * 1e3:g} ms: a recording "
                "sampled by an acquisition system faster than the controller gives the wrong period here")
    return f"the {controller} controller is realised at a {period_s * 1e3:g} ms sampling period ({src})"


def _controller_period(what: str, obj, controller: str, design_file, notes: list) -> tuple[float, object]:
    """The controller's sampling period [s] and the design file to use (None for a modal table, which holds
    open-loop modes): a lab recording's own sample interval; else the design file's ``period_s`` where it
    gives one; else the thesis's (Sec. 5.3). A note says which.

    Raises
    ------
    OptionError
        The design file's period contradicts a lab recording's sample interval.
    DataFileError
        The design file is malformed (:func:`vlab.design.gains_file.read_gains_file`).
    """
    from ..design import thesis_period_s

    acquired = what == "recording" and not is_lab_recording(obj)
    period_s = float(obj.dt_s) if what == "recording" and not acquired else thesis_period_s(controller)
    if design_file is not None and what == "modal":
        notes.append(f"a modal table holds open-loop modes: the design file {design_file} is not used")
        design_file = None
    if controller == "none":
        return period_s, design_file
    file_period = read_gains_file(design_file)["period_s"] if design_file is not None else None
    if file_period is not None and (acquired or what == "frf"):
        notes.append(f"the {controller} controller is realised at a {file_period * 1e3:g} ms sampling period (the "
                     f"design file {design_file})")
        return file_period, design_file
    if file_period is not None and abs(file_period - period_s) > 1e-9 * period_s:
        raise OptionError(f"--design {design_file}: its period_s {file_period:g} s contradicts the recording's "
                          f"sample interval {period_s:g} s (the controller's period)")
    notes.append(_period_note(controller, "acquired" if acquired else what, period_s, thesis_period_s(controller)))
    return period_s, design_file


def _refer(inp: dict, opt: Options, notes: list, timing: dict, say) -> None:
    """Refer the data of ``inp`` to the model through the reference (baseline, replay or none); sets ``data``,
    ``replayed``, ``same_record`` and ``reference`` in ``inp``."""
    data, nominal, spec, fe = inp["data"], inp["nominal"], inp["spec"], inp["fe"]
    inp.update(replayed=None, same_record=False)
    replaying = opt.replay and opt.baseline is None and inp["what"] == "recording"
    if opt.baseline is not None:
        if not isinstance(data, FrfData):
            raise DataFileError(f"{inp['path']}: a baseline needs FRF data (time histories or FRFs), not a modal table")
        bwhat, bobj = read_uff_any(Path(opt.baseline))
        bmeta = dict(bobj.metadata) if bwhat == "recording" else {}
        bobj, _ = _through_test_setup(bwhat, bobj, bmeta, opt, Path(opt.baseline), notes)
        base = read_data(spec, fe, Path(opt.baseline), bwhat, bobj, resolution_hz=opt.resolution_hz,
                         band_hz=inp["band_hz"], settle_of=lambda: settling_time(nominal, inp["band_hz"]),
                         period_s=nominal.chain.period_s, estimator=opt.estimator)
        h_nom = predict_frf(nominal, data.freq_hz, excitation_point=data.excitation_point,
                            output_points=data.output_points)
        inp["data"] = refer_to_model(data, base, h_nom)
        inp["reference"] = f"the measured baseline {opt.baseline}"
        inp["same_record"] = shares_excitation_record(inp["data"], base.recording if bwhat == "recording" else None)
        if not inp["same_record"]:
            notes.append(f"the baseline {opt.baseline} was not excited by the recording's own force record: the two "
                         "are compared within the model-error floor only (differences that depend on the "
                         "excitation's realisation, such as nonlinear distortion, are not in the period-to-period "
                         "noise)")
    elif replaying and isinstance(data, FrfData) and data.recording is not None:
        say(f"replaying the recorded force on the nominal {inp['replay_plant']} plant")
        t = time.perf_counter()
        try:
            referred, replayed, kind = referred_through_replay(data, nominal, inp["replay_plant"],
                                                               guard_s=inp["guard_s"])
        except (VlabError, ImportError) as exc:
            notes.append(f"the recorded force could not be replayed on the nominal {inp['replay_plant']} plant "
                         f"({exc}): the recording is compared with the FE model alone")
            inp["reference"] = "the FE model (the replay failed)"
        else:
            inp.update(data=referred, replayed=replayed, same_record=True,
                       reference=f"the nominal {kind}'s replay of the recorded force", unreferred=data)
        timing["replay"] = time.perf_counter() - t
    elif (inp["what"] == "frf" and opt.replay and inp["setup_plant"] == "mujoco" and isinstance(data, FrfData)):
        _refer_through_plant(inp, notes, say)  # needs MuJoCo: plant_modes says so when it is missing
    elif inp["what"] == "modal" and opt.reference_column is not None:
        inp["reference"] = (f"the table's column {opt.reference_column!r} (a reference model's frequencies; vlab's FE "
                            "model predicts what an effect changes)")
    else:
        inp["reference"] = "the FE model"


def _refer_through_plant(inp: dict, notes: list, say) -> None:
    """FRFs the MuJoCo plant made, referred to the model through that plant's nominal linearisation
    (``H_ref = H_file H_FE / H_plant``, :func:`~vlab.diagnose.data.measured.refer_to_model`): the FE/plant
    difference present in the file is removed to first order, as a replay does for time histories."""
    from .fit.plantfit import plant_modes

    data, nominal = inp["data"], inp["nominal"]
    say("linearising the nominal MuJoCo plant (the FRFs' reference)")
    pts = tuple(dict.fromkeys(tuple(data.output_points) + nominal.actuators))
    try:
        on_plant = replace(nominal, point_modes=plant_modes(nominal.spec, pts))
    except ModelError as exc:
        notes.append(f"the FRFs name the MuJoCo plant, whose linearisation failed ({exc}): compared with the FE "
                     "model alone")
        inp["reference"] = "the FE model (the plant's linearisation failed)"
        return
    kw = dict(excitation_point=data.excitation_point, output_points=data.output_points)
    h_plant, h_nom = predict_frf(on_plant, data.freq_hz, **kw), predict_frf(nominal, data.freq_hz, **kw)
    base = replace(data, h=h_plant, var=np.zeros_like(data.var), source="the nominal MuJoCo plant's linearisation")
    inp.update(data=refer_to_model(data, base, h_nom), on_recording_plant=True,
               reference="the nominal MuJoCo plant's linearisation (the plant the FRFs name)")


def _nominal_lab(spec: StructureSpec, fe: FEModel, setup, controller: str, period_s: float, on_plant: bool,
                 mjcf, notes: list, design_file=None) -> LabState:
    """The nominal lab: the controller that ran, designed on the spec's own mesh at ``period_s`` (or the gains
    of ``design_file``, :func:`vlab.design.gains_file.design_from_file`); the FE model meshed as the MuJoCo
    plant resolves the structure when ``on_plant``."""
    model_spec = plant_resolution(spec) if on_plant else spec
    fe_model = fe if model_spec is spec else build_fe_model(model_spec)
    if model_spec is not spec:
        notes.append("compared with the MuJoCo plant: the FE model meshed as that plant resolves the structure "
                     f"({PLANT_RESOLUTION_ELEMENTS} elements per segment of a shear-flexible member, "
                     f"{fe_model.n} DOF instead of {fe.n}); the controller is the one designed on the spec's own "
                     "mesh")
    chain = with_hardware(recorded_chain(setup, period_s), spec)  # the structure file's [hardware] settings
    if design_file is not None:
        if controller == "none":
            raise OptionError(f"--design {design_file}: the recording ran no controller (open loop)")
        design = design_from_file(fe, design_file, controller=controller, period_s=chain.period_s)
        notes.append(f"the controller's gains from {design_file} (not redesigned)")
    else:
        design = nominal_design(fe, controller, setup.seed, period_s=chain.period_s, reduction=setup.reduction)
    lab = LabState(model_spec, fe_model, chain, design, mjcf=None if mjcf is None else str(mjcf))
    if on_plant:  # the model holds the coil forces over the plant's own physics step, as that plant does
        try:  # the plant built from the structure file (the model's finer mesh is the FE model's alone)
            lab = replace(lab, step_s=plant_step_s(replace(lab, spec=spec, fe=fe)))
        except (VlabError, ImportError) as exc:  # the replay falls back to the FE model the same way
            notes.append(f"the MuJoCo plant's physics step is not known ({exc}): the model holds the coil forces "
                         "over half a controller period")
    return lab


def _estimate(nominal: LabState, data, band_hz, *, simulated: bool, from_elsewhere: bool = False) -> dict:
    """The run's time and memory (:func:`vlab.diagnose.cost.estimate_diagnosis`) from the nominal lab, the
    library's size and the recording; ``simulated``: the recording is replayed and rerun on the MuJoCo plant;
    ``from_elsewhere``: its metadata names no vlab plant."""
    from ..sim import SimOptions
    from ..sim.planner import plan_structure
    from .cost import estimate_diagnosis
    from .effects.hypotheses import library
    from .problem.context import context_for

    rec = getattr(data, "recording", None)
    n_ticks = rec.n_samples if rec is not None else 0
    n_joints = None
    if simulated and rec is not None:
        plan, _ = plan_structure(nominal.spec, SimOptions().resolved(nominal.spec))
        n_joints = sum(len(b.joints) for b in plan.bodies.values())
    return estimate_diagnosis(n_fe_dofs=nominal.fe.n, n_hypotheses=len(library(nominal, context_for(nominal, band_hz,
                                                                                                   data))),
                              n_ticks=n_ticks, n_channels=rec.n_channels if rec is not None else 0, n_joints=n_joints,
                              from_elsewhere=from_elsewhere)


def _through_test_setup(what: str, obj, meta: dict, opt: Options, path: Path, notes: list) -> tuple:
    """The data and metadata of a recording completed by the test setup ``opt.test`` (unchanged without one):
    the metadata merged (:func:`~vlab.diagnose.data.reference.with_test_setup`), a time history's channels
    selected and renumbered (:func:`~vlab.io.setup_file.apply_setup`) and its metadata replaced by the merged."""
    if opt.test is None or what == "modal":
        return obj, meta
    meta, merged = with_test_setup(meta, opt.test.metadata, str(path), str(opt.test.path), force=opt.force)
    notes.extend(merged)
    if what == "recording":
        obj, applied = apply_setup(obj, opt.test, str(path))
        notes.extend(applied)
        obj = Recording(obj.dt_s, obj.channels, meta)
    elif opt.test.nodes or opt.test.sensor_points or opt.test.excitation_point is not None:
        notes.append(f"{path}: FRFs are taken as they are: the test setup's nodes, excitation point and sensors "
                     "select the channels of time histories")
    return obj, meta


def structure_of(structure: str | StructureSpec | None, test: RecordingSetup | None) -> StructureSpec:
    """The structure a diagnosis runs on: ``structure``, else the test setup's; both must name the same.

    Parameters
    ----------
    structure : str, StructureSpec or None
        A shipped structure's name, a structure file, or a spec (None: the test setup's).
    test : RecordingSetup or None

    Returns
    -------
    StructureSpec

    Raises
    ------
    OptionError
        Neither gives a structure, or the two name different structures (spec names compared).
    SpecError
        An unknown structure or a structure file that does not load.
    """
    if structure is None:
        if test is None:
            raise OptionError("no structure: give one, or a test setup whose 'structure' names it")
        return load_spec(test.structure)
    spec = load_spec(structure) if isinstance(structure, str) else structure
    if test is not None:
        named = load_spec(test.structure)
        if named.name != spec.name:
            raise OptionError(f"the structure {spec.name!r} contradicts the test setup {test.path}: its structure "
                              f"{test.structure!r} is {named.name!r}")
    return spec


def read_inputs(structure: str | StructureSpec | None, recording_path: str | Path, opt: Options,
                say=None) -> Inputs:
    """Stage 1: read the recording, find its setup, build the nominal lab and refer the data to it.

    Parameters
    ----------
    structure : str, StructureSpec or None
        None: the structure of the test setup ``opt.test`` (:func:`structure_of`).
    recording_path : str or Path
    opt : Options
    say : callable, optional
        Progress (one short string per step).

    Returns
    -------
    Inputs

    Raises
    ------
    DataFileError, MeasurementError, ModelError, OptionError, SpecError
        As :func:`vlab.diagnose.diagnose`.
    """
    t_start = time.perf_counter()
    say = say or (lambda s: None)
    spec = structure_of(structure, opt.test)
    fe = build_fe_model(spec)
    band = test_definition(spec).band_hz
    path = Path(recording_path)
    notes: list = []
    timing: dict = {}
    _check_options(opt, path)
    controller = opt.controller
    if detect_kind(path) == "modal" and controller not in (None, "none"):
        notes.append(f"a modal table holds open-loop modes: compared with the open-loop model (controller "
                     f"{controller!r} ignored)")
        controller = "none"
    say("reading data")
    if detect_kind(path) == "modal":
        what, obj = "modal", read_modal_csv(path, spec, reference_column=opt.reference_column)
    else:
        what, obj = read_uff_any(path)
    meta = dict(obj.metadata) if what == "recording" else read_sidecar(path) if what == "frf" else {}
    obj, meta = _through_test_setup(what, obj, meta, opt, path, notes)
    setup = recorded_setup(meta, str(path), controller=controller, seed=opt.seed,
                           plant=None if opt.plant == "auto" else opt.plant, force=opt.force)
    notes.extend(setup.notes)
    controller = setup.controller
    has_mujoco = importlib.util.find_spec("mujoco") is not None
    replay_plant = setup.plant or ("mujoco" if has_mujoco else "linear")  # the plant that made the recording
    plant = "linear" if opt.plant == "auto" and setup.plant == "linear" else opt.plant
    acquired = what == "recording" and not is_lab_recording(obj)
    period_s, design_file = _controller_period(what, obj, controller, opt.design, notes)
    replaying = opt.replay and opt.baseline is None and what == "recording"
    on_plant = ((opt.validate_run or replaying) and what == "recording" and plant != "linear" and has_mujoco
                and replay_plant == "mujoco")
    nominal = _nominal_lab(spec, fe, setup, controller, period_s, on_plant, opt.mjcf, notes, design_file)
    data = read_data(spec, fe, path, what, obj, resolution_hz=opt.resolution_hz, band_hz=band,
                     settle_of=lambda: settling_time(nominal, band), period_s=period_s, estimator=opt.estimator)
    if acquired:  # from here on the recording is the acquired one on the controller's clock
        obj = data.recording
    if opt.mjcf is not None:
        if what != "recording" or not has_mujoco or (setup.plant or "mujoco") != "mujoco":
            raise OptionError(f"--mjcf {opt.mjcf}: a nominal MJCF plant is replayed and rerun, which needs time "
                              "histories of a MuJoCo-plant recording and the mujoco package")
        from ..sim.runtime import load_plant_for_experiment

        load_plant_for_experiment(spec, mjcf=opt.mjcf, sensors=tuple(data.output_points))  # the contract, now
        notes.append(f"the nominal plant is {opt.mjcf}: the recorded force is replayed there; effects that edit the "
                     "structure are validated on the plant built from the spec, and refitted on its linearisation")
    loops = tuple(spec.instrumentation.actuators) if controller != "none" else ()
    # only a loop can make the lab's structure oscillate by itself: an open-loop recording is not searched (its
    # lightly damped modes, still settling after a period, would look like growing lines)
    unstable = find_instability(obj, feedback_points=loops) if what == "recording" and loops else None
    if unstable is not None and unstable.unstable:
        say("the recording shows a self-excited oscillation")
    inp = dict(spec=spec, fe=fe, band_hz=band, path=path, what=what, recording=obj, metadata=meta,
               controller=controller, plant=plant, replay_plant=replay_plant, nominal=nominal, data=data,
               instability=unstable, loops=loops,
               guard_s=settling_time(nominal, band, decay=GUARD_DECAY) if what == "recording" else None)
    inp["setup_plant"] = setup.plant
    if opt.confirm is not None:
        named = isinstance(meta.get("plant"), str) and meta.get("plant") != ""
        opt.confirm(_estimate(nominal, data, band, simulated=replaying and replay_plant == "mujoco",
                              from_elsewhere=not named))
    _refer(inp, opt, notes, timing, say)
    del inp["setup_plant"]
    data = inp["data"]
    # the search's fits are refitted and compared on the MuJoCo plant only where the data were referred to the
    # model through that plant (its replay): against a measured baseline or the FE model the plant takes no
    # part in the comparison, and its own difference from the structure would enter the reported parameters
    inp["on_plant"] = (on_plant and isinstance(data, FrfData) and data.recording is not None
                       and inp["replayed"] is not None)
    timing["read"] = time.perf_counter() - t_start
    return Inputs(**inp, notes=tuple(getattr(data, "notes", [])) + tuple(notes), timing_s=timing)
