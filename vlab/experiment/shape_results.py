"""An experiment's identified mode shapes in its outputs: the ``mode_shapes`` object of results.json,
``shapes.csv``, ``shapes.png`` and the lines of report.md.

The shapes are identified from the H1 FRFs of all measured points for the one excitation point
(:func:`vlab.measure.shapes.identify_shapes`: modal constants of the receptance's residues, LSFD with the
poles fixed) and compared with the FE model's normal modes at the same points by the MAC
(:func:`vlab.measure.shapes.compare_shapes`; Allemang & Brown, IMAC 1 (1982) 110-116). With a controller in
the loop they are the closed loop's shapes: their MAC against the open-loop model's shows how far the
feedback moved them.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..io.tabular import Column, write_csv

def _paired(result) -> dict[int, dict]:
    """Identified mode number -> its pair with a model mode (:attr:`ShapeComparison.pairs`)."""
    return {p["identified_mode"]: p for p in result.shape_comparison.pairs}


def shapes_summary(result) -> dict | None:
    """The ``mode_shapes`` object of results.json: identified shapes, the model's, their MAC and pairs.

    Parameters
    ----------
    result : ExperimentResult
        The experiment; its ``shapes``, ``shape_comparison`` and ``model_shapes``
        (:func:`vlab.measure.shapes.identify_shapes`, :func:`vlab.measure.shapes.compare_shapes`).

    Returns
    -------
    dict or None
        None when no shape was identified; else ``method``, ``reference_point``, ``point_ids``,
        ``identified`` (one object per mode: ``mode``, ``frequency_hz``, ``damping_ratio``, ``mpc``,
        ``shape_normalised`` (largest +1) and ``shape_mass_normalised_per_sqrt_kg`` at the points,
        ``model_mode``, ``mac``), ``model`` (``frequencies_hz``, ``damping_ratios`` and
        ``shapes_mass_normalised_per_sqrt_kg``, one list per mode, of the FE model's modes up to the band's
        upper edge), ``mac_matrix`` (rows: model modes, columns: identified modes), ``pairs`` (as
        :class:`vlab.measure.shapes.ShapeComparison`).
    """
    sh = result.shapes
    if sh is None:
        return None
    cmp = result.shape_comparison
    pairs = _paired(result)
    ident = []
    for r, mode in enumerate(sh.modes):
        p = pairs.get(mode, {})
        ident.append({"mode": mode, "frequency_hz": sh.freq_hz[r], "damping_ratio": sh.damping_ratio[r],
                      "mpc": sh.mpc[r], "shape_normalised": sh.shapes[:, r],
                      "shape_mass_normalised_per_sqrt_kg": sh.shapes_mass_normalised[:, r],
                      "model_mode": p.get("model_mode"), "mac": p.get("mac")})
    return {"method": sh.method, "reference_point": sh.reference_point, "point_ids": list(sh.point_ids),
            "identified": ident,
            "model": {"frequencies_hz": cmp.model_freq_hz, "damping_ratios": cmp.model_damping,
                      "shapes_mass_normalised_per_sqrt_kg": result.model_shapes.T},
            "mac_matrix": cmp.mac_matrix, "pairs": cmp.pairs}



def shape_rows(result) -> tuple[list[dict], list[Column]]:
    """One row per identified mode (``shapes.csv`` and the printed table) and its columns.

    Parameters
    ----------
    result : ExperimentResult
        The experiment, with ``shapes`` (not None).

    Returns
    -------
    rows : list of dict
        ``mode``, ``frequency_hz``, ``damping_ratio``, ``mpc``, ``model_mode``, ``frequency_model_hz``,
        ``damping_ratio_model``, ``mac``, then ``w_at_<point>`` (largest +1) and
        ``phi_at_<point>_per_sqrt_kg`` (mass-normalised) for every measured point.
    columns : list of Column
        Their keys (units in the names) and table headers.
    """
    sh = result.shapes
    pairs = _paired(result)
    rows = []
    for r, mode in enumerate(sh.modes):
        p = pairs.get(mode, {})
        row = {"mode": mode, "frequency_hz": float(sh.freq_hz[r]), "damping_ratio": float(sh.damping_ratio[r]),
               "mpc": float(sh.mpc[r]), "model_mode": p.get("model_mode"),
               "frequency_model_hz": p.get("frequency_model_hz"), "damping_ratio_model": p.get("damping_ratio_model"),
               "mac": p.get("mac")}
        row.update({f"w_at_{q}": float(sh.shapes[j, r]) for j, q in enumerate(sh.point_ids)})
        row.update({f"phi_at_{q}_per_sqrt_kg": float(sh.shapes_mass_normalised[j, r])
                    for j, q in enumerate(sh.point_ids)})
        rows.append(row)
    cols = [Column("mode", "mode"), Column("frequency_hz", "f ident [Hz]", ".3f"),
            Column("damping_ratio", "zeta ident [-]", ".4f"), Column("mpc", "MPC [-]", ".3f"),
            Column("model_mode", "FE mode"), Column("frequency_model_hz", "f FE [Hz]", ".3f"),
            Column("damping_ratio_model", "zeta FE [-]", ".4f"), Column("mac", "MAC [-]", ".4f")]
    cols += [Column(f"w_at_{q}", f"w at {q} [-]", "+.3f") for q in sh.point_ids]
    cols += [Column(f"phi_at_{q}_per_sqrt_kg", f"phi at {q} [1/sqrt(kg)]", "+.4g") for q in sh.point_ids]
    return rows, cols


def paired_model_shapes(result) -> tuple[np.ndarray, np.ndarray]:
    """The model shape paired with each identified mode, at the measured points, and the pair's MAC.

    Parameters
    ----------
    result : ExperimentResult
        An experiment with identified shapes (``result.shapes`` not None).

    Returns
    -------
    w_model : ndarray, shape (n_points, n_identified)
        The FE shape (mass-normalised, [1/sqrt(kg)]) of each identified mode's pair; a column of NaN where
        the mode has none (:func:`vlab.measure.shapes.compare_shapes`).
    mac : ndarray, shape (n_identified,)
        The pair's MAC [-], NaN where unpaired.
    """
    sh = result.shapes
    pairs = _paired(result)
    w_model = np.full(sh.shapes.shape, np.nan)
    macs = np.full(len(sh.modes), np.nan)
    for r, mode in enumerate(sh.modes):
        if mode in pairs:
            w_model[:, r] = result.model_shapes[:, pairs[mode]["model_mode"] - 1]
            macs[r] = pairs[mode]["mac"]
    return w_model, macs


def write_shape_outputs(result, spec, out: Path) -> dict[str, Path]:
    """Write ``shapes.csv`` (:func:`shape_rows`) and ``shapes.png`` (identified against paired FE shapes,
    :func:`vlab.viz.mode_figures.shape_comparison_figure`) into ``out``; nothing when no shape was identified.

    Parameters
    ----------
    result : ExperimentResult
        The experiment.
    spec : StructureSpec
        The structure, for the points' positions in the figure.
    out : Path
        An existing folder.

    Returns
    -------
    dict[str, Path]
        ``"shapes"`` and ``"shapes_figure"`` -> their files; empty when ``result.shapes`` is None.

    Raises
    ------
    OSError
        A file cannot be written.
    """
    from ..viz.mode_figures import line_positions, shape_comparison_figure
    from ..viz.rerun_structure import structure_geometry

    sh = result.shapes
    if sh is None:
        return {}
    files = {"shapes": out / "shapes.csv", "shapes_figure": out / "shapes.png"}
    rows, cols = shape_rows(result)
    with files["shapes"].open("w", newline="") as fh:
        write_csv(rows, cols, fh)
    w_model, macs = paired_model_shapes(result)
    points, _ = structure_geometry(spec)
    cfg = result.config
    shape_comparison_figure(sh.point_ids, sh.shapes, sh.freq_hz, w_model, macs, files["shapes_figure"],
                            positions=line_positions(points, sh.point_ids),
                            title=f"{cfg.structure} {cfg.controller}: mode shapes identified at the measured "
                                  f"points (excitation at {sh.reference_point}) vs the FE model")
    return files


def shapes_report_lines(summary: dict) -> list[str]:
    """The report.md section of the identified shapes: one table row per mode (frequency, damping, MPC,
    paired FE mode and MAC), from the ``mode_shapes`` object of results.json (:func:`shapes_summary`).

    Parameters
    ----------
    summary : dict
        The results.json object.

    Returns
    -------
    list of str
        Markdown lines; empty when ``mode_shapes`` is null or missing.
    """
    ms = summary.get("mode_shapes")
    if not ms:
        return []
    lines = [f"Mode shapes identified at points {', '.join(map(str, ms['point_ids']))} (excitation at "
             f"{ms['reference_point']}): {ms['method']}; against the FE model's modes by MAC.", "",
             "| mode | f identified [Hz] | zeta identified | MPC | FE mode | f FE [Hz] | MAC |",
             "|---|---|---|---|---|---|---|"]
    fe_f = ms["model"]["frequencies_hz"]
    for m in ms["identified"]:
        k = m["model_mode"]
        fe = f"{fe_f[k - 1]:.3f}" if k else "n/a"
        mac = f"{m['mac']:.4f}" if m["mac"] is not None else "n/a"
        lines.append(f"| {m['mode']} | {m['frequency_hz']:.3f} | {m['damping_ratio']:.4f} | {m['mpc']:.3f} | "
                     f"{k or 'n/a'} | {fe} | {mac} |")
    return lines + [""]
