"""The loop's stability (Nyquist) and the search for the cause of a self-excited oscillation.

Checked against independent references: the eigenvalues of a state-space closed loop, and vlab's
time-domain 2 kHz loop on the linear FE plant (a different path from the frequency-domain model) on
either side of the stability boundary the criterion finds.
"""

from __future__ import annotations

from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest

from vlab.diagnose.fit.identity import branch, nearest_mode, plausible_branches, plausible_modes, reproduces_oscillation
from vlab.diagnose.fit.boundary import destabilising_value, recorded_mode_band
from vlab.diagnose.instability_cause import recorded_growth_rate
from vlab.diagnose.model.labmodel import LabState
from vlab.diagnose.model.nominal import nominal_design
from vlab.diagnose.model.nyquist import loop_stability, poles_near, unstable_closed_loop_poles, zeros_in_box
from vlab.errors import ModelError
from vlab.lab.loop import HardwareChain
from vlab.models import nominal_fe_model


def _mechanical(rng, n_modes=3, n_io=2):
    """A lightly damped mechanical system with force inputs and velocity outputs (random, non-collocated)."""
    w = 2 * np.pi * np.sort(rng.uniform(2.0, 60.0, n_modes))
    z = rng.uniform(0.002, 0.03, n_modes)
    a = np.zeros((2 * n_modes, 2 * n_modes))
    a[:n_modes, n_modes:] = np.eye(n_modes)
    a[n_modes:, :n_modes] = -np.diag(w**2)
    a[n_modes:, n_modes:] = -np.diag(2 * z * w)
    b = np.vstack([np.zeros((n_modes, n_io)), rng.standard_normal((n_modes, n_io))])
    c = np.hstack([np.zeros((n_io, n_modes)), rng.standard_normal((n_io, n_modes))])
    return a, b, c


def test_nyquist_count_equals_the_state_space_eigenvalues():
    rng = np.random.default_rng(7)
    n_unstable_cases = 0
    for _ in range(40):
        a, b, c = _mechanical(rng)
        k = rng.standard_normal((2, 2)) * 10 ** rng.uniform(-1, 2)
        truth = int(np.sum(np.linalg.eigvals(a - b @ k @ c).real > 0))
        n_unstable_cases += truth > 0

        def det_of(f, a=a, b=b, c=c, k=k):
            s = 2j * np.pi * np.asarray(f)
            g = np.linalg.solve(s[:, None, None] * np.eye(a.shape[0])[None] - a[None], b[None])
            return np.linalg.det(np.eye(2)[None] + k[None] @ c[None] @ g)

        z, _w, _n = unstable_closed_loop_poles(det_of, 5000.0, 0, df_hz=1.0, seeds_hz=[])
        assert z == truth
    assert 5 <= n_unstable_cases <= 35  # both outcomes were tested


def test_the_box_count_equals_the_state_space_eigenvalues_in_the_box():
    """The argument principle around a box (:func:`zeros_in_box` on ``det(I + K C (sI - A)^-1 B)``) against
    the eigenvalues of ``A - B K C`` there, for random loops and boxes; the open loop is stable, so no pole
    of the return difference lies in a box right of ``Re s = 0``."""
    rng = np.random.default_rng(11)
    hits = 0
    for _ in range(40):
        a, b, c = _mechanical(rng)
        k = rng.standard_normal((2, 2)) * 10 ** rng.uniform(-1, 2)
        eig = np.linalg.eigvals(a - b @ k @ c)
        lo_w, hi_w = np.sort(rng.uniform(0.0, 2 * np.pi * 80.0, 2))
        sigma0 = rng.uniform(0.0, 2.0)
        box = ((sigma0, 2 * np.pi * 200.0), (lo_w, hi_w))
        truth = int(np.sum((eig.real > box[0][0]) & (eig.real < box[0][1]) & (eig.imag > lo_w) & (eig.imag < hi_w)))
        hits += truth > 0

        def det_of(s, a=a, b=b, c=c, k=k):
            g = np.linalg.solve(s[:, None, None] * np.eye(a.shape[0])[None] - a[None], b[None])
            return np.linalg.det(np.eye(2)[None] + k[None] @ c[None] @ g)

        assert round(zeros_in_box(det_of, *box)) == truth
    assert hits >= 3  # boxes holding poles were tested, not only empty ones
    with pytest.raises(ModelError, match="increasing"):
        zeros_in_box(np.exp, (1.0, 0.0), (0.0, 1.0))


def test_the_recorded_modes_band_is_its_branch_in_band_and_its_own_interval_above():
    natural = [10.0, 20.0, 40.0, 80.0]
    assert recorded_mode_band(25.0, natural, False, 1000.0) == (20.0, 40.0)
    assert recorded_mode_band(75.0, natural, True, 1000.0) == (60.0, 1000.0)  # nearest 80 Hz, up to Nyquist
    assert recorded_mode_band(33.0, natural, True, 1000.0) == (30.0, 60.0)
    assert recorded_mode_band(5.0, natural, False, 1000.0) == (0.0, 10.0)


@pytest.fixture(scope="module")
def bcc_mfdrf():
    fe = nominal_fe_model("bcc")
    return LabState(fe.spec, fe, HardwareChain(noise_m_s=0.0, amplifier_gain=2.0), nominal_design(fe, "mfdrf", 0))


def test_stability_boundary_agrees_with_the_time_domain_loop(bcc_mfdrf):
    """The delay at which the FE model's MFDRF loop (amplifier gain 2) loses stability, by the criterion,
    against vlab's 2 kHz loop on the linear FE plant 3 % on either side of it: steady below, growing above."""
    from vlab.diagnose.data.replay import rerun

    st = bcc_mfdrf
    assert loop_stability(st).unstable_poles == 0  # the nominal delay of 1.35 periods

    def unstable(periods):
        return loop_stability(replace(st, chain=replace(st.chain, delay_periods=periods))).unstable

    a, b = 1.35, 40.0
    assert unstable(b)
    for _ in range(10):
        m = 0.5 * (a + b)
        a, b = (a, m) if unstable(m) else (m, b)
    force = np.random.default_rng(0).standard_normal(16000) * 0.1
    growth = {}
    for factor in (0.97, 1.03):
        s = replace(st, chain=replace(st.chain, delay_periods=factor * b))
        run, _ = rerun(s, force, excitation_point=9, measured_points=(5,), plant="linear")
        v = np.asarray(run["vel5"])
        growth[factor] = np.std(v[-2000:]) / np.std(v[1000:3000])
    assert growth[0.97] < 1.5
    assert growth[1.03] > 2.5


def test_the_shifted_contour_counts_the_poles_growing_faster_than_the_recorded_rate(bcc_mfdrf):
    """Past the stability boundary (delay 1.15 x its boundary value) the growth rate of vlab's 2 kHz loop on
    the linear FE plant, fitted to the log-RMS of its time history, against the count on the contour shifted
    to ``Re s = sigma``: two poles (one pair) faster than 0.9 of it, none faster than 1.1 of it."""
    from vlab.diagnose.data.replay import rerun

    st = bcc_mfdrf

    def unstable(periods):
        return loop_stability(replace(st, chain=replace(st.chain, delay_periods=periods))).unstable

    a, b = 1.35, 40.0
    for _ in range(10):
        m = 0.5 * (a + b)
        a, b = (a, m) if unstable(m) else (m, b)
    s = replace(st, chain=replace(st.chain, delay_periods=1.15 * b))
    force = np.random.default_rng(0).standard_normal(16000) * 0.1
    run, _ = rerun(s, force, excitation_point=9, measured_points=(5,), plant="linear")
    v = np.asarray(run["vel5"])
    rms = np.array([np.std(v[i:i + 1000]) for i in range(0, v.size, 1000)])
    t = np.arange(rms.size) * 1000 * 5e-4
    sigma = np.polyfit(t[6:], np.log(rms[6:]), 1)[0]        # once the growing pole dominates
    assert sigma > 0.5
    assert loop_stability(s, sigma_1_s=0.9 * sigma).unstable_poles == 2
    assert loop_stability(s, sigma_1_s=1.1 * sigma).unstable_poles == 0
    # which mode: the growing pair's frequency, counted in a box, is the time history's oscillation
    spec = np.abs(np.fft.rfft(v[-8000:] * np.hanning(8000)))
    f_osc = np.fft.rfftfreq(8000, 5e-4)[np.argmax(spec)]
    assert poles_near(s, (0.97 * f_osc, 1.03 * f_osc), 0.9 * sigma) == 1
    assert poles_near(s, (1.03 * f_osc, 999.0), 0.9 * sigma) == 0
    assert poles_near(s, (0.0, 0.97 * f_osc), 0.9 * sigma) == 0
    with pytest.raises(ModelError, match="sigma_1_s"):
        loop_stability(s, sigma_1_s=-1.0)


def test_the_recorded_growth_rate_is_the_least_rate_that_made_the_rise():
    def line(rise, growing=False, rate=0.0, se=0.0, point=5, f=135.56):
        return {"point": point, "frequency_hz": f, "rise": rise, "growing": growing, "growth_rate_1_s": rate,
                "growth_rate_se_1_s": se}

    inst = {"frequency_hz": 135.56, "loop_point": 5, "resolution_hz": 0.25,
            "oscillations": [line(1e3, point=9), line(np.e ** 6)]}
    assert recorded_growth_rate(inst, 60.0) == pytest.approx(6 / 60)        # the loop's channel, ln(rise) / T
    inst["oscillations"][1] = line(np.e ** 6, growing=True, rate=2.0, se=0.1)
    assert recorded_growth_rate(inst, 60.0) == pytest.approx(1.7)           # still growing: its rate - 3 se
    inst["oscillations"][1] = line(0.5)                                     # no rise: no bound beyond 0
    assert recorded_growth_rate(inst, 60.0) == 0.0
    inst["oscillations"] = [line(1e3, f=86.0)]                               # another line: no bound
    assert recorded_growth_rate(inst, 60.0) == 0.0


def test_loop_stability_needs_a_controller_and_a_sane_grid(bcc_mfdrf):
    with pytest.raises(ModelError, match="open loop"):
        loop_stability(replace(bcc_mfdrf, design=None))
    with pytest.raises(ModelError, match="df_hz"):
        loop_stability(bcc_mfdrf, df_hz=0.0)


def _check(*freqs, resolution=0.05):
    """A rerun's instability check: lines at ``freqs``, the first the strongest at its loop point."""
    return SimpleNamespace(unstable=bool(freqs), resolution_hz=resolution, frequency_hz=freqs[0] if freqs else None,
                           oscillations=[SimpleNamespace(frequency_hz=f) for f in freqs])


def test_an_oscillation_is_reproduced_within_two_percent_or_on_its_branch():
    natural = [1.85, 4.8, 22.8, 36.9, 50.1, 67.4]
    assert branch(43.0, natural) == (36.9, 50.1)
    assert branch(0.5, natural) == (0.0, 1.85) and branch(80.0, natural) == (67.4, np.inf)
    assert reproduces_oscillation(43.0, _check(43.5))                       # within 2 %
    assert not reproduces_oscillation(43.0, _check(48.2))                   # 12 % off, no branch given
    assert reproduces_oscillation(43.0, _check(48.2), natural_hz=natural)   # same branch
    assert not reproduces_oscillation(43.0, _check(52.0), natural_hz=natural)  # the next branch
    assert not reproduces_oscillation(43.0, _check(), natural_hz=natural)   # the rerun is stable
    assert not reproduces_oscillation(43.0, None, natural_hz=natural)       # no rerun
    # only the rerun's own oscillation (its strongest line at its loop point) counts, not its weaker lines:
    # a diverging rerun has lines everywhere
    assert not reproduces_oscillation(43.0, _check(60.0, 43.0, 48.2), natural_hz=natural)
    assert reproduces_oscillation(43.0, _check(48.2, 60.0), natural_hz=natural)


def test_above_the_band_the_oscillating_mode_must_be_the_same():
    """Above the band the modes are known to their discretisation error only: an oscillation counts when its
    nearest natural frequency is the recording's (the default MuJoCo BCC plant's modes near 87-155 Hz)."""
    natural = [67.49, 87.22, 95.26, 97.45, 132.65, 154.23]
    assert nearest_mode(135.56, natural) == 132.65 and nearest_mode(86.17, natural) == 87.22
    # a limit cycle of the mode near 87 Hz does not reproduce one of the mode near 133 Hz
    assert not reproduces_oscillation(135.56, _check(86.17, 258.5), natural_hz=natural, same_mode=True)
    assert not reproduces_oscillation(135.56, _check(86.2, 48.9, 126.2), natural_hz=natural, same_mode=True)
    # the same mode, 2.6 % off: beyond the 2 % tolerance, on the same mode
    assert reproduces_oscillation(135.56, _check(132.0), natural_hz=natural, same_mode=True)
    # past the midpoint of two modes the branch changes, the nearest mode does not
    assert branch(130.0, natural) != branch(134.0, natural)
    assert reproduces_oscillation(134.0, _check(130.0), natural_hz=natural, same_mode=True)
    assert not reproduces_oscillation(134.0, _check(130.0), natural_hz=natural)


def test_the_recordings_identity_carries_the_models_frequency_uncertainty():
    """Closed forms: 42.94 Hz lies at log distances 0.1510 and 0.1542 from modes at 36.92 and 50.1 Hz. With each
    mode within w = z sigma of the model's, 50.1 Hz may be the nearest when 0.1542 - w <= 0.1510 + w, w >= 0.0016."""
    natural = [36.92, 50.1]
    z = 2.5758  # the two-sided 1 % quantile
    assert list(plausible_modes(42.94, natural)) == [36.92]
    assert list(plausible_modes(42.94, natural, [0.002, 0.002], z)) == [36.92, 50.1]   # w = 0.0052
    assert list(plausible_modes(42.94, natural, [0.0005, 0.0005], z)) == [36.92]       # w = 0.0013
    # a rerun on the model oscillating nearest the other mode (the default plant's 47.44 Hz against a converged
    # plant's 42.94 Hz): the same mode only within the model's uncertainty
    assert not reproduces_oscillation(42.94, _check(47.44), natural_hz=natural, same_mode=True)
    assert reproduces_oscillation(42.94, _check(47.44), natural_hz=natural, same_mode=True,
                                  sigma_rel=[0.002, 0.002], z=z)
    # a branch is plausible when the frequency may lie between its two modes: 20.5 Hz within 5 % of 20 Hz
    four = [10.0, 20.0, 40.0, 80.0]
    assert plausible_branches(20.5, four) == [(20.0, 40.0)]
    assert plausible_branches(20.5, four, [0.05] * 4, 1.0) == [(10.0, 20.0), (20.0, 40.0)]
    assert plausible_branches(20.5, four, [0.01] * 4, 1.0) == [(20.0, 40.0)]
    assert reproduces_oscillation(20.5, _check(15.0), natural_hz=four, sigma_rel=[0.05] * 4, z=1.0)
    assert not reproduces_oscillation(20.5, _check(15.0), natural_hz=four)
    # the loop poles' band follows the same sets: 75 Hz may be nearest 40 Hz when each mode may move 30 %
    assert recorded_mode_band(75.0, four, True, 1000.0, sigma_rel=[0.3] * 4, z=1.0) == (30.0, 1000.0)
    assert recorded_mode_band(20.5, four, False, 1000.0, sigma_rel=[0.05] * 4, z=1.0) == (10.0, 40.0)
    with pytest.raises(ValueError, match="sigma_rel"):
        plausible_modes(42.94, natural, [0.01], z)
    with pytest.raises(ValueError, match="sigma_rel"):
        recorded_mode_band(42.94, natural, True, 1000.0, sigma_rel=[0.01], z=z)


def test_a_recording_made_by_the_rerun_plant_has_no_frequency_uncertainty():
    """The recording's structure is the reruns' when the plant that made it is the one they run on."""
    import vlab.diagnose.instability_cause as ic

    problem = SimpleNamespace(policy=SimpleNamespace(identity_quantile=2.5758))
    assert ic._frequency_uncertainty(problem, None, [5.0, 14.0], on_plant=True, same_plant=True) == (None, 0.0, "")


def _lines(*lines, resolution=0.25):
    """A rerun's instability check from ``(frequency [Hz], amplitude [m/s], point)``, the first the strongest."""
    osc = [SimpleNamespace(frequency_hz=f, amplitude_m_s=a, point=p) for f, a, p in lines]
    return SimpleNamespace(unstable=True, resolution_hz=resolution, frequency_hz=lines[0][0], oscillations=osc)


def test_a_rerun_with_a_second_oscillation_the_recording_would_have_shown_does_not_reproduce_it():
    """A limit cycle's spectrum is its fundamental and harmonics. A rerun line at 85.77 Hz beside its 47.44 Hz
    oscillation, a tenth of its amplitude, would stand (0.1)^2 x 1.86e7 = 1.9e5 over the floor of a recording
    whose oscillation stands 1.86e7 over it: above the detector's 1e3, so the recording lacks it. At 0.005 of the
    amplitude it would stand 465 over the floor: the recording could not have shown it."""
    from vlab.diagnose.fit.identity import second_oscillation

    natural, z = [36.92, 50.07, 88.1], 2.5758
    kw = dict(natural_hz=natural, same_mode=True, sigma_rel=[0.004] * 3, z=z)
    recorded = {"frequency_hz": 42.94, "resolution_hz": 0.244,
                "oscillations": [{"point": 9, "frequency_hz": 42.94, "line_to_floor": 1.86e7}]}
    two = _lines((47.44, 1.0, 9), (94.88, 0.3, 9), (85.77, 0.1, 9))
    assert second_oscillation(two, recorded, **kw) == 85.77
    assert reproduces_oscillation(42.94, two, **kw)                       # its oscillation alone: the same mode
    assert not reproduces_oscillation(42.94, two, recorded=recorded, **kw)
    weak = _lines((47.44, 1.0, 9), (85.77, 0.005, 9))
    assert second_oscillation(weak, recorded, **kw) is None
    assert reproduces_oscillation(42.94, weak, recorded=recorded, **kw)
    harmonic = _lines((47.44, 1.0, 9), (94.9, 0.3, 9), (142.3, 0.1, 9))  # 2 f0 and 3 f0 within 2 k lines
    assert second_oscillation(harmonic, recorded, **kw) is None
    # a line the recording holds too (within 2 %) is no second oscillation; nor is one at a point where the
    # recorded oscillation is not measured (no footing)
    both = dict(recorded, oscillations=recorded["oscillations"] + [{"point": 9, "frequency_hz": 86.5,
                                                                    "line_to_floor": 1e4}])
    assert second_oscillation(two, both, **kw) is None
    # a point the recorded oscillation does not reach does not judge; one it reaches does, against the rerun's
    # oscillation there or, where it has none there, its largest
    elsewhere = _lines((47.44, 1.0, 9), (85.77, 0.1, 5))
    assert second_oscillation(elsewhere, recorded, **kw) is None
    at5 = dict(recorded, oscillations=recorded["oscillations"] + [{"point": 5, "frequency_hz": 42.94,
                                                                   "line_to_floor": 1e7}])
    assert second_oscillation(elsewhere, at5, **kw) == 85.77
    # the recorded oscillation's identity is the rerun's oscillation's: a rerun oscillating on both modes that
    # may be the recorded one's (47.44 and 38.0 Hz, nearest 50.07 and 36.92) holds two oscillations
    assert second_oscillation(_lines((47.44, 1.0, 9), (38.0, 0.2, 9)), recorded, **kw) == 38.0
    # a recorded harmonic (2 x 42.94 Hz) excuses a rerun line at its frequency only, not one of its mode
    harm = dict(recorded, oscillations=recorded["oscillations"] + [{"point": 9, "frequency_hz": 85.88,
                                                                    "line_to_floor": 1e4}])
    assert second_oscillation(_lines((47.44, 1.0, 9), (80.0, 0.1, 9)), harm, **kw) == 80.0
    assert second_oscillation(_lines((47.44, 1.0, 9), (86.5, 0.1, 9)), harm, **kw) is None


def test_the_identity_quantile_is_the_two_sided_normal_quantile_at_the_false_alarm_rate():
    from vlab.diagnose.policy import DecisionPolicy

    assert DecisionPolicy(false_alarm_rate=0.01).identity_quantile == pytest.approx(2.5758, abs=1e-4)
    assert DecisionPolicy(false_alarm_rate=0.05).identity_quantile == pytest.approx(1.9600, abs=1e-4)


class _Stub:
    """A one-parameter hypothesis on [0.1, 50] fitted at 2.0 (log or linear scale), scored by a parabola."""

    n_params = 1

    def __init__(self, log):
        self.log_scale, self.params_ = (log,), np.array([2.0])

    def space(self, state, ctx):
        return np.array([[1.0]]), np.array([0.1]), np.array([50.0])


class _StubProblem:
    base, ctx = None, None

    def state_for(self, h, x):
        return float(np.asarray(x)[0])

    def residual(self, x):
        return np.array([x - 2.0])


@pytest.mark.parametrize("log", [True, False])
def test_destabilising_value_is_the_boundary_nearest_the_fit(log):
    h, p = _Stub(log), _StubProblem()
    x = destabilising_value(h, p, lambda v: v > 3.7 or v < 0.2)   # unstable on both sides: 3.7 fits better
    assert 3.7 < x < 3.7 * 1.05
    assert destabilising_value(h, p, lambda v: False) is None      # never unstable in the range


def test_the_report_quotes_the_chi_square_of_the_selected_fit_not_the_best_ranked():
    """A self-excited recording's cause need not be the best-ranked fit: the report's chi-square is the selected
    effect's own (or none)."""
    from vlab.diagnose.report.verdict import selected_chi2 as _selected_chi2

    ranked = [{"effect": "member_stiffness+actuator_gain", "location": {"first": {"member": "beam"},
                                                                         "second": {"channel": 9}}, "chi2": 1417.0},
              {"effect": "loop_delay", "location": {"channel": 5}, "chi2": 1521.0}]
    res = {"ranked": ranked, "selected": [{"effect": "loop_delay", "location": {"channel": 5}}]}
    assert _selected_chi2(res) == 1521.0
    res["selected"] = [{"effect": "member_stiffness", "location": {"member": "beam"}},
                       {"effect": "actuator_gain", "location": {"channel": 9}}]
    assert _selected_chi2(res) == 1417.0
    res["selected"] = [{"effect": "loop_delay", "location": {"channel": 7}}]
    assert _selected_chi2(res) is None


def test_the_best_supported_candidate_is_rerun_even_when_its_linear_loop_is_stable(monkeypatch):
    """The loop analysis only saves reruns: the candidate the data support most is rerun whatever it says (near
    the boundary a linearisation cannot resolve the sign of the least-damped pole), and so is a nonlinear one;
    the others only with an unstable loop."""
    import vlab.diagnose.instability_cause as ic

    class Loops:
        band = None
        model = None

        def __init__(self, *a):
            self.on = "stub"

        def state(self, h, x=None):
            return SimpleNamespace(spec="base", chain=SimpleNamespace(period_s=5e-4))

        def poles(self, h, x=None, sigma=0.0):
            return 0  # every loop stable, the nominal's too

        def on_mode(self, h, x, sigma):
            return True

    cands = [SimpleNamespace(label=name, effect=name, n_params=2) for name in ("best", "second", "third")]
    cands.append(SimpleNamespace(label="saturation(channel=4)", effect="saturation", n_params=2))
    reran = []

    def rerun(problem, nominal, h, f, loops, **kw):
        reran.append(h.label)
        return {"effect": h.effect, "label": h.label, "rerun_frequencies_hz": [14.0], "reproduced": False}, None

    monkeypatch.setattr(ic, "_Loops", Loops)
    monkeypatch.setattr(ic, "structure_modes", lambda state: (np.array([5.0, 14.0, 30.0]),))
    monkeypatch.setattr(ic, "_supported", lambda *a: cands)
    monkeypatch.setattr(ic, "_rerun_candidate", rerun)
    monkeypatch.setattr(ic, "model_form_uncertainty",
                        lambda *a, **k: SimpleNamespace(frequency_rel=np.full(3, 0.01), describe=lambda: "stub"))
    problem = SimpleNamespace(ctx=SimpleNamespace(band_hz=(0.5, 10.0)), n_obs=100,
                              policy=SimpleNamespace(evidence=10.0, identity_quantile=2.5758))
    out = ic.search_cause(problem, None, cands, 14.0, (5,), chi2_0=1e4, c_hat=1.0, plant="linear", seed=0,
                          on_plant=False, growth_1_s=0.0)
    # a nonlinear candidate too: its linear loop is a describing function at one amplitude
    assert reran == ["best", "saturation(channel=4)"] and out.stable == ["second", "third"] and out.chosen is None


def test_a_rerun_oscillating_where_the_recording_and_the_linear_loop_do_not_is_the_plants_own(bcc_mfdrf):
    """vlab.diagnose.instability_cause.plant_own_oscillation: a rerun holding a growing 86 Hz line at a loop
    point (the MuJoCo plant's lightly damped mode above the band) beside a stable linear loop is the plant's
    own; the same rerun beside a linear loop that is unstable (delay 40 periods) is the effect's; a rerun
    without the line is no oscillation; a line within the data's band is not the plant's above-band modes'."""
    from types import SimpleNamespace

    from vlab.diagnose.instability_cause import plant_own_oscillation
    from vlab.io.recording import Recording

    dt, n = 5e-4, 16000
    t = np.arange(n) * dt
    rng = np.random.default_rng(3)
    force = rng.standard_normal(n) * 0.1
    quiet = {p: 1e-4 * rng.standard_normal(n) for p in (5, 7, 9)}
    rec = Recording.from_signals(dt, {"force9": force, **{f"vel{p}": v for p, v in quiet.items()}})
    growing = dict(quiet)
    growing[5] = quiet[5] + 1e-3 * np.exp(0.2 * t) * np.sin(2 * np.pi * 86.0 * t)
    unstable = replace(bcc_mfdrf, chain=replace(bcc_mfdrf.chain, delay_periods=40.0))
    f = plant_own_oscillation(SimpleNamespace(v_after=growing), rec, 9, (5, 7, 9), bcc_mfdrf, 25.0)
    assert f == pytest.approx(86.0, abs=0.1)
    assert plant_own_oscillation(SimpleNamespace(v_after=growing), rec, 9, (5, 7, 9), unstable, 25.0) is None
    assert plant_own_oscillation(SimpleNamespace(v_after=quiet), rec, 9, (5, 7, 9), bcc_mfdrf, 25.0) is None
    # in the band the plant carries the spec's modal damping: an oscillation there is not the plant's own
    assert plant_own_oscillation(SimpleNamespace(v_after=growing), rec, 9, (5, 7, 9), bcc_mfdrf, 100.0) is None


def test_a_recording_the_plant_made_tries_its_candidates_in_their_order_on_the_plant():
    """A 2.49 ms delay on grid channel 1 under LQG, recorded on the MuJoCo plant, oscillating at 0.81 Hz: on the
    FE model a 141 Hz lag on that channel fits as well as the delay (chi-square 590.6 against 591.4) and would be
    rerun first; on the plant's linearisation the delay is ahead (the order is by quasi-BIC there). Singles stay
    before pairs whatever the plant's chi-squares."""
    from types import SimpleNamespace

    import numpy as np

    import math

    from vlab.diagnose.effects.hypotheses import ActuatorLag, Combination, LoopDelay
    from vlab.diagnose.instability_cause import plant_order

    lag, delay = ActuatorLag(channel=1), LoopDelay(channel=1)
    lag.params_, delay.params_ = np.array([141.3]), np.array([0.00247])
    pair = Combination(first=LoopDelay(channel=1), second=ActuatorLag(channel=3))
    pair.params_ = np.array([0.00247, 50.0])
    table = {lag.label: 400.0, delay.label: 12.0, pair.label: 1.0}
    info = lambda chi2, k: (chi2 + 2 * k, chi2 + k * math.log(1000))  # noqa: E731 -- Problem.information
    model = SimpleNamespace(chi2=lambda h, x: table[h.label], problem=SimpleNamespace(information=info))
    assert plant_order([lag, delay, pair], model) == [delay, lag, pair]
