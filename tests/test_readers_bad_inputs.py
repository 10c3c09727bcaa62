"""Readers refuse corrupted inputs with the exact location of the problem (issue 26, item 5).

The corpus is ``tests/bad_inputs/readers_cases.py``: good files written by
vlab's own writers, corrupted programmatically. Each case must raise the
expected :class:`vlab.errors.VlabError` subclass, with a message that names
the file and the offending field, record, channel or value, and must leave
the folder exactly as it was (no file written, changed or removed).
"""

from __future__ import annotations

import importlib.util
import sys
from collections import Counter
from pathlib import Path

import pytest

from vlab.errors import VlabError

_spec = importlib.util.spec_from_file_location(
    "readers_cases", Path(__file__).parent / "bad_inputs" / "readers_cases.py")
readers_cases = importlib.util.module_from_spec(_spec)
sys.modules["readers_cases"] = readers_cases
_spec.loader.exec_module(readers_cases)
CASES = readers_cases.CASES


def _snapshot(d: Path) -> dict[str, bytes]:
    return {str(p.relative_to(d)): p.read_bytes() for p in sorted(d.rglob("*")) if p.is_file()}


def test_corpus_covers_every_input_kind():
    kinds = Counter(c.kind for c in CASES)
    assert len(CASES) >= 60 and len({c.id for c in CASES}) == len(CASES)
    assert set(kinds) == {"toml", "uff58-time", "uff58-frf", "uff55", "csv", "mjcf"}
    assert min(kinds.values()) >= 10, kinds


@pytest.mark.parametrize("case", CASES, ids=[c.id for c in CASES])
def test_bad_input_is_refused_with_its_location(case, tmp_path):
    d = tmp_path / "in"
    d.mkdir()
    path = case.make(d)
    before = _snapshot(d)
    with pytest.raises(VlabError) as info:
        case.read(path)
    msg = str(info.value)
    assert isinstance(info.value, case.error), f"{type(info.value).__name__}: {msg}"
    assert path.name in msg, msg                      # names the file
    for frag in case.fragments:                       # and the field / record / channel / value
        assert frag in msg, f"{frag!r} not in: {msg}"
    assert _snapshot(d) == before                     # nothing written, changed or removed
