"""FRFs that vlab wrote carry their test's setup, and diagnose as 'no mismatch'.

``vlab experiment`` writes ``frf.uff`` with the sidecar ``frf.uff.json`` (structure, controller, chain,
plant), as it does for ``recording.uff``; the diagnosis reads it as a recording's metadata, and FRFs that
name the MuJoCo plant are referred to the model through that plant's nominal linearisation (the FE/plant
difference removed, as a replay removes it for time histories). Without the sidecar and that reference,
the same file compared with the FE model alone declares a mismatch (so the test can fail).
"""

from __future__ import annotations

import json
import shutil

import pytest
from typer.testing import CliRunner

from vlab.cli import app

runner = CliRunner()


@pytest.fixture(scope="module")
def experiment(tmp_path_factory):
    out = tmp_path_factory.mktemp("frf_sidecar") / "run"
    res = runner.invoke(app, ["experiment", "--out", str(out), "--format", "json"])
    assert res.exit_code == 0, res.output
    return out


def test_the_frf_file_has_the_recording_setup(experiment):
    side = json.loads((experiment / "frf.uff.json").read_text())
    rec = json.loads((experiment / "recording.uff.json").read_text())
    assert side == rec and side["controller"] == "mfdrf" and side["structure"] == "bcc"
    manifest = json.loads((experiment / "vlab-manifest.json").read_text())
    assert "frf.uff.json" in json.dumps(manifest)


@pytest.mark.slow
def test_vlab_own_frfs_diagnose_as_no_mismatch(experiment, tmp_path):
    res = runner.invoke(app, ["diagnose", "--structure", "bcc", "--recording", str(experiment / "frf.uff"),
                              "--out", str(tmp_path / "d"), "--json"])
    assert res.exit_code == 0, res.output
    d = json.loads(res.stdout)
    assert d["mismatch"] is False, d["notes"]
    assert any("controller 'mfdrf' from the recording's metadata" in n for n in d["notes"])
    # the same file without its sidecar, compared with the FE model alone: the FE/plant difference shows
    bare = tmp_path / "bare"
    bare.mkdir()
    shutil.copy(experiment / "frf.uff", bare / "frf.uff")
    res = runner.invoke(app, ["diagnose", "--structure", "bcc", "--recording", str(bare / "frf.uff"),
                              "--controller", "mfdrf", "--out", str(tmp_path / "d2"), "--json"])
    assert res.exit_code == 0, res.output
    assert json.loads(res.stdout)["mismatch"] is True
