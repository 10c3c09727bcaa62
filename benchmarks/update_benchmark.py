"""Benchmark of ``vlab update``: conceal an effect in the plant, record, diagnose, update, redesign, rerun.

Each case conceals one structural effect of known size in the MuJoCo plant (the structure's spec changed
with :mod:`vlab.diagnose.effects.specedit`, which keeps the damping matrix of a physical change;
exported as MJCF), records a closed-loop
MFDRF (or ``--controller lqdrf``) experiment on it with the controller designed on the nominal model, diagnoses the recording blind
(``vlab.diagnose``), writes the updated structure file (``vlab.update``) and runs the controller designed on
the original and on the updated file against the same changed plant (``vlab.verify_update``).

Printed per case: what was concealed, what the diagnosis selected (or why it refused), the average peak
level error (Table 10's measure, ``mean |1 - r|``) of the design on the original and on the updated model,
and the largest relative difference between the closed-loop damping ratios predicted and measured for the
updated design. The criteria (each printed as pass/fail, a case whose diagnosis is wrong or refused is
reported as such, not dropped):

- the updated design's error is at most half of the original design's;
- at most 0.03 where the original design's error is above 0.06;
- closed-loop damping ratios measured within 10 % of those predicted.

Usage::

    python benchmarks/update_benchmark.py [--cases cantilever|bcc|grid|all] [--controller mfdrf|lqdrf] [--out DIR]

The structures: ``examples/cantilever_tip_mass.toml`` (a few seconds a case), the BCC (minutes a case:
its diagnosis dominates) and the grid (one case, longer). The sizes are fixed, chosen by hand well above the detection threshold (the
diagnosis names the cantilever's 0.3 g mass at point 3; the cases add 10-40 g), not drawn.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import vlab
from vlab.diagnose.effects import specedit
from vlab.errors import VlabError
from vlab.sim import build_plant, export_mjcf
from vlab.spec import load_spec

ROOT = Path(__file__).resolve().parent.parent
CANTILEVER = ROOT / "examples" / "cantilever_tip_mass.toml"

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


def run_case(structure, label: str, edit, duration_s, work: Path, controller: str = "mfdrf") -> dict:
    """One case: conceal, record, diagnose, update, verify. Returns the row printed."""
    nominal = load_spec(structure)
    work.mkdir(parents=True)
    plant = export_mjcf(build_plant(edit(nominal)), work / "plant.xml")
    t0 = time.perf_counter()
    vlab.run_experiment(nominal, controller, mjcf=plant, duration_s=duration_s, out_dir=work / "exp")
    res = vlab.diagnose(nominal, work / "exp" / "recording.uff", out_dir=work / "diag")
    d = res.as_dict()
    sel = "; ".join(f"{e['effect']} {e['location']} {e['parameters']}" for e in d["selected"]) or "nothing"
    row = {"case": label, "selected": sel}
    try:
        upd = vlab.update(nominal, work / "diag", out=work / "updated.toml")
    except VlabError as exc:
        row.update(refused=str(exc).split(": ", 1)[-1][:120])
        return row
    v = vlab.verify_update(nominal, upd.path, plant, controller=controller, duration_s=duration_s)
    e0, e1 = v["original"]["average_peak_level_error"], v["updated"]["average_peak_level_error"]
    dz = max(abs(m["damping_ratio_measured"] / m["damping_ratio_predicted"] - 1) for m in v["updated"]["modes"])
    row.update(e_original=e0, e_updated=e1, damping_dev=dz, seconds=time.perf_counter() - t0,
               half=e1 <= 0.5 * e0, below_003=(e1 <= 0.03) if e0 > 0.06 else None, damping_ok=dz <= 0.10)
    return row


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", choices=("cantilever", "bcc", "grid", "all"), default="cantilever")
    ap.add_argument("--only", type=int, nargs="*", default=None, help="run only these case numbers (0-based)")
    ap.add_argument("--controller", choices=("mfdrf", "lqdrf"), default="mfdrf",
                    help="the controller of the recording and of both designs")
    ap.add_argument("--out", default=None, help="folder for the cases' files (default: a temporary folder)")
    a = ap.parse_args()
    names = ("cantilever", "bcc", "grid") if a.cases == "all" else (a.cases,)
    base = Path(a.out) if a.out else Path(tempfile.mkdtemp(prefix="vlab-update-bench-"))
    print(f"{'case':44s} {'err orig':>9s} {'err upd':>9s} {'<=half':>7s} {'<=0.03':>7s} {'dzeta':>7s}  selected")
    n = 0
    for name in names:
        for i, (structure, label, edit, dur) in enumerate(CASES[name]):
            if a.only is not None and i not in a.only:
                continue
            row = run_case(structure, label, edit, dur, base / f"{name}_{i}", a.controller)
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
