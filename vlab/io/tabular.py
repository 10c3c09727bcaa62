"""Rows of a command's result printed as a rich table or as CSV (``--format table|csv``).

One description of the columns serves both: each :class:`Column` has a
machine name with its unit (the CSV header, e.g. ``frequency_hz``) and a
header for people with the unit in brackets (e.g. ``f [Hz]``). Cells hold the
raw values; the table formats them, the CSV writes them with full precision
(``repr`` of a float; empty for None or NaN).
"""

from __future__ import annotations

import csv
import math
import sys
from dataclasses import dataclass
from typing import Any, Iterable, TextIO

from rich.markup import escape
from rich.table import Table

#: Output formats of the commands that print tables.
FORMATS = ("table", "csv", "json")


@dataclass(frozen=True)
class Column:
    """One column of a result table.

    Attributes
    ----------
    key : str
        Machine name with the unit as suffix (``frequency_hz``, ``damping_ratio``,
        ``error_pct``): the CSV header and the key of the row dicts.
    header : str
        Header of the rich table, with the unit in brackets (``f [Hz]``).
    fmt : str
        Format spec of a number in the table (``".3f"``); text is shown as is.
    justify : str
        ``"right"`` or ``"left"`` in the table.
    """

    key: str
    header: str
    fmt: str = ""
    justify: str = "right"

    def text(self, value: Any) -> str:
        """The table cell of ``value``: '' for None or NaN, numbers formatted with :attr:`fmt`."""
        if value is None or (isinstance(value, float) and math.isnan(value)):
            return ""
        if isinstance(value, (int, float)) and not isinstance(value, bool) and self.fmt:
            return format(value, self.fmt)
        return str(value)


def rich_table(rows: Iterable[dict], columns: list[Column], *, title: str | None = None) -> Table:
    """A rich :class:`~rich.table.Table` of ``rows`` (dicts keyed by :attr:`Column.key`).

    Parameters
    ----------
    rows : iterable of dict
        One dict per row; a missing key is an empty cell.
    columns : list of Column
        The columns, in order.
    title : str, optional
        Plain-text title (escaped: brackets are not read as markup).

    Returns
    -------
    rich.table.Table
    """
    t = Table(title=escape(title) if title else None, min_width=len(title) if title else None)
    for c in columns:
        t.add_column(escape(c.header), justify=c.justify, overflow="fold")
    for r in rows:
        t.add_row(*(escape(c.text(r.get(c.key))) for c in columns))
    return t


def write_csv(rows: Iterable[dict], columns: list[Column], out: TextIO | None = None) -> None:
    """Write ``rows`` as CSV: a header of the column keys (units in the names), then one line per row.

    Floats are written with ``repr`` (round-trip precision); None and NaN as
    empty fields; numpy scalars as Python numbers.

    Parameters
    ----------
    rows : iterable of dict
        One dict per row, keyed by :attr:`Column.key`.
    columns : list of Column
    out : text stream, optional
        Default ``sys.stdout``.
    """
    w = csv.writer(out or sys.stdout, lineterminator="\n")
    w.writerow([c.key for c in columns])
    for r in rows:
        w.writerow([_csv_cell(r.get(c.key)) for c in columns])


def _csv_cell(v: Any) -> str:
    if hasattr(v, "item") and not isinstance(v, (str, bytes)):
        v = v.item()
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return ""
    if isinstance(v, float):
        return repr(v)
    return str(v)
