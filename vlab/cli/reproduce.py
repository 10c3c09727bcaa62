"""``vlab reproduce``: the dissertation's tables regenerated side by side with the published numbers."""

from __future__ import annotations

from . import checks
from .options import PlantKind, flag, opt
from .output import console
from .runtime import expect_output

REPRODUCE_OUT = "out/reproduce"


def reproduce(
    out: str = opt(REPRODUCE_OUT, "--out", help="output folder (its parent must exist)"),
    overwrite: bool = flag("--overwrite", help="replace an existing non-empty output folder"),
    fast: bool = flag("--fast", help="only the quick subset of tables"),
    plant: PlantKind = opt(PlantKind.linear, "--plant",
                           help="plant of the virtual experiments: MuJoCo or the linear FE model (fast)"),
) -> None:
    """Regenerate the dissertation's tables side by side with the published numbers (written atomically)."""
    from ..reproduce import reproduce as run_reproduce

    out_path = checks.out_dir(out, REPRODUCE_OUT, overwrite)
    expect_output(out_path)
    if out == REPRODUCE_OUT:
        out_path.absolute().parent.mkdir(parents=True, exist_ok=True)
    run_reproduce(out_path, fast=fast, plant=plant.value, progress=True, console=console, overwrite=overwrite)
