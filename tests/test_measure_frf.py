"""H1 FRF estimation (vlab.measure.frf) against analytic 2-DOF FRFs."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from _modal_systems import receptance, state_space, two_dof
from vlab.errors import MeasurementError
from vlab.lab.excitation import filtered_random, pseudo_random, time_grid
from vlab.io.recording import Recording
from vlab.io.frf import FRF
from vlab.measure.frf import h1, measure_frfs, required_duration_s

FS = 400.0
DT = 1 / FS


@pytest.fixture(scope="module")
def system():
    M, C, K, fn, z = two_dof()
    return M, C, K, state_space(M, C, K, in_dof=1, out_dof=0)


def _velocity_frf(freq_hz, M, C, K):
    return 2j * np.pi * np.asarray(freq_hz) * receptance(freq_hz, M, C, K, 0, 1)


def test_h1_random_excitation_recovers_analytic_frf(system):
    """Filtered random force, output noise: |H1 - H| / |H| small where coherence is high."""
    M, C, K, ss = system
    df, n_avg = 0.02, 9
    t = time_grid(dt_s=DT, duration_s=required_duration_s(df, n_averages=n_avg))
    x = filtered_random(t, band_hz=(0, 30), rms_n=1.0, seed=1)
    _, y, _ = signal.lsim(ss, x, t)
    y = y + 0.002 * np.std(y) * np.random.default_rng(2).standard_normal(y.size)
    frf = h1(x, y, dt_s=DT, resolution_hz=df, f_max_hz=20.0, input_name="force9",
             output_name="vel6")
    assert frf.n_averages == n_avg
    assert frf.freq_hz[1] == pytest.approx(df)
    assert frf.response == "velocity" and frf.unit == "(m/s)/N"
    H = _velocity_frf(frf.freq_hz, M, C, K)
    good = (frf.coherence > 0.98) & (frf.freq_hz > 0.5)
    assert good.mean() > 0.9
    err = np.abs(frf.h[good] - H[good]) / np.abs(H[good])
    assert np.median(err) < 0.01
    assert err.max() < 0.08            # leakage bias at the sharp peaks (Hann, df/bandwidth ~ 0.1)


def test_h1_periodic_excitation_is_leakage_free(system):
    """Multisine with period = block length and a rectangular window: exact at every line."""
    M, C, K, ss = system
    df = 0.05
    T = 1 / df
    fs = 1000.0
    t = time_grid(dt_s=1 / fs, duration_s=6 * T)
    x = pseudo_random(t, band_hz=(0, 20), resolution_hz=df, rms_n=1.0, seed=3)
    _, y, _ = signal.lsim(ss, x, t)
    n0 = int(2 * T * fs)                    # discard the start-up transient
    frf = h1(x[n0:], y[n0:], dt_s=1 / fs, resolution_hz=df, window="boxcar", overlap=0.0,
             f_max_hz=20.0)
    assert frf.n_averages == 4
    H = _velocity_frf(frf.freq_hz[1:], M, C, K)
    np.testing.assert_allclose(frf.h[1:], H, rtol=0.01)
    assert np.all(frf.coherence[1:] > 0.999)


def test_velocity_to_displacement_divides_by_i_omega(system):
    M, C, K, _ = system
    f = np.linspace(0, 20, 401)
    hv = FRF(freq_hz=f, h=_velocity_frf(f, M, C, K), response="velocity", coherence=np.ones(f.size))
    hd = hv.to_displacement()
    assert hd.response == "displacement" and hd.unit == "m/N"
    assert hd.freq_hz[0] == f[1]                         # 0 Hz dropped
    np.testing.assert_allclose(hd.h, receptance(f[1:], M, C, K, 0, 1), rtol=1e-12)
    np.testing.assert_allclose(hd.to_velocity().h, hv.h[1:], rtol=1e-12)
    with pytest.raises(MeasurementError, match="needs a velocity FRF"):
        hd.to_displacement()


def test_short_record_error_names_channel():
    x = np.random.default_rng(0).standard_normal(1000)
    with pytest.raises(MeasurementError, match=r"channel vel6 \(force force9\).*shorter than one block"):
        h1(x, x, dt_s=DT, resolution_hz=0.01, input_name="force9", output_name="vel6")
    with pytest.raises(MeasurementError, match="channel vel6: non-finite"):
        h1(x, np.full(1000, np.nan), dt_s=DT, resolution_hz=1.0, output_name="vel6")
    with pytest.raises(MeasurementError, match="window"):
        h1(x, x, dt_s=DT, resolution_hz=1.0, window="flattop")


def test_measure_frfs_from_recording(system):
    M, C, K, ss = system
    t = time_grid(dt_s=DT, duration_s=60.0)
    x = filtered_random(t, band_hz=(0, 30), rms_n=1.0, seed=4)
    _, y, _ = signal.lsim(ss, x, t)
    rec = Recording.from_signals(DT, {"force9": x, "vel6": y, "vel7": 2 * y})
    frfs = measure_frfs(rec, input_channel="force9", resolution_hz=0.1)
    assert list(frfs) == ["vel6", "vel7"]
    f6 = frfs["vel6"]
    assert (f6.output_name, f6.input_name, f6.output_point, f6.input_point) == ("vel6", "force9", 6, 9)
    np.testing.assert_allclose(frfs["vel7"].h[1:], 2 * f6.h[1:], rtol=1e-10)
    assert np.median(f6.coherence[(f6.freq_hz > 1) & (f6.freq_hz < 20)]) > 0.99   # noiseless, linear
    with pytest.raises(MeasurementError, match="must be a force"):
        measure_frfs(rec, input_channel="vel6", resolution_hz=0.1)


def test_frf_validation():
    with pytest.raises(MeasurementError, match="strictly increasing"):
        FRF(freq_hz=[0.0, 2.0, 1.0], h=[1, 2, 3])
    with pytest.raises(MeasurementError, match="unknown response"):
        FRF(freq_hz=[0.0, 1.0], h=[1, 2], response="strain")
    frf = FRF(freq_hz=[0.0, 1.0, 2.0], h=[1, 2, 3])
    with pytest.raises(ValueError):
        frf.h[0] = 5
    assert frf.band(0.5, 2.0).freq_hz.tolist() == [1.0, 2.0]
