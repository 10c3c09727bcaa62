"""Tier 3 of the diagnosis benchmark (benchmarks/diagnose_benchmark.py --tier 3, benchmarks/diagnose_tier3.py): the
case drawing and the mapping of vlab's effects onto the reference simulator's, without simulating or diagnosing.

Checked: at least a third of the cases are null cases, half of those closed loop; every kind the simulator conceals
is drawn, a loop delay and an actuator gain in closed loop; sizes are 2-5x their detection threshold; the
simulator accepts every drawn effect and its truth maps back (EI factor, delay in periods); the diagnosis is
called as a user without a sidecar calls it; a passenger is counted; a kept recording of another draw is refused.
"""

from __future__ import annotations

import importlib.util
import math
import sys
from pathlib import Path

import pytest

from benchmarks.reference_sim.cases import _check_effect, apply_effects
from benchmarks.reference_sim.params import load_bcc
from vlab.spec import load_spec

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def t3():
    sys.path.insert(0, str(ROOT / "benchmarks"))
    try:
        spec = importlib.util.spec_from_file_location("_bench_diagnose_tier3", ROOT / "benchmarks" / "diagnose_tier3.py")
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
        yield mod
    finally:
        sys.path.remove(str(ROOT / "benchmarks"))


@pytest.fixture(scope="module")
def cases(t3):
    return [t3.make_case(i, 12345) for i in range(24)]


def test_nulls_are_a_half_and_half_of_them_closed_loop(cases):
    nulls = [c for c in cases if not c["truth"]]
    assert len(nulls) == 12
    assert sum(c["controller"] != "none" for c in nulls) == 6
    assert {c["controller"] for c in nulls} == {"none", "mfdrf", "lqdrf"}


def test_every_kind_is_drawn_and_the_loop_kinds_closed(t3, cases):
    eff = [c for c in cases if c["truth"]]
    assert {c["truth"][0]["effect"] for c in eff} == set(t3.KINDS)
    for c in eff:
        if c["truth"][0]["effect"] in t3.CLOSED_ONLY:
            assert c["controller"] in ("mfdrf", "lqdrf")


def test_sizes_are_two_to_five_times_the_threshold(cases):
    ratios = [c["truth"][0]["threshold_ratio"] for c in cases if c["truth"]]
    assert min(ratios) >= 2.0 and max(ratios) <= 5.0 + 1e-9


def test_the_simulator_takes_every_effect_and_the_truth_maps_back(t3, cases):
    p = load_bcc()
    spec = load_spec("bcc")
    ei0 = spec.sections[next(m for m in spec.members if m.id == "beam").section].ei.si
    assert p.beam_ei_nm2 == pytest.approx(ei0, rel=1e-9)
    for c in cases:
        for i, e in enumerate(c["effects"]):
            apply_effects(p, [_check_effect(i, e)])
    t = {"effect": "member_stiffness", "location": {"member": "beam", "segment": [3, 4]},
         "parameters": {"ei_n_m2": 0.8 * ei0}}
    assert t3.simulator_effect(t, ei0, 5e-4)["factor"] == pytest.approx(0.8)
    t = {"effect": "loop_delay", "location": {"channel": "all"}, "parameters": {"delay_s": 1.5e-3}}
    assert math.isclose(t3.simulator_effect(t, ei0, 5e-4)["delay_periods"], 3.0)


def test_diagnosed_as_a_user_without_a_sidecar(t3, tmp_path):
    cmd = t3.diagnose_command(tmp_path / "lab.uff", "lqdrf", tmp_path / "out")
    assert cmd[1] == "diagnose" and cmd[cmd.index("--controller") + 1] == "lqdrf"
    assert cmd[cmd.index("--resolution") + 1] == "0.05"
    assert not {"--baseline", "--plant", "--model-form", "--test", "--force"} & set(cmd)


def test_a_passenger_is_counted(t3):
    truth = [{"effect": "added_mass", "location": {"point": 6}, "parameters": {"mass_kg": 0.1}}]
    sel = [{"effect": "added_mass", "location": {"point": 6}, "parameters": {"mass_kg": 0.1}},
           {"effect": "damping", "location": {"mode": 2}, "parameters": {"damping_ratio": 0.01}}]
    s = t3.score({"truth": truth, "result": {"selected": sel, "mismatch": True, "alternatives": [],
                                              "validated": {}}})
    assert s["passengers"] == 1 and not s["right"]


def test_a_kept_recording_of_another_draw_is_refused_and_nothing_is_diagnosed(t3, cases, tmp_path):
    """--kept with the wrong seed: the kept truth.json is not the case drawn now, so the case is an error and no
    diagnosis is made (a re-diagnosis scored against another draw would report wrong parameter errors)."""
    import json
    case = cases[0]
    sub = tmp_path / "case00"
    sub.mkdir()
    (sub / "truth.json").write_text(json.dumps({"seed": case["sim_seed"] + 1, "effects": case["effects"]}))
    r = t3.kept_case(case, tmp_path)
    assert r["result"] is None and "not the case drawn now" in r["error"] and not (sub / "rediagnosis").exists()
    missing = t3.kept_case(cases[1], tmp_path)
    assert missing["result"] is None and "truth.json" in missing["error"]


def test_a_compound_is_scored_in_full_by_part_with_its_remainder_or_neither(t3):
    """Two effects concealed together: both named is right; one of them named with a remainder stated (and
    nothing else named) is the other outcome the criterion accepts; one named without a remainder, or a
    case not diagnosed, is neither."""
    mass = {"effect": "added_mass", "location": {"point": 6}, "parameters": {"mass_kg": 0.1}}
    gain = {"effect": "actuator_gain", "location": {"channel": 9}, "parameters": {"gain": 1.07}}

    def outcome(sel, remainder=None, result=True):
        d = {"selected": sel, "mismatch": True, "alternatives": [], "validated": {}, "remainder": remainder}
        return t3.score({"truth": [mass, gain], "result": d if result else None}).get("compound")
    assert outcome([mass, gain]) == "in full"
    assert outcome([gain], remainder={"misfit_decades": 0.01}) == "remainder stated"
    assert outcome([gain]) == "neither"
    assert outcome([gain, {**mass, "location": {"point": 5}}], remainder={"misfit_decades": 0.01}) == "neither"
    assert outcome([], result=False) == "neither"
    single = t3.score({"truth": [mass], "result": {"selected": [mass], "mismatch": True, "alternatives": [],
                                                    "validated": {}}})
    assert "compound" not in single
