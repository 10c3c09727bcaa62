"""The ``vlab`` program: the typer app, its root options, and its commands in the order ``vlab --help`` lists."""

from __future__ import annotations

import os

import typer

from .crosscheck import crosscheck
from .design import design
from .diagnose import detectability, diagnose
from .experiment import experiment, export_mjcf_cmd
from .init import init_cmd
from .modes import modes
from .options import flag
from .reproduce import reproduce
from .robustness import robustness
from .runtime import EPILOG, STATE, VlabCommand, VlabGroup
from .update import update_cmd

app = typer.Typer(
    cls=VlabGroup,
    add_completion=False,
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    help="vlab: a virtual laboratory for active vibration control of flexible structures.",
    epilog=EPILOG,
)


@app.callback(epilog=EPILOG)
def _root(debug: bool = flag("--debug", help="show the Python traceback of an error"),
          allow_outside_inputs: bool = flag(
              "--allow-outside-inputs", help="read files that a structure file ([reference]) or an MJCF model "
                                             "(<include>, assets) names outside its own folder (default: refused)"),
          ) -> None:
    """vlab: a virtual laboratory for active vibration control of flexible structures."""
    from ..io.confine import ALLOW_ENV

    STATE["debug"] = debug
    if allow_outside_inputs:
        os.environ[ALLOW_ENV] = "1"  # read by the loaders, here and in worker processes; restored after the command


#: The commands as (name, function), in the order of ``vlab --help``.
COMMANDS = (("modes", modes), ("design", design), ("experiment", experiment), ("crosscheck", crosscheck),
            ("export-mjcf", export_mjcf_cmd), ("init", init_cmd), ("reproduce", reproduce), ("diagnose", diagnose),
            ("detectability", detectability), ("robustness", robustness), ("update", update_cmd))
for _name, _command in COMMANDS:
    app.command(_name, cls=VlabCommand)(_command)


def main() -> None:  # pragma: no cover - console entry
    """Run the ``vlab`` command line (the console script's entry point)."""
    app()
