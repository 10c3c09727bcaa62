"""``vlab init``: a commented structure file to edit and run like bcc or grid."""

from __future__ import annotations

from enum import Enum

from rich.markup import escape

from .options import arg, flag
from .output import console


class TemplateKind(str, Enum):
    """The templates of ``vlab init``."""

    beam = "beam"
    frame = "frame"
    bcc = "bcc"
    grid = "grid"


def init_cmd(
    kind: TemplateKind = arg(..., help="template: beam (clamped-free beam, two coils), frame (planar "
                                                  "portal frame, two coils), or a copy of bcc or grid",
                                        show_default=False),
    path: str = arg(..., help="structure file to write, ending in .toml; its folder must exist",
                               show_default=False),
    overwrite: bool = flag("--overwrite", help="replace an existing file"),
) -> None:
    """Write a commented structure file (with its test and design tables) to edit and run like bcc or grid."""
    from ..templates import write_template

    written = write_template(kind.value, path, overwrite=overwrite)
    console.print(f"wrote {escape(str(written))}; try `vlab modes {escape(str(written))}`", highlight=False)
