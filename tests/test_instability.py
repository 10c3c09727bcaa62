"""Self-excited oscillations in a recording (vlab.measure.instability).

Synthetic recordings whose content is known by construction (a periodic
multisine force through a resonance, a sine that grows and saturates, a mode
driven by white noise), and two recordings of the MuJoCo BCC in vlab's loop:
the LQG that spills over into a residual mode (a limit cycle near 48.6 Hz,
found independently by the experiment's out-of-band check and the
sampled-data eigenvalues of the Sec. 6.1 study) and the stable MFDRF.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from vlab.errors import MeasurementError
from vlab.io.recording import Recording
from vlab.measure.instability import ENVELOPE_CV_RAYLEIGH, find_instability, force_period

from _designs import bcc_design

FS = 2000.0
PERIOD = 20000  # 10 s
N = 3 * PERIOD


def _multisine(rng) -> np.ndarray:
    """A periodic pseudo-random force, lines 0.1-25 Hz, three identical periods [N]."""
    f = np.fft.rfftfreq(PERIOD, 1 / FS)
    spec = np.where((f > 0.1) & (f < 25), np.exp(2j * np.pi * rng.random(f.size)), 0)
    one = np.fft.irfft(spec, PERIOD)
    return np.tile(one / one.std(), 3)


def _resonance(x, f_hz, zeta):
    """Velocity of a single mode (f_hz, zeta) to force x, discretised bilinearly."""
    w = 2 * np.pi * f_hz
    b, a = signal.bilinear([1.0, 0.0], [1.0, 2 * zeta * w, w * w], FS)
    return signal.lfilter(b, a, x)


def _recording(x, channels) -> Recording:
    return Recording.from_signals(1 / FS, {"force9": x, **channels})


def _base(seed=0):
    rng = np.random.default_rng(seed)
    x = _multisine(rng)
    y = _resonance(x, 4.8, 0.03) + 1e-6 * rng.standard_normal(N)
    return rng, x, y


def test_forced_response_and_noise_are_stable():
    rng, x, y = _base()
    # a sharp forced resonance inside the band (incoherent by the Welch estimate, yet periodic) and a
    # lightly damped mode at 37 Hz driven by white noise (Rayleigh envelope)
    sharp = _resonance(x, 23.4, 0.002)  # decay time 3.4 s: settled within a period, as the lab runs it
    driven = _resonance(rng.standard_normal(N), 37.0, 0.002)
    driven *= 30e-6 / driven.std()
    rec = _recording(x, {"vel5": y + sharp, "vel6": y + driven})
    check = find_instability(rec, feedback_points=(5, 6))
    assert not check.unstable, check.summary()
    assert check.loop_point is None and check.frequency_hz is None
    assert "no self-excited oscillation" in check.summary()


def test_limit_cycle_is_found_with_frequency_growth_and_loop():
    rng, x, y = _base(1)
    t = np.arange(N) / FS
    envelope = 0.05 * np.tanh(np.exp(0.8 * (t - 6.0)))  # grows from ~0, then holds 0.05 m/s
    cycle = envelope * np.sin(2 * np.pi * 41.37 * t)
    rec = _recording(x, {"vel5": y + 0.2 * cycle, "vel6": y + cycle, "vel8": y})
    check = find_instability(rec, feedback_points=(5, 6))
    assert check.unstable
    assert abs(check.frequency_hz - 41.37) < 0.05
    assert check.loop_point == 6
    top = [o for o in check.oscillations if o.point == 6][0]
    assert top.rise > 10 and not top.growing
    assert top.envelope_cv < 0.1 * ENVELOPE_CV_RAYLEIGH
    assert top.coherence < 0.5 and top.period_change > 0.3
    assert 0.3 * 0.05 / np.sqrt(2) < top.amplitude_m_s < 3 * 0.05 / np.sqrt(2)
    assert f"{check.frequency_hz:.2f} Hz" in check.summary() and "limit cycle" in check.summary()
    js = check.as_dict()
    assert js["unstable"] is True and js["loop_point"] == 6 and "frequency_hz" in js


def test_growth_still_going_at_the_end():
    rng, x, y = _base(2)
    t = np.arange(N) / FS
    grow = 1e-5 * np.exp(0.25 * t) * np.sin(2 * np.pi * 61.0 * t)
    check = find_instability(_recording(x, {"vel7": y + grow}), feedback_points=(7,))
    assert check.unstable
    o = check.oscillations[0]
    assert o.growing and abs(o.growth_rate_1_s - 0.25) < 0.03
    assert "still growing" in check.summary()



@pytest.mark.parametrize("cycles_per_period, periodic", [(410.0, True), (410.016, True), (410.25, False),
                                                         (410.5, False)])
def test_period_change_is_measured_clear_of_the_filters_end(cycles_per_period, periodic):
    """A steady sine of frequency f0 changes by 2 |sin(pi f0 T)| over the excitation's period T (closed form):
    0 on a harmonic of the excitation (f0 T an integer), 0.10 at f0 T = 410.016, 1.41 and 2 at a quarter and
    half a cycle off. The change is measured where the zero-phase band-pass filter's response to the record's end
    does not reach (it made a sine on a harmonic look changed by 0.26): within 1 % of the closed form, and a
    sine closer to a harmonic than the detector's period gate is not a self-excited oscillation."""
    rng, x, y = _base(5)
    f0 = cycles_per_period / (PERIOD / FS)
    t = np.arange(N) / FS
    sine = 2e-3 * np.sin(2 * np.pi * f0 * t + 0.3)  # above the force's band: incoherent with it
    check = find_instability(_recording(x, {"vel6": y + sine}), feedback_points=(6,))
    expected = 2 * abs(np.sin(np.pi * cycles_per_period))
    assert check.unstable is not periodic
    if not periodic:
        top = check.oscillations[0]
        assert abs(top.frequency_hz - f0) < 0.05
        assert top.period_change == pytest.approx(expected, rel=0.01)


@pytest.mark.xfail(strict=True, reason="a known limitation: a start-up transient beside a forced line of its band, "
                   "too slow for the slope test over the record's second half, passes for an oscillation; a test "
                   "on the non-repeating part's fall also dropped limit cycles that set in during the record")
def test_a_transient_beside_a_forced_line_is_not_an_oscillation():
    """A lightly damped start-up transient (41.05 Hz, decaying at 0.15 1/s) beside a periodic line of the same
    band (41.0 Hz, a harmonic of the 10 s excitation period): the forced line holds the band's amplitude up,
    so its slope over the record's second half (-0.026 1/s) shows no decay, and the period change is large
    (0.67); but the part that does not repeat, z(t) - z(t - T), falls e^(0.15 T) = 4.5-fold from one period
    to the next: a transient, not a self-excited oscillation."""
    rng, x, y = _base(7)
    t = np.arange(N) / FS
    period_s = PERIOD / FS
    forced = 1e-3 * np.sin(2 * np.pi * 410.0 / period_s * t)
    transient = 3e-3 * np.exp(-0.15 * t) * np.sin(2 * np.pi * 410.5 / period_s * t + 0.4)
    check = find_instability(_recording(x, {"vel6": y + forced + transient}), feedback_points=(6,))
    assert not check.unstable, check.summary()


@pytest.mark.parametrize("fraction", [0.055, 0.07])
def test_a_limit_cycle_that_sets_in_during_the_record_is_found(fraction):
    """A steady oscillation near a harmonic of the excitation (f0 T = 410 + fraction: a period change of
    2 sin(pi fraction) = 0.34 and 0.44) that sets in about 6 s into a three-period record: its non-repeating part
    is largest at the onset, so it falls from the first period to the next as a transient's does -- but the
    line has grown since the record began; a self-excited oscillation."""
    rng, x, y = _base(11)
    t = np.arange(N) / FS
    f0 = (410.0 + fraction) / (PERIOD / FS)
    envelope = 2e-3 / (1.0 + np.exp(-(t - 6.0) / 0.3))
    check = find_instability(_recording(x, {"vel6": y + envelope * np.sin(2 * np.pi * f0 * t)}), feedback_points=(6,))
    assert check.unstable, check.summary()
    assert check.oscillations[0].period_change == pytest.approx(2 * np.sin(np.pi * fraction), rel=0.02)


def test_filter_settling_of_a_one_pole_section_in_closed_form():
    """h[n] = a^n: the energy from n on is a^(2n) of the whole, below level^2 from n = ceil(ln(level)/ln(a))."""
    from vlab.measure.instability import filter_settling

    a = 0.99
    sos = np.array([[1.0, 0.0, 0.0, 1.0, -a, 0.0]])
    assert filter_settling(sos, level=1e-3) == int(np.ceil(np.log(1e-3) / np.log(a)))
    with pytest.raises(ValueError, match="level"):
        filter_settling(sos, level=1.5)

def test_period_of_the_force():
    rng = np.random.default_rng(3)
    x = _multisine(rng)
    assert force_period(x) == PERIOD
    assert force_period(rng.standard_normal(N)) is None
    assert force_period(np.zeros(N)) is None


def test_bad_input_is_named():
    rng, x, y = _base()
    with pytest.raises(MeasurementError, match="no velocity channel"):
        find_instability(Recording.from_signals(1 / FS, {"force9": x}))
    with pytest.raises(MeasurementError, match="force3"):
        find_instability(_recording(x, {"vel5": y}), force_channel="force3")
    with pytest.raises(MeasurementError, match="at least 256"):
        find_instability(_recording(x[:200], {"vel5": y[:200]}))


@pytest.fixture(scope="module")
def bcc_fe():
    from vlab.models import nominal_fe_model

    return nominal_fe_model("bcc")


def _bcc_recording(fe, controller):
    from vlab.experiment.config import ExperimentConfig
    from vlab.experiment.runner import measure

    design = bcc_design(controller)  # = vlab.design("bcc", controller), made once per test process
    cfg = ExperimentConfig(structure="bcc", controller=controller)
    return measure(cfg, fe, design).loop.recording


def test_lqg_spillover_limit_cycle_on_the_mujoco_bcc(bcc_fe):
    rec = _bcc_recording(bcc_fe, "lqg")
    check = find_instability(rec, feedback_points=(5, 6, 7, 9))
    assert check.unstable
    assert abs(check.frequency_hz - 48.6) < 0.5  # the experiment's out-of-band check: 48.6 Hz
    assert check.loop_point in (5, 6, 7, 9)


@pytest.mark.slow
def test_stable_mfdrf_on_the_mujoco_bcc(bcc_fe):
    rec = _bcc_recording(bcc_fe, "mfdrf")
    check = find_instability(rec, feedback_points=(5, 6, 7, 9))
    assert not check.unstable, check.summary()


def test_a_decaying_mode_is_a_transient_not_an_oscillation():
    """A lightly damped mode's free response (zeta 0.0002 at 37 Hz, decaying at 0.047 1/s, started by the loop)
    stands far over the floor, incoherent with the force and not periodic, with a smooth envelope: yet it dies
    out, which a self-excited oscillation never does. The same line held at its level is one."""
    rng, x, y = _base(4)
    t = np.arange(N) / FS
    w = 2 * np.pi * 37.03  # above the force's lines, not a whole number of cycles per period
    free = 0.02 * np.exp(-0.0002 * w * t) * np.sin(w * np.sqrt(1 - 0.0002**2) * t)
    check = find_instability(_recording(x, {"vel8": y + free}), feedback_points=(8,))
    assert not check.unstable, check.summary()
    held = 0.02 * np.exp(-0.0002 * w * np.minimum(t, 5.0)) * np.sin(w * t)
    check = find_instability(_recording(x, {"vel8": y + held}), feedback_points=(8,))
    assert check.unstable and abs(check.frequency_hz - 37.03) < 0.05


def test_the_rerun_of_an_unstable_loop_counts_a_slow_growth():
    """A line on a harmonic of the excitation (41.0 Hz, above the force's band: incoherent with it) growing at
    0.025 1/s changes by e^(0.025 T) - 1 = 0.28 from one 10 s period to the next and rises 1.45x over the
    record's second half: below the period gate and the growth factor, which a stable mode building up from
    rest could reach. In the noise-free rerun of a loop whose linearisation has an unstable pole, that growth
    is the pole's: an oscillation."""
    rng, x, y = _base(9)
    t = np.arange(N) / FS
    line = 2e-3 * np.exp(0.025 * t) * np.sin(2 * np.pi * 410.0 / (PERIOD / FS) * t + 0.2)
    rec = _recording(x, {"vel6": y + line})
    assert not find_instability(rec, feedback_points=(6,)).unstable
    check = find_instability(rec, feedback_points=(6,), unstable_loop=True)
    assert check.unstable, check.summary()
    o = check.oscillations[0]
    assert o.growing and o.growth_rate_1_s == pytest.approx(0.025, rel=0.3)  # the filter's end lowers it
    assert abs(o.frequency_hz - 41.0) < 0.05


def test_a_stable_mode_building_up_from_rest_is_no_oscillation():
    """A sharp resonance (12.3 Hz, zeta 0.001) forced by the periodic force from rest builds up as
    1 - exp(-a t): from the record's middle to its end by 1 + exp(-a T/2) < 2, and its slope there is
    significant; leakage makes it incoherent by the Welch estimate. Below the growth factor it is no
    oscillation; a rule that counted any significant rise as growth would take it for one."""
    rng, x, _ = _base(9)
    rec = _recording(x, {"vel5": _resonance(x, 4.8, 0.03) + _resonance(x, 12.3, 0.001)})
    assert not find_instability(rec, feedback_points=(5,)).unstable
    assert find_instability(rec, feedback_points=(5,), unstable_loop=True).unstable  # the rule it would be
