"""The detection-threshold tables of docs/detectability.md are generated from the data files
(``benchmarks/detectability_tables.py``): what is committed must be what the files give, and a file without
a field it needs is named."""

from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "benchmarks"))  # the script imports its sibling validation_tables
_spec = importlib.util.spec_from_file_location("detectability_tables", ROOT / "benchmarks" / "detectability_tables.py")
dt = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(dt)


def test_the_page_is_what_the_data_files_give():
    page = dt.PAGE.read_text(encoding="utf-8")
    assert dt.replace_section(page, dt.section(dt.table_rows()), dt.BEGIN) == page, \
        "out of date: run python benchmarks/detectability_tables.py"


def test_a_threshold_file_is_read_into_its_row_and_a_broken_one_is_named(tmp_path):
    rec = {"structure": "bcc", "controller": "none", "model_form": "none", "noise_m_s": 1e-6, "seconds": 12.0,
           "thresholds": [{"effect": "added_mass", "location": {"point": 3}, "threshold": 0.0025},
                          {"effect": "added_mass", "location": {"points": [5, 7, 9]}, "threshold": 0.0001},
                          {"effect": "support_stiffness", "location": {"point": 9, "dof": "w"}, "threshold": 6.1}]}
    (tmp_path / "detectability_bcc_x.json").write_text(json.dumps(rec))
    rows = dt.table_rows(tmp_path)
    assert rows[0]["grams"] == pytest.approx({"3": 2.5, "5, 7, 9": 0.1})
    text = dt.section(rows)
    assert "| open | none (a recording of the model itself) | 2.5 | 0.1 | 12 s |" in text
    del rec["model_form"]
    (tmp_path / "detectability_bcc_x.json").write_text(json.dumps(rec))
    with pytest.raises(dt.ListingError, match="detectability_bcc_x.json: KeyError 'model_form'"):
        dt.table_rows(tmp_path)
