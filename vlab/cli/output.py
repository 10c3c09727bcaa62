"""What the command line prints: stdout's and stderr's consoles, error and warning lines, JSON, tables and CSV."""

from __future__ import annotations

import json
import sys
import time
from contextlib import contextmanager
from typing import Any, Iterable

import numpy as np
from rich.console import Console
from rich.markup import escape

#: Width of stdout's console when it is not a terminal (piped, redirected, captured) and COLUMNS is not set:
#: wide enough that no table cell is cut and no row wraps (a line is as long as its content).
PIPED_WIDTH = 10_000


class StdoutConsole(Console):
    """Console of stdout: the terminal's width on a terminal; when piped, :data:`PIPED_WIDTH` (no cut cells).

    ``COLUMNS`` is read when printing, not when the console is made: rich fixes the width it finds in the
    environment at construction, so a module imported while ``COLUMNS`` happened to be set would keep that
    width for the whole process.
    """

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        explicit = kwargs.get("width")
        super().__init__(*args, **kwargs)
        if explicit is None:
            self._width = None

    @property
    def size(self):
        from rich.console import ConsoleDimensions

        dims = super().size
        columns = self._environ.get("COLUMNS")
        if self._width is None and not self.is_terminal and not (columns and columns.isdigit()):
            return ConsoleDimensions(PIPED_WIDTH, dims.height)
        return dims

    @size.setter
    def size(self, new_size) -> None:
        Console.size.fset(self, new_size)


console = StdoutConsole()
err_console = Console(stderr=True)


def error_line(text: str) -> None:
    """``error: <text>`` on stderr, ``text`` escaped (rich markup never eats a value such as ``[0.0]``)."""
    err_console.print(f"[bold red]error:[/] {escape(text)}", soft_wrap=True, highlight=False)


def print_warnings(warnings: Iterable[str], label: str = "warning") -> None:
    """Each of ``warnings`` as one line ``<label>: <warning>`` on stderr (escaped)."""
    for w in warnings:
        err_console.print(f"[bold yellow]{label}:[/] {escape(w)}", soft_wrap=True, highlight=False)


def print_json(obj: dict[str, Any]) -> None:
    """``obj`` as one indented JSON object on stdout (numpy arrays and scalars as lists and numbers)."""

    def default(o: Any) -> Any:
        if isinstance(o, np.ndarray):
            return o.tolist()
        if isinstance(o, (np.floating, np.integer)):
            return o.item()
        raise TypeError(f"not JSON serialisable: {type(o).__name__}")

    sys.stdout.write(json.dumps(obj, default=default, indent=2) + "\n")


def print_rows(fmt: str, rows: list[dict], columns, title: str | None = None) -> None:
    """``rows`` as a rich table on stdout (``fmt == "table"``) or as CSV (``"csv"``)."""
    from ..io.tabular import rich_table, write_csv

    if fmt == "csv":
        write_csv(rows, columns, sys.stdout)
    else:
        console.print(rich_table(rows, columns, title=title))


@contextmanager
def stages(label: str, first: str, *, quiet: bool = False):
    """Show the stages of a long command on stderr, yielding a callable that takes the next stage's name.

    On a terminal: a spinner with the current stage and the elapsed time (cleared at the end); when stderr is
    piped or redirected: one line per stage, ``"<label>: <stage> (<t> s)"``, so that a log shows where a long
    run is; with ``quiet``: nothing.

    Parameters
    ----------
    label : str
        The command, e.g. ``"diagnose"``.
    first : str
        The first stage's name.
    quiet : bool
        Print nothing (``--quiet``, or an output format that owns stdout and stderr).
    """
    if quiet:
        yield lambda stage: None
        return
    if err_console.is_terminal:
        from rich.progress import Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

        with Progress(SpinnerColumn(), TextColumn(f"{escape(label)}: {{task.description}}"), TimeElapsedColumn(),
                      console=err_console, transient=True) as bar:
            task = bar.add_task(escape(first), total=None)
            yield lambda stage: bar.update(task, description=escape(str(stage)))
        return
    t0 = time.perf_counter()

    def line(stage) -> None:
        sys.stderr.write(f"{label}: {stage} ({time.perf_counter() - t0:.0f} s)\n")
        sys.stderr.flush()

    line(first)
    yield line
