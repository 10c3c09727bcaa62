"""Tests of vlab.correction: Baruch reference-basis correction (Eqs. 3.17-3.20).

The dissertation's experimental mode shapes are not published. The
"measured" modes here come from a perturbed model: the spring-mass chain with
spring 4 stiffened by 10 %, its modes taken at the master DOFs (and scaled
arbitrarily, as a modal test would deliver them). The analytical model is the
Guyan reduction of the nominal chain to the same masters.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import scipy.linalg as sla

from _modal_systems import spring_mass_chain as chain
from vlab.correction import (
    CorrectionHistory,
    baruch_correction,
    correct_model,
    corrected_damping,
    corrected_mass,
    corrected_stiffness,
    normalise_shapes,
    orthogonality_matrix,
    orthogonality_summary,
    sequential_correction,
)
from vlab.errors import ModelError
from vlab.reduction import ExactReduction, GuyanReduction, modal_damping, natural_frequencies_hz

MASSES = [1.0, 2.0, 1.5, 1.0, 3.0, 1.0, 0.8, 1.2]
SPRINGS = [100.0, 200.0, 150.0, 300.0, 120.0, 80.0, 250.0, 90.0]
MASTER = [0, 2, 4, 6, 7]
N_R = len(MASTER)


def measured(n_m):
    """'Measured' modes: spring 4 (between masses 4 and 5) 10 % stiffer."""
    springs = list(SPRINGS)
    springs[4] *= 1.10
    m, k = chain(MASSES, springs)
    lam, phi = sla.eigh(k, m)
    scale = np.array([3.0, -0.2, 1.7, -5.0, 0.9])[:n_m]  # arbitrary scaling and sign
    return phi[MASTER, :n_m] * scale, np.sqrt(lam[:n_m]) / (2 * np.pi)


@pytest.fixture(scope="module")
def guyan():
    m, k = chain(MASSES, SPRINGS)
    return GuyanReduction(m, k, MASTER).reduce()


def residual(k_hat, m_hat, phi, freq_hz):
    """max_i |k^ phi_i - w_i^2 m^ phi_i| / |k^ phi_i|."""
    w2 = (2 * np.pi * np.asarray(freq_hz)) ** 2
    r = k_hat @ phi - m_hat @ phi * w2
    return np.max(np.linalg.norm(r, axis=0) / np.linalg.norm(k_hat @ phi, axis=0))


@pytest.mark.parametrize("n_m", [1, 3, N_R])
def test_corrected_model_reproduces_measured_modes(guyan, n_m):
    phi_x, f_x = measured(n_m)
    cm = baruch_correction(guyan.m, guyan.k, phi_x, f_x)
    assert residual(cm.k, cm.m, cm.shapes, f_x) < 1e-8
    np.testing.assert_allclose(cm.shapes.T @ cm.m @ cm.shapes, np.eye(n_m), atol=1e-8)
    # Each measured frequency is a natural frequency of the corrected model.
    f_hat = cm.natural_frequencies_hz()
    for f in f_x:
        assert np.min(np.abs(f_hat / f - 1)) < 1e-8
    if n_m == N_R:  # all modes given: the corrected model *is* the measured one at the masters
        np.testing.assert_allclose(f_hat, f_x, rtol=1e-8)
    for a in (cm.m, cm.k):
        np.testing.assert_array_equal(a, a.T)
    assert np.all(np.linalg.eigvalsh(cm.m) > 0)


def test_mass_orthogonal_modes_leave_mass_unchanged(guyan):
    # The reduced model's own modes are perfectly m_R-orthogonal; give them new frequencies.
    lam, v = sla.eigh(guyan.k, guyan.m)
    phi_x = v[:, :3] * np.array([2.0, -7.0, 0.3])
    f_new = np.sqrt(lam[:3]) / (2 * np.pi) * np.array([1.1, 0.95, 1.02])
    o = orthogonality_matrix(phi_x, guyan.m)
    np.testing.assert_allclose(o, np.eye(3), atol=1e-12)
    cm = baruch_correction(guyan.m, guyan.k, phi_x, f_new)
    np.testing.assert_allclose(cm.m, guyan.m, rtol=0, atol=1e-12 * np.max(np.abs(guyan.m)))
    f_hat = cm.natural_frequencies_hz()
    np.testing.assert_allclose(f_hat[:3], f_new, rtol=1e-10)
    # The unmeasured modes keep their frequencies.
    np.testing.assert_allclose(f_hat[3:], np.sqrt(lam[3:]) / (2 * np.pi), rtol=1e-10)


def test_normalisation_eq_3_17_and_scale_invariance(guyan):
    phi_x, f_x = measured(3)
    phi = normalise_shapes(phi_x, guyan.m)
    np.testing.assert_allclose(np.einsum("ij,ik,kj->j", phi, guyan.m, phi), 1.0, rtol=1e-14)
    np.testing.assert_array_equal(np.sign(phi), np.sign(phi_x))
    o = orthogonality_matrix(phi_x, guyan.m)
    np.testing.assert_array_equal(np.diag(o), 1.0)
    np.testing.assert_array_equal(o, o.T)
    assert orthogonality_summary(o).max_abs_offdiag > 1e-3  # perturbed shapes are not orthogonal
    a = baruch_correction(guyan.m, guyan.k, phi_x, f_x)
    b = baruch_correction(guyan.m, guyan.k, phi_x * np.array([-4.0, 0.01, 2.5]), f_x)
    np.testing.assert_allclose(a.m, b.m, rtol=1e-12)
    np.testing.assert_allclose(a.k, b.k, rtol=1e-10, atol=1e-12 * np.max(np.abs(a.k)))


def test_mass_update_equals_the_dissertations_eq_3_18(guyan):
    # Eq. 3.18 as printed: m^ = m - m Phi ma^-1 (ma - I) ma^-1 Phi' m. Same sign as
    # the standard (Berman) form m + m Phi ma^-1 (I - ma) ma^-1 Phi' m.
    phi_x, _ = measured(3)
    m = guyan.m
    phi = normalise_shapes(phi_x, m)
    ma = phi.T @ m @ phi
    mai = np.linalg.inv(ma)
    thesis = m - m @ phi @ mai @ (ma - np.eye(3)) @ mai @ phi.T @ m
    np.testing.assert_allclose(corrected_mass(m, phi), thesis, rtol=1e-12, atol=1e-14)
    # Outside the measured shapes the mass is unchanged: m^ psi = m psi for psi m-orthogonal to Phi.
    psi = sla.null_space(phi.T @ m)
    np.testing.assert_allclose(corrected_mass(m, phi) @ psi, m @ psi, atol=1e-12)


def test_eq_3_19_as_printed_is_a_typo(guyan):
    # The dissertation's last term m^ Phi W^2 Phi' m_R (uncorrected m_R) breaks the
    # eigen-equation and symmetry when the mass changes; with m^ it holds.
    phi_x, f_x = measured(3)
    m, k = guyan.m, guyan.k
    phi = normalise_shapes(phi_x, m)
    m_hat = corrected_mass(m, phi)
    w2 = np.diag((2 * np.pi * f_x) ** 2)
    pp = phi @ phi.T
    printed = k - k @ pp @ m_hat - m_hat @ pp @ k + m_hat @ pp @ k @ pp @ m_hat + m_hat @ phi @ w2 @ phi.T @ m
    assert residual(printed, m_hat, phi, f_x) > 1e-3
    assert np.max(np.abs(printed - printed.T)) > 1e-6 * np.max(np.abs(printed))
    k_hat = corrected_stiffness(k, m_hat, phi, f_x)
    assert residual(k_hat, m_hat, phi, f_x) < 1e-10


def test_damping_eq_3_20(guyan):
    phi_x, f_x = measured(N_R)
    zeta = np.array([0.01, 0.02, 0.005, 0.03, 0.015])
    cm = baruch_correction(guyan.m, guyan.k, phi_x, f_x, zeta=zeta)
    np.testing.assert_array_equal(cm.c, cm.c.T)
    # Square case: m^-1 c^ = Phi diag(2 zeta w) Phi^-1 exactly as printed.
    ref = modal_damping(cm.shapes, f_x, zeta)
    np.testing.assert_allclose(np.linalg.solve(cm.m, cm.c), ref, atol=1e-9 * np.max(np.abs(ref)))
    # Fewer modes: the measured ones get their damping, modal coordinates stay decoupled.
    phi3, f3 = measured(3)
    cm3 = baruch_correction(guyan.m, guyan.k, phi3, f3, zeta=zeta[:3])
    modal_c = cm3.shapes.T @ cm3.c @ cm3.shapes
    np.testing.assert_allclose(modal_c, np.diag(2 * zeta[:3] * 2 * np.pi * f3), atol=1e-10 * np.max(modal_c))
    np.testing.assert_allclose(corrected_damping(cm3.m, cm3.shapes, f3, zeta[:3]), cm3.c)


@pytest.mark.parametrize("base", ["original", "previous"])
def test_sequential_correction_history(guyan, base):
    phi_x, f_x = measured(4)
    h = sequential_correction(guyan.m, guyan.k, phi_x, f_x, base=base)
    assert isinstance(h, CorrectionHistory) and h.base == base
    assert h.freq_hz.shape == (5, N_R) and len(h.steps) == 4
    np.testing.assert_allclose(h.freq_hz[0], guyan.natural_frequencies_hz())
    for j, step in enumerate(h.steps, start=1):
        assert step.n_modes == j
        assert residual(step.k, step.m, step.shapes, f_x[:j]) < 1e-8
        np.testing.assert_allclose(step.shapes.T @ step.m @ step.shapes, np.eye(j), atol=1e-8)
        np.testing.assert_allclose(h.freq_hz[j], step.natural_frequencies_hz())
    once = baruch_correction(guyan.m, guyan.k, phi_x[:, :1], f_x[:1])
    np.testing.assert_allclose(h.steps[0].k, once.k, rtol=1e-12)  # step 1 is the same for both bases
    if base == "original":
        full = baruch_correction(guyan.m, guyan.k, phi_x, f_x)
        np.testing.assert_allclose(h.final.m, full.m, rtol=1e-12)
        np.testing.assert_allclose(h.final.k, full.k, rtol=1e-12)
    with pytest.raises(ValueError):
        h.freq_hz[0, 0] = 1.0


def test_guyan_vs_exact_orthogonality_with_measured_shapes():
    # Sec. 3.3's comparison, on the chain: orthogonality of the measured shapes with
    # both reduced mass matrices (the tables' statistic; no claim which is better here).
    m, k = chain(MASSES, SPRINGS)
    phi_x, _ = measured(N_R)
    for red in (GuyanReduction(m, k, MASTER), ExactReduction(m, k, MASTER)):
        s = orthogonality_summary(orthogonality_matrix(phi_x, red.reduce().m))
        assert s.n_modes == N_R and 0 < s.mean_abs_offdiag <= s.max_abs_offdiag < 1


# Tables 4 and 6 of the dissertation (11 experimental modes, hanging grid).
TABLE_4 = """
1.00 0.71 0.12 0.37 -0.10 0.04 0.00 0.25 -0.19 0.29 0.08
0.71 1.00 -0.59 0.25 -0.18 -0.11 -0.32 0.60 -0.33 0.20 0.30
0.12 -0.59 1.00 -0.01 0.39 0.24 0.42 -0.57 0.24 -0.05 -0.30
0.37 0.25 -0.01 1.00 -0.19 -0.01 -0.13 0.17 -0.26 0.28 -0.06
-0.10 -0.18 0.39 -0.19 1.00 0.09 -0.06 -0.25 0.09 -0.05 -0.12
0.04 -0.11 0.24 -0.01 0.09 1.00 0.59 0.17 0.03 0.00 -0.13
0.00 -0.32 0.42 -0.13 -0.06 0.59 1.00 0.34 -0.35 0.21 0.18
0.25 0.60 -0.57 0.17 -0.25 0.17 0.34 1.00 -0.80 0.33 0.41
-0.19 -0.33 0.24 -0.26 0.09 0.03 -0.35 -0.80 1.00 -0.23 -0.05
0.29 0.20 -0.05 0.28 -0.05 0.00 0.21 0.33 -0.23 1.00 0.10
0.08 0.30 -0.30 -0.06 -0.12 -0.13 0.18 0.41 -0.05 0.10 1.00
"""
TABLE_6 = """
1.00 -0.19 0.01 0.05 -0.03 0.06 0.09 0.03 0.17 0.34 0.14
-0.19 1.00 0.16 0.01 0.12 0.01 0.19 -0.01 0.00 0.05 0.13
0.01 0.16 1.00 0.08 0.26 0.06 -0.28 -0.02 0.10 0.30 -0.10
0.05 0.01 0.08 1.00 -0.11 -0.05 0.12 0.06 -0.20 -0.24 -0.09
-0.03 0.12 0.26 -0.11 1.00 0.04 0.10 -0.10 -0.11 -0.23 0.04
0.06 0.01 0.06 -0.05 0.04 1.00 -0.58 0.14 -0.11 -0.23 0.04
0.09 0.19 -0.28 0.12 0.10 -0.58 1.00 -0.44 0.31 -0.42 -0.14
0.03 -0.01 -0.02 0.06 -0.10 0.14 -0.44 1.00 -0.24 0.06 -0.06
0.16 0.00 0.10 -0.20 -0.12 -0.02 0.31 -0.24 1.00 -0.12 0.15
0.34 0.05 0.30 -0.24 -0.23 -0.20 -0.42 0.06 -0.12 1.00 0.11
0.14 0.13 -0.10 -0.09 0.04 -0.01 -0.14 0.06 0.15 0.11 1.00
"""


@pytest.mark.parametrize("table, max_quoted, mean_quoted", [(TABLE_4, 0.80, 0.23), (TABLE_6, 0.58, 0.13)])
def test_summary_of_published_tables(table, max_quoted, mean_quoted):
    o = np.array([[float(x) for x in line.split()] for line in table.strip().splitlines()])
    s = orthogonality_summary(o)
    assert s.n_modes == 11
    assert s.max_abs_offdiag == pytest.approx(max_quoted, abs=1e-12)
    # Sec. 3.3 quotes 0.23 and 0.13; the printed (rounded) entries give 0.235 and 0.137.
    assert abs(s.mean_abs_offdiag - mean_quoted) < 0.01
    assert orthogonality_summary(np.eye(1)).max_abs_offdiag == 0.0


def test_correct_model_keeps_basis(guyan):
    phi_x, f_x = measured(3)
    rm = correct_model(guyan, phi_x, f_x, zeta=0.02)
    assert rm.method == "guyan+baruch" and rm.master == guyan.master
    np.testing.assert_array_equal(rm.T, guyan.T)
    assert rm.c is not None
    f_hat = natural_frequencies_hz(rm.m, rm.k)
    for f in f_x:
        assert np.min(np.abs(f_hat / f - 1)) < 1e-8
    with pytest.raises(dataclasses.FrozenInstanceError):
        rm.k = None
    with pytest.raises(ModelError, match="ReducedModel"):
        correct_model(guyan.m, phi_x, f_x)


def test_errors(guyan):
    m, k = guyan.m, guyan.k
    phi_x, f_x = measured(3)
    with pytest.raises(ModelError, match=r"expected \(5, n_m\)"):
        baruch_correction(m, k, phi_x[:4], f_x)
    with pytest.raises(ModelError, match="between 1 and n_R = 5"):
        baruch_correction(m, k, np.ones((5, 6)), np.ones(6))
    with pytest.raises(ModelError, match="2 dimension"):
        baruch_correction(m, k, phi_x[:, 0], f_x[:1])
    with pytest.raises(ModelError, match="complex"):
        baruch_correction(m, k, phi_x + 1j * phi_x, f_x)
    with pytest.raises(ModelError, match=r"freq_hz has shape \(2,\), expected \(3,\)"):
        baruch_correction(m, k, phi_x, f_x[:2])
    with pytest.raises(ModelError, match=">= 0 Hz"):
        baruch_correction(m, k, phi_x, -f_x)
    with pytest.raises(ModelError, match="mode 2 .*zero or negative modal mass"):
        baruch_correction(m, k, np.column_stack([phi_x[:, 0], np.zeros(5)]), f_x[:2])
    dependent = np.column_stack([phi_x[:, 0], phi_x[:, 1], -2.0 * phi_x[:, 0]])
    with pytest.raises(ModelError, match=r"linearly dependent: mode 1, mode 3"):
        baruch_correction(m, k, dependent, f_x)
    with pytest.raises(ModelError, match="zeta"):
        baruch_correction(m, k, phi_x, f_x, zeta=[0.01, -0.01, 0.02])
    with pytest.raises(ModelError, match="normalise the shapes"):
        corrected_stiffness(k, m, phi_x, f_x)
    with pytest.raises(ModelError, match="base must be"):
        sequential_correction(m, k, phi_x, f_x, base="cumulative")
    k_bad = np.array(k)
    k_bad[0, 1] += 1.0
    with pytest.raises(ModelError, match="k must be symmetric"):
        baruch_correction(m, k_bad, phi_x, f_x)
