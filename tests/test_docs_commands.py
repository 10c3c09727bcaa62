"""Every ``vlab`` command line shown in the documentation is one the program accepts.

README and the pages of ``docs/`` paste command lines; when an option is renamed or a choice removed,
the pasted line goes stale silently. This test takes each ``vlab`` command out of the fenced code
blocks of README and of every page (:func:`shown_commands`) and lets the command's own parser, typer's
click command for :data:`vlab.cli.app`, read it (:func:`check`): an unknown command or option, a missing
argument, a bad choice and a value of the wrong type are usage errors. Nothing runs: ``make_context``
parses the arguments and calls no command. An option name the parser still reads but ``--help`` no
longer shows (a former name kept as a hidden alias) is refused too: a page shows the current name.

The checks run on made-up page text as well, so that they can fail.
"""

from __future__ import annotations

import re
import shlex
from pathlib import Path
from typing import NamedTuple

import pytest
import typer

from vlab.cli import app

ROOT = Path(__file__).resolve().parent.parent

#: The languages of the fenced blocks that hold command lines ("" is a fence without one).
SHELL_LANGUAGES = frozenset({"", "bash", "console", "sh", "shell", "shell-session"})
FENCE = re.compile(r"^\s*(?P<fence>`{3,}|~{3,})\s*(?P<info>.*)$")
#: A ``vlab`` command at the start of a line or after a shell operator (``&&``, ``||``, ``;``, ``|``),
#: environment assignments before it allowed.
VLAB_AT_COMMAND = re.compile(r"(?:^|&&|\|\||;|\|)\s*(?:\w+=\S*\s+)*vlab(?:\s|$)")
#: An environment assignment before a command (``NAME=value vlab ...``).
ASSIGNMENT = re.compile(r"^[A-Za-z_]\w*=")
#: The file-descriptor number glued to a redirection (``2>/dev/null``, ``2>&1``), taken off before splitting.
FD_NUMBER = re.compile(r"(?<=\s)\d+(?=[<>])")
#: An angle-bracket placeholder (``<recording>``): read as the bare word, not as a shell redirection.
ANGLE_PLACEHOLDER = re.compile(r"<([A-Za-z][\w.-]*)>")
#: Placeholders a page writes for a value of the reader's own, and what the check reads in their place.
#: A placeholder for a path (``FILE.toml``, ``DIR``, ``PLANT.xml``, ``<recording>``) needs no entry:
#: every path is a plain string to the parser (whether the file exists is checked when the command
#: runs, not while it parses). Only a placeholder for a value the parser checks needs one: a choice.
PLACEHOLDERS = {
    "X": "mfdrf",  # --controller X: any controller
}
#: Shell operators that end one command (``vlab`` may follow or precede another command).
SEPARATORS = frozenset({"&&", "||", ";", "|", "&"})

#: click's UsageError (typer's own copy of click): the base of BadParameter, NoSuchOption and
#: MissingParameter.
USAGE_ERROR = next(c for c in typer.BadParameter.__mro__ if c.__name__ == "UsageError")
GROUP = typer.main.get_command(app)


class Shown(NamedTuple):
    """A ``vlab`` command line shown on a page.

    Attributes
    ----------
    line : int
        The line of the page where the command starts (1-based).
    args : tuple of str
        The words after ``vlab``, as the shell passes them (placeholders replaced).
    """

    line: int
    args: tuple[str, ...]


def _language(info: str) -> str:
    """The language of a fence's info string: ``bash`` of ```` ```bash ```` and of ```` ```{code-block} bash ````."""
    words = info.strip().lower().split()
    if words and words[0] in ("{code-block}", "{code}", "{sourcecode}"):
        words = words[1:]
    return words[0] if words else ""


def _logical_lines(block: list[tuple[int, str]], prompted: bool) -> list[tuple[int, str]]:
    """The command lines of a code block: ``\\`` continuations joined, output lines left out.

    In a block with a ``$`` prompt only the prompted lines are commands (the rest is their output);
    in a block without one every line is.
    """
    out, i = [], 0
    while i < len(block):
        number, text = block[i]
        i += 1
        text = text.strip()
        if prompted:
            if not text.startswith("$ "):
                continue
            text = text[2:]
        while text.endswith("\\") and i < len(block):
            follow = block[i][1].strip()
            if prompted and follow.startswith("> "):  # the shell's continuation prompt
                follow = follow[2:]
            text = text[:-1] + " " + follow
            i += 1
        out.append((number, text))
    return out


def _vlab_commands(text: str) -> list[tuple[str, ...]]:
    """The ``vlab`` commands of one shell line: the words after ``vlab``, comments and redirections left out."""
    text = FD_NUMBER.sub("", ANGLE_PLACEHOLDER.sub(r"\1", text))
    lexer = shlex.shlex(text, posix=True, punctuation_chars=True)
    lexer.whitespace_split = True
    commands, words, redirect = [], [], False
    for word in [*lexer, ";"]:
        if redirect:  # the target of a redirection
            redirect = False
        elif word in SEPARATORS:
            while words and ASSIGNMENT.match(words[0]):
                words.pop(0)
            if words and words[0] == "vlab":
                commands.append(tuple(PLACEHOLDERS.get(w, w) for w in words[1:]))
            words = []
        elif word and set(word) <= set("<>&") and set(word) & set("<>"):
            redirect = True
        else:
            words.append(word)
    return commands


def shown_commands(text: str) -> list[Shown]:
    """The ``vlab`` commands in the fenced shell blocks of a Markdown text.

    Parameters
    ----------
    text : str
        The page (Markdown, MyST).

    Returns
    -------
    list of Shown
        Each command with its line, in the page's order: lines starting with ``vlab`` or ``$ vlab`` and
        ``vlab`` after a shell operator (``... && vlab experiment``), in blocks of a shell language or of
        none (:data:`SHELL_LANGUAGES`).
    """
    found, fence, block, language = [], None, [], ""
    for number, line in enumerate(text.splitlines(), 1):
        m = FENCE.match(line)
        if fence is None:
            if m:
                fence, language, block = m["fence"], _language(m["info"]), []
            continue
        if m and m["fence"][0] == fence[0] and len(m["fence"]) >= len(fence) and not m["info"].strip():
            if language in SHELL_LANGUAGES:
                prompted = any(t.strip().startswith("$ ") for _, t in block)
                for start, command in _logical_lines(block, prompted):
                    if VLAB_AT_COMMAND.search(command):
                        try:
                            found.extend(Shown(start, args) for args in _vlab_commands(command))
                        except ValueError as exc:  # an unclosed quote
                            raise ValueError(f"line {start}: {command!r}: {exc}") from None
            fence = None
            continue
        block.append((number, line))
    return found


def _shown_option_names(command) -> set[str]:
    """The option names ``--help`` shows for a click command (a hidden alias left out)."""
    names = set()
    for p in command.params:
        if getattr(p, "param_type_name", "") == "option" and not getattr(p, "hidden", False):
            names.update(p.opts, p.secondary_opts)
    return names | {"--help"}


def _unshown_options(words, command) -> list[str]:
    """The words of ``words`` that name an option ``command``'s ``--help`` does not show."""
    shown = _shown_option_names(command)
    bad = []
    for w in words:
        if w == "--":
            break
        if w.startswith("-") and not re.match(r"^-\.?\d", w) and w.split("=", 1)[0] not in shown:
            bad.append(w)
    return bad


def check(args) -> str | None:
    """Whether the CLI accepts a command line, parsed and not run.

    Parameters
    ----------
    args : sequence of str
        The words after ``vlab``.

    Returns
    -------
    str or None
        None when the line parses; else why not (the parser's usage error, or an option name that
        ``--help`` does not show).
    """
    args = list(args)
    helping = "--help" in args
    if not args or args == ["--help"]:  # the program's help
        return None
    if helping:  # the help reads no other argument: the command and its option names must exist
        args = [a for a in args if a != "--help"]
    try:
        ctx = GROUP.make_context("vlab", list(args), resilient_parsing=helping)  # the parser eats its list
        rest = [*getattr(ctx, "_protected_args", []), *ctx.args]  # the command and its words
        bad = _unshown_options(args[: len(args) - len(rest)], GROUP)
        if not rest:
            return None if helping and not bad else f"no command, or root options not shown by --help: {bad}"
        name, sub, sub_args = GROUP.resolve_command(ctx, rest)
        if sub is None:  # resilient parsing (a help line) returns no command instead of refusing
            return f"No such command {rest[0]!r}"
        sub.make_context(name, list(sub_args), parent=ctx, resilient_parsing=helping)
    except USAGE_ERROR as exc:
        return exc.format_message()
    bad += _unshown_options(sub_args, sub)
    return f"options not shown by --help: {bad}" if bad else None


def documented() -> list[tuple[str, Shown]]:
    """Every ``vlab`` command shown in README and the pages of ``docs/`` (the build folder left out)."""
    pages = [ROOT / "README.md", *sorted(p for p in (ROOT / "docs").rglob("*.md") if "_build" not in p.parts)]
    found = []
    for p in pages:
        where = p.relative_to(ROOT).as_posix()
        try:
            found.extend((where, shown) for shown in shown_commands(p.read_text(encoding="utf-8")))
        except ValueError as exc:
            raise ValueError(f"{where}: {exc}") from None
    return found


DOCUMENTED = documented()


def test_the_docs_show_commands():
    # the tutorials alone show dozens; an extraction that finds a handful is broken
    assert len(DOCUMENTED) >= 40, DOCUMENTED
    assert {s.args[0] for _, s in DOCUMENTED if s.args} >= {
        "modes", "design", "experiment", "export-mjcf", "init", "diagnose", "reproduce", "crosscheck", "update"}
    # README's quick start: the vlab command after `&& `
    readme = (ROOT / "README.md").read_text(encoding="utf-8").splitlines()
    quick = next(n for n, line in enumerate(readme, 1) if "&& vlab " in line)
    assert ("README.md", quick) in {(where, s.line) for where, s in DOCUMENTED}


@pytest.mark.parametrize("where,shown", DOCUMENTED, ids=[f"{w}:{s.line}" for w, s in DOCUMENTED])
def test_documented_command_parses(where, shown):
    problem = check(shown.args)
    assert problem is None, f"{where}:{shown.line}: vlab {shlex.join(shown.args)}: {problem}"


PAGE = """\
# A made-up page

Prose mentioning vlab modes bcc is not a command.

```bash
python3 -m venv .venv && . .venv/bin/activate && pip install -e . && vlab experiment
vlab modes bcc --n 6   # a comment
vlab experiment --controller lqdrf \\
    --seed 3 > run.log 2>&1
```

```console
$ OMP_NUM_THREADS=2 vlab design bcc --controller X --json | python -m json.tool
vlab [Hz]   this output line is no command
$ vlab diagnose --structure FILE.toml --recording <recording> --out DIR
```

```python
# vlab experiment --plant nowhere
```

```
vlab crosscheck grid
```

~~~{code-block} console
$ vlab init beam my_beam.toml
~~~

```{toctree}
vlab modes nothing
```
"""


def test_the_extractor_reads_operators_continuations_prompts_and_placeholders():
    assert shown_commands(PAGE) == [
        Shown(6, ("experiment",)),
        Shown(7, ("modes", "bcc", "--n", "6")),
        Shown(8, ("experiment", "--controller", "lqdrf", "--seed", "3")),
        Shown(13, ("design", "bcc", "--controller", "mfdrf", "--json")),
        Shown(15, ("diagnose", "--structure", "FILE.toml", "--recording", "recording", "--out", "DIR")),
        Shown(23, ("crosscheck", "grid")),
        Shown(27, ("init", "beam", "my_beam.toml")),
    ]
    assert all(check(s.args) is None for s in shown_commands(PAGE))


@pytest.mark.parametrize("line,why", [
    ("vlab experiment --controler mfdrf", "No such option"),                # misspelt option
    ("vlab experiment --delay-samples 2", "not shown"),                     # a former name, a hidden alias
    ("vlab design bcc --controller pid", "Invalid value"),                  # not a choice
    ("vlab modes bcc --n six", "Invalid value"),                            # not an integer
    ("vlab modes", "Missing argument"),                                     # missing argument
    ("vlab experiment bcc grid", "unexpected extra argument"),              # one argument too many
    ("vlab simulate bcc", "No such command"),                               # no such command
    ("vlab simulate --help", "No such command"),                            # the help of no such command
    ("vlab modes --help --shapez", "not shown"),                            # the help of a misspelt option
    ("vlab --debugg modes bcc", "No such option"),                          # a misspelt root option
])
def test_a_stale_command_line_is_caught(line, why):
    page = f"Some prose.\n\n```console\n$ {line}   # a comment\nits output\n```\n"
    shown = shown_commands(page)
    assert shown == [Shown(4, tuple(line.split()[1:]))]
    problem = check(shown[0].args)
    assert problem is not None and why.lower() in problem.lower(), problem


def test_an_unclosed_quote_names_its_line():
    with pytest.raises(ValueError, match="line 2"):
        shown_commands("```\nvlab experiment --out 'run\n```\n")


def test_help_lines_parse():
    assert check(["--help"]) is None
    assert check(["modes", "--help"]) is None
    assert check(["--debug", "experiment", "--plant", "linear"]) is None


#: The commands a page shows that run in seconds; the others (experiments, diagnoses, updates, reproductions)
#: run for tens of seconds to minutes each and are exercised by their own tests.
QUICK = frozenset({"modes", "design", "init", "export-mjcf", "crosscheck", "--help"})


def _quick_by_page() -> dict[str, list[Shown]]:
    """Each page's quick commands (:data:`QUICK`), in page order; a command that reads a file a command of
    the page did not make (a recording) is left out."""
    pages: dict[str, list[Shown]] = {}
    for where, shown in DOCUMENTED:
        if shown.args and shown.args[0] in QUICK:
            pages.setdefault(where, []).append(shown)
    return pages


QUICK_PAGES = _quick_by_page()


@pytest.mark.parametrize("where", sorted(QUICK_PAGES))
def test_documented_quick_commands_run(where, tmp_path, monkeypatch):
    """Each page's quick commands run, in the page's order, in an empty folder (so that a command may read
    what an earlier one of the page wrote, as a reader following the page would), and end without error."""
    from typer.testing import CliRunner

    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MPLBACKEND", "Agg")
    runner = CliRunner()
    for shown in QUICK_PAGES[where]:
        out = runner.invoke(app, list(shown.args))
        assert out.exit_code == 0, (f"{where}:{shown.line}: vlab {shlex.join(shown.args)} exited "
                                    f"{out.exit_code}:\n{out.output[-2000:]}\n{out.exception!r}")
