"""Module-scoped fixtures of a shipped structure and its MuJoCo plant, shared by the plant tests.

A test module takes them with ``spec, plant = structure_fixtures("bcc")``: pytest finds fixtures by the
module's names, and each module builds its own plant (module scope), as when it defined them itself.
"""

from __future__ import annotations

import pytest

from vlab.sim import build_plant
from vlab.spec import load_spec


def structure_fixtures(structure: str):
    """The fixtures ``spec`` (``load_spec(structure)``) and ``plant`` (``build_plant(spec)``), module-scoped."""

    @pytest.fixture(scope="module")
    def spec():
        return load_spec(structure)

    @pytest.fixture(scope="module")
    def plant(spec):
        return build_plant(spec)

    return spec, plant
