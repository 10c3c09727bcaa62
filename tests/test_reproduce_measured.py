"""`vlab reproduce`'s diagnosis of the dissertation's measurements."""

from __future__ import annotations

import json
import pytest

from vlab.reference import column
from vlab.reproduce import reproduce


@pytest.mark.slow
def test_measured_data_group_reports_every_table_both_ways(tmp_path):
    res = reproduce(tmp_path / "r", groups=("measured-data",))
    got = {(m.table, m.compared_with) for m in res.measured}
    for t in ("Table 1", "Table 3"):
        assert (t, "vlab's model") in got and (t, "the published analysis") in got
    report = (tmp_path / "r" / "report.md").read_text()
    assert "## The dissertation's measurements, diagnosed" in report
    obj = json.loads((tmp_path / "r" / "reproduce.json").read_text())
    t1 = [m for m in obj["measured_data"] if m["table"] == "Table 1"]
    # the measured frequencies in the report are the published ones
    f_exp = column("table1_bcc_frequencies.csv", "experimental_hz")
    modes = t1[0]["diagnosis"]["validated"]["modes"]
    assert [round(m["frequency_measured_hz"], 6) for m in modes] == [round(float(f), 6) for f in f_exp]
    # against the published analysis, the prediction before any effect is that analysis
    f_ana = column("table1_bcc_frequencies.csv", "analytical_hz")
    modes = [m for m in obj["measured_data"] if m["table"] == "Table 1"][1]["diagnosis"]["validated"]["modes"]
    assert [round(m["frequency_before_hz"], 6) for m in modes] == [round(float(f), 6) for f in f_ana]
