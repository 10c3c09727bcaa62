"""The workflow pages run as a reader would follow them: every ``$`` line of the page's shell blocks, in page
order, in an empty folder, through ``bash`` with the installed ``vlab`` first on ``PATH``; each must end with
status 0. The quick commands of every page run in the default suite (test_docs_commands.py); these pages
record, diagnose and update (minutes), so they run with the slow tests.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent

#: The pages whose whole workflow runs here (each minutes on two cores).
WORKFLOWS = ("docs/tutorials/updating-the-model.md", "docs/tutorials/diagnosing-a-recording.md", "docs/mjcf.md")

FENCE = re.compile(r"^```(\w*)")


def prompt_lines(text: str) -> list[tuple[int, str]]:
    """``(line number, command)`` of every ``$ `` line in the page's console/shell blocks, continuation lines
    (ending in a backslash) joined."""
    out, block, inside, pending = [], False, False, None
    for n, line in enumerate(text.splitlines(), 1):
        m = FENCE.match(line)
        if m:  # a fence opens a block (a shell one by its language) or closes the open one
            block = not block
            inside = block and m.group(1) in ("", "console", "bash", "shell", "sh", "text")
            continue
        if not inside:
            continue
        if pending is not None:
            pending = (pending[0], pending[1] + " " + line.strip().rstrip("\\").strip())
            if not line.rstrip().endswith("\\"):
                out.append(pending)
                pending = None
            continue
        if line.startswith("$ "):
            cmd = line[2:].strip()
            if cmd.endswith("\\"):
                pending = (n, cmd.rstrip("\\").strip())
            else:
                out.append((n, cmd))
    return out


def test_prompt_lines_are_read_with_their_continuations():
    page = ("text\n```console\n$ vlab a \\\n    --b c\nprinted\n$ sed 's|x|y|' f > g\n```\n$ not in a block\n"
            "```toml\n$ not shell\n```\n```\n$ vlab d\n```\n")
    assert prompt_lines(page) == [(3, "vlab a --b c"), (6, "sed 's|x|y|' f > g"), (13, "vlab d")]


@pytest.mark.slow
@pytest.mark.parametrize("page", WORKFLOWS)
def test_a_workflow_page_runs_as_shown(page, tmp_path):
    env = dict(os.environ, PATH=str(Path(sys.executable).parent) + os.pathsep + os.environ.get("PATH", ""),
               MPLBACKEND="Agg")
    lines = prompt_lines((ROOT / page).read_text(encoding="utf-8"))
    assert lines, f"{page}: no $ line"
    # each line runs in its own shell: a page whose later lines rely on an earlier cd or export would need one
    carried = [f"{page}:{n}: {cmd}" for n, cmd in lines if cmd.split()[0] in ("cd", "export", "source", ".")]
    assert not carried, f"lines whose effect would not reach the next line here: {carried}"
    for n, cmd in lines:
        run = subprocess.run(["bash", "-c", cmd], cwd=tmp_path, env=env, capture_output=True, text=True,
                             timeout=900)
        assert run.returncode == 0, f"{page}:{n}: {cmd} exited {run.returncode}:\n{(run.stdout + run.stderr)[-2000:]}"
