"""The diagnosis's reference: the simulation by default, the recording's metadata honoured, and a
selection that obeys its own validation."""

from __future__ import annotations

import json
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from vlab.cli import app
from vlab.diagnose import diagnose
from vlab.diagnose import pipeline as pipeline_module
from vlab.diagnose.data.reference import recorded_chain, recorded_setup
from vlab.diagnose.effects import specedit
from vlab.errors import DataFileError, OptionError

sys.path.insert(0, str(Path(__file__).parent))
from test_diagnose import _record  # noqa: E402  (the linear BCC lab recorder of the diagnosis tests)

runner = CliRunner()


# ------------------------------------------------------------------ metadata and options ---

def test_metadata_fills_what_the_options_leave_unsaid():
    meta = {"controller": "mfdrf", "seed": 3, "plant": "MuJoCo plant", "reduction": "full",
            "chain": {"delay_periods": 2.0, "filter_hz": 500.0, "amplifier_gain": 1.0, "amplifier_limit_n": None}}
    s = recorded_setup(meta, "rec.uff", controller=None, seed=None, plant=None)
    assert (s.controller, s.seed, s.plant, s.reduction) == ("mfdrf", 3, "mujoco", "full")
    chain = recorded_chain(s, 0.0005)
    assert chain.delay_periods == 2.0 and chain.filter_hz == 500.0 and chain.noise_m_s == 0.0
    assert chain.period_s == 0.0005
    assert any("from the recording's metadata" in n for n in s.notes)


def test_an_option_contradicting_the_metadata_is_refused_naming_both():
    meta = {"controller": "mfdrf", "plant": "linear FE model"}
    with pytest.raises(OptionError, match=r"--controller 'none'.*rec\.uff.*'mfdrf'.*--force"):
        recorded_setup(meta, "rec.uff", controller="none", seed=None, plant=None)
    with pytest.raises(OptionError, match=r"--plant 'mujoco'.*'linear'"):
        recorded_setup(meta, "rec.uff", controller=None, seed=None, plant="mujoco")
    s = recorded_setup(meta, "rec.uff", controller="none", seed=None, plant=None, force=True)
    assert s.controller == "none" and s.reduction is None
    assert any("as forced" in n for n in s.notes)


def test_no_metadata_means_open_loop_seed_0_and_no_plant():
    s = recorded_setup({}, "rec.uff", controller=None, seed=None, plant=None)
    assert (s.controller, s.seed, s.plant, s.chain) == ("none", 0, None, {})


@pytest.mark.parametrize("meta, field", [({"seed": "3"}, "seed"), ({"controller": 7}, "controller"),
                                         ({"chain": {"delay_periods": -1}}, "chain.delay_periods"),
                                         ({"chain": [1]}, "chain")])
def test_bad_metadata_names_the_file_and_field(meta, field):
    with pytest.raises(DataFileError, match=rf"rec\.uff.*'{field}'"):
        recorded_setup(meta, "rec.uff", controller=None, seed=None, plant=None)


# ------------------------------------------------------------------ selection obeys validation ---

@pytest.mark.slow
def test_a_candidate_whose_validation_worsens_the_fit_is_rejected(tmp_path, monkeypatch):
    """A stand-in validation that makes the FRF misfit and the reruns' chi-square 10x worse: the pipeline must
    reject the candidate (shown with both numbers), select nothing, and say so; the real validation of the
    same case selects the mass."""
    from vlab.diagnose.model.labmodel import LabState
    from vlab.diagnose.model.nominal import nominal_design
    from vlab.lab.loop import HardwareChain
    from vlab.models import nominal_fe_model

    fe = nominal_fe_model("bcc")
    nominal = LabState(fe.spec, fe, HardwareChain(noise_m_s=1e-6), nominal_design(fe, "mfdrf", 0))
    path = _record(nominal.with_spec(specedit.add_mass(nominal.spec, 6, 0.12)), tmp_path / "rec.uff")
    real = pipeline_module.validate

    def worse(*args, **kwargs):
        v = real(*args, **kwargs)
        return replace(v, misfit_after=10 * v.misfit_before, chi2_after=10 * v.chi2_before)

    monkeypatch.setattr(pipeline_module, "validate", worse)
    r = diagnose("bcc", path, plant="linear")
    assert r.mismatch and r.selected is None and r.validation is None
    assert len(r.rejected) == 1 and r.rejected[0]["effect"] == "added_mass"
    rej = r.rejected[0]
    assert rej["misfit_after"] == pytest.approx(10 * rej["misfit_before"])
    assert rej["chi2_after"] == pytest.approx(10 * rej["chi2_before"])
    assert any("10 x higher" in n and "rejected" in n for n in r.notes)
    d = r.as_dict()
    assert d["selected"] == [] and d["rejected"][0]["label"] == rej["label"]
    monkeypatch.setattr(pipeline_module, "validate", real)
    ok = diagnose("bcc", path, plant="linear")
    assert ok.selected is not None and ok.selected.effect == "added_mass" and ok.rejected == []
    assert ok.validation.misfit_after < ok.validation.misfit_before


# ------------------------------------------------------------------ the simulation as the reference ---

def test_a_linear_recording_is_referred_through_its_replay(tmp_path):
    """A clean recording of the linear plant (metadata says so): replayed on the linear plant, no mismatch,
    and the report names the reference."""
    from vlab.diagnose.model.labmodel import LabState
    from vlab.diagnose.model.nominal import nominal_design
    from vlab.lab.loop import HardwareChain
    from vlab.models import nominal_fe_model

    fe = nominal_fe_model("bcc")
    nominal = LabState(fe.spec, fe, HardwareChain(noise_m_s=1e-6), nominal_design(fe, "mfdrf", 0))
    path = _record(nominal, tmp_path / "clean.uff")
    r = diagnose("bcc", path)  # no option: controller and plant from the metadata
    assert r.controller == "mfdrf"
    assert "replay" in r.reference and "linear" in r.reference
    assert not r.mismatch, r.notes


@pytest.mark.slow
def test_the_default_recording_diagnosed_without_any_option_has_no_mismatch(tmp_path):
    """`vlab experiment` with its defaults (the MuJoCo plant, MFDRF), then `vlab diagnose` with only
    the structure and the recording: "no significant mismatch" (before: a false alarm selecting a member
    stiffness and an actuator lag whose validation made the fit 4900x worse)."""
    exp = tmp_path / "exp"
    res = runner.invoke(app, ["experiment", "--out", str(exp)])
    assert res.exit_code == 0, res.output
    out = tmp_path / "diag"
    res = runner.invoke(app, ["diagnose", "--structure", "bcc", "--recording", str(exp / "recording.uff"),
                              "--out", str(out), "--json"])
    assert res.exit_code == 0, res.output
    d = json.loads(res.stdout)
    assert d["mismatch"] is False, d["notes"]
    assert d["controller"] == "mfdrf" and "MuJoCo" in d["reference"]
    meta = json.loads((exp / "recording.uff.json").read_text())
    assert meta["chain"]["delay_periods"] == pytest.approx(1.35)
    assert np.isfinite(d["statistics"]["chi2_nominal"])


def test_a_baseline_excited_by_another_record_does_not_make_an_unchanged_structure_a_mismatch(tmp_path):
    """The nominal lab recorded twice with two records of the same spectrum (other phases,
    other noise); one is the other's baseline. The decision is "no mismatch"; the record is told apart."""
    from vlab.diagnose.data.readers import read_uff_any
    from vlab.diagnose.data.reference import shares_excitation_record
    from vlab.diagnose.model.labmodel import LabState
    from vlab.diagnose.model.nominal import nominal_design
    from vlab.lab.loop import HardwareChain
    from vlab.models import nominal_fe_model

    fe = nominal_fe_model("bcc")
    nominal = LabState(fe.spec, fe, HardwareChain(noise_m_s=1e-6), nominal_design(fe, "mfdrf", 0))
    a = _record(nominal, tmp_path / "a.uff", seed=1)
    b = _record(nominal, tmp_path / "b.uff", seed=2)
    r = diagnose("bcc", a, baseline=b, validate_run=False)
    assert not r.mismatch, r.notes
    assert any("not excited by the recording's own force record" in n for n in r.notes)
    rec_a, rec_b = read_uff_any(a)[1], read_uff_any(b)[1]
    data = r.data
    assert not shares_excitation_record(data, rec_b)
    assert shares_excitation_record(data, rec_a)
    assert not shares_excitation_record(data, None)


def test_a_level_dependence_is_added_to_the_data_or_to_data_and_baseline():
    """A replay plant's level dependence (relative variance per line) is the data's variance times |H|^2: on the
    baseline the data were referred through (the baseline's too, and the relative variance kept for the
    validation's reruns), or on the data alone (the recording's own, referred through a linear replay)."""
    from vlab.diagnose.data.measured import FrfData
    from vlab.diagnose.data.reference import with_level_dependence

    lines = np.array([1.0, 2.0, 3.0])
    h = np.array([[1.0 + 1.0j, 2.0], [0.5j, 1.0], [3.0, -1.0]])
    var = np.full(h.shape, 1e-4)
    rel = np.array([[0.01, 0.0], [0.04, 0.02], [0.0, 0.09]])
    data = FrfData("x", "recording", lines, h, var, 9, (5, 6))
    own = with_level_dependence(data, rel, on_baseline=False)
    assert np.allclose(own.var, var + rel * np.abs(h) ** 2)
    assert own.var_baseline is None and own.var_distortion is None
    based = replace(data, h_baseline=2.0 * h, var_baseline=np.zeros(h.shape))
    both = with_level_dependence(based, rel, on_baseline=True)
    assert np.allclose(both.var, var + rel * np.abs(h) ** 2)
    assert np.allclose(both.var_baseline, 4.0 * rel * np.abs(h) ** 2)
    assert both.var_distortion is rel or np.array_equal(both.var_distortion, rel)
    with pytest.raises(ValueError, match="shape"):
        with_level_dependence(data, rel[:2], on_baseline=False)
    with pytest.raises(ValueError, match="baseline"):
        with_level_dependence(data, rel, on_baseline=True)
