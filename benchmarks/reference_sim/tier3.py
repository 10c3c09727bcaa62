"""A third benchmark tier: vlab's diagnosis on recordings of the reference simulator.

``python -m benchmarks.reference_sim.tier3 --cases 6 --seed 1 --out DIR`` draws cases
(about a quarter null, the rest one concealed effect each), records them in
compatibility mode with the MFDRF loop, runs ``vlab diagnose`` on each as a separate
program, and scores its answer against the truth: the right effect at the right
place, the parameter's error and whether the truth lies in the reported 95 %
interval. The simulator and this driver never import vlab.
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np

from .cases import DEFAULT_EXCITATION, Case
from .loop import Controller
from .params import load_bcc
from .run import simulate, write_outputs

EXCITATION = dict(DEFAULT_EXCITATION, period_s=20.0, periods=3, settle_periods=1)
"""vlab needs 0.05 Hz lines and at least 40 s: three 20-s periods after one discarded."""


def draw_effect(rng: np.random.Generator, beam_ei: float, period_s: float):
    """One concealed effect, its expected vlab name, location and parameter.

    Parameters
    ----------
    rng : numpy.random.Generator
    beam_ei : float
        Nominal beam EI [N m^2] (a member-stiffness truth is stated as EI).
    period_s : float
        Controller period [s] (a delay truth is stated in seconds added).

    Returns
    -------
    effect : dict or None
        The case's effect (None: a null case).
    expected : tuple or None
        (vlab effect name, location dict, parameter name, true value).
    """
    kind = str(rng.choice(["null", "added_mass", "member_stiffness", "support_spring",
                       "modal_damping", "actuator_gain", "loop_delay"],
                      p=[0.25, 0.2, 0.15, 0.1, 0.1, 0.1, 0.1]))
    if kind == "null":
        return None, None
    if kind == "added_mass":
        q, m = int(rng.integers(1, 10)), round(float(rng.uniform(0.05, 0.2)), 3)
        return ({"type": kind, "point": q, "mass_kg": m}, ("added_mass", {"point": q}, "mass_kg", m))
    if kind == "member_stiffness":
        lo = int(rng.integers(1, 9))
        f = round(float(rng.uniform(0.7, 0.9)), 3)
        return ({"type": kind, "segment": [lo, lo + 1], "factor": f},
                ("member_stiffness", {"member": "beam", "segment": [lo, lo + 1]}, "ei_n_m2", f * beam_ei))
    if kind == "support_spring":
        q, k = int(rng.integers(1, 10)), round(float(rng.uniform(100, 1000)), 1)
        return ({"type": kind, "point": q, "dof": "w", "stiffness": k},
                ("support_stiffness", {"point": q, "dof": "w"}, "stiffness_n_per_m", k))
    if kind == "modal_damping":
        mode, z = int(rng.integers(1, 7)), round(float(rng.uniform(0.008, 0.02)), 4)
        return ({"type": kind, "mode": mode, "ratio": z}, ("damping", {"mode": mode}, "damping_ratio", z))
    if kind == "actuator_gain":
        q, g = int(rng.choice([5, 7, 9])), round(float(rng.uniform(0.7, 0.9)), 3)
        return ({"type": kind, "point": q, "factor": g}, ("actuator_gain", {"channel": q}, "gain", g))
    d = round(float(rng.uniform(2.35, 3.35)), 2)
    return ({"type": kind, "delay_periods": d}, ("loop_delay", None, "delay_s", (d - 1.35) * period_s))


def score(expected, diag: dict) -> dict:
    """Compare vlab's ``diagnosis.json`` with the truth.

    Parameters
    ----------
    expected : tuple or None
        From :func:`draw_effect`.
    diag : dict
        vlab's diagnosis JSON (keys ``mismatch``, ``selected``).

    Returns
    -------
    dict
        ``right`` (bool), ``named`` (vlab's effect and location), ``value``,
        ``error`` (relative), ``in_ci`` (bool or None).
    """
    sel = diag.get("selected") or []
    named = [(s.get("effect"), s.get("location")) for s in sel]
    if expected is None:
        return {"right": not diag.get("mismatch") or not sel, "named": named,
                "value": None, "error": None, "in_ci": None}
    name, loc, par, truth = expected
    hit = [s for s in sel if s.get("effect") == name and (loc is None or s.get("location") == loc)]
    if len(sel) != 1 or not hit:
        return {"right": False, "named": named, "value": None, "error": None, "in_ci": None}
    params = hit[0].get("parameters", {})
    key = par if par in params else next(iter(params), None)
    value = params.get(key)
    ci = hit[0].get("ci95", {}).get(key)
    err = None if value is None else value / truth - 1
    in_ci = None if ci is None else bool(ci[0] <= truth <= ci[1])
    return {"right": True, "named": named, "value": value, "error": err, "in_ci": in_ci}


def run_case(i: int, effect, design: Path, seed: int, out: Path) -> dict:
    """Record one case and diagnose it with ``vlab diagnose`` (a separate program)."""
    case = Case(controller="mfdrf", design=str(design), effects=(effect,) if effect else (),
                excitation=dict(EXCITATION), seed=seed)
    folder = out / f"case{i:02d}"
    write_outputs(simulate(case, Controller.from_design_json(design)), folder)
    cmd = [shutil.which("vlab") or "vlab", "diagnose", "--structure", "bcc", "--recording",
           str(folder / "recording.uff"), "--controller", "mfdrf", "--out",
           str(folder / "diagnosis"), "--overwrite"]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    path = folder / "diagnosis" / "diagnosis.json"
    if proc.returncode != 0 or not path.exists():
        return {"_failed": (proc.stderr or proc.stdout).strip()[-400:]}
    return json.loads(path.read_text())


def main(argv=None) -> int:
    """Draw, record, diagnose and score; print a markdown table; write ``tier3.json``."""
    ap = argparse.ArgumentParser(prog="python -m benchmarks.reference_sim.tier3")
    ap.add_argument("--cases", type=int, default=6)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--out", required=True)
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    design = out / "design.json"
    if not design.exists():
        design.write_text(subprocess.run([shutil.which("vlab") or "vlab", "design", "bcc", "--controller",
                                          "mfdrf", "--json"], check=True, capture_output=True,
                                         text=True).stdout)
    p = load_bcc()
    period = Controller.from_design_json(design).period_s
    rng = np.random.default_rng(args.seed)
    rows = []
    print("| case | truth | vlab named | value | error | truth in 95 % CI | right |")
    print("|---|---|---|---|---|---|---|")
    for i in range(args.cases):
        effect, expected = draw_effect(rng, p.beam_ei_nm2, period)
        diag = run_case(i, effect, design, int(rng.integers(2**31)), out)
        res = score(expected, diag) if "_failed" not in diag else {"right": False, "failed": diag["_failed"]}
        rows.append({"case": i, "effect": effect, "expected": expected, **res})
        err = res.get("error")
        print(f"| {i} | {effect or 'null'} | {res.get('named', res.get('failed'))} | {res.get('value')} | "
              f"{'' if err is None else f'{100 * err:+.1f} %'} | {res.get('in_ci')} | {res['right']} |",
              flush=True)
    (out / "tier3.json").write_text(json.dumps(rows, indent=2, default=str) + "\n")
    print(f"right: {sum(r['right'] for r in rows)} of {len(rows)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
