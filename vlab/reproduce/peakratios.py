"""Diagnosis of the BCC's published peak level ratios (Table 10) as real data.

Table 10 lists the ratios *analytical / experimental* of the displacement-FRF
peak levels of the Beam Cross-Cable (force at point 9, displacement at point
6, Sec. 5.4.2) for six modes in four loop configurations: open loop, MFDRF,
LQDRF and LQG. The open-loop ratios of modes 1, 2, 4 and 5 are 0.17-0.55; the
dissertation explains them by "the extremely low inherent damping in the
structure and the frequency spacing of the evaluation points. The peaks are
so sharp that a minor shift away from the actual resonant frequency causes a
large decrease in the peak level" (Sec. 6.1), and the closed-loop agreement
by the added damping. This module tests that explanation against the others
of a small library, on all four columns at once: one explanation has to hold
in every loop configuration.

The analysis side
    The dissertation's analysis: the continuous closed loop on the full BCC
    model (Sec. 6.1) with Table 1's open-loop damping as proportional modal
    damping (Sec. 2.1.2), the Table 7 gains for MFDRF and LQDRF, vlab's LQG
    design for LQG (:func:`vlab.design.design_controller`, as
    :mod:`vlab.reproduce` uses it). The FE model's first six natural
    frequencies are set to Table 1's analytical values by a spectral shift
    that keeps the mode shapes (as :func:`vlab.reproduce.context.lab_structure`
    does with the experimental ones): where the analysis was read relative to
    its resonances matters to 0.001 Hz here, and vlab's model is up to
    0.016 Hz away from the dissertation's. Each configuration's FRF is kept in
    pole-residue form, ``H(f) = sum_k r_k / (j 2 pi f - p_k)`` [m/N]
    (:class:`PoleResidueFRF`), and each mode's peak is the highest local
    maximum of ``|H|`` between the midpoints to the neighbouring closed-loop
    natural frequencies (:func:`find_peaks`). A mode whose FRF has no local
    maximum there (vlab's LQG, mode 3) has no resonance to miss: explanations
    that act by moving the reading frequency predict ratio 1 for it.

The explanations (candidates)
    Each predicts the log ratio of all 24 cells (6 modes x 4 configurations):

    ``none``
        ratio 1 everywhere (0 parameters).
    ``spacing-grid`` (the dissertation's)
        the analysis FRF was evaluated on the grid ``f_n = origin + n Delta``
        and each peak read at the grid point nearest the resonance, i.e.
        ``|H(f_g)| / |H(f_peak)|``, the experiment's peak being the
        resonance's (2 parameters: ``spacing_hz`` Delta, ``origin_hz``).
        For a single mode this is ``1 / sqrt(1 + (delta / (zeta f0))^2)``
        with ``delta`` the distance to the grid.
    ``spacing-grid-origin-marginalised``
        the same with the origin unknown: the likelihood averaged over a
        uniform origin in ``[0, Delta)`` (1 parameter).
    ``spacing-random-offset``
        the same with each peak's distance to its grid point an independent
        uniform offset in ``[-Delta/2, Delta/2]``, the likelihood averaged
        over it (1 parameter). This is the limit the grid model reaches when
        the grid's position relative to each peak is not known: Table 1's
        analytical frequencies are printed to 0.001-0.01 Hz and a change of
        Delta by 1e-4 of itself moves the grid by 0.002 Hz at 22 Hz.
    ``damping``
        the structure's open-loop modal damping is ``structure_damping_factor``
        times the analysis' (Table 1) in every mode, the same controllers
        closed around both (1 parameter); open loop: ratio ~ factor.
    ``frequency-offset``
        the analysis read at the experimental natural frequencies (Table 1):
        each peak read ``f_exp,i - f_ana,i`` away from its resonance, the same
        offset in every configuration (0 parameters).
    ``frequency-error``
        the experiment is the same closed loop on the as-measured structure
        (Table 1 experimental frequencies, same shapes and damping), read at
        its own peaks (0 parameters).

The uncertainty of a published ratio (derived, per cell, in ``ln r``)
    1. Printing: a value printed with ``d`` decimals is uniform within
       ``+-0.5 10^-d`` (Table 10: two decimals), standard deviation
       ``0.5 10^-d / sqrt(3)``, i.e. ``0.0029 / r`` in ``ln r``.
    2. Open-loop damping: Table 1 prints each damping ratio to one significant
       digit (0.001-0.004), so the structure's damping is known to
       ``zeta +- h``, ``h = 0.5 10^-3``: uniform in ``ln zeta`` over
       ``[ln(zeta - h), ln(zeta + h)]``, standard deviation
       ``ln((zeta + h) / (zeta - h)) / sqrt(12)`` (0.073 for 0.004, 0.32 for
       0.001). A peak level scales as ``1/zeta``; here the sensitivity
       ``d ln P / d ln zeta_i`` of every cell's analysis peak to every mode's
       damping is computed by central differences on the analysis model
       (open loop: -1 for its own mode; closed loop: -0.002 to -0.07, the
       added damping dominates), and the contributions are added in squares.
    3. Not included: the experiment's own peak reading at its frequency
       resolution. The dissertation does not give the resolution (Sec. 5.4:
       STI-11/23 FFTs of pseudo-random or incremental sine-sweep data) nor
       how peaks were read, so its size cannot be derived. Also neglected:
       the printing of Table 1's analytical frequencies (+-0.0005 Hz for modes
       1-4, +-0.005 Hz for modes 5 and 6: at most 0.22 of mode 6's half-power
       half-width ``zeta f``), which moves where a grid falls on a peak.

Fit, selection and what is outside
    Each candidate is fitted to all 24 log ratios jointly by weighted least
    squares (scipy.optimize, after a global scan where the statistic has many
    minima) with one rule for cells beyond reach: a cell contributes
    ``min(z^2, c^2)``, ``z = (ln r_published - ln r_predicted) / sigma``,
    ``c = Phi^-1(1 - 0.05 / (2 n))`` the two-sided 95 % bound corrected for
    the ``n = 24`` cells (Bonferroni, ``c = 3.08``). A cell beyond ``c``
    costs the same whatever the parameters, so it cannot pull them: it is
    reported "not explained by the library: outside", never absorbed. For the
    averaged candidates the statistic is the deviance ``-2 ln`` of the
    averaged ``exp(-min(z^2, c^2) / 2)``. BIC = statistic + k ln n. 95 %
    intervals are profile-likelihood sets (statistic within 3.84 of its
    minimum); they are unions of disjoint intervals where the statistic has
    many minima, and "not bounded by the data" when they reach the searched
    range or are not one interval. A candidate is eligible only if no
    column's statistic is worse than with ``none`` by more than 1 (it must
    not trade one configuration for another); the eligible candidate with the
    lowest BIC is selected.

Source: Table 10 (and Table 2, its open-loop column), Table 1, Table 7,
Table 8, Sec. 2.1.2, Sec. 5.4, Sec. 6.1.
"""


from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from .peakanalysis import CONFIGS, N_MODES, analysis_side
from .peakfits import FitProblem, fit_candidates
from .peaktable import (CONFIG_LABELS, EXPLAINED, OUTSIDE, TABLE, WITHIN, CellResult, ConfidenceSet,
                        PeakRatioDiagnosis, cell_names, param_text, read_peak_ratio_table)

__all__ = ["CONFIGS", "DOC_PATH", "EXPLAINED", "OUTSIDE", "TABLE", "WITHIN", "ConfidenceSet", "diagnose_peak_ratios",
           "main", "read_peak_ratio_table", "to_json", "to_markdown"]


def diagnose_peak_ratios(table_path: str | Path = TABLE, structure: str = "bcc") -> PeakRatioDiagnosis:
    """Diagnose a Table 10 peak-ratio table: which explanation holds in all four loop configurations.

    Parameters
    ----------
    table_path : str or Path
        The table (a path, or a file name in ``assets/data``); columns
        ``mode``, ``open_loop``, ``mfdrf``, ``lqdrf``, ``lqg``; modes 1-6.
    structure : str
        ``"bcc"``.

    Returns
    -------
    PeakRatioDiagnosis
        Every candidate's fit, the selected one, the verdict and the per-cell
        before/after table (see the module docstring for the method).

    Raises
    ------
    DataFileError
        A missing or malformed table (names the file and the column).
    ModelError
        A structure other than ``"bcc"``.

    Source: Table 10, Sec. 6.1; Tables 1, 7, 8.
    """
    t0 = time.perf_counter()
    tab = read_peak_ratio_table(table_path)
    an = analysis_side(structure)
    pb = FitProblem(an, tab)
    cands = fit_candidates(pb)
    none = cands[0]
    eligible = [c for c in cands if c.eligible]
    best = min(eligible, key=lambda c: (c.bic, c.n_parameters))
    z_before, z_after = none.z, best.z
    out_b, out_a = np.abs(z_before) > pb.cap, best.outside
    cells = []
    for i in range(N_MODES):
        for c, cfg in enumerate(CONFIGS):
            status = OUTSIDE if out_a[i, c] else (EXPLAINED if out_b[i, c] else WITHIN)
            cells.append(CellResult(i + 1, cfg, float(tab.ratio[i, c]), float(pb.sig[i, c]),
                                    float(pb.sig_round[i, c]), float(pb.sig_damp[i, c]), 1.0,
                                    float(z_before[i, c]), float(np.exp(best.log_ratio_predicted[i, c])),
                                    float(z_after[i, c]), float(an.peak_hz[i, c]), bool(an.has_peak[i, c]), status))
    n_out = int(out_a.sum())
    if best.name == "none":
        if n_out == 0:
            verdict = "within the data's accuracy: every ratio is 1 within its uncertainty"
        else:
            verdict = (f"outside the library: no explanation fits better than none (BIC) without making a column "
                       f"worse; {n_out} of {pb.n} cells differ from 1 beyond their uncertainty ({cell_names(out_a)})")
    else:
        n_expl = int((out_b & ~out_a).sum())
        verdict = (f"{best.name} ({param_text(best)}): explains {n_expl} of the {int(out_b.sum())} cells that differ "
                   f"from 1 beyond their uncertainty, BIC {none.bic - best.bic:.1f} below none")
        verdict += (f"; not explained by the library (outside): {n_out} of {pb.n} cells ({cell_names(out_a)})"
                    if n_out else "; no cell left outside")
    inside = ~out_a
    chi_in_b = np.where(inside, z_before ** 2, 0.0).sum(0)
    chi_in_a = np.where(inside, z_after ** 2, 0.0).sum(0)
    cl_zeta = np.array([lp.zeta for lp in an.loops]).T
    no_peak = ~an.has_peak
    fr_h = np.array([0.0005] * 4 + [0.005] * 2)
    notes = [
        "Analysis: continuous closed loop on the full BCC model with its first six frequencies set to Table 1's "
        "analytical values; Table 7 gains (MFDRF, LQDRF); vlab's LQG design (reduced-model LQG as Table 8).",
        "Closed-loop damping of the analysis vs Table 8 (MFDRF, LQDRF, LQG), modes 1-6: " + "; ".join(
            f"mode {i + 1}: " + ", ".join(f"{cl_zeta[i, c + 1]:.4f}/{an.table8_zeta[i, c]:.4f}" for c in range(3))
            for i in range(N_MODES)) + ". vlab's LQG differs from the dissertation's (Table 8) most in modes 2 and 4, "
        "so the LQG column's analysis side is vlab's, not the dissertation's.",
        "Uncertainty not included: the experiment's peak reading at its (unpublished) frequency resolution; the "
        "printing of Table 1's analytical frequencies (at most "
        f"{np.max(fr_h / (an.zeta_open_loop * an.f_analysis_hz)):.2f} of a half-power half-width zeta f).",
    ]
    if best.name.startswith("spacing"):
        others = [c for c in cands if c.name.startswith("spacing") and c.name != best.name]
        notes.append("The spacing variants: " + "; ".join(
            f"{c.name} BIC {none.bic - c.bic:.1f} below none ({param_text(c)})" for c in others)
            + ". spacing-random-offset does not use where the grid falls on each peak, so its margin over none is "
            "the part of the evidence that does not come from tuning the grid's position to the six open-loop peaks.")
    if no_peak.any():
        notes.append(f"No peak in the analysis FRF (read at the closed-loop natural frequency; the spacing and "
                     f"frequency-offset candidates predict 1 there): {cell_names(no_peak)}.")
    return PeakRatioDiagnosis(tab.path, structure, tab.ratio, pb.sig, pb.cap, cands, best.name, verdict,
                              tuple(cells), (z_before ** 2).sum(0), (z_after ** 2).sum(0), chi_in_b, chi_in_a,
                              cl_zeta, an.table8_zeta, tuple(notes), time.perf_counter() - t0)


# --------------------------------------------------------------------------- output
def _ci_json(ci: ConfidenceSet, unit: str) -> dict:
    return {f"intervals{unit}": [[float(a), float(b)] for a, b in ci.intervals],
            f"lower{unit}": float(ci.lower), f"upper{unit}": float(ci.upper),
            f"search_range{unit}": [float(v) for v in ci.search_range], "bounded": bool(ci.bounded),
            "level": float(ci.level), "text": ci.describe()}


def _unit_of(name: str) -> str:
    return "_hz" if name.endswith("_hz") else ""


def to_json(d: PeakRatioDiagnosis) -> dict:
    """The diagnosis as a JSON-ready dict; every number's unit is in its key (``_hz``; others dimensionless).

    Parameters
    ----------
    d : PeakRatioDiagnosis

    Returns
    -------
    dict
        ``table``, ``verdict``, ``selected``, ``bound_z``, ``candidates``
        (name, parameters with ``ci95``, ``statistic``, ``chi2``, ``bic``,
        per-configuration values, ``outside_cells``), ``cells`` (mode,
        configuration, ``ratio_published``, ``sigma_ln_ratio``,
        ``ratio_before``, ``ratio_predicted``, ``z_before``, ``z_after``,
        ``peak_hz``, ``status``), ``chi2_by_config`` and ``notes``.
    """
    def cfg(v):
        return {c: float(x) for c, x in zip(CONFIGS, v)}

    cands = []
    for c in d.candidates:
        params = {}
        for p in c.parameters:
            u = _unit_of(p.name)
            params[p.name] = {f"value{u}": float(p.value), "ci95": _ci_json(p.ci, u)}
        cands.append({"name": c.name, "description": c.description, "n_parameters": c.n_parameters,
                      "parameters": params, "statistic": c.statistic, "statistic_by_config": cfg(c.statistic_by_config),
                      "chi2": c.chi2, "chi2_by_config": cfg(c.chi2_by_config), "bic": c.bic,
                      "column_change": dict(zip(CONFIGS, c.column_change)), "eligible": c.eligible,
                      "n_outside": int(c.outside.sum()),
                      "ratio_predicted": [[float(np.exp(v)) for v in row] for row in c.log_ratio_predicted]})
    cells = [{"mode": c.mode, "config": c.config, "ratio_published": c.ratio_published,
              "sigma_ln_ratio": c.sigma_ln_ratio, "sigma_rounding_ln_ratio": c.sigma_rounding_ln_ratio,
              "sigma_damping_ln_ratio": c.sigma_damping_ln_ratio, "ratio_before": c.ratio_before,
              "z_before": c.z_before, "ratio_predicted": c.ratio_predicted, "z_after": c.z_after,
              "peak_hz": c.peak_hz, "has_peak": c.has_peak, "status": c.status} for c in d.cells]
    return {"table": d.table, "structure": d.structure, "verdict": d.verdict, "selected": d.selected,
            "bound_z": d.bound_z, "configs": list(CONFIGS), "candidates": cands, "cells": cells,
            "chi2_by_config": {"before": cfg(d.chi2_before_by_config), "after": cfg(d.chi2_after_by_config),
                               "inside_before": cfg(d.chi2_inside_before_by_config),
                               "inside_after": cfg(d.chi2_inside_after_by_config)},
            "closed_loop_zeta": {c: [float(v) for v in d.closed_loop_zeta[:, j]] for j, c in enumerate(CONFIGS)},
            "table8_zeta": {c: [float(v) for v in d.table8_zeta[:, j]] for j, c in enumerate(CONFIGS[1:])},
            "notes": list(d.notes), "wall_s": d.wall_s}


def to_markdown(d: PeakRatioDiagnosis) -> str:
    """A short report: verdict, candidates, per-configuration chi2, per-mode table, what is outside.

    Parameters
    ----------
    d : PeakRatioDiagnosis

    Returns
    -------
    str
        Markdown text.
    """
    best = d.best
    lines = [f"**Verdict.** {d.verdict}.", "",
             f"Table: `{Path(d.table).name}`. Uncertainty of each published ratio: its printing (two decimals) and "
             f"Table 1's one-digit damping propagated through the analysis (module docstring); a cell with "
             f"|z| > {d.bound_z:.2f} (family-wise 95 % over {d.ratio_published.size} cells) is outside and costs "
             f"{d.bound_z ** 2:.2f} whatever the parameters.", "",
             "## Candidates", "",
             "| candidate | k | parameters (95 % CI) | statistic | chi2 (all cells) | BIC | outside "
             "| columns vs none |",
             "|---|---|---|---|---|---|---|---|"]
    for c in d.candidates:
        mark = " **(selected)**" if c.name == d.selected else ""
        cols = ", ".join(f"{CONFIG_LABELS[k]} {v}" for k, v in zip(CONFIGS, c.column_change))
        lines.append(f"| `{c.name}`{mark} | {c.n_parameters} | {param_text(c) or '-'} | {c.statistic:.1f} | "
                     f"{c.chi2:.4g} | {c.bic:.1f} | {int(c.outside.sum())} | {cols} |")
    lines += ["", "## Chi2 per configuration (before: ratio 1; after: " + f"`{best.name}`)", "",
              "| | " + " | ".join(CONFIG_LABELS[c] for c in CONFIGS) + " |",
              "|---|" + "---|" * len(CONFIGS),
              "| chi2 before, all cells | " + " | ".join(f"{v:.4g}" for v in d.chi2_before_by_config) + " |",
              "| chi2 after, all cells | " + " | ".join(f"{v:.4g}" for v in d.chi2_after_by_config) + " |",
              "| chi2 before, cells inside | " + " | ".join(f"{v:.4g}" for v in d.chi2_inside_before_by_config) + " |",
              "| chi2 after, cells inside | " + " | ".join(f"{v:.4g}" for v in d.chi2_inside_after_by_config) + " |",
              "| statistic before | " + " | ".join(f"{v:.1f}" for v in d.candidates[0].statistic_by_config) + " |",
              "| statistic after | " + " | ".join(f"{v:.1f}" for v in best.statistic_by_config) + " |",
              "", "## Per mode: published / predicted (z before -> z after)", "",
              "Predicted by `" + best.name + "`; before, every ratio is 1. `*` = outside the library, "
              "`+` = explained, no mark = within the data's accuracy; sigma = standard deviation of ln r.", "",
              "| mode | " + " | ".join(CONFIG_LABELS[c] for c in CONFIGS) + " |",
              "|---|" + "---|" * len(CONFIGS)]
    mark = {OUTSIDE: "*", EXPLAINED: "+", WITHIN: ""}
    by = {(c.mode, c.config): c for c in d.cells}
    for i in range(1, N_MODES + 1):
        row = []
        for cfg in CONFIGS:
            c = by[(i, cfg)]
            row.append(f"{c.ratio_published:.2f} / {c.ratio_predicted:.2f}{mark[c.status]} "
                       f"({c.z_before:+.1f} -> {c.z_after:+.1f}; sigma {c.sigma_ln_ratio:.3f})")
        lines.append(f"| {i} | " + " | ".join(row) + " |")
    out = [c for c in d.cells if c.status == OUTSIDE]
    lines += ["", "## Not explained by the library: outside", ""]
    if out:
        lines += [f"- {CONFIG_LABELS[c.config]} mode {c.mode}: published {c.ratio_published:.2f}, predicted "
                  f"{c.ratio_predicted:.3f}, z = {c.z_after:+.1f}" for c in out]
    else:
        lines.append("- none")
    lines += ["", "## Notes", ""] + [f"- {n}" for n in d.notes] + ["", f"Computed in {d.wall_s:.1f} s."]
    return "\n".join(lines) + "\n"


#: Where :func:`main` writes the report.
DOC_PATH = Path(__file__).resolve().parents[2] / "docs" / "diagnose_bcc_table10.md"


def main(out_path: str | Path | None = None) -> Path:
    """Diagnose the published Table 10 and write the markdown report (``docs/diagnose_bcc_table10.md``).

    Parameters
    ----------
    out_path : str or Path, optional
        Where to write; default :data:`DOC_PATH`.

    Returns
    -------
    Path
        The file written.

    Raises
    ------
    DataFileError
        As :func:`diagnose_peak_ratios`.
    """
    d = diagnose_peak_ratios()
    path = Path(out_path) if out_path is not None else DOC_PATH
    head = ("---\norphan: true\n---\n\n# Diagnosis of the BCC's Table 10 peak level ratios\n\n"
            "Generated by `vlab.reproduce.peakratios.to_markdown(diagnose_peak_ratios())` on "
            "`assets/data/table10_bcc_peak_ratios.csv`; regenerate with\n"
            "`python -c \"from vlab.reproduce.peakratios import main; main()\"`. "
            "Method: the docstring of `vlab/reproduce/peakratios.py`.\n\n")
    path.write_text(head + to_markdown(d))
    return path


if __name__ == "__main__":  # pragma: no cover
    print(main())
