"""Every ``vlab`` command line shown in the documentation parses with the current CLI.

The tutorials (``docs/``) and README paste real command lines; when an option is renamed or a
choice removed, the pasted line goes stale silently. This test takes each command line out of the
fenced code blocks (``$ vlab ...`` or ``vlab ...``, comments stripped) and lets the command's own
parser (typer's click command for :data:`vlab.cli.app`) read it: unknown options, bad choices and
missing arguments raise click's usage errors. Nothing is run (``make_context`` only parses).
"""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest
import typer

from vlab.cli import app

ROOT = Path(__file__).resolve().parent.parent
FENCE = re.compile(r"^(```|~~~)")
#: click's UsageError (from typer 0.26 on, typer's own copy of click): the base of BadParameter,
#: NoSuchOption and MissingParameter.
USAGE_ERROR = next(c for c in typer.BadParameter.__mro__ if c.__name__ == "UsageError")


def command_lines(text: str) -> list[str]:
    """The ``vlab`` command lines inside the fenced code blocks of a Markdown text."""
    lines, inside = [], False
    for line in text.splitlines():
        if FENCE.match(line.strip()):
            inside = not inside
            continue
        if not inside:
            continue
        s = line.strip()
        if s.startswith("$ "):
            s = s[2:]
        for part in s.split("&&"):
            part = part.strip()
            if part.startswith("vlab ") or part == "vlab":
                lines.append(part)
    return lines


def parse(line: str) -> None:
    """Parse one command line with the CLI's own parser; raise its usage error if it does not parse."""
    args = shlex.split(line, comments=True)[1:]
    helping = "--help" in args  # the help needs no arguments: check that the command exists
    args = [a for a in args if a != "--help"]
    group = typer.main.get_command(app)
    ctx = group.make_context("vlab", args, resilient_parsing=helping)
    rest = [*getattr(ctx, "_protected_args", []), *ctx.args]
    if not rest:  # "vlab --help", or a bare "vlab" (which prints the help)
        return
    sub = group.get_command(ctx, rest[0])
    if sub is None:
        raise ValueError(f"{line!r}: no command {rest[0]!r}")
    sub.make_context(rest[0], rest[1:], parent=ctx, resilient_parsing=helping)


def documented_lines() -> list[tuple[str, str]]:
    files = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
    return [(f.relative_to(ROOT).as_posix(), line) for f in files if "_build" not in f.parts
            for line in command_lines(f.read_text(encoding="utf-8"))]


DOCUMENTED = documented_lines()


def test_the_docs_show_commands():
    # the tutorials alone show more than a dozen; an extraction that finds none is broken
    assert len(DOCUMENTED) >= 15, DOCUMENTED
    assert {line.split()[1] for _, line in DOCUMENTED if len(line.split()) > 1} >= {
        "modes", "design", "experiment", "export-mjcf", "diagnose", "reproduce", "crosscheck"}


@pytest.mark.parametrize("where,line", DOCUMENTED, ids=[f"{w}:{ln}" for w, ln in DOCUMENTED])
def test_documented_command_parses(where, line):
    parse(line)


@pytest.mark.parametrize("line", [
    "vlab experiment --controler mfdrf",           # misspelt option
    "vlab design bcc --controller pid",            # not a choice
    "vlab modes",                                  # missing argument
    "vlab simulate bcc",                           # no such command
    "vlab simulate --help",                        # the help of no such command
])
def test_a_stale_command_line_is_caught(line):
    text = f"Some prose.\n\n```\n$ {line}   # a comment\nits output\n```\n"
    assert command_lines(text) == [f"{line}   # a comment"]
    with pytest.raises((USAGE_ERROR, ValueError)):
        parse(command_lines(text)[0])
