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

    python benchmarks/update_benchmark.py [--cases cantilever|bcc|grid|all] [--controller mfdrf|lqdrf] [--out DIR]

The structures: ``examples/cantilever_tip_mass.toml`` (a few seconds a case), the BCC (minutes a case:
its diagnosis dominates) and the grid (one case, longer). The sizes are fixed, chosen by hand well above the detection threshold (the
diagnosis names the cantilever's 0.3 g mass at point 3; the cases add 10-40 g), not drawn. ``--cases chain``
runs the chain cases of all three structures.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

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
    dz = max(abs(m["damping_ratio_measured"] / m["damping_ratio_predicted"] - 1) for m in v["updated"]["modes"])
    row.update(e_original=e0, e_updated=e1, damping_dev=dz, seconds=time.perf_counter() - t0,
               half=e1 <= 0.5 * e0, below_003=(e1 <= 0.03) if e0 > 0.06 else None, damping_ok=dz <= 0.10)
    return row


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", choices=("cantilever", "bcc", "grid", "all", "chain"), default="cantilever")
    ap.add_argument("--only", type=int, nargs="*", default=None, help="run only these case numbers (0-based)")
    ap.add_argument("--controller", choices=("mfdrf", "lqdrf"), default="mfdrf",
                    help="the controller of the recording and of both designs")
    ap.add_argument("--out", default=None, help="folder for the cases' files (default: a temporary folder)")
    a = ap.parse_args()
    names = ("cantilever", "bcc", "grid") if a.cases in ("all", "chain") else (a.cases,)
    table = CHAIN_CASES if a.cases == "chain" else {k: [c + (None,) for c in v] for k, v in CASES.items()}
    base = Path(a.out) if a.out else Path(tempfile.mkdtemp(prefix="vlab-update-bench-"))
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
