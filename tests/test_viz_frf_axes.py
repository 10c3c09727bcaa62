"""FRF figures with phase and a logarithmic frequency axis: the diagnosis overlay (misfit_overlay) and the
experiment's FRF figures (frf_figure, frf_panels_figure)."""

from __future__ import annotations

import numpy as np
import pytest

from vlab.errors import MeasurementError
from vlab.viz import figures


def _frf():
    f = np.linspace(0.0, 20.0, 401)
    fn, zeta = 5.0, 0.02
    return f, 1j * f / (fn**2 - f**2 + 2j * zeta * fn * f)


@pytest.fixture
def saved(monkeypatch):
    """The figures written, captured as they are saved."""
    out = []
    orig = figures._save
    monkeypatch.setattr(figures, "_save", lambda fig, path, dpi: (out.append(fig), orig(fig, path, dpi))[1])
    return out


def test_overlay_phase_panel_draws_the_phase_of_each_frf(tmp_path, saved):
    f, h = _frf()
    figures.misfit_overlay(f, h, 1.5 * h, -h, path=tmp_path / "o.png", phase=True, dpi=50)
    (fig,) = saved
    mag, ph, mis = fig.axes
    assert ph.get_ylabel() == "phase [deg]" and "misfit" in mis.get_ylabel()
    lines = ph.get_lines()
    np.testing.assert_allclose(lines[0].get_ydata(), np.degrees(np.angle(h)))
    np.testing.assert_allclose(lines[2].get_ydata(), np.degrees(np.angle(-h)))
    assert mag.get_xscale() == "linear"
    assert fig.get_size_inches()[1] == pytest.approx(8.0)


def test_overlay_default_is_unchanged_and_log_axis_starts_at_the_first_positive_line(tmp_path, saved):
    f, h = _frf()
    figures.misfit_overlay(f, h, h, h, path=tmp_path / "a.png", dpi=50)
    figures.misfit_overlay(f, h, h, h, path=tmp_path / "b.png", dpi=50, log_freq=True)
    lin, log = saved
    assert len(lin.axes) == 2 and lin.axes[0].get_xscale() == "linear"
    assert all(ax.get_xscale() == "log" for ax in log.axes)
    assert log.axes[-1].get_xlim() == pytest.approx((f[1], f[-1]))


def test_overlay_phase_needs_complex_frfs(tmp_path):
    f, h = _frf()
    with pytest.raises(MeasurementError, match="before: the phase panel needs a complex FRF"):
        figures.misfit_overlay(f, h, np.abs(h), h, path=tmp_path / "x.png", phase=True)


def test_frf_figures_take_a_log_frequency_axis(tmp_path, saved):
    f, h = _frf()
    figures.frf_figure(f, {"experiment": h, "analysis": 1.1 * h}, path=tmp_path / "a.png", log_freq=True, dpi=50)
    figures.frf_panels_figure(f[1:], {"experiment (H1)": h[1:]}, np.ones(f.size - 1), unit="(m/s)/N",
                              path=tmp_path / "b.png", log_freq=True, dpi=50)
    one, panels = saved
    assert one.axes[0].get_xscale() == "log" and one.axes[0].get_xlim() == pytest.approx((f[1], f[-1]))
    assert [ax.get_xscale() for ax in panels.axes] == ["log"] * 3
    with pytest.raises(MeasurementError, match="fewer than two lines above 0 Hz"):
        figures.frf_figure(np.array([-1.0, 0.0, 1.0]), {"x": np.ones(3)}, path=tmp_path / "c.png", log_freq=True)


def test_vlab_experiment_log_freq_draws_frf_png_on_a_log_axis(tmp_path, saved):
    from pathlib import Path

    from typer.testing import CliRunner

    from vlab.cli import app

    example = Path(__file__).resolve().parent.parent / "examples" / "cantilever_tip_mass.toml"
    res = CliRunner().invoke(app, ["experiment", str(example), "--controller", "none", "--plant", "linear",
                                   "--duration", "4", "--out", str(tmp_path / "exp"), "--log-freq"])
    assert res.exit_code == 0, res.output
    (frf,) = [f for f in saved if len(f.axes) == 3 and f.axes[1].get_ylabel() == "phase [deg]"]
    assert [ax.get_xscale() for ax in frf.axes] == ["log"] * 3
