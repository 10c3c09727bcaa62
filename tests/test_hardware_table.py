"""The ``[hardware]`` table of a structure file: per-channel gains, delays and lags, each applied once.

Checked against independent references: a sensor gain g on the recorded feedback sensor scales the open-loop
FRF (predicted and measured) by exactly g; a coil's gain put into the MuJoCo actuator's gainprm gives the FRF
the FE model predicts with the gain in its input matrix (and an exported MJCF carries it once, not twice); the
entries `vlab update` writes read back as the diagnosis applied them (gains multiply, delays and corners
replace); a concealed chain effect, diagnosed and written back, makes the design on the updated file predict
the experiment again.
"""

from __future__ import annotations

import json
import tomllib
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from vlab.cli import app
from vlab.errors import SpecError
from vlab.fe import build_fe_model
from vlab.spec import load_spec, spec_from_dict, structure_identity

ROOT = Path(__file__).resolve().parent.parent
EXAMPLE = ROOT / "examples" / "cantilever_tip_mass.toml"
runner = CliRunner()


def _file(tmp_path: Path, extra: str, name: str = "hw.toml", text: str | None = None) -> Path:
    p = tmp_path / name
    p.write_text((text or EXAMPLE.read_text(encoding="utf-8")) + "\n" + extra, encoding="utf-8")
    return p


def _gain(setting: str, channel, gain: float) -> str:
    ch = f'"{channel}"' if channel == "all" else str(channel)
    return f'[[hardware.{setting}]]\nchannel = {ch}\ngain = {gain!r}\nsource = "test"\n'


def test_entries_combine_per_channel():
    text = EXAMPLE.read_text(encoding="utf-8") + "\n" + _gain("sensor_gain", "all", 0.9) + _gain(
        "sensor_gain", 4, 1.1) + (
        '[[hardware.loop_delay]]\nchannel = "all"\ndelay = { value = 0.001, unit = "s", source = "t" }\n'
        '[[hardware.loop_delay]]\nchannel = 6\ndelay = { value = 0.0, unit = "s", source = "t" }\n'
        '[[hardware.sensor_lag]]\nchannel = 6\ncorner = { value = 200.0, unit = "Hz", source = "t" }\n')
    hw = spec_from_dict(tomllib.loads(text)).hardware
    assert hw.sensor_gain == pytest.approx({6: 0.9, 4: 0.99})
    assert hw.delay_s == {6: 0.0, 4: 0.001} and hw.sensor_lag_hz == {6: 200.0} and hw.actuator_gain == {}
    assert list(hw.input_gains((6, 4))) == [1.0, 1.0] and list(hw.output_gains((6, 4))) == pytest.approx([0.9, 0.99])


@pytest.mark.parametrize("entry, field, message", [
    (_gain("actuator_gain", 6, -1.0), r"hardware.actuator_gain\[0\].gain", "in \\(0, 100\\]"),
    (_gain("sensor_gain", 6, 0.0), r"hardware.sensor_gain\[0\].gain", "in \\(0, 100\\]"),
    (_gain("sensor_gain", 5, 1.1), r"hardware.sensor_gain\[0\].channel", "5 is not a channel"),
    ('[[hardware.loop_delay]]\nchannel = 6\ndelay = { value = -0.001, unit = "s", source = "t" }\n',
     r"hardware.loop_delay\[0\].delay.value", "must not be negative"),
    ('[[hardware.actuator_lag]]\nchannel = 6\ncorner = { value = 0.0, unit = "Hz", source = "t" }\n',
     r"hardware.actuator_lag\[0\].corner.value", "must be positive"),
    ('[[hardware.sensor_lag]]\nchannel = 6\ncorner = { value = 10.0, unit = "s", source = "t" }\n',
     r"hardware.sensor_lag\[0\].corner.unit", "not a unit of frequency"),
    ('[[hardware.gain]]\nchannel = 6\n', r"hardware.gain", "unknown field"),
])
def test_bad_entries_name_the_file_and_the_field(tmp_path, entry, field, message):
    p = _file(tmp_path, entry)
    with pytest.raises(SpecError, match=f"{p}: field '{field}.*{message}"):
        load_spec(p)


def test_a_bad_entry_exits_2_on_the_command_line(tmp_path):
    p = _file(tmp_path, _gain("sensor_gain", 6, -2.0))
    res = runner.invoke(app, ["experiment", str(p), "--plant", "linear", "--out", str(tmp_path / "e")])
    assert res.exit_code == 2 and "hardware.sensor_gain[0].gain" in res.stderr, res.stderr


def _open_loop(spec, plant: str = "linear", mjcf=None, seed: int = 0):
    from vlab.experiment.config import ExperimentConfig, default_chain
    from vlab.experiment.runner import run_experiment

    cfg = ExperimentConfig(structure=spec.name, controller="none", duration_s=4.0, seed=seed, plant=plant,
                           chain=default_chain("none"), mjcf=mjcf)
    return run_experiment(cfg, build_fe_model(spec))


def test_a_sensor_gain_scales_the_recorded_sensor_s_frf_by_exactly_g(tmp_path):
    text = EXAMPLE.read_text(encoding="utf-8").replace("response_point = 5", "response_point = 4")
    base = load_spec(_file(tmp_path, "", "base.toml", text))
    gained = load_spec(_file(tmp_path, _gain("sensor_gain", 4, 0.8), "gained.toml", text))
    r0, r1 = _open_loop(base), _open_loop(gained)
    np.testing.assert_allclose(r1.analysis_sampled, 0.8 * r0.analysis_sampled, rtol=1e-12)
    np.testing.assert_allclose(r1.measured, 0.8 * r0.measured, rtol=1e-9)
    # the sensor gain is in the loop's chain: point 5 (no feedback sensor) is not scaled
    np.testing.assert_allclose(r1.frfs["vel5"].h, r0.frfs["vel5"].h, rtol=1e-9)


def _peak(result) -> float:
    return float(np.max(np.abs(result.measured)))


def test_a_coil_gain_in_gainprm_gives_the_frf_of_the_gain_in_the_input_matrix(tmp_path):
    from vlab.sim import build_plant, export_mjcf

    base = load_spec(EXAMPLE)
    path = _file(tmp_path, _gain("actuator_gain", 6, 1.3))  # the excitation coil
    gained = load_spec(path)
    plant = build_plant(gained)
    i = plant.model.actuator("coil6").id
    assert plant.model.actuator_gainprm[i, 0] == 1.3 and plant.model.actuator_gainprm[
        plant.model.actuator("coil4").id, 0] == 1.0
    xml = export_mjcf(plant, tmp_path / "gained.xml")
    # the FE model with the gain in U: its prediction is the base one times 1.3, exactly (open loop)
    r_base, r_gain = _open_loop(base, "mujoco"), _open_loop(gained, "mujoco")
    np.testing.assert_allclose(r_gain.analysis_sampled, 1.3 * r_base.analysis_sampled, rtol=1e-12)
    # MuJoCo with the gain in gainprm measures what the FE model with the gain in U predicts
    assert _peak(r_gain) / _peak(r_base) == pytest.approx(1.3, rel=1e-3)
    assert r_gain.avg_peak_error == pytest.approx(r_base.avg_peak_error, abs=5e-3)
    # an exported MJCF carries the gain once: run with the file that states it, it is not applied twice
    r_mjcf = _open_loop(gained, "mujoco", mjcf=xml)
    assert _peak(r_mjcf) / _peak(r_base) == pytest.approx(1.3, rel=1e-3)
    assert r_mjcf.avg_peak_error == pytest.approx(r_base.avg_peak_error, abs=5e-3)


def test_the_linear_plant_carries_the_coil_gain():
    from dataclasses import replace

    base = load_spec(EXAMPLE)
    gained = spec_from_dict(tomllib.loads(EXAMPLE.read_text(encoding="utf-8") + "\n" + _gain(
        "actuator_gain", "all", 0.75)), path=EXAMPLE)
    r0, r1 = _open_loop(base), _open_loop(replace(gained, name=base.name))
    np.testing.assert_allclose(r1.measured, 0.75 * r0.measured, rtol=1e-9)
    np.testing.assert_allclose(r1.analysis_sampled, 0.75 * r0.analysis_sampled, rtol=1e-12)


def _diagnosis(tmp_path: Path, spec, selected) -> Path:
    d = {"structure": spec.name, "structure_sha256": structure_identity(spec), "mismatch": True,
         "outside_library": False, "too_small_to_name": False, "controller": "mfdrf",
         "data": {"source": "/somewhere/hidden.uff"}, "selected": selected}
    folder = tmp_path / "diag"
    folder.mkdir(exist_ok=True)
    (folder / "diagnosis.json").write_text(json.dumps(d))
    return folder


def _sel(effect, channel, name, value, lo, hi):
    return {"effect": effect, "location": {"channel": channel}, "parameters": {name: value},
            "ci95": {name: [lo, hi]}}


def test_update_writes_the_chain_effects_as_hardware_entries(tmp_path):
    from vlab.model_update import update

    first = load_spec(_file(tmp_path, _gain("sensor_gain", 4, 0.9)))
    sel = [_sel("sensor_gain", 4, "gain", 0.8, 0.79, 0.81), _sel("actuator_gain", 6, "gain", 1.25, 1.2, 1.3),
           _sel("loop_delay", "all", "delay_s", 0.0015, 0.0014, 0.0016),
           _sel("actuator_lag", 6, "corner_hz", 150.0, 140.0, 160.0),
           _sel("sensor_lag", 4, "corner_hz", 90.0, 80.0, 100.0)]
    out = tmp_path / "updated.toml"
    res = update(first, _diagnosis(tmp_path, first, sel), out=out)
    text = out.read_text(encoding="utf-8")
    assert 'source = "vlab diagnose somewhere/hidden.uff: fitted, 95 % interval [0.79, 0.81]"' in text
    assert 'delay = { value = 0.0015, unit = "s", source = "vlab diagnose somewhere/hidden.uff: fitted, 95 % ' \
           'interval [0.0014, 0.0016] s" }' in text
    hw = load_spec(out).hardware
    assert hw.sensor_gain == pytest.approx({4: 0.9 * 0.8})  # the fitted gain multiplies the file's own
    assert hw.actuator_gain == {6: 1.25} and hw.delay_s == {6: 0.0015, 4: 0.0015}
    assert hw.actuator_lag_hz == {6: 150.0} and hw.sensor_lag_hz == {4: 90.0}
    assert [e["table"] for e in res.entries] == ["hardware." + e["effect"] for e in sel]


def test_update_refuses_an_amplifier_saturation(tmp_path):
    cant = load_spec(EXAMPLE)
    folder = _diagnosis(tmp_path, cant, [_sel("saturation", 6, "limit_n", 0.5, 0.4, 0.6)])
    res = runner.invoke(app, ["update", str(EXAMPLE), "--diagnosis", str(folder), "--out", str(tmp_path / "u.toml")])
    assert res.exit_code == 2 and "saturation (channel 6) cannot be written into a structure file" in res.stderr
    assert not (tmp_path / "u.toml").exists()


def test_file_settings_fill_the_chain_and_explicit_entries_win():
    from vlab.experiment.config import default_chain, with_hardware

    spec = spec_from_dict(tomllib.loads(EXAMPLE.read_text(encoding="utf-8") + "\n" + _gain(
        "sensor_gain", "all", 0.9) + '[[hardware.loop_delay]]\nchannel = 4\n'
        'delay = { value = 0.001, unit = "s", source = "t" }\n'))
    chain = with_hardware(default_chain("mfdrf", sensor_gain={6: 1.2}), spec)
    assert chain.sensor_gain == {6: 1.2, 4: 0.9} and chain.delay_of(4) == pytest.approx(2.0)
    assert chain.delay_of(6) == pytest.approx(1.35) and with_hardware(chain, spec) == chain


@pytest.mark.slow
def test_a_concealed_sensor_gain_is_written_back_and_the_redesign_predicts_the_lab(tmp_path):
    import vlab
    from vlab.design import design_controller
    from vlab.experiment.config import ExperimentConfig, default_chain
    from vlab.experiment.runner import make_plant, measure
    from vlab.io.uff import write_recording
    from vlab.model_update import verify
    from vlab.sim import build_plant, export_mjcf

    nominal = load_spec(EXAMPLE)
    lab = default_chain("mfdrf", noise_m_s=1e-6, sensor_gain={4: 0.7})  # hidden from the model
    cfg = ExperimentConfig(structure=nominal.name, controller="mfdrf", duration_s=4.0, chain=lab)
    fe = build_fe_model(nominal)
    m = measure(cfg, fe, design_controller(fe, "mfdrf"), plant=make_plant(cfg, fe, (6, 4)))
    write_recording(tmp_path / "hidden.uff", m.loop.recording, overwrite=False)
    d = vlab.diagnose(nominal, tmp_path / "hidden.uff", out_dir=tmp_path / "diag").as_dict()
    assert [(e["effect"], e["location"]) for e in d["selected"]] == [("sensor_gain", {"channel": 4})]
    upd = vlab.update(nominal, tmp_path / "diag", out=tmp_path / "updated.toml")
    assert upd.spec.hardware.sensor_gain[4] == pytest.approx(0.7, rel=0.01)
    v = verify(nominal, upd.path, export_mjcf(build_plant(nominal), tmp_path / "plant.xml"), duration_s=4.0,
               lab_chain=lab)
    e0, e1 = v["original"]["average_peak_level_error"], v["updated"]["average_peak_level_error"]
    assert e1 <= 0.5 * e0 and e1 <= 0.03 < 0.06 < e0, (e0, e1)
    assert v["updated"]["damping_ratio_largest_relative_difference"] <= 0.1
    assert v["original"]["not_meaningful"] == v["updated"]["not_meaningful"] == []  # both loops stable


def test_an_explicit_delay_option_replaces_the_file_s_delays(tmp_path):
    from vlab.cli.experiment import ExpController, Excitation, PlantKind, _config
    from vlab.experiment.config import with_hardware

    spec = load_spec(_file(tmp_path, '[[hardware.loop_delay]]\nchannel = 4\n'
                                     'delay = { value = 0.002, unit = "s", source = "t" }\n'))
    kw = dict(controller=ExpController.mfdrf, reduction=None, excitation=Excitation.random, duration=None,
              period_ms=None, noise=0.0, seed=0, mjcf=None, plant=PlantKind.linear, spawn=False)
    default = _config(spec, delay_periods=1.35, **kw)
    given = _config(spec, delay_periods=2.5, file_delays=(4,), **kw)
    assert with_hardware(default.chain, spec).delay_of(4) == pytest.approx(4.0)
    assert with_hardware(given.chain, spec).delay_of(4) == 2.5 and with_hardware(given.chain, spec).delay_of(6) == 2.5
