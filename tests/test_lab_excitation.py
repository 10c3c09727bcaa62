"""Excitation signals (vlab.lab.excitation)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import signal

from vlab.errors import ModelError
from vlab.lab.excitation import (filtered_random, half_sine_pulse, multisine_lines_hz,
                                 pseudo_random, sine_sweep, stepped_sine, time_grid)

DT = 0.5e-3


def test_time_grid():
    t = time_grid(dt_s=DT, duration_s=1.0)
    assert t.size == 2000 and t[0] == 0.0 and t[1] == pytest.approx(DT)
    with pytest.raises(ModelError):
        time_grid(dt_s=0.0, duration_s=1.0)


def test_pseudo_random_rms_band_and_periodicity():
    df = 0.5
    t = time_grid(dt_s=DT, duration_s=4.0)          # two periods of 2 s
    x = pseudo_random(t, band_hz=(0, 25), resolution_hz=df, rms_n=2.0, seed=1)
    assert np.sqrt(np.mean(x**2)) == pytest.approx(2.0, rel=1e-12)
    n_per = int(round(1 / (df * DT)))
    np.testing.assert_allclose(x[:n_per], x[n_per:], atol=1e-12)
    spec = np.abs(np.fft.rfft(x[:n_per])) / n_per
    f = np.fft.rfftfreq(n_per, DT)
    lines = multisine_lines_hz((0, 25), df)
    assert lines[0] == df and lines[-1] == 25.0 and lines.size == 50
    on = np.isin(np.round(f / df).astype(int), np.round(lines / df).astype(int)) & (f > 0)
    assert np.all(spec[on] > 0.1) and np.all(spec[~on] < 1e-12)
    # equal amplitudes A/2 at each line
    np.testing.assert_allclose(spec[on], spec[on][0], rtol=1e-9)


def test_pseudo_random_seeded_and_fallback_path_agrees():
    t = time_grid(dt_s=DT, duration_s=2.0)
    a = pseudo_random(t, band_hz=(1, 10), resolution_hz=1.0, rms_n=1.0, seed=5)
    b = pseudo_random(t, band_hz=(1, 10), resolution_hz=1.0, rms_n=1.0, seed=5)
    c = pseudo_random(t, band_hz=(1, 10), resolution_hz=1.0, rms_n=1.0, seed=6)
    np.testing.assert_array_equal(a, b)
    assert not np.allclose(a, c)
    # a non-uniform grid takes the direct sum of cosines; same function of time
    tu = np.sort(np.concatenate([t[:50], t[50:100] + 0.1 * DT]))
    direct = pseudo_random(tu, band_hz=(1, 10), resolution_hz=1.0, rms_n=1.0, seed=5)
    np.testing.assert_allclose(direct[:50], a[:50], atol=1e-12)
    s = pseudo_random(t, band_hz=(1, 10), resolution_hz=1.0, rms_n=1.0, phases="schroeder")
    assert np.sqrt(np.mean(s**2)) == pytest.approx(1.0, rel=1e-12)
    assert np.max(np.abs(s)) < np.max(np.abs(a)) * 1.5


def test_pseudo_random_errors():
    t = time_grid(dt_s=DT, duration_s=1.0)
    with pytest.raises(ModelError, match="seed"):
        pseudo_random(t, band_hz=(0, 10), resolution_hz=1.0, rms_n=1.0)
    with pytest.raises(ModelError, match="Nyquist"):
        pseudo_random(t, band_hz=(0, 1000), resolution_hz=1.0, rms_n=1.0, seed=1)
    with pytest.raises(ModelError, match="band_hz"):
        pseudo_random(t, band_hz=(10, 5), resolution_hz=1.0, rms_n=1.0, seed=1)


def test_filtered_random_rms_and_band():
    t = time_grid(dt_s=DT, duration_s=60.0)
    x = filtered_random(t, band_hz=(0, 10), rms_n=3.0, seed=2)
    assert np.sqrt(np.mean(x**2)) == pytest.approx(3.0, rel=1e-12)
    f, p = signal.welch(x, fs=1 / DT, nperseg=8192)
    inband = p[(f > 1) & (f < 8)].mean()
    assert p[(f > 30) & (f < 100)].max() < 1e-4 * inband
    np.testing.assert_array_equal(x, filtered_random(t, band_hz=(0, 10), rms_n=3.0, seed=2))
    bp = filtered_random(t, band_hz=(5, 10), rms_n=1.0, seed=2, order=4)
    f, p = signal.welch(bp, fs=1 / DT, nperseg=8192)
    assert p[f < 1].max() < 1e-3 * p[(f > 6) & (f < 9)].mean()
    with pytest.raises(ModelError, match="uniformly"):
        filtered_random(np.array([0.0, 0.1, 0.3]), band_hz=(0, 1), rms_n=1.0, seed=1)


def test_sine_sweep_frequency_law():
    t = time_grid(dt_s=DT, duration_s=10.0)
    x = sine_sweep(t, f_start_hz=1.0, f_stop_hz=11.0, amplitude_n=2.0)
    assert x[0] == pytest.approx(2.0) and np.max(np.abs(x)) <= 2.0 + 1e-12
    phase = np.unwrap(np.angle(signal.hilbert(x)))
    f_inst = np.gradient(phase, DT) / (2 * np.pi)
    mid = slice(2000, 18000)
    np.testing.assert_allclose(f_inst[mid], 1.0 + t[mid], rtol=0.02)


def test_stepped_sine_dwells_and_continuity():
    t = time_grid(dt_s=DT, duration_s=7.0)
    freqs = [2.0, 3.0, 5.0]
    x = stepped_sine(t, freqs_hz=freqs, dwell_s=2.0, amplitude_n=1.5)
    for i, fk in enumerate(freqs):
        seg = x[int(i * 2.0 / DT):int((i + 1) * 2.0 / DT)]
        spec = np.abs(np.fft.rfft(seg))
        f = np.fft.rfftfreq(seg.size, DT)
        assert f[np.argmax(spec)] == pytest.approx(fk)
        assert np.max(np.abs(seg)) == pytest.approx(1.5, rel=1e-3)
    assert np.max(np.abs(np.diff(x))) < 2 * np.pi * 5.0 * 1.5 * DT * 1.01   # no jumps
    assert np.all(x[t >= 6.0] == 0.0)


def test_half_sine_pulse_impulse():
    t = time_grid(dt_s=1e-5, duration_s=0.1)
    x = half_sine_pulse(t, peak_n=10.0, duration_s=0.01, start_s=0.02)
    impulse = np.trapezoid(x, t) if hasattr(np, "trapezoid") else np.trapz(x, t)
    assert impulse == pytest.approx(2 * 10.0 * 0.01 / math.pi, rel=1e-6)
    assert np.all(x[t < 0.02] == 0.0) and np.all(x[t > 0.03 + 1e-9] == 0.0)
    assert x.max() == pytest.approx(10.0, rel=1e-6)
    with pytest.raises(ModelError, match="duration_s"):
        half_sine_pulse(t, peak_n=1.0, duration_s=0.0)
