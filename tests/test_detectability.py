"""Detection thresholds (vlab.diagnose.detectability, `vlab detectability`).

The threshold is computed from the frequency-domain model of the lab with the effect; it is checked
here against the diagnosis itself on time-domain recordings of the 2 kHz loop on the linear plant, with
their own excitation and noise seeds: at half the threshold the diagnosis must say "no significant
mismatch", at three times it must name the effect where it is (the full check over eight effects is
benchmarks/detectability_check.py, listing in docs/).

The naming thresholds, the damping threshold, the command's JSON and the profiled threshold are in
test_detectability_naming.py (a second file, so that pytest-xdist's ``--dist loadfile`` can run the two
halves on two workers); both use :func:`_detect_recordings.diagnosed`.
"""

from __future__ import annotations

import numpy as np
import pytest
from typer.testing import CliRunner

from vlab.cli import app
from vlab.diagnose.detectability import detectability
from vlab.spec import load_spec

from _detect_recordings import diagnosed as _diagnosed

runner = CliRunner()


@pytest.fixture(scope="module")
def mass_threshold():
    spec = load_spec("bcc")
    det = detectability(spec, "none", effects=("added_mass",), model_form="none")  # recordings by the model itself
    (t,) = det.of("added_mass", {"point": 6})
    return spec, det, t


def test_thresholds_are_positive_and_below_the_range(mass_threshold):
    _spec, det, t = mass_threshold
    assert t.null == 0.0 and 0 < t.threshold < t.bound
    assert t.by in ("chi2", "peak")
    assert det.chi2_noise < det.chi2_limit  # the nominal recording itself is within the test's limits
    assert all(x.threshold is None or x.threshold > 0 for x in det.thresholds)


@pytest.mark.slow
def test_half_the_threshold_is_mostly_no_mismatch(tmp_path, mass_threshold):
    """At half the threshold the test fires now and then (its largest-line statistic carries the noise and
    the unsettled transient of the record): at most one of three recordings."""
    spec, _det, t = mass_threshold
    quiet = [not _diagnosed(tmp_path, spec, t, 0.5, seed)["mismatch"] for seed in (70, 71, 72)]
    assert sum(quiet) >= 2, quiet


@pytest.mark.slow
def test_three_times_the_threshold_is_named(tmp_path, mass_threshold):
    spec, _det, t = mass_threshold
    d = _diagnosed(tmp_path, spec, t, 3.0, 73)
    assert d["mismatch"] is True
    (sel,) = d["selected"]
    assert sel["effect"] == "added_mass" and sel["location"] == {"point": 6}
    assert sel["parameters"]["mass_kg"] == pytest.approx(t.scaled(3.0), rel=0.1)


def test_scaling_of_an_effect_that_vanishes_only_in_a_limit():
    from vlab.diagnose.detectability import Threshold

    joint = Threshold("joint_flexibility", {"point": 7}, "rotational_stiffness_n_m_per_rad", None, 1e5, 0.1, "peak")
    assert joint.scaled(2.0) == pytest.approx(5e4) and joint.scaled(0.5) == pytest.approx(2e5)  # compliance x2
    mass = Threshold("added_mass", {"point": 6}, "mass_kg", 0.0, 1e-3, 15.7, "peak")
    assert mass.scaled(3.0) == pytest.approx(3e-3)
    gain = Threshold("actuator_gain", {"channel": 9}, "gain", 1.0, 0.98, 0.02, "chi2")
    assert gain.scaled(0.5) == pytest.approx(0.99)


def test_cli_refuses_a_negative_noise_and_an_unknown_effect():
    res = runner.invoke(app, ["detectability", "bcc", "--noise", "-1"])
    assert res.exit_code == 2 and "--noise" in res.output
    res = runner.invoke(app, ["detectability", "bcc", "--effect", "tuned_mass"])
    assert res.exit_code == 2 and "--effect tuned_mass" in res.output and "added_mass" in res.output


def test_the_threshold_map_is_drawn_and_bad_values_are_refused(tmp_path):
    from vlab.errors import DataFileError
    from vlab.viz.figures import point_value_map

    spec = load_spec("bcc")
    out = point_value_map(spec, {1: 1e-4, 6: 6e-4}, tmp_path / "map.png", label="mass [kg]")
    assert out.stat().st_size > 1000 and out.read_bytes()[:4] == b"\x89PNG"
    with pytest.raises(DataFileError, match="positive and finite"):
        point_value_map(spec, {1: 0.0}, tmp_path / "bad.png", label="mass [kg]")
    with pytest.raises(DataFileError, match="not points"):
        point_value_map(spec, {99: 1.0}, tmp_path / "bad.png", label="mass [kg]")
    assert not (tmp_path / "bad.png").exists()


@pytest.mark.slow
def test_the_models_own_uncertainty_raises_the_thresholds(mass_threshold):
    """A real recording (model form derived) shows no more than a recording of the model itself."""
    spec, det_own, _t = mass_threshold  # the same effects, model_form="none"
    real = {repr(t.location): t.threshold
            for t in detectability(spec, "none", effects=("added_mass",), model_form="derived").thresholds}
    own = {repr(t.location): t.threshold for t in det_own.thresholds}
    both = [k for k in real if real[k] is not None and own.get(k) is not None]
    assert both and all(real[k] >= own[k] * (1 - 1e-6) for k in both) and any(real[k] > 1.1 * own[k] for k in both)


def test_referral_variance_is_the_term_refer_to_model_adds():
    """The thresholds of a real measurement carry the variance that referring it through the replay plant
    adds (vlab.diagnose.thresholds.referral_variance); checked against what
    vlab.diagnose.data.measured.refer_to_model adds for a recording whose change since the replay is known:
    random FRFs, the model 20 % and 0.3 rad off the replay, an effect of 10 % on top."""
    from vlab.diagnose.data.measured import FrfData, refer_to_model
    from vlab.diagnose.thresholds import referral_variance

    rng = np.random.default_rng(5)
    shape = (40, 3)
    base = (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)) * 1e-3
    model_over_base = np.log(1.2) + 0.3j * rng.uniform(-1, 1, shape)
    h_model = base * np.exp(model_over_base)
    effect = np.exp(0.1 * (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)))
    h_meas = base * effect  # the real structure: the replay plant with the effect (no model-form error of its own)
    freq = np.arange(1, 41, dtype=float)
    tiny = np.full(shape, 1e-30)
    rec = FrfData("rec", "recording", freq, h_meas, tiny, 9, (1, 2, 3))
    ref = FrfData("replay", "recording", freq, base, tiny, 9, (1, 2, 3))
    out = refer_to_model(rec, ref, h_model)
    added = out.var / np.abs(out.h) ** 2
    expected = referral_variance(model_over_base, h_model * effect, h_model, None)
    assert np.allclose(added, expected, rtol=1e-6, atol=1e-20)


def test_a_plants_own_recording_carries_the_referrals_variance_only(mass_threshold):
    """The thresholds of a recording the MuJoCo plant made (model_form="plant") are those of the model's own
    recording with the variance the referral through the plant's replay adds: never below them, above them
    where the plant differs from the model; no profile, so detected by rule 1 alone. An unknown model form is
    refused before anything is recorded."""
    from vlab.errors import ModelError

    spec, det_own, _t = mass_threshold
    det = detectability(spec, "none", effects=("added_mass",), model_form="plant")
    assert det.model_form == "plant" and all(t.by in ("chi2", "peak") for t in det.thresholds if t.threshold)
    plant = {repr(t.location): t.threshold for t in det.thresholds}
    own = {repr(t.location): t.threshold for t in det_own.thresholds}
    both = [k for k in plant if plant[k] is not None and own.get(k) is not None]
    assert both and all(plant[k] >= own[k] * (1 - 1e-6) for k in both) and any(plant[k] > 1.05 * own[k] for k in both)
    with pytest.raises(ModelError, match="model form 'real'"):
        detectability(spec, "none", effects=("added_mass",), model_form="real")
