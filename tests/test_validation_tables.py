"""The diagnosis benchmarks' table and CSV are generated from the listings (``benchmarks/validation_tables.py``):
what is committed must be what the listings give, so a listing added or changed without regenerating
fails here; the parser reads a listing written here as the benchmark prints it, and names a listing it
cannot read; every file of the data folder is linked from the docs.
"""

from __future__ import annotations

import importlib.util
import re
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
_spec = importlib.util.spec_from_file_location("validation_tables", ROOT / "benchmarks" / "validation_tables.py")
vt = importlib.util.module_from_spec(_spec)
sys.modules["validation_tables"] = vt  # a dataclass looks its module up there
_spec.loader.exec_module(vt)

REGENERATE = "out of date: run python benchmarks/validation_tables.py"

LISTING = """\
$ python benchmarks/diagnose_benchmark.py --tier 2 --plant mujoco --structures bcc --cases 4 --seed 77 --closed-nulls --null-every 2   # a fresh seed; nothing else ran
case   0 bcc  none  truth added_mass(point=3) -> added_mass(point=3): OK (50 + 10 s) [threshold 2.5x; model-form shift up to 0.05 %]
case   1 bcc  mfdrf truth none -> no mismatch: OK (40 + 4 s) [model-form shift up to 0.1 %]
case   2 bcc  none  truth damping(mode=2) -> joint_flexibility(point=4): WRONG (45 + 20 s) [threshold 3.1x; model-form shift up to 0.07 %]
case   3 bcc  lqdrf truth none -> member_stiffness(member=beam): WRONG (41 + 6 s) [model-form shift up to 0.1 %]

cases: 4 (2 with concealed effects, 2 without)
right effect and location: 50 %   (target >= 90 %)
  the right one selected or among the look-alikes reported with the selection (the data cannot tell them apart, dBIC < 10): 50 %
parameter error: median 1.00 %, max 1.0 %, within 15 %: 100 %
false alarms on no-effect cases: 1 of 2
cases with an effect drawn below visibility (5 % on every line, 8 tries): none
time per case: diagnosis median 8 s, max 20 s; with the recording's simulation max 65 s
tier 2: right effect and location 1/2 effect cases, effects at >= 2.5x their detect-and-name threshold; false alarms 1/2 null cases; parameter error median 1.00 %, max 1.0 %, within 20 %: 100 %; time per case median 54 s (diagnosis 8 s)

# case 2 again, after a change
$ python benchmarks/diagnose_benchmark.py --tier 2 --plant mujoco --structures bcc --cases 4 --seed 77 --only 2
case   2 bcc  none  truth damping(mode=2) -> damping(mode=2): OK (45 + 12 s)
"""


def test_the_csv_and_the_page_are_what_the_listings_give():
    rows = vt.table_rows()
    assert vt.CSV_PATH.read_text(encoding="utf-8") == vt.csv_text(rows), REGENERATE
    page = vt.PAGE.read_text(encoding="utf-8")
    assert vt.replace_section(page, vt.section(rows)) == page, REGENERATE
    assert {r["listing"] for r in rows} == {p.name for p in vt.listings()}


def test_a_listing_added_without_regenerating_changes_the_tables(tmp_path):
    for name in ("diagnose_benchmark_mujoco_bcc_seed6868.txt", "diagnose_tier3_bcc_seed48048_baseline.txt"):
        (tmp_path / name).write_text((vt.DATA / name).read_text(encoding="utf-8"), encoding="utf-8")
    before = vt.table_rows(tmp_path)
    (tmp_path / "diagnose_tier2_bcc_seed77.txt").write_text(LISTING, encoding="utf-8")
    after = vt.table_rows(tmp_path)
    assert vt.csv_text(after) != vt.csv_text(before)
    assert "diagnose_tier2_bcc_seed77.txt" in vt.section(after) and "seed77" not in vt.section(before)


def test_a_listing_is_read_as_the_benchmark_prints_it():
    first, second = vt.parse_listing("diagnose_tier2_bcc_seed77.txt", LISTING)
    assert {k: first[k] for k in ("part", "purpose", "tier", "plant", "structures", "seed", "cases_drawn",
                                  "null_every", "closed_nulls", "baseline", "only_cases", "cases_run",
                                  "effect_cases", "effects_right", "null_cases", "false_alarms",
                                  "closed_loop_nulls", "passengers", "param_error_median_pct",
                                  "param_error_max_pct", "median_diagnosis_time_s", "max_diagnosis_time_s",
                                  "counts_from", "note")} == {
        "part": "1", "purpose": "fresh seed", "tier": "2", "plant": "mujoco", "structures": "bcc", "seed": "77",
        "cases_drawn": "4", "null_every": "2", "closed_nulls": "yes", "baseline": "no", "only_cases": "",
        "cases_run": "4", "effect_cases": "2", "effects_right": "1", "null_cases": "2", "false_alarms": "1",
        "closed_loop_nulls": "2", "passengers": "", "param_error_median_pct": "1.00", "param_error_max_pct": "1.0",
        "median_diagnosis_time_s": "8", "max_diagnosis_time_s": "20", "counts_from": "summary", "note": ""}
    assert first["command"].startswith("python benchmarks/diagnose_benchmark.py --tier 2")
    # the rerun after the summary: its own part, counted from its case line, a check by its own words
    assert (second["part"], second["purpose"], second["only_cases"], second["cases_run"], second["effects_right"],
            second["effect_cases"], second["median_diagnosis_time_s"], second["counts_from"]) == \
        ("2", "development or check", "2", "1", "1", "1", "12", "case lines")
    assert "times from the case lines" in second["note"]
    # a tier-3 summary's passengers; a file name that says dev
    tier3 = LISTING.replace("--tier 2", "--tier 3").replace("tier 2:", "tier 3:") + (
        "\ncases: 1 (1 with concealed effects, 0 without)\nright effect and location: 100 %   (target >= 90 %)\n"
        "false alarms on no-effect cases: 0 of 0\ntime per case: diagnosis median 12 s, max 12 s; with the "
        "recording's simulation max 57 s\ntier 3: right effect and place with the parameter within 20 %: 1/1 "
        "(100 %; target >= 90 %); passengers 0 (target 0); false alarms 0/0 (target 0)\n")
    rows = vt.parse_listing("diagnose_tier3_bcc_seed77_dev.txt", tier3)
    assert [(r["tier"], r["plant"], r["purpose"], r["passengers"], r["counts_from"]) for r in rows] == [
        ("3", "reference_sim", "development or check", "", "summary"),
        ("3", "reference_sim", "development or check", "0", "summary")]


def test_a_listing_that_cannot_be_read_is_named():
    with pytest.raises(vt.ListingError, match="diagnose_empty.txt"):
        vt.parse_listing("diagnose_empty.txt", "# a run that printed nothing\n")
    wrong = LISTING.replace("cases: 4 (2 with concealed effects, 2 without)",
                            "cases: 5 (3 with concealed effects, 2 without)")
    with pytest.raises(vt.ListingError, match=r"diagnose_bad\.txt, part 1: the summary counts 5 cases"):
        vt.parse_listing("diagnose_bad.txt", wrong)
    with pytest.raises(vt.ListingError, match="OK in the case lines"):
        vt.parse_listing("diagnose_bad.txt", LISTING.replace("location 1/2 effect", "location 2/2 effect"))
    # a case line in another format is named, not counted
    other = LISTING.replace("\n# case 2 again",
                            "\ncase   2 truth damping(mode=2) -> damping(mode=2): right\n# case 2 again")
    assert "not counted (line 16)" in vt.parse_listing("diagnose_x.txt", other)[0]["note"]


def test_every_file_of_the_data_folder_is_linked_from_the_docs():
    pages = [ROOT / "docs" / "benchmark-listings.md", vt.PAGE, ROOT / "docs" / "validation" / "update-benchmarks.md"]
    linked = {Path(m).name for p in pages for m in re.findall(r"data/([^)\s>`]+)", p.read_text(encoding="utf-8"))}
    missing = sorted(p.name for p in vt.DATA.iterdir() if p.is_file() and p.name not in linked)
    assert not missing, f"not linked from {[str(p.relative_to(ROOT)) for p in pages]}: {missing}"
