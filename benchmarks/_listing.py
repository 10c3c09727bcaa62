"""What the speed benchmarks share: the machine's load and the listing they print and write."""

from __future__ import annotations

import time
from pathlib import Path

from vlab.io.atomic import atomic_file


def best_time(fn, repeats: int = 3) -> float:
    """The shortest wall time [s] of ``repeats`` calls of ``fn()`` (the least disturbed run)."""
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def load_average() -> str:
    """``/proc/loadavg`` as one line (1, 5 and 15 min load, runnable/total tasks, last pid)."""
    with open("/proc/loadavg") as f:
        return f.read().strip()


def emit(lines: list[str], out: str | None) -> int:
    """Print the listing ``lines`` and, with ``out``, write it there whole (atomically: an interrupted run
    leaves the former file). Returns 0, the script's exit status."""
    text = "\n".join(lines)
    print(text)
    if out:
        with atomic_file(Path(out), overwrite=True) as tmp:
            tmp.write_text(text + "\n")
    return 0


def vlab_commit() -> str:
    """The commit of the vlab checkout this benchmark imports (``git describe --always --dirty``: ``-dirty``
    when its tracked files differ from the commit), or ``unknown`` outside a git checkout."""
    import subprocess

    import vlab

    root = Path(vlab.__file__).resolve().parents[1]
    try:
        out = subprocess.run(["git", "-C", str(root), "describe", "--always", "--dirty", "--abbrev=7"],
                             capture_output=True, text=True, timeout=30)
    except (OSError, subprocess.TimeoutExpired):
        return "unknown"
    return out.stdout.strip() if out.returncode == 0 and out.stdout.strip() else "unknown"


def command_header(script: str, argv: list[str]) -> list[str]:
    """The listing's first lines: the command as run (``python benchmarks/<script> <argv>``) and the commit."""
    return [f"# python benchmarks/{script} " + " ".join(argv), f"# vlab at {vlab_commit()}"]
