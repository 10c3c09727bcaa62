"""MAC, COMAC and mode pairing (vlab.measure.mac)."""

from __future__ import annotations

import numpy as np
import pytest

from vlab.errors import MeasurementError
from vlab.measure.mac import comac, mac, pair_modes


def _shapes(n_points=8, n_modes=4, seed=0):
    q, _ = np.linalg.qr(np.random.default_rng(seed).standard_normal((n_points, n_modes)))
    return q


def test_mac_identity_for_orthonormal_sets_and_scale_invariance():
    phi = _shapes()
    np.testing.assert_allclose(mac(phi, phi), np.eye(4), atol=1e-12)
    scaled = phi * np.array([2.0, -1.0, 0.5, -3.0])
    np.testing.assert_allclose(mac(phi, scaled), np.eye(4), atol=1e-12)
    cplx = phi * np.exp(1j * np.array([0.3, 1.0, -2.0, 0.1]))
    np.testing.assert_allclose(mac(cplx, phi), np.eye(4), atol=1e-12)
    assert mac(phi[:, 0], phi[:, 0]).shape == (1, 1)


def test_mac_known_value():
    a = np.array([1.0, 0.0])
    b = np.array([1.0, 1.0])
    assert mac(a, b)[0, 0] == pytest.approx(0.5)


def test_comac_flags_the_disturbed_point():
    phi = _shapes()
    np.testing.assert_allclose(comac(phi, -2.0 * phi), np.ones(8), atol=1e-12)
    bad = phi.copy()
    bad[5] = -bad[5] + 0.3
    c = comac(phi, bad)
    assert np.argmin(c) == 5
    assert c[5] < 0.9


def test_pair_modes_finds_permutation():
    phi = _shapes()
    perm = [2, 0, 3, 1]
    pairs = pair_modes(mac(phi, phi[:, perm]), threshold=0.9)
    assert [(i, j) for i, j, _ in pairs] == [(0, 1), (1, 3), (2, 0), (3, 2)]
    assert all(v == pytest.approx(1.0) for *_, v in pairs)
    assert pair_modes(np.zeros((2, 2)) + 0.1, threshold=0.5) == []


def test_errors():
    with pytest.raises(MeasurementError, match="8 points"):
        mac(_shapes(), _shapes(7))
    with pytest.raises(MeasurementError, match="mode 2 is identically zero"):
        mac(np.array([[1.0, 0.0], [0.0, 0.0]]), np.eye(2))
    with pytest.raises(MeasurementError, match="paired"):
        comac(_shapes(8, 4), _shapes(8, 3))
