"""``vlab diagnose``: a mismatch between a recording and the simulation located, named and fitted;
``vlab detectability``: the smallest size of each effect the diagnosis detects and names.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path
from typing import Any

import typer
from rich.markup import escape
from rich.table import Table

from ..errors import OptionError
from . import checks
from .options import (STRUCTURE_HELP, STRUCTURE_METAVAR, ExpController, OutputFormat, arg_structure, flag,
                      format_opt, json_flag, opt, quiet_flag)
from .output import console, print_json, print_rows, stages
from .runtime import expect_output

DIAGNOSE_OUT = "out/diagnose"
DIAGNOSE_PLANTS = ("auto", "linear", "mujoco")
DETECT_OUT = "out/detectability"


def diagnose(
    structure: str = opt(None, "--structure", help=STRUCTURE_HELP + " (default: the --test file's structure)",
                         metavar=STRUCTURE_METAVAR),
    recording: str = opt(..., "--recording",
                         help="the recording: UFF 58 time histories (as `vlab experiment` writes, or from an "
                              "acquisition system: any motion quantity, unit and rate), CSV time histories "
                              "(header 'time [s]', then '<node><+|-><X|Y|Z> <quantity> [<unit>]'), HDF5 time "
                              "histories (.h5/.hdf5: a dataset per channel with attributes node, direction, "
                              "quantity, unit; needs pip install \"vlab[hdf5]\"), UFF 58 FRFs, or a CSV modal table"),
    test: str = opt(None, "--test", metavar="<test.toml>",
                    help="the test that made the recording (written by `vlab init test`): structure, controller, "
                         "hardware chain, excitation point and period, sensors, node map -- what a recording "
                         "without vlab's sidecar leaves unsaid (default: none, the sidecar's and the options' values)"),
    estimator: str = opt("auto", "--estimator", metavar="<auto|periodic|h1|transient>",
                         help="how the FRFs of time histories are estimated: periodic (period by period), h1 (H1 "
                              "with a Hann window: random excitation), transient (impact hammer or burst random: "
                              "one record of 1/--resolution s per event, a force window, the response decayed "
                              "within it), auto (chosen by the force; the default)"),
    resolution: float = opt(None, "--resolution", metavar="<Hz>",
                            help="line spacing of the excitation [Hz] = 1 / its period (default: the recording's "
                                 "metadata, else the structure's test resolution)"),
    controller: ExpController = opt(None, "--controller",
                                    help="controller that was running during the recording (none = open loop; "
                                         "default: the recording's metadata, else none)"),
    force: bool = flag("--force", help="use --controller/--plant even where the recording's metadata says "
                                       "otherwise"),
    out: str = opt(DIAGNOSE_OUT, "--out", help="output folder (its parent must exist)"),
    overwrite: bool = flag("--overwrite", help="replace an existing non-empty output folder"),
    plant: str = opt("auto", "--plant", metavar="<auto|linear|mujoco>",
                     help="plant of the replay and the validation rerun: auto (the plant the recording's "
                          "metadata names, else MuJoCo), linear or mujoco"),
    baseline: str = opt(None, "--baseline",
                        help="a measured reference: recording of the same test on the structure before the "
                             "change (default: the recorded force replayed on the nominal plant)"),
    mjcf: str = opt(None, "--mjcf", help="the nominal plant as an MJCF file (from `vlab export-mjcf`, edited): the "
                                         "recorded force is replayed on it (default: the plant built from the "
                                         "structure); needs a MuJoCo-plant recording"),
    design: str = opt(None, "--design", metavar="<design.json>",
                      help="the gains the controller ran with (the JSON of `vlab design --json`, or the lab's own: "
                           "controller, gain_n_s_per_m): used as they are instead of a redesign (default: the "
                           "controller designed as vlab designs it); direct rate feedback only"),
    reference_column: str = opt(None, "--reference-column",
                                help="modal tables: compare with this column's frequencies (e.g. analytical_hz, "
                                     "a published analysis) instead of vlab's model; the model predicts what "
                                     "an effect changes (default: none, compared with vlab's model)"),
    model_form: str = opt("auto", "--model-form", metavar="<auto|derived|none>",
                          help="the model's own uncertainty in the decision: derived (from its calibration and "
                               "discretisation), none (the data come from this model itself), auto (none for a "
                               "recording whose metadata names the vlab plant that made it or with --baseline, "
                               "else derived)"),
    false_alarm_rate: float = opt(0.01, "--false-alarm-rate", metavar="<alpha>",
                                  help="probability [1], in (0, 0.5), of reporting a mismatch on a recording of "
                                       "the nominal structure; every threshold of the decision follows from it "
                                       "(chi-square and single-line limits, the likelihood-ratio test)"),
    yes: bool = flag("--yes", help="run a diagnosis estimated to take more than 30 min"),
    log_freq: bool = flag("--log-freq", help="draw the report's FRF overlays on a logarithmic frequency axis "
                                             "(default linear, as the dissertation's Figs. 22-31)"),
    fmt: OutputFormat = format_opt(),
    as_json: bool = json_flag(),
    quiet: bool = quiet_flag(),
) -> None:
    """Locate a mismatch between a recording and the simulation, name and fit the missing physics.

    Once the recording is read, the run's time and memory are estimated (on stderr); a run estimated beyond
    30 min asks for --yes.
    """
    from ..diagnose import diagnose as run_diagnose
    from ..diagnose.policy import DecisionPolicy
    from ..io.atomic import atomic_dir

    out_fmt = checks.output_format(fmt, as_json)
    DecisionPolicy(false_alarm_rate=false_alarm_rate)  # a bad rate is refused before any work
    spec, setup = _structure_and_setup(structure, test)
    out_path = checks.out_dir(out, DIAGNOSE_OUT, overwrite)
    _check_choices(estimator, plant, resolution)
    checks.input_file("--recording", recording)
    checks.input_file("--baseline", baseline)
    checks.input_file("--design", design)
    checks.mjcf_input(mjcf)
    expect_output(out_path)
    with stages("diagnose", "reading the recording", quiet=quiet or out_fmt != "table") as say:
        with atomic_dir(out_path, overwrite=overwrite, create_parent=out == DIAGNOSE_OUT) as tmp:
            res = run_diagnose(spec, Path(recording), out_dir=tmp, plant=plant, baseline=baseline, mjcf=mjcf,
                               resolution_hz=resolution,
                               controller=None if controller is None else controller.value, force=force,
                               overwrite=False, reference_column=reference_column, model_form=model_form,
                               false_alarm_rate=false_alarm_rate, progress=say, test=setup, estimator=estimator,
                               confirm=_confirm(yes, quiet or out_fmt != "table"), log_freq=log_freq,
                               design=design)
    res.files = {k: out_path / Path(v).relative_to(tmp) for k, v in res.files.items()}
    if out_fmt == "json":
        print_json(res.as_dict())
        return
    d = res.as_dict()
    if out_fmt == "csv":
        diagnosis_csv(d)
        return
    _print_diagnosis(d, out_path)


def _structure_and_setup(structure: str | None, test: str | None):
    """The structure's spec and the test setup of ``--structure`` and ``--test`` (one of them names the
    structure; both must name the same)."""
    from ..diagnose.reading import structure_of
    from ..io.setup_file import read_setup

    setup = read_setup(checks.input_file("--test", test)) if test is not None else None
    if structure is None and setup is None:
        raise OptionError("--structure is missing: name the structure, or give --test with a test setup that does")
    return structure_of(checks.load_structure(structure if structure is not None else setup.structure), setup), setup


def _check_choices(estimator: str, plant: str, resolution: float | None) -> None:
    """Refuse an unknown ``--estimator`` or ``--plant`` and a ``--resolution`` that is not a positive number."""
    from ..diagnose.data.frfestimate import ESTIMATORS

    if estimator not in ESTIMATORS:
        raise OptionError(f"--estimator {estimator!r} is not one of {', '.join(ESTIMATORS)}")
    if plant not in DIAGNOSE_PLANTS:
        raise OptionError(f"--plant {plant!r} is not one of {', '.join(DIAGNOSE_PLANTS)}")
    if resolution is not None and not (math.isfinite(resolution) and resolution > 0):
        raise OptionError(f"--resolution must be a positive number of Hz, got {resolution!r}")


def _confirm(yes: bool, quiet: bool):
    """The diagnosis's estimate printed on stderr (unless ``quiet``); a run beyond 30 min refused without ``yes``
    (:func:`vlab.diagnose.cost.estimate_diagnosis`)."""
    from ..units import format_bytes, format_duration
    from .output import err_console

    def confirm(est: dict) -> None:
        checks.confirm_long_run("vlab diagnose", est["time_s"], est["what"], yes,
                                "diagnose fewer effects (the Python API's effects=...) or a coarser plant "
                                "([mujoco] segments_per_element)")
        if not quiet:
            err_console.print(f"estimate: at most ~{format_duration(est['time_s'])} (a mismatch found: "
                              f"{est['what']}), ~{format_bytes(est['memory_bytes'])} memory", highlight=False,
                              soft_wrap=True)

    return confirm


def diagnosis_csv(d: dict[str, Any], out=None) -> None:
    """Every ranked hypothesis of ``d`` (:meth:`DiagnosisResult.as_dict`) as one CSV line on ``out`` (stdout).

    Columns: rank, effect, location, parameters (SI, with 95 % intervals), BIC difference to the best, misfit
    after the effect is modelled (its unit in the column name: decades for FRF data).
    """
    from ..diagnose.report.text import hypothesis_rows, misfit_unit
    from ..io.tabular import Column, write_csv

    unit = misfit_unit(d).replace(".", "").replace(" ", "_")
    rows = [{"rank": i, "effect": r["effect"], "location": r["location"], "parameters_si_ci95": r["parameters"],
             "delta_bic": r["delta_bic"], f"misfit_after_{unit}": r["misfit_after"]}
            for i, r in enumerate(hypothesis_rows(d, limit=None), start=1)]
    write_csv(rows, [Column("rank", ""), Column("effect", ""), Column("location", ""),
                     Column("parameters_si_ci95", ""), Column("delta_bic", ""), Column(f"misfit_after_{unit}", "")],
              out or sys.stdout)


def _print_diagnosis(d: dict[str, Any], out_path) -> None:
    """The ranked hypotheses as a table (units in the headers and cells) and the one-paragraph verdict."""
    from ..diagnose.report.text import hypothesis_rows, misfit_unit
    from ..diagnose.report.verdict import verdict

    rows = hypothesis_rows(d, limit=8)
    unit = misfit_unit(d)
    if rows:
        t = Table(title=f"ranked hypotheses (best {len(rows)} of {len(d['ranked'])}; BIC: lower is better)")
        for col, justify in (("#", "right"), ("effect", "left"), ("location", "left"),
                             ("parameters, SI [95 % interval]", "left"), ("dBIC to the best", "right"),
                             (escape(f"misfit after [{unit}]"), "right")):
            t.add_column(col, justify=justify, overflow="fold")
        for i, r in enumerate(rows, start=1):
            t.add_row(str(i), escape(r["effect"]), escape(r["location"]), escape(r["parameters"]),
                      r["delta_bic"], r["misfit_after"])
        console.print(t)
    console.print(escape(verdict(d)), highlight=False)
    console.print(f"report: {escape(str(out_path / 'diagnosis.md'))}", highlight=False)


def detectability(
    structure: str = arg_structure(),
    controller: ExpController = opt(ExpController("none"), "--controller",
                                    help="controller running during the test (none = open loop)"),
    effect: list[str] = opt(None, "--effect", metavar="<effect>",
                            help="only this effect of the library (repeatable; default: all one-parameter "
                                 "effects): added_mass, support_stiffness, joint_flexibility, member_stiffness, "
                                 "damping, loop_delay, actuator_lag, sensor_lag, actuator_gain, sensor_gain, "
                                 "gravity_prestress, saturation"),
    noise: float = opt(1e-6, "--noise", help="velocity-sensor noise standard deviation [m/s], >= 0"),
    seed: int = opt(0, "--seed", help="seed of the excitation, the noise and the design's multi-start"),
    out: str = opt(None, "--out", help="also write detectability.json and a figure into this folder"),
    overwrite: bool = flag("--overwrite", help="replace an existing non-empty output folder"),
    model_form: str = opt("derived", "--model-form", metavar="<derived|plant|none>",
                          help="derived: thresholds of a real measurement, within the model's own uncertainty "
                               "(calibration residual, plant discretisation); plant: of a recording made by the "
                               "MuJoCo plant (an exported plant with a concealed effect); none: of a recording "
                               "made by the model itself"),
    naming: bool = typer.Option(True, "--naming/--no-naming",
                                help="also the smallest size at which the diagnosis names the effect among its "
                                     "look-alikes (every one-parameter effect of the library; minutes)"),
    yes: bool = flag("--yes", help="go on with a loop estimated (from its first item) to take more than 30 min"),
    fmt: OutputFormat = format_opt(),
    as_json: bool = json_flag(),
    quiet: bool = quiet_flag(),
) -> None:
    """Smallest size of each effect of the library, at each location, that the diagnosis detects and names.

    Each loop (the thresholds, the look-alikes, the naming) is estimated from its first item (on stderr); a loop
    estimated beyond 30 min stops there unless --yes.
    """
    from ..diagnose.detectability import MODEL_FORMS, detectability as run, figure
    from ..diagnose.effects.hypotheses import EFFECTS
    from ..experiment.results import jsonable
    from ..io.atomic import atomic_dir

    out_fmt = checks.output_format(fmt, as_json)
    if not (math.isfinite(noise) and noise >= 0):
        raise OptionError(f"--noise must be a finite number >= 0 [m/s], got {noise!r}")
    unknown = [e for e in effect or () if e not in EFFECTS]
    if unknown:
        raise OptionError(f"--effect {', '.join(unknown)}: not an effect of the library ({', '.join(EFFECTS)})")
    if model_form not in MODEL_FORMS:
        raise OptionError(f"--model-form {model_form!r}: use one of {', '.join(MODEL_FORMS)}")
    spec = checks.load_structure(structure)
    checks.seed(seed)
    out_path = checks.out_dir(out, DETECT_OUT, overwrite) if out is not None else None
    with stages("detectability", "recording the nominal test", quiet=quiet or out_fmt != "table") as say:
        res = run(spec, controller.value, effects=tuple(effect) if effect else None, noise_m_s=noise, seed=seed,
                  model_form=model_form, naming=naming, progress=say,
                  confirm=lambda seconds, what: checks.confirm_long_run(
                      "vlab detectability", seconds, what, yes, "fewer effects (--effect) or --no-naming"))
    d = res.as_dict()
    if out_path is not None:
        with atomic_dir(out_path, overwrite=overwrite, create_parent=False) as tmp:
            (tmp / "detectability.json").write_text(json.dumps(jsonable(d), indent=2))
            figure(res, spec, tmp / "added_mass.png")
    if out_fmt == "json":
        print_json(d)
        return
    _print_thresholds(out_fmt, res, spec, controller.value, noise, naming)


def _print_thresholds(out_fmt: str, res, spec, controller: str, noise: float, naming: bool) -> None:
    """The thresholds of ``vlab detectability`` as a table or CSV (units in the cells)."""
    from ..diagnose.report.text import format_location, parameter_unit
    from ..io.tabular import Column

    rows = []
    for t in res.thresholds:
        q, unit = parameter_unit(t.parameter)
        rel = (100 * (t.threshold / t.null - 1) if t.threshold is not None and t.null not in (None, 0.0) else None)
        rows.append({"effect": t.effect, "location": format_location(t.location),
                     "parameter": f"{q} [{unit}]" if unit else q,
                     "null": "limit" if t.null is None else f"{t.null:.4g}",
                     "threshold": "not detected in range" if t.threshold is None else f"{t.threshold:.3g}",
                     "change_pct": rel, "test": t.by or "",
                     "named": ("" if not naming else "not named in range" if t.named_at is None
                               else f"{t.named_at:.3g}"),
                     "look_alike": (f"{t.look_alike} ({t.look_alike_chi2:.3g})" if t.look_alike else "")})
    cols = [Column("effect", "effect"), Column("location", "location"), Column("parameter", "parameter [unit]"),
            Column("null", "null value"), Column("threshold", "threshold"),
            Column("change_pct", "change [%]", "+.3g"), Column("test", "found by")]
    if naming:
        cols += [Column("named", "named from"), Column("look_alike", "closest look-alike (chi2)")]
    print_rows(out_fmt, rows, cols, f"{spec.title}, {controller}: smallest detectable size of each effect "
                                    f"(noise {noise:g} m/s; chi2 limit {res.chi2_limit:.4g}, "
                                    f"N = {res.n_obs})")
    if out_fmt == "table" and res.skipped:
        console.print(f"not computed (more than one parameter): {', '.join(res.skipped)}", highlight=False)
