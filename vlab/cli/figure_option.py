"""The ``--figure FILE`` option of ``vlab modes`` and ``vlab design``: checked before any work; files written atomically."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from ..errors import OptionError

#: File suffixes a figure may have (matplotlib's formats that :mod:`vlab.viz.figures` writes).
SUFFIXES = (".png", ".svg", ".pdf")


def figure_path(figure: str | None, overwrite: bool) -> Path | None:
    """``--figure`` checked: a .png/.svg/.pdf in a writable folder, not replacing a file without ``--overwrite``."""
    from ..io.atomic import check_output_file

    if figure is None:
        return None
    if not str(figure).lower().endswith(SUFFIXES):
        raise OptionError(f"--figure {figure}: give a .png, .svg or .pdf file")
    return check_output_file(figure, overwrite=overwrite, option="--figure")


def write_atomically(path: Path, overwrite: bool, draw: Callable[[Path], object]) -> None:
    """Call ``draw(tmp)`` on a temporary sibling of ``path`` and move it into place when it succeeds."""
    from ..io.atomic import atomic_file

    with atomic_file(path, overwrite=overwrite) as tmp:
        draw(tmp)
