"""The options and arguments several commands share: their help texts, types and the choices they offer.

Help texts are plain text: brackets such as ``[s]`` are escaped, not read as rich markup.
"""

from __future__ import annotations

from enum import Enum
from typing import Any

import typer
from rich.markup import escape

STRUCTURE_HELP = ("structure: bcc (Beam Cross-Cable), grid (Hanging Grid) or the path of a .toml structure file "
                  "(`vlab init` writes one)")
STRUCTURE_METAVAR = "<bcc|grid|FILE.toml>"  # the type shown for --structure (diagnose)
REDUCTION_HELP = ("design model: full FE model, exact reduction, Guyan reduction or Guyan corrected with measured "
                  "modes (default: the thesis's choice: DRF on the full model for the BCC, "
                  "everything else on the structure's default reduction)")


class OutputFormat(str, Enum):
    """``--format``: a rich table, CSV or one JSON object."""

    table = "table"
    csv = "csv"
    json = "json"


class DesignReduction(str, Enum):
    """``--reduction`` of a design: the model the controller is designed on."""

    full = "full"
    exact = "exact"
    guyan = "guyan"
    corrected_guyan = "corrected-guyan"


class ExpController(str, Enum):
    """Controllers an experiment can run (LQR is not offered: it needs every state measured)."""

    none = "none"
    lqg = "lqg"
    mfdrf = "mfdrf"
    lqdrf = "lqdrf"
    lqdrf_diag = "lqdrf-diag"


class PlantKind(str, Enum):
    """``--plant`` of a run: the MuJoCo model or the linear FE model stepped exactly."""

    mujoco = "mujoco"
    linear = "linear"


def opt(default: Any, *decls: str, help: str, **kwargs: Any) -> Any:
    """``typer.Option`` whose help is plain text: brackets such as ``[s]`` are escaped, not read as rich markup."""
    return typer.Option(default, *decls, help=escape(help), **kwargs)


def arg(default: Any, *, help: str, **kwargs: Any) -> Any:
    """``typer.Argument`` whose help is plain text: brackets such as ``[test]`` are escaped, not read as rich markup."""
    return typer.Argument(default, help=escape(help), **kwargs)


def flag(*decls: str, help: str) -> Any:
    """An on/off option: off by default, shown without a type (no ``<bool>``) in ``--help``."""
    return typer.Option(False, *decls, help=escape(help) + " (a flag; default: off)", metavar="",
                        show_default=False)


def arg_structure() -> Any:
    """The required ``structure`` argument (a shipped name or a ``.toml`` path)."""
    return arg(..., help=STRUCTURE_HELP, show_default=False)


def format_opt() -> Any:
    """The ``--format`` option (table, CSV or JSON)."""
    return opt(OutputFormat.table, "--format",
               help="output: a rich table (full width when piped), CSV (a header of column names with units, "
                    "one line per row) or one JSON object (keys with units)")


def quiet_flag() -> Any:
    """The ``--quiet`` flag of a long command: no stages on stderr (:func:`vlab.cli.output.stages`)."""
    return flag("--quiet", help="print no stages on stderr (a spinner on a terminal, one line per stage when piped)")


def json_flag(what: str = "the table") -> Any:
    """The ``--json`` flag (= ``--format json``), printing one JSON object instead of ``what``."""
    return flag("--json", help=f"print one JSON object instead of {what} (= --format json)")
