"""Readers refuse corrupted inputs with the exact location of the problem.

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


def test_a_file_named_outside_is_not_read_nor_echoed_and_an_option_allows_it(tmp_path, monkeypatch):
    """A structure file naming /etc/hostname is refused before it is opened: its content is not in the message;
    the explicit allowance (environment of ``vlab --allow-outside-inputs``) reads it."""
    from vlab.errors import SpecError
    from vlab.io.confine import ALLOW_ENV
    from vlab.spec import load_spec

    host = Path("/etc/hostname")
    if not host.is_file() or not host.read_text().strip():
        pytest.skip("no /etc/hostname here")
    p = tmp_path / "s.toml"
    p.write_text(readers_cases.with_reference(readers_cases.BCC_TOML, '"/etc/hostname"'))
    monkeypatch.delenv(ALLOW_ENV, raising=False)
    with pytest.raises(SpecError) as info:
        load_spec(p)
    assert "reaches outside" in str(info.value)
    assert host.read_text().splitlines()[0].strip() not in str(info.value).replace("/etc/hostname", "")
    assert load_spec(p, allow_outside=True).reference["frequencies"] == "/etc/hostname"
    monkeypatch.setenv(ALLOW_ENV, "1")
    assert load_spec(p).reference["frequencies"] == "/etc/hostname"


def test_files_beside_the_structure_file_and_includes_beside_the_model_are_read(tmp_path):
    """The confinement keeps the legitimate uses: a table beside the structure file, an include beside the MJCF."""
    import re
    import shutil

    from vlab.sim import load_mjcf
    from vlab.spec import DATA_DIR, load_spec

    shutil.copy(DATA_DIR / "table1_bcc_frequencies.csv", tmp_path / "mine.csv")
    p = tmp_path / "s.toml"
    p.write_text(readers_cases.with_reference(readers_cases.BCC_TOML, '"mine.csv"'))
    assert load_spec(p).reference["frequencies"] == str((tmp_path / "mine.csv").resolve())
    t = readers_cases.good_mjcf_text()
    sensors = re.search(r"<sensor>.*?</sensor>", t, flags=re.S).group(0)
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "sensors.xml").write_text(f"<mujoco>{sensors}</mujoco>")
    (tmp_path / "plant.xml").write_text(t.replace(sensors, '<include file="sub/sensors.xml"/>'))
    assert load_mjcf(tmp_path / "plant.xml").nsensor == load_mjcf_text_sensors(t)


def load_mjcf_text_sensors(text: str) -> int:
    import mujoco

    return mujoco.MjModel.from_xml_string(text).nsensor


def test_an_frf_axis_in_rad_per_s_is_read_in_hz(tmp_path):
    """A frequency abscissa labelled rad/s is converted (not read as Hz); the coherence record still pairs."""
    import numpy as np

    from vlab.io.uff import read_frfs

    good = readers_cases.good_frfs()
    p = readers_cases.write_frf(tmp_path, good)

    def to_rad(sets):
        for s in sets:
            s["x"] = np.asarray(s["x"]) * 2 * np.pi
            s["abscissa_axis_units_lab"] = "rad/s"
    readers_cases.rewrite(p, to_rad)
    back = read_frfs(p)
    assert len(back) == len(good)
    for a, b in zip(back, good):
        np.testing.assert_allclose(a.freq_hz, b.freq_hz, rtol=1e-9)
        assert a.coherence is not None


def test_a_periodic_recording_without_corruption_is_accepted(tmp_path):
    """The force-repeat check accepts the same recording uncorrupted (no false refusal)."""
    from vlab.io.uff import read_recording

    for n in (2, 3):
        p = readers_cases.write_rec(tmp_path, readers_cases.periodic_recording(n), name=f"ok{n}.uff")
        data = readers_cases.diagnose_rec(p)
        assert data.periodic and read_recording(p).n_samples == n * readers_cases.N
