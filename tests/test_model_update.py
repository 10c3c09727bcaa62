"""`vlab update`: the structure file with what a diagnosis found, and the design on it run on the changed plant.

Checked against independent references: the change tables of a structure file (vlab.spec.changes) against
the diagnosis's own edits of a spec (vlab.diagnose.effects.specedit, a separate implementation) by the FE
natural frequencies; the written file keeps the original text byte for byte; a concealed added mass of known
size (0.04 kg) comes back in the written file; the design on the updated file predicts the experiment on
the changed plant better than the design on the original.
"""

from __future__ import annotations

import json
import tomllib
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from vlab.cli import app
from vlab.diagnose.effects import specedit
from vlab.errors import DataFileError, OutputError, SpecError
from vlab.fe import build_fe_model
from vlab.fe.modal import modal_analysis
from vlab.model_update import update
from vlab.spec import load_spec, spec_from_dict, structure_identity

ROOT = Path(__file__).resolve().parent.parent
EXAMPLE = ROOT / "examples" / "cantilever_tip_mass.toml"
FRAME = ROOT / "assets" / "templates" / "frame.toml"
runner = CliRunner()


def _freqs(spec, n=6):
    fe = build_fe_model(spec)
    return np.asarray(modal_analysis(fe.m, fe.k, n_modes=n).frequencies_hz)


def _with_text(path: Path, extra: str):
    text = path.read_text(encoding="utf-8") + "\n" + extra
    return spec_from_dict(tomllib.loads(text), path=path)


def test_change_tables_give_the_frequencies_of_the_diagnosis_edits():
    frame = load_spec(FRAME)
    mem = frame.members[0]
    seg = (mem.points[2], mem.points[3])
    ei0 = frame.sections[mem.section].ei.si
    src = 'source = "test"'
    got = _with_text(FRAME, f'[[member_stiffness]]\nmember = "{mem.id}"\nsegment = [{seg[0]}, {seg[1]}]\n'
                            f'ei = {{ value = {0.7 * ei0!r}, unit = "N*m^2", {src} }}\n'
                            f'[[joint_flexibility]]\npoint = {mem.points[4]}\n'
                            f'rotational_stiffness = {{ value = 150.0, unit = "N*m/rad", {src} }}\n')
    want = specedit.soften_joint(specedit.scale_segments(frame, {seg: 0.7}), mem.points[4], 150.0)
    assert _freqs(got) == pytest.approx(_freqs(want), rel=1e-9)
    assert not _freqs(got) == pytest.approx(_freqs(frame), rel=1e-3)  # the change is seen at all
    # a whole member, and the damping ratio of one mode beyond the listed ones
    cant = load_spec(EXAMPLE)
    ei1 = cant.sections["steel_strip"].ei.si
    got = _with_text(EXAMPLE, f'[[member_stiffness]]\nmember = "strip"\nei = {{ value = {1.3 * ei1!r}, '
                              f'unit = "N*m^2", {src} }}\n[[mode_damping]]\nmode = 5\nratio = 0.02\n{src}\n')
    assert [m.id for m in got.members] == ["strip"]
    assert _freqs(got) == pytest.approx(_freqs(specedit.scale_member(cant, "strip", 1.3)), rel=1e-9)
    assert got.damping.modal_ratios == (0.01, 0.01, 0.01, 0.01, 0.02)


def test_a_spring_replacing_a_support_releases_it():
    cant = load_spec(EXAMPLE)
    got = _with_text(EXAMPLE, '[[springs]]\nid = "clamp_rx"\npoint = 1\ndof = "rx"\nreplaces_support = true\n'
                              'stiffness = { value = 400.0, unit = "N*m/rad", source = "test" }\n')
    assert got.supports[0].fixed == ("w",)
    assert _freqs(got) == pytest.approx(_freqs(specedit.add_spring(cant, 1, "rx", 400.0)), rel=1e-9)
    # an added element keeps the damping matrix of the structure without it, as the diagnosis models it
    from vlab.fe.damping import structural_damping

    text = '[[springs]]\nid = "wire"\npoint = 5\ndof = "w"\nadded = true\n' \
           'stiffness = { value = 300.0, unit = "N/m", source = "test" }\n'
    got, plain = _with_text(EXAMPLE, text), _with_text(EXAMPLE, text.replace("added = true\n", ""))
    want = specedit.add_spring(cant, 5, "w", 300.0)
    c_got, c_want = structural_damping(build_fe_model(got)), structural_damping(build_fe_model(want))
    assert np.allclose(c_got, c_want, rtol=1e-9, atol=1e-12 * np.abs(c_want).max())
    assert not np.allclose(structural_damping(build_fe_model(plain)), c_want, rtol=1e-3)
    with pytest.raises(SpecError, match=r"springs\[0\].replaces_support.*no support fixes DOF 'rx' at point 3"):
        _with_text(EXAMPLE, '[[springs]]\nid = "s"\npoint = 3\ndof = "rx"\nreplaces_support = true\n'
                            'stiffness = { value = 400.0, unit = "N*m/rad", source = "test" }\n')
    with pytest.raises(SpecError, match=r"member_stiffness\[0\].segment"):
        _with_text(EXAMPLE, '[[member_stiffness]]\nmember = "strip"\nsegment = [1, 3]\n'
                            'ei = { value = 1.0, unit = "N*m^2", source = "test" }\n')


def _diagnosis(tmp_path: Path, spec, selected, **extra) -> Path:
    d = {"structure": spec.name, "structure_sha256": structure_identity(spec), "mismatch": True,
         "outside_library": False, "too_small_to_name": False, "controller": "mfdrf",
         "data": {"source": "/somewhere/hidden.uff"}, "selected": selected, **extra}
    folder = tmp_path / "diag"
    folder.mkdir(exist_ok=True)
    (folder / "diagnosis.json").write_text(json.dumps(d))
    return folder


def _sel(effect, location, name, value, lo, hi):
    return {"effect": effect, "location": location, "parameters": {name: value}, "ci95": {name: [lo, hi]}}


def test_update_appends_commented_entries_and_keeps_the_original_text(tmp_path):
    cant = load_spec(EXAMPLE)
    sel = [_sel("added_mass", {"points": [6, 4]}, "mass_kg", 0.012345678, 0.011, 0.013),
           _sel("damping", {"mode": 2}, "damping_ratio", 0.0137, 0.012, 0.015)]
    out = tmp_path / "updated.toml"
    res = update(EXAMPLE, _diagnosis(tmp_path, cant, sel), out=out)
    text = out.read_text(encoding="utf-8")
    assert text.startswith(EXAMPLE.read_text(encoding="utf-8").rstrip("\n"))
    assert 'source = "vlab diagnose somewhere/hidden.uff: fitted, 95 % interval [0.011, 0.013] kg"' in text
    back = load_spec(out)
    added = [m for m in back.masses if m.id.startswith("added_mass")]
    assert sorted(m.point for m in added) == [4, 6] and all(m.mass.si == pytest.approx(0.012345678) for m in added)
    assert back.damping.modal_ratios[1] == pytest.approx(0.0137)
    want = specedit.add_mass(specedit.add_mass(cant, 6, 0.012345678), 4, 0.012345678)
    assert _freqs(back) == pytest.approx(_freqs(want), rel=1e-6)
    assert [e["table"] for e in res.entries] == ["masses", "masses", "mode_damping"]
    with pytest.raises(OutputError, match="exists"):
        update(EXAMPLE, tmp_path / "diag", out=out)


def test_the_look_alikes_of_the_selection_are_named_in_the_written_file(tmp_path):
    cant = load_spec(EXAMPLE)
    sel = [_sel("added_mass", {"point": 6}, "mass_kg", 0.012, 0.011, 0.013)]
    looks = ["added_mass(point=5)", "member_stiffness(member=beam, segment=[5, 6])"]
    out = tmp_path / "updated.toml"
    update(EXAMPLE, _diagnosis(tmp_path, cant, sel, alternatives=looks), out=out)
    text = out.read_text(encoding="utf-8")
    assert ("# The data could not tell it from: added_mass(point=5); member_stiffness(member=beam, segment=[5, 6])"
            in text)
    out2 = tmp_path / "alone.toml"
    update(EXAMPLE, _diagnosis(tmp_path, cant, sel), out=out2)
    assert "could not tell" not in out2.read_text(encoding="utf-8")


@pytest.mark.parametrize("change, message", [
    ({"selected": []}, "nothing selected .no mismatch was found"),
    ({"outside_library": True}, "outside vlab's library"),
    ({"structure_sha256": "0" * 64}, "made for another structure"),
])
def test_update_refuses_a_diagnosis_it_cannot_apply(tmp_path, change, message):
    cant = load_spec(EXAMPLE)
    sel = [_sel("added_mass", {"point": 3}, "mass_kg", 0.04, 0.039, 0.041)]
    extra = {k: v for k, v in change.items() if k != "selected"}
    folder = _diagnosis(tmp_path, cant, change.get("selected", sel), **extra)
    if change.get("selected") == []:
        d = json.loads((folder / "diagnosis.json").read_text())
        d["mismatch"] = False
        (folder / "diagnosis.json").write_text(json.dumps(d))
    with pytest.raises(DataFileError, match=message):
        update(EXAMPLE, folder, out=tmp_path / "u.toml")
    assert not (tmp_path / "u.toml").exists()


@pytest.mark.slow
def test_concealed_mass_is_written_back_and_the_redesign_predicts_the_changed_plant(tmp_path):
    from vlab.design import design_controller
    from vlab.io.uff import write_recording
    from vlab.experiment.config import ExperimentConfig
    from vlab.experiment.runner import make_plant, measure
    from vlab.sim import build_plant, export_mjcf
    from vlab.spec import LumpedMass, Quantity

    nominal = load_spec(EXAMPLE)
    hidden = nominal.replace(masses=nominal.masses + (LumpedMass("concealed", 3, Quantity(0.04, "hidden")),),
                             damping=replace(nominal.damping, basis=nominal))
    cfg = ExperimentConfig(structure=nominal.name, controller="mfdrf", duration_s=4.0)
    fe_nom = build_fe_model(nominal)
    plant = make_plant(cfg, build_fe_model(hidden), tuple(nominal.instrumentation.actuators))
    m = measure(cfg, fe_nom, design_controller(fe_nom, "mfdrf"), plant=plant)
    write_recording(tmp_path / "hidden.uff", m.loop.recording, overwrite=False)
    res = runner.invoke(app, ["diagnose", "--structure", str(EXAMPLE), "--recording", str(tmp_path / "hidden.uff"),
                              "--controller", "mfdrf", "--out", str(tmp_path / "diag"), "--format", "json"])
    assert res.exit_code == 0, res.stderr
    export_mjcf(build_plant(hidden), tmp_path / "hidden.xml")
    out = tmp_path / "updated.toml"
    res = runner.invoke(app, ["update", str(EXAMPLE), "--diagnosis", str(tmp_path / "diag"), "--out", str(out),
                              "--verify", "--mjcf", str(tmp_path / "hidden.xml"), "--duration", "4",
                              "--format", "json"])
    assert res.exit_code == 0, res.stderr
    d = json.loads(res.stdout)
    added = [x for x in load_spec(out).masses if x.id.startswith("added_mass")]
    assert [x.point for x in added] == [3] and added[0].mass.si == pytest.approx(0.04, rel=0.01)
    v = d["verify"]
    e0, e1 = v["original"]["average_peak_level_error"], v["updated"]["average_peak_level_error"]
    assert e1 <= 0.5 * e0, (e0, e1)
    for mode in v["updated"]["modes"]:
        assert mode["damping_ratio_measured"] == pytest.approx(mode["damping_ratio_predicted"], rel=0.1)
    assert v["updated"]["damping_ratio_largest_relative_difference"] == pytest.approx(max(
        abs(m["damping_ratio_measured"] / m["damping_ratio_predicted"] - 1) for m in v["updated"]["modes"]))
    # the updated file was made for another structure than the original: a second update is refused
    with pytest.raises(DataFileError, match="another structure"):
        update(out, tmp_path / "diag")


def test_experiment_refuses_a_plant_without_the_structure_s_coils(tmp_path):
    from vlab.sim import build_plant, export_mjcf

    export_mjcf(build_plant(load_spec(EXAMPLE)), tmp_path / "plant.xml")
    text = EXAMPLE.read_text(encoding="utf-8").replace("actuators = [6, 4]", "actuators = [6, 5]")
    other = tmp_path / "other.toml"
    other.write_text(text, encoding="utf-8")
    res = runner.invoke(app, ["experiment", str(other), "--mjcf", str(tmp_path / "plant.xml"), "--duration", "4",
                              "--out", str(tmp_path / "exp")])
    assert res.exit_code == 2 and "coil5" in res.stderr and "missing" in res.stderr, res.stderr


@pytest.mark.parametrize("kind", ["beam", "frame"])
def test_the_template_s_commented_change_entries_load_when_uncommented(kind):
    from vlab.templates import template_text

    text = template_text(kind)
    head, block = text.split("# ---- changes found by a diagnosis")
    lines = [ln[2:].split("  #")[0] for ln in block.splitlines() if ln.startswith("# ")]
    lines = [ln for ln in lines if (ln.startswith("[[") or " = " in ln)
             and not ln.startswith(("added", "replaces_support"))]
    spec = spec_from_dict(tomllib.loads(head + "\n".join(lines).replace('"..."', '"test"')))
    base = spec_from_dict(tomllib.loads(text))
    assert spec.damping.modal_ratios[1] == 0.012 and len(spec.members) > len(base.members)
    assert not _freqs(spec) == pytest.approx(_freqs(base), rel=1e-3)
