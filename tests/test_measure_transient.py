"""Transient removal for periodic excitation (vlab.measure.transient), against the closed-form FRF of a
discrete two-mode system: the transient left after five of seven periods biases the plain period average far
beyond the noise at the quasi-static lines; the local polynomial method removes it, and its variance
accounts for what is left."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal

from vlab.errors import MeasurementError
from vlab.measure.transient import periodic_spectra

DT, T_S, PERIODS, SKIP = 5e-4, 20.0, 7, 5


@pytest.fixture(scope="module")
def test_case():
    n = int(round(T_S / DT))
    rng = np.random.default_rng(1)
    f = np.fft.rfftfreq(n, DT)
    lines = np.flatnonzero((f >= 0.5 - 1e-9) & (f <= 40.0))
    spec = np.zeros(f.size, complex)
    spec[lines] = np.exp(2j * np.pi * rng.random(lines.size))
    x1 = np.fft.irfft(spec, n)
    x1 /= x1.std()
    a, b, c = np.zeros((4, 4)), np.zeros((4, 1)), np.zeros((1, 4))
    for i, (fn, z, mass) in enumerate([(1.853, 0.004, 1.0), (4.8, 0.002, 2.0)]):  # the BCC's first two modes
        w = 2 * np.pi * fn
        ad, bd, cd, _, _ = scipy.signal.cont2discrete(
            (np.array([[0, 1], [-w * w, -2 * z * w]]), np.array([[0], [1 / mass]]), np.array([[0.0, 1.0]]),
             np.zeros((1, 1))), DT, "zoh")
        a[2 * i:2 * i + 2, 2 * i:2 * i + 2], b[2 * i:2 * i + 2], c[:, 2 * i:2 * i + 2] = ad, bd, cd
    _, y, _ = scipy.signal.dlsim((a, b, c, np.zeros((1, 1)), DT), np.tile(x1, PERIODS))
    y = y[:, 0] + 1e-4 * np.std(y) * rng.standard_normal(y.shape[0])
    zz = np.exp(2j * np.pi * f[lines] * DT)  # the exact FRF of the discrete system at the lines
    h_exact = np.array([(c @ np.linalg.solve(q * np.eye(4) - a, b))[0, 0] for q in zz])
    return n, lines, f[lines], np.fft.rfft(x1)[lines], y[SKIP * n:], h_exact


def test_transient_is_removed_to_the_noise(test_case):
    n, lines, f, x, y, h_exact = test_case
    plain = np.fft.rfft(y.reshape(-1, n), axis=1)[:, lines].mean(axis=0) / x
    ps = periodic_spectra(y, n, lines)
    h = ps.y[:, 0] / x
    e_plain, e_new = np.abs(np.log(plain / h_exact)), np.abs(np.log(h / h_exact))
    sd = np.sqrt(ps.noise_var[:, 0]) / np.abs(x) / np.abs(h_exact)
    low = f < 1.5  # quasi-static lines below mode 1
    assert np.median(e_plain[low]) > 10 * np.median(sd[low])  # the bias the plain average carries
    assert np.median(e_new[low]) < 2 * np.median(sd[low])
    assert e_new.max() < 0.1 * e_plain.max()
    assert 0.7 < np.sqrt(np.mean((e_new / sd) ** 2)) < 1.6  # the variance accounts for the error
    assert ps.dof == 6 and ps.transient.shape == ps.y.shape


def test_steady_state_is_unchanged(test_case):
    """A periodic record without transient (the same period repeated) comes back as it was."""
    n, lines, _f, x, y, _h = test_case
    one = y[-n:]
    ps = periodic_spectra(np.tile(one, 3), n, lines)
    np.testing.assert_allclose(ps.y[:, 0], np.fft.rfft(one)[lines], rtol=1e-9, atol=1e-9 * np.abs(ps.y).max())
    assert np.abs(ps.transient).max() < 1e-9 * np.abs(ps.y).max()


def test_bad_input_is_named(test_case):
    n, lines, *_ = test_case
    with pytest.raises(MeasurementError, match="two or more whole periods"):
        periodic_spectra(np.zeros(n), n, lines)
    with pytest.raises(MeasurementError, match="excited lines"):
        periodic_spectra(np.zeros(2 * n), n, np.array([0, 5]))
    with pytest.raises(MeasurementError, match="polynomial"):
        periodic_spectra(np.zeros(2 * n), n, lines, half_width=1, degree=2)
