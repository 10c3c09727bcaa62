"""The verdict of a diagnosis: one paragraph written from its JSON object, so that every number in it is the
JSON's (mismatch tests, selection, validation, remainder, detection threshold)."""

from __future__ import annotations

import math

from .text import (_fmt, finite_numbers, format_location, format_parameters, misfit_unit, parameter_unit, ratio_text,
                   separable_why)


def _where_text(res: dict) -> str:
    """Where an unexplained mismatch is, in one sentence: points, modes, resonances the model lacks (from
    ``located``); the whole mismatch is then the remainder, whose size the mismatch sentence states."""
    loc = res.get("located") or {}
    parts = []
    if loc.get("points"):
        parts.append(f"at point{'s' if len(loc['points']) > 1 else ''} {', '.join(str(p) for p in loc['points'])}")
    if loc.get("modes"):
        parts.append(f"in mode{'s' if len(loc['modes']) > 1 else ''} {', '.join(str(m) for m in loc['modes'])}")
    extra = loc.get("extra_resonances") or []
    if extra:
        parts.append("with resonance" + ("s" if len(extra) > 1 else "") + " the model does not have at "
                     + ", ".join(f"{_fmt(r['frequency_hz'], 4)} Hz (damping ratio {_fmt(r.get('damping_ratio'), 3)}, "
                                 f"strongest at point {r['point']})" for r in extra))
    return f" Located {'; '.join(parts)}." if parts else ""


def nominal_fit_chi2(s: dict) -> float:
    """The nominal lab's chi-square on the fits' footing (``statistics.chi2_nominal_fit``: its residual
    whitened linearly by the model form, as every fitted effect's), the value a fitted effect's chi-square is
    compared with; ``chi2_nominal`` where absent (no model form: the two are one)."""
    v = s.get("chi2_nominal_fit")
    return float(s["chi2_nominal"] if v is None else v)


def selected_chi2(res: dict) -> float | None:
    """The chi-square of the selected effect's fit (its entry in ``res["ranked"]``), None when it has none there."""
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
        Plain text (no markup). It names the mismatch tests that failed
        (``statistics.mismatch_tests``), the selection and why (the decision
        policy's rules, :mod:`vlab.diagnose.fit.rules`), the validation's misfit
        ratio ("N x lower" or "N x higher"), a remainder, or why nothing is
        selected; every number is one of ``res``.
    """
    s = res["statistics"]
    n = s.get("n_obs")
    inst = res.get("instability") or {}
    first = f"Instability: {inst['summary']}. " if inst.get("unstable") else ""
    return first + _verdict_body(res, s, n)


def mismatch_text(s: dict, n) -> str:
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
        elif t["test"] == "model_form_largest":
            parts.append(f"one of the nominal model's modes must move beyond its model-form uncertainty to fit "
                         f"({t['largest']} by {t['largest_sigmas']:+.3g} sigma, limit {math.sqrt(t['limit']):.3g})")
        elif t["test"] == "change":
            parts.append(f"without the model-error floor the recording differs from its reference: chi2 = "
                         f"{_fmt(t['statistic'])} over N = {n} residuals exceeds its limit {_fmt(t['limit'])} (with "
                         "the floor it is within)")
        elif t["test"] == "oscillation":
            parts.append(f"the recording oscillates by itself at {_fmt(t['frequency_hz'])} Hz and the nominal lab's "
                         f"replay does not (the line's power over its channel's incoherent floor "
                         f"{_fmt(t['statistic'])}, limit {_fmt(t['limit'])})")
    if not parts:  # a result written without the tests: the total chi-square is what it quotes
        parts.append(f"the nominal model's chi2 = {_fmt(s['chi2_nominal'])} over N = {n} residuals (limit "
                     f"{_fmt(s['chi2_limit'])})")
    rate = (s.get("policy") or {}).get("false_alarm_rate")
    return "; ".join(parts) + (f" (false-alarm rate {rate:g})" if rate is not None else "")


def _remainder_text(rem: dict | None, unit: str = "decades") -> str:
    """The verdict's sentence on a remainder the selected effect leaves (empty without one); ``unit``: the
    misfit's (:func:`misfit_unit`)."""
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
    why = ("; the choice is nonlinear: part of it may be the error of its value, fitted through a describing "
           "function)" if rem.get("nonlinear_choice") else "), outside the library")
    return (f" Explained in part: a remainder is left (misfit {_fmt(rem['misfit_decades'], 3)} {unit} on "
            f"{rem['judged_on']}" + (f", an exact model leaves {_fmt(noise, 3)}" if noise is not None else "")
            + (f"; {'; '.join(where)}" if where else "") + why + ".")


def _best_rejected_text(res: dict) -> str:
    """The clause of an outside-library verdict that says how the best candidate failed (empty if none
    was rejected for explaining only part or for its validation rerun)."""
    part = [r for r in res.get("rejected") or [] if str(r.get("reason", "")).startswith(
        ("explains only part of the mismatch", "its validation rerun makes the fit worse"))]
    best = ""
    if part and part[-1]["reason"].startswith("explains"):
        best = (f" (the best, {part[-1]['label']}, lowers the misfit only "
                f"{part[-1]['misfit_before'] / part[-1]['misfit_after']:.3g} x"
                + (f" and is not separated from {len(part[-1]['look_alikes'])} look-alike(s)"
                   if part[-1].get("look_alikes") else "") + ")")
    elif part:
        r = part[-1]
        chi2 = (f"chi2 {_fmt(r['chi2_before'])} -> {_fmt(r['chi2_after'])}, "
                if finite_numbers(r, "chi2_before", "chi2_after") else "")
        best = (f" (the best, {r['label']}, fails its validation rerun: {chi2}FRF misfit "
                f"{ratio_text(r['misfit_before'], r['misfit_after'])}, time-domain error "
                f"{ratio_text(r['time_error_before'], r['time_error_after'])})")
    return best


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
    text = "Mismatch: " + mismatch_text(s, n) + "."
    sel = res.get("selected") or []
    if not sel and res.get("too_small_to_name"):
        pts = (res.get("located") or {}).get("points") or []
        where = f" at point{'s' if len(pts) > 1 else ''} {', '.join(str(p) for p in pts)}" if pts else ""
        return text + (f" A change{where}, beyond the noise but within the model's accuracy "
                       f"({100 * s.get('floor', 0.005):g} % a line): too small to name.")
    if not sel and res.get("outside_library"):
        best = _best_rejected_text(res)
        where = _where_text(res)
        return text + (f" It lies outside the library: no effect of it, alone or in pairs, explains more than part of "
                       f"it{best}.{where}")
    inst = res.get("instability") or {}
    if not sel and inst.get("unstable") and inst.get("in_replay") is False:
        tried = [r["label"] for r in res.get("rejected") or []
                 if str(r.get("reason", "")).startswith("does not reproduce the self-excited oscillation")]
        return text + (" No effect of the library whose linear loop is unstable reproduces the self-excited "
                       f"oscillation at {_fmt(inst.get('frequency_hz'), 5)} Hz in its rerun"
                       + (f" (rerun: {', '.join(tried)})" if tried else " (none was unstable and supported by the data)")
                       + ": the cause is not identified." + _where_text(res))
    if not sel:
        worse = [r for r in res.get("rejected") or [] if r.get("reason") == "fits no better than the nominal lab"]
        if worse:
            return text + (f" No effect of the library fits the data better than the nominal model within its own "
                           f"uncertainty (the best, {worse[-1]['label']}, does not): the cause is not identified."
                           + _where_text(res))
        ev = (s.get("policy") or {}).get("evidence", 10.0)
        return text + (f" No hypothesis of the library (alone or in pairs) improves the BIC by {ev:g} or more and "
                       "explains it: the cause is not identified." + _where_text(res))
    what = " + ".join(f"{x['effect']} at {format_location(x['location'])} "
                      f"({format_parameters(x['parameters'], x.get('ci95'), names=True)})" for x in sel)
    ranked = res.get("ranked") or []
    text += f" Selected: {what}"
    top_is_selected = bool(ranked) and (len(sel) > 1 or ranked[0]["effect"] == sel[0]["effect"]) and (
        ranked[0]["location"] == (sel[0]["location"] if len(sel) == 1 else
                                  {"first": sel[0]["location"], "second": sel[1]["location"]}))
    if top_is_selected:
        top = ranked[0]
        text += (f", the lowest BIC of {len(ranked)} fitted hypotheses (chi2 {_fmt(nominal_fit_chi2(s))} -> "
                 f"{_fmt(top['chi2'])}")
        if len(ranked) > 1:
            text += f"; the next, {ranked[1]['effect']} at {format_location(ranked[1]['location'])}, is " \
                    f"{_fmt(float(ranked[1]['score'] - top['score']))} higher"
        text += ")"
    text += "."
    alts = res.get("alternatives") or []
    if alts:
        text += f" Not separable by these data ({separable_why(res)}): {', '.join(alts)}."
    v = res.get("validated") or {}
    ratio = ratio_text(v.get("misfit_before"), v.get("misfit_after"))
    if ratio:
        text += (f" Validation ({v.get('plant', 'model')}): misfit {_fmt(v['misfit_before'], 3)} -> "
                 f"{_fmt(v['misfit_after'], 3)} {misfit_unit(res)}, {ratio}")
        if v.get("phase_misfit_before") is not None:
            text += (f" (with phase {_fmt(v['phase_misfit_before'], 3)} -> {_fmt(v['phase_misfit_after'], 3)}, "
                     f"{ratio_text(v['phase_misfit_before'], v['phase_misfit_after'])})")
        if finite_numbers(v, "chi2_before", "chi2_after"):
            text += (f"; chi2 on the fit's footing {_fmt(v['chi2_before'])} -> {_fmt(v['chi2_after'])}"
                     + (f" (a change beyond {_fmt(v['chi2_change_limit'])} is resolved)"
                        if v.get("chi2_change_limit") is not None else ""))
        if v.get("noise_misfit") is not None:
            carried = (res.get("uncertainty") or {}).get("model_form") == "derived"
            text += (f"; the measured noise {'and the model form leave' if carried else 'alone leaves'} "
                     f"{_fmt(v['noise_misfit'], 3)}")
        text += "."
    text += _remainder_text(res.get("remainder"), misfit_unit(res))
    osc = res.get("instability") or {}
    if osc.get("unexplained"):
        text += (f" The self-excited oscillation at {_fmt(osc['frequency_hz'], 4)} Hz is not reproduced by the rerun of "
                 "any candidate tried: it remains unexplained.")
    cause = osc.get("cause")
    if cause:
        text += (f" Its rerun oscillates by itself too (at {', '.join(_fmt(f, 4) for f in cause['rerun_frequencies_hz'][:2])}"
                 " Hz): the cause of the oscillation; a limit cycle's FRFs are not the lab's linear response, so the "
                 "misfit's fall does not judge it, nor can they show whether anything else changed beside it (no "
                 "remainder is judged: diagnose a recording without the oscillation: open loop, or with a lower loop gain).")
    thr = res.get("detection_threshold") or {}
    if thr.get("threshold") is not None:
        q, unit = parameter_unit(thr["parameter"])
        text += (f" The smallest {thr['effect']} there that these data would show: {q} "
                 f"{_fmt(thr['threshold'], _digits_beside(thr['threshold'], thr.get('null')))}"
                 + (f" {unit}" if unit else "") + " (vlab detectability).")
    return text


def _digits_beside(value, null, least: int = 3) -> int:
    """Significant digits that show ``value`` apart from ``null`` with two digits of their difference (a gain
    threshold of 1.0031 beside its null 1 is not printed as "1"); ``least`` when there is no null."""
    try:
        value, null = float(value), float(null)
    except (TypeError, ValueError):
        return least
    if not (math.isfinite(value) and math.isfinite(null)) or value == null:
        return least
    scale = max(abs(value), abs(null))
    return max(least, math.ceil(math.log10(scale / abs(value - null))) + 2)
