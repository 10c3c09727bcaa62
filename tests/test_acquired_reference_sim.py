"""vlab's readers and diagnosis on recordings of the independent reference simulator in its lab mode.

The simulator (``benchmarks/reference_sim``, no vlab code) writes what an acquisition system writes:
accelerations at points 1-9 and the force at 5 kHz through an 8-pole anti-alias filter, 16-bit
quantised, with noise, as ASCII UFF 58 records named ``9+Z``, no sidecar. vlab reads them by node and
direction, resamples them to the loop's clock and converts the FRFs to velocity
(:mod:`vlab.diagnose.data.acquired`). Checked here:

- the FRF at point 6 against plain FFTs of the same 5 kHz samples (``A / F / (j w)`` times the hold of
  the lab's command), and against the simulator's own controller-rate velocity and command of the same
  run (its compatibility recording, another sensor path): within 1 % (the simulator's own noise-free
  check of its two paths: 0.5 %);
- a nominal recording referred through a nominal baseline recording (another excitation and noise
  realisation): no mismatch;
- 0.12 kg concealed at point 6, referred through the same baseline: ``added_mass`` at point 6 named and
  confirmed by the validation rerun on the MuJoCo plant (referred through the baseline too).

Short records keep the test small: a 2-s multisine period (0.5 Hz lines), three periods, the
simulator's mesh at 2 elements per segment (its own model, the same for every case).
"""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.reference_sim.cases import Case
from benchmarks.reference_sim.loop import Controller
from benchmarks.reference_sim.run import Settings, simulate, write_outputs

EXCITATION = {"kind": "multisine", "rms_n": 0.5, "band_hz": [0.5, 25.0], "period_s": 2.0, "periods": 3,
              "settle_periods": 0}
RESOLUTION_HZ = 0.5
MASS_KG = 0.12


@pytest.fixture(scope="module")
def lab(tmp_path_factory):
    """Three lab-mode runs: two nominal (seeds 21, 22) and one with a mass at point 6 (seed 23)."""
    root = tmp_path_factory.mktemp("refsim")
    settings = Settings(elements_per_segment=2, arm_elements=2)
    runs = {}
    for name, seed, effects in (("base", 21, ()), ("null", 22, ()),
                                ("mass", 23, ({"type": "added_mass", "point": 6, "mass_kg": MASS_KG},))):
        res = simulate(Case(controller="none", excitation=dict(EXCITATION), seed=seed, effects=effects, mode="both"),
                       Controller.zero(3), settings=settings)
        write_outputs(res, root / name)
        runs[name] = (root / name, res)
    return runs


def test_lab_recording_is_read_and_agrees_with_the_controller_rate_velocity(lab):
    from vlab.diagnose.data.readers import read_data, read_uff_any
    from vlab.fe import build_fe_model
    from vlab.spec import load_spec

    folder, res = lab["null"]
    what, rec = read_uff_any(folder / "lab.uff")
    assert what == "recording" and rec.dt_s == pytest.approx(2e-4)
    assert set(rec.names) == {"force9"} | {f"acc{p}" for p in range(1, 10)}
    spec = load_spec("bcc")
    data = read_data(spec, build_fe_model(spec), folder / "lab.uff", what, rec, resolution_hz=RESOLUTION_HZ,
                     band_hz=(0.5, 25.0), settle_of=lambda: 0.0)
    assert data.periodic and data.output_points == tuple(range(1, 10)) and data.recording.dt_s == 5e-4
    j = data.output_points.index(6)
    k = np.rint(data.freq_hz / RESOLUTION_HZ).astype(int)
    w = 2 * np.pi * data.freq_hz
    hold = (1 - np.exp(-1j * w * 5e-4)) / (1j * w * 5e-4)

    def averaged(x, n, first):  # the periods after the first, averaged, at the analysed lines
        return np.fft.rfft(np.asarray(x)[first * n:3 * n].reshape(3 - first, n), axis=1).mean(axis=0)[k]

    # 1. the same 5 kHz samples by plain FFTs: H = A / F / (j w) times the command's hold
    n_lab = int(round(1 / (RESOLUTION_HZ * 2e-4)))
    h_fft = averaged(rec["acc6"], n_lab, 1) / averaged(rec["force9"], n_lab, 1) / (1j * w) * hold
    assert np.max(np.abs(data.h[:, j] / h_fft - 1)) < 1e-3
    # 2. the simulator's own velocity at 6 and command at 9, sampled by its controller: another sensor path,
    #    within 1 % (its own noise-free check of the two paths: 0.5 %)
    n = int(round(1 / (RESOLUTION_HZ * 5e-4)))
    h_compat = averaged(res["compat"]["vel6"][2], n, 1) / averaged(res["compat"]["force9"][2], n, 1)
    assert np.max(np.abs(data.h[:, j] / h_compat - 1)) < 0.01


def test_nominal_recording_against_a_nominal_baseline_is_no_mismatch(lab):
    from vlab.diagnose import diagnose

    res = diagnose("bcc", lab["null"][0] / "lab.uff", controller="none", resolution_hz=RESOLUTION_HZ,
                   baseline=lab["base"][0] / "lab.uff", validate_run=False)
    d = res.as_dict()
    assert not d["mismatch"] and not d["selected"], d["selected"]
    assert any("acquired at 5000 samples/s" in n for n in d["notes"])


def test_concealed_mass_is_named(lab):
    from vlab.diagnose import diagnose

    res = diagnose("bcc", lab["mass"][0] / "lab.uff", controller="none", resolution_hz=RESOLUTION_HZ,
                   baseline=lab["base"][0] / "lab.uff")
    d = res.as_dict()
    assert d["mismatch"] and len(d["selected"]) == 1
    sel = d["selected"][0]
    assert sel["effect"] == "added_mass" and sel["location"] == {"point": 6}
    assert sel["parameters"]["mass_kg"] == pytest.approx(MASS_KG, rel=0.05)
    # compared through the measured baseline, the FE fit is the answer (the MuJoCo plant takes no part in the
    # comparison, so nothing is refitted there), and the validation rerun on that plant, referred through the
    # same baseline and started in the steady state as the recording was, confirms it
    assert res.plant_refit is None
    v = d["validated"]
    assert v["plant"].startswith("MuJoCo plant") and v["misfit_after"] < 0.5 * v["misfit_before"], v


def _write_csv(path, t, columns):
    """CSV time histories as an acquisition system exports them: 'time [s]', then '<node>+Z <quantity> [<unit>]'."""
    header = ",".join(["time [s]", *columns])
    np.savetxt(path, np.column_stack([t, *columns.values()]), delimiter=",", header=header, comments="",
               fmt="%.10g")
    return path


@pytest.mark.slow
def test_the_same_recording_resampled_or_integrated_to_velocity_diagnoses_the_same(lab, tmp_path):
    """The concealed-mass recording exported twice as another acquisition system might: accelerations in g
    resampled from 5 to 4 kHz (a polyphase filter, scipy.signal.resample_poly), and velocities in mm/s
    (trapezoidal integration, linear trend removed) with the force in lbf. Each read from CSV and diagnosed
    against the original baseline: the same effect at the same point, the mass within 0.5 % of the
    original's (the resampler's passband ripple and the integration's error are far below that at 25 Hz)."""
    from scipy import integrate, signal

    from vlab.diagnose import diagnose
    from vlab.diagnose.data.readers import read_uff_any

    _what, rec = read_uff_any(lab["mass"][0] / "lab.uff")
    points = range(1, 10)
    acc = {p: np.asarray(rec[f"acc{p}"]) for p in points}
    force = np.asarray(rec["force9"])
    fs = 1 / rec.dt_s
    resampled = {f"{p}+Z acceleration [g]": signal.resample_poly(acc[p], 4, 5) / 9.80665 for p in points}
    resampled["9+Z force [N]"] = signal.resample_poly(force, 4, 5)
    n4 = len(resampled["9+Z force [N]"])
    t = np.arange(len(force)) / fs

    def velocity(a):
        return signal.detrend(integrate.cumulative_trapezoid(a, t, initial=0.0), type="linear")

    integrated = {f"{p}+Z velocity [mm/s]": 1e3 * velocity(acc[p]) for p in points}
    integrated["9+Z force [lbf]"] = force / 4.4482216152605
    files = {"original": lab["mass"][0] / "lab.uff",
             "resampled": _write_csv(tmp_path / "acc_4khz.csv", np.arange(n4) / (0.8 * fs), resampled),
             "velocity": _write_csv(tmp_path / "vel.csv", t, integrated)}
    found = {}
    for name, path in files.items():
        d = diagnose("bcc", path, controller="none", resolution_hz=RESOLUTION_HZ,
                     baseline=lab["base"][0] / "lab.uff", validate_run=False).as_dict()
        assert d["mismatch"] and len(d["selected"]) == 1, (name, d["selected"])
        sel = d["selected"][0]
        found[name] = (sel["effect"], sel["location"], sel["parameters"]["mass_kg"])
    assert {k: v[:2] for k, v in found.items()} == {k: ("added_mass", {"point": 6}) for k in files}
    m0 = found["original"][2]
    for name in ("resampled", "velocity"):
        assert found[name][2] == pytest.approx(m0, rel=0.005), found
