"""The dissertation's measurements diagnosed as real data.

Every other table of ``vlab reproduce`` compares vlab's *analysis* with the
dissertation's. Here the published *experimental* numbers are handed to
``vlab diagnose`` as a user's measurement would be, in two ways each:

- against vlab's own model, within the measurement's and the model's
  uncertainty (:mod:`vlab.diagnose.model.modelform`): does the structure
  differ from the model by more than the model is known to be accurate?
- against the published analysis (the table's ``analytical_hz`` column,
  ``--reference-column``): what would explain the dissertation's own
  analysis-versus-experiment differences, vlab's model predicting what each
  effect changes?

Table 1 (BCC frequencies) and Table 3 (grid frequencies; the dissertation
blames wires added for the actuators for modes 1-2, Sec. 2.2.2). Table 10
(BCC peak level ratios in four loop configurations) is diagnosed by
:mod:`vlab.reproduce.peakratios`, all four configurations together.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from ..spec import DATA_DIR

#: (name, structure, table file) of the modal tables diagnosed.
MODAL_TABLES = (("Table 1", "bcc", "table1_bcc_frequencies.csv"),
                ("Table 3", "grid", "table3_grid_frequencies.csv"))


@dataclass(frozen=True)
class MeasuredDiagnosis:
    """One published table diagnosed one way.

    Attributes
    ----------
    table : str
        "Table 1", "Table 3", "Table 10".
    compared_with : str
        "vlab's model" or "the published analysis".
    verdict : str
        The diagnosis's verdict (plain text).
    result : dict
        The diagnosis's JSON object (:meth:`vlab.diagnose.report.result.DiagnosisResult.as_dict`, or
        the peak-ratio diagnosis's).
    """

    table: str
    compared_with: str
    verdict: str
    result: dict = field(default_factory=dict)

    def mode_rows(self) -> list[dict]:
        """Per mode: measured, before, after (selected effect or best rejected candidate) [Hz] and errors."""
        return list((self.result.get("validated") or {}).get("modes") or [])


def diagnose_measurements() -> list[MeasuredDiagnosis]:
    """Diagnose Tables 1 and 3 (each against vlab's model and against the published analysis), and
    Table 10 (:mod:`vlab.reproduce.peakratios`).

    Returns
    -------
    list of MeasuredDiagnosis

    Raises
    ------
    DataFileError
        A published table is missing or malformed.
    """
    from ..diagnose import diagnose
    from ..diagnose.report.verdict import verdict

    out = []
    for name, structure, fn in MODAL_TABLES:
        path = Path(DATA_DIR) / fn
        for ref, what in ((None, "vlab's model"), ("analytical_hz", "the published analysis")):
            d = diagnose(structure, path, out_dir=None, reference_column=ref).as_dict()
            out.append(MeasuredDiagnosis(name, what, verdict(d), d))
    from . import peakratios

    d = peakratios.diagnose_peak_ratios()
    out.append(MeasuredDiagnosis("Table 10", "the published analysis (four loop configurations together)",
                                 d.verdict, peakratios.to_json(d)))
    return out


def _pct(v) -> str:
    return "n/a" if v is None else f"{100 * v:+.1f} %"


def markdown_section(items: list[MeasuredDiagnosis]) -> list[str]:
    """The report section: per table and comparison, the verdict and the per-mode errors before and after.

    Parameters
    ----------
    items : list of MeasuredDiagnosis
        From :func:`diagnose_measurements`.

    Returns
    -------
    list of str
        Markdown lines.
    """
    lines = ["## The dissertation's measurements, diagnosed", "",
             "The published experimental numbers given to `vlab diagnose` as real data: against vlab's model "
             "(within the measurement's and the model's own uncertainty) and against the published analysis "
             "(`--reference-column analytical_hz`). `vlab diagnose --structure bcc --recording "
             "assets/data/table1_bcc_frequencies.csv` repeats one.", ""]
    for it in items:
        lines += [f"### {it.table} against {it.compared_with}", "", it.verdict, ""]
        if it.table == "Table 10":
            lines += ["Per cell, the candidates and their intervals: `docs/diagnose_bcc_table10.md` "
                      "(`python -c \"from vlab.reproduce.peakratios import main; main()\"`).", ""]
        rows = it.mode_rows()
        if not rows:
            continue
        best = "frequency_best_candidate_hz" in rows[0]
        if best:
            lines += [f"Best fitted candidate, not selected: {it.result['validated']['best_candidate']}.", ""]
        after = "best candidate (rejected)" if best else "with the selected effect"
        lines += [f"| mode | measured [Hz] | predicted [Hz] | error | {after} [Hz] | error |", "|---|---|---|---|---|---|"]
        for r in rows:
            fa = r["frequency_best_candidate_hz"] if best else r["frequency_after_hz"]
            ea = r["error_best_candidate"] if best else r["error_after"]
            lines.append(f"| {r['mode']} | {r['frequency_measured_hz']:.4g} | {r['frequency_before_hz']:.4g} | "
                         f"{_pct(r['error_before'])} | {fa:.4g} | {_pct(ea)} |")
        lines.append("")
    return lines


def main(argv: list[str] | None = None) -> int:
    """``python -m vlab.reproduce.measured [FILE]``: diagnose the published measurements and write the
    markdown section to FILE (default ``docs/measured-data.md``).

    Parameters
    ----------
    argv : list of str, optional
        Command-line arguments without the program name (default ``sys.argv[1:]``).

    Returns
    -------
    int
        Exit status 0.
    """
    import sys

    argv = sys.argv[1:] if argv is None else argv
    path = Path(argv[0] if argv else "docs/measured-data.md")
    lines = ["# The dissertation's measurements as real data", "",
             "Written by `python -m vlab.reproduce.measured` (the same section is in `vlab reproduce`'s report).", "",
             "How the uncertainty is set: a measured frequency carries its `frequency_sigma_hz` column, else the "
             "rounding of its printed digits (resolution / sqrt(12)); the model carries its model-form "
             "uncertainty, derived in `vlab.diagnose.model.modelform`: the residual standard error of the "
             "model against the published analysis it was calibrated to (BCC 0.05 %, grid 9.7 %), the FE "
             "mesh against one twice as fine, and the printed rounding of the spec's measured damping. The "
             "published analysis-versus-experiment differences are not used to set it: they are the data "
             "diagnosed here. Compared with the published analysis (`--reference-column analytical_hz`), the "
             "calibration residual cancels.", ""]
    lines += [ln[1:] if ln.startswith("### ") else ln for ln in markdown_section(diagnose_measurements())[2:]]
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text("\n".join(lines))
    tmp.replace(path)
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
