"""The reference of a recording of a real structure: a MuJoCo replay's own level dependence counted as the
reference's variance (vlab.diagnose.data.reference.with_replay_distortion), and the modes of referred data
referred on their poles where the replay plant places a lightly damped mode more than a bandwidth off
(vlab.diagnose.fit.locate._referred_mode)."""

from __future__ import annotations

import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from vlab.diagnose.data.reference import referred_through_replay, with_replay_distortion
from vlab.diagnose.fit.locate import _referred_mode
from vlab.diagnose.model.labmodel import LabState
from vlab.diagnose.model.nominal import nominal_design
from vlab.diagnose.reading import Options, read_inputs
from vlab.errors import OptionError
from vlab.lab.loop import HardwareChain
from vlab.measure.modal import peak_levels
from vlab.measure.modal_fit import fit_modes
from vlab.models import nominal_fe_model

sys.path.insert(0, str(Path(__file__).parent))
from _recordings import RES_HZ, record_linear  # noqa: E402


def _mode(f, fn, zeta, residue=1.0):
    """Velocity FRF of one mode, ``j w r / (wn^2 - w^2 + 2 j zeta wn w)`` [(m/s)/N], on lines ``f`` [Hz]."""
    w, wn = 2 * np.pi * f, 2 * np.pi * fn
    return (1j * w * residue / (wn**2 - w**2 + 2j * zeta * wn * w))[:, None]


@pytest.mark.parametrize("df", [0.05, 0.01])
def test_a_mode_the_baseline_places_two_bandwidths_off_is_referred_on_its_poles(df):
    """The BCC's mode 6 (0.1 % damping, half-power bandwidth 0.045 Hz) as the tier-3 recordings had it: the
    structure at 22.681 Hz, the MuJoCo replay at 22.797 Hz, the FE model at 22.714 Hz. The referral's closed
    form on the poles: f = 22.714 * 22.681 / 22.797, zeta = 0.001 * 0.001 / 0.00103 -- with the guesses
    :func:`frf_modes` passes (the baseline's at the model's peak, 0.083 Hz off its own) and its peak-level
    band (three half-power bandwidths of the model, at least two lines: 0.068 Hz)."""
    f = np.arange(20.0, 25.0 + df / 2, df)
    model, rec, base = _mode(f, 22.714, 0.001), _mode(f, 22.681, 0.001, 1.1), _mode(f, 22.797, 0.00103)
    d = SimpleNamespace(freq_hz=f, h_recorded=rec, h_baseline=base, source="synthetic")
    pred = fit_modes(f, model[:, 0], [22.714])[0]
    assert pred.damping_ratio == pytest.approx(0.001, rel=1e-3)
    half = max(3 * 0.001 * 22.714, 2 * df)
    fm, zm, ratio = _referred_mode(d, 0, 22.70, 22.714, (pred.freq_hz, pred.damping_ratio), half, 4.0)
    assert fm == pytest.approx(22.714 * 22.681 / 22.797, rel=1e-5)
    assert zm == pytest.approx(0.001 * 0.001 / 0.00103, rel=1e-3)
    # peak levels as measured (Sec. 5.4.1, the refined largest line): the baseline's over the recording's,
    # predicted over measured as in Table 10 (not its inverse)
    levels = [peak_levels(f, h[:, 0], [f0], half_band_hz=half)[0] for h, f0 in ((base, 22.797), (rec, 22.681))]
    assert ratio == pytest.approx(levels[0] / levels[1], rel=1e-9)
    # what the line-by-line referral gives a curve fit instead: the two plants' resonances on one line set
    lines = fit_modes(f, (rec * model / base)[:, 0], [22.70])[0]
    assert abs(lines.damping_ratio / 0.00097 - 1) > 0.3


def test_a_referred_mode_whose_fit_leaves_its_peak_is_not_referred():
    f = np.arange(20.0, 25.0001, 0.05)
    d = SimpleNamespace(freq_hz=f, h_recorded=_mode(f, 22.681, 0.001), h_baseline=_mode(f, 24.5, 0.001),
                        source="synthetic")
    assert _referred_mode(d, 0, 22.70, 22.80, (22.714, 0.001), 0.2, 0.5) is None


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """A clean MFDRF recording of the linear BCC lab without a sidecar plant, read as a user's would be."""
    fe = nominal_fe_model("bcc")
    lab = LabState(fe.spec, fe, HardwareChain(noise_m_s=1e-6), nominal_design(fe, "mfdrf", 0))
    path = record_linear(lab, tmp_path_factory.mktemp("rec") / "rec.uff")
    opt = Options(controller="mfdrf", plant="linear", resolution_hz=RES_HZ, replay=False)
    return read_inputs("bcc", path, opt, lambda s: None)


def test_a_linear_replay_has_no_level_dependence(recorded):
    """Superposition: the linear FE plant replayed at a tenth of the level gives the same FRFs per newton."""
    data, _rec, _kind = referred_through_replay(recorded.data, recorded.nominal, "linear")
    out, largest, _low = with_replay_distortion(data, recorded.nominal, "linear")
    assert largest < 1e-9
    np.testing.assert_allclose(out.var, data.var, rtol=1e-9)


def test_a_mujoco_replays_level_dependence_enters_the_variance_it_refers_through(recorded):
    """The hinge chains of the MuJoCo plant are not linear: the replay at 0.1 x the level differs, and that
    difference is the reference's own relative variance, propagated as a baseline's noise."""
    data, _rec, _kind = referred_through_replay(recorded.data, recorded.nominal, "mujoco")
    out, largest, _low = with_replay_distortion(data, recorded.nominal, "mujoco")
    assert 1e-6 < largest < 1.0
    added = (out.var - data.var) / np.abs(out.h) ** 2
    np.testing.assert_allclose(added, (out.var_baseline - data.var_baseline) / np.abs(out.h_baseline) ** 2,
                               rtol=1e-6, atol=1e-18)
    assert np.all(added >= 0) and np.sqrt(added.max()) == pytest.approx(largest, rel=1e-6)


def test_the_level_dependence_needs_data_referred_through_a_replay(recorded):
    with pytest.raises(OptionError, match="referred through a replay"):
        with_replay_distortion(recorded.data, recorded.nominal, "mujoco")


def test_the_low_level_replay_is_the_validations_nominal_rerun_at_that_level(recorded):
    """The diagnosis keeps the reference's replay at LOW_LEVEL x the level as the validation's nominal rerun
    there in the default window (cache key ``"nominal@level"``; a validation over every analysed period,
    key suffix ``"@all"``, makes its own): made again by the validation's own path (``reruns`` at that
    amplitude, default window), it gives the same signals."""
    from vlab.diagnose.data.reference import RERUN_SEED
    from vlab.diagnose.data.replay import LOW_LEVEL
    from vlab.diagnose.data.rerun_jobs import reruns, window_for
    from vlab.diagnose.problem.context import context_for
    from vlab.diagnose.problem.residuals import Problem

    data, _rec, _kind = referred_through_replay(recorded.data, recorded.nominal, "mujoco")
    _out, _largest, low = with_replay_distortion(data, recorded.nominal, "mujoco", guard_s=recorded.guard_s)
    problem = Problem(data, recorded.nominal, context_for(recorded.nominal, recorded.band_hz, data),
                      guard_s=recorded.guard_s, replay_plant="mujoco")
    window, suffix = window_for(problem, (recorded.nominal,))
    assert (window is None) == (suffix == "")  # only the default window's key is the kept replay's
    fresh, = reruns(problem, [(recorded.nominal, None)], "mujoco", seed=RERUN_SEED, workers=1, window=None,
                    amplitude=LOW_LEVEL)
    assert [c.name for c in fresh.channels] == [c.name for c in low.channels]
    assert fresh.dt_s == low.dt_s
    for c in fresh.channels:
        a, b = np.asarray(fresh[c.name]), np.asarray(low[c.name])
        assert a.shape == b.shape
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-9 * np.abs(b).max())
