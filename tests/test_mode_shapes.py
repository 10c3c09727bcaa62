"""Mode shapes at the structure's points (``vlab modes --shapes/--figure/--rerun``) against the FE shapes."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

import vlab
from vlab.cli import app
from vlab.errors import ModelError
from vlab.fe import modal_analysis
from vlab.fe.point_shapes import SHAPE_UNITS, normalise_shapes, point_mode_shapes
from vlab.measure.mac import mac
from vlab.models import nominal_fe_model, reduce_model
from vlab.viz.mode_figures import mode_shapes_axes
from vlab.viz.rerun_structure import structure_geometry

runner = CliRunner()


@pytest.fixture(scope="module")
def bcc():
    fe = nominal_fe_model("bcc")
    return fe, modal_analysis(fe.m, fe.k, 6)


def test_shapes_are_the_fe_w_rows_scaled_to_a_largest_plus_one(bcc):
    fe, res = bcc
    pts = point_mode_shapes(fe, res.shapes)
    assert pts.point_ids == tuple(range(1, 10)) and pts.units == SHAPE_UNITS and pts.constrained == ()
    rows = [fe.dofs.index(p, "w") for p in pts.point_ids]
    w_fe = res.shapes[rows, :]
    np.testing.assert_allclose(pts.w * pts.scale, w_fe, rtol=0, atol=1e-12)
    assert np.max(pts.w, axis=0) == pytest.approx(np.ones(6), abs=0)       # largest displacement is +1 exactly
    assert np.all(np.max(np.abs(pts.w), axis=0) == 1.0)
    for r in range(6):                                                    # same sign as the FE entry of largest |w|
        j = np.argmax(np.abs(w_fe[:, r]))
        assert np.sign(pts.scale[r]) == np.sign(w_fe[j, r])


def test_mac_with_vlab_modes_is_one(bcc):
    fe, _ = bcc
    f, shapes = vlab.modes("bcc", 6)
    pts = point_mode_shapes(fe, shapes)
    w_api = shapes[[fe.dofs.index(p, "w") for p in pts.point_ids], :]
    m = mac(pts.w, w_api)
    np.testing.assert_allclose(np.diag(m), 1.0, atol=1e-12)
    assert np.max(m - np.diag(np.diag(m))) < 0.99                       # distinct modes stay distinct


def test_exact_reduction_expanded_gives_the_full_shapes(bcc):
    fe, res = bcc
    red = reduce_model(fe, "exact")
    n = min(6, red.m.shape[0])
    rr = modal_analysis(red.m, red.k, n)
    a = point_mode_shapes(fe, rr.shapes, basis=red.T)
    b = point_mode_shapes(fe, res.shapes[:, :n])
    np.testing.assert_allclose(a.w, b.w, atol=1e-6)


def test_constrained_points_are_zero_and_named():
    fe = nominal_fe_model("grid")
    res = modal_analysis(fe.m, fe.k, 4)
    pts = point_mode_shapes(fe, res.shapes)
    assert set(pts.constrained) == {p for p in fe.spec.points if (p, "w") not in fe.dofs}
    assert pts.constrained                                                # the bearings 13 and 22
    for p in pts.constrained:
        assert np.all(pts.w[pts.point_ids.index(p)] == 0.0)


def test_normalise_rejects_bad_input_and_keeps_zero_modes():
    w, s = normalise_shapes(np.array([[0.0, -2.0], [0.0, 1.0]]))
    np.testing.assert_array_equal(w, [[0.0, 1.0], [0.0, -0.5]])
    np.testing.assert_array_equal(s, [1.0, -2.0])
    with pytest.raises(ModelError):
        normalise_shapes(np.array([1.0, np.nan]))
    fe = nominal_fe_model("bcc")
    with pytest.raises(ModelError, match="shapes must be"):
        point_mode_shapes(fe, np.ones((3, 2)))


def test_figure_draws_the_computed_shapes_on_the_beam(bcc):
    fe, res = bcc
    pts = point_mode_shapes(fe, res.shapes)
    points, members = structure_geometry(fe.spec)
    fig = mode_shapes_axes(points, members, pts.point_ids, pts.w, res.frequencies_hz)
    assert len(fig.axes) == 6
    y = np.array([points[p][1] for p in members[0]])
    rows = [pts.point_ids.index(p) for p in members[0]]
    for r, ax in enumerate(fig.axes):
        (line,) = [ln for ln in ax.get_lines() if ln.get_gid() == f"mode{r + 1}:member1"]
        np.testing.assert_array_equal(line.get_xdata(), pts.w[rows, r])
        np.testing.assert_array_equal(line.get_ydata(), y)
        assert f"{res.frequencies_hz[r]:.3f} Hz" in ax.get_title()


def test_figure_draws_the_grid_in_3d():
    fe = nominal_fe_model("grid")
    res = modal_analysis(fe.m, fe.k, 2)
    pts = point_mode_shapes(fe, res.shapes)
    points, members = structure_geometry(fe.spec)
    fig = mode_shapes_axes(points, members, pts.point_ids, pts.w, res.frequencies_hz)
    for r, ax in enumerate(fig.axes):
        for k, mem in enumerate(members):
            (line,) = [ln for ln in ax.get_lines() if ln.get_gid() == f"mode{r + 1}:member{k + 1}"]
            x, w, y = line.get_data_3d()
            np.testing.assert_array_equal(w, [pts.w[pts.point_ids.index(p), r] for p in mem])
            np.testing.assert_array_equal(x, [points[p][0] for p in mem])
            np.testing.assert_array_equal(y, [points[p][1] for p in mem])
    with pytest.raises(ModelError, match="expected w of shape"):
        mode_shapes_axes(points, members, pts.point_ids, pts.w[:, :1], res.frequencies_hz)


def test_cli_shapes_json_csv_and_unchanged_default(bcc):
    fe, res = bcc
    plain = json.loads(runner.invoke(app, ["modes", "bcc", "--n", "3", "--json"]).stdout)
    assert "shapes" not in plain
    out = runner.invoke(app, ["modes", "bcc", "--n", "3", "--shapes", "--json"])
    assert out.exit_code == 0, out.output
    js = json.loads(out.stdout)
    assert js["shapes"]["point_ids"] == list(range(1, 10)) and js["shapes"]["units"] == SHAPE_UNITS
    np.testing.assert_allclose(np.array(js["shapes"]["w"]).T, point_mode_shapes(fe, res.shapes[:, :3]).w, atol=1e-12)
    csv = runner.invoke(app, ["modes", "bcc", "--n", "2", "--shapes", "--format", "csv"]).stdout.splitlines()
    head = csv[0].split(",")
    assert head[-9:] == [f"w_at_{p}" for p in range(1, 10)]
    assert float(csv[1].split(",")[head.index("w_at_6")]) == pytest.approx(1.0)   # mode 1 largest at point 6
    table = runner.invoke(app, ["modes", "bcc", "--n", "2", "--shapes"]).stdout
    assert "mode shapes w at the points" in table and "+1.0000" in table


def test_cli_figure_written_and_not_replaced_silently(tmp_path):
    target = tmp_path / "modes.png"
    res = runner.invoke(app, ["modes", "bcc", "--n", "2", "--figure", str(target)])
    assert res.exit_code == 0, res.output
    assert target.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    again = runner.invoke(app, ["modes", "bcc", "--n", "2", "--figure", str(target)])
    assert again.exit_code != 0 and "--figure" in again.output
    assert runner.invoke(app, ["modes", "bcc", "--n", "2", "--figure", str(target), "--overwrite"]).exit_code == 0
    bad = runner.invoke(app, ["modes", "bcc", "--figure", str(tmp_path / "modes.gif")])
    assert bad.exit_code != 0 and ".png" in bad.output


class _Recorder:
    """A stand-in for rerun.RecordingStream that keeps the timeline of each log call."""

    def __init__(self):
        self.calls, self.time = [], None

    def set_time(self, timeline, duration):
        self.time = (timeline, duration)

    def reset_time(self):
        self.time = None

    def log(self, entity, archetype, static=False):
        self.calls.append((entity, None if static else self.time))


def test_rerun_each_mode_on_its_own_timeline_at_its_frequency(bcc):
    from vlab.viz.rerun_modes import log_mode_shapes

    fe, res = bcc
    pts = point_mode_shapes(fe, res.shapes[:, :2])
    points, members = structure_geometry(fe.spec)
    rec = _Recorder()
    written = log_mode_shapes(rec, points, members, pts.point_ids, pts.w, res.frequencies_hz[:2], cycles=2,
                              frames_per_cycle=8)
    assert written == ["modes/undeformed", "modes/mode_1/members", "modes/mode_1/points", "modes/mode_2/members",
                       "modes/mode_2/points"]
    for r in (1, 2):
        times = [t for e, t in rec.calls if e == f"modes/mode_{r}/members"]
        assert {tl for tl, _ in times} == {f"mode_{r}_time"}
        d = np.array([dt for _, dt in times])
        np.testing.assert_allclose(d, np.arange(16) / (8 * res.frequencies_hz[r - 1]))   # two periods of mode r


def test_cli_rerun_file_has_one_timeline_per_mode(tmp_path):
    from vlab.viz.rerun_log import rrd_entity_paths, rrd_row_counts

    target = tmp_path / "modes.rrd"
    res = runner.invoke(app, ["modes", "bcc", "--n", "2", "--rerun", str(target)])
    assert res.exit_code == 0, res.output
    assert "modes/mode_2/points" in rrd_entity_paths(target)
    assert rrd_row_counts(target, timeline="mode_1_time") == {"modes/mode_1/members": 48, "modes/mode_1/points": 48}
    bad = runner.invoke(app, ["modes", "bcc", "--rerun", str(tmp_path / "modes.png")])
    assert bad.exit_code != 0 and ".rrd" in bad.output
