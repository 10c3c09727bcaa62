"""The update benchmarks' table and CSV are generated from the drawn listings (``benchmarks/update_tables.py``):
what is committed must be what the listings give; the parser counts a listing written here as the benchmark
prints it, and refuses one whose case lines disagree with its own summary.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "benchmarks"))  # update_tables imports validation_tables as a sibling
_spec = importlib.util.spec_from_file_location("update_tables", ROOT / "benchmarks" / "update_tables.py")
ut = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(ut)

LISTING = """\
# python benchmarks/update_benchmark.py --draw 99 --structures bcc --controller lqdrf --k 2 5   (2026-01-01; vlab at abc1234)
# thresholds: bcc: docs/validation/data/detectability_bcc_lqdrf_plant.json (closed loop, lqdrf, model_form plant)
  # concealed                                                k  err orig   err upd <=half <=0.03   dzeta  <=10%  time  diagnosis
  0 nothing concealed                                        -    0.0050   refused   pass                           8s  right (no mismatch); selected: nothing
  1 added_mass 0.003 kg at point 1                        3.00    0.0200    0.0050   pass      -   0.011   pass    22s  right; fit/true 0.999
  2 support_stiffness 7.0 N/m at point 6                  2.10             refused      -                           5s  missed (no mismatch); selected: nothing
  3 loop_delay 9.0 periods (total) on channel 7           4.00    0.0800    0.0250   pass   pass   0.150   FAIL    15s  right; fit/true 1.000
  4 actuator_lag 139 Hz on channel 7                      3.00    0.0060    0.0065   FAIL      -   0.019   pass    16s  WRONG effect; selected: loop_delay
  5 nothing concealed                                        -             refused   pass                           0s  ERROR ValueError: a crash; selected: - [error]
  6 sensor_lag 120 Hz on channel all                      3.00    0.0150    0.0060   pass      -     nan   FAIL    15s  right; fit/true 1.000
# summary: 7 cases run (5 with an effect, 2 null)
# diagnosis: right 4, wrong 1, missed or not named 1
# null cases: update refused 2 of 2
# effect cases updated 4 of 5 (refused: 1); of those updated: error halved 3/4, <= 0.03 where the original > 0.06: 1/1, damping within 10 %: 2/4
# a seed not drawn before, drawn on abc1234 as committed
"""


def test_the_csv_and_the_page_are_what_the_listings_give():
    rows = ut.table_rows()
    assert rows and ut.CSV_PATH.read_text(encoding="utf-8") == ut.csv_text(rows), "run benchmarks/update_tables.py"
    page = ut.PAGE.read_text(encoding="utf-8")
    assert ut.replace_section(page, ut.section(rows), ut.BEGIN) == page, "run benchmarks/update_tables.py"


def test_a_listing_is_counted_from_its_case_lines():
    r = ut.parse_listing("x.txt", LISTING)
    assert (r["seed"], r["structures"], r["controller"], r["threshold_model_form"], r["vlab_commit"],
            r["provenance"]) == (99, "bcc", "lqdrf", "plant", "abc1234", "fresh")
    assert (r["effect_cases"], r["named_right"], r["wrong"], r["missed"], r["errors"]) == (5, 3, 1, 1, 1)
    # a null case that crashed printed "refused" too: it is counted as an error, not as a refused update
    assert (r["null_cases"], r["null_refused"], r["null_false_alarms"]) == (2, 1, 0)
    assert (r["updated"], r["halved"], r["floor_error"]) == (4, 3, "0.0050")
    # 0.0200, 0.0800 and 0.0150 are at least twice the floor and all halved; 0.0060 is not
    assert (r["above_twice_floor"], r["halved_above_twice_floor"]) == (3, 3)
    # a damping deviation that could not be measured (nan) does not pass
    assert (r["original_above_0_06"], r["updated_at_most_0_03"], r["damping_within_10pct"]) == (1, 1, 2)


def test_a_listing_whose_summary_disagrees_is_refused():
    bad = LISTING.replace("error halved 3/4", "error halved 4/4")
    with pytest.raises(ut.ListingError, match="x.txt: case lines and summary disagree"):
        ut.parse_listing("x.txt", bad)
    with pytest.raises(ut.ListingError, match="no case line"):
        ut.parse_listing("x.txt", "\n".join(LISTING.splitlines()[:3]) + "\n# diagnosis: right 0, wrong 0, missed or not named 0\n")
