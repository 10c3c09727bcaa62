"""Choosing among fitted hypotheses: pruning by localisation, look-alikes separated by rerun, located places.

Complements :mod:`vlab.diagnose.fit` (information criteria) with the
decisions that need the whole diagnosis: which local hypotheses are worth
fitting (the sensitivity-based localisation points at them), which of two
look-alike effects a rerun of the experiment prefers, and where the
mismatch is once effects are fitted.
"""

from __future__ import annotations

import numpy as np

from ..errors import VlabError
from .data import FrfData
from .hypotheses import Combination, Hypothesis
from .labmodel import LabState
from .locate import located_places
from .problem import Problem
from .validate import validate

#: Effects that act only in the controller path (seen closed loop only).
CONTROLLER_PATH = ("loop_delay", "sensor_lag", "sensor_gain")
#: Effects whose frequency-domain model is a describing function: look-alikes are separated by a rerun.
NONLINEAR = ("saturation", "friction")


def rerun_key(h: Hypothesis) -> str:
    """Cache key of the rerun of hypothesis ``h`` at its fitted parameters."""
    return f"{h.label}:{np.asarray(h.params_).tobytes().hex()}"


def data_has_signals(data) -> bool:
    """True when ``data`` holds time histories (a rerun is possible)."""
    return isinstance(data, FrfData) and data.recording is not None


def tie_break_by_rerun(problem: Problem, nominal: LabState, chosen: Hypothesis, alts: list, plant: str,
                       notes: list, *, max_candidates: int = 3) -> tuple[Hypothesis, list]:
    """Choose among look-alike effects by the time-domain error of a rerun.

    A saturating amplifier and a lower channel gain give nearly the same FRF
    (the saturation's describing function is a gain), and so do Coulomb
    friction and a dashpot at one point; the rerun through the loop
    reproduces the clipping or the friction force itself, so the time
    histories separate them.

    Parameters
    ----------
    problem : Problem
    nominal : LabState
    chosen : Hypothesis
        The selected hypothesis.
    alts : list of Hypothesis
        Its look-alikes; those with as many parameters are compared.
    plant : str
        Unused: the comparison runs on the linear plant (the only one carrying friction).
    notes : list of str
        Receives a line with the time errors.
    max_candidates : int
        Most hypotheses rerun.

    Returns
    -------
    (Hypothesis, list of Hypothesis)
        The winner and the others.
    """
    cands = [chosen] + [h for h in alts if h.n_params == chosen.n_params][: max_candidates - 1]
    if len(cands) < 2:
        return chosen, alts
    errs = []
    for h in cands:
        try:
            v = validate(problem, nominal, problem.state_for(h, h.params_), plant="linear", spec_level=False,
                         key=rerun_key(h))
            errs.append(v.time_error_after)
        except (VlabError, ImportError):
            errs.append(float("inf"))
    j = int(np.argmin(errs))
    notes.append("look-alikes compared by rerun (time-domain error): "
                 + ", ".join(f"{h.label}: {e:.3g}" for h, e in zip(cands, errs)))
    best = cands[j]
    return best, [h for h in [chosen] + alts if h is not best]


STRUCTURAL = ("added_mass", "support_stiffness", "joint_flexibility", "member_stiffness")


def located_from_fits(res, chi2_0: float, *, share: float = 0.9) -> tuple[list, list]:
    """Points and members where the mismatch is, from the fitted local hypotheses of ``res`` (nonlinear best
    subset; ``chi2_0`` is the nominal chi-square).

    The first-order sensitivity ranking (:func:`vlab.diagnose.locate.sensitivity_localisation`)
    chose which local hypotheses were fitted; here each fitted local effect
    counts by the share of the nominal chi-square it removes: the selected
    effect's places, and every local effect removing at least ``share`` of
    what the best local effect removes (places the data cannot tell apart,
    e.g. mirror points). Without a selected local effect, the places the
    sensitivity ranking points at are returned when there is an unexplained
    mismatch.
    """
    parts = res.selected_parts
    local = [h for h in res.ranked if not isinstance(h, Combination)
             and ("point" in h.location or "points" in h.location or "member" in h.location)]
    pts: list = []
    mems: list = []

    def add(h: Hypothesis) -> None:
        loc = h.location
        for p in ([loc["point"]] if "point" in loc else loc.get("points", [])):
            if p not in pts:
                pts.append(p)
        if "member" in loc:
            name = loc["member"] if "segment" not in loc else f"{loc['member']}[{loc['segment'][0]}-{loc['segment'][1]}]"
            if name not in mems:
                mems.append(name)

    for h in parts:
        add(h)
    sel_local = [h for h in parts if "point" in h.location or "points" in h.location or "member" in h.location]
    if sel_local and local:
        gain = max(chi2_0 - h.chi2_ for h in local)
        for h in local:
            if chi2_0 - h.chi2_ >= share * gain and h.effect in {p.effect for p in sel_local}:
                add(h)
    if res.selected is None and res.mismatch:
        return located_places(res.location.sensitivity)
    return pts, mems


def prune(hyps: list[Hypothesis], sensitivity: list[dict], *, share: float = 0.25, per_family: int = 6,
          min_explained: float = 0.2) -> list[Hypothesis]:
    """Keep, of ``hyps``, the local structural hypotheses the ``sensitivity`` ranking points at.

    When the best single local parameter explains at least ``min_explained`` of
    the frequency errors, a local structural hypothesis (added mass, spring at a
    free DOF, joint flexibility, member rigidity) is kept if its sensitivity
    candidate explains at least ``share`` of the best one or is among the
    ``per_family`` best of its effect; its first-order size becomes an extra
    trial value (``estimate_``). Other hypotheses are all kept.
    """
    if not sensitivity or sensitivity[0]["explained"] < min_explained:
        return hyps
    best = sensitivity[0]["explained"]
    by_key = {}
    rank_in_family: dict = {}
    for d in sensitivity:
        key = (d["effect"], tuple(sorted((k, tuple(v) if isinstance(v, list) else v)
                                         for k, v in d["location"].items())))
        rank_in_family[d["effect"]] = rank_in_family.get(d["effect"], 0) + 1
        by_key[key] = (d, rank_in_family[d["effect"]])
    out = []
    for h in hyps:
        if h.effect not in STRUCTURAL:
            out.append(h)
            continue
        key = (h.effect, tuple(sorted((k, tuple(v) if isinstance(v, list) else v) for k, v in h.location.items())))
        hit = by_key.get(key)
        if hit is None:
            out.append(h)  # not a local frequency parameter (e.g. a released support): keep
            continue
        d, r = hit
        if d["explained"] >= share * best or r <= per_family:
            h.estimate_ = d["estimate"]
            out.append(h)
    return out
