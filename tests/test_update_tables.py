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
# summary: 5 cases run (4 with an effect, 1 null)
# diagnosis: right 3, wrong 1, missed or not named 1
# null cases: update refused 1 of 1
# effect cases updated 3 of 4 (refused: 1); of those updated: error halved 2/3, <= 0.03 where the original > 0.06: 1/1, damping within 10 %: 2/3
# a seed not drawn before, drawn on abc1234 as committed
"""


def test_the_csv_and_the_page_are_what_the_listings_give():
    rows = ut.table_rows()
    assert rows and ut.CSV_PATH.read_text(encoding="utf-8") == ut.csv_text(rows), "run benchmarks/update_tables.py"
    page = ut.PAGE.read_text(encoding="utf-8")
    assert ut.replace_section(page, ut.section(rows), ut.BEGIN) == page, "run benchmarks/update_tables.py"


def test_a_listing_is_counted_from_its_case_lines():
    r = ut.parse_listing("x.txt", LISTING)
    assert (r["seed"], r["controller"], r["threshold_model_form"], r["vlab_commit"], r["provenance"]) == \
        (99, "lqdrf", "plant", "abc1234", "fresh")
    assert (r["effect_cases"], r["named_right"], r["wrong"], r["missed"], r["updated"], r["halved"]) == (4, 2, 1, 1, 3, 2)
    assert r["floor_error"] == "0.0050"
    # 0.0200 and 0.0800 are at least twice the floor and both halved; 0.0060 is not
    assert (r["above_twice_floor"], r["halved_above_twice_floor"]) == (2, 2)
    assert (r["original_above_0_06"], r["updated_at_most_0_03"], r["damping_within_10pct"]) == (1, 1, 2)


def test_a_listing_whose_summary_disagrees_is_refused():
    bad = LISTING.replace("error halved 2/3", "error halved 3/3")
    with pytest.raises(ut.ListingError, match="x.txt: case lines and summary disagree"):
        ut.parse_listing("x.txt", bad)
    with pytest.raises(ut.ListingError, match="no case line"):
        ut.parse_listing("x.txt", "\n".join(LISTING.splitlines()[:3]) + "\n# diagnosis: right 0, wrong 0, missed or not named 0\n")
