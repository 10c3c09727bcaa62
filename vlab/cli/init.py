"""``vlab init``: a commented structure file to edit and run like bcc or grid."""

from __future__ import annotations

from enum import Enum
from pathlib import Path

from rich.markup import escape

from . import checks
from .options import arg, flag, opt
from .output import console


class TemplateKind(str, Enum):
    """The templates of ``vlab init``."""

    beam = "beam"
    frame = "frame"
    bcc = "bcc"
    grid = "grid"
    test = "test"


def init_cmd(
    kind: TemplateKind = arg(..., help="template: beam (clamped-free beam, two coils), frame (planar "
                                                  "portal frame, two coils), a copy of bcc or grid, or test (the "
                                                  "setup of a test, for `vlab diagnose --test`)",
                                        show_default=False),
    path: str = arg(..., help="structure file to write, ending in .toml; its folder must exist",
                               show_default=False),
    overwrite: bool = flag("--overwrite", help="replace an existing file"),
    structure: str = opt(None, "--structure", metavar="<bcc|grid|FILE.toml>",
                         help="test: the structure tested (default: the --from recording's, else bcc)"),
    recording: str = opt(None, "--from", metavar="<recording.uff>",
                         help="test: take the values from a vlab recording's metadata sidecar"),
) -> None:
    """Write a commented structure file to edit and run like bcc or grid, or a test's setup (`init test`).

    A structure file carries its test and design tables; a test's setup describes a recording without
    vlab's sidecar, diagnosed with `vlab diagnose --test`."""
    from ..errors import OptionError
    from ..templates import write_template, write_test_setup

    if kind is not TemplateKind.test:
        if structure is not None or recording is not None:
            raise OptionError("--structure and --from belong to `vlab init test`")
        written = write_template(kind.value, path, overwrite=overwrite)
        console.print(f"wrote {escape(str(written))}; try `vlab modes {escape(str(written))}`", highlight=False)
        return
    checks.input_file("--from", recording)
    if structure is None and recording is not None:
        from ..io.uff_files import read_sidecar

        structure = read_sidecar(Path(recording)).get("structure")
    written = write_test_setup(path, structure or "bcc", recording=recording, overwrite=overwrite)
    console.print(f"wrote {escape(str(written))}; edit it, then `vlab diagnose --test {escape(str(written))} "
                  "--recording FILE`", highlight=False)
