"""HDF5 time histories (:mod:`vlab.io.hdf5_time`), checked against closed forms and against the CSV reader.

Files are written here with h5py itself. The unit factors are the definitions (NIST SP 811: g = 9.80665
m/s^2, lbf = 4.4482216152605 N, in = 0.0254 m). End to end, one recording written as CSV and as HDF5 (the
same numbers in the same units) gives the same FrfData, array for array, and the same diagnosis.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from vlab.errors import DataFileError, MeasurementError

h5py = pytest.importorskip("h5py")

G = 9.80665
LBF = 4.4482216152605
INCH = 0.0254
DT = 2e-4


def _h5(path, channels, *, attrs=None, time=None, group=None, order=False):
    """Write ``channels`` [(dataset name, samples, attributes or None)] and the sampling to ``path``."""
    with h5py.File(path, "w", track_order=order) as f:
        g = f if group is None else f.create_group(group, track_order=order)
        for k, v in (attrs or {}).items():
            g.attrs[k] = v
        if time is not None:
            g["time"] = time
        for name, data, a in channels:
            ds = g.create_dataset(name, data=np.asarray(data))
            for k, v in (a or {}).items():
                ds.attrs[k] = v
    return Path(path)


def _ch(node, direction, quantity, unit):
    return {"node": node, "direction": direction, "quantity": quantity, "unit": unit}


def _signal(n=400, dt=DT):
    t = np.arange(n) * dt
    return np.sin(2 * np.pi * 7.0 * t) + 0.3 * np.cos(2 * np.pi * 19.0 * t)


# ----------------------------------------------------------------------------- units and layout
def test_attributes_and_header_names_convert_to_si(tmp_path):
    from vlab.io.hdf5_time import read_time_hdf5

    x = _signal()
    p = _h5(tmp_path / "r.h5", [("force9", x, _ch(9, "+Z", "force", "lbf")),
                                ("acc6", 2 * x, _ch(6, "Z", "acceleration", "g")),
                                ("v5", 3 * x, _ch(5, "-Z", "velocity", "mm/s")),
                                ("d7", 4 * x, _ch(np.int32(7), np.int64(3), b"displacement", b"in")),
                                ("4+X acceleration [mg]", 5 * x, None)],
            time=np.arange(x.size) * DT)
    rec = read_time_hdf5(p)
    assert rec.dt_s == pytest.approx(DT, rel=1e-12)
    assert rec.names == ("acc4+X", "acc6", "disp7", "force9", "vel5-Z")  # by dataset name (order not tracked)
    assert np.allclose(rec["force9"], x * LBF, rtol=1e-12)
    assert np.allclose(rec["acc6"], 2 * x * G, rtol=1e-12)
    assert np.allclose(rec["vel5-Z"], 3 * x * 1e-3, rtol=1e-12)
    assert np.allclose(rec["disp7"], 4 * x * INCH, rtol=1e-12)
    assert np.allclose(rec["acc4+X"], 5 * x * 1e-3 * G, rtol=1e-12)
    assert rec.channel("vel5-Z").direction == -3 and rec.channel("acc4+X").direction == 1
    assert rec.metadata["channel_labels"]["vel5-Z"] == "/v5"
    assert rec.metadata["units_in_file"] == {"force9": "lbf", "acc6": "g", "vel5-Z": "mm/s", "disp7": "in",
                                             "acc4+X": "mg"}


@pytest.mark.parametrize("attrs", [{"dt_s": 1 / 5120}, {"sample_rate_hz": 5120.0},
                                   {"sample_rate_hz": np.array([5120]), "dt_s": 1 / 5120}])
def test_sampling_from_attributes_in_a_group(tmp_path, attrs):
    from vlab.io.hdf5_time import read_time_hdf5

    x = _signal(300, 1 / 5120)
    p = _h5(tmp_path / "g.hdf5", [("f", x, _ch(9, 3, "force", "N")), ("a", x, _ch(6, 3, "acceleration", "m/s^2"))],
            attrs=attrs, group="run1", order=True)
    rec = read_time_hdf5(p, group="run1")
    assert rec.dt_s == 1 / 5120 and rec.names == ("force9", "acc6") and rec.metadata["group"] == "/run1"
    with h5py.File(p, "a") as f:  # the root's attribute serves a group without its own
        del f["run1"].attrs["sample_rate_hz" if "sample_rate_hz" in attrs else "dt_s"]
        f["run1"].attrs.pop("dt_s", None)
        f.attrs["dt_s"] = 1 / 5120
    assert read_time_hdf5(p, group="/run1").dt_s == 1 / 5120


def test_read_uff_any_reads_hdf5_by_suffix(tmp_path):
    from vlab.diagnose.data.readers import detect_kind, read_uff_any

    x = _signal()
    for suffix in (".h5", ".HDF5"):
        p = _h5(tmp_path / f"r{suffix}", [("9+Z force [N]", x, None)], attrs={"dt_s": DT})
        assert detect_kind(p) == "uff"
        what, rec = read_uff_any(p)
        assert what == "recording" and rec.names == ("force9",)


def test_without_h5py_the_install_command_is_named(tmp_path, monkeypatch):
    from vlab.io.hdf5_time import read_time_hdf5

    p = _h5(tmp_path / "r.h5", [("9+Z force [N]", _signal(), None)], attrs={"dt_s": DT})
    monkeypatch.setitem(sys.modules, "h5py", None)  # import h5py raises ImportError
    with pytest.raises(DataFileError, match=r"r\.h5: reading HDF5 time histories needs the h5py package: "
                                            r"pip install \"vlab\[hdf5\]\""):
        read_time_hdf5(p)


# ----------------------------------------------------------------------------- errors
def _edit_attr(key, value):
    def edit(f):
        f["acc6"].attrs[key] = value
    return edit


def _del_attr(key):
    def edit(f):
        del f["acc6"].attrs[key]
    return edit


def _samples_at(index, value):
    def edit(f):
        x = f["acc6"][()]
        x[index] = value
        f["acc6"][...] = x
    return edit


def _replace(name, data, attrs=None, where=""):
    def edit(f):
        g = f[where] if where else f
        if name in g:
            del g[name]
        g[name] = data
        for k, v in (attrs or {}).items():
            g[name].attrs[k] = v
    return edit


def _root_attr(key, value):
    def edit(f):
        f.attrs[key] = value
    return edit


def _uneven(f):
    t = f["time"][()]
    t[9] += 0.3 * DT
    f["time"][...] = t


ERRORS = [
    (_del_attr("unit"), r"dataset '/acc6': attribute 'unit' missing \(a channel's attributes are node, direction, "
                        r"quantity, unit; found node, direction, quantity\)"),
    (_edit_attr("unit", "parsec"), r"dataset '/acc6': attribute 'unit': unit 'parsec' is not a unit of acceleration"),
    (_edit_attr("unit", ""), r"dataset '/acc6': attribute 'unit': no unit; write one of"),
    (_edit_attr("quantity", "accel"), r"dataset '/acc6': attribute 'quantity' = 'accel' is not one of force"),
    (_edit_attr("node", 0), r"dataset '/acc6': attribute 'node' = 0 is not a point id"),
    (_edit_attr("node", 2.5), r"dataset '/acc6': attribute 'node' = 2.5 is not a point id"),
    (_edit_attr("direction", "up"), r"dataset '/acc6': attribute 'direction' = 'up' is not a direction"),
    (_edit_attr("direction", 4), r"dataset '/acc6': attribute 'direction' = 4 is not a direction"),
    (_replace("a6", np.zeros(40) + 1.0, _ch(6, "+Z", "acceleration", "m/s^2")),
     r"datasets '/a6' and '/acc6' both hold acceleration at node 6, direction 3 \(acc6\)"),
    (_replace("trigger", np.zeros(40)), r"dataset '/trigger': name 'trigger' is not '<node><\+\|-><X\|Y\|Z> "
                                        r"<quantity> \[<unit>\]'.*; or give the dataset the attributes node"),
    (_replace("6+Z acceleration [furlong]", np.zeros(40)),
     r"dataset '/6\+Z acceleration \[furlong\]': name .*: unit 'furlong' is not a unit of acceleration"),
    (_samples_at(5, np.nan), r"dataset '/acc6', index 5: non-finite value nan \(1 in all\)"),
    (_replace("acc6", np.zeros((40, 2)), _ch(6, 3, "acceleration", "g")), r"dataset '/acc6': shape \(40, 2\) is not"),
    (_replace("acc6", np.array(["a"] * 40, dtype="S1"), _ch(6, 3, "acceleration", "g")),
     r"dataset '/acc6': type \|S1 is not real numbers"),
    (_replace("acc6", np.zeros(39) + 1.0, _ch(6, 3, "acceleration", "g")),
     r"dataset '/force9' has 40 samples, dataset '/acc6' 39"),
    (_uneven, r"dataset '/time', index 9: time .* s is 0.3\d* steps off the evenly spaced grid"),
    (_replace("time", np.arange(40) * -DT), r"dataset '/time': the step -[\d.]+ s is not positive \(index 0 to "
                                            r"index 39\)"),
    (_replace("time", np.arange(41) * DT), r"dataset '/time' has 41 instants, the channels 40 samples"),
    (_root_attr("dt_s", 2 * DT), r"dataset '/time' gives a step of 0.0002 s, group '/': attribute 'dt_s' 0.0004 s"),
    (_root_attr("sample_rate_hz", -5.0), r"group '/': attribute 'sample_rate_hz' = -5.0 is not a positive number"),
    (_root_attr("dt_s", True), r"group '/': attribute 'dt_s' = True is not a positive number"),
    (_replace("time", np.arange(40) * DT, {"unit": "ms"}), r"dataset '/time': attribute 'unit' = 'ms': the time "
                                                           r"must be in seconds"),
]


@pytest.mark.parametrize("edit, message", ERRORS)
def test_errors_name_the_file_dataset_and_attribute(tmp_path, edit, message):
    from vlab.io.hdf5_time import read_time_hdf5

    t = np.arange(40) * DT
    p = _h5(tmp_path / "bad.h5", [("acc6", np.sin(40 * t + 1), _ch(6, "+Z", "acceleration", "g")),
                                  ("force9", np.sin(30 * t), _ch(9, "+Z", "force", "N"))], time=t)
    with h5py.File(p, "a") as f:
        edit(f)
    with pytest.raises(DataFileError, match=r"bad\.h5: " + message):
        read_time_hdf5(p)


def test_file_level_errors(tmp_path):
    from vlab.io.hdf5_time import read_time_hdf5

    x = _signal(40)
    with pytest.raises(DataFileError, match=r"none\.h5: no such file"):
        read_time_hdf5(tmp_path / "none.h5")
    (tmp_path / "text.h5").write_text("time [s],9+Z force [N]\n")
    with pytest.raises(DataFileError, match=r"text\.h5: not a readable HDF5 file"):
        read_time_hdf5(tmp_path / "text.h5")
    p = _h5(tmp_path / "g.h5", [("9+Z force [N]", x, None)], group="run1")
    with pytest.raises(DataFileError, match=r"g\.h5: no group 'run2' \(groups at the root: run1\)"):
        read_time_hdf5(p, group="run2")
    with pytest.raises(DataFileError, match=r"g\.h5: group '/' holds no channel dataset"):
        read_time_hdf5(p)
    with pytest.raises(DataFileError, match=r"g\.h5: group '/run1': no sampling: give a 'time' dataset"):
        read_time_hdf5(p, group="run1")
    p = _h5(tmp_path / "s.h5", [("9+Z force [N]", x[:3], None)], attrs={"dt_s": DT})
    with pytest.raises(DataFileError, match=r"s\.h5: group '/': 3 sample\(s\); a record needs at least 4"):
        read_time_hdf5(p)


def test_clipped_channel_is_refused_unless_allowed(tmp_path):
    from vlab.io.hdf5_time import read_time_hdf5

    x = np.clip(_signal(), -0.8, 0.8)
    p = _h5(tmp_path / "c.h5", [("acc6", x, _ch(6, "+Z", "acceleration", "g"))], attrs={"dt_s": DT})
    with pytest.raises(MeasurementError, match=r"c\.h5: dataset '/acc6', channel acc6: clipped"):
        read_time_hdf5(p)
    assert np.allclose(read_time_hdf5(p, allow_clipped=True)["acc6"], x * G, rtol=1e-12)


# ----------------------------------------------------------------------------- the same data as CSV and as HDF5
def _as_files(folder: Path, rec, units: dict, *, rate_attr: bool):
    """``rec`` written as CSV (shortest round-trip decimals) and as HDF5 (float64), values in ``units``
    (channel -> unit label); the HDF5 file's channels by their attributes, in the CSV's order (tracked)."""
    from vlab.io.quantity_units import UNIT_FACTORS

    cols = {c.name: np.asarray(c.samples) / UNIT_FACTORS[c.quantity][units[c.name].lower()] for c in rec.channels}
    t = np.arange(rec.n_samples) * rec.dt_s
    axis = {3: "+Z", -3: "-Z", 1: "+X"}
    header = ["time [s]"] + [f"{c.point_id}{axis[c.direction]} {c.quantity} [{units[c.name]}]" for c in rec.channels]
    rows = np.c_[t, np.column_stack(list(cols.values()))]
    csv = folder / "run.csv"
    csv.write_text(",".join(header) + "\n" + "\n".join(",".join(repr(float(v)) for v in r) for r in rows) + "\n")
    h5 = _h5(folder / "run.h5", [(f"ch_{c.name}", cols[c.name], _ch(c.point_id, axis[c.direction], c.quantity,
                                                                      units[c.name])) for c in rec.channels],
             attrs={"sample_rate_hz": 1 / rec.dt_s} if rate_attr else None, time=None if rate_attr else t,
             order=True)
    return csv, h5


def _frf_arrays(data):
    return {k: getattr(data, k) for k in ("freq_hz", "h", "var", "force_amplitude", "var_steady", "h_recorded")} | {
        "meta": (data.excitation_point, data.output_points, data.periodic, data.analysed_from_s, data.var_dof,
                 tuple(data.notes)), "recording": {c.name: np.asarray(c.samples) for c in data.recording.channels}}


def _assert_same(a, b):
    assert a.keys() == b.keys()
    for k in a:
        if isinstance(a[k], np.ndarray):
            assert np.array_equal(a[k], b[k]), k
        elif isinstance(a[k], dict):
            assert a[k].keys() == b[k].keys() and all(np.array_equal(a[k][n], b[k][n]) for n in a[k]), k
        else:
            assert a[k] == b[k], k


def test_acquired_multisine_gives_the_same_frfs_as_csv(tmp_path):
    """5120 samples/s, force in lbf, accelerations in g and m/s^2 (one turned over): resampled, converted to
    velocity FRFs -- the same arrays from either file."""
    from vlab.diagnose.data.readers import read_data, read_uff_any
    from vlab.fe import build_fe_model
    from vlab.io.recording import Channel, Recording
    from vlab.spec import load_spec

    rate, lines = 5120.0, np.arange(2.0, 24.0, 3.0)
    t = np.arange(int(rate * 3)) / rate  # three 1-s periods
    ph = np.random.default_rng(3).uniform(0, 2 * np.pi, (3, lines.size))
    w = 2 * np.pi * lines
    sig = [np.cos(np.outer(t, w) + p) @ (0.1 + 0.02 * k * np.arange(lines.size)) for k, p in enumerate(ph)]
    rec = Recording(1 / rate, (Channel("force9", 9, "force", sig[0]), Channel("acc6", 6, "acceleration", sig[1]),
                               Channel("acc5-Z", 5, "acceleration", sig[2], direction=-3)))
    csv, h5 = _as_files(tmp_path, rec, {"force9": "lbf", "acc6": "g", "acc5-Z": "m/s^2"}, rate_attr=False)
    spec = load_spec("bcc")
    fe = build_fe_model(spec)
    frfs = []
    for path in (csv, h5):
        what, got = read_uff_any(path)
        frfs.append(read_data(spec, fe, path, what, got, resolution_hz=1.0, band_hz=(0.5, 25.0),
                              settle_of=lambda: 0.0))
    assert frfs[0].output_points == (6, 5) and np.allclose(frfs[0].freq_hz, lines)
    _assert_same(_frf_arrays(frfs[0]), _frf_arrays(frfs[1]))
    dead = _h5(tmp_path / "dead.h5", [("force9", sig[0], _ch(9, 3, "force", "N")),
                                      ("acc6", np.full(t.size, 0.5), _ch(6, 3, "acceleration", "g"))],
               attrs={"sample_rate_hz": rate})
    with pytest.raises(MeasurementError, match=r"dead\.h5: channel acc6: constant signal"):
        read_data(spec, fe, dead, *read_uff_any(dead), resolution_hz=1.0, band_hz=(0.5, 25.0), settle_of=lambda: 0.0)


@pytest.fixture(scope="module")
def mass_recording(tmp_path_factory):
    """0.12 kg at point 6 of the open-loop BCC, recorded on the linear lab (force and velocities at 2 kHz)."""
    from vlab.diagnose.effects import specedit
    from vlab.diagnose.model.labmodel import LabState
    from vlab.io.uff import read_recording
    from vlab.lab.loop import HardwareChain
    from vlab.models import nominal_fe_model

    from _recordings import record_linear

    fe = nominal_fe_model("bcc")
    nominal = LabState(fe.spec, fe, HardwareChain(noise_m_s=1e-6), None)
    truth = nominal.with_spec(specedit.add_mass(nominal.spec, 6, 0.12))
    path = record_linear(truth, tmp_path_factory.mktemp("mass") / "rec.uff", steady=True)
    return read_recording(path)


@pytest.mark.slow
def test_recording_as_hdf5_diagnoses_as_the_same_recording_as_csv(mass_recording, tmp_path):
    """Force in lbf, velocities in mm/s, no sidecar: the same verdict, statistic and fitted mass from either file."""
    from _recordings import RES_HZ
    from vlab.diagnose import diagnose

    units = {c.name: ("lbf" if c.quantity == "force" else "mm/s") for c in mass_recording.channels}
    csv, h5 = _as_files(tmp_path, mass_recording, units, rate_attr=True)
    verdicts = []
    for path in (csv, h5):
        d = diagnose("bcc", path, controller="none", plant="linear", resolution_hz=RES_HZ, validate_run=False,
                     effects=("added_mass",), pairs=False).as_dict()
        verdicts.append((d["mismatch"], d["statistics"], [(s["effect"], s["location"], s["parameters"])
                                                          for s in d["selected"]]))
    assert verdicts[0] == verdicts[1]
    mismatch, _stats, ((effect, location, parameters),) = verdicts[1]
    assert mismatch and effect == "added_mass" and location == {"point": 6}
    assert parameters["mass_kg"] == pytest.approx(0.12, rel=0.02)
