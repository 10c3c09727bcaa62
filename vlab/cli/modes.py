"""``vlab modes``: natural frequencies of a structure, beside the dissertation's where it has a table."""

from __future__ import annotations

from enum import Enum

import numpy as np

from ..errors import OptionError
from . import checks
from .options import OutputFormat, arg_structure, format_opt, json_flag, opt
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
    fmt: OutputFormat = format_opt(),
    as_json: bool = json_flag(),
) -> None:
    """Natural frequencies, against the dissertation's Table 1 (BCC) or Table 3 (grid) where the structure has one."""
    from ..fe import modal_analysis
    from ..io.tabular import Column
    from ..models import reduce_model
    from ..reference import column

    out = checks.output_format(fmt, as_json)
    spec = checks.load_structure(structure)
    fe = checks.fe_model_of(spec)
    if n > fe.m.shape[0]:
        raise OptionError(f"--n {n} exceeds the model's {fe.m.shape[0]} degrees of freedom")
    if reduction is Reduction.full:
        f = modal_analysis(fe.m, fe.k, n).frequencies_hz
    else:
        red = reduce_model(fe, reduction.value)
        f = red.natural_frequencies_hz()[:n]
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
        rows.append(row)
    cols = [Column("mode", "mode"), Column("frequency_hz", "vlab [Hz]", ".3f")]
    if table:
        cols += [Column("thesis_analytical_hz", "thesis analytical [Hz]", ".3f"),
                 Column("error_analytical_pct", "error [%]", "+.2f"),
                 Column("thesis_experimental_hz", "thesis experimental [Hz]", ".3f"),
                 Column("error_experimental_pct", "error [%]", "+.2f")]
    title = f"{spec.title}: natural frequencies ({reduction.value} model)" + (f" vs {table}" if table else "")
    print_rows(out, rows, cols, title)
