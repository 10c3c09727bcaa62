"""Mode shapes identified from the FRFs of one excitation point (vlab.measure.shapes), checked against
systems whose shapes are known: a closed-form 3-DOF chain solved directly, and the BCC FE model's own modes
summed into receptances; then end to end on a short open-loop experiment."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy import linalg
from typer.testing import CliRunner

from _modal_systems import receptance, spring_mass_chain
from vlab.errors import MeasurementError
from vlab.fe.point_shapes import normalise_shapes
from vlab.measure.shapes import compare_shapes, identify_shapes, lsfd_residues


def _chain():
    """A 3-DOF chain with modal damping: (M, C, K, mass-normalised V, f_n [Hz], zeta)."""
    m, k = spring_mass_chain([1.0, 0.8, 1.2], [4000.0, 3000.0, 2500.0])
    lam, v = linalg.eigh(k, m)
    wn = np.sqrt(lam)
    z = np.array([0.02, 0.01, 0.015])
    c = m @ v @ np.diag(2 * z * wn) @ v.T @ m
    return m, c, k, v, wn / (2 * np.pi), z


def _same_sign(phi: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """``ref``'s columns turned to the sign of ``phi``'s (a mode shape's sign is arbitrary)."""
    return ref * np.sign(np.sum(phi * ref, axis=0))


@pytest.mark.parametrize("ref", [0, 2])
def test_three_dof_chain_shapes_frequencies_and_damping(ref):
    """Direct solve of (K - w^2 M + i w C) x = e_ref (no modal sum): the identified shapes are the
    eigenvectors, largest +1 and mass-normalised, with the right signs, from either driving point."""
    m, c, k, v, fn, z = _chain()
    f = np.arange(0.25, 30.0, 0.05)
    h = np.array([receptance(f, m, c, k, j, ref) for j in range(3)]) * (2j * np.pi * f)  # mobility
    ids = identify_shapes(f, h, [11, 12, 13], fn * 1.01, reference_point=11 + ref, damping_hint=z)
    assert ids.modes == (1, 2, 3)
    np.testing.assert_allclose(ids.freq_hz, fn, rtol=1e-5)
    np.testing.assert_allclose(ids.damping_ratio, z, rtol=1e-3)
    assert np.all(ids.mpc > 0.9999)
    np.testing.assert_allclose(ids.shapes, normalise_shapes(v)[0], atol=1e-3)
    np.testing.assert_allclose(ids.shapes_mass_normalised, _same_sign(ids.shapes_mass_normalised, v), atol=1e-3)
    np.testing.assert_array_equal(np.sign(ids.shapes_mass_normalised), np.sign(ids.shapes))
    cmp = compare_shapes(ids, v, fn, z)
    assert np.all(np.diag(cmp.mac_matrix) > 0.9999)
    assert [(p["identified_mode"], p["model_mode"]) for p in cmp.pairs] == [(1, 1), (2, 2), (3, 3)]
    assert abs(cmp.pairs[1]["frequency_error_pct"]) < 1e-3


@pytest.fixture(scope="module")
def bcc_modes():
    from vlab.fe import modal_analysis
    from vlab.models import nominal_fe_model

    fe = nominal_fe_model("bcc")
    modes = modal_analysis(fe.m, fe.k, 12)
    points = (5, 6, 7, 9)
    rows = [fe.dofs.index(p, "w") for p in points]
    return modes.frequencies_hz, modes.shapes[rows], points


def test_bcc_fe_modes_summed_into_receptances_are_identified(bcc_modes):
    """Receptances summed from the BCC model's 12 lowest modes (6 in the 0.5-25 Hz band, 6 above it:
    the upper residual) at points 5, 6, 7, 9 driven at 9, with 0.5 % noise: MAC > 0.99 with the
    model's shapes, right signs, mass normalisation within 2 %."""
    fn, phi, points = bcc_modes
    wn = 2 * np.pi * fn
    z = np.linspace(0.004, 0.002, fn.size)
    f = np.arange(0.5, 25.0 + 1e-9, 0.05)
    s = 2j * np.pi * f
    k = points.index(9)
    hx = np.einsum("jr,r,rf->jf", phi, phi[k], 1 / (wn[:, None] ** 2 + 2 * (z * wn)[:, None] * s + s**2))
    rng = np.random.default_rng(3)
    noise = 0.005 * np.abs(hx) * (rng.standard_normal(hx.shape) + 1j * rng.standard_normal(hx.shape))
    band = fn <= 25.0
    ids = identify_shapes(f, (hx + noise) * s, points, fn[band], reference_point=9, damping_hint=z[band])
    assert ids.modes == tuple(range(1, band.sum() + 1))
    cmp = compare_shapes(ids, phi[:, band], fn[band], z[band])
    assert np.all(np.diag(cmp.mac_matrix) > 0.99)
    assert [p["model_mode"] for p in cmp.pairs] == list(ids.modes)
    np.testing.assert_array_equal(np.sign(ids.shapes), np.sign(normalise_shapes(phi[:, band])[0]))
    expected = _same_sign(ids.shapes_mass_normalised, phi[:, band])
    np.testing.assert_allclose(ids.shapes_mass_normalised, expected, atol=0.02 * np.abs(expected).max())
    np.testing.assert_allclose(ids.freq_hz, fn[band], rtol=1e-4)


def test_lsfd_recovers_residues_and_ignores_residual_terms():
    """Two modes plus the four residual terms, exactly: the residues come back to 1e-9."""
    f = np.linspace(3.0, 7.0, 60)
    s = 2j * np.pi * f
    lam = np.array([-0.3 + 2j * np.pi * 4.5, -0.4 + 2j * np.pi * 5.5])
    r = np.array([[1e-3 + 2e-4j, -5e-4 + 1e-4j], [2e-3 - 1e-4j, 7e-4 + 0j]])
    h = sum(r[:, [i]] / (s - lam[i]) + r[:, [i]].conj() / (s - lam[i].conj()) for i in range(2))
    h = h + 1e-3 / s**2 + 2e-6 / s + 3e-5 - 1e-8 * s
    np.testing.assert_allclose(lsfd_residues(f, h, lam), r, rtol=1e-9, atol=1e-12)


def test_bad_input_is_refused():
    f = np.linspace(1.0, 10.0, 50)
    with pytest.raises(MeasurementError, match="one row per distinct point"):
        identify_shapes(f, np.ones((2, 50), complex), [1, 1], [5.0], reference_point=1)
    with pytest.raises(MeasurementError, match="unknown response"):
        identify_shapes(f, np.ones((1, 50), complex), [1], [5.0], reference_point=1, response="strain")
    with pytest.raises(MeasurementError, match="was found in any FRF"), np.errstate(all="ignore"):
        identify_shapes(f, np.zeros((1, 50), complex), [1], [5.0], reference_point=1)
    with pytest.raises(MeasurementError, match="Im > 0"):
        lsfd_residues(f, np.ones((1, 50)), [-1.0 - 2j])
    m, c, k, v, fn, z = _chain()
    ids = identify_shapes(np.arange(0.25, 30, 0.05),
                          np.array([receptance(np.arange(0.25, 30, 0.05), m, c, k, j, 0) for j in range(3)]),
                          [1, 2, 3], fn, reference_point=1, damping_hint=z, response="displacement")
    with pytest.raises(MeasurementError, match="agree in the number of modes"):
        compare_shapes(ids, v, fn[:2])


@pytest.fixture(scope="module")
def open_loop_run():
    from vlab.experiment.config import ExperimentConfig
    from vlab.experiment.runner import run_experiment
    from vlab.models import nominal_fe_model

    fe = nominal_fe_model("bcc")
    return fe, run_experiment(ExperimentConfig(controller="none", plant="linear", resolution_hz=0.1, periods=2), fe)


def test_open_loop_experiment_identifies_the_fe_model_shapes(open_loop_run, tmp_path):
    """The BCC's open-loop test on the linear plant (points 5, 6, 7, 9, excitation at 9): every in-band
    mode identified, paired with the same FE mode at MAC > 0.999, mass-normalised shapes within 2 % of
    the FE model's; results.json, shapes.csv, shapes.png and report.md carry them."""
    from vlab.experiment.results import write_outputs

    fe, r = open_loop_run
    assert r.shapes.point_ids == (5, 6, 7, 9) and r.shapes.reference_point == 9
    pairs = r.shape_comparison.pairs
    assert [(p["identified_mode"], p["model_mode"]) for p in pairs] == [(i, i) for i in range(1, 7)]
    assert min(p["mac"] for p in pairs) > 0.999
    expected = _same_sign(r.shapes.shapes_mass_normalised, r.model_shapes[:, :6])
    np.testing.assert_allclose(r.shapes.shapes_mass_normalised, expected, atol=0.02)
    files = write_outputs(r, fe.spec, tmp_path / "out")
    ms = json.loads(files["results"].read_text())["mode_shapes"]
    assert ms["point_ids"] == [5, 6, 7, 9] and len(ms["identified"]) == 6
    assert {"frequency_hz", "damping_ratio", "mpc", "shape_normalised", "shape_mass_normalised_per_sqrt_kg",
            "model_mode", "mac"} <= set(ms["identified"][0])
    assert np.array(ms["mac_matrix"]).shape == (6, 6)
    header = files["shapes"].read_text().splitlines()[0].split(",")
    assert header[:8] == ["mode", "frequency_hz", "damping_ratio", "mpc", "model_mode", "frequency_model_hz",
                          "damping_ratio_model", "mac"]
    assert "w_at_6" in header and "phi_at_9_per_sqrt_kg" in header
    assert files["shapes_figure"].stat().st_size > 10_000
    assert "| 6 | 22.714 |" in files["report"].read_text()
    from vlab.viz.rerun_log import rrd_entity_paths

    paths = set(rrd_entity_paths(files["rerun"]))  # every channel's H1 FRF with phase and coherence
    assert {f"frf/h1/vel{p}/{q}" for p in (5, 6, 7, 9) for q in ("magnitude", "phase", "coherence")} <= paths
    assert {"frf/experiment/phase", "frf/analysis/phase"} <= paths
    # each identified mode animated at its frequency on its own timeline, the paired FE shape beside it
    from vlab.viz.rerun_log import rrd_row_counts

    assert {f"modes/identified/mode_{m}/{k}" for m in range(1, 7) for k in ("measured", "model")} <= paths
    assert rrd_row_counts(files["rerun"], timeline="identified_mode_3_time") == {
        "modes/identified/mode_3/measured": 48, "modes/identified/mode_3/model": 48}


def test_paired_model_shape_is_drawn_at_the_identified_scale_and_sign():
    from vlab.viz.rerun_modes import _turned_to

    w = np.array([1.0, -0.5, 0.25])
    np.testing.assert_allclose(_turned_to(np.array([-2.0, 1.0, -0.4]), w), [1.0, -0.5, 0.2])
    assert _turned_to(np.full(3, np.nan), w) is None and _turned_to(np.zeros(3), w) is None


def test_cli_prints_the_identified_shapes(tmp_path):
    from vlab.cli import app

    res = CliRunner().invoke(app, ["experiment", "bcc", "--controller", "none", "--plant", "linear",
                                   "--duration", "40", "--out", str(tmp_path / "exp")])
    assert res.exit_code == 0, res.output
    assert "mode shapes identified at points 5, 6, 7, 9 (excitation at 9)" in res.output
    assert "shapes.csv" in res.output and (tmp_path / "exp" / "shapes.csv").is_file()


def test_non_proportional_damping_gives_the_complex_modes_of_the_state_space():
    """A 10 N*s/m dashpot between masses 2 and 3 of the chain (non-proportional damping): the poles are the
    state matrix's eigenvalues (to 1e-3: the fit's residual terms approximate the other modes), the column
    of modal constants is the complex eigenvector (complex MAC > 1 - 1e-4) and the MPC is the
    eigenvector's own (to 2e-3; down to 0.89)."""
    from vlab.measure.mac import mac

    m, c, k, v, fn, z = _chain()
    c = c.copy()
    c[np.ix_([1, 2], [1, 2])] += 10.0 * np.array([[1.0, -1.0], [-1.0, 1.0]])
    a = np.block([[np.zeros((3, 3)), np.eye(3)], [-np.linalg.solve(m, k), -np.linalg.solve(m, c)]])
    lam, psi = np.linalg.eig(a)
    up = np.flatnonzero(lam.imag > 0)
    up = up[np.argsort(lam[up].imag)]
    f = np.arange(0.25, 30.0, 0.02)
    h = np.array([receptance(f, m, c, k, j, 0) for j in range(3)])
    ids = identify_shapes(f, h, [1, 2, 3], np.abs(lam[up]) / (2 * np.pi), reference_point=1,
                          damping_hint=-lam[up].real / np.abs(lam[up]), response="displacement")
    np.testing.assert_allclose(ids.pole_rad_s, lam[up], rtol=1e-3)
    for r, i in enumerate(up):
        x = psi[:3, i]
        assert mac(x, ids.modal_constants_per_kg[:, r])[0, 0] > 1 - 1e-4
        mpc = abs(np.sum(x**2)) ** 2 / np.sum(np.abs(x) ** 2) ** 2
        assert ids.mpc[r] == pytest.approx(mpc, abs=2e-3)
    assert ids.mpc.min() < 0.9  # the dashpot makes a mode clearly complex
