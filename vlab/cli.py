"""The ``vlab`` command line.

Thin: every command parses its options, calls the library and prints a rich
table or, with ``--json``, one JSON object with stable keys (README lists
them). Errors of vlab (bad input, singular models, diverging simulations) are
printed as one clear line and exit with status 2; nothing else is caught.
"""

from __future__ import annotations

import json
import sys
from enum import Enum
from typing import Any

import numpy as np
import typer
from rich.console import Console
from rich.table import Table

from .errors import VlabError

app = typer.Typer(
    add_completion=False,
    no_args_is_help=True,
    help="vlab: a virtual laboratory for active vibration control of flexible structures.",
)
console = Console()


@app.callback()
def _root() -> None:
    """vlab: a virtual laboratory for active vibration control of flexible structures."""

err_console = Console(stderr=True)


class Structure(str, Enum):
    bcc = "bcc"
    grid = "grid"


class Reduction(str, Enum):
    full = "full"
    exact = "exact"
    guyan = "guyan"


def _fail(exc: Exception) -> None:
    err_console.print(f"[bold red]error:[/] {exc}")
    raise typer.Exit(code=2)


def _print_json(obj: dict[str, Any]) -> None:
    def default(o: Any) -> Any:
        if isinstance(o, np.ndarray):
            return o.tolist()
        if isinstance(o, (np.floating, np.integer)):
            return o.item()
        raise TypeError(f"not JSON serialisable: {type(o).__name__}")

    sys.stdout.write(json.dumps(obj, default=default, indent=2) + "\n")


def _pad(values: np.ndarray, n: int) -> list[float | None]:
    out: list[float | None] = [float(v) for v in values[:n]]
    return out + [None] * (n - len(out))


@app.command()
def modes(
    structure: Structure = typer.Argument(..., help="bcc or grid"),
    reduction: Reduction = typer.Option(Reduction.full, help="full model, exact reduction or Guyan reduction"),
    n: int = typer.Option(12, "--n", min=1, help="number of modes"),
    as_json: bool = typer.Option(False, "--json", help="print one JSON object"),
) -> None:
    """Natural frequencies against the dissertation's Table 1 (BCC) or Table 3 (grid)."""
    from .fe import modal_analysis
    from .models import nominal_fe_model, reduce_model
    from .reference import column

    try:
        fe = nominal_fe_model(structure.value)
        if reduction is Reduction.full:
            f = modal_analysis(fe.m, fe.k, n).frequencies_hz
        else:
            red = reduce_model(fe, reduction.value)
            f = red.natural_frequencies_hz()[:n]
        table = fe.spec.reference["frequencies"]
        ref_a = column(table, "analytical_hz")
        ref_e = column(table, "experimental_hz")
    except VlabError as exc:
        _fail(exc)
    n_shown = len(f)
    if as_json:
        _print_json(
            {
                "structure": structure.value,
                "reduction": reduction.value,
                "frequencies_hz": f,
                "reference_analytical_hz": _pad(ref_a, n_shown),
                "reference_experimental_hz": _pad(ref_e, n_shown),
                "reference_table": table,
            }
        )
        return
    t = Table(title=f"{fe.spec.title}: natural frequencies ({reduction.value} model) vs {table}")
    for col in ("mode", "vlab [Hz]", "thesis analytical [Hz]", "error", "thesis experimental [Hz]", "error"):
        t.add_column(col, justify="right")
    for i in range(n_shown):
        row = [str(i + 1), f"{f[i]:.3f}"]
        for ref in (ref_a, ref_e):
            if i < len(ref):
                row += [f"{ref[i]:.3f}", f"{100 * (f[i] / ref[i] - 1):+.2f} %"]
            else:
                row += ["", ""]
        t.add_row(*row)
    console.print(t)


def main() -> None:  # pragma: no cover - console entry
    app()
