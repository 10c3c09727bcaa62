"""Bad-input corpus of vlab's readers: structure TOML, UFF 58 time
histories, UFF 58 FRFs, UFF 55 mode shapes, modal CSV and MJCF plants.

Every case writes a good file with vlab's own writer (or copies a shipped one),
corrupts it programmatically (bytes, values, headers) and names the reader, the
error class expected and fragments the message must contain (the offending
field, record, channel or value). ``tests/test_readers_bad_inputs.py`` runs them
and also checks that the message names the file and that nothing is written.

A case is ``Case(id, kind, make, read, error, fragments)``: ``make(d)`` writes
the corrupted file in the folder ``d`` and returns its path; ``read(path)`` is
the reader under test.
Cases that differ only in their data are rows of a table: a field of one
record changed (:func:`field_cases`), a text edited (:meth:`TextKind.table`).
"""

from __future__ import annotations

import json
import os
import re
import shutil
import struct
from dataclasses import dataclass
from functools import lru_cache, partial
from pathlib import Path
from typing import Callable

import numpy as np
import pyuff

from vlab.errors import DataFileError, MeasurementError, ModelError, SpecError

DT = 0.5e-3
N = 2000
ASSETS = Path(__file__).resolve().parents[2] / "assets" / "structures"


@dataclass(frozen=True)
class Case:
    id: str
    kind: str
    make: Callable[[Path], Path]
    read: Callable[[Path], object]
    error: type
    fragments: tuple[str, ...]


CASES: list[Case] = []


def case(kind, read, error, *fragments):
    def deco(make):
        CASES.append(Case(make.__name__, kind, make, read, error, tuple(fragments)))
        return make
    return deco


# ------------------------------------------------------------------------ shared models
@lru_cache(maxsize=1)
def _bcc():
    from vlab.fe import build_fe_model
    from vlab.spec import load_spec

    spec = load_spec("bcc")
    return spec, build_fe_model(spec)


# ------------------------------------------------------------------------ readers
def read_rec(p):
    from vlab.io.uff import read_recording
    return read_recording(p)


def diagnose_rec(p):
    from vlab.diagnose.data.frfestimate import frfs_from_recording
    spec, fe = _bcc()
    return frfs_from_recording(read_rec(p), spec, fe, path=str(p), resolution_hz=1.0, band_hz=(0.5, 25.0))


def read_frf(p):
    from vlab.io.uff import read_frfs
    return read_frfs(p)


def diagnose_frf(p):
    from vlab.diagnose.data.frfestimate import frfs_from_uff
    spec, fe = _bcc()
    return frfs_from_uff(read_frf(p), spec, fe, path=str(p), band_hz=(0.5, 25.0))


def read_modes(p):
    from vlab.io.uff import read_mode_shapes
    return read_mode_shapes(p, points=sorted(_bcc()[0].points))


def read_csv(p):
    from vlab.diagnose.data.modalcsv import read_modal_csv
    return read_modal_csv(p, _bcc()[0])


def read_toml(p):
    from vlab.spec import load_spec
    return load_spec(p)


def read_mjcf(p):
    from vlab.sim import load_plant_for_experiment
    return load_plant_for_experiment(_bcc()[0], mjcf=p)


# ------------------------------------------------------------------------ good files
def good_recording():
    from vlab.io.recording import Recording

    rng = np.random.default_rng(7)
    t = np.arange(N) * DT
    sig = {"force9": 0.5 * rng.standard_normal(N)}
    for p in (5, 7, 9, 6):
        sig[f"vel{p}"] = 1e-3 * np.sin(2 * np.pi * 1.3 * t + p) + 1e-5 * rng.standard_normal(N)
    return Recording.from_signals(DT, sig, metadata={"structure": "bcc", "seed": 1})


def write_rec(d, rec=None, name="rec.uff"):
    from vlab.io.uff import write_recording
    return write_recording(d / name, good_recording() if rec is None else rec)


def good_frfs(points=(5, 7, 6), freq=None):
    from vlab.io.frf import FRF

    f = np.arange(1, 126) * 0.2 if freq is None else freq
    out = []
    for k, p in enumerate(points):
        h = 1e-3 * (1 + k) / (1 + 1j * f)
        coh = np.full(f.size, 0.95)
        out.append(FRF(freq_hz=f, h=h, response="velocity", coherence=coh, output_name=f"vel{p}",
                       input_name="force9", output_point=p, input_point=9, n_averages=8))
    return out


def write_frf(d, frfs=None, name="frf.uff"):
    from vlab.io.uff import write_frfs
    return write_frfs(d / name, good_frfs() if frfs is None else frfs)


def good_modes(points=(1, 3, 5, 7, 9, 6)):
    from vlab.io.uff import ModeShapes

    rng = np.random.default_rng(3)
    return ModeShapes(freq_hz=[1.9, 4.8, 7.3], shapes=rng.standard_normal((len(points), 3)),
                      point_ids=list(points), damping_ratio=[0.004, 0.002, 0.004], description="bcc modes")


def write_modes(d, modes=None, name="modes.uff"):
    from vlab.io.uff import write_mode_shapes
    return write_mode_shapes(d / name, good_modes() if modes is None else modes)


GOOD_CSV = ("# measured modes of the BCC\n"
            "mode,frequency_hz,damping_ratio,frequency_sigma_hz,damping_sigma,shape_5,shape_7\n"
            "1,1.9,0.004,0.01,0.001,0.3,0.5\n"
            "2,4.8,0.002,0.02,0.0005,-0.6,0.2\n"
            "3,7.3,0.004,0.03,0.001,0.4,-0.7\n")


@lru_cache(maxsize=1)
def good_mjcf_text():
    import tempfile

    from vlab.sim import build_plant, export_mjcf
    with tempfile.TemporaryDirectory() as tmp:
        p = export_mjcf(build_plant(_bcc()[0]), Path(tmp) / "bcc.xml")
        return Path(p).read_text()


# ------------------------------------------------------------------------ corruptions
def rewrite(p, fn):
    """Read every dataset with pyuff, apply ``fn(sets)``, write them back (records stay binary)."""
    sets = pyuff.UFF(str(p)).read_sets()
    sets = [sets] if isinstance(sets, dict) else sets
    sets = fn(sets) or sets
    os.remove(p)
    pyuff.UFF(str(p)).write_sets(sets, mode="add")
    return p


def set_field(p, rec, **fields):
    def fn(sets):
        sets[rec].update(fields)
    return rewrite(p, fn)


def poke(p, sets_fn):
    return rewrite(p, sets_fn)


def set_items(record, key, items, dtype=None):
    """A ``poke`` edit: the entries ``items`` (index -> value) of the array ``key`` of record ``record``
    (0-based) replaced, on a copy of the array made with ``dtype``."""
    def fn(sets):
        a = np.array(sets[record][key], dtype=dtype)
        for i, v in items.items():
            a[i] = v
        sets[record][key] = a
    return fn


def raw_file(d, name, data):
    """The file ``d / name`` holding the bytes ``data``."""
    p = d / name
    p.write_bytes(data)
    return p


def with_sidecar(d, text):
    """The good recording with its JSON metadata sidecar replaced by ``text``."""
    p = write_rec(d)
    p.with_name(p.name + ".json").write_text(text)
    return p


def renamed_channel(d, old, new, scale=1):
    """The good recording with channel ``old`` renamed ``new`` and its samples multiplied by ``scale``."""
    from vlab.io.recording import Recording
    rec = good_recording()
    sig = {c.name: np.array(c.samples) for c in rec.channels}
    sig[new] = sig.pop(old) * scale
    return write_rec(d, Recording.from_signals(DT, sig, metadata=dict(rec.metadata)))


def field_cases(kind, write, read, rows, error=DataFileError):
    """Register a case per row ``(id, record, fields, fragments)``: the good file ``write(d)`` with ``fields``
    of its record ``record`` (0-based) changed, read by ``read``."""
    for id_, record, fields, fragments in rows:
        CASES.append(Case(id_, kind, partial(_set_fields, write, record, fields), read, error, fragments))


def _set_fields(write, record, fields, d):
    return set_field(write(d), record, **fields)


@dataclass(frozen=True)
class TextKind:
    """A text input: its cases write ``file_name``, the good text ``good()`` corrupted by an edit.

    Call it as a decorator, ``@csv_case(*fragments, error=...)`` on ``edit(text) -> text or bytes``, or
    register a table of edits with :meth:`table`.
    """

    kind: str
    read: Callable[[Path], object]
    file_name: str
    good: Callable[[], str]
    error: type

    def add(self, id_, edit, fragments, error=None):
        """Register the case ``id_``: the file holds ``edit(good())``, text (UTF-8) or bytes."""
        def make(d):
            p = d / self.file_name
            text = edit(self.good())
            if isinstance(text, bytes):
                p.write_bytes(text)
            else:
                assert text != self.good(), "corruption did nothing"
                p.write_text(text, encoding="utf-8")
            return p
        CASES.append(Case(id_, self.kind, make, self.read, error or self.error, tuple(fragments)))

    def __call__(self, *fragments, error=None):
        def deco(edit):
            self.add(edit.__name__, edit, fragments, error)
            return edit
        return deco

    def table(self, edit, rows):
        """Register a case per row ``(id, args, fragments)``: the good text changed by ``edit(text, *args)``."""
        for id_, args, fragments in rows:
            self.add(id_, partial(_edit_with, edit, args), fragments)


def _edit_with(edit, args, text):
    return edit(text, *args)


def truncated(p, numerator=1, denominator=2):
    """The file ``p`` cut to its first ``numerator / denominator`` of bytes."""
    raw = p.read_bytes()
    p.write_bytes(raw[: numerator * len(raw) // denominator])
    return p


def put_bytes(p, old: float, new: float, count=1):
    """Replace the binary double ``old`` by ``new`` (pyuff writes NaN as 0: this is the only way in)."""
    raw = p.read_bytes()
    a, b = struct.pack("<d", old), struct.pack("<d", new)
    assert raw.count(a) >= count, "sentinel not found once"
    p.write_bytes(raw.replace(a, b, count))
    return p


def rec_with(**changes):
    """The good recording with channel samples replaced (name -> function of the samples)."""
    from vlab.io.recording import Recording

    rec = good_recording()
    sig = {c.name: np.array(c.samples) for c in rec.channels}
    for name, fn in changes.items():
        sig[name] = fn(sig[name])
    return Recording.from_signals(DT, sig, metadata=dict(rec.metadata))


def sentinel_recording(d, channel, index, value=0.123456789e-3, name="rec.uff", n_put=1):
    def fn(x):
        x = x.copy()
        x[index:index + n_put] = value + np.arange(n_put) * 1e-9
        return x
    return write_rec(d, rec_with(**{channel: fn}), name=name)


# ================================================================ UFF 58 time histories
@case("uff58-time", read_rec, DataFileError, "vel7", "non-finite", "index 123")
def time_nan_sample(d):
    return put_bytes(sentinel_recording(d, "vel7", 123), 0.123456789e-3, float("nan"))


@case("uff58-time", read_rec, DataFileError, "force9", "non-finite", "index 40", "inf")
def time_inf_sample(d):
    return put_bytes(sentinel_recording(d, "force9", 40, value=7.654321), 7.654321, float("inf"))


@case("uff58-time", read_rec, DataFileError, "vel5", "non-finite", "100 in all")
def time_hundred_nans(d):
    p = sentinel_recording(d, "vel5", 500, n_put=100)
    raw = p.read_bytes()
    for k in range(100):
        raw = raw.replace(struct.pack("<d", 0.123456789e-3 + k * 1e-9), struct.pack("<d", float("nan")), 1)
    p.write_bytes(raw)
    return p


@case("uff58-time", read_rec, MeasurementError, "vel7", "RMS", "m/s", "implausible")
def time_velocity_scaled_1e12(d):
    return write_rec(d, rec_with(vel7=lambda x: x * 1e12))


@case("uff58-time", read_rec, MeasurementError, "vel6", "RMS", "implausible")
def time_velocity_in_wrong_unit(d):
    return write_rec(d, rec_with(vel6=lambda x: x * 1e5))  # e.g. um/s written as m/s


@case("uff58-time", read_rec, MeasurementError, "force9", "RMS", " N ")
def time_force_scaled_1e6(d):
    return write_rec(d, rec_with(force9=lambda x: x * 1e6))


@case("uff58-time", read_rec, MeasurementError, "vel5", "clipped", "maximum")
def time_clipped_top(d):
    return write_rec(d, rec_with(vel5=lambda x: np.minimum(x, 0.8 * x.max())))


@case("uff58-time", read_rec, MeasurementError, "force9", "clipped", "minimum")
def time_clipped_bottom(d):
    return write_rec(d, rec_with(force9=lambda x: np.maximum(x, 0.5 * x.min())))


# (id, record, fields, fragments): a field of one record of the good recording changed
field_cases("uff58-time", write_rec, read_rec, [
    ("time_channels_at_two_rates", 1, dict(x=np.arange(N) * 1e-3, id4="dt_s=0.001"), ("vel5", "sampled every 0.001")),
    ("time_id_line_disagrees_with_header", 0, dict(x=np.arange(N) * 2e-3), ("force9", "ID line time step", "0.0005")),
    ("time_zero_step", 0, dict(x=np.zeros(N), id4="dt_s=0.0"), ("force9", "not positive")),
    ("time_negative_step", 0, dict(x=-np.arange(N) * 5e-4, id4="dt_s=-0.0005"),
     ("force9", "not positive", "-0.0005")),
    ("time_unknown_data_type", 2, dict(ordinate_spec_data_type=2, id1="NONE"),
     ("record 3", "unsupported ordinate specific data type 2")),
    ("time_unit_label_in_per_s", 4, dict(ordinate_axis_units_lab="in/s"), ("vel6", "'in/s'")),
    ("time_force_in_lbf", 0, dict(ordinate_axis_units_lab="lbf"), ("force9", "'lbf'")),
    ("time_direction_seven", 2, dict(rsp_dir=7), ("vel7", "rsp_dir = 7")),
    ("time_direction_scalar", 1, dict(rsp_dir=0), ("vel5", "rsp_dir = 0")),
    ("time_node_zero", 1, dict(rsp_node=0), ("record 2", "rsp_node = 0")),
    ("time_negative_node", 0, dict(rsp_node=-9), ("record 1", "rsp_node = -9")),
    ("time_name_says_other_node", 2, dict(rsp_node=8), ("vel7", "point 7", "node 8", "mislabelled")),
    ("time_name_says_other_quantity", 2, dict(ordinate_spec_data_type=13), ("vel7", "force", "mislabelled")),
    ("time_abscissa_is_frequency", 3, dict(abscissa_spec_data_type=18), ("vel9", "abscissa specific data type 18")),
])


@case("uff58-time", read_rec, DataFileError, "vel9", "1500 samples", "2000")
def time_channels_of_different_lengths(d):
    def fn(sets):
        sets[3]["data"] = sets[3]["data"][:1500]
        sets[3]["x"] = sets[3]["x"][:1500]
    return poke(write_rec(d), fn)


@case("uff58-time", read_rec, DataFileError, "record 1", "3 sample(s)", "at least 4")
def time_three_samples(d):
    def fn(sets):
        for s in sets:
            s["data"], s["x"] = s["data"][:3], s["x"][:3]
    return poke(write_rec(d), fn)


@case("uff58-time", read_rec, DataFileError, "duplicate channel vel5")
def time_duplicated_record(d):
    def fn(sets):
        return sets[:2] + [dict(sets[1])] + sets[2:]
    p = poke(write_rec(d), fn)
    return _fix_counts(p)


def _fix_counts(p):
    """Renumber vlab's 'record i of n' ID lines after records were added or removed."""
    def fn(sets):
        for i, s in enumerate(sets, start=1):
            s["id5"] = f"record {i} of {len(sets)}"
    return rewrite(p, fn)


@case("uff58-time", read_rec, DataFileError, "ref5", "duplicates channel vel5")
def time_same_sensor_twice(d):
    def fn(sets):
        extra = dict(sets[1])
        extra["id1"] = "ref5"
        return sets + [extra]
    return _fix_counts(poke(write_rec(d), fn))


@case("uff58-time", read_rec, DataFileError, "period_s", "0.001", "mis-sampled")
def time_sidecar_period_disagrees(d):
    p = write_rec(d)
    side = p.with_name(p.name + ".json")
    meta = json.loads(side.read_text())
    meta["period_s"] = 1e-3
    side.write_text(json.dumps(meta))
    return p


@case("uff58-time", read_rec, DataFileError, "period_s", "'fast'")
def time_sidecar_period_not_a_number(d):
    return with_sidecar(d, json.dumps({"structure": "bcc", "period_s": "fast"}))


@case("uff58-time", read_rec, DataFileError, "rec.uff.json", "unreadable metadata sidecar")
def time_sidecar_not_json(d):
    return with_sidecar(d, "{structure: bcc")


@case("uff58-time", read_rec, DataFileError, "rec.uff.json", "JSON object")
def time_sidecar_a_list(d):
    return with_sidecar(d, "[1, 2]")


@case("uff58-time", read_rec, DataFileError, "truncated")
def time_truncated_half(d):
    return truncated(write_rec(d))


@case("uff58-time", read_rec, DataFileError, "truncated UFF", "record")
def time_truncated_at_record_boundary(d):
    return poke(write_rec(d), lambda sets: sets[:3])


@case("uff58-time", read_rec, DataFileError, "empty file")
def time_empty_file(d):
    return raw_file(d, "rec.uff", b"")


@case("uff58-time", read_rec, DataFileError, "malformed UFF")
def time_garbage(d):
    return raw_file(d, "rec.uff", b"    -1\n    58\nthis is not a UFF record\n    -1\n")


@case("uff58-time", read_rec, DataFileError, "no dataset-58 time-response")
def time_frf_file_read_as_recording(d):
    return write_frf(d, name="rec.uff")


# -------- what the diagnosis adds (it knows the structure and the lab's controller rate)
@case("uff58-time", diagnose_rec, DataFileError, "exactly one force channel", "none")
def time_force_channel_missing(d):
    return write_rec(d, good_recording().select(["vel5", "vel7", "vel9", "vel6"]))


@case("uff58-time", diagnose_rec, DataFileError, "exactly one force channel", "force5")
def time_two_force_channels(d):
    return renamed_channel(d, "vel5", "force5", scale=100)


@case("uff58-time", diagnose_rec, DataFileError, "vel42", "point id 42")
def time_channel_at_unknown_point(d):
    return renamed_channel(d, "vel6", "vel42")


@case("uff58-time", diagnose_rec, DataFileError, "4096 samples/s", "PC-1000")
def time_sampled_faster_than_the_pc1000(d):
    from vlab.io.recording import Recording
    rec = good_recording()
    return write_rec(d, Recording(1 / 4096, rec.channels, dict(rec.metadata)))


field_cases("uff58-time", write_rec, diagnose_rec, [
    ("time_acceleration_channel", 4, dict(ordinate_spec_data_type=12, id1="acc6", ordinate_axis_units_lab="m/s^2"),
     ("acc6", "acceleration")),
    ("time_in_plane_direction", 4, dict(rsp_dir=1), ("vel6", "direction 1")),
])


@case("uff58-time", diagnose_rec, MeasurementError, "vel9", "constant")
def time_dead_channel(d):
    return write_rec(d, rec_with(vel9=lambda x: np.zeros_like(x)))


# ====================================================================== UFF 58 FRFs
@case("uff58-frf", read_frf, DataFileError, "vel7/force9", "non-finite")
def frf_nan_value(d):
    from vlab.io.frf import FRF
    frfs = good_frfs()
    h = np.array(frfs[1].h)
    h[10] = 0.987654321e-3
    frfs[1] = FRF(freq_hz=frfs[1].freq_hz, h=h, response="velocity", coherence=frfs[1].coherence,
                  output_name="vel7", input_name="force9", output_point=7, input_point=9, n_averages=8)
    return put_bytes(write_frf(d, frfs), 0.987654321e-3, float("nan"))


@case("uff58-frf", read_frf, DataFileError, "vel5/force9", "not increasing", "line 11")
def frf_axis_not_increasing(d):
    def fn(sets):
        x = np.array(sets[0]["x"])
        x[10], x[11] = x[11], x[10]
        sets[0]["x"] = x
    return poke(write_frf(d), fn)


@case("uff58-frf", read_frf, DataFileError, "vel5/force9", "not increasing")
def frf_repeated_line(d):
    def fn(sets):
        x = np.array(sets[0]["x"])
        x[5] = x[4]
        sets[0]["x"] = x
    return poke(write_frf(d), fn)


@case("uff58-frf", read_frf, DataFileError, "negative frequency", "-0.2")
def frf_negative_frequency(d):
    return poke(write_frf(d), set_items(0, "x", {0: -0.2}))


@case("uff58-frf", read_frf, DataFileError, "coherence", "vel7/force9", "1.5", "outside [0, 1]")
def frf_coherence_above_one(d):
    return poke(write_frf(d), set_items(3, "data", {7: 1.5}))


field_cases("uff58-frf", write_frf, read_frf, [
    ("frf_denominator_velocity", 0, dict(orddenom_spec_data_type=11), ("denominator type 11", "not a force")),
    ("frf_force_over_force", 2, dict(ordinate_spec_data_type=13), ("unsupported response", "13")),
    ("frf_reference_node_zero", 0, dict(ref_node=0), ("FRF record 1", "ref_node = 0")),
    ("frf_bad_direction", 4, dict(rsp_dir=9), ("vel6/force9", "rsp_dir = 9")),
    ("frf_bad_reference_direction", 0, dict(ref_dir=-7), ("vel5/force9", "ref_dir = -7")),
    ("frf_unit_label_g", 2, dict(ordinate_axis_units_lab="g"), ("vel7/force9", "'g'")),
    ("frf_output_name_other_node", 0, dict(rsp_node=6), ("vel5", "node 6", "mislabelled")),
    ("frf_input_name_other_node", 2, dict(id1="vel7/force4"), ("force4", "reference node 9", "mislabelled")),
    ("frf_abscissa_time", 4, dict(abscissa_spec_data_type=17), ("vel6/force9", "not frequency")),
])


@case("uff58-frf", read_frf, DataFileError, "a second velocity FRF", "node 9 to node 5")
def frf_duplicated(d):
    from vlab.io.frf import FRF
    f = good_frfs()
    twin = FRF(freq_hz=f[0].freq_hz, h=f[0].h, response="velocity", output_name="vel5b", input_name="force9",
               output_point=5, input_point=9)
    return write_frf(d, f + [twin])


@case("uff58-frf", read_frf, DataFileError, "truncated")
def frf_truncated(d):
    return truncated(write_frf(d), 2, 3)


@case("uff58-frf", read_frf, DataFileError, "no dataset-58 FRF")
def frf_recording_read_as_frf(d):
    return write_rec(d, name="frf.uff")


@case("uff58-frf", diagnose_frf, DataFileError, "vel7/force9", "frequency axis differs", "vel5/force9")
def frf_axes_differ(d):
    f = good_frfs()
    other = good_frfs(freq=np.arange(1, 126) * 0.25)
    return write_frf(d, [f[0], other[1], f[2]])


@case("uff58-frf", diagnose_frf, DataFileError, "several excitation points", "[7, 9]")
def frf_two_references(d):
    from vlab.io.frf import FRF
    f = good_frfs()
    f[1] = FRF(freq_hz=f[1].freq_hz, h=f[1].h, response="velocity", output_name="vel6", input_name="force7",
               output_point=6, input_point=7)
    return write_frf(d, f[:2])


@case("uff58-frf", diagnose_frf, DataFileError, "vel42", "point id 42")
def frf_output_at_unknown_point(d):
    return write_frf(d, good_frfs(points=(5, 42)))


# ===================================================================== UFF 55 mode shapes
@case("uff55", read_modes, DataFileError, "node 42", "not a point of the structure")
def modes_unknown_node(d):
    return write_modes(d, good_modes(points=(1, 3, 5, 42)))


@case("uff55", read_modes, DataFileError, "mode record 1", "node 0", "not a point id")
def modes_node_zero(d):
    def fn(sets):
        for s in sets:
            s["node_nums"] = np.array([0, 3, 5, 7, 9, 6])
    return poke(write_modes(d), fn)


@case("uff55", read_modes, DataFileError, "node 5", "more than once")
def modes_repeated_node(d):
    def fn(sets):
        for s in sets:
            s["node_nums"] = np.array([1, 3, 5, 7, 5, 6])
    return poke(write_modes(d), fn)


field_cases("uff55", write_modes, read_modes, [
    ("modes_negative_frequency", 1, dict(freq=-4.8), ("mode record 2", "natural frequency -4.8")),
    ("modes_zero_frequency", 0, dict(freq=0.0), ("mode record 1", "natural frequency 0.0")),
    ("modes_damping_above_one", 2, dict(modal_damp_vis=1.5), ("mode record 3", "damping ratio 1.5")),
    ("modes_repeated_number", 1, dict(mode_n=1), ("mode number 1 repeats",)),
    ("modes_zero_shape", 0, dict(r3=np.zeros(6)), ("mode record 1", "zero at every node")),
    ("modes_nodes_differ", 1, dict(node_nums=np.array([1, 3, 5, 7, 9, 8])), ("mode 2", "different nodes")),
])


@case("uff55", read_modes, DataFileError, "mode record 2", "non-finite shape value", "node 5")
def modes_nan_shape(d):
    return poke(write_modes(d), set_items(1, "r3", {2: np.nan}, dtype=float))


@case("uff55", read_modes, DataFileError, "truncated")
def modes_truncated(d):
    return truncated(write_modes(d))


@case("uff55", read_modes, DataFileError, "truncated UFF", "mode record")
def modes_record_missing(d):
    return poke(write_modes(d), lambda sets: sets[:2])


# ============================================================================ modal CSV
csv_case = TextKind("csv", read_csv, "modes.csv", lambda: GOOD_CSV, DataFileError)


def sub_line(text, lineno, old, new):
    lines = text.split("\n")
    assert old in lines[lineno - 1], (old, lines[lineno - 1])
    lines[lineno - 1] = lines[lineno - 1].replace(old, new, 1)
    return "\n".join(lines)


# (id, (line number, old, new), fragments): ``old`` replaced by ``new`` on one line of the good CSV
csv_case.table(sub_line, [
    ("csv_nan_frequency", (3, "1.9", "nan"), ("line 3", "frequency_hz", "not finite", "nan")),
    ("csv_inf_shape", (4, "0.2", "inf"), ("line 4", "shape_7", "not finite", "inf")),
    ("csv_decimal_comma", (5, "7.3", '"7,3"'), ("line 5", "frequency_hz", "not a number", "'7,3'")),
    ("csv_zero_frequency", (3, "1.9", "0"), ("line 3", "frequency_hz", "> 0 Hz")),
    ("csv_frequency_in_millihertz", (4, "4.8", "4800"), ("line 4", "frequency_hz", "4800 Hz", "Nyquist")),
    ("csv_damping_above_one", (5, "0.004", "1.2"), ("line 5", "damping_ratio", "1.2")),
    ("csv_negative_damping", (3, "0.004", "-0.1"), ("line 3", "damping_ratio", "-0.1")),
    ("csv_negative_sigma", (4, "0.02", "-0.02"), ("line 4", "frequency_sigma_hz", "uncertainty", "-0.02")),
    ("csv_sigma_text", (3, "0.001,0.3", "big,0.3"), ("line 3", "damping_sigma", "not a number")),
    ("csv_duplicate_column", (2, "shape_7", "shape_5"), ("line 2", "'shape_5' appears twice")),
    ("csv_empty_column_name", (2, "damping_ratio", ""), ("line 2", "column 3 has no name")),
    ("csv_shape_at_unknown_point", (2, "shape_7", "shape_42"), ("shape_42", "point id 42")),
    ("csv_shape_column_without_point", (2, "shape_7", "shape_x"), ("shape_x", "shape_<point id>")),
    ("csv_mode_column_missing", (2, "mode,", "number,"), ("no 'mode' column",)),
    ("csv_frequency_column_missing", (2, "frequency_hz", "f"), ("no frequency column",)),
    ("csv_repeated_mode", (5, "3,", "2,"), ("repeated mode numbers [2]",)),
    ("csv_extra_field", (4, "0.2", "0.2,9"), ("line 4", "8 fields", "7")),
    ("csv_missing_field", (5, ",-0.7", ""), ("line 5", "6 fields")),
    ("csv_fractional_mode", (3, "1,1.9", "1.5,1.9"), ("line 3", "column 'mode'", "positive integer", "'1.5'")),
    ("csv_mode_zero", (3, "1,1.9", "0,1.9"), ("line 3", "column 'mode'", "positive integer", "'0'")),
    ("csv_zero_shape", (4, "-0.6,0.2", "0,0"), ("zero at every point",)),
])


@csv_case("repeated frequency 4.8")
def csv_duplicated_row(t):
    return t + "4,4.8,0.002,0.02,0.0005,-0.6,0.2\n"


@csv_case("no data rows")
def csv_header_only(t):
    return "\n".join(t.split("\n")[:2]) + "\n"


@csv_case("damping_sigma", "without a damping column")
def csv_sigma_without_damping(t):
    return t.replace("damping_ratio,", "note,")


@case("csv", read_csv, DataFileError, "line 1", "not UTF-8", "offset")
def csv_not_utf8(d):
    return raw_file(d, "modes.csv", GOOD_CSV.replace("BCC", "BCC \xe9t\xe9").encode("latin-1"))


@case("csv", read_csv, DataFileError, "NUL byte")
def csv_binary(d):
    return raw_file(d, "modes.csv", GOOD_CSV.encode() + b"\x00\x01\x02\x03")


@case("csv", read_csv, DataFileError, "no such file")
def csv_missing(d):
    return d / "modes.csv"


# ========================================================================= structure TOML
BCC_TOML = (ASSETS / "bcc.toml").read_text(encoding="utf-8")


toml_case = TextKind("toml", read_toml, "bcc_edit.toml", lambda: BCC_TOML, SpecError)


def sub1(text, old, new):
    assert old in text, old
    return text.replace(old, new, 1)


def with_reference(text, value):
    """The structure TOML ``text`` naming ``value`` (TOML source) as its reference frequencies file."""
    return sub1(text, 'frequencies = "table1_bcc_frequencies.csv"', f"frequencies = {value}")


@toml_case("not UTF-8", "line 1", "offset")
def toml_latin1(t):
    return t.replace("dissertation", "dissertation \xe9crite", 1).encode("latin-1")


@toml_case("not UTF-8", "line 20")
def toml_bad_byte_midway(t):
    lines = t.encode().split(b"\n")
    lines[19] += b" # \xff\xfe"
    return b"\n".join(lines)


# (id, (old, new), fragments): the first ``old`` of the good TOML replaced by ``new``
toml_case.table(sub1, [
    ("toml_ei_times_1e30", ("value = 9060.0", "value = 9060.0e30"),
     ("sections.steel_beam.ei.value", "plausible range", "9.06e+33")),
    ("toml_ei_times_1e_30", ("value = 9060.0", "value = 9060.0e-30"),
     ("sections.steel_beam.ei.value", "plausible range")),
    ("toml_modulus_nan", ("value = 29.0e6", "value = nan"), ("sections.steel_beam.modulus.value", "finite", "nan")),
    ("toml_density_inf", ("value = 0.098", "value = inf"),
     ("sections.aluminium_crosspiece.density.value", "finite", "inf")),
    ("toml_density_in_wrong_unit", ('value = 0.283, unit = "lbf/in^3"', 'value = 0.283e9, unit = "lbf/in^3"'),
     ("sections.steel_beam.density.value", "plausible range")),
    ("toml_coordinate_nan", ("5 = [0, 40]", "5 = [0, nan]"), ("points.coordinates.5", "finite")),
    ("toml_coordinate_huge", ("5 = [0, 40]", "5 = [0, 4e9]"), ("points.coordinates.5", "within")),
    ("toml_coordinate_bool", ("5 = [0, 40]", "5 = [false, 40]"), ("points.coordinates.5", "expected [x, y]")),
    ("toml_coincident_points", ("5 = [0, 40]", "5 = [0, 50]"), ("members[0].points", "points 4 and 5 coincide")),
    ("toml_negative_tension", ("value = 71.02", "value = -71.02"),
     ("strings[1].tension.value", "positive", "-71.02")),
    ("toml_tension_huge", ("value = 71.02", "value = 71.02e12"), ("strings[1].tension.value", "plausible range")),
    ("toml_mass_huge", ("value = 0.1447", "value = 0.1447e12"), ("masses[0].mass.value", "plausible range")),
    ("toml_mass_tiny",
     ('id = "coil9"\npoint = 9\nmass = { value = 0.1703', 'id = "coil9"\npoint = 9\nmass = { value = 0.1703e-12'),
     ("masses[2].mass.value", "plausible range")),
    ("toml_gravity_nan", ("gravity = [0.0, -1.0]", "gravity = [nan, -1.0]"), ("structure.gravity", "finite")),
    ("toml_unknown_unit", ('width = { value = 2.0, unit = "in"', 'width = { value = 2.0, unit = "furlong"'),
     ("sections.steel_beam.width.unit", "'furlong'")),
    ("toml_too_many_elements", ("elements_per_segment = 1", "elements_per_segment = 100000"),
     ("members[0].elements_per_segment", "100000")),
    ("toml_zero_elements", ("elements_per_segment = 1", "elements_per_segment = 0"),
     ("members[0].elements_per_segment", "0")),
    ("toml_default_damping_above_one", ("default_ratio = 0.01", "default_ratio = 1.5"),
     ("damping.default_ratio", "1.5")),
    ("toml_negative_modal_damping", ("modal_ratios = [0.004,", "modal_ratios = [-0.1,"),
     ("damping.modal_ratios", "-0.1")),
    ("toml_actuator_at_unknown_point", ("actuators = [5, 7, 9]", "actuators = [5, 7, 99]"),
     ("instrumentation.actuators", "99")),
    ("toml_repeated_actuator", ("actuators = [5, 7, 9]", "actuators = [5, 5, 9]"),
     ("instrumentation.actuators", "repeated", "[5, 5, 9]")),
    ("toml_float_point_id", ("sensors = [5, 7, 9, 6]", "sensors = [5, 7, 9, 6.0]"),
     ("instrumentation.sensors", "6.0")),
    ("toml_missing_source", (', source = "calibrated: Table 1 + Table 8 (cable attachment at the beam top)"', ""),
     ("masses[0].mass.source", "missing")),
    ("toml_zero_shear_modulus", ("value = 11.2e6", "value = 0"),
     ("sections.steel_beam.shear_modulus.value", "positive")),
    ("toml_unknown_dof", ('dofs = ["w", "rx"]', 'dofs = ["w", "wz"]'), ("structure.dofs", "'wz'")),
    ("toml_arm_in_wrong_unit", ("arm_length = { value = 15.0", "arm_length = { value = 15.0e6"),
     ("crosspieces[0].arm_length.value", "plausible range")),
])


@toml_case("not valid TOML")
def toml_truncated(t):
    return t[: t.index("[[masses]]") + 5]


def _missing_toml(d):
    return d / "nope.toml"


CASES.append(Case("toml_missing", "toml", _missing_toml, read_toml, SpecError, ("file not found",)))


# =============================================================================== MJCF
mjcf_case = TextKind("mjcf", read_mjcf, "plant.xml", good_mjcf_text, ModelError)


def _first_attr(t, attr):
    m = re.search(rf'{attr}="([^"]*)"', t)
    assert m, attr
    return m


def sub_attr(t, attr, value):
    m = _first_attr(t, attr)
    return t[:m.start()] + f'{attr}="{value}"' + t[m.end():]


# (id, (attribute, value), fragments): the first such attribute of the good MJCF set to ``value``
mjcf_case.table(sub_attr, [
    ("mjcf_mass_inf", ("mass", "inf"), ("body 'J1'", "mass", "inf")),
    ("mjcf_mass_huge", ("mass", "1e12"), ("body 'J1'", "mass 1e+12 kg")),
    ("mjcf_timestep_nan", ("timestep", "nan"), ("timestep", "nan")),
    ("mjcf_timestep_too_long", ("timestep", "2"), ("timestep", "2")),
    ("mjcf_gravity_nan", ("gravity", "0 nan 0"), ("gravity", "nan")),
    ("mjcf_stiffness_inf", ("stiffness", "inf"), ("joint", "stiffness", "inf")),
    ("mjcf_damping_nan", ("damping", "nan"), ("joint", "damping", "nan")),
    ("mjcf_gear_nan", ("gear", "0 0 nan"), ("actuator 'coil5'", "gear", "nan")),
])


@mjcf_case("custom numeric 'vlab_modal_A'", "not finite")
def mjcf_modal_data_nan(t):
    m = re.search(r'(<numeric name="vlab_modal_A" size="\d+" data=")(\S+)', t)
    assert m
    return t[:m.start(2)] + "nan" + t[m.end(2):]


@mjcf_case("sensor vel5", "missing")
def mjcf_sensors_removed(t):
    return re.sub(r"<sensor>.*?</sensor>", "", t, flags=re.S)


@mjcf_case("coil9", "missing")
def mjcf_coil_renamed(t):
    return sub1(t, '<general name="coil9"', '<general name="coil9x"').replace('actuator="coil9"', 'actuator="coil9x"')


@mjcf_case("not a loadable MJCF", error=DataFileError)
def mjcf_truncated(t):
    return t[: len(t) // 2]


@mjcf_case("not a loadable MJCF", error=DataFileError)
def mjcf_binary(t):
    return b"\x89PNG\r\n\x1a\n" + bytes(range(256)) * 4


def _missing_mjcf(d):
    return d / "nope.xml"


CASES.append(Case("mjcf_missing", "mjcf", _missing_mjcf, read_mjcf, DataFileError, ("file not found",)))


# ==================================================== files named by an input stay in its folder
OUTSIDE = "../" * 12  # enough parents to reach the root from any temporary folder


toml_case.table(with_reference, [
    ("toml_reference_not_a_name", ("5",), ("reference.frequencies", "5")),
    ("toml_reference_parent_path", (f'"{OUTSIDE}etc/passwd"',),
     ("reference.frequencies", "reaches outside", "/etc/passwd", "--allow-outside-inputs")),
    ("toml_reference_absolute_path", ('"/etc/passwd"',), ("reference.frequencies", "reaches outside", "/etc/passwd")),
    ("toml_reference_device", ('"/dev/zero"',), ("reference.frequencies", "reaches outside", "/dev/zero")),
    ("toml_reference_missing", ('"mine.csv"',), ("reference.frequencies", "'mine.csv'", "not found")),
])


def _toml_naming_freq_csv(d):
    """The structure file naming ``freq.csv`` (made by the case) as its reference frequencies."""
    p = d / "bcc_edit.toml"
    p.write_text(with_reference(BCC_TOML, '"freq.csv"'))
    return p


def _toml_reference_symlink(d):
    (d / "freq.csv").symlink_to("/etc/passwd")
    return _toml_naming_freq_csv(d)


def _toml_reference_fifo(d):
    os.mkfifo(d / "freq.csv")
    return _toml_naming_freq_csv(d)


def _toml_reference_too_large(d):
    with open(d / "freq.csv", "wb") as fh:
        fh.truncate(65 * 2**20)  # sparse: no disk used
    return _toml_naming_freq_csv(d)


CASES += [
    Case("toml_reference_symlink_outside", "toml", _toml_reference_symlink, read_toml, SpecError,
         ("reference.frequencies", "'freq.csv'", "reaches outside", "/etc/passwd")),
    Case("toml_reference_fifo", "toml", _toml_reference_fifo, read_toml, SpecError,
         ("reference.frequencies", "not a regular file")),
    Case("toml_reference_too_large", "toml", _toml_reference_too_large, read_toml, SpecError,
         ("reference.frequencies", "68157440 bytes")),
]


def _mjcf_with(d, tail, extra=None):
    """The good MJCF with ``tail`` inserted before its last closing tag; ``extra(d)`` makes companion files."""
    t = good_mjcf_text()
    i = t.rindex("</mujoco>")
    p = d / "plant.xml"
    p.write_text(t[:i] + tail + t[i:])
    if extra is not None:
        extra(d)
    return p


CASES += [
    Case("mjcf_include_absolute", "mjcf", lambda d: _mjcf_with(d, '<include file="/etc/hostname"/>'), read_mjcf,
         DataFileError, ("<include file=\"/etc/hostname\">", "reaches outside", "--allow-outside-inputs")),
    Case("mjcf_include_parent", "mjcf", lambda d: _mjcf_with(d, f'<include file="{OUTSIDE}etc/passwd"/>'),
         read_mjcf, DataFileError, ("include", "reaches outside", "/etc/passwd")),
    Case("mjcf_include_device", "mjcf", lambda d: _mjcf_with(d, '<include file="/dev/zero"/>'), read_mjcf,
         DataFileError, ("/dev/zero", "reaches outside")),
    Case("mjcf_include_nested_outside", "mjcf",
         lambda d: _mjcf_with(d, '<include file="more.xml"/>', lambda d: (d / "more.xml").write_text(
             '<mujoco><include file="/etc/passwd"/></mujoco>')),
         read_mjcf, DataFileError, ("more.xml", "/etc/passwd", "reaches outside")),
    Case("mjcf_include_missing", "mjcf", lambda d: _mjcf_with(d, '<include file="nope_inc.xml"/>'), read_mjcf,
         DataFileError, ("nope_inc.xml", "not found")),
    Case("mjcf_mesh_outside", "mjcf",
         lambda d: _mjcf_with(d, '<asset><mesh name="m" file="/etc/passwd"/></asset>'), read_mjcf,
         DataFileError, ("<mesh file=", "reaches outside")),
    Case("mjcf_meshdir_outside", "mjcf",
         lambda d: _mjcf_with(d, '<compiler meshdir="/etc"/><asset><mesh name="m" file="passwd"/></asset>'),
         read_mjcf, DataFileError, ("<mesh file=\"passwd\">", "reaches outside", "/etc/passwd")),
]


# ======================================================= UFF 58 units: honoured or refused, never assumed
def _units_record(units_code=2, description="BG", length=0.3048, force=4.44822):
    return dict(type=164, units_code=units_code, units_description=description, temp_mode=2, length=length,
                force=force, temp=1.8, temp_offset=459.67)


def _with_units_record(p, **kw):
    def fn(sets):
        return [_units_record(**kw)] + sets
    return rewrite(p, fn)


field_cases("uff58-frf", write_frf, read_frf, [
    ("frf_per_lbf", 0, dict(orddenom_axis_units_lab="lbf"), ("per 'lbf'", "FRF record 1")),
    ("frf_abscissa_rpm", 0, dict(abscissa_axis_units_lab="rpm"), ("'rpm'", "frequency axis")),
    ("frf_denominator_exponents_not_force", 0, dict(orddenom_len_unit_exp=1, orddenom_force_unit_exp=0),
     ("orddenom_len_unit_exp 1", "specific data type 13")),
])
field_cases("uff58-time", write_rec, read_rec, [
    ("time_abscissa_ms", 1, dict(abscissa_axis_units_lab="ms"), ("time axis in 'ms'", "record 2")),
    ("time_velocity_with_force_exponents", 1, dict(ordinate_len_unit_exp=0, ordinate_force_unit_exp=1),
     ("ordinate_len_unit_exp 0", "ordinate_force_unit_exp 1", "specific data type 11")),
])


@case("uff58-frf", read_frf, DataFileError, "units record (dataset 164)", "'BG'", "length factor 0.3048")
def frf_units_record_not_si(d):
    return _with_units_record(write_frf(d))


@case("uff58-time", read_rec, DataFileError, "units record (dataset 164)", "force factor 4.44822")
def time_units_record_not_si(d):
    return _with_units_record(write_rec(d, good_recording()))


# ============================== a NaN written by pyuff (as 0) into a periodic excitation's force
def periodic_recording(n_periods=3):
    """Three periods of 1 s (the corpus's 1 Hz resolution) of a periodic force and responses."""
    from vlab.io.recording import Recording

    rng = np.random.default_rng(11)
    force = np.tile(0.5 * rng.standard_normal(N), n_periods)
    t = np.arange(force.size) * DT
    sig = {"force9": force}
    for p in (5, 7, 9, 6):
        sig[f"vel{p}"] = 1e-3 * np.sin(2 * np.pi * 3.0 * t + p) + 1e-5 * rng.standard_normal(force.size)
    return Recording.from_signals(DT, sig, metadata={"structure": "bcc", "seed": 1})


def _nan_through_pyuff(d, index, n_periods=3):
    """pyuff's writer turns NaN into 0 (``np.nan_to_num``): the file holds 0 where the NaN was."""
    def fn(sets):
        data = np.array(sets[0]["data"], dtype=float)
        data[index] = np.nan
        sets[0]["data"] = data
    return rewrite(write_rec(d, periodic_recording(n_periods)), fn)


CASES += [
    Case("time_force_nan_in_analysed_period", "uff58-time", lambda d: _nan_through_pyuff(d, 2 * N + 345),
         diagnose_rec, MeasurementError, ("force9", f"sample {2 * N + 345}", "period 3 of 3",
                                          "repeats exactly")),
    Case("time_force_nan_in_two_periods", "uff58-time", lambda d: _nan_through_pyuff(d, 17, n_periods=2),
         diagnose_rec, MeasurementError, ("force9", "samples 17 and 2017", "repeats exactly")),
]
