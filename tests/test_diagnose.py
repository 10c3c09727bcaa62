"""Mismatch diagnosis (vlab.diagnose) end to end on the linear BCC lab: concealed effects are found and sized,
a clean recording gives no mismatch. Fast: 5 s excitation periods, three periods per recording."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from vlab.diagnose import EFFECTS, diagnose
from vlab.diagnose.effects import specedit
from vlab.diagnose.model.labmodel import LabState
from vlab.diagnose.model.nominal import nominal_design
from vlab.experiment.config import default_chain
from vlab.lab.loop import HardwareChain
from vlab.models import nominal_fe_model

from vlab.diagnose.report.verdict import verdict

from _recordings import record_linear as _record
from _verdict_numbers import unexplained_numbers


@pytest.fixture(scope="module")
def nominal():
    fe = nominal_fe_model("bcc")
    return LabState(fe.spec, fe, HardwareChain(noise_m_s=1e-6), nominal_design(fe, "mfdrf", 0))


@pytest.fixture(scope="module")
def mass_run(nominal, tmp_path_factory):
    d = tmp_path_factory.mktemp("mass")
    truth = nominal.with_spec(specedit.add_mass(nominal.spec, 6, 0.12))
    path = _record(truth, d / "rec.uff")
    return diagnose("bcc", path, controller="mfdrf", out_dir=d / "out", plant="linear")


def test_concealed_added_mass_is_located_and_sized(mass_run):
    r = mass_run
    assert r.mismatch
    assert r.selected is not None and r.selected.effect == "added_mass"
    assert r.selected.location == {"point": 6}
    assert r.selected.params_[0] == pytest.approx(0.12, rel=0.15)
    lo, hi = r.selected.ci95_[0]
    assert lo < r.selected.params_[0] < hi
    assert 6 in r.location.points
    assert r.loop == "both"


def test_validation_rerun_lowers_both_misfits(mass_run):
    v = mass_run.validation
    assert v is not None and "linear" in v.plant
    assert v.misfit_after < v.misfit_before / 5
    assert v.time_error_after < v.time_error_before / 5


def test_mujoco_validation_of_a_dashpot_raises_a_model_error(mass_run):
    """A point dashpot cannot be expressed in the spec the MuJoCo plant is built from: a clear ModelError
    (the pipeline turns it into a note), not a failure of the rerun cache."""
    from vlab.diagnose.validate import validate
    from vlab.errors import ModelError

    modified = replace(mass_run.nominal, dashpots=((6, 1.0),))
    with pytest.raises(ModelError, match="dashpots"):
        validate(mass_run.problem, mass_run.nominal, modified, plant="mujoco", key="dashpot at 6")


def test_json_and_report(mass_run):
    d = mass_run.as_dict()
    for key in ("mismatch", "located", "ranked", "selected", "validated"):
        assert key in d
    for key in ("modes", "points", "members", "band_hz", "loop"):
        assert key in d["located"]
    top = d["ranked"][0]
    for key in ("effect", "location", "parameters", "ci95", "score", "misfit_before", "misfit_after"):
        assert key in top
    assert top["effect"] in EFFECTS
    assert d["validated"]["misfit_after"] < d["validated"]["misfit_before"]
    json.dumps(d)  # serialisable as it stands
    text = verdict(json.loads(json.dumps(d)))  # the verdict of the JSON as written
    assert "Selected: added_mass at point 6" in text and unexplained_numbers(text, d) == [], text
    files = mass_run.files
    assert files["report"].read_text().startswith("# vlab diagnosis")
    assert json.loads(files["json"].read_text())["selected"][0]["effect"] == "added_mass"
    assert any(str(p).endswith(".png") and p.stat().st_size > 5000 for p in files.values())


def test_concealed_loop_delay_is_found(nominal, tmp_path):
    truth = replace(nominal, chain=replace(nominal.chain, delay_periods=4.0))
    path = _record(truth, tmp_path / "rec.uff")
    r = diagnose("bcc", path, controller="mfdrf", validate_run=False)
    assert r.mismatch and r.selected is not None
    assert r.selected.effect == "loop_delay"
    assert r.selected.params_[0] == pytest.approx(4.0 * nominal.chain.period_s, rel=0.15)
    assert r.loop == "closed"


@pytest.mark.slow
def test_concealed_saturation_is_found(nominal, tmp_path):
    """A clipping amplifier: its describing function looks like a lower gain; the selection (and, when a gain
    is within reach, the look-alike rerun of vlab.diagnose.fit.selection) must name the saturation."""
    truth = replace(nominal, chain=replace(nominal.chain, amplifier_limit_n=0.75))
    path = _record(truth, tmp_path / "rec.uff")
    r = diagnose("bcc", path, controller="mfdrf", plant="linear")
    assert r.mismatch and r.selected is not None
    assert r.selected.effect == "saturation"
    assert r.selected.params_[0] == pytest.approx(0.75, rel=0.15)
    assert r.validation is not None and r.validation.time_error_after < r.validation.time_error_before / 2


def test_clean_recording_has_no_mismatch(nominal, tmp_path):
    path = _record(nominal, tmp_path / "rec.uff", seed=5)
    r = diagnose("bcc", path, controller="mfdrf")
    d = r.as_dict()
    assert d["mismatch"] is False
    assert d["selected"] == [] and d["ranked"] == []
    assert d["located"]["points"] == [] and d["located"]["loop"] is None


def test_modal_table_with_concealed_mass(tmp_path):
    from vlab.fe.damping import open_loop_ratios
    from vlab.fe import modal_analysis

    fe = nominal_fe_model("bcc")
    m = fe.m.copy()  # the truth: 0.3 kg lumped on w at point 3, added to the FE matrix directly
    m[fe.dofs.index(3, "w"), fe.dofs.index(3, "w")] += 0.3
    f = modal_analysis(m, fe.k, 6).frequencies_hz
    z = open_loop_ratios(fe.spec, fe.n)[:6]
    csv = tmp_path / "modes.csv"
    csv.write_text("# synthetic\nmode,frequency_hz,damping_ratio\n"
                   + "".join(f"{i + 1},{fi:.6f},{zi}\n" for i, (fi, zi) in enumerate(zip(f, z))))
    r = diagnose("bcc", csv)
    assert r.mismatch and r.selected.effect == "added_mass" and r.selected.location == {"point": 3}
    assert r.selected.params_[0] == pytest.approx(0.3, rel=0.15)
    assert r.loop == "open"


@pytest.mark.parametrize("controller", ["none", "mfdrf"])
def test_predicted_frf_equals_the_sampled_data_analysis(controller):
    """The diagnosis's lab model against vlab.analysis (velocity FRF, Eq. 5.1 controller, closed loop).

    The excitation's hold is divided out; the loop applies the RC filter's exact average over each physics
    step, so the lab model and the analysis have the same chain (an independent composition of it)."""
    from vlab.analysis import closed_loop_frf, sampled_data_controller_frf, velocity_frf
    from vlab.fe.damping import modal_damping_matrix, open_loop_ratios
    from vlab.diagnose.model.labmodel import predict_frf, zoh

    fe = nominal_fe_model("bcc")
    chain = default_chain(controller)  # the thesis period of the controller (LQG 1 ms)
    acts = tuple(fe.spec.instrumentation.actuators)
    f = np.linspace(0.5, 25.0, 200)
    c = modal_damping_matrix(fe.m, fe.k, open_loop_ratios(fe.spec, fe.n))
    g = velocity_frf(fe.m, c, fe.k, fe.force_input(acts), fe.force_input(acts + (6,)).T, f)
    g_fb, g_out = g[:, :3, :], g[:, 3:, :]
    d = nominal_design(fe, controller, 0)
    st = LabState(fe.spec, fe, chain, d)
    h = predict_frf(st, f, excitation_point=9, output_points=(6,))[:, 0] / zoh(f, chain.period_s)
    if d is None:
        ref = g_out[:, 0, acts.index(9)]
    else:
        k = sampled_data_controller_frf(f, d.f11, d.f12, d.f21, d.f22, chain.period_s,
                                        delay_periods=chain.delay_periods,
                                        filter_hz=chain.filter_hz)
        ref = closed_loop_frf(g_fb, g_out, k, acts.index(9))[:, 0]
    np.testing.assert_allclose(h, ref, rtol=1e-8)


@pytest.mark.slow
def test_cli_prints_the_selection_and_the_noise_floor(nominal, tmp_path, monkeypatch):
    """``vlab diagnose`` on a recording: the ranked table, the selected effect, the validation misfits and
    the misfit the noise alone leaves; the report is written to --out, its FRF overlays on a logarithmic
    frequency axis with --log-freq."""
    from typer.testing import CliRunner

    from vlab.cli import app
    from vlab.viz import figures

    saved = []
    orig = figures._save
    monkeypatch.setattr(figures, "_save", lambda fig, path, dpi: (saved.append((path, fig)), orig(fig, path, dpi))[1])
    truth = nominal.with_spec(specedit.add_mass(nominal.spec, 6, 0.12))
    path = _record(truth, tmp_path / "rec.uff")
    res = CliRunner().invoke(app, ["diagnose", "--structure", "bcc", "--recording", path, "--controller", "mfdrf",
                                   "--plant", "linear", "--out", str(tmp_path / "out"), "--log-freq"])
    assert res.exit_code == 0, res.output
    out = " ".join(res.output.split())  # rich wraps long lines
    assert "Selected: added_mass at point 6 (mass 0.12" in out and "the measured noise alone leaves" in out
    assert (tmp_path / "out" / "diagnosis.md").is_file()
    overlays = [fig for p, fig in saved if "overlay_" in str(p)]
    assert overlays and all(ax.get_xscale() == "log" for fig in overlays for ax in fig.axes)


def test_background_rerun_equals_the_foreground_one(mass_run, monkeypatch):
    """The nominal rerun started in a background process (while the hypotheses are fitted) is picked up by
    the validation (no rerun in this process) and equals the rerun made here, sample for sample."""
    from vlab.diagnose.data import rerun_jobs as vmod

    p = mass_run.problem
    assert vmod.start_background_rerun(p, mass_run.nominal, "background", "linear")
    with monkeypatch.context() as mp:
        mp.setattr(vmod, "rerun", lambda *a, **k: pytest.fail("reran in the foreground"))
        bg = vmod.reruns(p, [(mass_run.nominal, "background")], "linear")[0]
    fg = vmod.reruns(p, [(mass_run.nominal, None)], "linear", workers=1)[0]
    assert not p.run.background  # collected into the run context's cache
    for q in p.data.output_points:
        np.testing.assert_array_equal(np.asarray(bg[f"vel{q}"]), np.asarray(fg[f"vel{q}"]))


def test_reruns_are_cached_per_seed(mass_run, monkeypatch):
    """A rerun is cached under its key, plant and sensor-noise seed: another seed is rerun, not looked up."""
    from vlab.diagnose.data import rerun_jobs as vmod

    calls = []

    def fake_rerun(state, force, *, seed=0, **_kw):
        calls.append(seed)
        return f"run with seed {seed}", "linear FE plant"

    monkeypatch.setattr(vmod, "rerun", fake_rerun)
    p = mass_run.problem
    first = [vmod.reruns(p, [(mass_run.nominal, "seeded")], "linear", seed=s, workers=1)[0] for s in (0, 0, 1)]
    assert calls == [0, 1] and first == ["run with seed 0", "run with seed 0", "run with seed 1"]


def test_open_loop_sensor_gain_is_found_on_the_recorded_sensor_channel(tmp_path):
    """Open loop, the recorded channel of a feedback sensor is that sensor's signal: a
    sensor reading 1.4x at point 7 scales only vel7. Before sensor_gain was tried open loop, no library
    effect could explain it."""
    fe = nominal_fe_model("bcc")
    open_lab = LabState(fe.spec, fe, HardwareChain(noise_m_s=1e-6), None)
    truth = replace(open_lab, chain=replace(open_lab.chain, sensor_gain={7: 1.4}))
    path = _record(truth, tmp_path / "rec.uff", steady=True)
    r = diagnose("bcc", path, controller="none", validate_run=False)
    assert r.mismatch and r.selected is not None
    assert r.selected.effect == "sensor_gain" and r.selected.location == {"channel": 7}
    assert r.selected.params_[0] == pytest.approx(1.4, rel=0.05)
