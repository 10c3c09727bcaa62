"""Outputs of a robustness study: JSON (units in keys), per-sample arrays, box plots, a rerun file, Markdown.

Files written into the output folder:

* ``robustness.json`` -- settings (distributions with sources), timings,
  per-controller statistics (:class:`vlab.robust.study.Summary`), the
  ranking per metric, whether the conclusion of Sec. 7 holds, the time-
  simulated checks;
* ``samples.npz`` -- every sample's values (keys ``<controller>/<quantity_unit>``);
* ``robustness.png`` -- box plots: damping ratio per mode, peak-ratio error
  per mode [dB], energy-index ratio, probability of instability;
* ``worst.rrd`` -- the recording of the worst time-simulated sample (rerun);
* ``robustness.md`` -- the conclusion with its numbers.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from .study import CONTROLLERS, METRICS, Nominal, StudyConfig, Summary
from .study import LABELS as _LABELS


def _peak_unit(nominal: Nominal) -> str:
    return "m_per_n" if nominal.displacement else "m_s_per_n"


def results_dict(cfg: StudyConfig, nominal: Nominal, summary: Summary, checks, timings: dict) -> dict:
    """The JSON object of ``robustness.json`` (every number's unit in its key).

    Parameters
    ----------
    cfg : StudyConfig
    nominal : Nominal
    summary : Summary
    checks : list of SimCheck
        Time-simulated samples (may be empty).
    timings : dict
        Seconds per stage (``"total"``, ``"study"``, ...) and ``"where"``.
    """
    out = {
        "structure": cfg.structure,
        "samples": cfg.n_samples,
        "seed": cfg.seed,
        "chunk_size_samples": cfg.chunk_size,
        "uncertainties": [{"group": u.group, "kind": u.kind,
                           ("spread_periods" if u.group == "delay_samples" else "spread_relative"): u.spread,
                           "source": u.source} for u in cfg.uncertainties],
        "controllers": {c: {"period_s": nominal.chains[c].period_s, "delay_periods": nominal.chains[c].delay_periods,
                            "filter_hz": nominal.chains[c].filter_hz} for c in cfg.controllers},
        "response_point": nominal.response_point,
        "compared_frf": "displacement [m/N]" if nominal.displacement else "velocity [(m/s)/N]",
        "timings_s": timings,
        "per_controller": summary.per_controller,
        "metrics": METRICS,
        "ranking_most_to_least_robust": summary.ranking,
        "thesis_conclusion_sec7": summary.thesis_conclusion,
        "time_simulation_checks": [
            {"controller": ch.controller, "samples": ch.indices.tolist(), "batches": ch.batches,
             "predicted_unstable": ch.predicted_unstable.tolist(), "diverged": ch.diverged.tolist(),
             "peak_measured_over_linear_by_mode": [[None if not np.isfinite(v) else float(v) for v in row]
                                                   for row in ch.peak_sim_over_linear]}
            for ch in checks],
    }
    return out


def write_samples(path: Path, cfg: StudyConfig, nominal: Nominal, res: dict) -> None:
    """``samples.npz``: per-sample arrays, keys with units.

    Parameters
    ----------
    path : Path
    cfg : StudyConfig
    nominal : Nominal
    res : dict
        Per-sample arrays of :func:`vlab.robust.study.run_study`.
    """
    pu = _peak_unit(nominal)
    arrays = {"sample_index": res["index"], "delay_periods": res["delay_periods"]}
    for c in cfg.controllers:
        arrays[f"{c}/damping_ratio"] = res[f"{c}/zeta"]
        arrays[f"{c}/frequency_hz"] = res[f"{c}/freq_hz"]
        arrays[f"{c}/spectral_radius"] = res[f"{c}/spectral_radius"]
        arrays[f"{c}/energy_index_j_s"] = res[f"{c}/energy_j_s"]
        arrays[f"{c}/peak_level_{pu}"] = res[f"{c}/peaks"]
    np.savez_compressed(path, **arrays)


def _finite(v: np.ndarray) -> np.ndarray:
    """The finite values of ``v`` (a box plot leaves out the samples whose value is inf or NaN)."""
    return v[np.isfinite(v)]


def _box_panel(ax, data: list, title: str, labels: list[str], *, nominal_values: list | None = None,
               zero_line: bool = False) -> None:
    """A panel of ``robustness.png``: a box per controller (``labels``), the nominal values (red x) or a zero line."""
    ax.boxplot(data, showfliers=True, flierprops={"markersize": 2})
    if nominal_values is not None:
        ax.plot(range(1, len(labels) + 1), nominal_values, "rx", label="nominal")
    if zero_line:
        ax.axhline(0.0, color="grey", lw=0.5)
    ax.set_title(title, fontsize=9)
    ax.set_xticks(range(1, len(labels) + 1), labels, rotation=45, fontsize=7)


def box_plots(path: Path, cfg: StudyConfig, nominal: Nominal, res: dict) -> Path:
    """``robustness.png``: the distributions as box plots (matplotlib, Agg).

    Parameters
    ----------
    path : Path
    cfg : StudyConfig
    nominal : Nominal
    res : dict
        Per-sample arrays of :func:`vlab.robust.study.run_study`.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ctl = [c for c in CONTROLLERS if c in cfg.controllers]
    labels = [_LABELS[c] for c in ctl]
    nm = nominal.n_modes
    fig, axes = plt.subplots(3, nm, figsize=(2.6 * nm, 8.5), squeeze=False)
    for r in range(nm):
        _box_panel(axes[0, r], [res[f"{c}/zeta"][:, r] for c in ctl], f"mode {r + 1}: damping ratio", labels,
                   nominal_values=[nominal.zeta[c][r] for c in ctl])
        _box_panel(axes[1, r], [_finite(20 * np.log10(nominal.peaks[c][r] / res[f"{c}/peaks"][:, r])) for c in ctl],
                   f"mode {r + 1}: peak ratio [dB]", labels, zero_line=True)
    axes[0, 0].legend(fontsize=7)
    _box_panel(axes[2, 0], [_finite(res[f"{c}/energy_j_s"] / nominal.energy_j_s[c]) for c in ctl],
               "energy index / nominal", labels)
    ax = axes[2, 1] if nm > 1 else axes[2, 0]
    ax.bar(labels, [100 * float(np.mean(res[f"{c}/spectral_radius"] >= 1.0)) for c in ctl])
    ax.set_title("probability of instability [%]", fontsize=9)
    ax.tick_params(axis="x", rotation=45, labelsize=7)
    for a in axes[2, 2:]:
        a.axis("off")
    fig.suptitle(f"{cfg.structure}: {cfg.n_samples} samples, seed {cfg.seed}, controllers designed on the nominal "
                 "model; peak ratio = analysis/experiment (Table 10)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _per_mode_table(caption: str, n_modes: int, rows: list[tuple[str, list[str]]]) -> list[str]:
    """Markdown lines (after a blank line and ``caption``) of a table: a row per controller, a column per mode."""
    lines = ["", caption, ""]
    lines.append("| controller | " + " | ".join(f"mode {r + 1}" for r in range(n_modes)) + " |")
    lines.append("|---|" + "---|" * n_modes)
    lines += [f"| {_LABELS[c]} | " + " | ".join(cells) + " |" for c, cells in rows]
    return lines


def markdown(cfg: StudyConfig, nominal: Nominal, summary: Summary, checks, timings: dict, command: str) -> str:
    """``robustness.md``: settings, the table of metrics, the verdict on Sec. 7 with the numbers.

    Parameters
    ----------
    cfg : StudyConfig
    nominal : Nominal
    summary : Summary
    checks : list of SimCheck
        Time-simulated samples (may be empty).
    timings : dict
        Seconds per stage (``"total"``, ``"study"``, ...) and ``"where"``.
    command : str
        The command line that measured it (named in the text).
    """
    pc = summary.per_controller
    lines = [
        f"# Robustness of the controllers to modelling errors: {cfg.structure.upper()}",
        "",
        f"Written by `{command}` ({cfg.n_samples} Monte Carlo samples, seed {cfg.seed}, "
        f"{timings.get('total', float('nan')):.0f} s on this machine; "
        f"the samples ran in {timings.get('study', float('nan')):.0f} s on {timings.get('where', '?')}).",
        "",
        "Each controller is designed once on the nominal FE model with the thesis settings and run, unchanged, "
        "on every perturbed model (the dissertation's situation: design on the analysis model, test on the "
        "structure). Each sample is evaluated with the exact sampled-data loop (zero-order hold, "
        "computation delay, 677 Hz RC filter, Eq. 5.1 engine; `vlab.robust.sampled_loop`).",
        "",
        "## Distributions",
        "",
        "| group | kind | spread | source |",
        "|---|---|---|---|",
    ]
    for u in cfg.uncertainties:
        sp = f"{u.spread:g} periods" if u.group == "delay_samples" else f"{100 * u.spread:g} %"
        lines.append(f"| {u.group} | {u.kind} | {sp} | {u.source} |")
    lines += [
        "",
        "## Results",
        "",
        "| controller | P(unstable) | median peak-ratio error [dB] | median relative damping change | "
        "median energy index / nominal | worst spectral radius |",
        "|---|---|---|---|---|---|",
    ]
    for c in cfg.controllers:
        v = pc[c]
        e = v["energy_index_ratio_to_nominal"]["median"]
        lines.append(f"| {_LABELS[c]} | {100 * v['probability_unstable']:.1f} % | "
                     f"{v['peak_ratio_error_db_median']:.3f} | {100 * v['damping_change_relative_median']:.2f} % | "
                     f"{'n/a' if e is None else f'{e:.3f}'} | {v['spectral_radius_max']:.5f} |")
    damping = [(c, [f"{q['median']:.4f} [{q['p5']:.4f}, {q['p95']:.4f}]; {pc[c]['nominal_damping_ratio'][r]:.4f}"
                    for r, q in enumerate(pc[c]["damping_ratio_by_mode"])]) for c in cfg.controllers]
    peaks = [(c, ["n/a" if q["median"] is None else f"{q['median']:.3f} [{q['p5']:.3f}, {q['p95']:.3f}]"
                  for q in pc[c]["peak_ratio_analysis_over_experiment_by_mode"]]) for c in cfg.controllers]
    lines += _per_mode_table("Damping ratio per mode (median [5 %, 95 %]; nominal):", nominal.n_modes, damping)
    lines += _per_mode_table("Peak level ratio analysis/experiment per mode (median [5 %, 95 %], as Table 10):",
                             nominal.n_modes, peaks)
    lines += ["", "## Does the conclusion of Sec. 7 hold?", "",
              "The dissertation: the more complex the control law, the more vulnerable to modelling errors -- "
              "LQG the worst, the diagonal LQDRF the best. Per metric (most to least robust):", ""]
    for m, order in summary.ranking.items():
        tc = summary.thesis_conclusion.get(m, {})
        note = ""
        if "most_robust_resolved_ci95" in tc:
            yes = {True: "resolved", False: "not resolved"}
            note = (f" (first place {yes[tc['most_robust_resolved_ci95']]}, last place "
                    f"{yes[tc['least_robust_resolved_ci95']]} by the 95 % intervals below)")
        lines.append(f"- **{m}** ({METRICS[m]}): " + " < ".join(_LABELS[c] for c in order)
                     + f" -- **{tc.get('verdict', 'n/a')}**{note}")
    lines += ["", "95 % bootstrap intervals of the medians (a difference inside them is not resolved by "
              f"{cfg.n_samples} samples):", "",
              "| controller | peak-ratio error [dB] | relative damping change |", "|---|---|---|"]
    for c in cfg.controllers:
        a, b = pc[c]["peak_ratio_error_db_median_ci95"], pc[c]["damping_change_relative_median_ci95"]
        fa = "n/a" if a[0] is None else f"{a[0]:.3f} .. {a[1]:.3f}"
        fb = "n/a" if b[0] is None else f"{100 * b[0]:.2f} .. {100 * b[1]:.2f} %"
        lines.append(f"| {_LABELS[c]} | {fa} | {fb} |")
    if checks:
        lines += ["", "## Time simulation of the worst samples (batched MuJoCo lab)", "",
                  "The worst samples of each controller (unstable first, then by peak-ratio error) were run on "
                  "MuJoCo plants built from their perturbed specs, together on `mujoco.batch.Batch` runs (one "
                  "per model layout: a perturbed grid may get another discretisation), with "
                  "their delay, channel gains and sensor noise; H1 at the response point over records of "
                  "4 s compared line by line with the linear prediction for the same sample:", "",
                  "| controller | samples | batches | predicted unstable | diverged "
                  "| measured/linear peak (min..max over modes) |",
                  "|---|---|---|---|---|---|"]
        for ch in checks:
            r = ch.peak_sim_over_linear[np.isfinite(ch.peak_sim_over_linear)]
            rng = f"{r.min():.3f}..{r.max():.3f}" if r.size else "n/a"
            lines.append(f"| {_LABELS[ch.controller]} | {ch.indices.tolist()} | {ch.batches} | "
                         f"{int(ch.predicted_unstable.sum())} | "
                         f"{int(ch.diverged.sum())} | {rng} |")
        dev = {ch.controller: float(np.nanmax(np.abs(ch.peak_sim_over_linear - 1.0), initial=0.0)) for ch in checks}
        worst = max(dev, key=dev.get)
        lines += ["", "Largest deviation of the time-simulated peak from the linear prediction: "
                  + ", ".join(f"{_LABELS[c]} {100 * v:.1f} %" for c, v in dev.items())
                  + f"; the largest is {_LABELS[worst]}'s (the MuJoCo hinge-chain plant is itself a model error "
                  "against the FE model the controllers were designed on)."]
    lines.append("")
    return "\n".join(lines)


def write_outputs(folder: Path, cfg: StudyConfig, nominal: Nominal, res: dict, summary: Summary, checks,
                  timings: dict, command: str) -> dict:
    """Write every output into ``folder`` (exists); return name -> path.

    ``res`` holds the per-sample arrays of :func:`vlab.robust.study.run_study`,
    ``command`` the command line named in the Markdown.

    Parameters
    ----------
    cfg : StudyConfig
    nominal : Nominal
    summary : Summary
    checks : list of SimCheck
        Time-simulated samples (may be empty).
    timings : dict
        Seconds per stage (``"total"``, ``"study"``, ...) and ``"where"``.

    Raises
    ------
    OSError
        From writing.
    """
    folder = Path(folder)
    files = {"json": folder / "robustness.json", "samples": folder / "samples.npz",
             "plot": folder / "robustness.png", "markdown": folder / "robustness.md"}
    files["json"].write_text(json.dumps(_clean(results_dict(cfg, nominal, summary, checks, timings)), indent=2,
                                        allow_nan=False, default=_json_default) + "\n")
    write_samples(files["samples"], cfg, nominal, res)
    box_plots(files["plot"], cfg, nominal, res)
    files["markdown"].write_text(markdown(cfg, nominal, summary, checks, timings, command))
    if checks:
        worst = max(checks, key=lambda ch: np.nanmax(np.abs(np.log(ch.peak_sim_over_linear)), initial=0.0)
                    if not ch.diverged.any() else np.inf)
        from ..viz.rerun_log import log_experiment

        rec = worst.recordings[0]
        files["rerun"] = log_experiment(folder / "worst.rrd", recording=rec.recording,
                                        metadata={"structure": cfg.structure, "controller": worst.controller,
                                                  "sample": int(worst.indices[0])})
    return files


def _clean(obj):
    """Non-finite floats -> None (JSON has no inf/NaN), recursively."""
    if isinstance(obj, dict):
        return {k: _clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_clean(v) for v in obj]
    if isinstance(obj, (float, np.floating)) and not np.isfinite(obj):
        return None
    return obj


def _json_default(obj):
    if isinstance(obj, (np.floating, np.integer)):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    raise TypeError(f"not JSON serialisable: {type(obj).__name__}")
