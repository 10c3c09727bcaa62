"""The MJCF round trip through the command line for the frame template, the example files and the shipped
structures (their runs slow): export, edit as docs/mjcf.md says, run, diagnose. The exported file's checks,
the beam template's round trips and the method are in test_mjcf_roundtrip.py (split in two files so that
pytest-xdist's ``--dist loadfile`` runs the round trips on two workers).
"""

from __future__ import annotations

import pytest

from test_mjcf_roundtrip import BEAM_SOURCES, ROUND_TRIPS, round_trip


@pytest.mark.parametrize(("source", "edit"), [p for p in ROUND_TRIPS if p.values[0] not in BEAM_SOURCES])
def test_round_trip_names_the_edit(source, edit, tmp_path):
    round_trip(source, edit, tmp_path)
