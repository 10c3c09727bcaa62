"""The sampled-data loop's margins and sensitivity (``vlab.design.loop``, ``vlab design --margins``).

Checked against closed forms (an integrator and a single damped mode with a gain and a delay), against
python-control's ``stability_margins`` on an FRF data object, and against the identities of loop-at-a-time
gains and singular values.
"""

from __future__ import annotations

import json

import control
import numpy as np
import pytest
from scipy.optimize import brentq
from typer.testing import CliRunner

from vlab.cli import app
from vlab.design import design_controller
from vlab.design.loop import (analyse_loop, channel_margins, loop_at_a_time, loop_frequencies, loop_summary,
                              nyquist_encirclements, sensitivity_sigma_max)
from vlab.errors import ModelError
from vlab.models import nominal_fe_model
from vlab.viz.loop_figures import loop_axes, unwrapped_phase_deg

from _designs import bcc_design

runner = CliRunner()


@pytest.fixture(scope="module")
def bcc_loops():
    fe = nominal_fe_model("bcc")
    return fe, {c: analyse_loop(fe, bcc_design(c)) for c in ("mfdrf", "lqg")}


def test_integrator_with_delay_closed_form():
    k, tau = 2 * np.pi * 5.0, 2e-3                       # l(s) = k e^{-s tau} / s
    f = np.geomspace(0.1, 400.0, 20000)
    w = 2 * np.pi * f
    m = channel_margins(f, k * np.exp(-1j * w * tau) / (1j * w))
    assert m.crossover_hz == pytest.approx(5.0, rel=1e-6)                       # |l| = 1 at w = k
    assert m.phase_margin_deg == pytest.approx(90.0 - np.degrees(k * tau), abs=1e-3)
    w180 = np.pi / (2 * tau)                                                    # pi/2 + w tau = pi
    assert m.phase_crossover_hz == pytest.approx(w180 / (2 * np.pi), rel=1e-5)
    assert m.gain_margin_db == pytest.approx(20 * np.log10(w180 / k), abs=1e-4)


def test_single_mode_with_gain_and_delay_against_its_analytic_crossings():
    f0, zeta, g, tau = 10.0, 0.02, 0.5, 1.5e-3         # l = g * 2 zeta w0 s / (s^2 + 2 zeta w0 s + w0^2) * e^{-s tau} * 30
    w0, kk = 2 * np.pi * f0, 30.0

    def ell(w):
        s = 1j * w
        return kk * g * 2 * zeta * w0 * s / (s * s + 2 * zeta * w0 * s + w0 * w0) * np.exp(-s * tau)

    f = np.unique(np.concatenate([np.geomspace(0.5, 300.0, 20000), f0 * (1 + zeta * np.linspace(-8, 8, 201))]))
    m = channel_margins(f, ell(2 * np.pi * f))
    # the two |l| = 1 crossings (analytic): take the one of smaller phase margin
    wc = [brentq(lambda w: abs(ell(w)) - 1, a, b) for a, b in ((0.2 * w0, w0), (w0, 5 * w0))]
    pms = [180 - abs(np.degrees(np.angle(ell(w)))) for w in wc]
    assert m.phase_margin_deg == pytest.approx(min(pms), abs=1e-3)
    assert m.crossover_hz == pytest.approx(wc[int(np.argmin(pms))] / (2 * np.pi), rel=1e-5)
    w180 = brentq(lambda w: ell(w).imag, 3 * w0, 2 * np.pi * 290)
    assert ell(w180).real < 0
    assert m.gain_margin_db == pytest.approx(-20 * np.log10(abs(ell(w180))), abs=1e-3)
    assert m.phase_crossover_hz == pytest.approx(w180 / (2 * np.pi), rel=1e-5)


def test_no_crossing_gives_infinite_margins():
    f = np.geomspace(1, 100, 50)
    m = channel_margins(f, 0.1 * np.ones(50) + 0.01j)
    assert m.gain_margin_db == np.inf and m.phase_margin_deg == np.inf and np.isnan(m.crossover_hz)
    with pytest.raises(ModelError):
        channel_margins(f[::-1], np.ones(50))


def test_loop_at_a_time_is_the_inverse_diagonal_of_the_sensitivity():
    rng = np.random.default_rng(3)
    lg = rng.normal(size=(7, 3, 3)) + 1j * rng.normal(size=(7, 3, 3))
    li = loop_at_a_time(lg)
    s = np.linalg.inv(np.eye(3) + lg)
    np.testing.assert_allclose(li, 1 / np.einsum("fii->fi", s) - 1, rtol=1e-10)
    diag = np.zeros_like(lg)
    diag[:, [0, 1, 2], [0, 1, 2]] = lg[:, [0, 1, 2], [0, 1, 2]]
    np.testing.assert_allclose(loop_at_a_time(diag), np.einsum("fii->fi", diag))
    np.testing.assert_allclose(sensitivity_sigma_max(lg), np.linalg.norm(s, ord=2, axis=(1, 2)), rtol=1e-10)


def test_margins_agree_with_python_control_on_the_bcc_loops(bcc_loops):
    _, loops = bcc_loops
    for a in loops.values():
        for i, m in enumerate(a.margins):
            gm, pm, _, wpc, wgc, _ = control.stability_margins(control.frd(a.channel_gain[:, i], 2 * np.pi * a.freq_hz))
            assert m.gain_margin_db == pytest.approx(20 * np.log10(gm), abs=0.05)
            assert m.phase_crossover_hz == pytest.approx(wpc / (2 * np.pi), rel=2e-3)
            if np.isfinite(m.phase_margin_deg):
                assert m.phase_margin_deg == pytest.approx(abs(pm), abs=0.5)   # python-control's PM is signed
                assert m.crossover_hz == pytest.approx(wgc / (2 * np.pi), rel=2e-3)
            else:
                assert np.isinf(pm) and np.max(np.abs(a.channel_gain[:, i])) < 1


def test_sign_convention_controller_is_plus_d_at_low_frequency(bcc_loops):
    fe, loops = bcc_loops
    a = loops["mfdrf"]
    d = bcc_design("mfdrf")  # the design analysed by the fixture
    np.testing.assert_allclose(a.controller[0].real, d.gain, rtol=1e-3, atol=1e-6 * np.abs(d.gain).max())
    np.testing.assert_allclose(a.loop_gain, a.controller @ a.plant)
    # collocated velocity feedback with D > 0: Re(l_i) >= 0 where delay and filter are negligible
    low = a.freq_hz < 5
    assert np.all(a.channel_gain[low].real > -1e-9)


def test_bcc_mfdrf_is_stable_with_margins_and_lqg_is_reported(bcc_loops):
    _, loops = bcc_loops
    a = loops["mfdrf"]
    assert a.freq_hz[-1] < 1 / (2 * a.period_s) and a.delay_periods == 1.35 and a.filter_hz == 677.0
    for m in a.margins:
        assert np.isfinite(m.gain_margin_db) and m.gain_margin_db > 6.0
        assert m.phase_margin_deg > 30.0                                          # inf: |l| < 1 throughout
    assert any(np.isfinite(m.phase_margin_deg) for m in a.margins)
    assert 1.0 < a.peak_sensitivity < 2.0
    lqg = loop_summary(loops["lqg"])
    assert [c["point"] for c in lqg["channels"]] == [5, 7, 9]
    for c in lqg["channels"]:
        assert set(c) == {"point", "gain_margin_db", "phase_crossover_hz", "phase_margin_deg", "crossover_hz"}
        assert all(v is None or np.isfinite(v) for v in c.values())
    assert lqg["peak_sensitivity"] > a.peak_sensitivity                    # Sec. 7: LQG the less robust design


@pytest.mark.parametrize("controller", ["mfdrf", "lqg"])
def test_gain_margin_is_where_the_generalised_nyquist_criterion_flips(bcc_loops, controller):
    """Raising one channel's gain just below its gain margin keeps det(I + L) clear of the origin; just above, not."""
    _, loops = bcc_loops
    a = loops[controller]
    assert a.closed_loop_unstable_poles == 0 and a.open_loop_unstable_poles == 0
    for i, m in enumerate(a.margins):
        for factor, stable in ((0.97, True), (1.03, False)):
            e = np.ones(len(a.points))
            e[i] = factor * 10 ** (m.gain_margin_db / 20)
            det = np.linalg.det(np.eye(len(a.points)) + (e[:, None] * a.controller) @ a.plant)
            assert (nyquist_encirclements(det) == 0) is stable, (controller, m.point, factor)


def test_grid_is_dense_at_every_mode_and_below_nyquist():
    fe = nominal_fe_model("bcc")
    f = loop_frequencies(fe, 0.5e-3)
    assert f[-1] < 1000 and np.all(np.diff(f) > 0)
    assert np.min(np.abs(f - 22.714)) < 22.714 * 0.001 * 0.5                  # mode 6, zeta 0.001
    with pytest.raises(ModelError):
        loop_frequencies(fe, 0.0)


def test_figure_plots_the_computed_arrays(bcc_loops):
    _, loops = bcc_loops
    a = loops["mfdrf"]
    labels = [f"point {p}" for p in a.points]
    fig = loop_axes(a.freq_hz, a.channel_gain, labels, a.sigma_max_s, det_return_difference=a.return_difference_det)
    lines = {ln.get_gid(): ln for ax in fig.axes for ln in ax.get_lines() if ln.get_gid()}
    for i, lb in enumerate(labels):
        l = a.channel_gain[:, i]
        np.testing.assert_allclose(lines[f"bode-magnitude:{lb}"].get_ydata(), 20 * np.log10(np.abs(l)))
        np.testing.assert_allclose(lines[f"bode-magnitude:{lb}"].get_xdata(), a.freq_hz)
        np.testing.assert_allclose(lines[f"bode-phase:{lb}"].get_ydata(), unwrapped_phase_deg(l))
        np.testing.assert_allclose(lines[f"nyquist:{lb}"].get_xdata(), l.real)
        np.testing.assert_allclose(lines[f"nyquist:{lb}"].get_ydata(), l.imag)
    np.testing.assert_allclose(lines["sigma-max-s"].get_ydata(), 20 * np.log10(a.sigma_max_s))
    np.testing.assert_allclose(lines["nyquist:det(I+L)-1"].get_xdata(), a.return_difference_det.real - 1)
    ph = unwrapped_phase_deg(a.channel_gain[:, 0])
    assert abs(np.angle(np.exp(1j * np.radians(ph)) / a.channel_gain[:, 0] * np.abs(a.channel_gain[:, 0]))).max() < 1e-9


def test_cli_margins_json_table_and_figure(tmp_path):
    plain = json.loads(runner.invoke(app, ["design", "bcc", "--json"]).stdout)
    assert "loop" not in plain
    res = runner.invoke(app, ["design", "bcc", "--margins", "--json"])
    assert res.exit_code == 0, res.output
    loop = json.loads(res.stdout)["loop"]
    assert loop["delay_periods"] == 1.35 and loop["peak_sensitivity"] > 1 and loop["nyquist"]["stable"] is True
    assert {"gain_margin_db", "phase_margin_deg", "crossover_hz", "phase_crossover_hz"} <= set(loop["channels"][0])
    table = runner.invoke(app, ["design", "bcc", "--margins"]).stdout
    assert "gain margin [dB]" in table and "M_s" in table and "stable" in table
    target = tmp_path / "loop.png"
    assert runner.invoke(app, ["design", "bcc", "--figure", str(target)]).exit_code == 0
    assert target.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_lqr_has_no_sensor_loop():
    fe = nominal_fe_model("bcc")
    with pytest.raises(ModelError, match="LQR"):
        analyse_loop(fe, design_controller(fe, "lqr"))
    res = runner.invoke(app, ["design", "bcc", "--controller", "lqr", "--margins"])
    assert res.exit_code != 0 and "LQR" in res.output
