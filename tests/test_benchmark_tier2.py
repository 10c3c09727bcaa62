"""Tier 2 of the diagnosis benchmark (benchmarks/diagnose_benchmark.py --tier 2): the case
generation, without simulating the converged plant or running a diagnosis.

Checked: the converged plant's options come from assets/model_form (benchmarks/plant_model_form.py) and reach
the simulation that records; the model-form perturbation's factors are drawn with the spread derived from the
FE sensitivities and recorded in the case; at least a third of the cases are null cases; the recording's
metadata and the diagnosis's arguments carry no seed of the recording and do not point at the converged plant
(nor name a vlab plant: tier 2's recordings are diagnosed as recordings of the real structure).
"""

from __future__ import annotations

import importlib.util
import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest

from vlab.diagnose.detectability import Threshold
from vlab.sim import SimOptions
from vlab.spec import ASSETS_DIR, load_spec

ROOT = Path(__file__).resolve().parent.parent


def _load(name: str):
    sys.path.insert(0, str(ROOT / "benchmarks"))  # the benchmarks import their siblings (_listing)
    try:
        spec = importlib.util.spec_from_file_location(f"_bench_{name}", ROOT / "benchmarks" / f"{name}.py")
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
    finally:
        sys.path.remove(str(ROOT / "benchmarks"))
    return mod


@pytest.fixture(scope="module")
def db():
    return _load("diagnose_benchmark")


def test_tier1_cases_are_unchanged(db):
    case = db.make_case(0, 7100, "mujoco", ("bcc",), 3)
    assert set(case) == {"index", "structure", "controller", "families", "rng_seed", "plant"}
    assert db.make_case(0, 7100, "mujoco", ("bcc",), 3, tier=2)["families"] == case["families"]


def test_tier2_uses_the_converged_plant_of_the_model_form_data(db):
    with open(ASSETS_DIR / "model_form" / "bcc.json") as fh:
        rec = json.load(fh)
    case = db.make_case(0, 7100, "mujoco", ("bcc",), 3, tier=2)
    assert case["tier"] == 2 and case["plant"] == "mujoco"
    assert case["plant_options"] == rec["converged_options"]["sim_options"]
    opts = SimOptions(**case["plant_options"])
    assert opts.timestep_s == pytest.approx(25e-6)
    default_links = rec["default_options"]["links_per_segment"]
    assert opts.member_segments == {"beam": 2 * default_links["beam"]}
    assert opts.crosspiece_segments == 2 * default_links["crosspiece"]
    with pytest.raises(ValueError, match="mujoco"):
        db.make_case(0, 7100, "linear", ("bcc",), 3, tier=2)


def test_tier2_has_at_least_a_third_null_cases(db):
    for n in (3, 6, 7, 12):
        cases = [db.make_case(i, 11, "mujoco", ("bcc",), db.TIER2_NULL_EVERY, tier=2) for i in range(n)]
        nulls = sum(not c["families"] for c in cases)
        assert nulls >= n // 3 and nulls / n >= (1 / 3 if n % 3 == 0 else 0.28)


def test_perturbation_spread_matches_the_calibration_uncertainty(db):
    sc = db.perturbation_scale("bcc")
    spec = load_spec("bcc")
    assert sc["names"] == db.perturbation_names(spec)
    assert {"ei:beam", "ei:crosspiece", "mass:coil5", "mass:crosspiece.tip"} <= set(sc["names"])
    # by construction: the RMS over the band's modes of the first-order frequency sd is the calibration sd
    assert math.sqrt(np.mean(np.asarray(sc["frequency_sd_rel"]) ** 2)) == pytest.approx(sc["calibration_rel"])
    assert 1e-4 < sc["calibration_rel"] < 1e-2 and 0 < sc["spread_ln"] < 0.05


def test_perturbation_factors_are_applied_and_recorded(db):
    spec0 = load_spec("bcc")
    spec, rec = db.draw_perturbation(np.random.default_rng(5), "bcc")
    f = rec["factors"]
    assert set(f) == set(db.perturbation_names(spec0)) and all(x != 1.0 for x in f.values())
    beam = next(m for m in spec.members if m.id == "beam")
    assert [m.id for m in spec.members] == [m.id for m in spec0.members]  # effects are located as on the nominal
    assert spec.sections[beam.section].ei.si == pytest.approx(spec0.sections["steel_beam"].ei.si * f["ei:beam"])
    assert spec.sections[beam.section].gj.si == spec0.sections["steel_beam"].gj.si
    coil = {m.id: m.mass.si for m in spec.masses}["coil5"]
    assert coil == pytest.approx({m.id: m.mass.si for m in spec0.masses}["coil5"] * f["mass:coil5"])
    cp, cp0 = spec.crosspieces[0], spec0.crosspieces[0]
    assert cp.tip_mass.si == pytest.approx(cp0.tip_mass.si * f["mass:crosspiece.tip"])
    # small factors: the FE model's shifts are the first-order ones
    np.testing.assert_allclose(rec["frequency_shift_fe"], rec["frequency_shift_first_order"], atol=2e-5)


def test_threshold_ratio(db):
    mass = Threshold("added_mass", {"point": 6}, "mass_kg", 0.0, 0.01, 5.0, "chi2")
    gain = [Threshold("actuator_gain", {"channel": 9}, "gain", 1.0, 0.98, 0.02, "chi2"),
            Threshold("actuator_gain", {"channel": 9}, "gain", 1.0, 1.02, 50.0, "chi2")]
    lag = Threshold("actuator_lag", {"channel": "all"}, "corner_hz", None, 700.0, 2.5, "chi2")
    ths = [mass, *gain, lag]
    t = {"effect": "added_mass", "location": {"point": 6}, "parameters": {"mass_kg": 0.05}}
    assert db.threshold_ratio(t, ths) == pytest.approx(5.0)
    t = {"effect": "actuator_gain", "location": {"channel": 9}, "parameters": {"gain": 0.9}}
    assert db.threshold_ratio(t, ths) == pytest.approx(5.0)
    t = {"effect": "actuator_lag", "location": {"channel": "all"}, "parameters": {"corner_hz": 70.0}}
    assert db.threshold_ratio(t, ths) == pytest.approx(10.0)
    t = {"effect": "added_mass", "location": {"point": 2}, "parameters": {"mass_kg": 0.05}}
    assert db.threshold_ratio(t, ths) is None


@pytest.mark.slow
def test_tier2_recording_reaches_the_diagnosis_without_its_seeds(db, tmp_path, monkeypatch):
    """A null case and an effect case generated with the simulation replaced by a stub: the converged
    options and the tier's noise seed reach the simulation; the recording's metadata and the diagnosis's
    arguments hold neither the seeds nor the plant options."""
    calls, diagnosed = [], []

    def fake_sim(state, force, exc, meas, seed, options):
        calls.append({"seed": seed, "options": options, "spec": state.spec})
        rng = np.random.default_rng(0)
        return {p: 1e-3 * rng.standard_normal(len(force)) for p in meas}

    def fake_diagnose(structure, recording, **kw):
        diagnosed.append((structure, recording, kw))
        raise RuntimeError("not diagnosed in this test")

    def detection_only(structure, controller, effect, noise_m_s):
        # the detect-and-name thresholds take minutes per effect and have their own tests (test_detectability);
        # the detection thresholds of a recording by the model itself stand in here
        from vlab.diagnose.detectability import detectability

        return detectability(structure, controller, effects=(effect,), noise_m_s=noise_m_s,
                             model_form="none").thresholds

    monkeypatch.setattr(db, "_simulate_on_plant", fake_sim)
    monkeypatch.setattr(db, "diagnose", fake_diagnose)
    monkeypatch.setattr(db, "_thresholds", detection_only)
    cases = [db.make_case(i, 7100, "mujoco", ("bcc",), 3, tier=2) for i in range(6)]
    null = next(c for c in cases if not c["families"] and c["controller"] == "none")
    eff = next(c for c in cases if c["families"] and c["controller"] == "none")
    for case in (null, eff):
        r = db.run_case(case, str(tmp_path))
        assert r["error"].startswith("RuntimeError")  # the stub diagnosis was reached
        call = calls[-1]
        assert call["options"] == case["plant_options"]
        seeds = r["recording_seeds"]
        assert call["seed"] == seeds["sensor_noise"] and seeds["sensor_noise"] != case["index"]
        # the recording was made on the perturbed spec (its own sections) and the factors are in the case
        assert any("@tier2:" in m.section for m in call["spec"].members)
        assert set(r["perturbation"]["factors"]) == set(db.perturbation_names(load_spec("bcc")))
        structure, path, kw = diagnosed[-1]
        assert structure == "bcc" and path == r["recording"]
        # as a recording of the real structure: the default plant ("auto": MuJoCo), no plant named
        assert kw == {"controller": case["controller"], "plant": "auto", "baseline": None}
        with open(path + ".json") as fh:
            meta = json.load(fh)
        assert "plant" not in meta and meta["seed"] == 0  # the controller design's seed, not the recording's
        assert set(meta) <= {"structure", "controller", "seed", "resolution_hz"}
        text = json.dumps(meta)
        assert all(str(v) not in text for v in seeds.values() if v is not None)
        assert "timestep" not in text and "segments" not in text
    assert r["truth"] and all(t["threshold_ratio"] is None or t["threshold_ratio"] >= db.MIN_THRESHOLD_RATIO
                              for t in r["truth"])


def test_threshold_sizer_draws_within_the_window(db):
    """Tier 2 sizes each effect at 2-5 times its detection threshold at the drawn place,
    on the side of the drawn value, within the searched range; a place without a threshold keeps its size."""
    mass = Threshold("added_mass", {"point": 6}, "mass_kg", 0.0, 0.01, 5.0, "chi2")
    lag = Threshold("actuator_lag", {"channel": "all"}, "corner_hz", None, 700.0, 2.5, "chi2")
    gain = [Threshold("actuator_gain", {"channel": 9}, "gain", 1.0, 0.9, 0.02, "chi2"),
            Threshold("actuator_gain", {"channel": 9}, "gain", 1.0, 1.3, 1.5, "chi2")]
    size_of = db.threshold_sizer(lambda effect: [mass, lag, *gain])
    rng = np.random.default_rng(3)
    ratios = []
    for _ in range(30):
        m = size_of(rng, "added_mass", {"point": 6}, "mass_kg", 1.0)
        ratios.append(db.threshold_ratio({"effect": "added_mass", "location": {"point": 6},
                                          "parameters": {"mass_kg": m}}, [mass]))
        fc = size_of(rng, "actuator_lag", {"channel": "all"}, "corner_hz", 100.0)
        ratios.append(db.threshold_ratio({"effect": "actuator_lag", "location": {"channel": "all"},
                                          "parameters": {"corner_hz": fc}}, [lag]))
        g = size_of(rng, "actuator_gain", {"channel": 9}, "gain", 0.7)
        assert g < 1.0  # the side of the drawn value
        ratios.append(db.threshold_ratio({"effect": "actuator_gain", "location": {"channel": 9},
                                          "parameters": {"gain": g}}, gain))
        assert size_of(rng, "actuator_gain", {"channel": 9}, "gain", 1.2) <= 1.5  # held within the range
    assert min(ratios) >= 2.0 - 1e-9 and max(ratios) <= 5.0 + 1e-9 and max(ratios) - min(ratios) > 1.0
    assert size_of(rng, "added_mass", {"point": 2}, "mass_kg", 0.3) == 0.3  # no threshold there: kept


def test_a_member_piece_of_a_split_spec_is_its_segment(db):
    """A compound case's second draw on a spec the first split (a softened joint splits its beam into pieces
    ``beam[a-b]``) names the piece; the diagnosis, on the nominal spec, names the segment: the same place."""
    assert db._same_location({"member": "beam[6-7]"}, {"member": "beam", "segment": [6, 7]})
    assert db._same_location({"member": "beam", "segment": (6, 7)}, {"member": "beam[6-7]"})
    assert not db._same_location({"member": "beam[6-7]"}, {"member": "beam", "segment": [7, 8]})
    assert not db._same_location({"member": "beam[6-7]"}, {"member": "beam"})
    assert db._same_location({"point": 7}, {"point": 7}) and not db._same_location({"point": 7}, {"point": 8})


def test_above_the_band_modes_pair_by_shape_then_frequency_and_stop_at_the_first_unpaired():
    """benchmarks/plant_model_form.py's above-band pairing on constructed modes: two arm-like modes of the same
    shape at the sites (8.6 Hz in the band, 74 Hz above it) pair with the default modes nearest in frequency, not
    across the band; the list stops at the first converged mode with no default mode of its shape (MAC < 0.9)."""
    pmf = _load("plant_model_form")
    arm, bend, odd = [0.0, 1.0, -1.0], [1.0, 0.0, -1.0], [1.0, -2.0, 1.0]
    conv = {"sampled_hz": np.array([1.0, 8.6, 74.0, 76.5, 77.0]),
            "shapes": np.array([[1.0, 1.0, 1.0], arm, arm, odd, bend]).T}
    default = {"sampled_hz": np.array([1.0, 8.63, 73.6, 77.6]),
               "shapes": np.array([[1.0, 1.0, 1.0], arm, arm, bend]).T}
    rows = pmf._above_band(default, conv, 2, {0, 1})
    assert [(r["converged_mode"], r["default_mode"]) for r in rows] == [(3, 3)]
    assert rows[0]["frequency_rel"] == pytest.approx(math.log(74.0 / 73.6))
    assert rows[0]["mac"] == pytest.approx(1.0)
