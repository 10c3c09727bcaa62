"""Property-based fuzzing of vlab's readers: UFF 58 time histories (binary
and ASCII), UFF 58 FRFs, UFF 55 mode shapes, modal CSV and structure TOML.

Good files are written by vlab's own writers (the TOML is the shipped
``bcc.toml``); hypothesis mutates their bytes: random byte changes, random
doubles written anywhere, truncation, inserted bytes, deleted, duplicated or
swapped lines (a field or record deleted or repeated), and numbers in the text
replaced by random ones (NaN, inf, huge, tiny, negative, integers). Every input
must end in either

* a clean error: a :class:`vlab.errors.VlabError` whose message names the
  file, or
* a correct read: the reader's own guarantees hold on what it returns (finite
  samples and lines, plausible magnitudes, no clipping, increasing frequency
  axes, coherence in [0, 1], frequencies positive, damping in [0, 1), values
  of a structure inside :data:`vlab.spec.PLAUSIBLE_RANGES`).

Anything else (a traceback of another type, a silent NaN) fails. The default
test runs about 200 inputs; the ``slow`` one runs 10^4 (2000 per reader).
"""

from __future__ import annotations

import dataclasses
import math
import re
import struct
import tempfile
from functools import lru_cache
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from vlab.errors import VlabError
from vlab.spec import PLAUSIBLE_RANGES, STRUCTURES_DIR, Quantity, load_spec

# ------------------------------------------------------------------------- good files
DT = 0.5e-3


@lru_cache(maxsize=1)
def _spec():
    return load_spec("bcc")


@lru_cache(maxsize=1)
def good_files() -> dict[str, bytes]:
    """Bytes of one good file of each kind, written by vlab's writers."""
    from vlab.io.uff import ModeShapes, write_frfs, write_mode_shapes, write_recording
    from vlab.io.recording import Recording
    from vlab.io.frf import FRF

    rng = np.random.default_rng(11)
    n = 64
    t = np.arange(n) * DT
    rec = Recording.from_signals(DT, {"force9": 0.5 * rng.standard_normal(n),
                                      "vel5": 1e-3 * np.sin(2 * np.pi * 7.0 * t) + 1e-5 * rng.standard_normal(n),
                                      "vel7": 1e-3 * np.cos(2 * np.pi * 3.0 * t) + 1e-5 * rng.standard_normal(n)})
    f = np.arange(1, 17) * 0.5
    frfs = [FRF(freq_hz=f, h=1e-3 * (1 + k) / (1 + 1j * f), response="velocity", coherence=np.full(f.size, 0.9),
                output_name=f"vel{p}", input_name="force9", output_point=p, input_point=9, n_averages=4)
            for k, p in enumerate((5, 7))]
    modes = ModeShapes(freq_hz=[1.9, 4.8], shapes=rng.standard_normal((4, 2)), point_ids=[1, 5, 7, 9],
                       damping_ratio=[0.004, 0.002])
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        out["time58b"] = write_recording(d / "a.uff", rec).read_bytes()
        out["time58"] = write_recording(d / "b.uff", rec, binary=False).read_bytes()
        out["frf58"] = write_frfs(d / "c.uff", frfs, binary=False).read_bytes()
        out["modes55"] = write_mode_shapes(d / "d.uff", modes).read_bytes()
    out["csv"] = ("mode,frequency_hz,damping_ratio,frequency_sigma_hz,shape_5,shape_7\n"
                  "1,1.9,0.004,0.01,0.3,0.5\n2,4.8,0.002,0.02,-0.6,0.2\n3,7.3,0.004,0.03,0.4,-0.7\n").encode()
    out["toml"] = (STRUCTURES_DIR / "bcc.toml").read_bytes()
    return out


SUFFIX = {"time58b": ".uff", "time58": ".uff", "frf58": ".uff", "modes55": ".uff", "csv": ".csv", "toml": ".toml"}


# ------------------------------------------------------------------------- readers + their guarantees
def _check_recording(rec):
    from vlab.io.recording import MAX_PLAUSIBLE_RMS, find_clipping

    assert math.isfinite(rec.dt_s) and rec.dt_s > 0
    for c in rec.channels:
        x = np.asarray(c.samples)
        assert x.size >= 4 and np.all(np.isfinite(x))
        assert np.sqrt(np.mean(x ** 2)) <= MAX_PLAUSIBLE_RMS[c.quantity]
        assert find_clipping(x) is None
        assert c.point_id >= 1 and c.direction in (-3, -2, -1, 1, 2, 3)


def _read_time(p):
    from vlab.io.uff import read_recording
    _check_recording(read_recording(p))


def _read_frf(p):
    from vlab.io.uff import read_frfs
    for f in read_frfs(p):
        fr = np.asarray(f.freq_hz)
        assert fr.size and np.all(np.isfinite(fr)) and fr[0] >= 0 and np.all(np.diff(fr) > 0)
        assert np.all(np.isfinite(f.h))
        if f.coherence is not None:
            assert np.all((f.coherence >= -1e-9) & (f.coherence <= 1 + 1e-9))


def _read_modes(p):
    from vlab.io.uff import read_mode_shapes
    ms = read_mode_shapes(p, points=sorted(_spec().points))
    assert np.all(np.isfinite(ms.freq_hz)) and np.all(ms.freq_hz > 0)
    assert np.all((ms.damping_ratio >= 0) & (ms.damping_ratio < 1)) and np.all(np.isfinite(ms.shapes))
    assert set(ms.point_ids.tolist()) <= set(_spec().points)


def _read_csv(p):
    from vlab.diagnose.data.modalcsv import MAX_MODAL_FREQUENCY_HZ, read_modal_csv
    md = read_modal_csv(p, _spec())
    assert np.all((md.freq_hz > 0) & (md.freq_hz <= MAX_MODAL_FREQUENCY_HZ))
    z = md.damping[np.isfinite(md.damping)]
    assert np.all((z >= 0) & (z < 1))
    if md.shapes is not None:
        assert np.all(np.isfinite(md.shapes))


def _quantities(obj, kind_of=None):
    """Every Quantity held (recursively) by a spec's dataclasses, dicts and tuples."""
    if isinstance(obj, Quantity):
        yield obj
    elif dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        for f in dataclasses.fields(obj):
            if f.name != "raw":
                yield from _quantities(getattr(obj, f.name))
    elif isinstance(obj, dict):
        for v in obj.values():
            yield from _quantities(v)
    elif isinstance(obj, (tuple, list)):
        for v in obj:
            yield from _quantities(v)


def _read_toml(p):
    spec = load_spec(p)
    hi = max(r[1] for r in PLAUSIBLE_RANGES.values())
    for q in _quantities(spec):
        assert math.isfinite(q.si) and abs(q.si) <= hi
    for xy in spec.points.values():
        assert all(math.isfinite(v) for v in xy)


READERS = {"time58b": _read_time, "time58": _read_time, "frf58": _read_frf, "modes55": _read_modes,
           "csv": _read_csv, "toml": _read_toml}


# ------------------------------------------------------------------------- mutations
_NUM = re.compile(rb"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")
_NUMBERS = st.one_of(
    st.sampled_from([b"nan", b"inf", b"-inf", b"NaN", b"0", b"-0", b"-1", b"1e308", b"1e-308", b"1e30",
                     b"-1e30", b"999999999", b"3", b"1.5", b"", b"1,5", b"0x10"]),
    st.floats(allow_nan=True, allow_infinity=True).map(lambda v: repr(v).encode()),
    st.integers(-10**12, 10**12).map(lambda v: str(v).encode()),
)
_DOUBLES = st.one_of(st.sampled_from([float("nan"), float("inf"), -float("inf"), 1e300, -1e300, 0.0, 5e-324]),
                     st.floats(allow_nan=True, allow_infinity=True))


@st.composite
def mutated(draw, kind):
    data = bytearray(good_files()[kind])
    for _ in range(draw(st.integers(1, 3))):
        op = draw(st.sampled_from(["bytes", "double", "truncate", "insert", "delete_line", "dup_line",
                                   "swap_lines", "number", "number", "number"]))
        if not data:
            break
        if op == "bytes":
            i = draw(st.integers(0, len(data) - 1))
            chunk = draw(st.binary(min_size=1, max_size=8))
            data[i:i + len(chunk)] = chunk
        elif op == "double":
            i = draw(st.integers(0, max(0, len(data) - 8)))
            data[i:i + 8] = struct.pack("<d", draw(_DOUBLES))
        elif op == "truncate":
            del data[draw(st.integers(0, len(data) - 1)):]
        elif op == "insert":
            i = draw(st.integers(0, len(data)))
            data[i:i] = draw(st.binary(min_size=1, max_size=16))
        else:
            lines = bytes(data).split(b"\n")
            if op in ("delete_line", "dup_line", "swap_lines"):
                i = draw(st.integers(0, len(lines) - 1))
                if op == "delete_line":
                    del lines[i]
                elif op == "dup_line":
                    lines.insert(i, lines[i])
                else:
                    j = draw(st.integers(0, len(lines) - 1))
                    lines[i], lines[j] = lines[j], lines[i]
                data = bytearray(b"\n".join(lines))
            else:  # replace one number in the text
                hits = list(_NUM.finditer(bytes(data)))
                if hits:
                    m = hits[draw(st.integers(0, len(hits) - 1))]
                    data[m.start():m.end()] = draw(_NUMBERS)
    return bytes(data)


def _check_one(kind: str, blob: bytes) -> str:
    """Read one mutated file; return 'read' or 'error', fail on anything else."""
    with tempfile.TemporaryDirectory() as tmp:
        p = Path(tmp) / f"fuzzed_{kind}{SUFFIX[kind]}"
        p.write_bytes(blob)
        before = sorted(x.name for x in Path(tmp).iterdir())
        try:
            READERS[kind](p)
            outcome = "read"
        except VlabError as exc:
            assert p.name in str(exc), f"{type(exc).__name__} does not name the file: {exc}"
            outcome = "error"
        assert sorted(x.name for x in Path(tmp).iterdir()) == before   # nothing written
        return outcome


KINDS = sorted(READERS)


def test_good_files_read():
    for kind in KINDS:
        assert _check_one(kind, good_files()[kind]) == "read", kind


_COMMON = dict(deadline=None, derandomize=True, database=None, print_blob=True,
               suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


@pytest.mark.parametrize("kind", KINDS)
@settings(max_examples=34, **_COMMON)
@given(data=st.data())
def test_fuzzed_files_end_in_a_clean_error_or_a_correct_read(kind, data):
    """About 200 inputs in all (34 per kind)."""
    _check_one(kind, data.draw(mutated(kind)))


@pytest.mark.long
@pytest.mark.parametrize("kind", KINDS)
@settings(max_examples=1700, **_COMMON)
@given(data=st.data())
def test_fuzzed_files_slow(kind, data):
    """10^4 inputs in all (1700 per kind, 6 kinds)."""
    _check_one(kind, data.draw(mutated(kind)))
