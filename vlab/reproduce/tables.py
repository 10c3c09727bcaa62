"""The dissertation's analytical tables of the models and the BCC designs (Tables 1-9), recomputed by vlab,
side by side with the published numbers.

One function per group of tables; each returns :class:`~vlab.reproduce.results.TableResult`
objects (published, vlab, difference, flag per number). Published numbers
come from ``assets/data/table*.csv`` (:func:`vlab.reference.read_table`).
The grid's design tables (11-18) are in :mod:`vlab.reproduce.grid_tables`; the
peak-level-ratio tables (10, 19-21) come from virtual experiments
(:mod:`vlab.reproduce.experiments`), in :mod:`vlab.reproduce.ratio_tables`.

Conventions: damping ratios are those of each *plant* mode (open-loop mode
paired with its closed-loop eigenvalue); performance indices are in the
thesis's unit system (in, lbf, cs) with initial conditions in the shape of
the plant's modes at unit maximum deflection (Sec. 4.1.1); gains in lb-s/in.
"""

from __future__ import annotations

import numpy as np

from ..calibration import drf_damping_ratios
from ..correction import orthogonality_matrix, orthogonality_summary, sequential_correction
from ..design import THESIS_SETTINGS
from ..fe import modal_analysis
from ..models import master_indices, reduce_model
from ..reduction import ExactReduction
from ..reference import bcc_gain
from ..units import CS_S
from .closedloop import performance_indices, plant_mode_damping, thesis_controller, thesis_plant
from .context import ReproContext
from .results import Row, TableResult
from .table_rows import ASSUMED, CAL, LABEL, RECON, gain_rows, gain_table_rows, mode_rows, t_title


# --------------------------------------------------------------------------- Tables 1, 3
def frequency_tables(ctx: ReproContext) -> list[TableResult]:
    """Tables 1 and 3: natural frequencies of the FE models against analysis and experiment.

    Parameters
    ----------
    ctx : ReproContext
        Models and designs of the run.

    Returns
    -------
    list of TableResult
        Table 1 (BCC, 6 modes) and Table 3 (grid, 12 modes); columns
        "analytical" (the thesis's FE model) and "experimental".

    Source: Tables 1, 3.
    """
    out = []
    for structure, name, fn, n, flag in (("bcc", "Table 1", "table1_bcc_frequencies.csv", 6, ""),
                                          ("grid", "Table 3", "table3_grid_frequencies.csv", 12, RECON)):
        fe = ctx.fe(structure)
        f = modal_analysis(fe.m, fe.k, n).frequencies_hz
        t, idx = mode_rows(fn)
        rows = []
        for j, i in enumerate(idx[:n]):
            mode = f"mode {int(t['mode'][i])}"
            rows.append(Row(mode, "analytical [Hz]", t["analytical_hz"][i], f[j], f"{flag},{CAL}"))
            rows.append(Row(mode, "experimental [Hz]", t["experimental_hz"][i], f[j], flag))
        notes = [f"vlab: the nominal FE model ({fe.spec.title}), undamped modes (Eq. 3.4)."]
        if structure == "bcc":
            notes.append("The BCC's unpublished cable, coil, clamp, tip and fitting parameters were calibrated to "
                         "Table 1's analytical frequencies and Table 8 (README), so the analytical column agrees by "
                         "construction; the experimental column is an independent check.")
        else:
            notes.append("The grid's geometry is a reconstruction (Figure 5 is not in the available text) calibrated "
                         "to Table 3's analytical column and Table 5's Guyan column; it does not reach 5 % "
                         "(README: 9.2 % rms).")
        out.append(TableResult(name, t_title(fn), tuple(rows), tuple(notes), 0.05, "relative", fn))
    return out



# --------------------------------------------------------------------------- Table 5, Sec. 3.3
def reduced_frequency_table(ctx: ReproContext) -> list[TableResult]:
    """Table 5: full, exact-reduced and Guyan-reduced grid frequencies.

    Parameters ``ctx``: as :func:`vlab.reproduce.tables.frequency_tables`.

    Returns
    -------
    list of TableResult
        One table; columns full model, exact reduction, Guyan reduction
        (all against the published columns) and experiment.

    Source: Table 5, Sec. 3.3.
    """
    fn = "table5_grid_reduced_frequencies.csv"
    grid = ctx.fe("grid")
    f_full = modal_analysis(grid.m, grid.k, 12).frequencies_hz
    f_exact = reduce_model(grid, "exact").natural_frequencies_hz()[:12]
    f_guyan = reduce_model(grid, "guyan").natural_frequencies_hz()[:12]
    t, idx = mode_rows(fn)
    rows = []
    for j, i in enumerate(idx[:12]):
        mode = f"mode {int(t['mode'][i])}"
        rows.append(Row(mode, "full model [Hz]", t["full_and_exact_hz"][i], f_full[j], f"{RECON},{CAL}"))
        rows.append(Row(mode, "exact reduction [Hz]", t["full_and_exact_hz"][i], f_exact[j], f"{RECON},{CAL}"))
        rows.append(Row(mode, "Guyan reduction [Hz]", t["guyan_hz"][i], f_guyan[j], f"{RECON},{CAL}"))
        rows.append(Row(mode, "experiment [Hz] vs Guyan", t["experiment_hz"][i], f_guyan[j], RECON))
    notes = ("Exact reduction on the 12 joint translations; Guyan on joints 1-9, 12 and the bearing rotations "
             "(Sec. 3.3, the spec's [reduction] table).",
             "The grid model was calibrated to the full and Guyan columns (README).")
    return [TableResult("Table 5", t_title(fn), tuple(rows), notes, 0.05, "relative", fn)]


def orthogonality_tables(ctx: ReproContext) -> list[TableResult]:
    """Tables 4 and 6 (orthogonality matrices) and the Sec. 3.3 summary numbers.

    The measured shapes are a virtual modal test
    (:func:`vlab.reproduce.context.virtual_modal_test`), so element-wise
    agreement is not expected; the summary (largest and mean absolute
    off-diagonal term, the sequential correction of the Guyan model) is the
    dissertation's own yardstick.

    Parameters ``ctx``: as :func:`vlab.reproduce.tables.frequency_tables`.

    Returns
    -------
    list of TableResult
        Table 4 (exact reduction), Table 6 (Guyan) and "Sec. 3.3".

    Source: Tables 4, 6; Sec. 3.3; Eqs. (3.17)-(3.19).
    """
    grid = ctx.fe("grid")
    out = []
    flag = f"{RECON},{ASSUMED}"
    summaries = {}
    for name, fn, method in (("Table 4", "table4_grid_orthogonality_exact.csv", "exact"),
                             ("Table 6", "table6_grid_orthogonality_guyan.csv", "guyan")):
        mm = ctx.measured_modes_at(method)
        red = reduce_model(grid, method)
        o = orthogonality_matrix(mm.shapes, red.m)
        summaries[method] = orthogonality_summary(o)
        t, idx = mode_rows(fn)
        n = len(idx)
        rows = []
        for a in range(n):
            for b in range(a + 1, n):
                rows.append(Row(f"mode {a + 1}", f"mode {b + 1}", t[str(b + 1)][idx[a]], o[a, b], flag))
        notes = (f"Measured shapes: {mm.description}.",
                 "Element-wise agreement is not expected: the 1990 shapes are not published and the signs of "
                 "the published terms depend on its shape normalisation. Compare the summary in 'Sec. 3.3'.",
                 "Upper triangle of the printed matrix (Table 6 is printed non-symmetric in a few entries; "
                 "the upper triangle is used).")
        out.append(TableResult(name, t_title(fn), tuple(rows), notes, 0.1, "absolute", fn))
    # exact reduction on the Guyan DOFs (Sec. 3.3: max 0.72, mean 0.29)
    gi = master_indices(grid, "guyan")
    ex_on_g = ExactReduction(grid.m, grid.k, gi, labels=list(grid.dofs.labels)).reduce()
    mm_g = ctx.measured_modes()
    s_eg = orthogonality_summary(orthogonality_matrix(mm_g.shapes, ex_on_g.m))
    red_g = reduce_model(grid, "guyan")
    hist = sequential_correction(red_g.m, red_g.k, mm_g.shapes, mm_g.freq_hz)
    f12_before, f12_after = float(hist.freq_hz[0][11]), float(hist.freq_hz[-1][11])
    rows = [
        Row("exact reduction", "max |off-diagonal|", 0.80, summaries["exact"].max_abs_offdiag, flag),
        Row("exact reduction", "mean |off-diagonal|", 0.23, summaries["exact"].mean_abs_offdiag, flag),
        Row("Guyan reduction", "max |off-diagonal|", 0.58, summaries["guyan"].max_abs_offdiag, flag),
        Row("Guyan reduction", "mean |off-diagonal|", 0.13, summaries["guyan"].mean_abs_offdiag, flag),
        Row("exact reduction on the Guyan DOFs", "max |off-diagonal|", 0.72, s_eg.max_abs_offdiag, flag),
        Row("exact reduction on the Guyan DOFs", "mean |off-diagonal|", 0.29, s_eg.mean_abs_offdiag, flag),
        Row("Guyan model, mode 12 [Hz]", "before correction", 11.32, f12_before, f"{RECON},{CAL}"),
        Row("Guyan model, mode 12 [Hz]", "after correction with 11 modes", 9.84, f12_after, flag),
    ]
    # does the sequential correction move the unmeasured modes adversely? (Sec. 3.3)
    red_e = reduce_model(grid, "exact")
    mm_e = ctx.measured_modes_at("exact")
    try:
        hist_e = sequential_correction(red_e.m, red_e.k, mm_e.shapes, mm_e.freq_hz)
        f12_exact = float(hist_e.freq_hz[-1][11])
        exact_note = (f"Sequential correction of the exact reduction moves its 12th frequency from "
                      f"{hist_e.freq_hz[0][11]:.2f} Hz to {f12_exact:.2f} Hz (the thesis: 'severely altered' higher modes).")
    except Exception as exc:  # noqa: BLE001 - reported, not hidden
        exact_note = f"Sequential correction of the exact reduction failed: {exc}"
    notes = ("Orthogonality O = Phi'^T m_R Phi' with shapes normalised by Eq. (3.17); summary numbers from the text of Sec. 3.3.",
             "The dissertation's finding to check: the exact reduction's mass matrix makes the measured shapes far "
             "less orthogonal than the Guyan mass matrix, because of the reduction, not the DOFs.",
             "Guyan sequential correction (mode 1, then 1-2, ...; Eqs. 3.17-3.19) with the measured shapes and the "
             "Table 3 experimental frequencies: 12th frequency " f"{f12_before:.2f} -> {f12_after:.2f} Hz.",
             exact_note)
    out.append(TableResult("Sec. 3.3", "Orthogonality summary and sequential correction (text of Sec. 3.3)",
                           tuple(rows), notes, 0.25, "relative", "text of Sec. 3.3"))
    return out


# --------------------------------------------------------------------------- Tables 7-9 (BCC)
def bcc_design_tables(ctx: ReproContext) -> list[TableResult]:
    """Tables 7, 8 and 9: the BCC's DRF gains, closed-loop damping and performance indices.

    vlab designs the controllers with the thesis's settings (Sec. 6.1; DRF and
    LQR on the full model, LQG on the exact reduction -- masters assumed) and
    also applies the published Table 7 gains (the calibration target).

    Parameters ``ctx``: as :func:`vlab.reproduce.tables.frequency_tables`.

    Returns
    -------
    list of TableResult
        Tables 7, 8, 9.

    Source: Tables 7, 8, 9; Sec. 6.1; Eqs. (4.20), (4.26), (4.33).
    """
    fe = ctx.fe("bcc")
    acts = tuple(fe.spec.instrumentation.actuators)
    full = ctx.design_model("bcc", "full")
    st = THESIS_SETTINGS["bcc"]
    plant = thesis_plant(full)
    q, r = st.q_scale * np.eye(2 * plant.n), st.r * np.eye(len(acts))
    out = []
    # Table 7
    fn7 = "table7_bcc_gains.csv"
    rows = gain_table_rows(ctx, "bcc", fn7, ("mfdrf", "lqdrf"), None, CAL)
    # the objectives of the published gains on vlab's model, against vlab's optimum
    d7 = gain_rows(fn7, "lqdrf", acts) / CS_S
    beta7 = float(np.max(performance_indices(plant, {"d": d7}, q, r, 6)))
    beta_v = float(np.max(performance_indices(plant, thesis_controller(ctx.design("bcc", "lqdrf")), q, r, 6)))
    z7 = drf_damping_ratios(fe, bcc_gain("lqdrf"), 6)
    gamma7 = float(np.max(np.sum(np.abs(gain_rows(fn7, "mfdrf", acts)), axis=1)))
    dgain = float(np.max(np.abs(np.asarray(ctx.design("bcc", "lqdrf").extra["gain_thesis_lb_s_per_in"])
                                - gain_rows(fn7, "lqdrf", acts))))
    out.append(TableResult(
        "Table 7", t_title(fn7), tuple(rows),
        ("vlab's MFDRF (Eq. 4.32) and LQDRF (Eq. 4.38) designs on the full BCC model: zeta_L = 0.03 on 6 modes, "
         f"Q = {st.q_scale:g} I, R = {st.r:g} I (thesis units), multi-start SLSQP (32 starts MFDRF, 4 LQDRF) "
         "instead of NEWSUMT-A.",
         "The model was calibrated so that these published gains give Table 8's damping; the design optimum is "
         "not a calibration target but depends on the same parameters.",
         f"MFDRF objective gamma = max_i sum_j |d_ij|: vlab {ctx.design('bcc', 'mfdrf').gamma_lb_s_per_in:.4f}, Table 7 "
         f"{gamma7:.4f} lb-s/in.",
         f"LQDRF objective beta = max_i J_i (6 modal initial conditions) on vlab's model: vlab's gains {beta_v:.1f}, "
         f"Table 7's gains {beta7:.1f} (their min damping over 6 modes {np.min(z7):.4f}). "
         + (f"The objective is flat: beta differs by {100 * (beta7 / beta_v - 1):.1f} % while the gains differ by up "
            f"to {dgain:.3f} lb-s/in (the largest J_i, mode 6, barely depends on them), so the published LQDRF gains -- and "
            "the LQDRF columns of Tables 8 and 9 that follow from them -- are not a sharp target."
            if abs(beta7 / beta_v - 1) < 0.02 else
            "vlab's optimiser finds a clearly different optimum on this model.")),
        0.005, "absolute", fn7))
    # Table 8
    fn8 = "table8_bcc_damping.csv"
    t, idx = mode_rows(fn8)
    z = {c: plant_mode_damping(full, ctx.design("bcc", c), 6)[1] for c in ("mfdrf", "lqdrf", "lqg")}
    z7 = {c: drf_damping_ratios(fe, bcc_gain(c), 6) for c in ("mfdrf", "lqdrf")}
    rows = []
    for j, i in enumerate(idx):
        mode = f"mode {int(t['mode'][i])}"
        for c in ("mfdrf", "lqdrf"):
            rows.append(Row(mode, f"{LABEL[c]} (vlab design)", t[c][i], z[c][j], CAL))
            rows.append(Row(mode, f"{LABEL[c]} (Table 7 gains)", t[c][i], z7[c][j], CAL))
        rows.append(Row(mode, "LQG (reduced-model design on the full model)", t["lqg"][i], z["lqg"][j],
                        f"{CAL},{ASSUMED}"))
    out.append(TableResult(
        "Table 8", t_title(fn8), tuple(rows),
        ("Damping of the full model's modes closed with each controller (Table 1 experimental open-loop damping).",
         "'Table 7 gains' rows are the calibration residual (README); 'vlab design' rows use vlab's own gains.",
         "LQG: designed on the exact reduction to six assumed masters (points 1, 3, 5, 6, 7, 9; the thesis does not "
         "list them), Q = I, R = 0.22 I, V1 = 1e-6 I, V2 = 5e-4 I, alpha = 0.2, applied to the full model (Eq. 4.24)."),
        0.10, "relative", fn8))
    # Table 9
    fn9 = "table9_bcc_performance.csv"
    t, idx = mode_rows(fn9)
    rows = []
    for c in ("lqr", "lqg", "mfdrf", "lqdrf"):
        d = ctx.design("bcc", c, "full")
        jj = performance_indices(plant, thesis_controller(d), q, r, 6)
        for j, i in enumerate(idx):
            rows.append(Row(f"mode {int(t['mode'][i])}", LABEL[c], t[c][i], jj[j], CAL))
    for c in ("mfdrf", "lqdrf"):
        jj = performance_indices(plant, {"d": gain_rows(fn7, c, acts) / CS_S}, q, r, 6)
        for j, i in enumerate(idx):
            rows.append(Row(f"mode {int(t['mode'][i])}", f"{LABEL[c]} (Table 7 gains)", t[c][i], jj[j], CAL))
    out.append(TableResult(
        "Table 9", t_title(fn9), tuple(rows),
        ("Performance index J_i (Eq. 4.4; Q = I, R = 0.22 I; in, lbf, cs) for initial conditions in the shape of "
         "mode i at 1 in maximum deflection, all four controllers designed on the full model (Sec. 6.1).",
         "'Table 7 gains' rows: the published DRF gains applied to vlab's model (J was not a calibration target).",
         "Mode 4 is 23-42 % high in every column, LQR included (which depends on the model only): vlab's mode-4 "
         "shape (one of the close pair 3/4, normalised to 1 in) differs from the thesis's."),
        0.15, "relative", fn9))
    return out


