"""A recording without vlab's sidecar, diagnosed with the setup of its test (``test.toml``).

The sidecar of a vlab recording is one such setup: ``vlab init test --from`` writes the ``test.toml`` of a
recording's sidecar, and the bare recording (no sidecar) diagnosed with it gives the diagnosis of the recording
with its sidecar, number for number. An acquisition system's numbering (nodes 101..) mapped by the setup's
``[nodes]`` and a second force channel left out by its ``[excitation] point`` give it too. Each wrong field is
refused naming the file and the field.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from vlab.cli import app
from vlab.diagnose import diagnose
from vlab.diagnose.effects import specedit
from vlab.diagnose.model.labmodel import LabState
from vlab.diagnose.model.nominal import nominal_design
from vlab.errors import DataFileError, MeasurementError, OptionError, SpecError
from vlab.io.recording import Channel, Recording
from vlab.io.setup_file import PLANT_LABELS, apply_setup, read_setup
from vlab.io.uff import read_recording, write_recording
from vlab.lab.loop import HardwareChain
from vlab.models import nominal_fe_model

from _recordings import RES_HZ, record_linear


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    """0.12 kg at point 6 under MFDRF, recorded on the linear lab with its sidecar."""
    fe = nominal_fe_model("bcc")
    nominal = LabState(fe.spec, fe, HardwareChain(noise_m_s=1e-6), nominal_design(fe, "mfdrf", 0))
    truth = nominal.with_spec(specedit.add_mass(nominal.spec, 6, 0.12))
    return Path(record_linear(truth, tmp_path_factory.mktemp("rec") / "rec.uff"))


def _verdict(res) -> tuple:
    d = res.as_dict()
    (sel,) = d["selected"]
    return (d["mismatch"], sel["effect"], tuple(sorted(sel["location"].items())),
            round(d["statistics"]["chi2_nominal"], 6), tuple(round(v, 9) for v in sel["parameters"].values()))


def _bare(recording: Path, folder: Path) -> Path:
    """The recording without its sidecar."""
    folder.mkdir()
    shutil.copy(recording, folder / recording.name)
    return folder / recording.name


def test_init_test_writes_the_sidecars_fields_and_reads_back(recording, tmp_path):
    res = CliRunner().invoke(app, ["init", "test", str(tmp_path / "t.toml"), "--from", str(recording)])
    assert res.exit_code == 0, res.output
    s = read_setup(tmp_path / "t.toml")
    assert s.structure == "bcc" and s.excitation_point == 9
    assert s.metadata == {"controller": "mfdrf", "seed": 0, "plant": PLANT_LABELS["linear"], "resolution_hz": RES_HZ}
    blank = CliRunner().invoke(app, ["init", "test", str(tmp_path / "blank.toml"), "--structure", "grid"])
    assert blank.exit_code == 0, blank.output
    g = read_setup(tmp_path / "blank.toml")
    assert g.structure == "grid" and g.metadata == {"controller": "none"} and g.nodes == {}


@pytest.mark.slow
def test_a_bare_recording_with_its_test_setup_diagnoses_as_with_its_sidecar(recording, tmp_path):
    with_sidecar = diagnose("bcc", recording, validate_run=False)
    CliRunner().invoke(app, ["init", "test", str(tmp_path / "t.toml"), "--from", str(recording)])
    bare = _bare(recording, tmp_path / "bare")
    with pytest.raises(MeasurementError, match="too short for a 0.05 Hz resolution"):  # the structure's default
        diagnose("bcc", bare, validate_run=False)
    with_setup = diagnose(None, bare, test=tmp_path / "t.toml", validate_run=False)
    assert with_setup.controller == "mfdrf"
    assert _verdict(with_setup) == _verdict(with_sidecar)
    assert _verdict(with_setup)[:3] == (True, "added_mass", (("point", 6),))


@pytest.mark.slow
def test_acquisition_numbering_and_a_second_force_channel(recording, tmp_path):
    """Nodes 101.. mapped to points 1..; the control force at 7 recorded too and left out by the setup."""
    rec = read_recording(recording)
    rng = np.random.default_rng(3)
    chans = [Channel(f"{c.quantity[:3] if c.quantity != 'velocity' else 'vel'}{100 + c.point_id}", 100 + c.point_id,
                     c.quantity, c.samples) for c in rec.channels]
    chans.append(Channel("force107", 107, "force", rng.standard_normal(rec.n_samples)))
    acq = tmp_path / "acq" / "acq.uff"
    acq.parent.mkdir()
    write_recording(acq, Recording(rec.dt_s, tuple(chans), {}))
    nodes = "\n".join(f"{100 + p} = {p}" for p in range(1, 10))
    (tmp_path / "t.toml").write_text(f'structure = "bcc"\ncontroller = "mfdrf"\nplant = "linear"\n'
                                     f'[excitation]\npoint = 9\nresolution_hz = {RES_HZ}\n'
                                     f'[sensors]\nquantity = "velocity"\n[nodes]\n{nodes}\n', encoding="utf-8")
    res = diagnose(None, acq, test=tmp_path / "t.toml", validate_run=False)
    assert _verdict(res) == _verdict(diagnose("bcc", recording, validate_run=False))
    text = " ".join(res.notes)
    assert "force107->force7" in text and "force channels other than the excitation at point 9 left out: force7" in text


def test_setup_that_contradicts_the_sidecar_is_refused_unless_forced(recording, tmp_path):
    (tmp_path / "t.toml").write_text('structure = "bcc"\ncontroller = "lqdrf"\n', encoding="utf-8")
    with pytest.raises(OptionError, match=r"t.toml: controller 'lqdrf' contradicts .*rec.uff: its metadata says "
                                          r"'mfdrf'"):
        diagnose(None, recording, test=tmp_path / "t.toml", validate_run=False)
    (tmp_path / "g.toml").write_text('structure = "grid"\n', encoding="utf-8")
    with pytest.raises(OptionError, match="the structure 'bcc' contradicts the test setup"):
        diagnose("bcc", recording, test=tmp_path / "g.toml", validate_run=False)


def test_channels_checked_against_the_setup(recording, tmp_path):
    rec = read_recording(recording)
    (tmp_path / "a.toml").write_text('structure = "bcc"\n[sensors]\nquantity = "acceleration"\n', encoding="utf-8")
    with pytest.raises(DataFileError, match=r"do not measure acceleration as the test setup"):
        apply_setup(rec, read_setup(tmp_path / "a.toml"), "rec.uff")
    (tmp_path / "p.toml").write_text('structure = "bcc"\n[excitation]\npoint = 5\n', encoding="utf-8")
    with pytest.raises(DataFileError, match=r"no out-of-plane force channel at the excitation point 5"):
        apply_setup(rec, read_setup(tmp_path / "p.toml"), "rec.uff")
    (tmp_path / "s.toml").write_text('structure = "bcc"\n[sensors]\npoints = [5, 6]\n', encoding="utf-8")
    sub, notes = apply_setup(rec, read_setup(tmp_path / "s.toml"), "rec.uff")
    assert sorted(c.name for c in sub.channels) == ["force9", "vel5", "vel6"] and "left out" in notes[0]


@pytest.mark.parametrize("text, field", [
    ('controller = "mfdrf"\n', "structure"),
    ('structure = "bcc"\ncontroler = "mfdrf"\n', "controler"),
    ('structure = "bcc"\nplant = "real"\n', "plant"),
    ('structure = "bcc"\nseed = -1\n', "seed"),
    ('structure = "bcc"\n[excitation]\nresolution_hz = 0\n', "excitation.resolution_hz"),
    ('structure = "bcc"\n[chain]\ndelay_periods = -1\n', "chain.delay_periods"),
    ('structure = "bcc"\n[chain]\nfilter = 600\n', "chain.filter"),
    ('structure = "bcc"\n[sensors]\nquantity = "strain"\n', "sensors.quantity"),
    ('structure = "bcc"\n[nodes]\n101 = 1\n102 = 1\n', "nodes"),
    ('structure = "bcc"\n[nodes]\nA = 1\n', "nodes.A"),
    ('structure = "nowhere/my.toml"\n', "structure"),
])
def test_a_wrong_field_is_named(tmp_path, text, field):
    (tmp_path / "t.toml").write_text(text, encoding="utf-8")
    with pytest.raises(SpecError, match=rf"t.toml: field '{field}'"):
        read_setup(tmp_path / "t.toml")


def test_a_structure_path_is_written_as_toml_reads_it(tmp_path):
    """A path with backslashes and quotes survives the round trip through the written file."""
    from vlab.io.setup_file import setup_text

    (tmp_path / 'my "odd" dir\\').mkdir()
    target = tmp_path / 'my "odd" dir\\' / "s.toml"
    target.write_text("", encoding="utf-8")
    (tmp_path / "t.toml").write_text(setup_text(str(target)), encoding="utf-8")
    assert read_setup(tmp_path / "t.toml").structure == str(target)


def test_unreadable_files_are_named(tmp_path):
    (tmp_path / "t.toml").write_text("structure = \n", encoding="utf-8")
    with pytest.raises(DataFileError, match=r"t.toml: not a TOML test setup"):
        read_setup(tmp_path / "t.toml")
    with pytest.raises(DataFileError, match=r"missing.toml: cannot read the test setup"):
        read_setup(tmp_path / "missing.toml")
    res = CliRunner().invoke(app, ["diagnose", "--recording", str(tmp_path / "t.toml")])
    assert res.exit_code == 2 and "--structure is missing" in " ".join(res.output.split())
