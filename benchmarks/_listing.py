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
