"""Settings shared by the whole test suite."""

from __future__ import annotations

import os


def pytest_configure(config) -> None:
    """Remove ``COLUMNS`` and ``LINES`` from the environment: pytest-xdist's workers set them (80 x 24), and the
    command line's tables follow ``COLUMNS`` when piped, so the tests would see a narrower table than a user's
    pipe gets (tests that need a width set it themselves)."""
    for name in ("COLUMNS", "LINES"):
        os.environ.pop(name, None)
