"""vlab.viz: rerun recordings read back with rerun.chunk.RrdReader; figures written with the right size."""

from __future__ import annotations

import struct
import subprocess
import sys

import numpy as np
import pytest

from vlab.errors import DataFileError, MeasurementError, ModelError, VlabError
from vlab.io.recording import Recording
from vlab.viz import figures, rerun_common, rerun_log, rerun_structure

DT = 0.5e-3
N = 2000  # 1 s at 2 kHz
POINTS = {1: (0.0, 1.0), 2: (0.0, 0.5), 3: (0.0, 0.0), 4: (0.5, 0.5)}
MEMBERS = ((1, 2, 3), (2, 4))


def _recording() -> Recording:
    t = np.arange(N) * DT
    return Recording.from_signals(DT, {"force9": np.sin(2 * np.pi * 3 * t), "vel6": np.cos(2 * np.pi * 3 * t)},
                                  metadata={"structure": "test", "seed": 7})


def _displacement() -> np.ndarray:
    t = np.arange(N) * DT
    shape = np.array([1.0, 0.5, 0.0, 0.7]) * 1e-3
    return np.outer(np.sin(2 * np.pi * 2 * t), shape)  # (n_frames, n_points) [m]


def _frf(scale: float = 1.0):
    f = np.linspace(0.0, 20.0, 401)
    fn, zeta = 5.0, 0.02
    h = scale * 1j * f / (fn**2 - f**2 + 2j * zeta * fn * f)  # velocity-like: zero at 0 Hz
    return f, h


def _png_size(path) -> tuple[int, int]:
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    return struct.unpack(">II", data[16:24])


# ----------------------------------------------------------------- rerun ---


@pytest.fixture(scope="module")
def rrd(tmp_path_factory):
    path = tmp_path_factory.mktemp("rrd") / "run" / "exp.rrd"
    out = rerun_log.log_experiment(
        path, recording=_recording(), structure_points=POINTS, members=MEMBERS,
        displacement=_displacement(), frfs={"experiment/v6_f9": _frf(), "analysis/v6_f9": _frf(1.2)},
        extra_signals={"u5": np.zeros(N)}, extra_units={"u5": "N"}, recording_id="test-run")
    assert out == path
    return path


def test_rrd_has_expected_entity_paths(rrd):
    paths = set(rerun_log.rrd_entity_paths(rrd))
    expected = {"signals/vel6", "signals/force9", "signals/u5", "structure/members", "structure/points",
                "structure/undeformed", "frf/experiment/v6_f9/magnitude", "frf/analysis/v6_f9/magnitude",
                "meta/run"}
    assert expected <= paths


def test_rrd_read_back_with_rrdreader_directly(rrd):
    from rerun.chunk import RrdReader

    reader = RrdReader(str(rrd))
    (entry,) = reader.recordings()
    assert entry.application_id == "vlab" and entry.recording_id == "test-run"
    chunks = [c for c in reader.store().stream() if c.entity_path == "/signals/vel6" and not c.is_static]
    assert sum(c.num_rows for c in chunks) == N
    assert all(rerun_common.SIM_TIMELINE in c.timeline_names for c in chunks)


def test_rrd_row_counts_signals_animation_frfs(rrd):
    sim = rerun_log.rrd_row_counts(rrd, timeline=rerun_common.SIM_TIMELINE)
    assert sim["signals/force9"] == N and sim["signals/u5"] == N
    assert sim["structure/members"] == 50  # 1 s decimated to 50 frames per second
    assert sim["structure/points"] == 50
    freq = rerun_log.rrd_row_counts(rrd, timeline=rerun_common.FREQUENCY_TIMELINE)
    assert freq == {"frf/experiment/v6_f9/magnitude": 401, "frf/analysis/v6_f9/magnitude": 401}


def test_deformed_strips_hold_scaled_displacement(tmp_path):
    from rerun.chunk import RrdReader

    path = tmp_path / "shape.rrd"
    w = _displacement()
    rec = rerun_log.open_recording(path)
    s = rerun_structure.log_deformed_shapes(rec, POINTS, MEMBERS, w, dt_s=DT, fps=10.0, scale=100.0)
    rerun_log.close_recording(rec)
    assert s == 100.0
    (chunk,) = [c for c in RrdReader(str(path)).store().stream()
                if c.entity_path == "/structure/members" and not c.is_static]
    batch = chunk.to_record_batch()
    strips = batch.column(batch.schema.names.index("LineStrips3D:strips")).to_pylist()
    assert len(strips) == 10 and all(len(frame) == len(MEMBERS) for frame in strips)
    k = 3  # 4th kept frame = sample 3 * 200
    first_member = np.array(strips[k][0])
    np.testing.assert_allclose(first_member[:, 2], 100.0 * w[3 * 200, [0, 1, 2]], rtol=1e-5, atol=1e-7)
    np.testing.assert_allclose(first_member[:, :2], [POINTS[1], POINTS[2], POINTS[3]], atol=1e-6)


def test_frame_indices_decimate_to_fps():
    np.testing.assert_array_equal(rerun_structure.frame_indices(2000, 0.5e-3, 50.0), np.arange(0, 2000, 40))
    np.testing.assert_array_equal(rerun_structure.frame_indices(5, 0.1, 50.0), np.arange(5))  # already sparse


def test_auto_scale_maps_largest_deflection_to_ten_percent():
    xy = np.array(list(POINTS.values()))
    assert rerun_structure.auto_scale(xy, _displacement()) == pytest.approx(0.1 * 1.0 / 1e-3, rel=1e-3)
    assert rerun_structure.auto_scale(xy, np.zeros((3, 4))) == 1.0


def test_structure_geometry_from_spec():
    from vlab.spec import load_spec

    pts, members = rerun_structure.structure_geometry(load_spec("bcc"))
    assert set(pts) >= {5, 6, 7, 9}
    assert all(len(m) >= 2 and set(m) <= set(pts) for m in members)


def test_errors_name_the_array(tmp_path):
    rec = rerun_log.open_recording(tmp_path / "bad.rrd")
    try:
        with pytest.raises(MeasurementError, match="displacement"):
            rerun_structure.log_deformed_shapes(rec, POINTS, MEMBERS, np.zeros((10, 3)), dt_s=DT)
        with pytest.raises(ModelError, match="unknown point id"):
            rerun_structure.log_deformed_shapes(rec, POINTS, [(1, 99)], np.zeros((10, 4)), dt_s=DT)
        with pytest.raises(MeasurementError, match="'u5'"):
            rerun_log.log_signals(rec, np.arange(10) * DT, {"u5": np.zeros(9)})
        with pytest.raises(MeasurementError, match="'bad'.*h has shape"):
            rerun_log.log_frfs(rec, {"bad": (np.arange(5.0), np.zeros(4))})
        with pytest.raises(MeasurementError, match="entity path"):
            rerun_log.log_signals(rec, np.arange(3) * DT, {"vel 6": np.zeros(3)})
    finally:
        rerun_log.close_recording(rec)
    with pytest.raises(DataFileError, match=".rrd"):
        rerun_log.open_recording(tmp_path / "x.txt")
    with pytest.raises(MeasurementError, match="displacement_dt_s"):
        rerun_log.log_experiment(tmp_path / "y.rrd", structure_points=POINTS, members=MEMBERS,
                                 displacement=np.zeros((3, 4)))
    with pytest.raises(DataFileError):
        rerun_log.rrd_entity_paths(tmp_path / "missing.rrd")


def test_spawn_streams_to_viewer_and_file(tmp_path, monkeypatch):
    import rerun as rr

    calls = {}
    # the viewer is started by vlab itself (listening on 127.0.0.1 only), not by rerun's spawn
    monkeypatch.setattr(rerun_log, "spawn_viewer",
                        lambda **kw: calls.setdefault("spawn", (None, "rerun+http://127.0.0.1:1/proxy")))
    monkeypatch.setattr(rr.RecordingStream, "set_sinks",
                        lambda self, *sinks, **kw: calls.setdefault("sinks", [type(s).__name__ for s in sinks]))
    monkeypatch.setattr(rr.RecordingStream, "disconnect", lambda self: None)
    monkeypatch.setattr(rr.RecordingStream, "flush", lambda self, **kw: None)
    rerun_log.log_experiment(tmp_path / "s.rrd", frfs={"a": _frf()}, spawn=True)
    assert "spawn" in calls  # one viewer started; the stream goes to it and to the file
    assert calls["sinks"] == ["GrpcSink", "FileSink"]


def test_import_has_no_side_effects():
    code = "import sys, vlab.viz; print('rerun' in sys.modules, 'matplotlib.pyplot' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.split() == ["False", "False"]


# --------------------------------------------------------------- figures ---


def test_frf_figure_png_written_with_size(tmp_path):
    f, h = _frf()
    path = figures.frf_figure(f, {"experiment": h, "analysis": (f, 1.2 * h)}, "Open loop, joint 4",
                              "|H| [(m/s)/N]", tmp_path / "figs" / "frf.png", peaks_hz={"experiment": [5.0]},
                              xlim_hz=(0.0, 10.0))
    assert path == tmp_path / "figs" / "frf.png" and path.stat().st_size > 5000
    assert _png_size(path) == (840, 540)  # 7 x 4.5 in at 120 dpi


def test_frf_figure_svg_and_frf_objects(tmp_path):
    class FRFLike:
        def __init__(self, f, h):
            self.freq_hz, self.h = f, h

    f, h = _frf()
    path = figures.frf_figure(None, {"measured": FRFLike(f, h), "FE model": FRFLike(f[::2], h[::2])},
                              path=tmp_path / "frf.svg")
    assert path.read_text().lstrip().startswith("<?xml")


def test_misfit_overlay_and_comparison_bar(tmp_path):
    f, h = _frf()
    p1 = figures.misfit_overlay(f, h, 1.5 * h, 1.05 * h, title="fit", ylabel="|H|",
                                path=tmp_path / "misfit.png", dpi=100)
    assert _png_size(p1) == (700, 600)
    p2 = figures.comparison_bar(["mode 1", "mode 2", "mode 3"], [5.0, -3.0, 2.0], [0.5, -0.2, 0.1],
                                ylabel="frequency error [%]", path=tmp_path / "bar.png",
                                reference=[0.0, 0.0, 0.0])
    assert _png_size(p2) == (840, 480) and p2.stat().st_size > 3000


def test_figure_errors(tmp_path):
    f, h = _frf()
    with pytest.raises(MeasurementError, match="'analysis'"):
        figures.frf_figure(f, {"experiment": h, "analysis": h[:-1]}, path=tmp_path / "a.png")
    with pytest.raises(MeasurementError, match="after"):
        figures.misfit_overlay(f, h, h, h[:10], path=tmp_path / "b.png")
    with pytest.raises(MeasurementError, match="before"):
        figures.comparison_bar(["a", "b"], [1.0], [1.0, 2.0], path=tmp_path / "c.png")
    with pytest.raises(DataFileError, match="jpg"):
        figures.frf_figure(f, {"x": h}, path=tmp_path / "d.jpg")
    assert issubclass(MeasurementError, VlabError)
