"""Every help text is shown as written: rich markup never eats a bracketed word such as ``[test]``."""

from __future__ import annotations

import click
import typer
from rich.text import Text

from vlab.cli import app


def _commands(group: click.Command, path: str = "vlab"):
    yield path, group
    for name, sub in getattr(group, "commands", {}).items():
        yield from _commands(sub, f"{path} {name}")


def _unescaped(text: str) -> str:
    return text.replace("\\[", "[")


def test_no_help_text_loses_a_bracketed_word():
    root = typer.main.get_command(app)
    checked = 0
    for path, cmd in _commands(root):
        for param in cmd.params:
            help_text = getattr(param, "help", None)
            if not help_text:
                continue
            shown = Text.from_markup(help_text).plain
            assert shown == _unescaped(help_text), f"{path} {param.name}: {shown!r}"
            checked += 1
    assert checked > 50


def test_the_robustness_argument_names_its_tables():
    from typer.testing import CliRunner

    res = CliRunner().invoke(app, ["robustness", "--help"], env={"COLUMNS": "200"})
    assert res.exit_code == 0
    assert "[instrumentation] and [test]" in res.output
