"""Recordings from an acquisition system, checked against closed forms.

Files are written here by pyuff itself (not by vlab's writer) or as CSV text; every expected value
is computed in this file from its definition: the unit factors (NIST SP 811), the units record's
"divide by the factor" rule (UFF dataset 164), the FRF of a known multisine in acceleration,
displacement or velocity (``H_v = H_a / (j w)``, ``H_v = j w H_d``) times the zero-order hold
``(1 - e^{-j w T}) / (j w T)`` of the lab's command, and the passband of the resampling filter
measured on a sinusoid.
"""

from __future__ import annotations

import numpy as np
import pytest

from vlab.errors import DataFileError

pyuff = pytest.importorskip("pyuff")

G = 9.80665
LBF = 4.4482216152605
INCH = 0.0254


def _record(node, direction, code, data, dt, label, *, exps=(1, 0), id1="NONE"):
    return pyuff.prepare_58(
        binary=0, id1=id1, id2="acquisition", id3="NONE", id4="NONE", id5="NONE", func_type=1, rsp_node=node,
        rsp_dir=direction, ref_node=0, ref_dir=0, data=np.asarray(data, float), x=np.arange(len(data)) * dt,
        abscissa_spacing=1, abscissa_min=0.0, abscissa_inc=dt, abscissa_spec_data_type=17,
        abscissa_axis_units_lab="s", ordinate_spec_data_type=code, ordinate_len_unit_exp=exps[0],
        ordinate_force_unit_exp=exps[1], ordinate_axis_units_lab=label, orddenom_spec_data_type=0,
        z_axis_spec_data_type=0)


def _write(path, records, units=None):
    sets = ([pyuff.prepare_164(units_code=units[0], units_description=units[1], temp_mode=2, length=units[2],
                               force=units[3], temp=1.0, temp_offset=273.15)] if units else []) + records
    pyuff.UFF(str(path)).write_sets(sets, mode="overwrite")
    return path


def _signal(n=400, dt=2e-4):
    t = np.arange(n) * dt
    return np.sin(2 * np.pi * 7.0 * t) + 0.3 * np.cos(2 * np.pi * 19.0 * t)


# ----------------------------------------------------------------------------- units
def test_unit_labels_convert_to_si(tmp_path):
    from vlab.io.uff_acquired import read_acquired_uff

    x = _signal()
    p = _write(tmp_path / "a.uff", [_record(9, 3, 13, x, 2e-4, "lbf", exps=(0, 1)),
                                   _record(6, 3, 12, x, 2e-4, "g"),
                                   _record(5, -3, 11, x, 2e-4, "mm/s", id1="Point 5 -Z"),
                                   _record(7, 3, 8, x, 2e-4, "in")])
    rec = read_acquired_uff(p)
    assert rec.dt_s == pytest.approx(2e-4)
    assert set(rec.names) == {"force9", "acc6", "vel5-Z", "disp7"}
    assert np.allclose(rec["force9"], x * LBF, rtol=1e-9)
    assert np.allclose(rec["acc6"], x * G, rtol=1e-9)
    assert np.allclose(rec["vel5-Z"], x * 1e-3, rtol=1e-9)
    assert np.allclose(rec["disp7"], x * INCH, rtol=1e-9)
    assert rec.channel("vel5-Z").direction == -3
    assert rec.metadata["channel_labels"]["vel5-Z"] == "Point 5 -Z"
    assert rec.metadata["units_in_file"]["acc6"] == "g"


def test_units_record_divides_by_its_factors(tmp_path):
    """Dataset 164, record 2: "to convert from universal file units to SI divide by the factor" (inch, lbf)."""
    from vlab.io.uff_acquired import read_acquired_uff

    x = _signal()
    units = (7, "IN: Inch (pound f)", 1 / INCH, 1 / LBF)
    p = _write(tmp_path / "b.uff", [_record(9, 3, 13, x, 2e-4, "NONE", exps=(0, 1)),
                                   _record(6, 3, 12, x, 2e-4, ""),
                                   _record(7, 3, 11, x, 2e-4, "in/s")], units=units)
    rec = read_acquired_uff(p)
    assert np.allclose(rec["force9"], x * LBF, rtol=1e-9)
    assert np.allclose(rec["acc6"], x * INCH, rtol=1e-9)
    assert np.allclose(rec["vel7"], x * INCH, rtol=1e-9)


def test_contradicting_or_unknown_units_are_refused(tmp_path):
    from vlab.io.uff_acquired import read_acquired_uff

    x = _signal()
    units = (7, "IN: Inch (pound f)", 1 / INCH, 1 / LBF)
    p = _write(tmp_path / "c.uff", [_record(9, 3, 13, x, 2e-4, "N", exps=(0, 1))], units=units)
    with pytest.raises(DataFileError, match=r"c\.uff.*'N'.*contradicts the units record 'IN: Inch"):
        read_acquired_uff(p)
    p = _write(tmp_path / "d.uff", [_record(6, 3, 12, x, 2e-4, "furlong/s^2")])
    with pytest.raises(DataFileError, match=r"d\.uff: record 1, channel acc6: ordinate unit label 'furlong/s\^2'"):
        read_acquired_uff(p)
    p = _write(tmp_path / "e.uff", [_record(6, 3, 12, x, 2e-4, "m/s^2"), _record(6, 3, 12, x, 2e-4, "g")])
    with pytest.raises(DataFileError, match=r"e\.uff: duplicate channel acc6 \(record 2\)"):
        read_acquired_uff(p)


# ----------------------------------------------------------------------------- CSV
def _csv(path, header, rows, comment="# acquisition export"):
    lines = [comment, ",".join(header)] + [",".join(f"{v:.10g}" for v in r) for r in rows]
    path.write_text("\n".join(lines) + "\n")
    return path


def test_csv_time_histories_convert_to_si(tmp_path):
    from vlab.io.csv_time import is_time_csv, read_time_csv

    n, dt = 500, 1 / 5120
    t = np.round(np.arange(n) * dt, 7)  # printed to 0.1 us: off the grid by less than 1 % of a step
    x = _signal(n, dt)
    p = _csv(tmp_path / "r.csv", ["time [s]", "9+Z force [lbf]", "6 Z acceleration [g]", "5-Z velocity [mm/s]"],
             np.c_[t, x, 2 * x, 3 * x])
    assert is_time_csv(p)
    rec = read_time_csv(p)
    assert rec.dt_s == pytest.approx(dt, rel=1e-9)
    assert np.allclose(rec["force9"], x * LBF, rtol=1e-8)
    assert np.allclose(rec["acc6"], 2 * x * G, rtol=1e-8)
    assert np.allclose(rec["vel5-Z"], 3 * x * 1e-3, rtol=1e-8)


@pytest.mark.parametrize("header, edit, message", [
    (["time [s]", "6+Z accel [g]"], None, r"column 2 header '6\+Z accel \[g\]' is not"),
    (["time [s]", "6+Z acceleration []"], None, r"column 2 header .*: no unit"),
    (["time [s]", "6+Z acceleration [parsec]"], None, r"unit 'parsec' is not a unit of acceleration"),
    (["time [ms]", "6+Z acceleration [g]"], None, r"line 3: the first column must be 'time \[s\]'"),
    (["time [s]", "6+Z acceleration [g]", "6+Z acceleration [m/s^2]"], None, r"columns 2 and 3 both hold"),
    (["time [s]", "6+Z acceleration [g]"], ("row", 5, "abc"), r"line 9, column 2: 'abc' is not a number"),
    (["time [s]", "6+Z acceleration [g]"], ("row", 4, "nan"), r"line 8, column 2: non-finite value"),
    (["time [s]", "6+Z acceleration [g]"], ("time", 9, 0.0031), r"line 13: time 0.0031 s is .* steps off"),
])
def test_csv_errors_name_the_line_and_column(tmp_path, header, edit, message):
    from vlab.io.csv_time import read_time_csv

    t = np.arange(40) * 2e-4
    rows = [[f"{a:.10g}"] + [f"{np.sin(40 * a + k):.6g}" for k in range(len(header) - 1)] for a in t]
    if edit and edit[0] == "row":
        rows[edit[1]][1] = edit[2]
    if edit and edit[0] == "time":
        rows[edit[1]][0] = f"{edit[2]:g}"
    p = tmp_path / "bad.csv"
    p.write_text("# one comment\n\n" + ",".join(header) + "\n" + "\n".join(",".join(r) for r in rows) + "\n")
    with pytest.raises(DataFileError, match=r"bad\.csv.*" + message):
        read_time_csv(p)


# ----------------------------------------------------------------------------- resampling
@pytest.mark.parametrize("rate", [5000.0, 5120.0, 10240.0, 1024.0, 2000.0])
def test_resampling_passband_below_its_bound(rate):
    """The filter's stated bound over the BCC band, and a 25 Hz sinusoid resampled onto the loop's clock:
    amplitude within the bound, no time shift (output sample j at input time j down / up)."""
    from vlab.diagnose.data.acquired import PASSBAND_ERROR, passband_error, resample, resampling_ratio

    up, down = resampling_ratio(rate, 4000.0)
    assert rate * up / down == pytest.approx(4000.0, rel=1e-12)
    assert passband_error(up, down, rate, np.linspace(0.0, 25.0, 101)) < PASSBAND_ERROR
    n = int(round(rate * 2.0))  # two whole seconds: 50 periods of 25 Hz
    t_in = np.arange(n) / rate
    for periodic in (True, False):
        y = resample(np.sin(2 * np.pi * 25.0 * t_in + 0.4), up, down, periodic=periodic)
        t_out = np.arange(y.size) / 4000.0
        mid = slice(400, y.size - 400)  # away from the ends (a line-extended record's filter edge)
        want = np.sin(2 * np.pi * 25.0 * t_out + 0.4)
        assert np.max(np.abs(y[mid] - want[mid])) < 2 * PASSBAND_ERROR
        if periodic:
            assert np.max(np.abs(y - want)) < 2 * PASSBAND_ERROR


def test_rates_that_are_no_small_ratio_are_refused():
    from vlab.diagnose.data.acquired import resampling_ratio

    with pytest.raises(DataFileError, match="not a ratio of small integers"):
        resampling_ratio(5000.0 * (1 + 1e-7), 4000.0, "x.uff")


def test_velocity_history_integrates_a_cosine_exactly():
    from vlab.diagnose.data.acquired import velocity_history

    dt, f = 5e-4, 3.0
    t = np.arange(4000) * dt  # six whole periods
    w = 2 * np.pi * f
    v = velocity_history("acceleration", 2.0 * np.cos(w * t) + 0.7, dt, 0.25)  # the offset is dropped
    assert np.allclose(v, 2.0 / w * np.sin(w * t), atol=1e-12)
    d = velocity_history("displacement", 2.0 * np.cos(w * t), dt, 0.25)
    assert np.allclose(d, -2.0 * w * np.sin(w * t), atol=1e-9)


# ----------------------------------------------------------------------------- FRFs of a known multisine
LINES_HZ = np.array([2.0, 5.0, 8.0, 11.0, 14.0, 17.0, 20.0, 23.0])


def _h_true(f):
    """A made-up velocity-per-force FRF [(m/s)/N] (a damped mode at 9 Hz)."""
    s = 2j * np.pi * f
    return 0.05 * s / (s**2 + 2 * 0.02 * 2 * np.pi * 9 * s + (2 * np.pi * 9) ** 2) * (2 * np.pi * 9) ** 2 / 20


def _multisine_recording(rate, quantity, direction=3, periods=4):
    """Force at 9 and a motion channel at 6 in the quantity asked, exact sums of sinusoids at ``rate``."""
    from vlab.io.recording import Channel, Recording

    t = np.arange(int(round(rate * periods))) / rate  # 1-s period
    rng = np.random.default_rng(5)
    ph = 2 * np.pi * rng.random(LINES_HZ.size)
    w = 2 * np.pi * LINES_HZ
    h_motion = {"velocity": _h_true(LINES_HZ), "acceleration": 1j * w * _h_true(LINES_HZ),
                "displacement": _h_true(LINES_HZ) / (1j * w)}[quantity]
    force = np.sum(0.2 * np.cos(np.outer(t, w) + ph), axis=1)
    motion = np.sum(0.2 * np.abs(h_motion) * np.cos(np.outer(t, w) + ph + np.angle(h_motion)), axis=1)
    sign = 1.0 if direction > 0 else -1.0
    return Recording(1.0 / rate, (Channel("force9", 9, "force", force),
                                  Channel("m6", 6, quantity, sign * motion, direction=direction)))


@pytest.mark.parametrize("rate, quantity, direction", [
    (5000.0, "acceleration", 3), (5120.0, "acceleration", -3), (10240.0, "displacement", 3),
    (1024.0, "velocity", 3), (2000.0, "acceleration", 3)])
def test_frf_of_a_known_multisine_is_the_lab_velocity_frf(rate, quantity, direction):
    """``h = H_v (1 - e^{-j w T}) / (j w T)`` on the excited lines, T = 0.5 ms, within the filter's bound."""
    from vlab.diagnose.data.acquired import PASSBAND_ERROR, frfs_from_acquired
    from vlab.fe import build_fe_model
    from vlab.spec import load_spec

    spec = load_spec("bcc")
    rec = _multisine_recording(rate, quantity, direction)
    data = frfs_from_acquired(rec, spec, build_fe_model(spec), path="m.uff", period_s=5e-4, resolution_hz=1.0,
                              band_hz=(0.5, 25.0))
    assert data.periodic and data.output_points == (6,) and data.excitation_point == 9
    assert np.allclose(data.freq_hz, LINES_HZ)
    wt = 2 * np.pi * LINES_HZ * 5e-4
    want = _h_true(LINES_HZ) * (1 - np.exp(-1j * wt)) / (1j * wt)
    assert np.max(np.abs(data.h[:, 0] / want - 1)) < 3 * PASSBAND_ERROR
    assert data.recording.dt_s == pytest.approx(5e-4) and set(data.recording.names) == {"force9", "vel6"}
    if direction < 0:
        assert any("turned over" in n for n in data.notes)


def test_acquired_recording_checks(tmp_path):
    from vlab.diagnose.data.acquired import frfs_from_acquired, is_lab_recording
    from vlab.fe import build_fe_model
    from vlab.io.recording import Channel, Recording
    from vlab.spec import load_spec

    spec = load_spec("bcc")
    fe = build_fe_model(spec)
    rec = _multisine_recording(5000.0, "acceleration")
    assert not is_lab_recording(rec)
    slow = _multisine_recording(40.0, "velocity")
    kw = dict(path="r.uff", period_s=5e-4, resolution_hz=1.0, band_hz=(0.5, 25.0))
    with pytest.raises(DataFileError, match="40 samples/s: the band up to 25 Hz needs more than 50"):
        frfs_from_acquired(slow, spec, fe, **kw)
    two = Recording(rec.dt_s, rec.channels + (Channel("v6", 6, "velocity", rec["m6"]),))
    with pytest.raises(DataFileError, match="channels m6 and v6 both measure point 6"):
        frfs_from_acquired(two, spec, fe, **kw)
    side = Recording(rec.dt_s, rec.channels + (Channel("a6x", 6, "acceleration", rec["m6"], direction=1),))
    data = frfs_from_acquired(side, spec, fe, **kw)
    assert data.output_points == (6,) and any("in-plane channels left out" in n and "a6x" in n for n in data.notes)
