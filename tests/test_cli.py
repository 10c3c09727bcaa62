"""The ``vlab`` command line: tables, JSON keys, clear errors."""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

from vlab.cli import app

runner = CliRunner()


def test_modes_bcc_json_keys_and_values():
    res = runner.invoke(app, ["modes", "bcc", "--n", "6", "--json"])
    assert res.exit_code == 0, res.output
    out = json.loads(res.stdout)
    for key in ("structure", "reduction", "frequencies_hz", "reference_analytical_hz", "reference_experimental_hz"):
        assert key in out
    assert out["structure"] == "bcc" and out["reduction"] == "full"
    assert len(out["frequencies_hz"]) == 6
    for f, ref in zip(out["frequencies_hz"], out["reference_analytical_hz"]):
        assert abs(f / ref - 1) < 0.015


def test_modes_exact_reduction_keeps_full_frequencies():
    full = json.loads(runner.invoke(app, ["modes", "bcc", "--n", "6", "--json"]).stdout)
    exact = json.loads(runner.invoke(app, ["modes", "bcc", "--reduction", "exact", "--json"]).stdout)
    assert exact["frequencies_hz"] == pytest.approx(full["frequencies_hz"], rel=1e-8)


def test_modes_table_prints_reference():
    res = runner.invoke(app, ["modes", "bcc", "--n", "3"])
    assert res.exit_code == 0
    assert "1.853" in res.stdout and "Beam Cross-Cable" in res.stdout


def test_unknown_structure_is_a_clear_error():
    res = runner.invoke(app, ["modes", "bridge"])
    assert res.exit_code != 0
    assert "bridge" in res.output


def test_crosscheck_bcc_json_targets():
    res = runner.invoke(app, ["crosscheck", "bcc", "--json"])
    assert res.exit_code == 0, res.output
    out = json.loads(res.stdout)
    for key in ("frequencies_hz", "relative_error", "mac"):
        assert key in out
    assert max(abs(e) for e in out["relative_error"]) <= 0.015
    assert min(out["mac"]) >= 0.98
    assert out["free_decay_mode1_hz"] == pytest.approx(out["frequencies_hz"]["fe"][0], rel=0.015)


def test_export_mjcf_reloads(tmp_path):
    import mujoco

    path = tmp_path / "bcc.xml"
    res = runner.invoke(app, ["export-mjcf", "bcc", "-o", str(path)])
    assert res.exit_code == 0, res.output
    model = mujoco.MjModel.from_xml_path(str(path))
    assert model.actuator("coil9").id >= 0 and model.sensor("vel6").id >= 0
