"""A lab played back at a lower level (vlab.diagnose.data.replay.at_amplitude): every response of the lab's
own elements scales with the level -- the amplifier's clipping, Coulomb friction, the sensor noise -- so
that what does not scale in a rerun is the plant's own level dependence; and that dependence counted as a
variance about the low-level reruns (vlab.diagnose.data.replay.distortion_variance)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from vlab.diagnose.data.replay import at_amplitude, rerun
from vlab.diagnose.model.labmodel import LabState
from vlab.diagnose.model.nominal import nominal_design
from vlab.diagnose.data.replay import distortion_variance
from vlab.diagnose.validate import reruns_distortion
from vlab.lab.loop import HardwareChain
from vlab.models import nominal_fe_model

PTS = (5, 6, 7)


@pytest.fixture(scope="module")
def clipped():
    """The BCC under MFDRF with its amplifiers clipping at 0.05 N and the controller's sensor noise on."""
    fe = nominal_fe_model("bcc")
    return LabState(fe.spec, fe, HardwareChain(noise_m_s=1e-5, amplifier_limit_n=0.05), nominal_design(fe, "mfdrf", 0))


def _force(n=1200, rms=0.5):
    return np.random.default_rng(4).normal(0.0, rms, n)


def _velocities(state, force, seed=3):
    rec, _ = rerun(state, force, excitation_point=9, measured_points=PTS, plant="linear", seed=seed)
    return np.stack([np.asarray(rec[f"vel{p}"]) for p in PTS])


def test_a_clipping_lab_at_a_tenth_of_the_level_responds_a_tenth(clipped):
    force = _force()
    full = _velocities(clipped, force)
    tenth = _velocities(at_amplitude(clipped, 0.1), 0.1 * force)
    np.testing.assert_allclose(tenth, 0.1 * full, rtol=1e-9, atol=1e-12 * np.abs(full).max())
    # the clipping acts: the same lab with a linear amplifier responds otherwise, and so does the clipping lab
    # played at a tenth of the level with its limit kept (it then clips far less)
    linear = _velocities(replace(clipped, chain=replace(clipped.chain, amplifier_limit_n=None)), force)
    kept = _velocities(clipped, 0.1 * force)
    assert np.abs(linear - full).max() > 0.05 * np.abs(full).max()
    assert np.abs(kept - 0.1 * full).max() > 0.05 * np.abs(0.1 * full).max()


def test_friction_forces_and_per_channel_limits_scale_and_the_equivalent_dashpots_stay(clipped):
    lab = replace(clipped, frictions=((6, 0.02, 3.0),), rms_force_n={5: 0.4},
                  chain=replace(clipped.chain, channel_limit_n={5: 0.08, 7: None}))
    low = at_amplitude(lab, 0.25)
    assert low.frictions == ((6, 0.005, 3.0),) and low.rms_force_n == {5: 0.1}
    assert low.chain.channel_limit_n == {5: 0.02, 7: None}
    assert low.chain.amplifier_limit_n == pytest.approx(0.0125) and low.chain.noise_m_s == pytest.approx(2.5e-6)
    assert low.spec is lab.spec and low.design is lab.design
    for bad in (0.0, -1.0, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="amplitude scale"):
            at_amplitude(lab, bad)


def test_the_distortion_variance_is_the_sum_of_both_reruns_squared_relative_distortions():
    rng = np.random.default_rng(0)
    lb, la = (rng.normal(size=(50, 3)) + 1j * rng.normal(size=(50, 3)) for _ in range(2))
    db, da = (0.01 * (rng.normal(size=(50, 3)) + 1j * rng.normal(size=(50, 3))) for _ in range(2))
    var = distortion_variance((lb * (1 + db), la * (1 + da)), (lb, la))
    np.testing.assert_allclose(var, np.abs(db) ** 2 + np.abs(da) ** 2, rtol=1e-9)
    low_a = la.copy()
    low_a[0, 0] = 0.0  # a line the low-level rerun does not reach counts no distortion of that rerun
    var = distortion_variance((lb * (1 + db), la), (lb, low_a))
    assert var[0, 0] == pytest.approx(abs(db[0, 0]) ** 2, rel=1e-9) and np.all(np.isfinite(var))


def test_the_replays_distortion_in_the_data_is_not_counted_again_by_the_reruns():
    """Where the data were referred through the nominal replay with its distortion ``d_b`` in their variance,
    the reruns on that plant add only the modified rerun's ``|d_a|^2``: ``|d_b|^2 + |d_a|^2 - |d_b|^2``."""
    rng = np.random.default_rng(1)
    lb, la = (rng.normal(size=(40, 2)) + 1j * rng.normal(size=(40, 2)) for _ in range(2))
    db, da = (0.02 * (rng.normal(size=(40, 2)) + 1j * rng.normal(size=(40, 2))) for _ in range(2))
    full, low = (lb * (1 + db), la * (1 + da)), (lb, la)
    np.testing.assert_allclose(reruns_distortion(full, low, np.abs(db) ** 2), np.abs(da) ** 2, rtol=1e-9,
                               atol=1e-18)
    np.testing.assert_allclose(reruns_distortion(full, low, None), np.abs(db) ** 2 + np.abs(da) ** 2, rtol=1e-9)
    assert np.all(reruns_distortion(full, low, np.full((40, 2), 1.0)) == 0.0)  # never below zero


def test_a_rerun_runs_every_analysed_period_where_the_slowest_mode_outlasts_the_warm_starts_guard(clipped):
    """The guard before the analysed periods is one 20 s period: the BCC's open loop (mode 1 damped 0.4 %
    at 1.85 Hz decays to 1e-3 in ln(1000) / (0.004 * 2 pi 1.85) = 149 s) outlasts it and its reruns run
    through every analysed period; under MFDRF (its slowest closed-loop mode decays in under 10 s) they
    take the default window."""
    from types import SimpleNamespace

    from vlab.diagnose.data.rerun_jobs import outlasts_guard, window_for

    data = SimpleNamespace(periodic=True, recording=SimpleNamespace(dt_s=5e-4), freq_hz=np.arange(20, 500) * 0.05,
                           analysed_from_s=40.0, output_points=PTS)
    problem = SimpleNamespace(data=data, guard_s=None, ctx=SimpleNamespace(band_hz=(1.0, 25.0)))
    open_loop = replace(clipped, design=None)
    assert outlasts_guard(problem, (open_loop,)) and outlasts_guard(problem, (clipped, open_loop))
    assert not outlasts_guard(problem, (clipped,))
    assert window_for(problem, (clipped,)) == (None, "")
    data.periodic = False  # H1 with a window: no warm start, no guard
    assert not outlasts_guard(problem, (open_loop,))
