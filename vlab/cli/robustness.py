"""``vlab robustness``: the Monte Carlo robustness study of the controllers designed on the nominal model."""

from __future__ import annotations

import json
from dataclasses import replace

from rich.markup import escape
from rich.table import Table

from ..errors import OptionError
from ..lab.blocks import PC1000_DELAY_PERIODS
from . import checks
from .options import arg, flag, opt, quiet_flag
from .output import console, print_json, stages
from .runtime import expect_output

ROBUSTNESS_OUT = "out/robustness"


def robustness(
    structure: str = arg(..., help="structure: bcc (Beam Cross-Cable), grid (Hanging Grid) or a "
                                              "structure file (TOML, with [instrumentation] and [test]; `vlab "
                                              "init` writes one)", show_default=False),
    samples: str = opt("1000", "--samples", metavar="<integer>",
                       help="Monte Carlo samples, >= 1 (1e4 is read as 10000); a study estimated to take more "
                            "than 30 min asks for --yes (a structure file's study is estimated after its designs, "
                            "from one sample and a short MuJoCo run)"),
    seed: int = opt(0, "--seed", help="seed of the draws (sample i draws from default_rng([seed, i])) and of the "
                                      "designs' multi-start, an integer in [0, 2**32)"),
    uncertainty: str = opt(None, "--uncertainty",
                           help="TOML of distributions ([parameters.<group>] kind, spread, source) replacing the "
                                "defaults: EI ±5 %, section mass ±3 %, cable tension ±10 %, lumped masses ±10 %, "
                                "coil masses ±10 %, support springs ±10 %, delay 1.15-1.55 periods, actuator "
                                "gains ±5 %, sensor gains ±5 %, all uniform and assumed (the dissertation states "
                                "no tolerances; EI measured, Sec. 2.1; masses calibrated, Tables 1 and 8; delay "
                                f"{PC1000_DELAY_PERIODS:g} periods measured, Sec. 5.3); each group's source in robustness.json"),
    scheduler: str = opt("local", "--scheduler",
                         help="where the chunks run: local (a Dask LocalCluster, one process per CPU), none "
                              "(this process) or tcp://HOST:PORT (an existing Dask scheduler, which must answer "
                              "within 8 s, before any computation)"),
    workers: int = opt(None, "--workers", help="processes of the local cluster (default: one per CPU)"),
    chunk_size: int = opt(25, "--chunk-size", help="samples per independent chunk, >= 1"),
    controllers: str = opt("mfdrf,lqdrf,lqdrf-diag,lqg", "--controllers",
                           help="comma-separated subset of mfdrf, lqdrf, lqdrf-diag, lqg"),
    simulate: int = opt(4, "--simulate",
                        help="worst samples per controller (by the linear measure) also run in time on the "
                             "batched MuJoCo lab, >= 0"),
    simulate_random: int = opt(None, "--simulate-random",
                               help="samples per controller drawn at random and run on the MuJoCo lab, >= 0: "
                                    "the MuJoCo plant's P(unstable) is estimated from them (default: 100 for the "
                                    "BCC, 10 for the grid, whose 12 s runs take about 6 s each, and for a "
                                    "structure file)"),
    yes: bool = flag("--yes", help="run a study estimated to take more than 30 min"),
    out: str = opt(ROBUSTNESS_OUT, "--out", help="output folder (its parent must exist)"),
    overwrite: bool = flag("--overwrite", help="replace an existing non-empty output folder"),
    markdown_copy: str = opt(None, "--markdown", help="also write robustness.md to this file; an existing file is "
                                                       "replaced only with --overwrite (default: none)"),
    as_json: bool = flag("--json", help="print robustness.json to stdout instead of the table"),
    quiet: bool = quiet_flag(),
) -> None:
    """Monte Carlo robustness of MFDRF, LQDRF, LQDRF-diag and LQG, designed on the nominal model (Sec. 7).

    Per controller and per plant: P(unstable) with its Wilson interval, the median analysis/experiment
    peak-ratio error (Table 10) and the closed-loop damping change with their intervals. Plants: the exact
    sampled-data loop on every perturbed FE model, and the MuJoCo plant run in time for the worst and for
    randomly drawn samples (a run that self-excites counts as unstable there and its peak ratios are not
    used; its damping comes from the sampled-data loop on that plant's linearisation). Progress and a
    run-time estimate on stderr. Outputs: robustness.json, samples.npz, robustness.png,
    worst_time_history.png, robustness.md, worst.rrd.
    """
    from ..io.atomic import atomic_dir
    from ..robust.pipeline import default_random, mujoco_runs, run_pipeline
    from ..robust.report import write_outputs
    from ..robust.scheduler import confirm_size, parse_samples, parse_scheduler
    from ..robust.study import StudyConfig, default_workers, is_dissertation, study_spec
    from ..robust.uncertainty import defaults_for, load_uncertainties

    checks.seed(seed)
    checks.load_structure(structure)
    n_samples = parse_samples(samples)
    sched = parse_scheduler(scheduler)
    simulate_random = _check_counts(workers, simulate, default_random(structure) if simulate_random is None
                                    else simulate_random)
    cfg_controllers = tuple(c.strip() for c in controllers.split(",") if c.strip())
    confirm_size(samples, structure, n_samples, len(cfg_controllers),
                 1 if sched is None else (workers or default_workers()), yes,
                 runs=mujoco_runs(len(cfg_controllers), n_samples, simulate, simulate_random))
    out_path = checks.out_dir(out, ROBUSTNESS_OUT, overwrite)
    if markdown_copy is not None:
        from ..io.atomic import check_output_file

        check_output_file(markdown_copy, overwrite=overwrite, option="--markdown")
    checks.input_file("--uncertainty", uncertainty)
    cfg = StudyConfig(structure=structure, n_samples=n_samples, seed=seed, chunk_size=chunk_size,
                      controllers=cfg_controllers)
    study_spec(cfg)  # a structure file without [test] or actuators is refused before anything runs
    defaults = defaults_for(is_dissertation(cfg))
    uncs = load_uncertainties(uncertainty, defaults) if uncertainty else defaults
    cfg = replace(cfg, uncertainties=uncs)
    expect_output(out_path)
    with stages("robustness", "starting", quiet=quiet or as_json) as say:
        nominal, res, summary, study_checks, timings, extras = run_pipeline(
            cfg, scheduler=sched, workers=workers, n_worst=simulate, n_random=simulate_random, progress=say,
            yes=yes, samples_text=samples)
    command = _command_line(cfg, uncertainty=uncertainty, controllers=controllers, simulate=simulate,
                            simulate_random=simulate_random)
    with atomic_dir(out_path, overwrite=overwrite, create_parent=out == ROBUSTNESS_OUT) as tmp:
        files = write_outputs(tmp, cfg, nominal, res, summary, study_checks, timings, command, extras=extras)
    if markdown_copy is not None:
        from ..io.atomic import atomic_file

        with atomic_file(markdown_copy, overwrite=overwrite) as tmp_md:
            tmp_md.write_text((out_path / "robustness.md").read_text())
    if as_json:
        print_json(json.loads((out_path / "robustness.json").read_text()))
        return
    _print_robustness(json.loads((out_path / "robustness.json").read_text()), n_samples, structure)
    console.print(f"outputs: {escape(str(out_path))}/ ({len(files)} files) in {timings['total']:.0f} s",
                  highlight=False)


def _check_counts(workers: int | None, simulate: int, simulate_random: int) -> int:
    """``--workers`` (>= 1), ``--simulate`` and ``--simulate-random`` (>= 0) checked; ``simulate_random`` back.

    Raises
    ------
    OptionError
        A count out of range, naming the option and the value.
    """
    if workers is not None and workers < 1:
        raise OptionError(f"--workers must be >= 1, got {workers!r}")
    for name, value in (("--simulate", simulate), ("--simulate-random", simulate_random)):
        if value < 0:
            raise OptionError(f"{name} must be >= 0, got {value!r}")
    return simulate_random


def _command_line(cfg, *, uncertainty: str | None, controllers: str, simulate: int, simulate_random: int) -> str:
    """The ``vlab robustness`` command that reruns the study of ``cfg`` (options at their defaults left out)."""
    from ..robust.pipeline import default_random
    from ..robust.study import CONTROLLERS as CONTROLLER_ORDER

    return f"vlab robustness {cfg.structure} --samples {cfg.n_samples} --seed {cfg.seed}" + (
        f" --uncertainty {uncertainty}" if uncertainty else "") + (
        f" --controllers {controllers}" if cfg.controllers != CONTROLLER_ORDER else "") + (
        f" --simulate {simulate}" if simulate != 4 else "") + (
        f" --simulate-random {simulate_random}" if simulate_random != default_random(cfg.structure) else "")


def _print_robustness(data: dict, n_samples: int, structure: str) -> None:
    """The per-plant table of ``vlab robustness`` (probabilities with Wilson intervals) and Sec. 7 per plant."""
    names = {"fe_sampled_loop": "FE sampled loop", "mujoco_time_simulation": "MuJoCo, time simulation"}
    name = data.get("structure_title") or structure
    t = Table(title=f"{name}: {n_samples} samples, controllers designed on the nominal model")
    for col in ("controller", "plant", "samples", "P(unstable) [95 %]", "peak-ratio error [dB] [95 %]",
                "damping change [95 %]", "works at nominal"):
        t.add_column(escape(col), justify="right")
    for c in data["per_plant"]["fe_sampled_loop"]:
        for plant, per in data["per_plant"].items():
            v = per[c]
            p, ci = v["probability_unstable"], v["probability_unstable_ci95"]
            e, dz = v["peak_ratio_error_db_median"], v.get("damping_change_relative_median")
            eci, dci = v.get("peak_ratio_error_db_median_ci95"), v.get("damping_change_relative_median_ci95")
            n = v.get("samples", v.get("simulated_random_samples"))
            t.add_row(c, names.get(plant, plant), str(n),
                      "n/a" if p is None else f"{100 * p:.1f} % [{100 * ci[0]:.1f}, {100 * ci[1]:.1f}]",
                      _with_ci(e, eci, ".3f"), _with_ci(dz, dci, ".2f", 100, " %"),
                      {True: "yes", False: "no"}.get(v.get("working_loop_at_nominal"), ""))
    console.print(t)
    lead = "Sec. 7" if data.get("dissertation_structure", True) else "The controllers"
    for plant, text in data["sec7_on_plants"].items():
        console.print(f"{lead} on the {names.get(plant, plant)}: {text}", highlight=False, soft_wrap=True)


def _with_ci(v, ci, fmt: str, scale: float = 1.0, unit: str = "") -> str:
    """``v`` and its interval, e.g. ``"8.94 % [8.67, 9.39]"``; ``"n/a"`` for None."""
    if v is None or v != v or v in (float("inf"), float("-inf")):
        return "n/a"
    text = f"{scale * v:{fmt}}{unit}"
    return text + (f" [{scale * ci[0]:{fmt}}, {scale * ci[1]:{fmt}}]" if ci and ci[0] is not None else "")
