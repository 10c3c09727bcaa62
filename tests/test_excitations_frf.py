"""Every excitation reproduces the linear plant's exact FRF at the modes.

The reference is the closed-loop FRF of the FE model with the sampled-data
controller (hold, delay, filter), computed in the frequency domain by
:mod:`vlab.analysis` -- independent of the time-domain loop, the excitation
and the H1 estimate that are tested. Records of 4 s (0.25 Hz lines) keep the
runs short.
"""

from __future__ import annotations

import numpy as np
import pytest

from vlab.analysis import closed_loop_modes
from vlab.fe.damping import modal_damping_matrix, open_loop_ratios
from vlab.experiment.checks import not_meaningful
from vlab.experiment.config import EXCITATIONS, TESTS, ExperimentConfig
from vlab.experiment.runner import run_experiment
from vlab.experiment.settling import settle_records
from vlab.models import nominal_fe_model

from _designs import bcc_design

RES_HZ = 0.25  # 4 s records


@pytest.fixture(scope="module")
def bcc():
    return nominal_fe_model("bcc")


@pytest.fixture(scope="module")
def mfdrf(bcc):
    return bcc_design("mfdrf")  # design_controller(bcc, "mfdrf", seed=0), shared with other test files


def _mode_lines(result):
    """Index of the line nearest each predicted closed-loop mode in band."""
    return [int(np.argmin(np.abs(result.freq_hz - m.frequency_predicted_hz))) for m in result.modes]


@pytest.mark.parametrize("excitation", EXCITATIONS)
def test_excitation_reproduces_exact_frf_mfdrf(bcc, mfdrf, excitation):
    cfg = ExperimentConfig(structure="bcc", controller="mfdrf", excitation=excitation, plant="linear",
                           resolution_hz=RES_HZ)
    r = run_experiment(cfg, bcc, design=mfdrf)
    assert len(r.modes) == TESTS["bcc"].n_modes
    for m, i in zip(r.modes, _mode_lines(r)):
        err = abs(abs(r.measured[i]) / abs(r.analysis_sampled[i]) - 1)
        assert err < 0.02, (excitation, m.mode, r.freq_hz[i], err)
        assert abs(m.peak_level_ratio - 1) < 0.02, (excitation, m.mode, m.peak_level_ratio)
    # the impulse's response above the band is forced, not a self-excited oscillation
    assert not not_meaningful(r.warnings), r.warnings
    # frf.uff content: only the excited band's lines
    lo, hi = TESTS["bcc"].band_hz
    for frf in r.frfs.values():
        assert frf.freq_hz[0] >= lo and frf.freq_hz[-1] <= hi


def test_settle_records_closed_form():
    # exp(-sigma * n * T) <= 0.01 with the smallest such n
    sigma, rec = 0.0603, 20.0
    n = settle_records(sigma, rec, tolerance=0.01)
    assert np.exp(-sigma * n * rec) <= 0.01 < np.exp(-sigma * (n - 1) * rec)
    assert settle_records(None, rec) == 1 and settle_records(10.0, rec) == 1


@pytest.fixture(scope="module")
def short_open_loop(bcc):
    cfg = ExperimentConfig(structure="bcc", controller="none", excitation="random", plant="linear",
                           resolution_hz=RES_HZ, duration_s=8.0)
    return run_experiment(cfg, bcc)


def test_open_loop_short_run_warns_with_numbers(bcc, short_open_loop):
    """BCC open loop (zeta = 0.2-0.4 %): a run too short to settle says so with the transient left."""
    c = modal_damping_matrix(bcc.m, bcc.k, open_loop_ratios(bcc.spec, bcc.n))
    u = bcc.force_input(tuple(bcc.spec.instrumentation.actuators))
    fm, zm = closed_loop_modes(bcc.m, c, bcc.k, u, u.T, None)
    sel = (fm >= 0.5) & (fm <= 25.0)
    sigma = float(np.min(2 * np.pi * fm[sel][:6] * zm[sel][:6]))
    left = np.exp(-sigma * 4.0)  # one 4 s record settles
    r = short_open_loop
    w = [x for x in r.warnings if "start-up transient" in x]
    assert w, r.warnings
    assert f"{100 * left:.0f} %" in w[0] and f"{sigma:.4g} 1/s" in w[0]


def test_frf_uff_holds_only_the_band_and_figure_has_three_panels(bcc, short_open_loop, tmp_path, monkeypatch):
    import pyuff

    import vlab.viz.figures as figs
    from vlab.experiment.results import write_outputs

    saved = []
    orig = figs._save
    monkeypatch.setattr(figs, "_save", lambda fig, path, dpi: (saved.append(fig), orig(fig, path, dpi))[1])
    files = write_outputs(short_open_loop, bcc.spec, tmp_path)
    lo, hi = TESTS["bcc"].band_hz
    sets = [d for d in pyuff.UFF(str(files["frf"])).read_sets() if d["func_type"] == 4]
    assert len(sets) == len(short_open_loop.frfs)
    for d in sets:
        x = np.asarray(d["x"])
        assert x[0] >= lo and x[-1] <= hi and x.size == round((hi - lo) / RES_HZ) + 1
        assert f"excited band {lo:g}-{hi:g} Hz" in d["id4"]
        frf = short_open_loop.frfs[f"vel{d['rsp_node']}"]
        np.testing.assert_allclose(x, frf.freq_hz)
        np.testing.assert_allclose(d["data"], frf.h, rtol=1e-12)
    # the figure: magnitude in (m/s)/N, phase, coherence
    (fig,) = [f for f in saved if f.axes and "phase" in f.axes[1].get_ylabel()]  # not shapes.png
    axes = fig.axes
    assert len(axes) == 3
    assert "(m/s)/N" in axes[0].get_ylabel() and "phase" in axes[1].get_ylabel()
    assert "coherence" in axes[2].get_ylabel()
    resp = short_open_loop.frfs["vel6"]
    y = axes[0].get_lines()[0].get_ydata()
    np.testing.assert_allclose(y, np.abs(resp.h), rtol=1e-12)


def test_cli_exits_1_on_not_meaningful_warning(short_open_loop, tmp_path, monkeypatch):
    from dataclasses import replace

    from typer.testing import CliRunner

    import vlab.experiment.runner as ex
    from vlab.cli import app
    from vlab.experiment.checks import NOT_MEANINGFUL

    bad = replace(short_open_loop, warnings=("self-excited oscillation at 41.0 Hz (90 % ...); " + NOT_MEANINGFUL,))
    monkeypatch.setattr(ex, "run_experiment", lambda cfg, fe, **kw: bad)
    runner = CliRunner()
    out = tmp_path / "o"
    res = runner.invoke(app, ["experiment", "bcc", "--controller", "none", "--plant", "linear", "--out", str(out)])
    assert res.exit_code == 1, res.output
    assert "self-excited oscillation at 41.0 Hz" in res.output and (out / "results.json").exists()
    res = runner.invoke(app, ["experiment", "bcc", "--controller", "none", "--plant", "linear", "--out", str(out),
                              "--allow-unstable", "--overwrite"])
    assert res.exit_code == 0, res.output
    monkeypatch.setattr(ex, "run_experiment", lambda cfg, fe, **kw: short_open_loop)
    res = runner.invoke(app, ["experiment", "bcc", "--controller", "none", "--plant", "linear", "--out", str(out),
                              "--overwrite"])
    assert res.exit_code == 0, res.output


def test_open_loop_under_resolved_peaks_warned_with_numbers(bcc, short_open_loop):
    """BCC open-loop mode 2 (zeta 0.2 %) is far narrower than 0.25 Hz lines: named with its numbers."""
    m2 = short_open_loop.modes[1]
    w = [x for x in short_open_loop.warnings if "peaks narrower than" in x]
    assert w, short_open_loop.warnings
    zeta = open_loop_ratios(bcc.spec, bcc.n)
    c = modal_damping_matrix(bcc.m, bcc.k, zeta)
    u = bcc.force_input(tuple(bcc.spec.instrumentation.actuators))
    fm, zm = closed_loop_modes(bcc.m, c, bcc.k, u, u.T, None)
    f2, z2 = fm[(fm >= 0.5)][1], zm[(fm >= 0.5)][1]
    assert abs(f2 - m2.frequency_predicted_hz) < RES_HZ
    bw = 2 * z2 * f2
    worst = 2 * z2 * f2 / np.hypot(RES_HZ, 2 * z2 * f2)  # single mode, a line df/2 from resonance
    assert f"mode 2 ({f2:.2f} Hz, zeta {z2:.4f}, bandwidth {bw:.3f} Hz: a line may read {100 * worst:.0f} %" in w[0]
