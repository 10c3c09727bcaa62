"""The ``vlab`` command line.

Thin: every command parses its options, calls the library and prints a rich
table or, with ``--json``, one JSON object with stable keys (README lists
them). Errors of vlab (bad input, singular models, diverging simulations) are
printed as one clear line and exit with status 2; nothing else is caught.
"""

from __future__ import annotations

import json
import sys
from enum import Enum
from typing import Any

import numpy as np
import typer
from rich.console import Console
from rich.table import Table

from .errors import VlabError

app = typer.Typer(
    add_completion=False,
    no_args_is_help=True,
    help="vlab: a virtual laboratory for active vibration control of flexible structures.",
)
console = Console()


@app.callback()
def _root() -> None:
    """vlab: a virtual laboratory for active vibration control of flexible structures."""

err_console = Console(stderr=True)


class Structure(str, Enum):
    bcc = "bcc"
    grid = "grid"


class Reduction(str, Enum):
    full = "full"
    exact = "exact"
    guyan = "guyan"


def _fail(exc: Exception) -> None:
    err_console.print(f"[bold red]error:[/] {exc}")
    raise typer.Exit(code=2)


def _print_json(obj: dict[str, Any]) -> None:
    def default(o: Any) -> Any:
        if isinstance(o, np.ndarray):
            return o.tolist()
        if isinstance(o, (np.floating, np.integer)):
            return o.item()
        raise TypeError(f"not JSON serialisable: {type(o).__name__}")

    sys.stdout.write(json.dumps(obj, default=default, indent=2) + "\n")


def _pad(values: np.ndarray, n: int) -> list[float | None]:
    out: list[float | None] = [float(v) for v in values[:n]]
    return out + [None] * (n - len(out))


@app.command()
def modes(
    structure: Structure = typer.Argument(..., help="bcc or grid"),
    reduction: Reduction = typer.Option(Reduction.full, help="full model, exact reduction or Guyan reduction"),
    n: int = typer.Option(12, "--n", min=1, help="number of modes"),
    as_json: bool = typer.Option(False, "--json", help="print one JSON object"),
) -> None:
    """Natural frequencies against the dissertation's Table 1 (BCC) or Table 3 (grid)."""
    from .fe import modal_analysis
    from .models import nominal_fe_model, reduce_model
    from .reference import column

    try:
        fe = nominal_fe_model(structure.value)
        if reduction is Reduction.full:
            f = modal_analysis(fe.m, fe.k, n).frequencies_hz
        else:
            red = reduce_model(fe, reduction.value)
            f = red.natural_frequencies_hz()[:n]
        table = fe.spec.reference["frequencies"]
        ref_a = column(table, "analytical_hz")
        ref_e = column(table, "experimental_hz")
    except VlabError as exc:
        _fail(exc)
    n_shown = len(f)
    if as_json:
        _print_json(
            {
                "structure": structure.value,
                "reduction": reduction.value,
                "frequencies_hz": f,
                "reference_analytical_hz": _pad(ref_a, n_shown),
                "reference_experimental_hz": _pad(ref_e, n_shown),
                "reference_table": table,
            }
        )
        return
    t = Table(title=f"{fe.spec.title}: natural frequencies ({reduction.value} model) vs {table}")
    for col in ("mode", "vlab [Hz]", "thesis analytical [Hz]", "error", "thesis experimental [Hz]", "error"):
        t.add_column(col, justify="right")
    for i in range(n_shown):
        row = [str(i + 1), f"{f[i]:.3f}"]
        for ref in (ref_a, ref_e):
            if i < len(ref):
                row += [f"{ref[i]:.3f}", f"{100 * (f[i] / ref[i] - 1):+.2f} %"]
            else:
                row += ["", ""]
        t.add_row(*row)
    console.print(t)


class ControllerName(str, Enum):
    lqr = "lqr"
    lqg = "lqg"
    mfdrf = "mfdrf"
    lqdrf = "lqdrf"
    lqdrf_diag = "lqdrf-diag"


class DesignReduction(str, Enum):
    full = "full"
    exact = "exact"
    guyan = "guyan"
    corrected_guyan = "corrected-guyan"


@app.command()
def design(
    structure: Structure = typer.Argument(..., help="bcc or grid"),
    controller: ControllerName = typer.Option(ControllerName.mfdrf, "--controller", help="controller type"),
    reduction: DesignReduction = typer.Option(None, "--reduction", help="design model (default: thesis choice)"),
    modes_file: str = typer.Option(None, "--modes", help="UFF 55 measured modes for corrected-guyan"),
    seed: int = typer.Option(0, help="seed of the optimiser's multi-start"),
    period_ms: float = typer.Option(None, "--period-ms",
                                    help="sampling period of the realization [ms] (default: the thesis's, "
                                         "LQG 1, others 0.5)"),
    as_json: bool = typer.Option(False, "--json", help="print one JSON object"),
) -> None:
    """Design a controller with the dissertation's settings; print gains, damping and performance."""
    from .design import design_controller
    from .io.results import design_summary
    from .lab.experiment import period_source
    from .models import nominal_fe_model

    try:
        period_s = _period_s(period_ms)
        fe = nominal_fe_model(structure.value)
        measured = _measured_modes(fe, modes_file) if reduction is DesignReduction.corrected_guyan else None
        d = design_controller(fe, controller.value, model=reduction.value if reduction else None,
                              measured_modes=measured, seed=seed, period_s=period_s)
    except (VlabError, ValueError) as exc:
        _fail(exc)
    if as_json:
        _print_json({**design_summary(d), "period_source": period_source(d.controller, d.period_s)})
        return
    console.print(f"[bold]{structure.value} {d.controller}[/] on the {d.model} model — converged: {d.converged} ({d.message})")
    console.print(f"sampling period {d.period_s * 1e3:g} ms ({period_source(d.controller, d.period_s)})")
    if d.gamma is not None:
        console.print(f"gamma = {d.gamma:.4f} lb*s/in" + (f", beta = {d.beta:.4g}" if d.beta is not None else ""))
    g = d.extra.get("gain_thesis_lb_s_per_in")
    if g is not None:
        console.print("D in lb*s/in (thesis units, the form of Tables 7, 11, 15):")
        console.print(np.array2string(np.asarray(g), precision=4, suppress_small=True))
    t = Table(title="closed loop on the design model")
    for col in ("mode", "f [Hz]", "zeta", "J (modal IC)"):
        t.add_column(col, justify="right")
    for i in range(max(len(d.performance_index), 6)):
        if i >= len(d.damping_ratios):
            break
        j = f"{d.performance_index[i]:.4g}" if i < len(d.performance_index) else ""
        t.add_row(str(i + 1), f"{d.frequencies_hz[i]:.3f}", f"{d.damping_ratios[i]:.4f}", j)
    console.print(t)


class ExpController(str, Enum):
    none = "none"
    lqr = "lqr"
    lqg = "lqg"
    mfdrf = "mfdrf"
    lqdrf = "lqdrf"
    lqdrf_diag = "lqdrf-diag"


class Excitation(str, Enum):
    random = "random"
    sweep = "sweep"
    impulse = "impulse"


class PlantKind(str, Enum):
    mujoco = "mujoco"
    linear = "linear"


@app.command()
def experiment(
    structure: Structure = typer.Argument(Structure.bcc, help="bcc or grid"),
    controller: ExpController = typer.Option(ExpController.mfdrf, "--controller"),
    reduction: DesignReduction = typer.Option(None, "--reduction", help="design model (default: thesis choice)"),
    excitation: Excitation = typer.Option(Excitation.random, "--excitation"),
    duration: float = typer.Option(
        None, "--duration", help="run length [s] (default: the records the slowest mode needs to settle + 2 measured)"),
    delay_samples: float = typer.Option(1.35, "--delay-samples", help="computation delay [sampling periods]"),
    period_ms: float = typer.Option(None, "--period-ms",
                                    help="controller sampling period [ms] (default: the thesis's for the "
                                         "controller, Sec. 5.3: LQG 1, others 0.5)"),
    noise: float = typer.Option(1e-6, "--noise", help="velocity-sensor noise sigma [m/s]"),
    seed: int = typer.Option(0, "--seed"),
    mjcf: str = typer.Option(None, "--mjcf", help="run on an exported (and edited) MJCF plant"),
    plant: PlantKind = typer.Option(PlantKind.mujoco, "--plant", help="mujoco plant or the linear FE model"),
    out: str = typer.Option("out/experiment", "--out", help="output folder"),
    spawn: bool = typer.Option(False, "--spawn", help="open the rerun viewer live"),
    as_json: bool = typer.Option(False, "--json", help="print results.json to stdout"),
    allow_unstable: bool = typer.Option(False, "--allow-unstable",
                                        help="exit 0 even when a warning calls the comparison not meaningful"),
) -> None:
    """Run a closed-loop experiment (DRF at 2 kHz, LQG at 1 kHz as Sec. 5.3), measure it like a modal test.

    The outputs are always written; a run whose own warning calls the comparison not meaningful
    (self-excited oscillation, limit cycle) exits with status 1 unless --allow-unstable.
    """
    from pathlib import Path

    from rich.progress import Progress

    from .io.results import experiment_summary, write_outputs
    from .lab.experiment import ExperimentConfig, default_chain, not_meaningful, run_experiment
    from .models import nominal_fe_model

    try:
        period_s = _period_s(period_ms)
        chain = default_chain(controller.value, delay_periods=delay_samples, noise_m_s=noise,
                              **({} if period_s is None else {"period_s": period_s}))
    except (VlabError, ValueError) as exc:
        _fail(exc)
    cfg = ExperimentConfig(
        structure=structure.value, controller=controller.value,
        reduction=reduction.value if reduction else None, excitation=excitation.value, duration_s=duration,
        chain=chain, seed=seed, plant=plant.value,
        mjcf=Path(mjcf) if mjcf else None,
    )
    try:
        fe = nominal_fe_model(structure.value)
        with Progress(console=err_console, transient=True, disable=as_json) as bar:
            task = bar.add_task(f"{structure.value} {controller.value}: simulating", total=1.0)
            result = run_experiment(cfg, fe, progress=lambda x: bar.update(task, completed=x))
        files = write_outputs(result, fe.spec, Path(out), spawn=spawn)
    except (VlabError, ValueError) as exc:
        partial = getattr(exc, "partial", None)
        if partial is not None:
            from .io.uff import write_recording

            Path(out).mkdir(parents=True, exist_ok=True)
            kept = write_recording(Path(out) / "recording_partial.uff", partial.recording, overwrite=True)
            err_console.print(f"the recording up to the failure is kept in {kept}")
        _fail(exc)
    summary = experiment_summary(result)
    blocking = not_meaningful(result.warnings)

    def _exit_if_not_meaningful() -> None:
        if blocking and not allow_unstable:
            err_console.print(f"[bold red]error:[/] the comparison is not meaningful ({blocking[0]}); outputs "
                              f"written to {files['results'].parent}/; use --allow-unstable to exit 0")
            raise typer.Exit(code=1)

    if as_json:
        _print_json(summary)
        _exit_if_not_meaningful()
        return
    t = Table(title=f"{fe.spec.title}, {controller.value}: analysis (sampled-data) vs experiment ({summary['plant']})")
    for col in ("mode", "f pred [Hz]", "f meas [Hz]", "zeta pred", "zeta meas", "peak ratio"):
        t.add_column(col, justify="right")
    for m in result.modes:
        t.add_row(str(m.mode), f"{m.frequency_predicted_hz:.3f}", f"{m.frequency_measured_hz:.3f}",
                  f"{m.damping_predicted:.4f}", f"{m.damping_measured:.4f}", f"{m.peak_level_ratio:.3f}")
    console.print(t)
    console.print(f"sampling period {summary['period_s'] * 1e3:g} ms ({summary['period_source']})")
    console.print(f"average peak level error: {result.avg_peak_error:.3f}   outputs: {files['results'].parent}/")
    for w in result.warnings:
        err_console.print(f"[bold yellow]warning:[/] {w}")
    _exit_if_not_meaningful()


@app.command()
def crosscheck(
    structure: Structure = typer.Argument(..., help="bcc or grid"),
    segments: int = typer.Option(None, "--segments", min=1, help="hinges per element segment (default: chosen per member)"),
    n: int = typer.Option(None, "--n", min=1, help="modes compared (default 6 BCC, 12 grid)"),
    as_json: bool = typer.Option(False, "--json", help="print one JSON object"),
) -> None:
    """Cross-check the MuJoCo plant against the FE model: frequencies, MAC, free decay.

    Modes are paired one-to-one by MAC over a common band, against the spec's (thesis) mesh and the spec
    meshed at the plant's resolution; MuJoCo modes in the band without an FE partner are listed.
    """
    import math

    from .sim import SimOptions, build_plant
    from .sim import crosscheck as run_crosscheck
    from .sim import free_decay
    from .spec import load_spec

    n_modes = n or (6 if structure is Structure.bcc else 12)
    try:
        spec = load_spec(structure.value)
        plant = build_plant(spec, SimOptions(segments_per_element=segments))
        refs = {"thesis_mesh": run_crosscheck(plant, n_modes),
                "plant_resolution": run_crosscheck(plant, n_modes, mesh="plant")}
        cc = refs["thesis_mesh"]
        first = cc.pairs[0]
        decay = free_decay(plant, first.sim_mode, sim_modes=cc.sim_modes) if first.sim_mode else None
    except (VlabError, ValueError) as exc:
        _fail(exc)

    def num(x: float) -> float | None:
        return None if x is None or not math.isfinite(x) else float(x)

    if as_json:
        _print_json({
            "structure": structure.value,
            "frequencies_hz": {"fe": [p.fe_hz for p in cc.pairs], "mujoco": [num(p.sim_hz) for p in cc.pairs]},
            "relative_error": [num(p.error_pct / 100) for p in cc.pairs],
            "mac": [p.mac for p in cc.pairs],
            "mujoco_mode": [p.sim_mode for p in cc.pairs],
            "references": {key: {
                "fe_elements_per_segment": r.fe_elements,
                "pairing_band_hz": r.band_hz,
                "pairs": [{"fe_mode": p.fe_mode, "fe_hz": p.fe_hz, "mujoco_mode": p.sim_mode,
                           "mujoco_hz": num(p.sim_hz), "error_pct": num(p.error_pct), "mac": p.mac}
                          for p in r.pairs],
                "max_abs_error_pct": num(r.max_error_pct()),
                "min_mac": r.min_mac(),
                "unpaired_mujoco_modes": [{"mujoco_mode": u.sim_mode, "mujoco_hz": u.sim_hz,
                                           "best_fe_mode": u.best_fe_mode, "best_mac": u.best_mac,
                                           "reason": u.reason} for u in r.unpaired],
            } for key, r in refs.items()},
            "free_decay_mode1_hz": None if decay is None else decay.frequency_hz,
            "free_decay_mode1_damping": None if decay is None else decay.damping_ratio,
            "timestep_s": plant.timestep_s,
        })
        return
    thesis, fine = refs["thesis_mesh"], refs["plant_resolution"]
    t = Table(title=f"{spec.title}: MuJoCo plant vs FE model (timestep {plant.timestep_s * 1e3:g} ms), "
                    "modes paired one-to-one by MAC")
    for col in ("FE mode", "MuJoCo mode", "MuJoCo [Hz]", "FE [Hz] thesis mesh", "error", "MAC",
                "FE [Hz] plant resolution", "error", "MAC"):
        t.add_column(col, justify="right")
    for a, b in zip(thesis.pairs, fine.pairs):
        sm = "-" if a.sim_mode is None else str(a.sim_mode)
        if b.sim_mode != a.sim_mode:
            sm += f" / {'-' if b.sim_mode is None else b.sim_mode}"
        t.add_row(str(a.fe_mode), sm, f"{a.sim_hz:.4f}", f"{a.fe_hz:.4f}", f"{a.error_pct:+.2f} %", f"{a.mac:.4f}",
                  f"{b.fe_hz:.4f}", f"{b.error_pct:+.2f} %", f"{b.mac:.4f}")
    console.print(t)
    by_count: dict[int, list[str]] = {}
    for k, v in fine.fe_elements.items():
        by_count.setdefault(v, []).append(k)
    els = "; ".join(f"{v} in {', '.join(ks) if len(ks) <= 3 else f'{len(ks)} members'}"
                    for v, ks in sorted(by_count.items()))
    console.print(f"FE at the plant's resolution, elements per segment: {els}")
    console.print(f"max |error|: {thesis.max_error_pct():.2f} % (thesis mesh), "
                  f"{fine.max_error_pct():.2f} % (plant resolution)")
    for label, r in (("thesis mesh", thesis), ("plant resolution", fine)):
        if not r.unpaired:
            console.print(f"{label}: every MuJoCo mode up to {r.band_hz:.4g} Hz has an FE partner")
        for u in r.unpaired:
            console.print(f"{label}: MuJoCo mode {u.sim_mode} ({u.sim_hz:.4f} Hz) unpaired: {u.reason}")
    if decay is not None:
        console.print(f"free decay of mode 1: {decay.frequency_hz:.4f} Hz, zeta = {decay.damping_ratio:.4f}")


@app.command("export-mjcf")
def export_mjcf_cmd(
    structure: Structure = typer.Argument(..., help="bcc or grid"),
    output: str = typer.Option(None, "-o", "--output", help="MJCF file (default: <structure>.xml)"),
) -> None:
    """Write the complete MuJoCo plant as MJCF, to edit and run with `vlab experiment --mjcf`."""
    from .sim import build_plant, export_mjcf
    from .spec import load_spec

    path = output or f"{structure.value}.xml"
    try:
        written = export_mjcf(build_plant(load_spec(structure.value)), path)
    except (VlabError, ValueError, OSError) as exc:
        _fail(exc)
    console.print(f"wrote {written}")


@app.command()
def reproduce(
    out: str = typer.Option("out/reproduce", "--out", help="output folder"),
    fast: bool = typer.Option(False, "--fast", help="the quick subset of tables"),
    plant: PlantKind = typer.Option(PlantKind.linear, "--plant", help="plant of the virtual experiments"),
) -> None:
    """Regenerate the dissertation's tables side by side with the published numbers."""
    from pathlib import Path

    from .reproduce import reproduce as run_reproduce

    try:
        run_reproduce(Path(out), fast=fast, plant=plant.value, progress=True, console=console)
    except (VlabError, ValueError) as exc:
        _fail(exc)


@app.command()
def diagnose(
    structure: Structure = typer.Option(..., "--structure", help="bcc or grid"),
    recording: str = typer.Option(..., "--recording", help="UFF 58 time histories or FRFs, or a modal CSV"),
    controller: ExpController = typer.Option(ExpController.none, "--controller", help="controller that was running"),
    out: str = typer.Option("out/diagnose", "--out", help="output folder"),
    plant: str = typer.Option("auto", "--plant", help="validation plant: auto, linear or mujoco"),
    baseline: str = typer.Option(None, "--baseline",
                                        help="recording of the same test before the change (removes the "
                                             "model's own offsets against the plant)"),
    as_json: bool = typer.Option(False, "--json", help="print one JSON object"),
) -> None:
    """Locate a mismatch between a recording and the simulation, name and fit the missing physics."""
    from pathlib import Path

    from .diagnose import diagnose as run_diagnose

    try:
        res = run_diagnose(structure.value, Path(recording), controller=controller.value, out_dir=Path(out),
                           plant=plant, baseline=baseline)
    except (VlabError, ValueError) as exc:
        _fail(exc)
    if as_json:
        _print_json(res.as_dict())
        return
    d = res.as_dict()
    console.print(f"mismatch: {d['mismatch']}")
    t = Table(title="ranked hypotheses")
    for col in ("effect", "location", "parameters (SI)", "score", "misfit before", "misfit after"):
        t.add_column(col)
    for h in d["ranked"][:8]:
        t.add_row(str(h["effect"]), str(h["location"]), str(h["parameters"]), f"{h['score']:.4g}",
                  f"{h['misfit_before']:.4g}", f"{h['misfit_after']:.4g}")
    console.print(t)
    console.print(f"selected: {d['selected']}   report: {Path(out) / 'diagnosis.md'}")
    v = d["validated"]
    if v.get("noise_misfit") is not None:
        console.print(f"validation ({v['plant']}): FRF misfit {v['misfit_before']:.3g} -> {v['misfit_after']:.3g} "
                      f"decades; the measured noise alone leaves {v['noise_misfit']:.3g}")


def _period_s(period_ms: float | None) -> float | None:
    """``--period-ms`` in seconds (None stays None); a non-positive or non-finite value is an error."""
    from .errors import ModelError

    if period_ms is None:
        return None
    if not np.isfinite(period_ms) or period_ms <= 0:
        raise ModelError(f"--period-ms must be a positive number of milliseconds, got {period_ms!r}")
    return period_ms * 1e-3


def _measured_modes(fe, modes_file: str | None):
    """Measured modes (frequencies, shapes at the Guyan masters) for corrected-guyan."""
    from .errors import DataFileError
    from .models import master_indices

    if modes_file is None:
        return _virtual_measured_modes(fe)
    from .io.uff import read_mode_shapes

    ms = read_mode_shapes(modes_file)
    idx = master_indices(fe, "guyan")
    labels = [fe.dofs.labels[i] for i in idx]
    rows = []
    for node, dof in labels:
        if dof != "w":
            raise DataFileError(f"{modes_file}: the Guyan master {dof}@{node} is a rotation; UFF 55 gives translations only")
        if node not in ms.point_ids:
            raise DataFileError(f"{modes_file}: no shape value at master point {node}")
        rows.append(list(ms.point_ids).index(node))
    return np.asarray(ms.freq_hz), np.real(np.asarray(ms.shapes))[rows, :]


def _virtual_measured_modes(fe):
    """:func:`vlab.sim.modaltest.virtual_measured_modes`, saying on stderr where the modes come from."""
    from .sim.modaltest import virtual_measured_modes

    freq, shapes = virtual_measured_modes(fe)
    err_console.print(
        f"corrected-guyan: {len(freq)} modes, shapes from a virtual modal test on the MuJoCo plant (paired with the "
        f"FE modes by MAC), frequencies from {fe.spec.reference['frequencies']} (experimental)"
    )
    return freq, shapes


def main() -> None:  # pragma: no cover - console entry
    app()
