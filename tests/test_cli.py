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
