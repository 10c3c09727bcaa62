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
from ...io.results import jsonable


def _fmt(v, nd: int = 4) -> str:
    if v is None:
        return "n/a"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_fmt(x, nd) for x in v) + "]"
    if isinstance(v, float):
        if not np.isfinite(v):
            return "n/a"
        return f"{v:.{nd}g}"
    return str(v)


def _params(d: dict, ci: dict) -> str:
    return format_parameters(d, ci, names=True)


def _peak_text(s: dict) -> str:
    """The local test of the verdict: the largest single-line residual against its limit."""
    p, lim = s.get("peak_nominal"), s.get("peak_limit")
    if p is None or lim is None or not (math.isfinite(p) and math.isfinite(lim)):
        return ""
    word = "exceeds" if p > lim else "is within"
    return f"; largest single-line residual {p:.3g} {word} its limit {lim:.3g}"


def markdown(res: dict) -> str:
    """The report text from ``res``, the JSON object of a diagnosis."""
    s = res["statistics"]
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
        lines += [f"**Mismatch, not explained.** {_mismatch_text(s, s['n_obs'])}{peak}; no effect of the library "
                  "(alone or in pairs) explains it: see the verdict.", ""]
    else:
        sel = " + ".join(f"`{x['effect']}` at {_loc(x['location'])}" for x in res["selected"])
        chi2_sel = _selected_chi2(res)
        arrow = "" if chi2_sel is None else f" -> {chi2_sel:.4g}"
        lines += [f"**Mismatch: {sel}.** chi2 {s['chi2_nominal']:.4g}{arrow} "
                  f"(noise limit {s['chi2_limit']:.4g}, N = {s['n_obs']}){peak}.", ""]
        for x in res["selected"]:
            fe = ("" if not x.get("fe_fit") else
                  " (refitted on the MuJoCo plant's linearisation; the FE model's fit: "
                  + ", ".join(f"{k} = {v:.4g}" for k, v in x["fe_fit"].items()) + ")")
            lines.append(f"- {x['effect']} at {_loc(x['location'])}: {_params(x['parameters'], x['ci95'])}{fe}")
        lines.append("")
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
    if res["ranked"]:
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
            lines += ["Within 10 of the selected BIC (not separable by these data): "
                      + ", ".join(res["alternatives"]), ""]
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
                     f"{_fmt(v['time_error_before'])} -> {_fmt(v['time_error_after'])}")
    lines.append("")
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


def _ok(a, b) -> bool:
    return a is not None and b is not None and np.isfinite(a) and np.isfinite(b) and b > 0


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


# ------------------------------------------------------------------ readable formatting ---

#: Unit suffixes of parameter names (longest first) and how they are printed.
UNIT_SUFFIXES = (
    ("_n_m_per_rad", "N m/rad"), ("_n_s_per_m", "N s/m"), ("_m_per_s2", "m/s^2"), ("_n_per_m", "N/m"),
    ("_n_m2", "N m^2"), ("_kg", "kg"), ("_hz", "Hz"), ("_n", "N"), ("_s", "s"), ("_m", "m"),
)


def parameter_unit(name: str) -> tuple[str, str]:
    """Split a parameter name into its quantity and unit (``"mass_kg"`` -> ``("mass", "kg")``).

    Parameters
    ----------
    name : str
        A parameter name of :mod:`vlab.diagnose` (SI, the unit as a suffix:
        ``mass_kg``, ``ei_n_m2``, ``c_n_s_per_m``, ...); a combination's
        ``first.``/``second.`` prefix is kept in the quantity.

    Returns
    -------
    quantity : str
    unit : str
        ``""`` for a dimensionless parameter (``damping_ratio``, ``gain``).
    """
    for suffix, unit in UNIT_SUFFIXES:
        if name.endswith(suffix) and len(name) > len(suffix):
            return name[: -len(suffix)], unit
    return name, ""


def _sig(v: float, digits: int) -> str:
    return f"{v:.{digits}g}"


def format_parameter(name: str, value, ci95=None) -> str:
    """One fitted parameter as ``"0.12 kg [0.1198, 0.1203]"``: value, unit, 95 % interval.

    The significant digits (3 to 6) are the fewest that keep the interval's
    two ends distinct.

    Parameters
    ----------
    name : str
        Parameter name with its unit suffix (:func:`parameter_unit`).
    value : float or None
        Fitted value [SI unit of ``name``].
    ci95 : sequence of two floats, optional
        Lower and upper end of the 95 % interval [same unit]; None is left
        out, an interval with no finite end (the data do not bound the
        parameter, or its fit failed) is shown as "[not bounded by the data]".

    Returns
    -------
    str
    """
    _, unit = parameter_unit(name)
    if value is None or not np.isfinite(value):
        return "n/a"
    lo, hi = (ci95 if ci95 is not None and len(ci95) == 2 else (None, None))
    have_ci = lo is not None and hi is not None and np.isfinite(lo) and np.isfinite(hi)
    digits = 3
    while have_ci and digits < 6 and _sig(lo, digits) == _sig(hi, digits):
        digits += 1
    text = _sig(float(value), digits) + (f" {unit}" if unit else "")
    if have_ci:
        text += f" [{_sig(float(lo), digits)}, {_sig(float(hi), digits)}]"
    elif ci95 is not None and len(ci95) == 2 and not any(e is not None and np.isfinite(e) for e in ci95):
        text += " [not bounded by the data]"
    return text


def format_parameters(params: dict, ci95: dict | None = None, *, names: bool = False) -> str:
    """Every fitted parameter of a hypothesis, ``"; "``-separated (:func:`format_parameter`).

    Parameters
    ----------
    params : dict
        Name -> value (``parameters`` of an entry of ``ranked`` or ``selected``
        in :meth:`DiagnosisResult.as_dict`).
    ci95 : dict, optional
        Name -> [low, high] (``ci95`` of the same entry).
    names : bool
        Prefix each value with its quantity (``"mass 0.12 kg [...]"``); always
        done when there is more than one parameter.

    Returns
    -------
    str
    """
    ci95 = ci95 or {}
    parts = []
    for k, v in params.items():
        text = format_parameter(k, v, ci95.get(k))
        if names or len(params) > 1:
            q = parameter_unit(k)[0].replace("_", " ")
            text = f"{'EI' if q.split('.')[-1] == 'ei' else q} {text}"
        parts.append(text)
    return "; ".join(parts)


def format_location(loc: dict | None) -> str:
    """Where a hypothesis acts, in words: ``"point 6"``, ``"beam 4-5"``, ``"channel 9"``, ``"all channels"``.

    Parameters
    ----------
    loc : dict or None
        ``location`` of an entry of ``ranked`` or ``selected``
        (:meth:`DiagnosisResult.as_dict`): keys ``point``, ``points``,
        ``dof``, ``member``, ``segment``, ``mode``, ``channel``, or
        ``first``/``second`` for a combination of two effects.

    Returns
    -------
    str
        ``"global"`` for an empty location.
    """
    if not loc:
        return "global"
    if "first" in loc:
        return f"{format_location(loc['first'])} + {format_location(loc['second'])}"
    parts = []
    for k, v in loc.items():
        if k == "point":
            parts.append(f"point {v}")
        elif k == "points":
            parts.append("points " + ", ".join(str(p) for p in v))
        elif k == "member":
            seg = loc.get("segment")
            parts.append(f"{v} {seg[0]}-{seg[1]}" if seg else f"{v} (whole member)")
        elif k == "segment":
            continue
        elif k == "channel":
            parts.append("all channels" if v == "all" else f"channel {v}")
        elif k == "dof":
            parts.append(f"dof {v}")
        else:
            parts.append(f"{k} {v}")
    return ", ".join(parts)


def misfit_unit(res: dict) -> str:
    """What the misfits of a diagnosis measure: ``"decades"`` (FRF data) or ``"rel. freq. error"`` (modal data).

    Parameters
    ----------
    res : dict
        :meth:`DiagnosisResult.as_dict`.

    Returns
    -------
    str
    """
    return "rel. freq. error" if res["data"]["kind"] == "modal" else "decades"


def hypothesis_rows(res: dict, limit: int | None = 8) -> list[dict]:
    """The ranked hypotheses as readable text: effect, location, parameters, BIC difference, misfit.

    Parameters
    ----------
    res : dict
        :meth:`DiagnosisResult.as_dict`.
    limit : int or None
        At most this many rows (best first); None = all.

    Returns
    -------
    list of dict
        Keys ``effect``, ``location`` (:func:`format_location`),
        ``parameters`` (:func:`format_parameters`, with the 95 % intervals),
        ``delta_bic`` (BIC minus the best hypothesis' BIC: 0 for the first,
        lower is better), ``misfit_after`` (misfit with the effect modelled, in
        :func:`misfit_unit`), all strings.
    """
    ranked = res.get("ranked") or []
    best = ranked[0]["score"] if ranked else None
    rows = []
    for h in ranked[: limit if limit is not None else len(ranked)]:
        rows.append({"effect": str(h["effect"]), "location": format_location(h["location"]),
                     "parameters": format_parameters(h["parameters"], h.get("ci95")),
                     "delta_bic": _fmt(float(h["score"] - best), 4) if best is not None else "n/a",
                     "misfit_after": _fmt(h["misfit_after"], 3)})
    return rows


def ratio_text(before, after) -> str:
    """``before -> after`` as "N x lower" or "N x higher" (never a fraction); "" when either is
    not a positive finite number."""
    if not _ok(before, after) or before <= 0:
        return ""
    r = before / after
    return f"{r:.3g} x lower" if r >= 1 else f"{1 / r:.3g} x higher"


def _where_text(res: dict) -> str:
    """Where an unexplained mismatch is, in one sentence: points, modes, band (from ``located``)."""
    loc = res.get("located") or {}
    parts = []
    if loc.get("points"):
        parts.append(f"at point{'s' if len(loc['points']) > 1 else ''} {', '.join(str(p) for p in loc['points'])}")
    if loc.get("modes"):
        parts.append(f"in mode{'s' if len(loc['modes']) > 1 else ''} {', '.join(str(m) for m in loc['modes'])}")
    extra = loc.get("extra_resonances") or []
    if extra:
        parts.append("with resonance" + ("s" if len(extra) > 1 else "") + " the model does not have at "
                     + ", ".join(f"{r['frequency_hz']:.2f} Hz (zeta {r['damping_ratio']:.3g}, point {r['point']})"
                                 for r in extra))
    return f" Located {'; '.join(parts)}." if parts else ""


def _selected_chi2(res: dict) -> float | None:
    """The chi-square of the selected effect's fit (its entry in ``ranked``), None when it has none there."""
    sel = res.get("selected") or []
    if not sel:
        return None
    effect = "+".join(x["effect"] for x in sel)
    where = sel[0]["location"] if len(sel) == 1 else {"first": sel[0]["location"], "second": sel[1]["location"]}
    for r in res.get("ranked") or []:
        if r["effect"] == effect and r["location"] == where:
            return r["chi2"]
    return None


def verdict(res: dict) -> str:
    """One paragraph: mismatch or not, what was selected and why, what the validation shows.

    Parameters
    ----------
    res : dict
        :meth:`DiagnosisResult.as_dict`.

    Returns
    -------
    str
        Plain text (no markup). The selection rule is the pipeline's
        (:mod:`vlab.diagnose.pipeline`): lowest BIC, at least 10 below the
        nominal model's, explaining the mismatch; the validation's misfit ratio
        is given as "N x lower" or "N x higher".
    """
    s = res["statistics"]
    n = s.get("n_obs")
    inst = res.get("instability") or {}
    first = f"Instability: {inst['summary']}. " if inst.get("unstable") else ""
    return first + _verdict_body(res, s, n)


def _mismatch_text(s: dict, n) -> str:
    """The tests the nominal lab failed (``statistics.mismatch_tests``), each with its statistic and limit."""
    parts = []
    for t in s.get("mismatch_tests") or []:
        if t["test"] == "chi2":
            parts.append(f"the nominal model's chi2 = {_fmt(t['statistic'])} over N = {n} residuals exceeds its limit "
                         f"{_fmt(t['limit'])}")
        elif t["test"] == "line":
            parts.append(f"one line stands out (largest squared residual {_fmt(t['statistic'])}, limit "
                         f"{_fmt(t['limit'])})")
        elif t["test"] == "model_form":
            parts.append(f"the nominal model's modes must move beyond their model-form uncertainty to fit (chi-square "
                         f"of the moves {_fmt(t['statistic'])}, limit {_fmt(t['limit'])}; most: {t['largest']} by "
                         f"{t['largest_sigmas']:+.3g} sigma)")
        elif t["test"] == "change":
            parts.append(f"without the model-error floor the recording differs from its reference: chi2 = "
                         f"{_fmt(t['statistic'])} over N = {n} residuals exceeds its limit {_fmt(t['limit'])} (with "
                         "the floor it is within)")
    if not parts:  # a result written without the tests: the total chi-square is what it quotes
        parts.append(f"the nominal model's chi2 = {_fmt(s['chi2_nominal'])} over N = {n} residuals (limit "
                     f"{_fmt(s['chi2_limit'])})")
    rate = (s.get("policy") or {}).get("false_alarm_rate")
    return "; ".join(parts) + (f" (false-alarm rate {rate:g})" if rate is not None else "")


def _remainder_text(rem: dict | None) -> str:
    """The verdict's sentence on a remainder the selected effect leaves (empty without one)."""
    if not rem:
        return ""
    where = []
    if rem.get("modes"):
        where.append("modes " + ", ".join(str(m) for m in rem["modes"]))
    if rem.get("points"):
        where.append("points " + ", ".join(str(p) for p in rem["points"]))
    line = rem.get("largest_line")
    if line:
        where.append(f"largest at {_fmt(line['frequency_hz'])} Hz, point {line['point']}")
    noise = rem.get("noise_misfit_decades")
    return (f" Explained in part: a remainder is left (misfit {_fmt(rem['misfit_decades'], 3)} decades on "
            f"{rem['judged_on']}" + (f", an exact model leaves {_fmt(noise, 3)}" if noise is not None else "")
            + (f"; {'; '.join(where)}" if where else "") + "), outside the library.")


def _verdict_body(res: dict, s: dict, n) -> str:
    """The verdict after the instability sentence: mismatch, selection, validation (:func:`verdict`)."""
    if not res["mismatch"]:
        if res.get("within_model_accuracy"):
            return (f"Within the model's accuracy: the nominal model's weighted residual chi2 = "
                    f"{_fmt(s['chi2_nominal'])} over N = {n} residuals is within the limit {_fmt(s['chi2_limit'])} "
                    "set by the measurement's and the model's own uncertainty, though beyond the measurement's "
                    "alone: no effect is proposed (see 'Uncertainty').")
        return (f"No significant mismatch: the nominal model's weighted residual chi2 = {_fmt(s['chi2_nominal'])} over "
                f"N = {n} residuals is within the noise limit {_fmt(s['chi2_limit'])}, so no effect is proposed.")
    text = "Mismatch: " + _mismatch_text(s, n) + "."
    sel = res.get("selected") or []
    if not sel and res.get("too_small_to_name"):
        pts = (res.get("located") or {}).get("points") or []
        where = f" at point{'s' if len(pts) > 1 else ''} {', '.join(str(p) for p in pts)}" if pts else ""
        return text + (f" A change{where}, beyond the noise but within the model's accuracy "
                       f"({100 * s.get('floor', 0.005):g} % a line): too small to name.")
    if not sel and res.get("outside_library"):
        part = [r for r in res.get("rejected") or [] if r.get("reason") in (
            "explains only part of the mismatch", "its validation rerun makes the fit worse")]
        best = ""
        if part and part[-1]["reason"].startswith("explains"):
            best = (f" (the best, {part[-1]['label']}, lowers the misfit only "
                    f"{part[-1]['misfit_before'] / part[-1]['misfit_after']:.3g} x)")
        elif part:
            r = part[-1]
            best = (f" (the best, {r['label']}, fails its validation rerun: FRF misfit "
                    f"{ratio_text(r['misfit_before'], r['misfit_after'])}, time-domain error "
                    f"{ratio_text(r['time_error_before'], r['time_error_after'])})")
        where = _where_text(res)
        return text + (f" It lies outside the library: no effect of it, alone or in pairs, explains more than part of "
                       f"it{best}.{where}")
    if not sel:
        worse = [r for r in res.get("rejected") or [] if r.get("reason") == "fits no better than the nominal lab"]
        if worse:
            return text + (f" No effect of the library fits the data better than the nominal model within its own "
                           f"uncertainty (the best, {worse[-1]['label']}, does not): the cause is not identified.")
        ev = (s.get("policy") or {}).get("evidence", 10.0)
        return text + (f" No hypothesis of the library (alone or in pairs) improves the BIC by {ev:g} or more and "
                       "explains it: the cause is not identified.")
    what = " + ".join(f"{x['effect']} at {format_location(x['location'])} "
                      f"({format_parameters(x['parameters'], x.get('ci95'), names=True)})" for x in sel)
    ranked = res.get("ranked") or []
    text += f" Selected: {what}"
    top_is_selected = bool(ranked) and (len(sel) > 1 or ranked[0]["effect"] == sel[0]["effect"]) and (
        ranked[0]["location"] == (sel[0]["location"] if len(sel) == 1 else
                                  {"first": sel[0]["location"], "second": sel[1]["location"]}))
    if top_is_selected:
        top = ranked[0]
        text += (f", the lowest BIC of {len(ranked)} fitted hypotheses (chi2 {_fmt(s['chi2_nominal'])} -> "
                 f"{_fmt(top['chi2'])}")
        if len(ranked) > 1:
            text += f"; the next, {ranked[1]['effect']} at {format_location(ranked[1]['location'])}, is " \
                    f"{_fmt(float(ranked[1]['score'] - top['score']))} higher"
        text += ")"
    text += "."
    alts = res.get("alternatives") or []
    if alts:
        text += f" Not separable by these data (BIC within 10): {', '.join(alts)}."
    v = res.get("validated") or {}
    ratio = ratio_text(v.get("misfit_before"), v.get("misfit_after"))
    if ratio:
        text += (f" Validation ({v.get('plant', 'model')}): misfit {_fmt(v['misfit_before'], 3)} -> "
                 f"{_fmt(v['misfit_after'], 3)} {misfit_unit(res)}, {ratio}")
        if v.get("noise_misfit") is not None:
            carried = (res.get("uncertainty") or {}).get("model_form") == "derived"
            text += (f"; the measured noise {'and the model form leave' if carried else 'alone leaves'} "
                     f"{_fmt(v['noise_misfit'], 3)}")
        text += "."
    text += _remainder_text(res.get("remainder"))
    cause = (res.get("instability") or {}).get("cause")
    if cause:
        text += (f" Its rerun oscillates by itself too (at {', '.join(_fmt(f, 4) for f in cause['rerun_frequencies_hz'][:2])}"
                 " Hz): the cause of the oscillation; a limit cycle's FRFs are not the lab's linear response, so the "
                 "misfit's fall does not judge it.")
    thr = res.get("detection_threshold") or {}
    if thr.get("threshold") is not None:
        q, unit = parameter_unit(thr["parameter"])
        text += (f" The smallest {thr['effect']} there that these data would show: {q} {_fmt(thr['threshold'], 3)}"
                 + (f" {unit}" if unit else "") + " (vlab detectability).")
    return text
