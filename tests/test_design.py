"""The thesis's designs on vlab's BCC model (Sec. 6.1, Tables 7-9)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from vlab.cli import app
from vlab.design import design_controller
from vlab.fe import modal_analysis
from vlab.models import nominal_fe_model
from vlab.reference import column


@pytest.fixture(scope="module")
def fe():
    return nominal_fe_model("bcc")


def test_bcc_mfdrf_gamma_near_table7_and_damping_constraints(fe):
    d = design_controller(fe, "mfdrf")
    assert d.converged
    assert d.gamma_lb_s_per_in == pytest.approx(0.050, rel=0.25)  # Table 7: max row sum 0.0500 lb*s/in
    assert np.all(d.damping_ratios[:6] >= 0.03 - 1e-6)
    np.testing.assert_allclose(d.gain, d.gain.T)
    assert np.all(np.linalg.eigvalsh(d.gain) > 0)
    # realization: F11 = -D in SI
    np.testing.assert_allclose(d.f11, -d.gain)


def test_bcc_lqg_reduced_on_full_like_table8(fe):
    d = design_controller(fe, "lqg")
    assert d.model == "exact"
    z = d.damping_ratios[:6]
    # Table 8: the sixth LQG damping ratio falls just below 3 % because of reduction and estimation
    assert z[5] < 0.03
    assert np.all(z[:5] > 0.03)
    # Kalman poles respect the alpha shift (alpha = 0.2 / cs = 20 / s)
    assert d.extra["kalman_poles_max_real_per_s"] < -20.0 + 1e-6


def test_bcc_lqr_performance_close_to_table9(fe):
    d = design_controller(fe, "lqr")
    ref = column("table9_bcc_performance.csv", "lqr")
    # Table 9 was not used in the calibration: modes 1-3, 5, 6 within 10 %; mode 4 (the
    # crosspiece mode, normalised to 1 in at the crosspiece tip) comes out 31 % high
    rel = d.performance_index_thesis_units[:6] / ref - 1
    assert np.all(np.abs(rel[[0, 1, 2, 4, 5]]) < 0.10)
    assert 0.2 < rel[3] < 0.4


def test_design_cli_json_keys():
    res = CliRunner().invoke(app, ["design", "bcc", "--controller", "mfdrf", "--json"])
    assert res.exit_code == 0, res.output
    out = json.loads(res.stdout)
    for key in ("controller", "gain_n_s_per_m", "gain_thesis_lb_s_per_in", "damping_ratios", "frequencies_hz",
                "performance_index_thesis_units", "gamma_lb_s_per_in", "gamma_n_s_per_m", "period_s", "converged"):
        assert key in out
    assert np.shape(out["gain_n_s_per_m"]) == (3, 3)


def test_corrected_guyan_grid_from_virtual_modal_test_matches_table3():
    """Without --modes: shapes from the MuJoCo plant, Table 3 experimental frequencies (Sec. 3.3)."""
    from vlab.design import design_model
    from vlab.sim.modaltest import virtual_measured_modes

    fe = nominal_fe_model("grid")
    freq, shapes = virtual_measured_modes(fe)
    assert len(freq) == 11
    dm = design_model(fe, "corrected-guyan", measured_modes=(freq, shapes))
    import scipy.linalg

    f = np.sqrt(scipy.linalg.eigvalsh(dm.k, dm.m)) / (2 * np.pi)
    ref = column("table3_grid_frequencies.csv", "experimental_hz")[:11]
    np.testing.assert_allclose(f[:11], ref, rtol=1e-6)  # the corrected model has the measured frequencies


def test_virtual_modal_test_pairs_the_bcc_modes_by_shape():
    """The BCC plant has an extra mode (arms' antisymmetric bending) near FE mode 3: pairing must skip it."""
    from vlab.measure.mac import mac
    from vlab.models import master_indices
    from vlab.sim.modaltest import virtual_measured_modes

    fe = nominal_fe_model("bcc")
    freq, shapes = virtual_measured_modes(fe)
    idx = master_indices(fe, "guyan")
    phi = modal_analysis(fe.m, fe.k, len(freq)).shapes[idx, :]
    assert len(freq) == 5
    np.testing.assert_allclose(freq, column("table1_bcc_frequencies.csv", "experimental_hz")[:5])
    assert np.all(np.diag(mac(phi, shapes)) > 0.99)


def test_missing_modes_file_is_a_clear_error(tmp_path):
    res = CliRunner().invoke(app, ["design", "grid", "--reduction", "corrected-guyan", "--modes",
                                   str(tmp_path / "none.uff")])
    assert res.exit_code == 2
    assert "none.uff" in res.output


def test_bcc_mfdrf_gamma_matches_table7():
    """Table 7's MFDRF objective gamma = max_i sum_j |d_ij| (0.0500 lb*s/in, from the published D) is reached
    within 1 % on the calibrated model (the calibration used Table 7's gains, not this optimum)."""
    from vlab.reference import read_table

    t = read_table("table7_bcc_gains.csv")
    d7 = np.array([[t[f"sensor_{s}"][i] for s in (5, 7, 9)]
                   for i, c in enumerate(t["controller"]) if c == "mfdrf"])
    gamma7 = float(np.max(np.sum(np.abs(d7), axis=1)))
    d = design_controller(nominal_fe_model("bcc"), "mfdrf")
    assert d.gamma_lb_s_per_in == pytest.approx(gamma7, rel=0.01)
