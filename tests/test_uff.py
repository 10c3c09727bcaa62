"""UFF 58/55 input/output (vlab.io.uff) with pyuff."""

from __future__ import annotations

import json
import os
import struct

import numpy as np
import pytest
import pyuff

from vlab.errors import DataFileError
from vlab.io.uff import (ModeShapes, read_frfs, read_mode_shapes, read_recording, sidecar_path,
                         write_frfs, write_mode_shapes, write_recording)
from vlab.io.recording import Recording
from vlab.io.frf import FRF
from vlab.measure.frf import h1


def _recording(n=1001, dt=1 / 2048):
    rng = np.random.default_rng(1)
    return Recording.from_signals(
        dt, {"force4": rng.standard_normal(n), "vel1": 1e-3 * rng.standard_normal(n),
             "vel5": 1e-3 * rng.standard_normal(n), "disp22": 1e-5 * rng.standard_normal(n)},
        metadata={"structure": "grid", "seed": 3, "controller": {"type": "MFDRF", "D": [[0.1]]}})


def _raw58(node, data, dt=1e-3, code=11, func=1, name="NONE", x=None, binary=0):
    """A UFF 58 time record written by 'another program' (no vlab ID lines)."""
    data = np.asarray(data, dtype=float)
    return dict(type=58, binary=binary, func_type=func, rsp_node=node, rsp_dir=3, ref_node=0, ref_dir=0,
                x=np.arange(data.size) * dt if x is None else x, data=data, abscissa_spacing=1,
                abscissa_spec_data_type=17, ordinate_spec_data_type=code,
                orddenom_spec_data_type=0, id1=name)


def _write_raw(path, dsets):
    pyuff.UFF(str(path)).write_sets(dsets, mode="add")
    return path


# --------------------------------------------------------------------------- recordings
def test_recording_round_trip_is_identical(tmp_path):
    rec = _recording()
    path = write_recording(tmp_path / "run.uff", rec)
    assert path.is_file() and sidecar_path(path).is_file()
    back = read_recording(path)
    assert back == rec                                   # names, points, quantities, samples, metadata
    assert back.dt_s == 1 / 2048                         # exact, not the header's 6 digits
    assert back.channel("disp22").quantity == "displacement"
    raw = pyuff.UFF(str(path)).read_sets()
    assert [d["rsp_node"] for d in raw] == [4, 1, 5, 22]
    assert {d["rsp_dir"] for d in raw} == {3}
    assert [d["ordinate_spec_data_type"] for d in raw] == [13, 11, 11, 8]
    assert {d["func_type"] for d in raw} == {1}


def test_recording_ascii_round_trip(tmp_path):
    rec = _recording(n=50)
    back = read_recording(write_recording(tmp_path / "run.uff", rec, binary=False))
    for a, b in zip(rec, back):
        np.testing.assert_allclose(b.samples, a.samples, rtol=1e-10)
    assert back.dt_s == rec.dt_s


def test_write_never_silently_overwrites(tmp_path):
    rec = _recording(n=20)
    path = write_recording(tmp_path / "run.uff", rec)
    before = path.read_bytes()
    with pytest.raises(DataFileError, match="exists; pass overwrite=True"):
        write_recording(path, rec.with_metadata(seed=4))
    assert path.read_bytes() == before
    os.remove(path)                                      # sidecar alone also protects
    with pytest.raises(DataFileError, match=r"run\.uff\.json: file exists"):
        write_recording(path, rec)
    write_recording(path, rec.with_metadata(seed=4), overwrite=True)
    assert read_recording(path).metadata["seed"] == 4
    assert json.loads(sidecar_path(path).read_text())["seed"] == 4
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.uff", "run.uff.json"]  # no temp files left


def test_unserialisable_metadata_is_refused(tmp_path):
    rec = _recording(n=20).with_metadata(rng=np.random.default_rng(0))
    with pytest.raises(DataFileError, match=r"\['rng'\]"):
        write_recording(tmp_path / "run.uff", rec)
    assert not (tmp_path / "run.uff").exists()


def test_truncated_files_are_detected(tmp_path):
    path = write_recording(tmp_path / "run.uff", _recording(n=500))
    data = path.read_bytes()
    cut = tmp_path / "cut.uff"
    cut.write_bytes(data[: len(data) // 2])                       # inside a record
    with pytest.raises(DataFileError, match=r"cut\.uff: truncated"):
        read_recording(cut)
    end_of_first = data.index(b"    -1", data.index(b"58b")) + len(b"    -1\n")
    cut.write_bytes(data[:end_of_first])                          # at a record boundary
    with pytest.raises(DataFileError, match="truncated UFF: 1 dataset-58 record"):
        read_recording(cut)


def test_malformed_missing_and_empty_files(tmp_path):
    junk = tmp_path / "junk.uff"
    junk.write_text("this is not\na universal file\n")
    with pytest.raises(DataFileError, match="junk.uff"):
        read_recording(junk)
    with pytest.raises(DataFileError, match="no such file"):
        read_recording(tmp_path / "missing.uff")
    empty = tmp_path / "empty.uff"
    empty.write_text("")
    with pytest.raises(DataFileError, match="empty file"):
        read_recording(empty)


def test_nan_sample_names_file_and_channel(tmp_path):
    # pyuff replaces NaN by 0 when writing, so patch a sentinel in the binary data instead
    sentinel = 12345.678
    path = _write_raw(tmp_path / "nan.uff", [_raw58(4, [0.0, 1.0, 2.0, 3.0], code=13, binary=1),
                                            _raw58(1, [0.0, sentinel, 2.0, 3.0], name="vel1", binary=1)])
    raw = path.read_bytes()
    packed = struct.pack("<d", sentinel)
    assert raw.count(packed) == 1
    path.write_bytes(raw.replace(packed, struct.pack("<d", float("nan"))))
    with pytest.raises(DataFileError, match=r"nan\.uff: channel vel1: non-finite sample at index 1"):
        read_recording(path)


def test_mismatched_rates_and_lengths(tmp_path):
    rates = _write_raw(tmp_path / "rates.uff", [_raw58(4, np.zeros(10), dt=1e-3, code=13),
                                                _raw58(1, np.zeros(10), dt=2e-3)])
    with pytest.raises(DataFileError, match=r"rates\.uff: channel vel1 is sampled every 0\.002 s"):
        read_recording(rates)
    lengths = _write_raw(tmp_path / "len.uff", [_raw58(4, np.zeros(10), code=13),
                                                _raw58(1, np.zeros(12))])
    with pytest.raises(DataFileError, match=r"len\.uff: channel vel1 has 12 samples, channel force4 has 10"):
        read_recording(lengths)
    weird = _write_raw(tmp_path / "weird.uff", [_raw58(4, np.zeros(10), code=2)])
    with pytest.raises(DataFileError, match="unsupported ordinate specific data type 2"):
        read_recording(weird)


def test_foreign_file_gets_conventional_names(tmp_path):
    path = _write_raw(tmp_path / "sti.uff", [_raw58(4, np.arange(8.0), code=13),
                                             _raw58(1, np.ones(8))])
    rec = read_recording(path)
    assert rec.names == ("force4", "vel1")
    assert rec.dt_s == pytest.approx(1e-3)
    assert dict(rec.metadata) == {}


# --------------------------------------------------------------------------- FRFs
def _frfs():
    rng = np.random.default_rng(0)
    x = rng.standard_normal(4096)
    y = np.convolve(x, [0.5, 0.3, 0.1], mode="same") + 0.01 * rng.standard_normal(x.size)
    hv = h1(x, y, dt_s=1 / 200, resolution_hz=0.5, input_name="force4", output_name="vel1",
            input_point=4, output_point=1)
    return [hv, hv.to_displacement(),
            FRF(freq_hz=[1.0, 2.0, 3.0], h=[1 + 1j, 2, 3j], response="acceleration",
                output_name="acc2", input_name="force4", output_point=2, input_point=4)]


def test_frf_round_trip_is_identical(tmp_path):
    frfs = _frfs()
    path = write_frfs(tmp_path / "frf.uff", frfs)
    back = read_frfs(path)
    assert back == frfs
    assert back[0].n_averages == frfs[0].n_averages and back[2].coherence is None
    raw = pyuff.UFF(str(path)).read_sets()
    assert [d["func_type"] for d in raw] == [4, 6, 4, 6, 4]
    assert (raw[0]["rsp_node"], raw[0]["ref_node"], raw[0]["orddenom_spec_data_type"]) == (1, 4, 13)
    with pytest.raises(DataFileError, match="exists"):
        write_frfs(path, frfs)
    write_frfs(path, {"vel1": frfs[0]}, overwrite=True)
    assert read_frfs(path) == [frfs[0]]


def test_frf_without_points_cannot_be_written(tmp_path):
    frf = FRF(freq_hz=[1.0, 2.0], h=[1.0, 2.0], output_name="vel1", input_name="force4")
    with pytest.raises(DataFileError, match="FRF vel1/force4 has no output_point"):
        write_frfs(tmp_path / "frf.uff", [frf])


def test_non_finite_frf_is_refused(tmp_path):
    frf = FRF(freq_hz=[1.0, 2.0], h=[1.0, np.nan], output_name="vel1", input_name="force4",
              output_point=1, input_point=4)
    with pytest.raises(DataFileError, match="FRF vel1/force4: non-finite"):
        write_frfs(tmp_path / "frf.uff", [frf])


def test_reading_frfs_from_a_time_file_fails(tmp_path):
    path = write_recording(tmp_path / "run.uff", _recording(n=20))
    with pytest.raises(DataFileError, match="no dataset-58 FRF"):
        read_frfs(path)


# --------------------------------------------------------------------------- mode shapes
def test_mode_shapes_round_trip_real_and_complex(tmp_path):
    rng = np.random.default_rng(2)
    real = ModeShapes(freq_hz=[1.9, 4.8, 7.3], shapes=rng.standard_normal((4, 3)),
                      point_ids=[9, 7, 6, 5], damping_ratio=[0.004, 0.003, 0.01],
                      description="BCC experiment")
    back = read_mode_shapes(write_mode_shapes(tmp_path / "modes.uff", real))
    np.testing.assert_allclose(back.freq_hz, real.freq_hz, rtol=1e-5)
    np.testing.assert_allclose(back.damping_ratio, real.damping_ratio, rtol=1e-5)
    np.testing.assert_allclose(back.shapes, real.shapes, rtol=1e-5)   # E13.5: 6 significant digits
    assert back.point_ids.tolist() == [9, 7, 6, 5] and back.description == "BCC experiment"
    cplx = ModeShapes(freq_hz=[2.0], shapes=rng.standard_normal((3, 1)) + 1j * rng.standard_normal((3, 1)),
                      point_ids=[1, 2, 4], damping_ratio=[0.05])
    back = read_mode_shapes(write_mode_shapes(tmp_path / "cmodes.uff", cplx))
    np.testing.assert_allclose(back.shapes, cplx.shapes, rtol=1e-5)
    assert back.freq_hz[0] == pytest.approx(2.0, rel=1e-5)
    assert back.damping_ratio[0] == pytest.approx(0.05, rel=1e-5)
    with pytest.raises(DataFileError, match="exists"):
        write_mode_shapes(tmp_path / "modes.uff", real)


def test_mode_shapes_validation():
    with pytest.raises(DataFileError, match="must be"):
        ModeShapes(freq_hz=[1.0, 2.0], shapes=np.ones((3, 1)), point_ids=[1, 2, 3])
    with pytest.raises(DataFileError, match="distinct"):
        ModeShapes(freq_hz=[1.0], shapes=np.ones((2, 1)), point_ids=[1, 1])
