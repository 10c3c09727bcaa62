"""Readable numbers for the diagnosis's reports and the command line: parameters with their units, places,
misfit units, ratios. Plain text, no markup."""

from __future__ import annotations

import numpy as np


def _ok(a, b) -> bool:
    return a is not None and b is not None and np.isfinite(a) and np.isfinite(b) and b > 0


def finite_numbers(d: dict, *keys: str) -> bool:
    """Whether every one of ``keys`` of the report dict ``d`` is a finite number (missing, a JSON null or NaN
    is not)."""
    return all(isinstance(d.get(k), (int, float)) and np.isfinite(d[k]) for k in keys)


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
    """What the misfits of a diagnosis ``res`` (:meth:`DiagnosisResult.as_dict`) measure: ``"decades"`` (FRF
    data) or ``"rel. freq. error"`` (modal data)."""
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


def separable_why(res: dict) -> str:
    """Why the JSON result ``res``'s ``alternatives`` are look-alikes of the selection: within the policy's
    evidence (10) in BIC, or -- those in ``alternatives_by_prediction`` -- their fitted predictions within
    the chi-square limit of the selection's (:mod:`vlab.diagnose.fit.separation`)."""
    by = res.get("alternatives_by_prediction") or {}
    dist = by.get("distance_chi2") or {}
    parts = []
    if any(a not in dist for a in res.get("alternatives") or []):
        parts.append("BIC within 10")
    if dist:
        parts.append(f"{', '.join(dist)}: predictions within chi-square {_fmt(float(by['limit_chi2']))} of the "
                     "selection's")
    return "; ".join(parts)
