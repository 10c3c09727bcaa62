"""The diagnosis report: markdown, JSON and figures in an output folder.

Files (stable names):

- ``diagnosis.md`` -- the report (what was compared, where the mismatch is,
  the ranked hypotheses with 95 % intervals, the selected effect, the
  validation);
- ``diagnosis.json`` -- :meth:`DiagnosisResult.as_dict`;
- ``overlay_<point>.png`` -- measured FRF with the model before and after and
  the log-magnitude misfit (:func:`vlab.viz.figures.misfit_overlay`), for the
  channel with the largest error and the excitation point;
- ``modes.png`` -- per-mode frequency errors before and after
  (:func:`vlab.viz.figures.comparison_bar`);
- ``time.png`` -- recorded and rerun velocity (before/after) at the
  worst channel, when time histories were given.

Everything is written to a temporary name and moved into place, so a failed
run leaves no partial file; existing files are replaced only with
``overwrite=True``.
"""

from __future__ import annotations

import json
import math
import os
import uuid
from pathlib import Path

import numpy as np

from ...errors import DataFileError, VlabError
from ...experiment.results import jsonable
from .text import _fmt, finite_numbers, format_location, format_parameters, misfit_unit, ratio_text, separable_why
from .verdict import mismatch_text, nominal_fit_chi2, selected_chi2, verdict


def _params(d: dict, ci: dict) -> str:
    return format_parameters(d, ci, names=True)


def _peak_text(s: dict) -> str:
    """The local test of the verdict: the largest single-line residual against its limit."""
    p, lim = s.get("peak_nominal"), s.get("peak_limit")
    if p is None or lim is None or not (math.isfinite(p) and math.isfinite(lim)):
        return ""
    word = "exceeds" if p > lim else "is within"
    return f"; largest single-line residual {p:.3g} {word} its limit {lim:.3g}"


def _head_lines(res: dict) -> list[str]:
    """Title, data, notes, the verdict and any self-excited oscillation."""
    lines = [f"# vlab diagnosis: {res['structure']}, controller {res['controller']}", ""]
    lines += [f"Data: `{res['data']['source']}` ({res['data']['kind']}); {res['data']['n_lines']} lines x "
              f"{res['data']['n_channels']} channels" if res["data"]["kind"] != "modal" else
              f"Data: `{res['data']['source']}` (modal table, {res['data']['n_modes']} modes)", ""]
    for n in res.get("notes", []):
        lines.append(f"- {n}")
    lines += ["", "## Verdict", "", verdict(res), ""]
    inst = res.get("instability") or {}
    if inst.get("unstable"):
        lines += ["## Instability", "", "Self-excited lines (`vlab.measure.instability`: not caused by the force, "
                  "not periodic with it, a steady or growing envelope):", "",
                  "| channel | f [Hz] | RMS [m/s] | above floor [dB] | coherence [-] | growth [1/s] | grown since start [x] |",
                  "|---|---|---|---|---|---|---|"]
        for o in inst["oscillations"]:
            lines.append(f"| {o['channel']} | {o['frequency_hz']:.2f} | {o['amplitude_m_s']:.3g} | "
                         f"{10 * math.log10(o['line_to_floor']):.0f} | {o['coherence']:.2f} | "
                         f"{o['growth_rate_1_s']:.3g} | {o['rise']:.3g} |")
        lines.append("")
    return lines


def _mismatch_lines(res: dict) -> list[str]:
    """The mismatch test's outcome in words, with the selected effects and their parameters."""
    s = res["statistics"]
    lines = []
    peak = _peak_text(s)
    if s.get("noise_only"):  # found by the test without the model-error floor (a baseline given)
        q = s["noise_only"]
        peak += (f"; within the {100 * s['floor']:g} % model-error floor, but the recording differs from its "
                 f"baseline beyond the noise of the two: chi2 = {q['chi2']:.4g} (limit {q['chi2_limit']:.4g}), "
                 f"largest single-line residual {q['peak']:.3g} (limit {q['peak_limit']:.3g})")
    if not res["mismatch"] and res.get("within_model_accuracy"):
        lines += [f"**Within the model's accuracy.** The nominal model's weighted residual chi2 = "
                  f"{s['chi2_nominal']:.4g} over N = {s['n_obs']} residuals is within the limit {s['chi2_limit']:.4g} "
                  f"set by the measurement's and the model's uncertainty, though beyond the measurement's alone"
                  f"{peak}; no effect is proposed.", ""]
    elif not res["mismatch"]:
        lines += [f"**No significant mismatch.** The nominal model's weighted residual chi2 = {s['chi2_nominal']:.4g} "
                  f"over N = {s['n_obs']} residuals is within the noise (limit {s['chi2_limit']:.4g}){peak}; no "
                  "effect is proposed.", ""]
    elif not res["selected"]:
        lines += [f"**Mismatch, not explained.** {mismatch_text(s, s['n_obs'])}{peak}; no effect of the library "
                  "(alone or in pairs) explains it: see the verdict.", ""]
    else:
        sel = " + ".join(f"`{x['effect']}` at {_loc(x['location'])}" for x in res["selected"])
        chi2_sel = selected_chi2(res)
        arrow = "" if chi2_sel is None else f" -> {chi2_sel:.4g}"
        c0, cp = nominal_fit_chi2(s), s["chi2_nominal"]
        tested = "" if c0 == cp else f"; the mismatch tests' statistic: {cp:.4g}"
        refit = (res.get("validated") or {}).get("refit") or {}
        if refit.get("chi2") is not None:  # the footing the choice was judged on (its remainder, rule 10)
            within = "within" if refit["chi2"] <= s["chi2_limit"] else "beyond"
            tested += f"; refitted on the MuJoCo plant's linearisation: chi2 {refit['chi2']:.4g}, {within} the limit"
        lines += [f"**Mismatch: {sel}.** chi2 {c0:.4g}{arrow} "
                  f"(noise limit {s['chi2_limit']:.4g}, N = {s['n_obs']}{tested}){peak}.", ""]
        for x in res["selected"]:
            fe = ("" if not x.get("fe_fit") else
                  " (refitted on the MuJoCo plant's linearisation; the FE model's fit: "
                  + ", ".join(f"{k} = {v:.4g}" for k, v in x["fe_fit"].items()) + ")")
            if x.get("plant_fit"):
                fe = (" (fitted on the structure's own model, the data referred through its linear replay; the "
                      "value fitted through the MuJoCo plant's replay: "
                      + ", ".join(f"{k} = {v:.4g}" for k, v in x["plant_fit"].items()) + ")")
            if x.get("structure_fit"):
                fe += ("; the structure's own model, which these data reject, fitted "
                       + ", ".join(f"{k} = {v:.4g}" for k, v in x["structure_fit"].items()))
            lines.append(f"- {x['effect']} at {_loc(x['location'])}: {_params(x['parameters'], x['ci95'])}{fe}")
        lines.append("")
    return lines


def _where_lines(res: dict) -> list[str]:
    """Where the mismatch is: loop, band, modes, points, members, sensors, the model's uncertainty."""
    lines = []
    loc = res["located"]
    lines += ["## Where", "",
              f"- loop: {loc['loop']}",
              f"- band: {_fmt(loc['band_hz'])} Hz",
              f"- modes with a mismatch: {loc['modes'] or 'none'}",
              f"- points (sensitivity-based localisation): {loc['points'] or 'none'}",
              f"- members: {loc['members'] or 'none'}",
              f"- sensors that disagree: {loc.get('sensors') or 'none'}", ""]
    if loc.get("mode_errors"):
        lines += ["| mode | f predicted [Hz] | f measured [Hz] | measured / predicted - 1 | zeta predicted | zeta measured | "
                  "peak ratio | mismatch |", "|---|---|---|---|---|---|---|---|"]
        for m in loc["mode_errors"]:
            fe = m["frequency_error"]
            lines.append(f"| {m['mode']} | {_fmt(m['frequency_predicted_hz'])} | {_fmt(m['frequency_measured_hz'])} | "
                         f"{_pct(fe)} | {_fmt(m['damping_predicted'], 3)} | {_fmt(m['damping_measured'], 3)} | "
                         f"{_fmt(m['peak_ratio'], 3)} | {'yes' if m['mismatch'] else ''} |")
        lines.append("")
    lines += _uncertainty_lines(res.get("uncertainty"))
    if loc.get("sensitivity"):
        lines += ["Sensitivity-based localisation (share of the frequency errors one local parameter explains):", ""]
        for d in loc["sensitivity"][:6]:
            where = d.get("point", d.get("member"))
            lines.append(f"- {d['parameter']} at {where}: {100 * d['explained']:.0f} %")
        lines.append("")
    if loc.get("channels"):
        lines += ["| channel (point) | chi2 per residual | misfit [decades] | COMAC |", "|---|---|---|---|"]
        for p, c in loc["channels"].items():
            lines.append(f"| {p} | {_fmt(c['chi2_per_residual'], 3)} | {_fmt(c['misfit_decades'], 3)} | "
                         f"{_fmt(c['comac'], 3)} |")
        lines.append("")
    return lines


def _ranked_lines(res: dict) -> list[str]:
    """The hypotheses ranked by BIC (the first 15) and the alternatives not separable from the selection."""
    lines = []
    if not res["ranked"]:
        return lines
    lines += ["## Hypotheses (ranked by BIC, lower is better)", "",
              "| # | effect | location | parameters [95 % interval] | BIC | dBIC to the best | dBIC vs nominal | "
              f"misfit before [{misfit_unit(res)}] | misfit after [{misfit_unit(res)}] |",
              "|---|---|---|---|---|---|---|---|---|"]
    best = res["ranked"][0]["score"]
    for i, h in enumerate(res["ranked"][:15], start=1):
        lines.append(f"| {i} | {h['effect']} | {_loc(h['location'])} | {_params(h['parameters'], h['ci95'])} | "
                     f"{h['score']:.5g} | {h['score'] - best:.4g} | {h['delta_bic']:.4g} | "
                     f"{_fmt(h['misfit_before'], 3)} | {_fmt(h['misfit_after'], 3)} |")
    lines.append("")
    if res.get("alternatives"):
        lines += [f"Not separable by these data ({separable_why(res)}): " + ", ".join(res["alternatives"]), ""]
    return lines


def _validation_lines(res: dict) -> list[str]:
    """The validation: misfit before and after on the plant, the refit, the modes, the time-domain error."""
    lines = []
    v = res["validated"]
    what = ("RMS relative frequency error" if res["data"]["kind"] == "modal"
            else "FRF log-magnitude misfit [decades]")
    lines += ["## Validation", "", f"Plant: {v.get('plant', 'model')}.", ""]
    if v.get("refit"):
        r = v["refit"]
        others = {n: x for n, x in v.get("parameters", {}).items() if n != r["parameter"]}
        lines += [f"The rerun used {r['parameter']} = {r['value']:.5g}, refitted on {r['on']} "
                  f"({r.get('start', 'FE fit')} {r['fe_value']:.5g}, {100 * r['change']:+.1f} %; "
                  f"chi-square on the plant's linearisation {r['chi2_fe_value']:.4g} -> {r['chi2']:.4g})"
                  + ("; with " + ", ".join(f"{n} = {x:.5g}" for n, x in others.items()) if others else "")
                  + ".", ""]
    before, after = v['misfit_before'], v['misfit_after']
    lines.append(f"- {what}: {_fmt(before)} -> {_fmt(after)}"
                 + (f" ({ratio_text(before, after)})" if ratio_text(before, after) else ""))
    if finite_numbers(v, "chi2_before", "chi2_after"):
        lines.append(f"- chi-square on the fit's footing (noise, floor and model form; the reruns referred as the "
                     f"data are): {_fmt(v['chi2_before'])} -> {_fmt(v['chi2_after'])}")
    if v.get("noise_misfit") is not None:
        lines.append(f"- the same misfit of an exact model, from the measured noise (and the model's own "
                     f"uncertainty, where it is carried): {_fmt(v['noise_misfit'])}")
    if v.get("modes"):
        base = "reference" if v.get("modes_compared_with") else "nominal model"
        if v.get("modes_compared_with"):
            lines += ["", f"Predictions: {v['modes_compared_with']}."]
        best = v.get("best_candidate")
        if best:
            lines += ["", f"No effect selected; the last columns show the best fitted candidate, {best}, rejected."]
        lines += ["", f"| mode | measured [Hz] | {base} [Hz] | {base} / measured - 1 | with the selected effect [Hz] | "
                  "with the effect / measured - 1 |" + (" best candidate [Hz] | best candidate / measured - 1 |"
                                                         if best else ""),
                  "|---|---|---|---|---|---|" + ("---|---|" if best else "")]
        for m in v["modes"]:
            lines.append(f"| {m['mode']} | {_fmt(m['frequency_measured_hz'])} | {_fmt(m['frequency_before_hz'])} | "
                         f"{_pct(m['error_before'])} | {_fmt(m['frequency_after_hz'])} | {_pct(m['error_after'])} |"
                         + (f" {_fmt(m['frequency_best_candidate_hz'])} | {_pct(m['error_best_candidate'])} |"
                            if best else ""))
    if v.get("time_error_before") is not None:
        lines.append(f"- time-domain error ||v_model - v_recorded|| / ||v_recorded||: "
                     f"{_fmt(v['time_error_before'])} -> {_fmt(v['time_error_after'])}"
                     + (f" (an exact model leaves {_fmt(v['noise_time_error'])})"
                        if v.get("noise_time_error") is not None else ""))
    lines.append("")
    return lines


def markdown(res: dict) -> str:
    """The report text from ``res``, the JSON object of a diagnosis."""
    lines = _head_lines(res) + _mismatch_lines(res) + _where_lines(res) + _ranked_lines(res) + _validation_lines(res)
    if res.get("files"):
        lines += ["## Figures", ""] + [f"![{k}]({f})" for k, f in res["files"].items() if f.endswith(".png")] + [""]
    t = res.get("timing_s", {})
    if t:
        lines += ["Time: " + ", ".join(f"{k} {v:.1f} s" for k, v in t.items()), ""]
    return "\n".join(lines)


def _uncertainty_lines(u: dict | None) -> list[str]:
    """The 'Uncertainty' paragraph (and, for a modal table, a per-mode table) of the report."""
    if not u:
        return []
    if "modes" not in u:
        out = ["## Uncertainty", "",
               f"Each line is compared within its measured noise (median {_spct(u['noise_sigma_median_rel'])} of the "
               f"FRF) and a {_spct(u['model_floor_rel'])} model-error floor"
               + (f", and the model's own uncertainty (median {_spct(u['model_form_sigma_median_rel'])}, up to "
                  f"{_spct(u['model_form_sigma_max_rel'])} at a line; correlated across the lines of a mode)"
                  if u.get("model_form") == "derived" else "") + f": the {u['dominant']} dominates.", ""]
        p = u.get("nominal_profile")
        if p:
            out += [f"The nominal model's modes, moved to their most likely frequencies and damping within that "
                    f"uncertainty: chi-square of the moves {p['nuisance_chi2']:.4g} (limit {p['nuisance_limit']:.4g}); "
                    f"the largest, {p['largest']}, by {p['largest_sigmas']:+.3g} standard uncertainties.", ""]
        return out
    out = ["## Uncertainty", "",
           f"Each residual is weighted by the root sum of squares of the measurement's and the model's standard "
           f"uncertainty; the **{u['dominant']}** dominates. Model form: "
           + "; ".join(f"{k}: {v}" for k, v in u["sources"].items()) + ".", "",
           "| mode | frequency: measurement | frequency: model form | damping: measurement | damping: model form |",
           "|---|---|---|---|---|"]
    for i, m in enumerate(u["modes"]):
        z = [u["damping_sigma_measurement_rel"][i], u["damping_sigma_model_form_rel"][i]]
        out.append(f"| {m} | {_spct(u['frequency_sigma_measurement_rel'][i])} | "
                   f"{_spct(u['frequency_sigma_model_form_rel'][i])} | "
                   + " | ".join("not compared" if v is None else _spct(v) for v in z) + " |")
    return out + [""]


def _pct(v) -> str:
    return f"{100 * v:+.2f} %" if v is not None and np.isfinite(v) else "n/a"


def _spct(v) -> str:
    """An uncertainty in percent, three significant digits, no sign."""
    return f"{100 * v:.3g} %" if v is not None and np.isfinite(v) else "n/a"


def _loc(loc: dict) -> str:
    return format_location(loc)


def _atomic_write(path: Path, data: bytes, overwrite: bool) -> None:
    if path.exists() and not overwrite:
        raise DataFileError(f"{path}: exists (pass overwrite=True to replace it)")
    tmp = path.with_name(f".{path.name}.{uuid.uuid4().hex}.tmp")
    try:
        tmp.write_bytes(data)
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()


def time_figure(t_s: np.ndarray, measured: np.ndarray, before: np.ndarray, after: np.ndarray, *, path: Path,
                title: str = "") -> Path:
    """Recorded velocity ``measured`` with the reruns ``before`` and ``after`` [m/s] against ``t_s`` [s]
    (last 5 s), written as PNG to ``path`` with ``title``."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(7.0, 4.0), dpi=120, layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    sel = t_s >= t_s[-1] - 5.0
    ax.plot(t_s[sel], measured[sel], "k-", lw=1.2, label="recorded")
    ax.plot(t_s[sel], before[sel], color="tab:red", ls="--", lw=1.1, label="model before")
    ax.plot(t_s[sel], after[sel], color="tab:blue", ls="--", lw=1.2, label="model after")
    ax.set_xlabel("Time [s]")
    ax.set_ylabel("Velocity [m/s]")
    if title:
        ax.set_title(title)
    ax.grid(True, alpha=0.4)
    ax.legend(loc="best", fontsize="small")
    fig.savefig(path, dpi=120, format="png")
    return path


def write_report(out_dir: str | Path, res: dict, figures: dict, *, overwrite: bool = True) -> dict:
    """Write ``diagnosis.md``, ``diagnosis.json`` and the figures into ``out_dir``.

    Parameters
    ----------
    out_dir : str or Path
        Created if missing.
    res : dict
        JSON object of the diagnosis (``files`` is filled in here).
    figures : dict
        Name -> callable(path) that draws one PNG.
    overwrite : bool
        Replace existing report files.

    Returns
    -------
    dict
        Name -> path of every file written.

    Raises
    ------
    DataFileError
        Folder cannot be created, or a file exists and ``overwrite`` is False.
    """
    out = Path(out_dir)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise DataFileError(f"{out}: cannot create the output folder ({exc})") from None
    names = {"report": "diagnosis.md", "json": "diagnosis.json", **{k: f"{k}.png" for k in figures}}
    if not overwrite:
        for n in names.values():
            if (out / n).exists():
                raise DataFileError(f"{out / n}: exists (pass overwrite=True to replace it)")
    files = {}
    failed = []
    for k, draw in figures.items():
        tmp = out / f".{k}.{uuid.uuid4().hex}.png"
        try:
            draw(path=tmp)
            os.replace(tmp, out / names[k])
            files[k] = names[k]
        except (VlabError, ValueError) as exc:  # a figure that cannot be drawn does not stop the report
            failed.append(f"figure {k} not drawn: {exc}")
        finally:
            if tmp.exists():
                tmp.unlink()
    if failed:
        res = dict(res, notes=list(res.get("notes", [])) + failed)
    res = dict(res, files=files)
    _atomic_write(out / names["json"], (json.dumps(jsonable(res), indent=2) + "\n").encode(), True)
    _atomic_write(out / names["report"], markdown(res).encode(), True)
    return {**{k: out / v for k, v in files.items()}, "report": out / names["report"], "json": out / names["json"]}


