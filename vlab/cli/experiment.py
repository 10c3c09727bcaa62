"""``vlab experiment``: a closed-loop experiment on the virtual lab, measured like a modal test and compared
with the analysis; ``vlab export-mjcf``: the plant it runs as an MJCF file.
"""

from __future__ import annotations

from enum import Enum
from pathlib import Path

import typer
from rich.markup import escape

from ..errors import OptionError, ResourceError, VlabError
from ..lab.blocks import PC1000_DELAY_PERIODS
from ..units import format_bytes, format_duration
from . import checks
from .options import (REDUCTION_HELP, STRUCTURE_HELP, DesignReduction, ExpController, OutputFormat, PlantKind,
                      arg, arg_structure, flag, format_opt, opt)
from .output import console, err_console, error_line, print_json, print_rows, print_warnings
from .runtime import expect_output


class Excitation(str, Enum):
    """``--excitation``: the force at the excitation point."""

    random = "random"
    sweep = "sweep"
    impulse = "impulse"


EXPERIMENT_OUT = "out/experiment"


def experiment(
    structure: str = arg("bcc", help=STRUCTURE_HELP),
    controller: ExpController = opt(ExpController.mfdrf, "--controller",
                                    help="controller in the loop: none (open loop), LQG, MFDRF, LQDRF or LQDRF "
                                         "with a diagonal gain (LQR needs the full state: run it as LQG)"),
    reduction: DesignReduction = opt(None, "--reduction", help=REDUCTION_HELP + "; not with --controller none"),
    excitation: Excitation = opt(Excitation.random, "--excitation",
                                 help="force at the excitation point, periodic over one record in the structure's "
                                      "band (Sec. 5.4): pseudo-random, linear sweep or half-sine impulse"),
    duration: float = opt(
        None, "--duration", help="run length [s], at least 2 records of 1/resolution (BCC: 2 x 20 s = 40 s; "
                                 "grid: 2 x 50 s = 100 s) (default: the records the slowest mode needs to settle "
                                 "+ 2 measured)"),
    delay_periods: float = opt(None, "--delay-periods", "--delay-samples",
                               help=f"computation delay [sampling periods], >= 0 (Sec. 5.3; default {PC1000_DELAY_PERIODS:g}); "
                                    "given, "
                                    "it also replaces the per-channel delays of the structure file's [hardware] "
                                    "table, whose other settings the run always uses"),
    period_ms: float = opt(None, "--period-ms",
                           help="controller sampling period [ms], > 0 (default: the thesis's for the "
                                "controller, Sec. 5.3: LQG 1 ms, the others 0.5 ms)"),
    noise: float = opt(1e-6, "--noise", help="velocity-sensor noise standard deviation [m/s], >= 0 (0 = off)"),
    seed: int = opt(0, "--seed", help="seed of the excitation, the sensor noise and the design's multi-start, "
                                      "an integer in [0, 2**32)"),
    mjcf: str = opt(None, "--mjcf", help="MJCF file exported by `vlab export-mjcf` (and edited) to run instead "
                                         "of the built plant; needs --plant mujoco (default: none)"),
    plant: PlantKind = opt(PlantKind.mujoco, "--plant",
                           help="plant: the MuJoCo model or the linear FE model stepped exactly (fast)"),
    out: str = opt(EXPERIMENT_OUT, "--out", help="output folder (its parent must exist)"),
    overwrite: bool = flag("--overwrite", help="replace an existing non-empty output folder"),
    spawn: bool = flag("--spawn", help="open the rerun viewer live (needs a display)"),
    log_freq: bool = flag("--log-freq", help="draw frf.png's frequency on a logarithmic axis (default linear, "
                                             "as the dissertation's Figs. 22-31)"),
    fmt: OutputFormat = format_opt(),
    as_json: bool = flag("--json", help="print results.json to stdout instead of the table (= --format json)"),
    allow_unstable: bool = flag("--allow-unstable",
                                help="exit 0 even when the comparison is not meaningful: a warning says so, "
                                     "the loop is predicted unstable or the delay is at least one record"),
    yes: bool = flag("--yes", help="run an experiment estimated to take more than 30 min (plant build and loop)"),
) -> None:
    """Run a closed-loop experiment (DRF at 2 kHz, LQG at 1 kHz as Sec. 5.3), measure it like a modal test.

    Every option is checked before the run starts; the run's memory and time are estimated and a run that
    does not fit in the available memory is refused, one estimated beyond 30 min asks for --yes. The
    outputs are written atomically; a run whose own
    warning calls the comparison not meaningful (self-excited oscillation, limit cycle), whose loop the analysis
    predicts unstable (a negative predicted damping ratio) or whose delay is at least one record exits with
    status 1 unless --allow-unstable.
    """
    from ..experiment.results import write_outputs

    out_fmt = checks.output_format(fmt, as_json)
    spec = checks.load_structure(structure)
    out_path = checks.out_dir(out, EXPERIMENT_OUT, overwrite)
    file_delays = () if delay_periods is None or spec.hardware is None else tuple(spec.hardware.delay_s)
    delay_periods = PC1000_DELAY_PERIODS if delay_periods is None else delay_periods
    cfg = _config(spec, controller=controller, reduction=reduction, excitation=excitation, duration=duration,
                  delay_periods=delay_periods, period_ms=period_ms, noise=noise, seed=seed, mjcf=mjcf, plant=plant,
                  spawn=spawn, file_delays=file_delays)
    fe = checks.fe_model_of(spec)
    _guard_experiment(fe, plant=plant.value, period_s=cfg.chain.period_s, duration_s=duration,
                      delay_periods=delay_periods, quiet=out_fmt != "table", yes=yes,
                      build=None if plant.value != "mujoco" or mjcf else checks.plant_estimate(spec))
    expect_output(out_path)
    result = _run(cfg, fe, out_path, overwrite=overwrite, create_parent=out == EXPERIMENT_OUT,
                  quiet=out_fmt != "table")
    if out == EXPERIMENT_OUT:
        out_path.absolute().parent.mkdir(parents=True, exist_ok=True)
    files = write_outputs(result, fe.spec, out_path, spawn=spawn, overwrite=overwrite, log_freq=log_freq)
    blocking = _report(result, files, fe, controller.value, out_fmt)
    if blocking and not allow_unstable:
        error_line(f"the comparison is not meaningful ({blocking[0]}); outputs written to "
                   f"{files['results'].parent}/; use --allow-unstable to exit 0")
        raise typer.Exit(code=1)


def _config(spec, *, controller: ExpController, reduction: DesignReduction | None, excitation: Excitation,
            duration: float | None, delay_periods: float, period_ms: float | None, noise: float, seed: int,
            mjcf: str | None, plant: PlantKind, spawn: bool, file_delays: tuple = ()):
    """The run's :class:`~vlab.experiment.config.ExperimentConfig`, every option checked (OptionError: exit 2);
    ``file_delays``: channels of the file's per-channel delays that the given ``--delay-periods`` replaces."""
    from ..experiment.config import ExperimentConfig, default_chain, test_definition

    checks.number("--noise", noise, low=0.0, what="sensor noise sigma [m/s]")
    checks.number("--delay-periods", delay_periods, low=0.0, what="computation delay [sampling periods]")
    checks.number("--duration", duration, low=0.0, low_open=True, what="run length [s]")
    period_s = checks.period_s(period_ms)
    checks.seed(seed)
    if reduction is not None and controller is ExpController.none:
        raise OptionError(f"--reduction {reduction.value} has no effect with --controller none (no design)")
    if mjcf is not None:
        if plant is PlantKind.linear:
            raise OptionError(f"--mjcf {mjcf} runs a MuJoCo plant: it contradicts --plant linear")
        checks.mjcf_input(mjcf)
    if spawn:
        from ..viz.viewer import viewer_unavailable_reason

        why = viewer_unavailable_reason()
        if why is not None:
            raise OptionError(f"--spawn: the rerun viewer cannot be started here ({why}); run without --spawn "
                              "and open run.rrd with `rerun` where there is a display")
    chain = default_chain(controller.value, delay_periods=delay_periods, noise_m_s=noise,
                          channel_delay_periods={p: delay_periods for p in file_delays},
                          **({} if period_s is None else {"period_s": period_s}))
    test = test_definition(spec)
    if duration is not None and duration < 2.0 / test.resolution_hz - 1e-9:
        raise OptionError(f"--duration {duration:g} s is too short for the {test.resolution_hz:g} Hz resolution: "
                          f"one record of {1 / test.resolution_hz:g} s settles and at least one is measured "
                          f"(>= {2 / test.resolution_hz:g} s)")
    return ExperimentConfig(
        structure=spec.name, controller=controller.value,
        reduction=reduction.value if reduction else None, excitation=excitation.value, duration_s=duration,
        chain=chain, seed=seed, plant=plant.value,
        mjcf=Path(mjcf) if mjcf else None,
    )


def _run(cfg, fe, out_path: Path, *, overwrite: bool, create_parent: bool, quiet: bool):
    """The run with a progress bar on stderr; after a failure, the recording up to it is kept in ``out_path``."""
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

    from ..diagnose.instability_cause import oscillation_cause
    from ..experiment.runner import run_experiment
    from ..io.atomic import atomic_dir

    try:
        with Progress(TextColumn("{task.description}"), BarColumn(), TextColumn("{task.percentage:>3.0f} %"),
                      TimeElapsedColumn(), TextColumn("ETA"), TimeRemainingColumn(),
                      console=err_console, transient=True, disable=quiet) as bar:
            task = bar.add_task(f"{cfg.structure} {cfg.controller}: simulating", total=1.0)
            return run_experiment(cfg, fe, progress=lambda x: bar.update(task, completed=x),
                                  explain_oscillation=oscillation_cause)
    except VlabError as exc:
        partial = getattr(exc, "partial", None)
        if partial is not None:
            from ..io.uff import write_recording

            with atomic_dir(out_path, overwrite=overwrite, create_parent=create_parent) as tmp:
                write_recording(tmp / "recording_partial.uff", partial.recording, overwrite=False)
            err_console.print(f"the recording up to the failure is kept in {escape(str(out_path))}/recording_partial.uff",
                              highlight=False, soft_wrap=True)
        raise


def _report(result, files: dict, fe, controller: str, out_fmt: str) -> list[str]:
    """Print the run's warnings and its comparison (table, CSV or JSON); return why it is not meaningful."""
    from ..experiment.results import experiment_summary, failed_premises
    from ..experiment.checks import not_meaningful
    from ..io.tabular import Column

    summary = experiment_summary(result)
    premise = failed_premises(result)
    blocking = premise + not_meaningful(result.warnings)
    print_warnings(premise)
    print_warnings(files["warnings"])
    if out_fmt == "json":
        print_json(summary)
        return blocking
    rows = [{"mode": m.mode, "frequency_predicted_hz": m.frequency_predicted_hz,
             "frequency_measured_hz": m.frequency_measured_hz, "damping_ratio_predicted": m.damping_predicted,
             "damping_ratio_measured": m.damping_measured, "peak_level_ratio": m.peak_level_ratio}
            for m in result.modes]
    cols = [Column("mode", "mode"), Column("frequency_predicted_hz", "f pred [Hz]", ".3f"),
            Column("frequency_measured_hz", "f meas [Hz]", ".3f"),
            Column("damping_ratio_predicted", "zeta pred [-]", ".4f"),
            Column("damping_ratio_measured", "zeta meas [-]", ".4f"),
            Column("peak_level_ratio", "peak ratio pred/meas [-]", ".3f")]
    if out_fmt == "csv":
        print_rows(out_fmt, rows, cols)
        print_warnings(result.warnings)
        return blocking
    print_rows(out_fmt, rows, cols, f"{fe.spec.title}, {controller}: analysis vs experiment on the {summary['plant']}")
    from ..experiment.config import period_source

    source = period_source(controller, summary["period_s"], fe.spec)
    console.print(f"analysis: the sampled-data loop (hold, delay, RC filter); sampling period "
                  f"{summary['period_s'] * 1e3:g} ms ({escape(source)})", highlight=False)
    console.print(f"average peak level error: {result.avg_peak_error:.3f}   outputs: "
                  f"{escape(str(files['results'].parent))}/", highlight=False)
    _print_shapes(result, files, fe)
    print_warnings(result.warnings)
    return blocking


def _print_shapes(result, files: dict, fe) -> None:
    """The identified mode shapes' table (frequency, damping, MPC, paired FE mode, MAC); the shapes
    themselves are in shapes.csv."""
    from ..experiment.shape_results import shape_rows

    if result.shapes is None:
        return
    rows, cols = shape_rows(result)
    sh = result.shapes
    print_rows("table", rows, cols[:8],
               f"mode shapes identified at points {', '.join(map(str, sh.point_ids))} (excitation at "
               f"{sh.reference_point}) vs the FE model, paired by MAC")
    console.print(f"shapes at the points: {escape(files['shapes'].name)}, figure: "
                  f"{escape(files['shapes_figure'].name)}", highlight=False)


def _guard_experiment(fe, *, plant: str, period_s: float, duration_s: float | None, delay_periods: float,
                      quiet: bool, yes: bool = False, build: dict | None = None) -> dict[str, float]:
    """Refuse a run that cannot fit in memory, whose delay exceeds it or that would take more than 30 min
    without ``yes`` (the loop and, with ``build`` from :func:`checks.plant_estimate`, the plant's build);
    print the estimate."""
    from ..experiment.estimate import available_memory_bytes, estimate_experiment

    est = estimate_experiment(fe, plant=plant, period_s=period_s, duration_s=duration_s, delay_periods=delay_periods)
    if delay_periods >= est["n_ticks"]:
        raise OptionError(f"--delay-periods {delay_periods:g} is longer than the whole run "
                          f"({est['n_ticks']:.0f} sampling periods of {est['duration_s']:g} s): the controller "
                          "output would never reach the coils")
    avail = available_memory_bytes()
    if avail is not None and est["memory_bytes"] > 0.8 * avail:
        raise ResourceError(
            f"the run ({est['duration_s']:g} s, {est['n_ticks']:.3g} ticks, delay line {delay_periods:g} "
            f"periods) would need about {format_bytes(est['memory_bytes'])} of memory; "
            f"{format_bytes(avail)} is available: shorten --duration or --delay-periods")
    build_s = 0.0 if build is None else build["time_s"]
    what = f"{est['n_ticks']:.3g} ticks" + ("" if build is None else f", a plant of {build['what']}")
    checks.confirm_long_run("--duration" if duration_s is not None else "the run", est["time_s"] + build_s, what,
                            yes, "a shorter --duration" + ("" if build is None else
                                                           " or a coarser plant ([mujoco] segments_per_element)"))
    if not quiet:
        bound = "at most " if duration_s is None else ""  # the open loop's settling: a controller settles sooner
        built = "" if build is None else f", ~{format_duration(build_s)} to build the plant ({build['what']})"
        err_console.print(f"estimate: {bound}{est['duration_s']:g} s simulated, {est['n_ticks']:.0f} ticks, "
                          f"~{format_bytes(est['memory_bytes'])} memory, {bound}~{format_duration(est['time_s'])} for the "
                          f"loop{built} (plus design and outputs)", highlight=False, soft_wrap=True)
    return est


def export_mjcf_cmd(
    structure: str = arg_structure(),
    output: str = opt(None, "-o", "--output",
                      help="MJCF file to write, ending in .xml; its folder must exist (default: <structure>.xml)"),
    overwrite: bool = flag("--overwrite", help="replace an existing file"),
    yes: bool = flag("--yes", help="build a plant estimated to take more than 30 min"),
) -> None:
    """Write the complete MuJoCo plant as MJCF, to edit and run with `vlab experiment --mjcf`.

    The plant's size is checked and its build time estimated first; beyond 30 min it asks for --yes.
    """
    from ..io.atomic import check_output_file
    from ..sim import build_plant, export_mjcf

    spec = checks.load_structure(structure)
    path = check_output_file(f"{spec.name}.xml" if output is None else output, overwrite=overwrite,
                             option="--output", suffix=".xml")
    build = checks.plant_estimate(spec)
    checks.confirm_long_run(structure, build["time_s"], f"a plant of {build['what']}", yes,
                            "a coarser plant ([mujoco] segments_per_element)")
    written = export_mjcf(build_plant(spec), path, overwrite=overwrite)
    console.print(f"wrote {escape(str(written))}", highlight=False)
