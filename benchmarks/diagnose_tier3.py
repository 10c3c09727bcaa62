"""Tier 3 of the diagnosis benchmark: recordings of the independent reference simulator, as an acquisition system writes them.

``python benchmarks/diagnose_benchmark.py --tier 3 --cases 24 --seed S`` (this module is its tier 3; BCC
only: the reference simulator, :mod:`benchmarks.reference_sim`, has no Hanging Grid).

Each case is drawn from ``numpy.random.default_rng([seed, i, 3])``:

- every K-th case (``--null-every``, default :data:`NULL_EVERY`, at most 3: at least a third of the cases)
  is a null case, recorded in turn open loop, with MFDRF, open loop, with LQDRF (:data:`NULL_CONTROLLERS`:
  half of the nulls closed loop);
- the other cases conceal one effect of a kind the simulator can conceal (:data:`KINDS`), the kinds in
  rounds (each round every kind once, in an order drawn per round); the loop is drawn open or closed
  (MFDRF or LQDRF) with equal odds, except that a loop delay and an actuator gain are concealed closed
  loop only (a delay acts on the feedback alone; in open loop only the excitation coil's gain would act,
  scaling every FRF alike);
- the place and side are drawn among the detection thresholds of that loop that the simulator can carry
  (one point, one beam segment, ``w`` springs, modes 1-6, coil channels 5, 7, 9, the loop delay of all
  channels above the nominal 1.35 periods); the size is ``q`` times the threshold, ``q`` log-uniform in
  2-5 (tier 2's :func:`diagnose_benchmark.threshold_sizer`, held within the range searched); a draw whose
  ratio to the threshold (:func:`diagnose_benchmark.threshold_ratio`) falls below 2 is drawn again.

The thresholds are vlab's detection thresholds (:func:`vlab.diagnose.detectability.detectability`,
``model_form="derived"``, sensor noise 1e-6 m/s, no naming thresholds) for the loop used, read from the
caches ``docs/validation/data/detectability_bcc_<controller>.json`` (written by
:func:`update_benchmark.draw_thresholds`; the open loop's restricted to the kinds drawn here). They are
thresholds of detection, not of naming, and of vlab's own test with velocity sensors: the recordings'
accelerometer noise differs.

Each case is recorded by the simulator as a separate program (``python -m benchmarks.reference_sim``, it
never imports vlab) in lab mode: ``lab.uff``, accelerations at points 1-9 and the force at 5 kHz through
the anti-alias filter, 16-bit, with noise, no sidecar; multisine 0.5-25 Hz, 0.5 N rms, 20-s period, one
period discarded and three recorded (:data:`EXCITATION`); closed loop with the gains of ``vlab design bcc
--controller <c> --json``. It is diagnosed by ``vlab diagnose`` as a separate program with the options a
user without a sidecar gives (:func:`diagnose_command`): ``--structure bcc --controller <c> --resolution
0.05``; no baseline, no plant, no model-form option.

Mapping between the simulator's truth and vlab's names, made here: ``member_stiffness`` factor = EI /
the nominal EI of vlab's spec (the segment's EI in N m^2 is vlab's parameter); ``loop_delay``
delay_periods = delay_s / the controller period (vlab's parameter is the loop's total delay in s, the
simulator's its total delay in periods); ``support_spring`` (w) = vlab's ``support_stiffness``;
``modal_damping`` = vlab's ``damping`` of the mode; ``actuator_gain`` point = vlab's channel.

Scored as tiers 1 and 2 (:func:`diagnose_benchmark.score`): right = the one selected effect has the true
kind and place (null: no mismatch); a passenger = an effect selected beside the true one; the parameter
error of the diagnosis's answer (its FE fit) and of the value refitted on the MuJoCo plant. Targets: >= 90
% of the effects right with the parameter within 20 %, no passenger, no false alarm on the nulls.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from diagnose_benchmark import MIN_THRESHOLD_RATIO, _line, _same_location, score, threshold_ratio, threshold_sizer
from vlab.diagnose.detectability import Threshold
from vlab.spec import load_spec

ROOT = Path(__file__).resolve().parent.parent
#: The effect kinds the reference simulator conceals, as vlab names them (the simulator's own in
#: :data:`SIM_TYPE`).
KINDS = ("added_mass", "member_stiffness", "support_stiffness", "damping", "actuator_gain", "loop_delay")
SIM_TYPE = {"added_mass": "added_mass", "member_stiffness": "member_stiffness",
            "support_stiffness": "support_spring", "damping": "modal_damping", "actuator_gain": "actuator_gain",
            "loop_delay": "loop_delay"}
#: Kinds concealed in closed loop only (see the module notes).
CLOSED_ONLY = ("actuator_gain", "loop_delay")
#: The loops of the null cases, in turn: half of them closed.
NULL_CONTROLLERS = ("none", "mfdrf", "none", "lqdrf")
#: Default: every second case a null case.
NULL_EVERY = 2
#: The excitation of every recording (simulator case keys): vlab needs 0.05 Hz lines and 40 s at least.
EXCITATION = {"kind": "multisine", "rms_n": 0.5, "band_hz": [0.5, 25.0], "period_s": 20.0, "periods": 3,
              "settle_periods": 1}
RESOLUTION_HZ = 0.05
#: Redraws of a place, side and size until the size is at least MIN_THRESHOLD_RATIO times its threshold.
ATTEMPTS = 20


def thresholds(controller: str) -> tuple:
    """vlab's detection thresholds of the BCC's test with ``controller`` (``"none"``, ``"mfdrf"``,
    ``"lqdrf"``), as :class:`vlab.diagnose.detectability.Threshold` objects.

    Read from ``docs/validation/data/detectability_bcc_<controller>.json``, computed there first when missing
    (:func:`update_benchmark.draw_thresholds` with the model form derived, as a real recording is read:
    minutes).

    Raises
    ------
    ModelError
        An unknown controller (from the detectability run).
    """
    from update_benchmark import draw_thresholds

    cache = ROOT / "docs" / "validation" / "data" / f"detectability_bcc_{controller}.json"
    d = draw_thresholds("bcc", controller, cache, model_form="derived")
    return tuple(Threshold(effect=t["effect"], location=t["location"], parameter=t["parameter"], null=t["null"],
                           threshold=t["threshold"], bound=t["bound"], by=t.get("detected_by"))
                 for t in d["thresholds"])


def carried(t: Threshold) -> bool:
    """Can the reference simulator conceal the effect of threshold ``t`` (kind, place and side)?"""
    loc = t.location
    if t.effect not in KINDS or t.threshold is None:
        return False
    if t.effect == "added_mass" or t.effect == "support_stiffness":
        return "point" in loc and loc.get("dof", "w") == "w" and 1 <= loc["point"] <= 9
    if t.effect == "member_stiffness":
        return loc.get("member") == "beam" and "segment" in loc
    if t.effect == "damping":
        return 1 <= loc.get("mode", 0) <= 6
    if t.effect == "actuator_gain":
        return loc.get("channel") in (5, 7, 9)
    return loc.get("channel") == "all" and t.threshold > t.null  # loop_delay: longer than nominal


def _kind_of(seed: int, n_effect: int) -> str:
    """The kind of the ``n_effect``-th effect case: :data:`KINDS` in rounds, each round's order drawn."""
    order = np.random.default_rng([seed, n_effect // len(KINDS), 33]).permutation(len(KINDS))
    return KINDS[int(order[n_effect % len(KINDS)])]


def draw_size(rng, kind: str, controller: str) -> dict:
    """Place, side and size of one ``kind`` effect for the test with ``controller`` (module notes).

    Returns
    -------
    dict
        vlab's truth record: ``effect``, ``location``, ``parameters`` ({name: SI value}),
        ``threshold_ratio``.

    Raises
    ------
    RuntimeError
        No draw at least :data:`MIN_THRESHOLD_RATIO` times its threshold in :data:`ATTEMPTS` draws.
    """
    ths = thresholds(controller)
    valid = [t for t in ths if t.effect == kind and carried(t)]
    size_of = threshold_sizer(lambda effect: [t for t in ths if carried(t)])
    for _ in range(ATTEMPTS):
        t = valid[int(rng.integers(len(valid)))]
        hint = t.threshold  # the side of the drawn threshold
        x = size_of(rng, kind, t.location, t.parameter, hint)
        truth = {"effect": kind, "location": dict(t.location), "parameters": {t.parameter: x}}
        truth["threshold_ratio"] = threshold_ratio(truth, ths)
        if truth["threshold_ratio"] is not None and truth["threshold_ratio"] >= MIN_THRESHOLD_RATIO:
            return truth
    raise RuntimeError(f"no {kind} draw at {MIN_THRESHOLD_RATIO}x its threshold in {ATTEMPTS} draws")


def simulator_effect(truth: dict, nominal_ei: float, period_s: float) -> dict:
    """The reference simulator's effect (case JSON) for vlab's truth record ``truth`` (mapping in the module
    notes). ``nominal_ei`` [N m^2]: the beam's EI in vlab's spec; ``period_s``: the controller period [s].

    Raises
    ------
    ValueError
        A kind the simulator does not conceal.
    """
    kind, loc = truth["effect"], truth["location"]
    (value,) = truth["parameters"].values()
    if kind == "added_mass":
        return {"type": "added_mass", "point": loc["point"], "mass_kg": value}
    if kind == "member_stiffness":
        return {"type": "member_stiffness", "segment": list(loc["segment"]), "factor": value / nominal_ei}
    if kind == "support_stiffness":
        return {"type": "support_spring", "point": loc["point"], "dof": "w", "stiffness": value}
    if kind == "damping":
        return {"type": "modal_damping", "mode": loc["mode"], "ratio": value}
    if kind == "actuator_gain":
        return {"type": "actuator_gain", "point": loc["channel"], "factor": value}
    if kind == "loop_delay":
        return {"type": "loop_delay", "delay_periods": value / period_s}
    raise ValueError(f"the reference simulator does not conceal {kind!r}")


def make_case(i: int, seed: int, null_every: int = NULL_EVERY) -> dict:
    """Draw case ``i`` of tier 3 (module notes): controller, vlab's truth, the simulator's effects and seed.

    Raises
    ------
    ValueError
        ``null_every`` outside 1-3.
    """
    if not 1 <= null_every <= 3:
        raise ValueError(f"tier 3 needs at least a third of null cases: null_every 1, 2 or 3, got {null_every}")
    rng = np.random.default_rng([seed, i, 3])
    case = {"index": i, "tier": 3, "structure": "bcc", "plant": "reference simulator", "rng_seed": [seed, i, 3],
            "sim_seed": int(rng.integers(1, 2**31))}
    if i % null_every == null_every - 1:
        n_null = i // null_every
        return {**case, "controller": NULL_CONTROLLERS[n_null % len(NULL_CONTROLLERS)], "truth": [], "effects": []}
    n_effect = i - (i + 1) // null_every
    kind = _kind_of(seed, n_effect)
    closed = kind in CLOSED_ONLY or rng.random() < 0.5
    controller = str(rng.choice(["mfdrf", "lqdrf"])) if closed else "none"
    truth = draw_size(rng, kind, controller)
    spec = load_spec("bcc")
    ei0 = spec.sections[next(m for m in spec.members if m.id == "beam").section].ei.si
    period = float(json.loads(design_json(controller).read_text())["period_s"]) if closed else 0.5e-3
    return {**case, "controller": controller, "truth": [truth], "effects": [simulator_effect(truth, ei0, period)]}


def design_json(controller: str) -> Path:
    """The file of ``vlab design bcc --controller <controller> --json`` (made once per process, in the
    system's temporary folder, by ``vlab`` as a separate program)."""
    path = Path(os.environ.get("TMPDIR", "/tmp")) / f"vlab-tier3-design-{controller}-{os.getpid()}.json"
    if not path.exists():
        out = subprocess.run([_vlab(), "design", "bcc", "--controller", controller, "--json"], check=True,
                             capture_output=True, text=True).stdout
        path.write_text(out)
    return path


def _vlab() -> str:
    return shutil.which("vlab") or "vlab"


def diagnose_command(recording: Path, controller: str, out: Path, baseline: Path | None = None) -> list:
    """The ``vlab diagnose`` command of a user with the recording and no sidecar (module notes); with a
    ``baseline`` recording of the structure before the change, that too (``--baseline``)."""
    return [_vlab(), "diagnose", "--structure", "bcc", "--recording", str(recording), "--controller", controller,
            "--resolution", f"{RESOLUTION_HZ:g}", "--out", str(out), "--overwrite", "--quiet"] + \
        ([] if baseline is None else ["--baseline", str(baseline)])


def record(case: dict, folder: Path) -> Path:
    """Record ``case`` with the reference simulator, a separate program, in lab mode; returns ``lab.uff``.

    Raises
    ------
    RuntimeError
        The simulator failed (its last output lines).
    """
    folder.mkdir(parents=True, exist_ok=True)
    sim_case = {"controller": case["controller"], "seed": case["sim_seed"], "mode": "lab",
                "excitation": EXCITATION, "effects": case["effects"]}
    if case["controller"] != "none":
        sim_case["design"] = str(design_json(case["controller"]))
    (folder / "case.json").write_text(json.dumps(sim_case, indent=1))
    proc = subprocess.run([sys.executable, "-m", "benchmarks.reference_sim", "--structure", "bcc", "--case",
                           str(folder / "case.json"), "--out", str(folder)], cwd=ROOT, capture_output=True,
                          text=True)
    if proc.returncode != 0:
        raise RuntimeError(f"reference simulator: {(proc.stderr or proc.stdout).strip()[-400:]}")
    (folder / "recording.uff").unlink(missing_ok=True)  # the controller-rate channels: not the tier's recording
    return folder / "lab.uff"


def run_case(case: dict, workdir: str, keep: bool = False, baseline: bool = False) -> dict:
    """Record one tier-3 case and diagnose it blind with ``vlab diagnose`` (:func:`diagnose_command`).

    With ``baseline``, the structure before the change is recorded too -- the same loop, no concealed effect,
    another excitation realisation and noise (the simulator's seed + 1), as a lab records its structure
    before a change -- and given as ``--baseline``.

    Returns the case with ``result`` (vlab's ``diagnosis.json``, or None), ``error`` (or None), ``command``
    (the diagnosis's arguments after the program name, the recording's path shortened) and the times
    ``time_generate_s``, ``time_diagnose_s`` [s]. Unless ``keep``, the recording is deleted afterwards."""
    folder = Path(workdir) / f"case{case['index']:02d}"
    t0 = time.perf_counter()
    rec = {**case, "result": None, "error": None, "time_diagnose_s": 0.0}
    try:
        lab = record(case, folder)
        base = record({**case, "effects": [], "sim_seed": case["sim_seed"] + 1}, folder / "baseline") \
            if baseline else None
    except (RuntimeError, OSError, subprocess.CalledProcessError) as exc:
        return {**rec, "error": f"{type(exc).__name__}: {exc}", "time_generate_s": time.perf_counter() - t0}
    rec["time_generate_s"] = time.perf_counter() - t0
    rec = _diagnosed(rec, lab, base, folder / "diagnosis")
    if not keep:
        lab.unlink(missing_ok=True)
    return rec


def _diagnosed(rec: dict, lab: Path, base: Path | None, out: Path) -> dict:
    """``rec`` with the blind diagnosis of recording ``lab`` (baseline ``base``) written to ``out``: ``result``,
    ``error``, ``command`` and ``time_diagnose_s`` set (:func:`run_case`)."""
    cmd = diagnose_command(lab, rec["controller"], out, base)
    short = {str(lab): "lab.uff", str(base): "baseline/lab.uff"}
    rec = {**rec, "command": " ".join(["vlab"] + [short.get(a, a) for a in cmd[1:]])}
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True)
    rec["time_diagnose_s"] = time.perf_counter() - t0
    path = out / "diagnosis.json"
    if proc.returncode != 0 or not path.exists():
        rec["error"] = f"vlab diagnose exit {proc.returncode}: {(proc.stderr or proc.stdout).strip()[-400:]}"
    else:
        rec["result"] = json.loads(path.read_text())
    return rec


def kept_case(case: dict, folder: Path) -> dict:
    """Diagnose again the recording a run kept for ``case`` (``folder/caseNN``, :func:`run_tier3` ``keep``) with
    the code as it is now; the new diagnosis goes to ``caseNN/rediagnosis`` (the kept one is left as it was).

    Returns the case as :func:`run_case` does (``time_generate_s`` 0, ``error`` set when the recording is missing
    or its ``truth.json`` is not the one ``case`` draws: another seed, or cases drawn by other code)."""
    sub = folder / f"case{case['index']:02d}"
    rec = {**case, "result": None, "error": None, "time_diagnose_s": 0.0, "time_generate_s": 0.0}
    try:
        truth = json.loads((sub / "truth.json").read_text())
    except (OSError, ValueError) as exc:
        return {**rec, "error": f"{sub}: no readable truth.json ({exc})"}
    if truth.get("seed") != case["sim_seed"] or truth.get("effects") != case["effects"]:
        return {**rec, "error": f"{sub}/truth.json: not the case drawn now (seed {truth.get('seed')} for "
                                f"{case['sim_seed']}, effects {truth.get('effects')} for {case['effects']}): give "
                                "the seed of the run that kept it"}
    base = sub / "baseline" / "lab.uff"
    return _diagnosed(rec, sub / "lab.uff", base if base.exists() else None, sub / "rediagnosis")


def case_line(r: dict, s: dict, line: str) -> str:
    """Tier 2's listing line ``line`` of case ``r`` (score ``s``) with the parameter the diagnosis gave
    (its FE fit) against the truth, and its error [%]."""
    if not r["truth"] or r["result"] is None:
        return line
    parts = []
    for t in r["truth"]:
        (name, true), = t["parameters"].items()
        hit = next((x for x in r["result"]["selected"] if x["effect"] == t["effect"]
                    and _same_location(x["location"], t["location"])), None)
        if hit is not None and name in hit["parameters"]:
            got = hit["parameters"][name]
            parts.append(f"{name} {got:.4g} for {true:.4g} ({100 * (got / true - 1):+.1f} %)")
        else:
            parts.append(f"{name} {true:.4g} not found")
    return line + " [" + "; ".join(parts) + "]" + (f" [{s['passengers']} passenger(s)]" if s["passengers"] else "")


def run_tier3(n_cases: int, seed: int, null_every: int = NULL_EVERY, only=None, jobs: int = 1,
              keep: str | None = None, baseline: bool = False, kept: str | None = None) -> tuple[list, float]:
    """Draw, record, diagnose and print the cases of tier 3 (one line each, as they finish).

    Parameters
    ----------
    n_cases, seed, null_every : int
        As :func:`make_case`, cases 0 .. n_cases - 1.
    only : sequence of int, optional
        Run only these case indices.
    jobs : int
        Cases run at once (each in its own process; its times then include the other's load).
    keep : str, optional
        Folder that keeps every case's recording, case file, truth and diagnosis (default: a temporary one,
        recordings deleted).
    baseline : bool
        Record the structure before the change for each case and diagnose with it (:func:`run_case`).
    kept : str, optional
        Record nothing: diagnose again the recordings a run with ``keep`` left in this folder
        (:func:`kept_case`; ``seed`` and ``null_every`` must be that run's).

    Returns
    -------
    (list of dict, float)
        The cases with their results (:func:`run_case`) and the run's wall time [s].
    """
    import tempfile
    from concurrent.futures import ProcessPoolExecutor

    cases = [make_case(i, seed, null_every) for i in range(n_cases) if not only or i in only]
    t0 = time.perf_counter()
    results = []
    with tempfile.TemporaryDirectory(prefix="vlab-tier3-") as tmp:
        work = keep or tmp
        with ProcessPoolExecutor(max(jobs, 1)) as ex:
            runs = (ex.map(kept_case, cases, [Path(kept)] * len(cases)) if kept else
                    ex.map(run_case, cases, [work] * len(cases), [bool(keep)] * len(cases), [baseline] * len(cases)))
            for r in runs:
                results.append(r)
                s = score(r)
                print(case_line(r, s, _line(r, s)), flush=True)
    return results, time.perf_counter() - t0
