"""``vlab reproduce``: regenerate the dissertation's results next to its published numbers.

:func:`reproduce` computes every table group (:mod:`vlab.reproduce.tables`),
runs the virtual experiments (:mod:`vlab.reproduce.experiments`) and the
Sec. 6.1 limit-cycle study (:mod:`vlab.reproduce.limit_cycle`), and writes

- ``report.md``: per table the published value, vlab's value, the difference
  and a flag, with notes on how vlab's number was obtained; the limit-cycle
  finding; the figures;
- ``reproduce.json``: the same numbers (keys: ``settings``, ``runtime_s``,
  ``summary``, ``tables`` [name, title, source, notes, agreement, rows
  [row, column, published, ours, difference, relative, flag]],
  ``limit_cycle``, ``runs``, ``figures``);
- ``figures/``: FRF figures in the manner of Figs. 22-31 and the limit-cycle
  envelope.

:func:`print_summary` prints the agreement per table.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Iterable, Sequence

import numpy as np

from ..errors import ModelError
from ..experiment.results import write_json
from .context import LABS, ReproContext
from .experiments import PLANTS, RunSpec, VirtualRun, compare_run, run_virtual_experiment
from .grid_tables import grid_corrected_tables, grid_exact_tables
from .limit_cycle import BAND_HZ, LimitCycleResult, limit_cycle_study
from .ratio_tables import bcc_peak_ratio_table, grid_peak_ratio_tables
from .results import FLAG_TEXT, FLAGS, ReproduceResult, TableResult
from .table_rows import LABEL
from .tables import bcc_design_tables, frequency_tables, orthogonality_tables, reduced_frequency_table

#: Table groups in run order (``groups`` argument of :func:`reproduce`).
GROUPS = ("frequencies", "reduction", "bcc-designs", "grid-exact", "grid-corrected", "bcc-experiments",
          "grid-experiments", "limit-cycle", "measured-data")

#: Experiment settings: (BCC resolution [Hz], grid resolution [Hz], periods, limit-cycle run lengths [s]).
FULL = {"bcc_resolution_hz": 0.05, "grid_resolution_hz": 0.025, "periods": 2, "limit_cycle_s": 180.0,
        "limit_cycle_saturated_s": 60.0}
FAST = {"bcc_resolution_hz": 0.1, "grid_resolution_hz": 0.05, "periods": 2, "limit_cycle_s": 20.0,
        "limit_cycle_saturated_s": 20.0}

GRID_CONTROLLERS = ("lqg", "mfdrf", "lqdrf", "lqdrf-diag")
FIG_NUMBERS_EXACT = {"mfdrf": 24, "lqdrf": 25, "lqdrf-diag": 26, "lqg": 27}
FIG_NUMBERS_CG = {"mfdrf": 28, "lqdrf": 29, "lqdrf-diag": 30, "lqg": 31}


class _Bars:
    """Progress of a reproduction: rich bars on a terminal (one overall bar and one per simulation); when
    stderr is piped or redirected, one line per finished step with the time spent and, after the first
    simulation, the time left (:meth:`left`); nothing without ``progress``."""

    def __init__(self, progress) -> None:
        import sys

        self._own = None
        self.lines = progress is True and not sys.stderr.isatty()
        if progress is True and not self.lines:
            from rich.console import Console
            from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

            self._own = Progress(TextColumn("{task.description}"), BarColumn(), TextColumn("{task.percentage:>3.0f}%"),
                                 TimeElapsedColumn(), console=Console(stderr=True), transient=False)
            self.p = self._own
        else:
            self.p = None if progress is True else (progress or None)
        self.main, self.total, self.done = None, 0, 0
        self.t0 = time.perf_counter()
        self.sim_s = {"planned": 0.0, "done": 0.0, "spent": 0.0}

    def __enter__(self):
        if self._own is not None:
            self._own.__enter__()
        return self

    def __exit__(self, *exc):
        if self._own is not None:
            self._own.__exit__(*exc)
        return False

    def _line(self, text: str) -> None:
        import sys

        sys.stderr.write(f"reproduce: {text} ({time.perf_counter() - self.t0:.0f} s)\n")
        sys.stderr.flush()

    def start(self, total: int, simulated_s: float) -> None:
        """``total`` steps, of which the simulations cover ``simulated_s`` [s] of simulated time (at least)."""
        self.total, self.sim_s["planned"] = total, float(simulated_s)
        if self.lines:
            self._line(f"{total} steps, at least {simulated_s:.0f} s simulated in all")
        elif self.p is not None:
            self.main = self.p.add_task("reproduce", total=total)

    def step(self, text: str) -> None:
        self.done += 1
        if self.lines:
            self._line(f"{self.done} of {self.total} steps done ({text}){self.left()}")
        elif self.p is not None and self.main is not None:
            self.p.update(self.main, advance=1, description=f"reproduce: {text}")

    def left(self) -> str:
        """The simulations' time left, from the wall time per simulated second of those done (empty before
        the first)."""
        s = self.sim_s
        if s["done"] <= 0 or s["planned"] <= s["done"]:
            return ""
        from ..units import format_duration

        return f"; the simulations left: about {format_duration(s['spent'] / s['done'] * (s['planned'] - s['done']))}"

    def sub(self, text: str, simulated_s: float):
        """A callback taking the fraction done of a simulation of ``simulated_s`` [s], and a finisher."""
        t = time.perf_counter()

        def finish(remove=None) -> None:
            self.sim_s["done"] += simulated_s
            self.sim_s["spent"] += time.perf_counter() - t
            if remove is not None:
                remove()

        if self.p is None:
            if self.lines:
                self._line(f"{text} ...")
            return None, finish
        task = self.p.add_task(f"  {text}", total=1.0)
        return (lambda x: self.p.update(task, completed=x)), (lambda: finish(lambda: self.p.remove_task(task)))


def _run(spec: RunSpec, ctx: ReproContext, plant: str, bars: _Bars) -> VirtualRun:
    sim_s = spec.periods / spec.resolution_hz
    cb, done = bars.sub(f"{spec.key} ({sim_s:.0f} s simulated, and the settling)", sim_s)
    try:
        return run_virtual_experiment(spec, ctx=ctx, plant=plant, progress=cb)
    finally:
        done()


def _frf_fig(path: Path, freq, curves: dict, title: str, ylabel: str) -> Path:
    from ..viz.figures import frf_figure

    return frf_figure(freq, {k: np.abs(v) for k, v in curves.items()}, title=title, ylabel=ylabel, path=path)


def _limit_cycle_figure(lc: LimitCycleResult, path: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.0, 4.0), dpi=120)
    for r in lc.runs:
        ax.semilogy(r.times_s, r.band_rms_m_s, label=r.label)
    ax.set_xlabel("time [s]")
    ax.set_ylabel(f"RMS velocity at 6, {BAND_HZ[0]:g}-{BAND_HZ[1]:g} Hz [m/s]")
    ax.set_title("BCC LQG at rest, 1 kHz, 1.35-period delay (Sec. 6.1)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize="small")
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path


def reproduce(out_dir: str | Path, *, fast: bool = False, plant: str = "linear", lab: str | None = None,
              groups: Sequence[str] | None = None, progress=None, console=None, seed: int = 0,
              overwrite: bool = False) -> ReproduceResult:
    """Regenerate the dissertation's tables, figures and the Sec. 6.1 limit-cycle study.

    The output folder is written atomically (:func:`vlab.io.atomic.atomic_dir`):
    everything goes into a temporary folder beside ``out_dir``, renamed into
    place when complete; a failed or interrupted run leaves ``out_dir`` as it was.

    Parameters
    ----------
    out_dir : str or Path
        Output folder (created; its parent must exist): ``report.md``,
        ``reproduce.json``, ``figures/``.
    fast : bool
        Coarser frequency resolution and short limit-cycle runs (a quick
        look; the numbers of the experiment tables move).
    plant : {"linear", "mujoco"}
        Plant of the virtual experiments: the laboratory structure stepped
        exactly, or the MuJoCo model (needs ``lab="nominal"``). The
        limit-cycle study always runs on the linear plant.
    lab : {"as-measured", "nominal"}, optional
        Laboratory structure (:mod:`vlab.reproduce.context`); default
        "as-measured" with the linear plant, "nominal" with MuJoCo.
    groups : sequence of str, optional
        Subset of :data:`GROUPS` (default: all).
    progress : None, True or rich.progress.Progress
        True: show rich progress bars on stderr; a Progress: add bars to it.
    console : rich.console.Console, optional
        Where to print the agreement summary (nothing printed if None).
    seed : int
        Seed of the optimisers' multi-start and of the excitation.
    overwrite : bool
        Replace an existing non-empty ``out_dir`` whole (after the new one is
        complete); only a vlab output folder is ever replaced
        (:data:`vlab.io.atomic.OUTPUT_MARKERS`). Default False.

    Returns
    -------
    ReproduceResult
        With ``out_dir`` and ``figures`` in the final folder.

    Raises
    ------
    ModelError
        Unknown plant, lab or group; MuJoCo with the as-measured structure.
    OutputError
        ``out_dir`` is a file, a non-empty folder without ``overwrite``, or its
        parent folder is missing or not writable.
    """
    from dataclasses import replace

    from ..io.atomic import atomic_dir, check_output_dir

    final = check_output_dir(out_dir, overwrite=overwrite, option="out_dir")
    with atomic_dir(final, overwrite=overwrite) as tmp:
        result = _reproduce_into(tmp, fast=fast, plant=plant, lab=lab, groups=groups, progress=progress, seed=seed)
    result = replace(result, out_dir=final, figures=tuple(final / p.relative_to(tmp) for p in result.figures))
    if console is not None:
        print_summary(result, console)
    return result


def _checked_options(plant: str, lab: str | None, groups: Sequence[str] | None) -> tuple[str, tuple[str, ...]]:
    """The laboratory structure (default for the plant) and the table groups, checked; ModelError otherwise."""
    if plant not in PLANTS:
        raise ModelError(f"unknown plant {plant!r}; use one of {PLANTS}")
    if lab is None:
        lab = "nominal" if plant == "mujoco" else "as-measured"
    if lab not in LABS:
        raise ModelError(f"unknown laboratory structure {lab!r}; use one of {LABS}")
    if plant == "mujoco" and lab != "nominal":
        raise ModelError("the MuJoCo plant is built from the nominal spec: use lab='nominal' with plant='mujoco'")
    groups = tuple(GROUPS if groups is None else groups)
    bad = [g for g in groups if g not in GROUPS]
    if bad:
        raise ModelError(f"unknown table group(s) {bad}; use some of {GROUPS}")
    return lab, groups


def _bcc_experiments(ctx: ReproContext, cfg: dict, plant: str, seed: int, bars: _Bars, runs: list,
                     figdir: Path) -> tuple[TableResult, list[Path]]:
    """The BCC's virtual experiments (appended to ``runs``): Table 10 and the Fig. 22 FRFs."""
    comps, figures = {}, []
    for c in ("none", "mfdrf", "lqdrf", "lqg"):
        run = _run(RunSpec("bcc", c, None, cfg["bcc_resolution_hz"], cfg["periods"], seed), ctx, plant, bars)
        runs.append(run)
        comps[c] = compare_run(ctx, run, ("full",))
        bars.step(run.spec.key)
    table = bcc_peak_ratio_table(ctx, comps, plant, cfg["bcc_resolution_hz"])
    for c, cmp_ in comps.items():
        name = "open loop" if c == "none" else LABEL.get(c, c.upper())
        figures.append(_frf_fig(
            figdir / f"fig22_bcc_{c}.png", cmp_.run.freq_hz,
            {"experiment (virtual)": cmp_.run.h, "analysis (full model)": cmp_.analysis["full"][0]},
            f"BCC, {name}: force at 9, displacement at 6 (cf. Fig. 22)", "|x6 / f9| [m/N]"))
    return table, figures


def _grid_experiments(ctx: ReproContext, cfg: dict, plant: str, seed: int, bars: _Bars, runs: list,
                      figdir: Path) -> tuple[list[TableResult], list[Path]]:
    """The grid's virtual experiments (appended to ``runs``): Tables 19-21 and the Figs. 23-31 FRFs."""
    comps, figures = {}, []
    specs = [RunSpec("grid", "none", None, cfg["grid_resolution_hz"], cfg["periods"], seed)]
    specs += [RunSpec("grid", c, "exact", cfg["grid_resolution_hz"], cfg["periods"], seed) for c in GRID_CONTROLLERS]
    specs += [RunSpec("grid", c, "corrected-guyan", cfg["grid_resolution_hz"], cfg["periods"], seed)
              for c in GRID_CONTROLLERS]
    for sp in specs:
        run = _run(sp, ctx, plant, bars)
        runs.append(run)
        models = ("corrected-guyan",) if sp.model == "corrected-guyan" else ("exact", "corrected-guyan")
        comps[(sp.controller, sp.model)] = compare_run(ctx, run, models)
        bars.step(sp.key)
    tables = grid_peak_ratio_tables(ctx, comps, plant, cfg["grid_resolution_hz"])
    ylabel = "|v4 / f4| [(m/s)/N]"
    ol = comps[("none", None)]
    figures.append(_frf_fig(figdir / "fig23_grid_open_loop.png", ol.run.freq_hz, {
        "exact reduction (analysis)": ol.analysis["exact"][0], "experiment (virtual)": ol.run.h,
        "corrected Guyan (analysis)": ol.analysis["corrected-guyan"][0]},
        "Grid, open loop: force and velocity at joint 4 (cf. Fig. 23)", ylabel))
    for c in GRID_CONTROLLERS:
        e = comps[(c, "exact")]
        figures.append(_frf_fig(figdir / f"fig{FIG_NUMBERS_EXACT[c]}_grid_{c}_exact.png", e.run.freq_hz, {
            "exact reduction (analysis)": e.analysis["exact"][0], "experiment (virtual)": e.run.h,
            "corrected Guyan (analysis)": e.analysis["corrected-guyan"][0]},
            f"Grid, {LABEL[c]} designed on the exact reduction (cf. Fig. {FIG_NUMBERS_EXACT[c]})", ylabel))
        g = comps[(c, "corrected-guyan")]
        figures.append(_frf_fig(figdir / f"fig{FIG_NUMBERS_CG[c]}_grid_{c}_corrected_guyan.png", g.run.freq_hz, {
            "experiment (virtual)": g.run.h, "corrected Guyan (analysis)": g.analysis["corrected-guyan"][0]},
            f"Grid, {LABEL[c]} designed on the corrected Guyan model (cf. Fig. {FIG_NUMBERS_CG[c]})", ylabel))
    return tables, figures


def _reproduce_into(out_dir: Path, *, fast: bool, plant: str, lab: str | None, groups: Sequence[str] | None,
                    progress, seed: int) -> ReproduceResult:
    """:func:`reproduce` written into the (temporary) folder ``out_dir``."""
    t_start = time.perf_counter()
    lab, groups = _checked_options(plant, lab, groups)
    out = Path(out_dir)
    figdir = out / "figures"
    figdir.mkdir(parents=True, exist_ok=True)
    cfg = FAST if fast else FULL
    ctx = ReproContext(lab=lab, seed=seed)
    tables: list[TableResult] = []
    figures: list[Path] = []
    runs: list[VirtualRun] = []
    lc: LimitCycleResult | None = None
    measured: list = []
    n_bcc_runs = 4 if "bcc-experiments" in groups else 0
    n_grid_runs = 9 if "grid-experiments" in groups else 0
    total = len(groups) + n_bcc_runs + n_grid_runs
    with _Bars(progress) as bars:
        bars.start(total, cfg["periods"] * (n_bcc_runs / cfg["bcc_resolution_hz"]
                                            + n_grid_runs / cfg["grid_resolution_hz"])
                   + (cfg["limit_cycle_s"] + cfg["limit_cycle_saturated_s"] if "limit-cycle" in groups else 0.0))
        analytic = {"frequencies": lambda: frequency_tables(ctx),
                    "reduction": lambda: reduced_frequency_table(ctx) + orthogonality_tables(ctx),
                    "bcc-designs": lambda: bcc_design_tables(ctx),
                    "grid-exact": lambda: grid_exact_tables(ctx),
                    "grid-corrected": lambda: grid_corrected_tables(ctx)}
        for g in groups:
            if g in analytic:
                tables += analytic[g]()
                bars.step(g)
        if "bcc-experiments" in groups:
            table, figs = _bcc_experiments(ctx, cfg, plant, seed, bars, runs, figdir)
            tables.append(table)
            figures += figs
            bars.step("bcc-experiments")
        if "grid-experiments" in groups:
            tabs, figs = _grid_experiments(ctx, cfg, plant, seed, bars, runs, figdir)
            tables += tabs
            figures += figs
            bars.step("grid-experiments")
        if "limit-cycle" in groups:
            lc_s = cfg["limit_cycle_s"] + cfg["limit_cycle_saturated_s"]
            cb, done = bars.sub(f"limit cycle ({lc_s:.0f} s simulated)", lc_s)
            try:
                lc = limit_cycle_study(ctx, duration_s=cfg["limit_cycle_s"],
                                       saturated_duration_s=cfg["limit_cycle_saturated_s"], progress=cb)
            finally:
                done()
            figures.append(_limit_cycle_figure(lc, figdir / "limit_cycle.png"))
            bars.step("limit-cycle")
        if "measured-data" in groups:
            from .measured import diagnose_measurements  # the diagnosis, imported only when asked for

            measured = diagnose_measurements()
            bars.step("measured-data")
    settings = {"fast": fast, "plant": plant, "lab": lab, "lab_description": {s: ctx.lab(s).description
                                                                          for s in ("bcc", "grid")},
                "groups": list(groups), "seed": seed, **cfg}
    if "grid-corrected" in groups or "grid-experiments" in groups or "reduction" in groups:
        settings["measured_modes"] = ctx.measured_modes().description
    result = ReproduceResult(out, tuple(tables), lc, tuple(figures), settings, time.perf_counter() - t_start,
                             tuple(measured))
    _write_json(result, runs, out / "reproduce.json")
    (out / "report.md").write_text(report_markdown(result, runs))
    return result


# --------------------------------------------------------------------------- outputs
def summary_rows(result: ReproduceResult) -> list[dict]:
    """Agreement per table: name, rows compared, within tolerance, median/max error, tolerance, flags.

    Parameters
    ----------
    result : ReproduceResult

    Returns
    -------
    list of dict
        ``{"table": name, **TableResult.agreement()}`` per table.
    """
    out = []
    for t in result.tables:
        a = t.agreement()
        out.append({"table": t.name, **a})
    return out


def _write_json(result: ReproduceResult, runs: Iterable[VirtualRun], path: Path) -> Path:
    obj = {
        "settings": result.settings,
        "runtime_s": result.runtime_s,
        "flags": FLAG_TEXT,
        "summary": summary_rows(result),
        "tables": [t.as_dict() for t in result.tables],
        "limit_cycle": None if result.limit_cycle is None else result.limit_cycle.as_dict(),
        "measured_data": [{"table": m.table, "compared_with": m.compared_with, "verdict": m.verdict,
                           "diagnosis": m.result} for m in result.measured],
        "runs": [{"run": r.spec.key, "resolution_hz": r.spec.resolution_hz, "duration_s": r.duration_s,
                  "wall_s": r.wall_s, "plant": r.plant} for r in runs],
        "figures": [str(p.relative_to(result.out_dir)) for p in result.figures],
    }
    return write_json(path, obj)


def _fmt(v, digits: int = 4) -> str:
    if v is None:
        return "—"
    if v == 0:
        return "0"
    a = abs(v)
    if a >= 1000 or a < 1e-3:
        return f"{v:.3e}"
    return f"{v:.{digits}g}"


def _fmt_err(t: TableResult, v) -> str:
    if v is None:
        return "—"
    return f"{100 * v:.1f} %" if t.tolerance_kind == "relative" else f"{v:.3g}"


def report_markdown(result: ReproduceResult, runs: Sequence[VirtualRun] = ()) -> str:
    """The report: settings, agreement summary, every table with notes, the limit cycle, the figures.

    Parameters
    ----------
    result : ReproduceResult
    runs : sequence of VirtualRun
        The virtual experiments (listed with their timings).

    Returns
    -------
    str
        Markdown.
    """
    s = result.settings
    lines = [
        "# vlab reproduce: the dissertation's results, side by side",
        "",
        f"Run: {'fast' if s.get('fast') else 'full'}; plant of the virtual experiments: **{s.get('plant')}** "
        f"(laboratory structure: {s.get('lab')}); wall time {result.runtime_s:.0f} s.",
        "",
        "Flags: **calibrated** — vlab's model was fitted to this published number, so agreement is partly built in "
        "(BCC: Table 1 analytical, Table 8 with the Table 7 gains; grid: Table 3 analytical, Table 5 Guyan); "
        "**reconstructed** — rests on the reconstructed grid geometry (Figure 5 is not available; 9.2 % rms "
        "frequency error, README); **assumed** — rests on data the dissertation does not publish (measured mode "
        "shapes, the BCC's reduction masters, damping of unmeasured modes, the laboratory structure of a virtual "
        "experiment).",
        "",
    ]
    if s.get("lab_description"):
        lines += ["Laboratory structure of the virtual experiments:", ""]
        lines += [f"- {k}: {v}." for k, v in s["lab_description"].items()]
        lines.append("")
    if s.get("measured_modes"):
        lines += [f"Measured modes (grid): {s['measured_modes']}.", ""]
    lines += ["## Agreement per table", "",
              "| table | rows compared | within tolerance | tolerance | median error | max error | flags |",
              "|---|---|---|---|---|---|---|"]
    for t in result.tables:
        a = t.agreement()
        tol = f"{100 * t.tolerance:g} %" if t.tolerance_kind == "relative" else f"±{t.tolerance:g}"
        lines.append(f"| {t.name} | {a['n_compared']} | {a['n_within']} ({100 * (a['fraction_within'] or 0):.0f} %) | "
                     f"{tol} | {_fmt_err(t, a['median_error'])} | {_fmt_err(t, a['max_error'])} | {a['flags'] or '—'} |")
    lines.append("")
    for t in result.tables:
        head = t.title if t.title.startswith(t.name) else f"{t.name}: {t.title}"
        lines += [f"## {head}", "", f"Published numbers: `assets/data/{t.source}`." if t.source.endswith(".csv")
                  else f"Published numbers: {t.source}.", ""]
        lines += [f"- {n}" for n in t.notes]
        lines += ["", "| row | column | published | vlab | difference | flag |", "|---|---|---|---|---|---|"]
        for r in t.rows:
            diff = r.difference
            d = "—" if diff is None else (f"{_fmt(diff)} ({100 * r.relative:+.1f} %)" if r.relative is not None
                                          else _fmt(diff))
            lines.append(f"| {r.row} | {r.column} | {_fmt(r.published)} | {_fmt(r.ours)} | {d} | {r.flag or '—'} |")
        lines.append("")
    lc = result.limit_cycle
    if lc is not None:
        lines += ["## Sec. 6.1: the LQG limit cycle", "", lc.conclusion, "",
                  "Sampled-data analysis (exact discrete-time loop: full BCC model, LQG engine, delay, hold, RC filter):",
                  "", "| case | damping of unmodelled modes | least damped mode in band [Hz] | its zeta | spectral radius |",
                  "|---|---|---|---|---|"]
        for c in lc.cases:
            rad = "—" if c.max_abs_z is None else f"{c.max_abs_z:.6f}"
            lines.append(f"| {c.label} | {c.higher_mode_damping:.2%} | {c.least_damped_hz:.1f} | "
                         f"{c.least_damped_zeta:+.5f} | {rad} |")
        lines += ["", "Virtual-lab runs (linear plant, whatever the experiments' plant: they vary the damping of the "
                  "unmeasured modes; structure at rest, velocity-sensor noise only):", "",
                  "| run | simulated [s] | grows | limit cycle | fitted rate [1/s] | predicted rate [1/s] | frequency [Hz] |",
                  "|---|---|---|---|---|---|---|"]
        for r in lc.runs:
            lines.append(f"| {r.label} | {r.duration_s:.0f} | {r.grows} | {r.settled} | {_fmt(r.growth_rate_per_s)} | "
                         f"{_fmt(r.predicted_rate_per_s)} | {r.dominant_hz:.1f} |")
        lines += ["", "![limit cycle](figures/limit_cycle.png)", ""]
    if result.measured:
        from .measured import markdown_section

        lines += markdown_section(list(result.measured))
    if runs:
        lines += ["## Virtual experiments", "", "| run | resolution [Hz] | simulated [s] | wall [s] |", "|---|---|---|---|"]
        lines += [f"| {r.spec.key} | {r.spec.resolution_hz:g} | {r.duration_s:.0f} | {r.wall_s:.1f} |" for r in runs]
        lines.append("")
    if result.figures:
        lines += ["## Figures", ""]
        lines += [f"![{p.stem}]({p.relative_to(result.out_dir)})" for p in result.figures
                  if p.name != "limit_cycle.png"]
        lines.append("")
    lines += ["## Limitations", "",
              "- The grid geometry is a reconstruction (README: 9.2 % rms against Table 3); every grid number carries "
              "that error, and the grid's closed-loop numbers (Tables 12-21) inherit it through the mode shapes at "
              "the actuators.",
              "- The BCC's unpublished parameters were calibrated to Tables 1 and 8; agreement there is partly built in.",
              "- Measured mode shapes are not published: Tables 4, 6, 15-18 and 21 use a virtual modal test.",
              "- The virtual laboratory has no unmodelled physics and no measurement noise in the FRF runs; its "
              "peak-level ratios measure model-versus-laboratory-structure differences and the hardware chain only.",
              ""]
    return "\n".join(lines)


def print_summary(result: ReproduceResult, console=None) -> None:
    """Print the agreement per table as a rich table (and the limit-cycle verdict).

    Parameters
    ----------
    result : ReproduceResult
    console : rich.console.Console, optional
        Default: a new console on stdout.
    """
    from rich.console import Console
    from rich.table import Table

    console = console or Console()
    tab = Table(title=f"vlab reproduce: agreement with the dissertation ({result.settings.get('plant')} plant, "
                      f"{result.runtime_s:.0f} s)")
    for col in ("table", "compared", "within tol.", "tolerance", "median err", "max err", "flags"):
        tab.add_column(col, justify="right" if col not in ("table", "flags") else "left")
    for t in result.tables:
        a = t.agreement()
        tol = f"{100 * t.tolerance:g} %" if t.tolerance_kind == "relative" else f"±{t.tolerance:g}"
        frac = a["fraction_within"]
        tab.add_row(t.name, str(a["n_compared"]), f"{a['n_within']} ({100 * (frac or 0):.0f} %)", tol,
                    _fmt_err(t, a["median_error"]), _fmt_err(t, a["max_error"]), a["flags"] or "")
    console.print(tab)
    lc = result.limit_cycle
    if lc is not None:
        for r in lc.runs:
            verdict = ("limit cycle" if r.settled else "grows") if r.grows else "no growth"
            console.print(f"Sec. 6.1 limit cycle — {r.label}: {verdict}"
                          + (f" at {r.dominant_hz:.1f} Hz" if r.grows else ""))
    for m in result.measured:
        console.print(f"{m.table} (measured) against {m.compared_with}: {m.verdict.split(':')[0]}")
    console.print(f"report: {result.out_dir / 'report.md'}")


__all__ = ["GROUPS", "FLAGS", "reproduce", "print_summary", "report_markdown", "summary_rows"]
