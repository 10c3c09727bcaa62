"""FRFs in a rerun recording with phase and coherence (vlab.viz.rerun_frf), read back from the .rrd file."""

from __future__ import annotations

import numpy as np
import pytest

from vlab.errors import MeasurementError
from vlab.io.frf import FRF
from vlab.viz import rerun_frf, rerun_log


def _h1():
    f = np.linspace(0.5, 20.0, 391)
    h = 1j * f / (25.0 - f**2 + 0.2j * f)
    coh = np.clip(1.0 - 0.01 * f, 0.0, 1.0)
    coh[5] = np.nan  # a line without input power: a gap
    return FRF(f, h, "velocity", coh, "vel6", "force9", 6, 9)


def _values(path, entity: str) -> tuple[np.ndarray, np.ndarray]:
    """(frequency [mHz], value) rows of one scalar entity of a .rrd file."""
    from rerun.chunk import RrdReader

    mhz, vals = [], []
    for c in RrdReader(str(path)).store().stream():
        if c.entity_path == f"/{entity}" and not c.is_static:
            b = c.to_record_batch()
            mhz += b.column(b.schema.names.index("frequency_mhz")).to_pylist()
            vals += [v[0] for v in b.column(b.schema.names.index("Scalars:scalars")).to_pylist()]
    return np.array(mhz), np.array(vals, dtype=float)


def _view_names(path) -> set[str]:
    from rerun.chunk import RrdReader

    r = RrdReader(str(path))
    names = set()
    for c in r.store(store=r.blueprints()[0]).stream():
        b = c.to_record_batch()
        if "ViewBlueprint:display_name" in b.schema.names:
            names.update(v[0] for v in b.column(b.schema.names.index("ViewBlueprint:display_name")).to_pylist())
    return names


def test_log_frfs_writes_magnitude_phase_and_coherence(tmp_path):
    frf = _h1()
    path = tmp_path / "f.rrd"
    rec = rerun_log.open_recording(path)
    written = rerun_frf.log_frfs(rec, {"h1/vel6": frf, "analysis": (frf.freq_hz, 2 * frf.h)}, phase=True)
    rerun_log.close_recording(rec)
    assert written == ["frf/h1/vel6/magnitude", "frf/h1/vel6/phase", "frf/h1/vel6/coherence",
                       "frf/analysis/magnitude", "frf/analysis/phase"]
    mhz, ph = _values(path, "frf/h1/vel6/phase")
    np.testing.assert_array_equal(mhz, np.rint(frf.freq_hz * 1000))
    np.testing.assert_allclose(ph, np.degrees(np.angle(frf.h)), atol=1e-9)
    _, coh = _values(path, "frf/h1/vel6/coherence")
    np.testing.assert_allclose(coh, frf.coherence, equal_nan=True)
    _, mag = _values(path, "frf/analysis/magnitude")
    np.testing.assert_allclose(mag, np.log10(2 * np.abs(frf.h)))


def test_without_phase_only_magnitude_and_the_coherence_given():
    f = np.linspace(1.0, 2.0, 11)
    panels = rerun_frf.frf_panels({"a": (f, f), "b": (f, f, np.ones(11))})
    assert panels == {"magnitude": ["frf/a/magnitude", "frf/b/magnitude"], "coherence": ["frf/b/coherence"]}
    with pytest.raises(MeasurementError, match="unknown quantities"):
        rerun_frf.frf_views({"gain": ["frf/a/gain"]})


def test_bad_coherence_is_named(tmp_path):
    f = np.linspace(1.0, 2.0, 11)
    rec = rerun_log.open_recording(tmp_path / "bad.rrd")
    try:
        with pytest.raises(MeasurementError, match="'x': coherence has shape"):
            rerun_frf.log_frfs(rec, {"x": (f, f, np.ones(3))})
    finally:
        rerun_log.close_recording(rec)


def test_log_experiment_with_phase_lays_out_one_view_per_quantity(tmp_path):
    path = rerun_log.log_experiment(tmp_path / "e.rrd", frfs={"h1/vel6": _h1()}, frf_phase=True)
    paths = set(rerun_log.rrd_entity_paths(path))
    assert {"frf/h1/vel6/magnitude", "frf/h1/vel6/phase", "frf/h1/vel6/coherence"} <= paths
    assert {"FRF log10|H| vs frequency_mhz (1 Hz = 1000)", "FRF phase [deg] vs frequency_mhz",
            "coherence [-] vs frequency_mhz"} <= _view_names(path)
