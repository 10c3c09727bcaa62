"""``vlab modes``: natural frequencies of a structure, beside the dissertation's where it has a table."""

from __future__ import annotations

from enum import Enum

import numpy as np

from ..errors import OptionError
from . import checks
from .figure_option import figure_path, write_atomically
from .options import OutputFormat, arg_structure, flag, format_opt, json_flag, opt
from .output import print_json, print_rows


class Reduction(str, Enum):
    """``--reduction`` of ``vlab modes``: the model whose frequencies are listed."""

    full = "full"
    exact = "exact"
    guyan = "guyan"


def _pad(values: np.ndarray, n: int) -> list[float | None]:
    out: list[float | None] = [float(v) for v in values[:n]]
    return out + [None] * (n - len(out))


def modes(
    structure: str = arg_structure(),
    reduction: Reduction = opt(Reduction.full, "--reduction",
                               help="model: the full FE model, its exact reduction or Guyan reduction"),
    n: int = opt(12, "--n", min=1, help="number of modes listed, >= 1 (at most the model's degrees of freedom)"),
    shapes: bool = flag("--shapes", help="also give the mode shapes: the out-of-plane displacement w at each point, "
                                         "largest +1 per mode (a second table; JSON key shapes; CSV columns "
                                         "w_at_<point>)"),
    figure: str = opt(None, "--figure", help="also draw the mode shapes on the structure into this file "
                                             "(.png, .svg or .pdf; default: no figure)"),
    rerun: str = opt(None, "--rerun", help="also write a rerun recording (.rrd) of the mode shapes, each mode "
                                           "animated at its frequency on its own timeline mode_<r>_time "
                                           "(default: none)"),
    overwrite: bool = flag("--overwrite", help="replace an existing --figure or --rerun file"),
    fmt: OutputFormat = format_opt(),
    as_json: bool = json_flag(),
) -> None:
    """Natural frequencies, against the dissertation's Table 1 (BCC) or Table 3 (grid) where the structure has one."""
    from ..io.tabular import Column
    from ..reference import column

    out = checks.output_format(fmt, as_json)
    spec = checks.load_structure(structure)
    fe = checks.fe_model_of(spec)
    if n > fe.m.shape[0]:
        raise OptionError(f"--n {n} exceeds the model's {fe.m.shape[0]} degrees of freedom")
    fig_path = figure_path(figure, overwrite)
    rrd_path = _rerun_path(rerun, overwrite)
    f, pts = _modes_at_points(fe, reduction, n, shapes or fig_path is not None or rrd_path is not None)
    if fig_path is not None:
        _write_figure(spec, pts, f, fig_path, reduction, overwrite)
    if rrd_path is not None:
        _write_rerun(spec, pts, f, rrd_path, overwrite)
    table = spec.reference.get("frequencies")
    ref_a = column(table, "analytical_hz") if table else np.zeros(0)
    ref_e = column(table, "experimental_hz") if table else np.zeros(0)
    n_shown = len(f)
    if out == "json":
        print_json(
            {
                "structure": spec.name,
                "reduction": reduction.value,
                "frequencies_hz": f,
                "reference_analytical_hz": _pad(ref_a, n_shown),
                "reference_experimental_hz": _pad(ref_e, n_shown),
                "reference_table": table,
                **({"shapes": _shapes_json(pts)} if shapes else {}),
            }
        )
        return
    rows = []
    for i in range(n_shown):
        row = {"mode": i + 1, "frequency_hz": float(f[i])}
        for key, ref in (("analytical", ref_a), ("experimental", ref_e)):
            if i < len(ref):
                row[f"thesis_{key}_hz"] = float(ref[i])
                row[f"error_{key}_pct"] = 100 * (f[i] / ref[i] - 1)
        if shapes and out == "csv":
            row.update({f"w_at_{p}": float(pts.w[j, i]) for j, p in enumerate(pts.point_ids)})
        rows.append(row)
    cols = [Column("mode", "mode"), Column("frequency_hz", "vlab [Hz]", ".3f")]
    if table:
        cols += [Column("thesis_analytical_hz", "thesis analytical [Hz]", ".3f"),
                 Column("error_analytical_pct", "error [%]", "+.2f"),
                 Column("thesis_experimental_hz", "thesis experimental [Hz]", ".3f"),
                 Column("error_experimental_pct", "error [%]", "+.2f")]
    if shapes and out == "csv":
        cols += [Column(f"w_at_{p}", f"w at {p} [1]", ".4f") for p in pts.point_ids]
    title = f"{spec.title}: natural frequencies ({reduction.value} model)" + (f" vs {table}" if table else "")
    print_rows(out, rows, cols, title)
    if shapes and out == "table":
        _print_shapes_table(pts, f, reduction)


def _modes_at_points(fe, reduction: Reduction, n: int, with_shapes: bool):
    """Frequencies [Hz] of the first ``n`` modes and, when asked, their shapes at the points (or None)."""
    from ..fe import modal_analysis
    from ..fe.point_shapes import point_mode_shapes
    from ..models import reduce_model

    if reduction is Reduction.full:
        res = modal_analysis(fe.m, fe.k, n)
        return res.frequencies_hz, point_mode_shapes(fe, res.shapes) if with_shapes else None
    red = reduce_model(fe, reduction.value)
    if not with_shapes:
        return red.natural_frequencies_hz()[:n], None
    res = modal_analysis(red.m, red.k, min(n, red.m.shape[0]))
    return res.frequencies_hz, point_mode_shapes(fe, res.shapes, basis=red.T)


def _shapes_json(pts) -> dict:
    """The ``shapes`` object of the JSON: point ids, units, and ``w`` as one list per mode."""
    return {"point_ids": list(pts.point_ids), "units": pts.units, "constrained_point_ids": list(pts.constrained),
            "w": pts.w.T}


def _print_shapes_table(pts, f: np.ndarray, reduction: Reduction) -> None:
    """The shapes as a table: one row per point, one column per mode."""
    from ..io.tabular import Column

    rows = [{"point": p, **{f"mode_{r + 1}": float(pts.w[j, r]) for r in range(len(f))}}
            for j, p in enumerate(pts.point_ids)]
    cols = [Column("point", "point")] + [Column(f"mode_{r + 1}", f"{r + 1}: {f[r]:.2f} Hz", "+.4f")
                                         for r in range(len(f))]
    print_rows("table", rows, cols, f"mode shapes w at the points ({reduction.value} model; largest +1 per mode)")


def _write_figure(spec, pts, f: np.ndarray, path, reduction: Reduction, overwrite: bool) -> None:
    """Draw the shapes on the structure (:func:`vlab.viz.mode_figures.mode_shapes_figure`), atomically."""
    from ..viz.mode_figures import mode_shapes_figure
    from ..viz.rerun_structure import structure_geometry

    points, members = structure_geometry(spec)
    write_atomically(path, overwrite, lambda tmp: mode_shapes_figure(
        points, members, pts.point_ids, pts.w, f, tmp, title=f"{spec.title}: mode shapes ({reduction.value} model)"))


def _rerun_path(rerun: str | None, overwrite: bool):
    """``--rerun`` checked before any work: a ``.rrd`` file in a writable folder."""
    from ..io.atomic import check_output_file

    if rerun is None:
        return None
    return check_output_file(rerun, overwrite=overwrite, option="--rerun", suffix=".rrd")


def _write_rerun(spec, pts, f: np.ndarray, path, overwrite: bool) -> None:
    """The shapes animated, one timeline per mode (:func:`vlab.viz.rerun_modes.log_mode_shapes`), atomically."""
    from ..viz.rerun_log import close_recording, open_recording
    from ..viz.rerun_modes import log_mode_shapes, mode_blueprint
    from ..viz.rerun_structure import structure_geometry

    points, members = structure_geometry(spec)

    def draw(tmp):
        rec = open_recording(tmp, app_id=f"vlab-modes-{spec.name}", recording_id=f"modes-{spec.name}",
                             blueprint=mode_blueprint(f))
        try:
            log_mode_shapes(rec, points, members, pts.point_ids, pts.w, f)
        finally:
            close_recording(rec)

    write_atomically(path, overwrite, draw)
