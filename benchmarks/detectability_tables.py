"""The detection-threshold tables of ``docs/detectability.md``, generated from the thresholds that
``vlab detectability --out DIR`` wrote (``detectability.json``, kept as ``docs/validation/data/detectability_*.json``).

    python benchmarks/detectability_tables.py           # write the page's generated section
    python benchmarks/detectability_tables.py --check   # exit 1 if it differs from the data files

One table per structure: the smallest added mass the diagnosis's mismatch test detects at each point (and
at the points a multi-point mass spans), one row per data file (its loop and its model form). A data file
without its structure, controller, model form or thresholds stops the script with an error naming it.

The standard library, and the page-section and writing helpers of ``validation_tables.py``.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from validation_tables import DATA, END, ROOT, ListingError, generated_main, replace_section

PAGE = ROOT / "docs" / "detectability.md"
FILES = "detectability_*.json"
BEGIN = "<!-- generated: detectability_tables.py -->"
EFFECT = "added_mass"
MODEL_FORM = {"derived": "derived (a real measurement)", "plant": "plant (a recording the MuJoCo plant made)",
              "none": "none (a recording of the model itself)"}


def _place(location: dict) -> str:
    """A column name for a threshold's location: ``"3"`` or ``"5, 7, 9"``."""
    if "point" in location:
        return str(location["point"])
    return ", ".join(str(p) for p in location["points"])


def read(path: Path) -> dict:
    """One data file's row: ``file``, ``structure``, ``controller``, ``model_form``, ``noise_m_s``, ``seconds`` and
    ``grams`` (place -> threshold of the added mass [g]). Raises :class:`ListingError` naming the file and the
    field when one is missing or not a number."""
    try:
        d = json.loads(path.read_text(encoding="utf-8"))
        row = {"file": path.name, "structure": d["structure"], "controller": d["controller"],
               "model_form": d["model_form"], "noise_m_s": float(d["noise_m_s"]), "seconds": float(d["seconds"])}
        row["grams"] = {_place(t["location"]): 1e3 * float(t["threshold"]) for t in d["thresholds"]
                        if t["effect"] == EFFECT and t.get("threshold") is not None}
    except (KeyError, TypeError, ValueError) as err:
        raise ListingError(f"{path.name}: {type(err).__name__} {err}") from err
    return row


def table_rows(data: Path = DATA) -> list[dict]:
    """The rows of every data file, by structure, loop and model form."""
    order = {"none": 0, "mfdrf": 1, "lqdrf": 2}
    rows = [read(p) for p in sorted(data.glob(FILES))]
    return sorted(rows, key=lambda r: (r["structure"], order.get(r["controller"], 9), r["model_form"], r["file"]))


def _columns(rows: list[dict]) -> list[str]:
    """The places of a structure's rows: single points in order, then the multi-point masses."""
    places = {p for r in rows for p in r["grams"]}
    single = sorted((p for p in places if "," not in p), key=int)
    return single + sorted(p for p in places if "," in p)


def section(rows: list[dict], link_prefix: str = "validation/data/") -> str:
    """The page's generated section: one table of added-mass thresholds per structure."""
    lines = [BEGIN, ""]
    for structure in sorted({r["structure"] for r in rows}):
        mine = [r for r in rows if r["structure"] == structure]
        cols = _columns(mine)
        lines += [f"**{structure.upper() if structure == 'bcc' else structure.capitalize()}**: the smallest "
                  "added mass detected [g] at each point (a multi-point column: that mass at each of the points)",
                  "", "| loop | model form | " + " | ".join(cols) + " | computed in | data |",
                  "|---|---|" + "---|" * len(cols) + "---|---|"]
        for r in mine:
            cells = [f"{r['grams'][c]:.3g}" if c in r["grams"] else "" for c in cols]
            loop = "open" if r["controller"] == "none" else r["controller"].upper()
            lines.append(f"| {loop} | {MODEL_FORM.get(r['model_form'], r['model_form'])} | " + " | ".join(cells)
                         + f" | {r['seconds']:.0f} s | [{r['file']}]({link_prefix}{r['file']}) |")
        lines.append("")
    lines.append(END)
    return "\n".join(lines)


def main(argv=None) -> int:
    def files(rows):
        return ((PAGE, replace_section(PAGE.read_text(encoding="utf-8"), section(rows), BEGIN)),)

    return generated_main(argv, __doc__.split("\n")[0], table_rows, files, "detectability_tables.py",
                          lambda rows: f"{len(rows)} data files -> {PAGE.relative_to(ROOT)}")


if __name__ == "__main__":
    sys.exit(main())
