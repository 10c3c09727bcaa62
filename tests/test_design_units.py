"""Units of ``vlab design --json`` / ``vlab modes --json`` and the controllers' sampling periods.

Every number of the JSON is converted back here independently: the LQ gains
are recomputed in the dissertation's unit system (inch, lbf, centisecond;
Sec. 3.1) with python-control from the SI design model, with the unit
factors written out below (not taken from :mod:`vlab.units`), and the
closed-loop poles of the SI gain on the SI model must equal those of the
thesis-unit design. The periods follow Sec. 5.3: MFDRF/LQDRF at 2000
samples/s, LQG discretised and run at Delta t = 0.001 s.
"""

from __future__ import annotations

import json
import re
from dataclasses import replace

import control
import numpy as np
import pytest
import scipy.linalg
from typer.testing import CliRunner

from _json_numbers import json_numbers

from vlab.cli import app
from vlab.design import THESIS_SETTINGS, design_model
from vlab.models import nominal_fe_model

IN_M = 0.0254             # 1 in [m]
LBF_N = 4.4482216152605   # 1 lbf [N]
CS_S = 0.01               # 1 cs [s]


def _cli_json(*args):
    res = CliRunner().invoke(app, list(args))
    assert res.exit_code == 0, res.output
    return json.loads(res.stdout)


def _thesis_state_space(dm):
    """A, B of the design model in in, lbf, cs (state [q' per cs; q]) and in SI seconds, written out here."""
    s = np.array([IN_M if d == "w" else 1.0 for _n, d in dm.labels])
    m, c, k = (a * np.outer(s, s) / (LBF_N * IN_M) for a in (dm.m, dm.c, dm.k))
    n = m.shape[0]
    u = np.zeros((n, len(dm.actuator_rows)))
    for j, r in enumerate(dm.actuator_rows):
        u[r, j] = 1.0
    mi = np.linalg.inv(m)
    t = CS_S
    a_th = np.block([[-t * mi @ c, -t**2 * mi @ k], [np.eye(n), np.zeros((n, n))]])
    b_th = np.vstack([t**2 * mi @ u, np.zeros((n, u.shape[1]))])
    mi_si = np.linalg.inv(dm.m)
    a_si = np.block([[-mi_si @ dm.c, -mi_si @ dm.k], [np.eye(n), np.zeros((n, n))]])
    b_si = np.vstack([mi_si @ u, np.zeros((n, u.shape[1]))])
    # SI value of one thesis state unit: in/cs (rad/cs), then in (rad)
    sx = np.concatenate([s / CS_S, s])
    return a_th, b_th, a_si, b_si, sx


def _sorted_eigs(a):
    e = np.linalg.eigvals(a)
    return e[np.lexsort((e.imag, np.round(e.real, 6)))]


@pytest.mark.parametrize("structure,controller,model", [("bcc", "lqg", "exact"), ("bcc", "lqr", "full")])
def test_lq_gain_json_is_force_per_si_state(structure, controller, model):
    """gain_n_per_si_state = 4.448 N/lbf * F_thesis / (SI value of each thesis state unit).

    The BCC full model has rotations (rx: rad, rad/cs), the exact reduction translations only.
    """
    out = _cli_json("design", structure, "--controller", controller, "--json")
    fe = nominal_fe_model(structure)
    dm = design_model(fe, model)
    st = THESIS_SETTINGS[structure]
    a_th, b_th, a_si, b_si, sx = _thesis_state_space(dm)
    n2, nc = b_th.shape
    f_th, _, _ = control.lqr(a_th, b_th, st.q_scale * np.eye(n2), st.r * np.eye(nc))
    f_th = np.asarray(f_th)
    f_si = LBF_N * f_th / sx[None, :]
    assert out["reduction"] == model
    np.testing.assert_allclose(out["gain_thesis_lbf_per_thesis_state"], f_th, rtol=1e-6, atol=1e-9 * np.abs(f_th).max())
    np.testing.assert_allclose(out["gain_n_per_si_state"], f_si, rtol=1e-6, atol=1e-9 * np.abs(f_si).max())
    assert len(out["gain_state_labels"]) == n2
    for lab, (_nd, d) in zip(out["gain_state_labels"], list(dm.labels) * 2):
        assert lab.endswith("[m/s]" if d == "w" else "[rad/s]") or lab.endswith("[m]" if d == "w" else "[rad]")
    # the thesis gain's columns are labelled in the thesis's units, and those units are the ones that convert it
    si_of = {"[in/cs]": IN_M / CS_S, "[rad/cs]": 1.0 / CS_S, "[in]": IN_M, "[rad]": 1.0}
    units = [lab[lab.rindex("["):] for lab in out["gain_thesis_state_labels"]]
    np.testing.assert_allclose(np.asarray(out["gain_thesis_lbf_per_thesis_state"]) * LBF_N
                               / np.array([si_of[u] for u in units])[None, :], out["gain_n_per_si_state"], rtol=1e-9)
    # the SI gain on the SI model closes the loop with the poles of the thesis design (in 1/s)
    poles_si = _sorted_eigs(a_si - b_si @ np.asarray(out["gain_n_per_si_state"]))
    poles_th = _sorted_eigs(a_th - b_th @ f_th) / CS_S
    np.testing.assert_allclose(poles_si, poles_th, rtol=1e-6, atol=1e-6 * np.abs(poles_th).max())


def test_lqg_continuous_controller_in_si_state_has_the_thesis_transfer_function():
    """K(s) of design.continuous equals the thesis controller F (sI - A~)^-1 K with y in in/cs, u in lbf."""
    from controllers.lq import lqg
    from vlab.design import design_controller

    fe = nominal_fe_model("bcc")
    d = design_controller(fe, "lqg")
    dm = design_model(fe, "exact")
    st = THESIS_SETTINGS["bcc"]
    a_th, b_th, _, _, sx = _thesis_state_space(dm)
    n2, nc = b_th.shape
    c_th = np.hstack([np.eye(n2 // 2)[list(dm.actuator_rows)], np.zeros((nc, n2 // 2))])  # y = q' at the sensors
    des = lqg(a_th, b_th, c_th, st.q_scale * np.eye(n2), st.r * np.eye(nc), st.v1 * np.eye(n2),
              st.v2 * np.eye(nc), alpha=st.alpha, time_unit_s=CS_S)
    at, kk, ff = des.controller_matrix, des.estimator.gain, des.regulator.gain
    cont = d.continuous
    np.testing.assert_allclose(cont["c"], d.gain)
    for f_hz in (1.0, 7.0, 20.0):
        s_cs = 2j * np.pi * f_hz * CS_S
        k_th = ff @ np.linalg.solve(s_cs * np.eye(n2) - at, kk)  # lbf per in/cs
        k_si_ref = k_th * LBF_N * CS_S / IN_M  # N per m/s
        s = 2j * np.pi * f_hz
        k_si = cont["c"] @ np.linalg.solve(s * np.eye(n2) - cont["a"], cont["b"])
        np.testing.assert_allclose(k_si, k_si_ref, rtol=1e-6, atol=1e-9 * np.abs(k_si_ref).max())


def test_mfdrf_gamma_in_both_units_and_gain_in_n_s_per_m():
    out = _cli_json("design", "bcc", "--controller", "mfdrf", "--json")
    d_si = np.asarray(out["gain_n_s_per_m"])
    d_th = np.asarray(out["gain_thesis_lb_s_per_in"])
    np.testing.assert_allclose(d_si, d_th * LBF_N / IN_M, rtol=1e-9)
    # Table 7's gamma: max row sum of |D| [lb*s/in]
    gamma_th = float(np.max(np.sum(np.abs(d_th), axis=1)))
    assert out["gamma_lb_s_per_in"] == pytest.approx(gamma_th, rel=1e-4)
    assert out["gamma_n_s_per_m"] == pytest.approx(gamma_th * LBF_N / IN_M, rel=1e-4)
    assert out["gamma_n_s_per_m"] == pytest.approx(float(np.max(np.sum(np.abs(d_si), axis=1))), rel=1e-4)
    assert out["period_s"] == 0.5e-3


# keys of numbers that are dimensionless (ratios, counts, indices) or carry their unit as a suffix
_DIMENSIONLESS = {"damping_ratios", "reduced_model_damping_ratios", "spillover_destabilised_modes",
                  "spillover_lowered_modes", "seed", "mode", "damping_predicted", "damping_measured",
                  "peak_level_ratio", "avg_peak_error",
                  # identified mode shapes: ratios, correlations and indices
                  "damping_ratio", "damping_ratio_identified", "damping_ratio_model", "identified_mode", "model_mode",
                  "mac", "mac_matrix", "mpc", "point_ids", "reference_point", "shape_normalised"}
_UNIT_SUFFIX = re.compile(r"_(hz|s|per_s|n_s_per_m|lb_s_per_in|n_per_si_state|lbf_per_thesis_state|thesis_units|"
                          r"periods|n|m_s|m_per_n|m_s_per_n|n_per_n|pct|per_sqrt_kg|"
                          # the SI weights of the design (vlab design --json: weights.si)
                          r"per_m2|s2_per_m2|per_rad2|s2_per_rad2|per_n2|m2_per_s|m2_per_s3|rad2_per_s|rad2_per_s3)$")


def _numeric_keys(obj):
    return (key for key, _ in json_numbers(obj))


@pytest.mark.parametrize("args", [
    ("design", "bcc", "--controller", "lqg", "--json"),
    ("design", "bcc", "--controller", "lqr", "--json"),
    ("design", "bcc", "--controller", "lqdrf", "--json"),
    ("modes", "grid", "--json"),
    ("modes", "bcc", "--reduction", "exact", "--json"),
])
def test_every_json_number_has_its_unit_in_its_key(args):
    out = _cli_json(*args)
    keys = set(_numeric_keys(out))
    assert keys
    bad = sorted(k for k in keys if k not in _DIMENSIONLESS and not _UNIT_SUFFIX.search(str(k)))
    assert not bad, f"numbers without a unit in their key: {bad}"


# ---- item 5: the sampling period per controller (Sec. 5.3) ----

def test_thesis_periods_and_default_chain():
    from vlab.design import thesis_period_s
    from vlab.experiment.config import ExperimentConfig

    assert thesis_period_s("lqg") == 1e-3  # "Delta t = 0.001 seconds", 1000 samples per second
    for c in ("mfdrf", "lqdrf", "lqdrf-diag", "none"):
        assert thesis_period_s(c) == 0.5e-3  # "2000 samples per second"
    assert ExperimentConfig(controller="lqg").chain.period_s == 1e-3
    assert ExperimentConfig(controller="mfdrf").chain.period_s == 0.5e-3
    assert ExperimentConfig(controller="lqg").chain.delay_periods == 1.35  # 1.35 Delta t at either period


@pytest.fixture
def quick_bcc_test(monkeypatch):
    """The BCC test at a 0.5 Hz resolution (2 s records) to keep the runs short."""
    from vlab.experiment import config as experiment

    monkeypatch.setitem(experiment.TESTS, "bcc", replace(experiment.TESTS["bcc"], resolution_hz=0.5))


def _lqg_realised_at(design, dt):
    """eig(F22) = exp(eig(a) dt) for the continuous controller matrix a [1/s] (Eq. 5.4; similarity-invariant)."""
    z = np.sort_complex(scipy.linalg.eigvals(design.f22))
    ref = np.sort_complex(np.exp(scipy.linalg.eigvals(design.continuous["a"]) * dt))
    return np.allclose(z, ref, rtol=1e-8, atol=1e-10)


@pytest.mark.parametrize("period_ms,expected_s", [(None, 1e-3), (0.5, 0.5e-3)])
def test_lqg_experiment_runs_at_the_thesis_period_or_the_option(quick_bcc_test, tmp_path, period_ms, expected_s):
    from vlab.io.uff import read_recording

    out = tmp_path / "exp"
    args = ["experiment", "bcc", "--controller", "lqg", "--plant", "linear", "--duration", "4", "--noise", "0",
            "--out", str(out), "--json"] + ([] if period_ms is None else ["--period-ms", str(period_ms)])
    summary = _cli_json(*args)
    assert summary["period_s"] == pytest.approx(expected_s, rel=1e-12)
    assert summary["hardware"]["period_s"] == pytest.approx(expected_s, rel=1e-12)
    assert summary["design"]["period_s"] == pytest.approx(expected_s, rel=1e-12)
    assert summary["period_source"].startswith("set by the user") == (period_ms is not None)
    bad = sorted(k for k in set(_numeric_keys(summary)) if k not in _DIMENSIONLESS and not _UNIT_SUFFIX.search(str(k)))
    assert not bad, f"numbers without a unit in their key: {bad}"
    modes = summary["modes"]
    assert modes and all("peak_measured_m_per_n" in m for m in modes)  # the BCC's FRF is a displacement FRF
    results = json.loads((out / "results.json").read_text())
    assert results["period_s"] == pytest.approx(expected_s, rel=1e-12)
    rec = read_recording(out / "recording.uff")
    assert rec.dt_s == pytest.approx(expected_s, rel=1e-9)
    assert len(np.asarray(rec[rec.channels[0].name])) == pytest.approx(4.0 / expected_s, abs=2)


def test_lqg_realization_is_made_at_the_loop_period(quick_bcc_test):
    from vlab.design import design_controller
    from vlab.errors import ModelError
    from vlab.experiment.config import ExperimentConfig
    from vlab.experiment.runner import run_experiment

    fe = nominal_fe_model("bcc")
    cfg = ExperimentConfig(structure="bcc", controller="lqg", plant="linear", duration_s=4.0)
    res = run_experiment(cfg, fe)
    assert res.loop.recording.dt_s == pytest.approx(1e-3)
    assert res.design.period_s == 1e-3
    assert _lqg_realised_at(res.design, 1e-3) and not _lqg_realised_at(res.design, 0.5e-3)
    d05 = design_controller(fe, "lqg", period_s=0.5e-3)
    assert _lqg_realised_at(d05, 0.5e-3)
    with pytest.raises(ModelError, match="0.5 ms"):
        run_experiment(cfg, fe, design=d05)


def test_bad_period_option_is_a_clear_error():
    res = CliRunner().invoke(app, ["design", "bcc", "--controller", "lqg", "--period-ms", "-1"])
    assert res.exit_code == 2
    assert "--period-ms must be a positive number" in " ".join(res.output.split())
