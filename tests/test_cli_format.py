"""`--format table|csv|json`: CSV with units in the column names, JSON with units in the keys,
the rich table by default; `--json` stays as `--format json` and clashes with `--format csv`."""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from vlab.cli import app
from vlab.spec import DATA_DIR

EXAMPLE = Path(__file__).resolve().parent.parent / "examples" / "cantilever_tip_mass.toml"
runner = CliRunner()


def _run(*args):
    res = runner.invoke(app, [str(a) for a in args])
    assert res.exit_code == 0, res.output
    return res.stdout


def _csv(text):
    rows = list(csv.DictReader(io.StringIO(text)))
    assert rows
    return rows


def _published(column):
    with open(DATA_DIR / "table1_bcc_frequencies.csv", newline="") as f:
        return [float(r[column]) for r in csv.DictReader(line for line in f if not line.startswith("#"))]


def test_modes_csv_has_units_in_the_header_and_the_published_table():
    rows = _csv(_run("modes", "bcc", "--n", "4", "--format", "csv"))
    assert list(rows[0]) == ["mode", "frequency_hz", "thesis_analytical_hz", "error_analytical_pct",
                             "thesis_experimental_hz", "error_experimental_pct"]
    assert [float(r["thesis_analytical_hz"]) for r in rows] == _published("analytical_hz")[:4]
    for r in rows:  # the error column is the one of its own row
        f, ref = float(r["frequency_hz"]), float(r["thesis_analytical_hz"])
        assert float(r["error_analytical_pct"]) == pytest.approx(100 * (f / ref - 1))
        assert abs(f / ref - 1) < 0.01  # Table 1 analytical, within 1 %
    js = json.loads(_run("modes", "bcc", "--n", "4", "--format", "json"))
    assert np.allclose([float(r["frequency_hz"]) for r in rows], js["frequencies_hz"], rtol=1e-12)
    assert js == json.loads(_run("modes", "bcc", "--n", "4", "--json"))


def test_modes_of_a_structure_without_published_table():
    rows = _csv(_run("modes", EXAMPLE, "--n", "3", "--format", "csv"))
    assert list(rows[0]) == ["mode", "frequency_hz"] and len(rows) == 3
    table = _run("modes", EXAMPLE, "--n", "3")
    assert "vlab [Hz]" in table and "Cantilever with tip mass" in table


def test_design_csv_lists_the_closed_loop_modes_with_units():
    rows = _csv(_run("design", "bcc", "--controller", "mfdrf", "--format", "csv"))
    assert list(rows[0]) == ["mode", "frequency_hz", "damping_ratio", "performance_index_thesis_units"]
    zeta = [float(r["damping_ratio"]) for r in rows[:6]]
    assert min(zeta) >= 0.03 - 1e-4  # Sec. 6.1: zeta_L = 0.03 on the first six modes
    assert "zeta [-]" in _run("design", "bcc", "--controller", "mfdrf")


def test_experiment_csv_and_json_on_the_linear_plant(tmp_path):
    args = ["experiment", EXAMPLE, "--controller", "none", "--plant", "linear", "--duration", "4"]
    rows = _csv(_run(*args, "--out", tmp_path / "a", "--format", "csv"))
    assert list(rows[0]) == ["mode", "frequency_predicted_hz", "frequency_measured_hz", "damping_ratio_predicted",
                             "damping_ratio_measured", "peak_level_ratio"]
    assert len(rows) == 2
    js = json.loads(_run(*args, "--out", tmp_path / "b", "--format", "json"))
    assert js["structure"] == "cantilever_tip_mass" and js["resolution_hz"] == 0.5
    for r, m in zip(rows, js["modes"]):
        assert float(r["frequency_measured_hz"]) == pytest.approx(m["frequency_measured_hz"])
    assert (tmp_path / "a" / "results.json").exists()


def test_json_flag_clashes_with_csv():
    res = runner.invoke(app, ["modes", "bcc", "--json", "--format", "csv"])
    assert res.exit_code == 2 and "--json" in res.output and "csv" in res.output


def test_format_rejects_an_unknown_value():
    res = runner.invoke(app, ["modes", "bcc", "--format", "xml"])
    assert res.exit_code == 2


def test_csv_writer_keeps_full_precision_and_empty_missing_cells():
    from vlab.io.tabular import Column, write_csv

    buf = io.StringIO()
    write_csv([{"a_hz": 1 / 3, "b_pct": None}, {"a_hz": np.float64(2.5), "b_pct": float("nan")}],
              [Column("a_hz", "a [Hz]", ".2f"), Column("b_pct", "b [%]")], buf)
    assert buf.getvalue() == f"a_hz,b_pct\n{1 / 3!r},\n2.5,\n"
