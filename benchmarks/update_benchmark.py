"""Benchmark of ``vlab update``: conceal an effect in the plant, record, diagnose, update, redesign, rerun.

Each case conceals one effect of known size: a structural one in the MuJoCo plant (the structure's spec changed
with :mod:`vlab.diagnose.effects.specedit`, which keeps the damping matrix of a physical change;
exported as MJCF), a coil's gain in the plant (the exported MJCF's ``gainprm``), or a gain, delay or lag
of one channel in the lab's hardware chain (the chain the runs use, hidden from the models: the
recording's metadata does not hold it). It records a closed-loop
MFDRF (or ``--controller lqdrf``) experiment on it with the controller designed on the nominal model, diagnoses the recording blind
(``vlab.diagnose``), writes the updated structure file (``vlab.update``) and runs the controller designed on
the original and on the updated file against the same changed plant and chain (:func:`vlab.model_update.verify`).

Printed per case: what was concealed, what the diagnosis selected (or why it refused), the average peak
level error (Table 10's measure, ``mean |1 - r|``) of the design on the original and on the updated model,
and the largest relative difference between the closed-loop damping ratios predicted and measured for the
updated design. The criteria (each printed as pass/fail, a case whose diagnosis is wrong or refused is
reported as such, not dropped):

- the updated design's error is at most half of the original design's;
- at most 0.03 where the original design's error is above 0.06;
- closed-loop damping ratios measured within 10 % of those predicted.

Usage::

    python benchmarks/update_benchmark.py [--cases cantilever|bcc|grid|all|chain] [--controller mfdrf|lqdrf]
                                          [--work DIR]
    python benchmarks/update_benchmark.py --draw SEED [--structures bcc [grid]] [--limit N] [--out FILE] [--work DIR]

The structures: ``examples/cantilever_tip_mass.toml`` (a few seconds a case), the BCC (minutes a case:
its diagnosis dominates) and the grid (one case, longer). The sizes are fixed, chosen by hand well above the detection threshold (the
diagnosis names the cantilever's 0.3 g mass at point 3; the cases add 10-40 g), not drawn. ``--cases chain``
runs the chain cases of all three structures.

``--draw SEED`` draws the cases instead (:func:`draw_cases`, ``numpy.random.default_rng(SEED)``): on each
structure asked (the BCC by default; the grid is slow), two of every kind of :data:`DRAW_KINDS` -- the
structural ones (added mass, grounded spring at a free point, softened joint, member or segment EI, one mode's
damping ratio) concealed in the plant with :mod:`vlab.diagnose.effects.specedit`, a coil's ``gainprm``, and a
sensor gain, coil gain, delay, actuator lag or sensor lag of one channel or of all in the hidden lab chain --
and two null cases (nothing concealed: the diagnosis should find no mismatch and ``vlab update`` refuse). Each
at a location (and side of the null value) drawn uniformly among those where the effect is detectable, with a
size ``k`` times its detection threshold, ``k`` log-uniform in [2, 5] (distance from the null value: the
difference above it, the log ratio below it, the compliance for a joint or lag, :func:`_size`; ``--k LO HI``
for other sizes), and its own seed for the recording's excitation and noise. The thresholds are vlab's own
(:func:`vlab.diagnose.detectability.detectability`) for the closed-loop test with the benchmark's controller,
``model_form="plant"`` (a recording the MuJoCo plant made, compared through that plant's replay without a
model form, as the diagnosis reads the draws' recordings, whose metadata name their plant), computed once and
cached in ``docs/validation/data/detectability_<structure>_<controller>_plant.json``. They are not those of the shipped
open-loop table (``detectability_bcc_open_loop.csv``): the closed loop moves and damps the peaks, and its
per-channel chain effects exist only there. The cases run in rounds (one null case and one of every kind,
kinds shuffled, then the rest) so that a run stopped early (``--limit N``) covers every kind once. Each case
is printed as it ends (and written with ``--out``): what was concealed, ``k``, the two errors, the three
criteria, the time, how the diagnosis compares (right / WRONG effect / WRONG place / missed / not named / for
null cases a false alarm) with the fitted size over the concealed one, and what it selected; then a summary.

The measured runs are listed in ``docs/validation/data/update_benchmark_draw_*.txt`` (the listing index:
``docs/benchmark-listings.md``).
"""

from __future__ import annotations

import argparse
import math
import tempfile
import time
from pathlib import Path

from _listing import vlab_commit

import vlab
from vlab.design import design_controller
from vlab.diagnose.effects import specedit
from vlab.errors import VlabError
from vlab.experiment.config import ExperimentConfig, default_chain
from vlab.experiment.runner import measure
from vlab.experiment.settling import slowest_decay_rate
from vlab.fe import build_fe_model
from vlab.io.uff import write_recording
from vlab.model_update import verify
from vlab.sim import build_plant, export_mjcf
from vlab.spec import Hardware, load_spec

ROOT = Path(__file__).resolve().parent.parent
CANTILEVER = ROOT / "examples" / "cantilever_tip_mass.toml"


def _damping_deviation(modes: list[dict]) -> float:
    """Largest ``|zeta_measured / zeta_predicted - 1|`` over the closed-loop modes that have a damping ratio in
    both (an overdamped closed-loop pair, e.g. LQDRF's mode 1 at zeta ~ 1, has two real poles and none: left
    out); NaN when no mode has one."""
    pairs = [(m["damping_ratio_measured"], m["damping_ratio_predicted"]) for m in modes]
    dev = [abs(a / b - 1) for a, b in pairs if a is not None and b is not None and math.isfinite(a)
           and math.isfinite(b) and b > 0]
    return max(dev) if dev else float("nan")


def _coil_gain(point: int, gain: float):
    """The edit that gives the plant's coil at ``point`` the force per command ``gain`` (its ``gainprm``)."""
    return lambda s: s.replace(hardware=Hardware(actuator_gain={point: gain}))


def _same(s):
    return s


#: Chain cases: (structure, label, edit of the plant's spec, run length [s] or None, the lab chain's settings
#: hidden from the models: keyword arguments of :func:`vlab.experiment.config.default_chain`)
CHAIN_CASES = {
    "cantilever": [
        (CANTILEVER, "sensor_gain 0.7 on channel 4", _same, 4.0, {"sensor_gain": {4: 0.7}}),
        (CANTILEVER, "sensor_gain 1.25 on channel 6", _same, 4.0, {"sensor_gain": {6: 1.25}}),
        (CANTILEVER, "coil 6 gainprm 1.4 (plant)", _coil_gain(6, 1.4), 4.0, {}),
        (CANTILEVER, "actuator_gain 0.75 on channel 4 (chain)", _same, 4.0, {"actuator_gain": {4: 0.75}}),
        (CANTILEVER, "loop_delay 6 periods on channel 4", _same, 4.0, {"channel_delay_periods": {4: 6.0}}),
        (CANTILEVER, "actuator_lag 80 Hz on every coil", _same, 4.0,
         {"channel_actuator_lag_hz": {6: 80.0, 4: 80.0}}),
        (CANTILEVER, "sensor_lag 100 Hz on channel 6", _same, 4.0, {"channel_sensor_lag_hz": {6: 100.0}}),
        (CANTILEVER, "sensor_gain 0.97 on channel 4", _same, 4.0, {"sensor_gain": {4: 0.97}}),
        (CANTILEVER, "coil 4 gainprm 1.05 (plant)", _coil_gain(4, 1.05), 4.0, {}),
        (CANTILEVER, "loop_delay 2.5 periods on channel 6", _same, 4.0, {"channel_delay_periods": {6: 2.5}}),
        (CANTILEVER, "actuator_lag 300 Hz on channel 6", _same, 4.0, {"channel_actuator_lag_hz": {6: 300.0}}),
        (CANTILEVER, "sensor_lag 400 Hz on channel 4", _same, 4.0, {"channel_sensor_lag_hz": {4: 400.0}}),
    ],
    "bcc": [
        ("bcc", "sensor_gain 0.8 on channel 7", _same, None, {"sensor_gain": {7: 0.8}}),
        ("bcc", "coil 9 gainprm 1.3 (plant)", _coil_gain(9, 1.3), None, {}),
        ("bcc", "loop_delay 5 periods on channel 5", _same, None, {"channel_delay_periods": {5: 5.0}}),
        ("bcc", "actuator_lag 60 Hz on channel 9", _same, None, {"channel_actuator_lag_hz": {9: 60.0}}),
    ],
    "grid": [
        ("grid", "sensor_gain 0.8 on channel 2", _same, None, {"sensor_gain": {2: 0.8}}),
    ],
}

#: (structure, label, edit of the spec, run length [s] or None for the structure's default)
CASES = {
    "cantilever": [
        (CANTILEVER, "added_mass 0.04 kg at point 3", lambda s: specedit.add_mass(s, 3, 0.04), 4.0),
        (CANTILEVER, "added_mass 0.015 kg at point 5", lambda s: specedit.add_mass(s, 5, 0.015), 4.0),
        (CANTILEVER, "spring 300 N/m at point 5", lambda s: specedit.add_spring(s, 5, "w", 300.0), 4.0),
        (CANTILEVER, "clamp rx 400 N*m/rad (support released)", lambda s: specedit.add_spring(s, 1, "rx", 400.0),
         4.0),
        (CANTILEVER, "strip EI x 0.85", lambda s: specedit.scale_member(s, "strip", 0.85), 4.0),
        (CANTILEVER, "segment 2-3 EI x 0.6", lambda s: specedit.scale_segments(s, {(2, 3): 0.6}), 4.0),
        (CANTILEVER, "mode 2 damping 0.02", lambda s: specedit.set_modal_damping(s, 2, 0.02), 4.0),
        (CANTILEVER, "mode 1 damping 0.005", lambda s: specedit.set_modal_damping(s, 1, 0.005), 4.0),
        (CANTILEVER, "joint at point 3, 300 N*m/rad", lambda s: specedit.soften_joint(s, 3, 300.0), 4.0),
        (CANTILEVER, "joint at point 4, 150 N*m/rad", lambda s: specedit.soften_joint(s, 4, 150.0), 4.0),
    ],
    "bcc": [
        ("bcc", "added_mass 0.12 kg at point 6", lambda s: specedit.add_mass(s, 6, 0.12), None),
        ("bcc", "spring 150 N/m at point 5", lambda s: specedit.add_spring(s, 5, "w", 150.0), None),
        ("bcc", "beam segment 6-7 EI x 0.7", lambda s: specedit.scale_segments(s, {(6, 7): 0.7}), None),
        ("bcc", "mode 3 damping x 2", lambda s: specedit.set_modal_damping(
            s, 3, 2 * (s.damping.modal_ratios[2] if len(s.damping.modal_ratios) > 2 else s.damping.default_ratio)),
         None),
    ],
    "grid": [
        ("grid", "added_mass 1.0 kg at joint 6", lambda s: specedit.add_mass(s, 6, 1.0), None),
    ],
}


def _record(nominal, controller: str, plant: Path, lab, duration_s, work: Path) -> Path:
    """The closed-loop recording of the design on ``nominal`` run on ``plant`` with the lab chain ``lab``."""
    fe = build_fe_model(nominal)
    design = design_controller(fe, controller, seed=0, period_s=lab.period_s)
    cfg = ExperimentConfig(structure=nominal.name, controller=controller, duration_s=duration_s, chain=lab,
                           plant="mujoco", mjcf=plant)
    m = measure(cfg, fe, design, decay_rate_1_s=slowest_decay_rate(fe, design))
    (work / "exp").mkdir()
    return write_recording(work / "exp" / "recording.uff", m.loop.recording, overwrite=False)


def run_case(structure, label: str, edit, duration_s, work: Path, controller: str = "mfdrf",
             chain: dict | None = None) -> dict:
    """One case: conceal, record, diagnose, update, verify. Returns the row printed.

    ``chain``: settings of the lab's chain hidden from the models (:func:`default_chain` keywords); None or
    empty: the thesis chain."""
    nominal = load_spec(structure)
    work.mkdir(parents=True)
    plant = export_mjcf(build_plant(edit(nominal)), work / "plant.xml")
    lab = default_chain(controller, noise_m_s=1e-6, **chain) if chain else None
    t0 = time.perf_counter()
    if lab is None:
        vlab.run_experiment(nominal, controller, mjcf=plant, duration_s=duration_s, out_dir=work / "exp")
    else:
        _record(nominal, controller, plant, lab, duration_s, work)
    res = vlab.diagnose(nominal, work / "exp" / "recording.uff", out_dir=work / "diag")
    d = res.as_dict()
    sel = "; ".join(f"{e['effect']} {e['location']} {e['parameters']}" for e in d["selected"]) or "nothing"
    row = {"case": label, "selected": sel}
    try:
        upd = vlab.update(nominal, work / "diag", out=work / "updated.toml")
    except VlabError as exc:
        row.update(refused=str(exc).split(": ", 1)[-1][:120])
        return row
    v = verify(nominal, upd.path, plant, controller=controller, duration_s=duration_s, lab_chain=lab)
    e0, e1 = v["original"]["average_peak_level_error"], v["updated"]["average_peak_level_error"]
    dz = _damping_deviation(v["updated"]["modes"])
    row.update(e_original=e0, e_updated=e1, damping_dev=dz, seconds=time.perf_counter() - t0,
               half=e1 <= 0.5 * e0, below_003=(e1 <= 0.03) if e0 > 0.06 else None, damping_ok=dz <= 0.10)
    return row


#: The effect kinds ``--draw`` conceals: kind -> the library effect whose detection threshold sizes it
DRAW_KINDS = {"added_mass": "added_mass", "support_stiffness": "support_stiffness",
              "joint_flexibility": "joint_flexibility", "member_stiffness": "member_stiffness",
              "modal_damping": "damping", "coil_gain": "actuator_gain", "sensor_gain": "sensor_gain",
              "actuator_gain": "actuator_gain", "loop_delay": "loop_delay", "actuator_lag": "actuator_lag",
              "sensor_lag": "sensor_lag"}

#: The library effects whose thresholds ``--draw`` needs
DRAW_EFFECTS = tuple(sorted(set(DRAW_KINDS.values())))


def _key(location: dict) -> str:
    """A location as a comparable string (a segment's tuple and list alike)."""
    return str(sorted((k, list(v) if isinstance(v, (list, tuple)) else v) for k, v in location.items()))


def _rel(path: Path) -> str:
    """``path`` relative to the repository where it lies in it."""
    try:
        return str(Path(path).resolve().relative_to(ROOT))
    except ValueError:
        return str(path)


def draw_thresholds(structure: str, controller: str, cache: Path, model_form: str = "plant") -> dict:
    """The detection thresholds of ``structure``'s closed-loop test with ``controller`` (cached as JSON).

    :func:`vlab.diagnose.detectability.detectability` with ``model_form``: ``"plant"`` (default) for a
    recording the MuJoCo plant made, referred through that plant's replay without a model form, as the
    diagnosis reads the benchmark's recordings (their metadata name the plant that made them); ``"derived"``
    for a recording of another source read as real data (tier 3); restricted to :data:`DRAW_EFFECTS`, no
    naming thresholds. Computed once and written to ``cache``; a cache of another model form is refused.

    Raises
    ------
    ValueError
        ``cache`` holds the thresholds of another model form."""
    import json
    if cache.exists():
        d = json.loads(cache.read_text())
        if d.get("model_form") != model_form:
            raise ValueError(f"{cache}: thresholds of model form {d.get('model_form')!r}, {model_form!r} asked")
        return d
    from vlab.diagnose.detectability import detectability
    t0 = time.perf_counter()
    d = detectability(structure, controller, effects=DRAW_EFFECTS, model_form=model_form, naming=False).as_dict()
    d["seconds"] = time.perf_counter() - t0
    cache.parent.mkdir(parents=True, exist_ok=True)
    cache.write_text(json.dumps(d, indent=1, default=float))
    return d


def _valid(kind: str, thresholds: list[dict]) -> list[dict]:
    """The thresholds (location and side) at which ``kind`` can be concealed: detected within its range,
    one point, coil or channel that the concealment can change."""
    eff = DRAW_KINDS[kind]
    out = []
    for t in thresholds:
        loc = t["location"]
        if t["effect"] != eff or t["threshold"] is None:
            continue
        if "points" in loc:  # a group of points: not drawn
            continue
        if kind == "support_stiffness" and loc.get("dof") != "w":  # released supports: not drawn
            continue
        if kind == "modal_damping" and "mode" not in loc:  # point dashpots: no spec edit
            continue
        if kind == "coil_gain" and loc.get("channel") == "all":  # one coil's gainprm
            continue
        if kind == "loop_delay" and t["threshold"] < t["null"]:  # a delay below the chain's 1.35 periods: not drawn
            continue
        out.append(t)
    return out


def _size(t: dict, k: float) -> float:
    """The value of ``t``'s parameter ``k`` times as far from its null value as the threshold.

    Distance: the difference from the null value, where the null is 0 (mass, spring) or the size is above it
    (gains, EI, damping ratios, the total delay above the chain's 1.35 periods); the log of the ratio to the null
    below it (so that a smaller gain, EI or damping ratio stays positive); the compliance (1/value) where the
    null is a limit (a rigid joint, a lag of infinite corner frequency)."""
    null, thr = t["null"], t["threshold"]
    if null is None:
        return thr / k
    if thr > null:
        return null + k * (thr - null)
    return null * (thr / null) ** k


def draw_cases(seed: int, structure: str, controller: str, thresholds: dict, *, per_kind: int = 2,
               nulls: int = 2, k_range: tuple[float, float] = (2.0, 5.0)) -> list[dict]:
    """The concealed effects of ``--draw``: ``per_kind`` of each kind of :data:`DRAW_KINDS` and ``nulls`` null
    cases, in rounds (each round: one null case, if left, and one case of every kind, kinds shuffled), so that
    a run stopped early has covered every kind once before any twice.

    Each case: a location and side drawn uniformly among :func:`_valid`'s, a size ``k`` times the threshold's
    distance from the null value (:func:`_size`), ``k`` log-uniform in ``k_range``, and a seed for the recording's
    excitation and noise."""
    import numpy as np
    rng = np.random.default_rng(seed)
    period_s = default_chain(controller).period_s
    cases = []
    for r in range(max(per_kind, nulls)):
        kinds = [str(x) for x in rng.permutation(list(DRAW_KINDS))] if r < per_kind else []
        if r < nulls:
            cases.append({"structure": structure, "kind": "null", "label": "nothing concealed", "k": None,
                          "edit": _same, "chain": {}, "expect": None, "seed": int(rng.integers(2**31))})
        for kind in kinds:
            valid = _valid(kind, thresholds["thresholds"])
            locs = sorted({_key(t["location"]) for t in valid})
            loc = locs[int(rng.integers(len(locs)))]
            sides = [t for t in valid if _key(t["location"]) == loc]
            t = sides[int(rng.integers(len(sides)))]
            k = float(np.exp(rng.uniform(np.log(k_range[0]), np.log(k_range[1]))))
            cases.append(_conceal(structure, kind, t, k, _size(t, k), period_s, int(rng.integers(2**31))))
    return cases


def _conceal(structure: str, kind: str, t: dict, k: float, x: float, period_s: float, seed: int) -> dict:
    """One drawn case: the spec edit or the chain settings that conceal ``kind`` of size ``x`` at ``t``'s place."""
    loc, edit, chain = t["location"], _same, {}
    p, c = loc.get("point"), loc.get("channel")
    if kind == "added_mass":
        edit, what = (lambda s: specedit.add_mass(s, p, x)), f"{x:.4g} kg at point {p}"
    elif kind == "support_stiffness":
        edit, what = (lambda s: specedit.add_spring(s, p, "w", x)), f"{x:.4g} N/m at point {p}"
    elif kind == "joint_flexibility":
        edit, what = (lambda s: specedit.soften_joint(s, p, x)), f"{x:.4g} N*m/rad at point {p}"
    elif kind == "member_stiffness":
        f, seg = x / t["null"], loc.get("segment")
        if seg:
            edit = lambda s: specedit.scale_segments(s, {tuple(seg): f})  # noqa: E731
            what = f"{loc['member']} {seg[0]}-{seg[1]} EI x {f:.4g}"
        else:
            edit, what = (lambda s: specedit.scale_member(s, loc["member"], f)), f"{loc['member']} EI x {f:.4g}"
    elif kind == "modal_damping":
        m = loc["mode"]
        edit, what = (lambda s: specedit.set_modal_damping(s, m, x)), f"mode {m} ratio {t['null']:.4g} -> {x:.4g}"
    elif kind == "coil_gain":
        edit, what = _coil_gain(c, x), f"coil {c} gainprm {x:.4g} (plant)"
    else:
        # the channels the chain's dicts name: one, or every coil for "all"
        chans = list(load_spec(structure).instrumentation.actuators) if c == "all" else [c]
        key, val, unit = {"sensor_gain": ("sensor_gain", x, ""), "actuator_gain": ("actuator_gain", x, " (chain)"),
                          "loop_delay": ("channel_delay_periods", x / period_s, " periods (total)"),
                          "actuator_lag": ("channel_actuator_lag_hz", x, " Hz"),
                          "sensor_lag": ("channel_sensor_lag_hz", x, " Hz")}[kind]
        chain = {key: {ch: val for ch in chans}}
        what = f"{val:.4g}{unit} on channel {c}"
    expect = {"effect": DRAW_KINDS[kind], "location": loc}
    return {"structure": structure, "kind": kind, "label": f"{kind} {what}", "k": k, "edit": edit,
            "chain": chain, "expect": expect, "value": x, "seed": seed}


def _verdict(case: dict, d: dict) -> str:
    """How the diagnosis ``d`` (``DiagnosisResult.as_dict()``) compares with what ``case`` concealed."""
    sel = d["selected"]
    if case["expect"] is None:
        return "right (no mismatch)" if not d["mismatch"] else ("WRONG: false alarm" if not sel else "WRONG: named one")
    if not d["mismatch"]:
        return "missed (no mismatch)"
    if not sel:
        return "not named"
    e = case["expect"]
    hit = [x for x in sel if x["effect"] == e["effect"] and _key(x["location"]) == _key(e["location"])]
    if hit and len(sel) == 1:
        return "right"
    if hit:
        return "right + other"
    if any(x["effect"] == e["effect"] for x in sel):
        return "WRONG place"
    return "WRONG effect"


def run_drawn(case: dict, work: Path, controller: str = "mfdrf") -> dict:
    """One drawn case: conceal, record (with the case's seed), diagnose, update, verify. Returns the row."""
    nominal = load_spec(case["structure"])
    work.mkdir(parents=True)
    t0 = time.perf_counter()
    plant = export_mjcf(build_plant(case["edit"](nominal)), work / "plant.xml")
    lab = default_chain(controller, noise_m_s=1e-6, **case["chain"])
    fe = build_fe_model(nominal)
    design = design_controller(fe, controller, seed=case["seed"], period_s=lab.period_s)  # as vlab experiment
    cfg = ExperimentConfig(structure=nominal.name, controller=controller, chain=lab, plant="mujoco", mjcf=plant,
                           seed=case["seed"])
    m = measure(cfg, fe, design, decay_rate_1_s=slowest_decay_rate(fe, design))
    (work / "exp").mkdir()
    rec = write_recording(work / "exp" / "recording.uff", m.loop.recording, overwrite=False)
    res = vlab.diagnose(nominal, rec, out_dir=work / "diag")
    d = res.as_dict()
    sel = "; ".join(f"{e['effect']} {e['location']} {e['parameters']}" for e in d["selected"]) or "nothing"
    row = {"case": case["label"], "selected": sel, "verdict": _verdict(case, d), "mismatch": d["mismatch"]}
    if case["expect"] is not None:
        hit = [x for x in d["selected"] if x["effect"] == case["expect"]["effect"]
               and _key(x["location"]) == _key(case["expect"]["location"])]
        if hit:  # the fitted size against the concealed one
            row["fitted_over_concealed"] = float(next(iter(hit[0]["parameters"].values()))) / case["value"]
    try:
        upd = vlab.update(nominal, work / "diag", out=work / "updated.toml")
    except VlabError as exc:
        row.update(refused=str(exc).split(": ", 1)[-1][:100])
        if case["expect"] is None:  # the floor: the design on the nominal model run on the unchanged plant
            v = verify(nominal, nominal, plant, controller=controller)
            row["e_floor"] = v["original"]["average_peak_level_error"]
        row["seconds"] = time.perf_counter() - t0
        return row
    v = verify(nominal, upd.path, plant, controller=controller, lab_chain=lab if case["chain"] else None)
    e0, e1 = v["original"]["average_peak_level_error"], v["updated"]["average_peak_level_error"]
    dz = _damping_deviation(v["updated"]["modes"])
    row.update(e_original=e0, e_updated=e1, damping_dev=dz, seconds=time.perf_counter() - t0,
               half=e1 <= 0.5 * e0, below_003=(e1 <= 0.03) if e0 > 0.06 else None, damping_ok=dz <= 0.10,
               not_meaningful={k: [w.split(";")[0] for w in v[k]["not_meaningful"]] for k in ("original", "updated")})
    return row


def _draw_line(i: int, case: dict, row: dict) -> str:
    """One listing line of a drawn case."""
    b = {True: "pass", False: "FAIL", None: "-"}
    k = f"{case['k']:.2f}" if case["k"] is not None else "-"
    head = f"{i:3d} {case['label'][:52]:52s} {k:>5s} "
    fit = f" fit/true {row['fitted_over_concealed']:.3f};" if "fitted_over_concealed" in row else ""
    tail = f" {row.get('seconds', 0):5.0f}s  {row['verdict']};{fit} selected: {row['selected']}"
    if "refused" in row:
        ok = "pass" if case["expect"] is None else "-"
        e0 = f"{row['e_floor']:9.4f}" if "e_floor" in row else f"{'':9s}"
        return head + f"{e0} {'refused':>9s} {ok:>6s} {'':6s} {'':7s} {'':6s}" + tail + f" [{row['refused']}]"
    osc = "".join(f" [the {k} design's run on the plant: {'; '.join(w)}: its FRF comparison is not meaningful]"
                  for k, w in row.get("not_meaningful", {}).items() if w)
    return (head + f"{row['e_original']:9.4f} {row['e_updated']:9.4f} {b[row['half']]:>6s} {b[row['below_003']]:>6s} "
            f"{row['damping_dev']:7.3f} {b[row['damping_ok']]:>6s}" + tail + osc)


def _draw_summary(done: list) -> list[str]:
    """Counts per criterion over the drawn cases run."""
    eff = [(c, r) for c, r in done if c["expect"] is not None]
    nul = [(c, r) for c, r in done if c["expect"] is None]
    ver = [r for _, r in done]
    upd = [r for _, r in eff if "refused" not in r]
    big = [r for r in upd if r["below_003"] is not None]
    n = lambda rows, f: sum(1 for r in rows if f(r))  # noqa: E731
    lines = [f"# summary: {len(done)} cases run ({len(eff)} with an effect, {len(nul)} null)",
             f"# diagnosis: right {n(ver, lambda r: r['verdict'].startswith('right'))}, "
             f"wrong {n(ver, lambda r: r['verdict'].startswith('WRONG'))}, "
             f"missed or not named {n(ver, lambda r: r['verdict'] in ('missed (no mismatch)', 'not named'))}",
             f"# null cases: update refused {n([r for _, r in nul], lambda r: 'refused' in r)} of {len(nul)}",
             f"# effect cases updated {len(upd)} of {len(eff)} (refused: {len(eff) - len(upd)}); of those updated: "
             f"error halved {n(upd, lambda r: r['half'])}/{len(upd)}, "
             f"<= 0.03 where the original > 0.06: {n(big, lambda r: r['below_003'])}/{len(big)}, "
             f"damping within 10 %: {n(upd, lambda r: r['damping_ok'])}/{len(upd)}"]
    osc = [r for r in upd if any(r.get("not_meaningful", {}).values())]
    if osc:
        lines.append(f"# of the updates, {len(osc)} ran into a self-excited oscillation or limit cycle on the plant with the "
                     "original or the updated design (the loop unstable there: counted as they came, though such a run's "
                     "error does not test a linear prediction)")
    fl = [r["e_floor"] for _, r in nul if "e_floor" in r]
    if fl:
        lines.append("# floor (null cases: the nominal design run on the unchanged plant): average peak level error "
                     + ", ".join(f"{x:.4f}" for x in fl))
        floor = max(fl)  # an updated design cannot go below it: an original error under twice it cannot be halved
        low = [r for r in upd if r["e_original"] < 2 * floor]
        lines.append(f"# of the updates, {len(low)} started below twice the floor ({2 * floor:.4f}; halved "
                     f"{n(low, lambda r: r['half'])}); the {len(upd) - len(low)} others halved "
                     f"{n(upd, lambda r: r['half']) - n(low, lambda r: r['half'])}")
    if upd:
        import numpy as np
        e0, e1 = np.array([r["e_original"] for r in upd]), np.array([r["e_updated"] for r in upd])
        lines.append(f"# err orig median {np.median(e0):.4f} (range {e0.min():.4f}-{e0.max():.4f}); err upd median "
                     f"{np.median(e1):.4f} (range {e1.min():.4f}-{e1.max():.4f})")
    return lines


def main_draw(a) -> None:
    """``--draw SEED``: the drawn cases, printed and (``--out``) written as they finish."""
    base = Path(a.work) if a.work else Path(tempfile.mkdtemp(prefix="vlab-update-draw-"))
    cases = []
    thr_files = {}
    for name in a.structures:
        cache = Path(a.thresholds.format(structure=name, controller=a.controller))
        thr_files[name] = cache
        thr = draw_thresholds(name, a.controller, cache)
        cases += draw_cases(a.draw, name, a.controller, thr, k_range=tuple(a.k))
    numbered = list(enumerate(cases if a.limit is None else cases[:a.limit]))
    if a.only is not None:
        beyond = sorted(i for i in a.only if not 0 <= i < len(numbered))
        if beyond:
            raise SystemExit(f"--only {' '.join(map(str, beyond))}: the draw has cases 0-{len(numbered) - 1}")
        numbered = [(i, c) for i, c in numbered if i in a.only]
    header = [f"# python benchmarks/update_benchmark.py --draw {a.draw} --structures {' '.join(a.structures)} "
              f"--controller {a.controller} --k {a.k[0]:g} {a.k[1]:g}"
              + (f" --limit {a.limit}" if a.limit is not None else "")
              + (f" --only {' '.join(map(str, a.only))}" if a.only is not None else "") + f"   ({time.strftime('%Y-%m-%d')}; vlab at {vlab_commit()})",
              "# thresholds: " + ", ".join(f"{k}: {_rel(v)}" for k, v in thr_files.items()) + " (closed loop, "
              f"{a.controller}, model_form plant)",
              "# k: size / detection threshold (distance from the null value: _size); err: average peak level error "
              "mean|1 - r| of the design on the original / updated model on the changed plant; dzeta: largest "
              "relative difference of the updated design's closed-loop damping ratios, measured vs predicted; "
              "a null case passes (<=half column) when the update is refused; its err orig: the nominal design on the "
              "unchanged plant (the model-form floor)",
              f"{'#':>3s} {'concealed':52s} {'k':>5s} {'err orig':>9s} {'err upd':>9s} {'<=half':>6s} {'<=0.03':>6s} "
              f"{'dzeta':>7s} {'<=10%':>6s}  time  diagnosis"]
    t_all = time.perf_counter()
    done, lines = [], []

    def write(final: bool) -> None:
        run = f"# cases run {len(done)} / drawn {len(cases)}" + ("" if final else " (running)") + \
              f"; {time.perf_counter() - t_all:.0f} s"
        text = "\n".join(header[:2] + [run] + header[2:] + lines + (_draw_summary(done) if done else [])) + "\n"
        if a.out:
            Path(a.out).write_text(text)

    for line in header:
        print(line, flush=True)
    for i, case in numbered:
        try:
            row = run_drawn(case, base / f"draw{a.draw}_{i}", a.controller)
        except Exception as exc:  # noqa: BLE001 -- reported, not dropped
            row = {"case": case["label"], "selected": "-", "verdict": f"ERROR {type(exc).__name__}: {exc}"[:160],
                   "refused": "error", "mismatch": None}
        done.append((case, row))
        lines.append(_draw_line(i, case, row))
        print(lines[-1], flush=True)
        write(False)
    for line in _draw_summary(done):
        print(line)
    write(True)
    print(f"files in {base}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", choices=("cantilever", "bcc", "grid", "all", "chain"), default="cantilever")
    ap.add_argument("--only", type=int, nargs="*", default=None, help="run only these case numbers (0-based; with --draw: "
                                                                     "the numbers in the draw)")
    ap.add_argument("--controller", choices=("mfdrf", "lqdrf"), default="mfdrf",
                    help="the controller of the recording and of both designs")
    ap.add_argument("--work", default=None, help="folder for the cases' files (default: a temporary folder)")
    ap.add_argument("--out", default=None, help="--draw: also write the listing to this file")
    ap.add_argument("--draw", type=int, default=None, metavar="SEED",
                    help="draw the cases with numpy.random.default_rng(SEED) instead of the fixed ones")
    ap.add_argument("--structures", nargs="+", choices=("bcc", "grid"), default=["bcc"],
                    help="--draw: the structures (grid: slow)")
    ap.add_argument("--k", type=float, nargs=2, default=[2.0, 5.0], metavar=("LO", "HI"),
                    help="--draw: sizes log-uniform between LO and HI times the detection threshold")
    ap.add_argument("--limit", type=int, default=None, help="--draw: run only the first N cases drawn")
    ap.add_argument("--thresholds", default=str(ROOT / "docs" / "validation" / "data" /
                                                  "detectability_{structure}_{controller}_plant.json"),
                    help="--draw: the thresholds' cache file ({structure}, {controller} filled in)")
    a = ap.parse_args()
    if a.draw is not None:
        main_draw(a)
        return
    names = ("cantilever", "bcc", "grid") if a.cases in ("all", "chain") else (a.cases,)
    table = CHAIN_CASES if a.cases == "chain" else {k: [c + (None,) for c in v] for k, v in CASES.items()}
    base = Path(a.work) if a.work else Path(tempfile.mkdtemp(prefix="vlab-update-bench-"))
    print(f"{'case':44s} {'err orig':>9s} {'err upd':>9s} {'<=half':>7s} {'<=0.03':>7s} {'dzeta':>7s}  selected")
    n = 0
    for name in names:
        for i, (structure, label, edit, dur, chain) in enumerate(table[name]):
            if a.only is not None and i not in a.only:
                continue
            row = run_case(structure, label, edit, dur, base / f"{name}_{i}", a.controller, chain)
            n += 1
            if "refused" in row:
                print(f"{label:44s} update refused: {row['refused']}  (selected: {row['selected']})")
                continue
            b = {True: "pass", False: "FAIL", None: "-"}
            print(f"{label:44s} {row['e_original']:9.4f} {row['e_updated']:9.4f} {b[row['half']]:>7s} "
                  f"{b[row['below_003']]:>7s} {row['damping_dev']:7.3f}  {row['selected']}", flush=True)
    print(f"{n} cases; files in {base}")


if __name__ == "__main__":
    main()
