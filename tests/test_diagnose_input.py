"""Bad input to ``vlab.diagnose``: clear errors naming file and channel, nothing overwritten."""

from __future__ import annotations

import struct

import numpy as np
import pytest
import pyuff

from vlab.diagnose import diagnose
from vlab.errors import DataFileError, MeasurementError
from vlab.io.uff import write_recording
from vlab.lab.excitation import pseudo_random
from vlab.io.recording import Recording

DT = 0.5e-3


def _signals(n_periods=3.0, res=0.2, points=(5, 6, 7, 9)):
    n = int(round(n_periods / res / DT))
    t = np.arange(n) * DT
    force = pseudo_random(t, band_hz=(0.5, 25.0), resolution_hz=res, rms_n=0.5, seed=2)
    rng = np.random.default_rng(0)
    sig = {"force9": force}
    for p in points:
        sig[f"vel{p}"] = 1e-3 * np.sin(2 * np.pi * 1.3 * t + p) + 1e-5 * rng.standard_normal(n)
    return sig


def _write(path, sig, **meta):
    write_recording(path, Recording.from_signals(DT, sig, metadata={"structure": "bcc", **meta}), overwrite=True)
    return path


def _raw58(node, data, dt=DT, code=11, name="NONE", binary=0):
    data = np.asarray(data, dtype=float)
    return dict(type=58, binary=binary, func_type=1, rsp_node=node, rsp_dir=3, ref_node=0, ref_dir=0,
                x=np.arange(data.size) * dt, data=data, abscissa_spacing=1, abscissa_spec_data_type=17,
                ordinate_spec_data_type=code, orddenom_spec_data_type=0, id1=name)


def test_truncated_uff(tmp_path):
    p = _write(tmp_path / "rec.uff", _signals())
    raw = p.read_bytes()
    p.write_bytes(raw[: len(raw) // 2])
    with pytest.raises(DataFileError, match="rec.uff"):
        diagnose("bcc", p)


def test_garbage_file(tmp_path):
    p = tmp_path / "rec.uff"
    p.write_text("this is not a UFF file\n    -1\n")
    with pytest.raises(DataFileError, match="rec.uff"):
        diagnose("bcc", p)


def test_missing_file(tmp_path):
    with pytest.raises(DataFileError, match="nope.uff"):
        diagnose("bcc", tmp_path / "nope.uff")


def test_unknown_point_names_the_channel(tmp_path):
    sig = _signals()
    sig["vel42"] = sig.pop("vel6")
    p = _write(tmp_path / "rec.uff", sig)
    with pytest.raises(DataFileError, match=r"rec\.uff.*vel42.*point id 42"):
        diagnose("bcc", p)


def test_excitation_not_at_an_actuator(tmp_path):
    sig = _signals()
    sig["force6"] = sig.pop("force9")
    p = _write(tmp_path / "rec.uff", sig)
    with pytest.raises(DataFileError, match="force6.*not at an actuator"):
        diagnose("bcc", p)


def test_mismatched_sample_rates(tmp_path):
    sig = _signals()
    p = tmp_path / "rec.uff"
    sets = [_raw58(9, sig["force9"], code=13, name="force9"), _raw58(5, sig["vel5"], name="vel5"),
            _raw58(6, sig["vel6"], dt=1e-3, name="vel6")]
    pyuff.UFF(str(p)).write_sets(sets, mode="add")
    with pytest.raises(DataFileError, match=r"rec\.uff.*vel6"):
        diagnose("bcc", p)


def test_mismatched_lengths(tmp_path):
    sig = _signals()
    p = tmp_path / "rec.uff"
    sets = [_raw58(9, sig["force9"], code=13, name="force9"), _raw58(5, sig["vel5"][:-10], name="vel5")]
    pyuff.UFF(str(p)).write_sets(sets, mode="add")
    with pytest.raises(DataFileError, match=r"rec\.uff.*vel5"):
        diagnose("bcc", p)


def test_nan_samples(tmp_path):
    sig = _signals()
    v = sig["vel7"].copy()
    sentinel = 0.123456789e-3
    v[1234] = sentinel
    p = tmp_path / "rec.uff"
    sets = [_raw58(9, sig["force9"], code=13, name="force9", binary=1), _raw58(7, v, name="vel7", binary=1)]
    pyuff.UFF(str(p)).write_sets(sets, mode="add")
    raw = p.read_bytes()  # pyuff writes NaN as 0: put the NaN into the binary record directly
    assert raw.count(struct.pack("<d", sentinel)) == 1
    p.write_bytes(raw.replace(struct.pack("<d", sentinel), struct.pack("<d", float("nan"))))
    with pytest.raises(DataFileError, match=r"rec\.uff.*vel7.*non-finite"):
        diagnose("bcc", p)


def test_clipped_samples(tmp_path):
    sig = _signals()
    v = sig["vel7"]
    sig["vel7"] = np.clip(v, -0.8 * np.abs(v).max(), 0.8 * np.abs(v).max())
    p = _write(tmp_path / "rec.uff", sig)
    with pytest.raises(MeasurementError, match=r"rec\.uff.*vel7.*clipped"):
        diagnose("bcc", p)


def test_dead_channel(tmp_path):
    sig = _signals()
    sig["vel5"] = np.zeros_like(sig["vel5"])
    p = _write(tmp_path / "rec.uff", sig)
    with pytest.raises(MeasurementError, match="vel5.*constant"):
        diagnose("bcc", p)


def test_too_short_for_the_resolution(tmp_path):
    p = _write(tmp_path / "rec.uff", _signals(n_periods=1.5))
    with pytest.raises(MeasurementError, match=r"rec\.uff.*force9.*too short"):
        diagnose("bcc", p, resolution_hz=0.2)


def test_recording_of_another_structure(tmp_path):
    p = _write(tmp_path / "rec.uff", _signals(), structure="grid")
    with pytest.raises(DataFileError, match="grid"):
        diagnose("bcc", p)


def test_nothing_overwritten_on_bad_input(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "diagnosis.md").write_text("previous report")
    sig = _signals()
    sig["vel42"] = sig.pop("vel6")
    p = _write(tmp_path / "rec.uff", sig)
    before = p.read_bytes()
    with pytest.raises(DataFileError):
        diagnose("bcc", p, out_dir=out)
    assert (out / "diagnosis.md").read_text() == "previous report"
    assert sorted(x.name for x in out.iterdir()) == ["diagnosis.md"]
    assert p.read_bytes() == before


@pytest.mark.parametrize("text, match", [
    ("mode,frequency_hz\n1,abc\n", "line 2.*frequency_hz.*not a number"),
    ("mode,frequency_hz,shape_42\n1,1.8,1.0\n", "shape_42.*point id 42"),
    ("mode,frequency_hz,damping_ratio\n1,1.8,1.5\n", "damping ratio"),
    ("frequency_hz\n1.8\n", "no 'mode' column"),
    ("mode,frequency_hz\n1,1.8\n1,4.8\n", "repeated mode"),
    ("mode,frequency_hz\n1,1.8,3\n", "line 2: 3 fields"),
])
def test_malformed_modal_csv(tmp_path, text, match):
    p = tmp_path / "modes.csv"
    p.write_text(text)
    with pytest.raises(DataFileError, match=match):
        diagnose("bcc", p)


def _frf_data(h, var, freq=None, outputs=(5, 6), source="x.uff"):
    from vlab.diagnose.data.measured import FrfData

    freq = np.linspace(1.0, 2.0, h.shape[0]) if freq is None else freq
    return FrfData(source, "frf", freq, h, var, 9, tuple(outputs))


def test_baseline_referral_removes_the_shared_model_form_error():
    """H_rec * H_model / H_base: a plant offset present in both recordings cancels, a change is kept."""
    from vlab.diagnose.data.measured import refer_to_model

    rng = np.random.default_rng(0)
    h_model = rng.standard_normal((50, 2)) + 1j * rng.standard_normal((50, 2))
    offset = 1.0 + 0.3 * rng.standard_normal((50, 2))  # the plant against the model, in both recordings
    change = 1.0 + 0.1 * rng.standard_normal((50, 2))  # what happened since the baseline
    var = np.full((50, 2), 1e-6)
    base = _frf_data(h_model * offset, var, source="base.uff")
    data = _frf_data(h_model * offset * change, var)
    out = refer_to_model(data, base, h_model)
    np.testing.assert_allclose(out.h, h_model * change, rtol=1e-12)
    np.testing.assert_allclose(out.h_recorded, data.h)
    rel = out.var / np.abs(out.h) ** 2  # relative variances add, plus model-form error x change
    cross = np.abs(np.log(1 / offset)) * np.abs(np.log(change))
    np.testing.assert_allclose(rel, var / np.abs(data.h) ** 2 + var / np.abs(base.h) ** 2 + cross**2, rtol=1e-9)
    assert "base.uff" in out.notes[-1]
    # limits: nothing changed, or the model already matches the baseline -> only the two noises add
    for d_, b_ in ((base, base), (_frf_data(h_model * change, var), _frf_data(h_model, var))):
        o = refer_to_model(d_, b_, h_model)
        np.testing.assert_allclose(o.var / np.abs(o.h) ** 2,
                                   var / np.abs(d_.h) ** 2 + var / np.abs(b_.h) ** 2, rtol=1e-9)


def test_baseline_of_another_test_is_refused():
    from vlab.diagnose.data.measured import refer_to_model

    h = np.ones((10, 2), dtype=complex)
    var = np.full((10, 2), 1e-6)
    with pytest.raises(DataFileError, match="base.uff.*same test"):
        refer_to_model(_frf_data(h, var), _frf_data(h, var, outputs=(5, 7), source="base.uff"), h)
    with pytest.raises(DataFileError, match="base.uff.*lines"):
        refer_to_model(_frf_data(h, var), _frf_data(h, var, freq=np.linspace(1, 3, 10), source="base.uff"), h)


def test_modal_csv_uncertainty_columns_follow_the_frequency_order(tmp_path):
    from vlab.diagnose.data.modalcsv import read_modal_csv
    from vlab.spec import load_spec

    p = tmp_path / "modes.csv"
    p.write_text("\ufeffmode,frequency_hz,damping_ratio,frequency_sigma_hz,damping_sigma\n"
                 "2,4.8,0.002,0.02,\n1,1.9,0.004,0.01,0.001\n", encoding="utf-8")  # BOM, unsorted, one blank
    md = read_modal_csv(p, load_spec("bcc"))
    assert md.modes.tolist() == [1, 2]
    np.testing.assert_array_equal(md.freq_sigma_hz, [0.01, 0.02])
    assert md.damping_sigma[0] == 0.001 and np.isnan(md.damping_sigma[1])
    assert not md.notes                                   # the sigma columns are used, not ignored
