"""Table of the update benchmark's drawn runs: ``docs/validation/data/update_runs.csv`` and the table of
``docs/validation/update-benchmarks.md``, both generated from the listings ``update_benchmark_draw_*.txt``
that ``benchmarks/update_benchmark.py --draw SEED --out FILE`` wrote (one line a case and a summary).

    python benchmarks/update_tables.py           # write the CSV and the page's generated section
    python benchmarks/update_tables.py --check   # exit 1 if either differs from the listings

Every count is taken from the case lines and checked against the listing's own summary lines; a listing
whose case lines disagree with its summary, or that has no case line, stops the script with an error
naming it. The settings come from the command in the listing's first line; the thresholds' model form
from its second; whether the seed was fresh from the provenance line the run's author added ("a seed not
drawn before ..." or "a check on ...").

The standard library, and the page-section and writing helpers of ``validation_tables.py``.
"""

from __future__ import annotations

import re
import statistics
import sys
from pathlib import Path

from validation_tables import DATA, END, ROOT, ListingError, generated_main, replace_section
from validation_tables import csv_text as table_csv

PAGE = ROOT / "docs" / "validation" / "update-benchmarks.md"
CSV_PATH = DATA / "update_runs.csv"
LISTINGS = "update_benchmark_draw_*.txt"
BEGIN = "<!-- generated: update_tables.py -->"

COLUMNS = [
    "listing", "seed", "structures", "controller", "k_lo", "k_hi", "threshold_model_form", "vlab_commit", "provenance",
    "effect_cases", "named_right", "wrong", "missed", "errors", "null_cases", "null_refused", "null_false_alarms",
    "updated", "halved",
    "floor_error", "above_twice_floor", "halved_above_twice_floor", "original_above_0_06", "updated_at_most_0_03",
    "damping_within_10pct", "err_original_median", "err_updated_median",
]

HEAD = re.compile(r"^# python benchmarks/update_benchmark\.py --draw (\d+) --structures ([\w ]+?) --controller (\w+) "
                  r"--k ([\d.]+) ([\d.]+).*?(?:vlab at ([\w-]+))?\)?$")
FORM = re.compile(r"model_form (\w+)\)")
CASE = re.compile(r"^\s*(\d+) (.+?)\s+(-|\d+\.\d+)\s+(\d\.\d{4})?\s+(refused|\d\.\d{4})\s+(pass|FAIL|-)"
                  r"(?:\s+(pass|FAIL|-))?(?:\s+(nan|\d+\.\d+)\s+(pass|FAIL))?\s+(\d+)s\s+(.*)$")
S_DIAG = re.compile(r"^# diagnosis: right (\d+), wrong (\d+), missed or not named (\d+)")
S_NULL = re.compile(r"^# null cases: update refused (\d+) of (\d+)")
S_UPD = re.compile(r"^# effect cases updated (\d+) of (\d+) .*error halved (\d+)/(\d+), <= 0\.03 where the original "
                   r"> 0\.06: (\d+)/(\d+), damping within 10 %: (\d+)/(\d+)")


def _cases(name: str, text: str) -> list[dict]:
    """The case lines of a listing as dicts (``err_orig`` None where the update was refused before a run)."""
    out = []
    for line in text.splitlines():
        if line.lstrip().startswith("#"):
            continue
        m = CASE.match(line)
        if m is None:
            if line.strip():
                raise ListingError(f"{name}: a line that is not a case line: {line[:80]!r}")
            continue
        i, what, k, e0, e1, half, b003, dz, dz_ok, _s, diag = m.groups()
        out.append({"index": int(i), "null": what.strip() == "nothing concealed", "k": k,
                    "err_orig": float(e0) if e0 else None, "err_upd": None if e1 == "refused" else float(e1),
                    "half": half, "below_003": b003, "damping_ok": dz_ok, "diagnosis": diag})
    if not out:
        raise ListingError(f"{name}: no case line")
    return out


def _summary(name: str, text: str) -> dict:
    """The counts the listing's summary states (each line required)."""
    got = {}
    for pat, key in ((S_DIAG, "diag"), (S_NULL, "null"), (S_UPD, "upd")):
        m = next((pat.match(x) for x in text.splitlines() if pat.match(x)), None)
        if m is None:
            raise ListingError(f"{name}: no summary line matching {pat.pattern[:40]!r}")
        got[key] = tuple(int(g) for g in m.groups())
    return got


def parse_listing(name: str, text: str) -> dict:
    """One row of the table: the listing's settings and the counts from its case lines (checked against its
    summary). Raises :class:`ListingError` naming the listing where it cannot be read so."""
    lines = text.splitlines()
    head = HEAD.match(lines[0]) if lines else None
    if head is None:
        raise ListingError(f"{name}: the first line is not an update_benchmark.py --draw command")
    form = FORM.search(lines[1]) if len(lines) > 1 else None
    cases = _cases(name, text)
    eff, nul = [c for c in cases if not c["null"]], [c for c in cases if c["null"]]
    upd = [c for c in eff if c["err_upd"] is not None]
    measured = [c["err_orig"] for c in nul if c["err_orig"] is not None]  # the nominal design on the plant
    floor = statistics.median(measured) if measured else None
    above = [c for c in upd if floor is not None and c["err_orig"] >= 2 * floor]
    null_ok = [c for c in nul if c["diagnosis"].startswith("right")]  # no mismatch found: the update refused
    row = {
        "listing": name, "seed": int(head.group(1)), "structures": head.group(2), "controller": head.group(3),
        "k_lo": head.group(4), "k_hi": head.group(5), "threshold_model_form": form.group(1) if form else "",
        "vlab_commit": head.group(6) or "",
        "provenance": ("fresh" if any(x.startswith("# a seed not") for x in lines)
                       else "seen" if any(x.startswith("# a check on") for x in lines) else ""),
        "effect_cases": len(eff), "named_right": sum(c["diagnosis"].startswith("right") for c in eff),
        "wrong": sum(c["diagnosis"].startswith("WRONG") for c in eff),
        "missed": sum(c["diagnosis"].startswith(("missed", "not named")) for c in eff),
        "errors": sum(c["diagnosis"].startswith("ERROR") for c in cases),
        "null_cases": len(nul), "null_refused": sum(c["err_upd"] is None for c in null_ok),
        "null_false_alarms": sum(c["diagnosis"].startswith("WRONG") for c in nul), "updated": len(upd),
        "halved": sum(c["half"] == "pass" for c in upd), "floor_error": "" if floor is None else f"{floor:.4f}",
        "above_twice_floor": "" if floor is None else len(above),
        "halved_above_twice_floor": "" if floor is None else sum(c["half"] == "pass" for c in above),
        "original_above_0_06": sum(c["below_003"] in ("pass", "FAIL") for c in upd),
        "updated_at_most_0_03": sum(c["below_003"] == "pass" for c in upd),
        "damping_within_10pct": sum(c["damping_ok"] == "pass" for c in upd),
        "err_original_median": f"{statistics.median(c['err_orig'] for c in upd):.4f}" if upd else "",
        "err_updated_median": f"{statistics.median(c['err_upd'] for c in upd):.4f}" if upd else "",
    }
    s = _summary(name, text)
    right_all = sum(c["diagnosis"].startswith("right") for c in cases)  # the summary counts right nulls too
    wrong_all = sum(c["diagnosis"].startswith("WRONG") for c in cases)
    stated = {"right (all cases)": s["diag"][0], "wrong (all cases)": s["diag"][1], "missed": s["diag"][2],
              "nulls without an update": s["null"][0], "null_cases": s["null"][1], "updated": s["upd"][0],
              "effect_cases": s["upd"][1], "halved": s["upd"][2], "updated_at_most_0_03": s["upd"][4],
              "original_above_0_06": s["upd"][5], "damping_within_10pct": s["upd"][6]}
    counted = dict(row, **{"right (all cases)": right_all, "wrong (all cases)": wrong_all,
                           "nulls without an update": sum(c["err_upd"] is None for c in nul)})
    differ = {k: (counted[k], v) for k, v in stated.items() if counted[k] != v}
    if differ:
        raise ListingError(f"{name}: case lines and summary disagree (from the lines, stated): {differ}")
    return row


def table_rows(data: Path = DATA) -> list[dict]:
    """The rows of every drawn listing in ``data``, by seed and controller."""
    rows = [parse_listing(p.name, p.read_text(encoding="utf-8")) for p in sorted(data.glob(LISTINGS))]
    return sorted(rows, key=lambda r: (r["seed"], r["controller"], r["listing"]))


def csv_text(rows: list[dict]) -> str:
    """The CSV of ``rows`` (columns :data:`COLUMNS`)."""
    return table_csv(rows, COLUMNS)


def section(rows: list[dict], link_prefix: str = "data/") -> str:
    """The page's generated section: one table row a listing."""
    lines = [BEGIN, "", "| listing | seed | structures | controller | k | thresholds | seed was | named right | wrong | "
             "missed | errors | nulls refused (false alarms) | error halved | halved, original >= 2x floor | floor | <= 0.03 where > 0.06 | "
             "damping within 10 % | err original / updated (median) |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        above = ("n/a" if r["above_twice_floor"] == ""
                 else f"{r['halved_above_twice_floor']}/{r['above_twice_floor']}")
        lines.append(
            f"| [{r['listing']}]({link_prefix}{r['listing']}) | {r['seed']} | {r['structures']} | {r['controller']} | "
            f"{r['k_lo']}-{r['k_hi']} | {r['threshold_model_form']} | {r['provenance'] or 'not stated'} | "
            f"{r['named_right']}/{r['effect_cases']} | {r['wrong']} | {r['missed']} | {r['errors']} | "
            f"{r['null_refused']}/{r['null_cases']} ({r['null_false_alarms']}) | {r['halved']}/{r['updated']} | {above} | "
            f"{r['floor_error'] or 'not measured'} | {r['updated_at_most_0_03']}/{r['original_above_0_06']} | "
            f"{r['damping_within_10pct']}/{r['updated']} | {r['err_original_median']} / {r['err_updated_median']} |")
    lines += ["", END]
    return "\n".join(lines)


def main(argv=None) -> int:
    def files(rows):
        return (CSV_PATH, csv_text(rows)), (PAGE, replace_section(PAGE.read_text(encoding="utf-8"), section(rows), BEGIN))

    return generated_main(argv, __doc__.split("\n")[0], table_rows, files, "update_tables.py",
                          lambda rows: f"{len(rows)} listings -> {CSV_PATH.relative_to(ROOT)}, {PAGE.relative_to(ROOT)}")

if __name__ == "__main__":
    sys.exit(main())
