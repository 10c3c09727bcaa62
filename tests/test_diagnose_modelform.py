"""Model-form uncertainty in the diagnosis of modal tables.

Checked against things the diagnosis does not compute itself: the dissertation's tables read directly
from their CSV files, the grid calibration's documented residual, and per-mode uncertainty columns
that must change the decision when (and only when) they change the weights.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from vlab.diagnose import diagnose
from vlab.diagnose.data.modalcsv import read_modal_csv
from vlab.diagnose.model.modelform import (ROUNDING_SIGMA, calibration_residual, damping_uncertainty,
                                           model_form_uncertainty, printed_resolution)
from vlab.errors import DataFileError, OptionError
from vlab.fe import build_fe_model, modal_analysis
from vlab.reference import column
from vlab.spec import load_spec


@pytest.mark.parametrize("text, res", [("1.899", 1e-3), ("0.04", 1e-2), ("1.5e-3", 1e-4), ("1200", 1.0),
                                       ("-2.50", 1e-2), ("7.", 1.0), ("3E2", 100.0)])
def test_printed_resolution(text, res):
    assert printed_resolution(text) == pytest.approx(res)


def test_printed_resolution_of_text_that_is_no_number_is_nan():
    assert math.isnan(printed_resolution("n/a"))


def _freqs(name: str, n: int) -> np.ndarray:
    fe = build_fe_model(load_spec(name))
    return modal_analysis(fe.m, fe.k, n).frequencies_hz


def test_grid_calibration_residual_is_the_documented_reconstruction_error():
    # vlab.grid_fit documents 9.2 % rms against Table 3 analytical (modes paired by character); by order here
    f = _freqs("grid", 12)
    s, src = calibration_residual(load_spec("grid"), f)
    ref = column("table3_grid_frequencies.csv", "analytical_hz")
    assert s == pytest.approx(float(np.sqrt(np.mean(np.log(f / ref) ** 2))))
    assert 0.08 < s < 0.11 and "table3_grid_frequencies.csv" in src


def test_bcc_model_form_is_small_and_grows_with_the_coarse_mesh():
    f = _freqs("bcc", 12)
    u = model_form_uncertainty(load_spec("bcc"), f)
    # calibrated to Table 1 analytical within 0.1 % (python -m vlab.calibration bcc)
    assert 0.0 < u.components["calibration"][0] < 1e-3
    # one element per beam segment: high modes carry a larger discretisation error than mode 1
    assert u.components["discretisation"][11] > 10 * u.components["discretisation"][0]
    assert np.all(u.frequency_rel >= u.components["calibration"])


def test_assumed_damping_is_not_compared_and_measured_damping_carries_its_rounding():
    spec = load_spec("bcc")  # modal_ratios = Table 1's six values, higher modes assumed
    z = damping_uncertainty(spec, 8)
    assert z[0] == pytest.approx(ROUNDING_SIGMA * 0.001 / 0.004)
    assert z[5] == pytest.approx(ROUNDING_SIGMA * 0.001 / 0.001)
    assert np.all(np.isinf(z[6:]))


def test_a_structure_without_a_calibration_reference_says_so():
    spec = load_spec("bcc").replace(reference={})
    u = model_form_uncertainty(spec, _freqs("bcc", 6))
    assert np.all(u.components["calibration"] == 0.0)
    assert u.sources["calibration"].startswith("none")


def _table(tmp_path, rows, sigma=None):
    p = tmp_path / "modes.csv"
    head = "mode,frequency_hz,damping_ratio" + (",frequency_sigma_hz" if sigma is not None else "")
    lines = [head] + [f"{m},{f:.6f},{z}" + (f",{sigma * f:.8f}" if sigma is not None else "")
                      for m, f, z in rows]
    p.write_text("\n".join(lines) + "\n")
    return p


def test_frequency_sigma_column_sets_the_weight(tmp_path):
    f = _freqs("bcc", 6)
    z = [0.004, 0.002, 0.004, 0.002, 0.003, 0.001]
    f_meas = f.copy()
    f_meas[0] *= 1.005  # 0.5 % on mode 1
    rows = list(zip(range(1, 7), f_meas, z))
    loose = diagnose("bcc", _table(tmp_path, rows, sigma=0.01), out_dir=None, pairs=False)
    assert not loose.mismatch  # 0.5 sigma
    tight = diagnose("bcc", _table(tmp_path, rows, sigma=1e-4), out_dir=None, pairs=False)
    assert tight.mismatch  # 50 sigma of the measurement, ~10 of the model form
    u = tight.as_dict()["uncertainty"]
    assert u["frequency_sigma_measurement_rel"][0] == pytest.approx(1e-4, rel=1e-3)


def test_table1_is_a_mismatch_dominated_by_the_model_form():
    res = diagnose("bcc", "assets/data/table1_bcc_frequencies.csv", out_dir=None).as_dict()
    assert res["mismatch"]
    u = res["uncertainty"]
    assert u["dominant"] == "model form"
    assert max(u["frequency_sigma_model_form_rel"]) < 0.002
    # the measured frequency of mode 1 against the model, from the published table directly
    f_exp = column("table1_bcc_frequencies.csv", "experimental_hz")
    m1 = next(m for m in res["validated"]["modes"] if m["mode"] == 1)
    assert m1["frequency_measured_hz"] == pytest.approx(f_exp[0])


def test_table3_is_within_the_reconstructed_grids_accuracy():
    res = diagnose("grid", "assets/data/table3_grid_frequencies.csv", out_dir=None).as_dict()
    assert not res["mismatch"] and not res["selected"]
    assert res["uncertainty"]["dominant"] == "model form"


@pytest.mark.slow
def test_table3_referred_to_its_analytical_column(tmp_path):
    res = diagnose("grid", "assets/data/table3_grid_frequencies.csv", out_dir=None,
                   reference_column="analytical_hz").as_dict()
    f_exp = column("table3_grid_frequencies.csv", "experimental_hz")
    f_ana = column("table3_grid_frequencies.csv", "analytical_hz")
    # referred, the nominal misfit is the published analysis' own error against the experiment
    assert res["validated"]["misfit_before"] == pytest.approx(float(np.sqrt(np.mean(np.log(f_ana / f_exp) ** 2))),
                                                              rel=1e-6)
    assert res["mismatch"]
    assert res["uncertainty"]["sources"]["calibration"].startswith("cancels")
    before = [m["frequency_before_hz"] for m in res["validated"]["modes"]]
    np.testing.assert_allclose(before, f_ana, rtol=1e-9)


def test_reference_column_errors(tmp_path):
    spec = load_spec("bcc")
    with pytest.raises(DataFileError, match="no column 'model_hz'"):
        read_modal_csv("assets/data/table1_bcc_frequencies.csv", spec, reference_column="model_hz")
    with pytest.raises(DataFileError, match="own"):
        read_modal_csv("assets/data/table1_bcc_frequencies.csv", spec, reference_column="experimental_hz")
    p = tmp_path / "x.uff"
    p.write_text("not read")
    with pytest.raises(OptionError, match="only a modal table"):
        diagnose("bcc", p, out_dir=None, reference_column="analytical_hz")


# ----------------------------------------------------------------------------- FRF data
def test_frf_variance_matches_the_modal_closed_form():
    """Open loop, one mode uncertain: d ln H / d ln f_r of the modal sum, written out here."""
    from vlab.diagnose.model.labmodel import LabState, natural_frequencies, predict_frf
    from vlab.diagnose.model.modelform import ModelFormUncertainty, frf_model_form
    from vlab.lab.loop import HardwareChain
    from vlab.models import nominal_fe_model

    fe = nominal_fe_model("bcc")
    st = LabState(fe.spec, fe, HardwareChain(noise_m_s=0.0), None)
    f = np.linspace(1.0, 12.0, 400)
    fr, zeta, phi = natural_frequencies(st)
    n = len(fr)
    r, sig = 2, 2e-3  # mode 3, 0.2 %
    freq_rel = np.zeros(n)
    freq_rel[r] = sig
    unc = ModelFormUncertainty(freq_rel, np.full(n, np.inf), {}, {})
    var = frf_model_form(st, f, excitation_point=9, output_points=(6,), uncertainty=unc).variance[:, 0]
    # closed form: H = jw sum_k a_k / D_k (times a chain that does not depend on f_r), D = wr^2 - w^2 + 2j z wr w
    w, wr = 2 * np.pi * f, 2 * np.pi * fr
    i6, i9 = fe.dofs.index(6, "w"), fe.dofs.index(9, "w")
    a = phi[i6, :] * phi[i9, :]
    d = wr[None, :] ** 2 - w[:, None] ** 2 + 2j * zeta[None, :] * wr[None, :] * w[:, None]
    g = (a[None, :] / d).sum(axis=1)
    dg = -a[r] * (2 * wr[r] ** 2 + 2j * zeta[r] * wr[r] * w) / d[:, r] ** 2  # d g / d ln wr
    expect = np.abs(dg / g) ** 2 * sig**2
    np.testing.assert_allclose(var, expect, rtol=2e-3)
    h = predict_frf(st, f, excitation_point=9, output_points=(6,))
    assert np.all(np.isfinite(h))


@pytest.mark.slow
def test_a_recording_within_the_model_form_is_no_mismatch_only_with_it(tmp_path):
    """The structure 0.1 % stiffer in frequency (its stiffness matrix 0.2 % up), as a real structure may
    differ from its calibrated model: with the model-form uncertainty (BCC: 0.06-0.37 %)
    no mismatch; without it, the same recording is a mismatch."""
    from dataclasses import replace

    from test_diagnose import _record  # the linear BCC lab recorder of the end-to-end diagnosis tests
    from vlab.diagnose.model.labmodel import LabState
    from vlab.lab.loop import HardwareChain
    from vlab.models import nominal_fe_model

    fe = nominal_fe_model("bcc")
    stiff = LabState(fe.spec, replace(fe, k=fe.k * 1.002), HardwareChain(noise_m_s=1e-6), None)
    path = _record(stiff, tmp_path / "stiff.uff", noise=0.002, steady=True)
    with_mf = diagnose("bcc", path, out_dir=None, model_form="derived", pairs=False).as_dict()
    without = diagnose("bcc", path, out_dir=None, model_form="none", pairs=False).as_dict()
    assert without["mismatch"]
    assert not with_mf["mismatch"] and with_mf["within_model_accuracy"]
    assert with_mf["uncertainty"]["model_form"] == "derived"
    prof = with_mf["uncertainty"]["nominal_profile"]
    assert prof["nuisance_chi2"] < prof["nuisance_limit"]
    # five times as far (0.5 % in frequency, 2-9 sigma on the first modes): beyond the model's accuracy
    far = LabState(fe.spec, replace(fe, k=fe.k * 1.01), HardwareChain(noise_m_s=1e-6), None)
    path = _record(far, tmp_path / "far.uff", noise=0.002, steady=True)
    d = diagnose("bcc", path, out_dir=None, model_form="derived", pairs=False).as_dict()
    assert d["mismatch"] and d["uncertainty"]["nominal_profile"]["beyond"]


def test_a_stated_model_form_replaces_the_derived_one(tmp_path):
    from vlab.errors import SpecError

    base = open("examples/cantilever_tip_mass.toml").read()
    good = tmp_path / "stated.toml"
    good.write_text(base + '\n[model_form]\nfrequency_rel = [0.02, 0.03]\nsource = "calibrated against my modal test"\n')
    spec = load_spec(str(good))
    fe = build_fe_model(spec)
    f = modal_analysis(fe.m, fe.k, 4).frequencies_hz
    u = model_form_uncertainty(spec, f)
    np.testing.assert_allclose(u.components["calibration"], [0.02, 0.03, 0.03, 0.03])
    assert "calibrated against my modal test" in u.sources["calibration"]
    bad = tmp_path / "bad.toml"
    bad.write_text(base + '\n[model_form]\nfrequency_rel = 1.5\nsource = "x"\n')
    with pytest.raises(SpecError, match="frequency_rel"):
        load_spec(str(bad))


def test_a_malformed_plant_model_form_file_is_named(tmp_path, monkeypatch):
    from vlab.diagnose.model import modelform

    (tmp_path / "bcc.json").write_text('{"modes": [{"frequency_default_hz": 1.85}]}')
    monkeypatch.setattr(modelform, "MODEL_FORM_DIR", tmp_path)
    with pytest.raises(DataFileError, match="bcc.json"):
        modelform.plant_discretisation(load_spec("bcc"), np.array([1.85]))
    with pytest.raises(DataFileError, match="bcc.json"):
        modelform.plant_shape_uncertainty(load_spec("bcc"), np.array([1.85]))


def test_the_plants_discretisation_above_the_band_is_read_and_bounded_from_below(tmp_path, monkeypatch):
    """A mode takes its own entry (within 3 %), else the largest entry up to its frequency (the discretisation
    grows with frequency), else the lowest entry's. The cache tells frequencies of the same count apart."""
    from vlab.diagnose.model import modelform

    rows = [{"frequency_default_hz": 1.0, "frequency_rel": 0.001, "mac": 1.0}]
    above = [{"frequency_default_hz": 50.0, "frequency_rel": 0.004, "mac": 0.99},
             {"frequency_default_hz": 100.0, "frequency_rel": 0.05, "mac": 0.95}]
    (tmp_path / "bcc.json").write_text(json.dumps({"modes": rows, "above_band_modes": above}))
    monkeypatch.setattr(modelform, "MODEL_FORM_DIR", tmp_path)
    rel, _src = modelform.plant_discretisation(load_spec("bcc"), np.array([1.0, 50.5, 70.0, 99.0, 300.0, 0.5, 0.0]))
    assert list(rel) == [0.001, 0.004, 0.004, 0.05, 0.05, 0.001, 0.001]  # below every entry: the lowest one's
    spec = load_spec("bcc")
    a = modelform.model_form_uncertainty(spec, np.array([1.0, 50.0]), compared_with="plant")
    b = modelform.model_form_uncertainty(spec, np.array([1.0, 100.0]), compared_with="plant")
    assert a.components["plant"][1] == 0.004 and b.components["plant"][1] == 0.05
