"""``robustness.md``: the study's settings, Sec. 7 restated per plant, the FE loop's tables, the MuJoCo check.

Every number in it comes from the objects the study returned (the JSON's
numbers); :func:`markdown` writes it, ``vlab robustness --markdown FILE``
copies it into the docs.
"""

from __future__ import annotations

import numpy as np

from .study import LABELS, METRICS, Nominal, StudyConfig, Summary


def _per_mode_table(caption: str, n_modes: int, rows: list[tuple[str, list[str]]]) -> list[str]:
    """Markdown lines (after a blank line and ``caption``) of a table: a row per controller, a column per mode."""
    lines = ["", caption, ""]
    lines.append("| controller | " + " | ".join(f"mode {r + 1}" for r in range(n_modes)) + " |")
    lines.append("|---|" + "---|" * n_modes)
    lines += [f"| {LABELS[c]} | " + " | ".join(cells) + " |" for c, cells in rows]
    return lines


def _pct(p, ci) -> str:
    if p is None:
        return "n/a"
    return f"{100 * p:.1f} % [{100 * ci[0]:.1f}, {100 * ci[1]:.1f}]"


def _num(v, ci, fmt: str, scale: float = 1.0, unit: str = "") -> str:
    if v is None:
        return "n/a"
    if not np.isfinite(v):
        return "n/a (no stable sample)"
    text = f"{scale * v:{fmt}}{unit}"
    return text + (f" [{scale * ci[0]:{fmt}}, {scale * ci[1]:{fmt}}]" if ci and ci[0] is not None else "")


def plant_table(plants: dict, sim: dict, n_modes: int) -> list[str]:
    """Sec. 7 restated: a row per controller and plant (P(unstable), peak-ratio error, damping change, nominal).

    Parameters
    ----------
    plants : dict
        Of :func:`vlab.robust.plants.per_plant`.
    sim : dict
        Settings of the time simulation (``resolution_hz`` named where modes are left out).
    n_modes : int
        Modes compared.

    Returns
    -------
    list of str
        Markdown lines.
    """
    from .plants import PLANTS

    lines = ["| controller | plant | P(unstable) [95 % interval] | median peak-ratio error [dB] [95 %] | "
             "median relative damping change [95 %] | a working loop at nominal? |", "|---|---|---|---|---|---|"]
    controllers = list(plants["fe_sampled_loop"])
    for c in controllers:
        for plant, per in plants.items():
            v = per.get(c)
            if v is None:
                continue
            w = v.get("working_loop_at_nominal")
            nominal = "n/a" if w is None else "yes" if w else "**no**"
            if plant == "mujoco_time_simulation":
                where = f"{PLANTS[plant]}: {v['simulated_random_samples']} random samples"
                f0 = v["nominal_plant"]["frequency_hz"]
                if not w and f0 is not None:
                    nominal += f": self-excited at {f0:.1f} Hz"
            else:
                where = f"{PLANTS[plant]}: all {v['samples']} samples"
            damp = v.get("damping_change_relative_median")
            err = _num(v['peak_ratio_error_db_median'], v['peak_ratio_error_db_median_ci95'], '.3f')
            compared = v.get("peak_ratio_modes_compared")
            if compared and len(compared) < n_modes:
                err += (f" (modes {', '.join(map(str, compared))}: the others' windows hold no "
                        f"{sim.get('resolution_hz', '?')} Hz line)")
            lines.append(f"| {LABELS[c]} | {where} | {_pct(v['probability_unstable'], v['probability_unstable_ci95'])} "
                         f"| {err} | "
                         + _num(damp, v.get("damping_change_relative_median_ci95"), ".2f", 100, " %")
                         + f" | {nominal} |")
    return lines


def _not_working(plants: dict, fe_modes: dict, dissertation: bool = True) -> list[str]:
    """Sentences for the controllers whose unperturbed loop is unstable on the MuJoCo plant (Sec. 6.1 compared)."""
    lines = []
    for c, v in plants.get("mujoco_time_simulation", {}).items():
        if v["working_loop_at_nominal"]:
            continue
        fe = plants["fe_sampled_loop"][c]
        m = fe_modes.get(c)
        near = ("" if m is None else f" (its closed-loop mode nearest the line, {m['frequency_hz']:.2f} Hz, keeps "
                f"a damping ratio of {m['damping_ratio']:+.4f} there)")
        if fe.get("working_loop_at_nominal") is False:
            on_fe = (f"It is not a working loop on the FE model either (unstable at nominal, P(unstable) "
                     f"{100 * fe['probability_unstable']:.1f} %)")
        else:
            on_fe = (f"Its numbers on the FE model (P(unstable) {100 * fe['probability_unstable']:.1f} %, peak-ratio "
                     f"error {_num(fe['peak_ratio_error_db_median'], None, '.3f')} dB) are those of a loop that "
                     f"works on the FE model, residual modes included{near}, and not on the MuJoCo plant")
        lines += ["", f"**{LABELS[c]} is not a working loop on the MuJoCo plant**, already at nominal: "
                  f"{v['nominal_plant']['summary']}. {on_fe}: "
                  f"{v['unstable_random_samples']} of {v['simulated_random_samples']} random samples self-excite "
                  "there." + (" The dissertation's LQG ended in a limit cycle too, at about 41 Hz (Sec. 6.1)."
                              if dissertation and c == "lqg" else "")]
    return lines


def _fe_lines(cfg: StudyConfig, nominal: Nominal, summary: Summary, dissertation: bool = True) -> list[str]:
    pc = summary.per_controller
    lines = ["", "## The sampled-data loop on the perturbed FE model (all samples)", "",
             "| controller | P(unstable) | median peak-ratio error [dB] | median relative damping change | "
             "median energy index / nominal | worst spectral radius |", "|---|---|---|---|---|---|"]
    for c in cfg.controllers:
        v = pc[c]
        e = v["energy_index_ratio_to_nominal"]["median"]
        lines.append(f"| {LABELS[c]} | {100 * v['probability_unstable']:.1f} % | "
                     f"{_num(v['peak_ratio_error_db_median'], None, '.3f')} | "
                     f"{_num(v['damping_change_relative_median'], None, '.2f', 100, ' %')} | "
                     f"{'n/a' if e is None else f'{e:.3f}'} | {v['spectral_radius_max']:.5f} |")
    damping = [(c, [f"{q['median']:.4f} [{q['p5']:.4f}, {q['p95']:.4f}]; {pc[c]['nominal_damping_ratio'][r]:.4f}"
                    for r, q in enumerate(pc[c]["damping_ratio_by_mode"])]) for c in cfg.controllers]
    peaks = [(c, ["n/a" if q["median"] is None else f"{q['median']:.3f} [{q['p5']:.3f}, {q['p95']:.3f}]"
                  for q in pc[c]["peak_ratio_analysis_over_experiment_by_mode"]]) for c in cfg.controllers]
    lines += _per_mode_table("Damping ratio per mode (median [5 %, 95 %]; nominal):", nominal.n_modes, damping)
    lines += _per_mode_table("Peak level ratio analysis/experiment per mode (median [5 %, 95 %]"
                             + (", as Table 10):" if dissertation else "):"), nominal.n_modes, peaks)
    lines += ["", ("Sec. 7's ordering" if dissertation else "The dissertation's ordering (Sec. 7: LQG least, "
                   "LQDRF-diag most robust)") + " on this plant, per metric (most to least robust):", ""]
    for m, order in summary.ranking.items():
        tc = summary.thesis_conclusion.get(m, {})
        note = ""
        if "most_robust_resolved_ci95" in tc:
            yes = {True: "resolved", False: "not resolved"}
            note = (f" (first place {yes[tc['most_robust_resolved_ci95']]}, last place "
                    f"{yes[tc['least_robust_resolved_ci95']]} by the 95 % intervals of the table above)")
        lines.append(f"- **{m}** ({METRICS[m]}): " + " < ".join(LABELS[c] for c in order)
                     + f" -- **{tc.get('verdict', 'n/a')}**{note}")
    return lines


def _sim_lines(checks, sim: dict) -> list[str]:
    lines = ["", "## The MuJoCo plant: time simulation", "",
             f"Per controller the {sim.get('worst_per_controller', '?')} worst samples by the linear measure "
             f"(unstable first, then by peak-ratio error) and {sim.get('random_per_controller', '?')} drawn at "
             "random from all samples (the same for every controller) ran on MuJoCo plants built from their "
             "perturbed specs, with their delay, channel gains and sensor noise, together with the unperturbed "
             f"plant, {sim.get('run_s', '?')} s each. A run that diverges, holds a self-excited line "
             "(`find_instability`: a line not caused by the force, 30 dB above the noise floor, steady or growing) "
             "or most of its response power above the excitation band (`vlab experiment`'s test) is unstable on "
             "this plant; its H1 is not used. P(unstable) on MuJoCo counts the random samples only.", "",
             "| controller | unperturbed plant | worst samples unstable | random samples unstable | "
             "oscillation [Hz] | power above band (unstable runs) | measured/linear peak, stable runs |",
             "|---|---|---|---|---|---|---|"]
    for ch in checks:
        bad = ch.unstable_on_plant
        osc = ch.oscillation_hz[bad & np.isfinite(ch.oscillation_hz)]
        share = ch.power_above_band[bad & np.isfinite(ch.power_above_band)]
        r = ch.peak_sim_over_linear[np.isfinite(ch.peak_sim_over_linear)]
        nom = (f"unstable, {ch.nominal.frequency_hz:.1f} Hz" if ch.nominal.unstable else "stable")
        lines.append(f"| {LABELS[ch.controller]} | {nom} | {int((bad & ch.worst).sum())} of {int(ch.worst.sum())} | "
                     f"{int((bad & ch.random).sum())} of {int(ch.random.sum())} | "
                     + (f"{osc.min():.1f}..{osc.max():.1f}" if osc.size else "none") + " | "
                     + (f"{100 * share.min():.1f}..{100 * share.max():.1f} %" if share.size else "n/a") + " | "
                     + (f"{r.min():.3f}..{r.max():.3f}" if r.size else "n/a (no stable run)") + " |")
    return lines


def _limit_cycle_lines(rows_by_controller: dict) -> list[str]:
    lines = []
    for c, rows in rows_by_controller.items():
        lines += ["", f"### What moves {LABELS[c]}'s limit cycle on the MuJoCo plant", "",
                  "The unperturbed loop rerun with one thing changed at a time (`vlab.robust.limit_cycle`):", "",
                  "| change | self-excited line [Hz] | shift [Hz] | growth [1/s] | nearest FE open-loop mode [Hz] |",
                  "|---|---|---|---|---|"]
        for r in rows:
            what = ("none (thesis chain)" if r["quantity"] == "nominal" else
                    f"every section's EI x {r['value']:g}" if r["quantity"] == "bending_stiffness_factor" else
                    f"{r['quantity']} = {r['value']:g} {r['unit']}")
            f = "stable" if r["frequency_hz"] is None else f"{r['frequency_hz']:.2f}"
            sh = "" if r["shift_hz"] is None else f"{r['shift_hz']:+.2f}"
            g = "" if r["growth_rate_1_s"] is None else f"{r['growth_rate_1_s']:.3f}"
            m = "" if r["residual_mode_hz"] is None else f"{r['residual_mode_hz']:.2f}"
            lines.append(f"| {what} | {f} | {sh} | {g} | {m} |")
    return lines


def markdown(cfg: StudyConfig, nominal: Nominal, summary: Summary, checks, timings: dict, command: str, *,
             extras: dict | None = None) -> str:
    """``robustness.md``: settings, Sec. 7 restated per plant, the FE loop's tables, the MuJoCo check.

    Parameters
    ----------
    cfg, nominal, summary, checks, timings, extras
        As :func:`vlab.robust.report.results_dict`.
    command : str
        The command line that measured it (named in the text).

    Returns
    -------
    str
    """
    from .plants import per_plant, sec7_on_plants

    from .study import is_dissertation, nominal_spec
    from .uncertainty import DEFAULTS

    extras = extras or {}
    sim = extras.get("time_simulation", {})
    plants = per_plant(summary, checks, cfg.n_samples, cfg.seed)
    diss = is_dissertation(cfg)
    spec = nominal_spec(cfg, nominal)
    lines = [
        f"# Robustness of the controllers to modelling errors: {cfg.structure.upper() if diss else spec.title}"
        + ("" if cfg.uncertainties == DEFAULTS else " (the spreads of the command's --uncertainty file)"), "",
        f"Written by `{command}` ({cfg.n_samples} Monte Carlo samples, seed {cfg.seed}, "
        f"{timings.get('total', float('nan')):.0f} s on this machine; the samples ran in "
        f"{timings.get('study', float('nan')):.0f} s on {timings.get('where', '?')}, the MuJoCo runs took "
        f"{timings.get('time_simulation', float('nan')):.0f} s).", "",
        "Each controller is designed once on the nominal FE model with "
        + ("the thesis settings" if diss else "the structure file's [design] settings")
        + " and run, unchanged, on every perturbed model (" + ("the dissertation's situation: " if diss else "")
        + "design on the analysis model, test on the structure). Two plants answer: the exact sampled-data loop on each perturbed FE model "
        f"(zero-order hold, computation delay, {_filter_text(nominal)}, Eq. 5.1 engine; "
        "`vlab.robust.sampled_loop`), and the MuJoCo plant built from the same perturbed spec, run in time "
        "(hinge chain, residual modes above the design model's).",
        "", "## Distributions", "", "| group | kind | spread | source |", "|---|---|---|---|"]
    for u in cfg.uncertainties:
        sp = f"{u.spread:g} periods" if u.group == "delay_periods" else f"{100 * u.spread:g} %"
        lines.append(f"| {u.group} | {u.kind} | {sp} | {u.source} |")
    lines += ["", "## " + ("Sec. 7 restated: each" if diss else "Each") + " controller on each plant", "",
              "Probabilities with the Wilson 95 % interval, medians with a 95 % bootstrap interval; the peak-ratio "
              "error is each sample's mean over modes of |20 log10(analysis/experiment)| "
              + ("(Table 10's ratio), " if diss else "") + "over the samples stable on that plant; the damping "
              "change each sample's mean over modes of |zeta / zeta_nominal - 1| against the nominal FE loop's "
              "damping (on the MuJoCo plant: the sampled-data loop on the linearisation of each simulated sample's "
              "plant, `vlab.robust.plant_loop` -- the 4 s records' line spacing is wider than the controlled "
              "modes' half-power bands).", ""]
    lines += plant_table(plants, sim, nominal.n_modes)
    lines += [""] + [f"- **{p}**: {text}" for p, text in sec7_on_plants(plants).items()]
    lines += _model_part(plants)
    lines += _not_working(plants, extras.get("fe_loop_mode_near_limit_cycle", {}), diss)
    lines += _fe_lines(cfg, nominal, summary, diss)
    if checks:
        lines += _sim_lines(checks, sim)
    lines += _limit_cycle_lines(extras.get("limit_cycle_sensitivity", {}))
    lines.append("")
    return "\n".join(lines)


def _filter_text(nominal: Nominal) -> str:
    """The RC filter of the controllers' chains in words (``"677 Hz RC filter"``, or ``"no RC filter"``)."""
    corners = {ch.filter_hz for ch in nominal.chains.values()}
    return ", ".join("no RC filter" if f is None else f"{f:g} Hz RC filter" for f in sorted(corners, key=str))


def _model_part(plants: dict) -> list[str]:
    """A sentence on the MuJoCo plant's damping change at nominal (the model's part), per controller."""
    rows = {c: v.get("nominal_plant_damping_change_relative")
            for c, v in plants.get("mujoco_time_simulation", {}).items()}
    rows = {c: v for c, v in rows.items() if v is not None}
    if not rows:
        return []
    return ["", "The unperturbed MuJoCo plant's damping change from the nominal FE loop (the model's own part of "
            "the MuJoCo plant's numbers): " + ", ".join(f"{LABELS[c]} {100 * v:.2f} %" for c, v in rows.items())
            + "."]
