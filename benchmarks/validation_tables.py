"""Tables of the diagnosis benchmark listings: ``docs/validation/data/diagnose_runs.csv`` and the table of
``docs/validation/diagnosis-benchmarks.md``, both generated from the listings ``diagnose_*.txt`` that
``benchmarks/diagnose_benchmark.py`` wrote (its printed case lines and summary).

    python benchmarks/validation_tables.py           # write the CSV and the page's generated section
    python benchmarks/validation_tables.py --check   # exit 1 if either differs from the listings

A listing holds one or more *parts*: a run's case lines and the summary that follows them (a listing
that reruns some cases after its main run, or gives a run in pieces, has several). Each part is one
row of the CSV and of the page. Its figures come from the summary where the listing prints one and are
checked against the case lines (``case N structure controller truth ... -> ...: OK|WRONG (gen + diag s)``);
a part without a summary is counted from its case lines (column ``counts_from``). The settings come
from the command the listing names (``python benchmarks/diagnose_benchmark.py ...``), else from the
file name (column ``note`` says so). Case lines in another format are named in ``note`` and not counted.
A listing that cannot be read so -- no case line and no summary, case lines that disagree with the
summary -- stops the script with an error naming it.

The standard library, and vlab.io.atomic for the writes (each file whole or as it was, also on Ctrl-C).
"""

from __future__ import annotations

import argparse
import csv
import io
import re
import shlex
import statistics
import sys
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DATA = ROOT / "docs" / "validation" / "data"
PAGE = ROOT / "docs" / "validation" / "diagnosis-benchmarks.md"
CSV_PATH = DATA / "diagnose_runs.csv"
BEGIN = "<!-- generated: validation_tables.py -->"
END = "<!-- end generated -->"

COLUMNS = [
    "listing", "part", "purpose", "tier", "plant", "structures", "seed", "cases_drawn", "null_every",
    "closed_nulls", "baseline", "only_cases", "kept", "cases_run", "effect_cases", "effects_right",
    "null_cases", "false_alarms", "closed_loop_nulls", "passengers", "param_error_median_pct",
    "param_error_max_pct", "median_diagnosis_time_s", "max_diagnosis_time_s", "counts_from", "command",
    "note",
]

ROW = re.compile(r"^case\s+(?P<index>\d+)\s+(?P<structure>bcc|grid)\s+(?P<controller>\S+)\s+truth (?P<truth>.+?) -> "
                 r"(?P<got>.*): (?P<verdict>OK|WRONG(?: \(the right one among its look-alikes\))?) "
                 r"\((?P<gen>\d+) \+ (?P<diag>\d+) s\)(?P<rest>.*)$")
ANY_CASE = re.compile(r"^case\s+\d+\b(?! note:)")
S_CASES = re.compile(r"^cases: (\d+) \((\d+) with concealed effects, (\d+) without\)$")
S_RIGHT = re.compile(r"^right effect and location: (\d+) %")
S_FALSE = re.compile(r"^false alarms on no-effect cases: (\d+) of (\d+)$")
S_TIME = re.compile(r"^time per case: diagnosis median (\d+) s, max (\d+) s")
S_PARAM = re.compile(r"^parameter error: median ([\d.]+) %, max ([\d.]+) %")
S_TIER = re.compile(r"^tier (\d): right effect and location (\d+)/(\d+) effect cases")
S_TIER3 = re.compile(r"^tier 3: right effect and place with the parameter within 20 %: (\d+)/(\d+) .*"
                     r"passengers (\d+)")
# the other lines the benchmark prints in its summary: read as summary, not used
S_OTHER = re.compile(r"^(  the right one selected|parameter error of the values|misfit reduction|"
                     r"time-domain error reduction|cases with an effect drawn below visibility|errors:)")
COMMAND = re.compile(r"diagnose_benchmark\.py|^#\s.*\bseed \d+: --cases\b")

DEV_WORDS = {"dev", "check", "recheck", "rerun", "partial"}
DEV_TEXT = re.compile(r"(?<!not )used while developing|\bdevelopment\b|\bnot a fresh\b|\bagain\b|"
                      r"\brecheck\b|\bre-diagnosed\b", re.I)
DEV_TEXT_LATER = re.compile(DEV_TEXT.pattern + r"|\brerun\b", re.I)  # a later part's own lines
FRESH_TEXT = re.compile(r"\bfresh (?:seed|sample)\b|\bseed not used\b|\bnever used before\b|"
                        r"\bnot used (?:before|while developing)\b", re.I)
PURPOSE_ORDER = {"fresh seed": 0, "not stated": 1, "development or check": 2}
STRUCTURE_NAMES = {"bcc": "BCC", "grid": "grid", "bcc grid": "BCC and grid"}
PLANT_NAMES = {"linear": "linear FE plant", "mujoco": "MuJoCo plant", "reference_sim": "reference simulator"}


class ListingError(ValueError):
    """A listing the parser cannot read; the message names it and the line."""


@dataclass
class Part:
    header: list[str] = field(default_factory=list)  # text lines before (and, for the last, after) it
    rows: list[dict] = field(default_factory=list)
    summary: dict = field(default_factory=dict)
    other_lines: list[int] = field(default_factory=list)  # case lines in another format (line numbers)
    phase: str = "header"


def _split(name: str, text: str) -> tuple[list[Part], list[str]]:
    """The parts of a listing and the text lines after its last summary."""
    parts = [Part()]
    pending: list[str] = []
    for n, line in enumerate(text.splitlines(), start=1):
        cur = parts[-1]
        s = line.rstrip()
        if not s.strip():
            continue
        m = ROW.match(s)
        summ = next(((k, r.match(s)) for k, r in (("cases", S_CASES), ("right", S_RIGHT), ("false", S_FALSE),
                                                   ("time", S_TIME), ("param", S_PARAM), ("tier", S_TIER),
                                                   ("tier3", S_TIER3), ("other", S_OTHER)) if r.match(s)), None)
        if m:
            if cur.phase == "summary" or (cur.phase == "rows" and pending):
                cur = Part()
                parts.append(cur)
            cur.header += pending
            pending = []
            row = m.groupdict()
            row["line"] = n
            cur.rows.append(row)
            cur.phase = "rows"
        elif summ:
            key, mm = summ
            if key == "cases" and cur.phase == "summary":
                cur = Part()
                parts.append(cur)
            cur.header += pending
            pending = []
            if key != "other":
                if key in cur.summary:
                    raise ListingError(f"{name}, line {n}: a second '{s.split(':')[0]}' line in one summary")
                cur.summary[key] = mm.groups()
            cur.phase = "summary"
        elif ANY_CASE.match(s):
            cur.other_lines.append(n)
        else:
            pending.append(s)
    return [p for p in parts if p.rows or p.summary], pending


def _options(command: str) -> dict:
    """The benchmark's options named in a command line (those it does not name are left out)."""
    text = command.strip().lstrip("#$ ").strip()
    if "diagnose_benchmark.py" in text:
        text, _, comment = text.partition(" # ")  # the shell comment after the command
        m = re.search(r"DIR: (--cases .*)", comment)
        if "--kept" in text and m:  # the options that generated the kept recordings
            return {**_options(m.group(1)), "kept": "yes", "seed": _options(m.group(1)).get("seed", "0")}
    try:
        words = shlex.split(text.replace("(", " ").replace(")", " "), comments=False, posix=True)
    except ValueError:
        words = text.split()
    out: dict = {}
    i = 0
    while i < len(words):
        w = words[i].rstrip(",;")
        nxt = [x.rstrip(",;") for x in words[i + 1:]]
        values = []
        for x in nxt:
            if x.startswith("--") or not re.fullmatch(r"\d+|\.\.\.?" if w == "--only" else r"[\w.]+", x):
                break
            values.append(x)
        if w in ("--tier", "--seed", "--cases", "--null-every") and values:
            out[w[2:].replace("-", "_")] = values[0]
        elif w == "--plant" and values:
            out["plant"] = values[0]
        elif w == "--structures" and values:
            out["structures"] = " ".join(v for v in values if v in ("bcc", "grid"))
        elif w == "--only":
            out["only"] = " ".join(values) if values and values != ["..."] else "yes"
        elif w == "--kept":
            out["kept"] = "yes"
        elif w in ("--baseline", "--closed-nulls"):
            out[w[2:].replace("-", "_")] = "yes"
        i += 1
    if "seed" not in out:
        m = re.search(r"\bseed (\d+)", text)
        if m:
            out["seed"] = m.group(1)
        elif "diagnose_benchmark.py" in text and "--kept" not in text:
            out["seed"] = "0"  # the benchmark's default
    return out


def _from_name(name: str) -> dict:
    """What the file name says of a run whose listing names no command."""
    out: dict = {}
    m = re.search(r"tier(\d)", name)
    out["tier"] = m.group(1) if m else "1"
    m = re.search(r"seed(\d+)", name)
    if m:
        out["seed"] = m.group(1)
    if "linear" in name:
        out["plant"] = "linear"
    elif "mujoco" in name:
        out["plant"] = "mujoco"
    if "baseline" in name:
        out["baseline"] = "yes"
    if "closed_nulls" in name:
        out["closed_nulls"] = "yes"
    return out


def _purpose(name: str, own: str, file_text: str, later: bool = False) -> str:
    """What the listing says of a part's seed: its file name and its own lines (``later``: a part after the
    first, whose own lines say "rerun" of a rerun), fresh-seed words in ``file_text``."""
    words = set(re.split(r"[_.]", name))
    if words & DEV_WORDS or (DEV_TEXT_LATER if later else DEV_TEXT).search(own):
        return "development or check"
    if FRESH_TEXT.search(own) or FRESH_TEXT.search(file_text):
        return "fresh seed"
    return "not stated"


def _fmt(x: float) -> str:
    return f"{x:g}"


def parse_listing(name: str, text: str) -> list[dict]:
    """The CSV rows (dicts of ``COLUMNS``) of one listing, one per part."""
    parts, trailer = _split(name, text)
    if not parts:
        raise ListingError(f"{name}: no case line and no summary the benchmark prints")
    file_text = "\n".join(parts[0].header)  # the listing's opening lines
    if trailer:
        parts[-1].header += trailer
    commands = [[h for h in p.header if COMMAND.search(h)] for p in parts]
    file_commands = commands[0]
    first_command = next((c for cs in commands for c in cs), "")
    out = []
    for i, p in enumerate(parts):
        note = []
        own = commands[i]
        if i == 0 and len(parts) > 1 and len(file_commands) == len(parts) and not any(commands[1:]):
            command = file_commands[0]  # the opening lines give one command per part, in order
        elif i > 0 and not own and len(file_commands) == len(parts):
            command = file_commands[i]
        else:
            command = own[0] if own else first_command
        if command and "diagnose_benchmark.py" in command:
            opts = _options(command)
        elif command:  # a partial command (options only): the rest from the listing's first command
            opts = {**(_options(first_command) if first_command != command else {}), **_options(command)}
            note.append("settings not in its own line from the listing's first command")
        else:
            opts = _from_name(name)
            note.append("no command in the listing: settings from the file name")
        s = p.summary
        tier = opts.get("tier") or (s["tier"][0] if "tier" in s else "1")
        if "tier" in s and s["tier"][0] != tier:
            raise ListingError(f"{name}: the command says tier {tier}, the summary tier {s['tier'][0]}")
        plant = opts.get("plant") or {"1": "linear", "2": "mujoco", "3": "reference_sim"}[tier]
        if tier == "3":
            plant = "reference_sim"
        rows = p.rows
        structures = " ".join(x for x in ("bcc", "grid") if any(r["structure"] == x for r in rows))
        named = opts.get("structures", "" if tier != "3" else "bcc")
        if structures and named and not set(structures.split()) <= set(named.split()):
            raise ListingError(f"{name}: case lines on {structures}, the command names {named}")
        structures = structures or named
        # counts from the case lines, checked against the summary where there is one
        eff = [r for r in rows if r["truth"] != "none"]
        nul = [r for r in rows if r["truth"] == "none"]
        rc = dict(cases=len(rows), effect=len(eff), right=sum(r["verdict"] == "OK" for r in eff),
                  null=len(nul), false=sum(r["verdict"] != "OK" for r in nul),
                  closed=sum(r["controller"] != "none" for r in nul))
        counts_from = "summary" if "cases" in s else "case lines"
        if "cases" in s:
            n, e, k = (int(x) for x in s["cases"])
            if rows and (n, e, k) != (rc["cases"], rc["effect"], rc["null"]):
                raise ListingError(f"{name}, part {i + 1}: the summary counts {n} cases ({e} with effects, "
                                   f"{k} without), the case lines {rc['cases']} ({rc['effect']}, {rc['null']})")
        elif rows:
            n, e, k = rc["cases"], rc["effect"], rc["null"]
        else:
            raise ListingError(f"{name}, part {i + 1}: a summary without a 'cases:' line and no case lines")
        right = None
        if "tier" in s:
            right = int(s["tier"][1])
            if int(s["tier"][2]) != e:
                raise ListingError(f"{name}, part {i + 1}: the tier line counts {s['tier'][2]} effect cases, "
                                   f"the summary {e}")
        elif rows:
            right = rc["right"]
        elif "right" in s and e:
            right = round(int(s["right"][0]) * e / 100)
            note.append("effects right from the summary's percentage")
        if rows and right is not None and right != rc["right"]:
            raise ListingError(f"{name}, part {i + 1}: {right} effects right in the summary, "
                               f"{rc['right']} OK in the case lines")
        if "right" in s and e and round(100 * right / e) != int(s["right"][0]):
            raise ListingError(f"{name}, part {i + 1}: {right} of {e} right is not the summary's "
                               f"{s['right'][0]} %")
        if "false" in s:
            false, nulls = (int(x) for x in s["false"])
            if rows and (false, nulls) != (rc["false"], rc["null"]):
                raise ListingError(f"{name}, part {i + 1}: {false} of {nulls} false alarms in the summary, "
                                   f"{rc['false']} of {rc['null']} in the case lines")
        else:
            false, nulls = rc["false"], rc["null"]
        closed = rc["closed"] if rows else None
        if "time" in s:
            t_med, t_max = s["time"]
        elif rows:
            diag = [int(r["diag"]) for r in rows]
            t_med, t_max = _fmt(statistics.median(diag)), str(max(diag))
            note.append("times from the case lines")
        else:
            t_med = t_max = ""
        passengers = s["tier3"][2] if "tier3" in s else ""
        p_med, p_max = s["param"] if "param" in s else ("", "")
        if p.other_lines:
            lines = ", ".join(str(x) for x in p.other_lines)
            note.append(f"case lines in another format not counted (line{'s' if len(p.other_lines) > 1 else ''} "
                        f"{lines})")
        # development words in the part's own lines (the opening lines for the first part); fresh-seed
        # words there, in the opening lines or after the last summary
        own_text = "\n".join(p.header) if i > 0 else file_text
        purpose = _purpose(name, own_text, "\n".join([own_text, file_text] + (trailer if i == len(parts) - 1 else [])),
                           later=i > 0)
        out.append({
            "listing": name, "part": str(i + 1), "purpose": purpose, "tier": tier, "plant": plant,
            "structures": structures, "seed": opts.get("seed", ""), "cases_drawn": opts.get("cases", ""),
            "null_every": opts.get("null_every", ""), "closed_nulls": opts.get("closed_nulls", "no"),
            "baseline": opts.get("baseline", "no"), "only_cases": opts.get("only", ""),
            "kept": opts.get("kept", "no"), "cases_run": str(n), "effect_cases": str(e),
            "effects_right": "" if right is None else str(right), "null_cases": "" if nulls is None else str(nulls),
            "false_alarms": "" if false is None else str(false),
            "closed_loop_nulls": "" if closed is None else str(closed), "passengers": passengers,
            "param_error_median_pct": p_med, "param_error_max_pct": p_max,
            "median_diagnosis_time_s": t_med, "max_diagnosis_time_s": t_max, "counts_from": counts_from,
            "command": command.lstrip("#$ ").strip(), "note": "; ".join(note),
        })
    return out


def listings(data: Path = DATA) -> list[Path]:
    """The diagnose benchmark listings of the data folder, by name."""
    return sorted(data.glob("diagnose_*.txt"))


def table_rows(data: Path = DATA) -> list[dict]:
    """Every part of every listing (a ``ListingError`` names the first listing that cannot be read)."""
    rows = []
    for path in listings(data):
        rows += parse_listing(path.name, path.read_text(encoding="utf-8"))
    return rows


def csv_text(rows: list[dict], columns: list[str] = COLUMNS) -> str:
    """The CSV of ``rows`` (default columns :data:`COLUMNS`)."""
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=columns, lineterminator="\n")
    w.writeheader()
    w.writerows(rows)
    return buf.getvalue()


def _options_cell(r: dict) -> str:
    out = []
    if r["baseline"] == "yes":
        out.append("baseline")
    if r["closed_nulls"] == "yes":
        out.append("closed-loop nulls")
    if r["null_every"]:
        out.append(f"null every {r['null_every']}")
    if r["only_cases"]:
        out.append("subset" if r["only_cases"] == "yes" else f"cases {r['only_cases']}")
    if r["kept"] == "yes":
        out.append("kept recordings")
    return ", ".join(out)


def _of(a: str, b: str) -> str:
    return f"{a}/{b}" if a != "" and b not in ("", "0") else ("--" if b == "0" else "")


def section(rows: list[dict], link_prefix: str = "data/") -> str:
    """The page's generated section: one table per tier, plant and structure."""
    groups: dict = {}
    for r in rows:
        groups.setdefault((r["tier"], r["plant"], r["structures"]), []).append(r)
    n_list = len({r["listing"] for r in rows})
    lines = [BEGIN, "",
             f"{n_list} listings, {len(rows)} runs (a listing that reruns cases after its main run, or gives a run "
             "in pieces, has one run a part). Right: effects named with the right location / cases with an "
             "effect; false alarms / cases without one; closed: the cases without an effect recorded in "
             "closed loop; passengers: effects named beside a right one (printed by tier 3 only); parameter "
             "error of the right effects, median and max; diagnosis time per case, median and max "
             "(seconds, on the shared two-core machine the listing names). Purpose: what the listing says "
             "of its seed (a fresh seed; development or check: a development seed, a check or a rerun of "
             "cases already seen; not stated). Also as "
             f"[diagnose_runs.csv]({link_prefix}diagnose_runs.csv).", ""]
    for key in sorted(groups, key=lambda k: (k[0], list(PLANT_NAMES).index(k[1]), k[2])):
        tier, plant, structures = key
        lines += [f"### Tier {tier}, {PLANT_NAMES[plant]}, {STRUCTURE_NAMES.get(structures, structures)}", "",
                  "| listing | purpose | seed | options | cases | right | false alarms | closed | passengers | "
                  "parameter error % | diagnosis time s |",
                  "|---|---|---|---|---|---|---|---|---|---|---|"]
        first_seed = {r["listing"]: int(r["seed"] or -1) for r in rows if r["part"] == "1"}
        group = sorted(groups[key], key=lambda r: (PURPOSE_ORDER[r["purpose"]], first_seed[r["listing"]],
                                                    r["listing"], int(r["part"])))
        for r in group:
            n_parts = sum(x["listing"] == r["listing"] for x in rows)
            label = r["listing"].removesuffix(".txt") + (f" (part {r['part']})" if n_parts > 1 else "")
            param = f"{r['param_error_median_pct']} / {r['param_error_max_pct']}" if r["param_error_max_pct"] else ""
            time = (f"{r['median_diagnosis_time_s']} / {r['max_diagnosis_time_s']}"
                    if r["max_diagnosis_time_s"] else "")
            lines.append(f"| [{label}]({link_prefix}{r['listing']}) | {r['purpose']} | {r['seed']} | "
                         f"{_options_cell(r)} | {r['cases_run']} | {_of(r['effects_right'], r['effect_cases'])} | "
                         f"{_of(r['false_alarms'], r['null_cases'])} | {r['closed_loop_nulls']} | "
                         f"{r['passengers']} | {param} | {time} |")
        lines.append("")
    noted = [r for r in rows if r["note"]]
    if noted:
        lines += ["Read with a note:", ""]
        lines += [f"- {r['listing']}" + (f" part {r['part']}" if sum(x['listing'] == r['listing'] for x in rows) > 1
                                         else "") + f": {r['note']}" for r in noted]
        lines.append("")
    lines.append(END)
    return "\n".join(lines)


def replace_section(page: str, new: str, begin: str = BEGIN) -> str:
    """``page`` with the text between the markers ``begin`` and :data:`END` (markers included) replaced by
    ``new``."""
    a = page.find(begin)
    b = page.find(END, a)
    if a < 0 or b < a:
        raise ValueError(f"the page has no '{begin}' ... '{END}' section")
    return page[:a] + new + page[b + len(END):]


def main(argv=None) -> int:
    def files(rows):
        page = replace_section(PAGE.read_text(encoding="utf-8"), section(rows))
        return (CSV_PATH, csv_text(rows)), (PAGE, page)

    return generated_main(argv, __doc__.split("\n")[0], table_rows, files, "validation_tables.py",
                          lambda rows: f"{len({r['listing'] for r in rows})} listings, {len(rows)} runs -> "
                                       f"{CSV_PATH.relative_to(ROOT)}, {PAGE.relative_to(ROOT)}")


def generated_main(argv, description: str, rows_of, files_of, script: str, summary) -> int:
    """The command line of a table script: ``rows_of()`` read from the listings (exit 2 naming the listing it
    cannot read), ``files_of(rows)`` the ``(path, text)`` pairs written, or with ``--check`` compared
    (:func:`write_or_check`), and ``summary(rows)`` printed after a write."""
    ap = argparse.ArgumentParser(description=description)
    ap.add_argument("--check", action="store_true", help="exit 1 if the CSV or the page is out of date")
    args = ap.parse_args(argv)
    try:
        rows = rows_of()
    except ListingError as err:
        print(f"cannot read a listing: {err}", file=sys.stderr)
        return 2
    rc = write_or_check(files_of(rows), args.check, script)
    if rc == 0 and not args.check:
        print(summary(rows))
    return rc


def write_or_check(files, check: bool, script: str) -> int:
    """Write each ``(path, text)`` of ``files`` whole (or leave it as it was, also on Ctrl-C), or with ``check``
    name on stderr those whose content differs; returns the exit status (1: some are out of date)."""
    if check:
        stale = [str(p.relative_to(ROOT)) for p, want in files
                 if not p.exists() or p.read_text(encoding="utf-8") != want]
        for s in stale:
            print(f"out of date: {s} (run python benchmarks/{script})", file=sys.stderr)
        return 1 if stale else 0
    from vlab.io.atomic import atomic_file

    for path, text in files:
        with atomic_file(path, overwrite=True) as tmp:
            tmp.write_text(text, encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
