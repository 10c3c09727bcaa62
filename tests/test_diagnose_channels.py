"""Controller-path effects located on one channel.

The library proposes ``loop_delay``, ``actuator_lag``, ``sensor_lag``,
``actuator_gain``, ``sensor_gain`` and ``saturation`` on every controller
channel and on all channels together; a per-channel hypothesis changes
only its channel's entry of the chain. End to end, a recording of the 2 kHz
loop (linear BCC plant, MFDRF) with an extra delay of 1.5 samples on one
coil channel must be named ``loop_delay`` on that channel with the delay
within 5 % (the user's report: it was named ``member_stiffness``).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from vlab.diagnose import diagnose
from vlab.diagnose.effects import hypotheses as H
from vlab.diagnose.model.labmodel import LabState, predict_frf
from vlab.diagnose.model.nominal import nominal_design
from vlab.diagnose.problem.context import context_for
from vlab.errors import ModelError
from vlab.experiment.config import TESTS
from vlab.lab.loop import HardwareChain
from vlab.models import nominal_fe_model

CHAIN = ("loop_delay", "actuator_lag", "sensor_lag", "actuator_gain", "sensor_gain", "saturation")


@pytest.fixture(scope="module")
def lab():
    fe = nominal_fe_model("bcc")
    st = LabState(fe.spec, fe, HardwareChain(noise_m_s=1e-6), nominal_design(fe, "mfdrf", 0))
    ctx = context_for(st, TESTS["bcc"].band_hz, None)
    f = np.linspace(*TESTS["bcc"].band_hz, 60)
    ctx.closed_loop, ctx.excitation_point = True, fe.spec.instrumentation.excitation
    ctx.freq_hz, ctx.force_amplitude = f, np.full(f.size, 0.05)
    return st, ctx


def test_closed_loop_library_has_each_chain_effect_on_every_channel_and_on_all(lab):
    st, ctx = lab
    hyps = H.library(st, ctx)
    for eff in CHAIN:
        where = [h.location["channel"] for h in hyps if h.effect == eff]
        assert where == ["all", *st.actuators], eff


def test_open_loop_library_has_no_per_channel_actuator_path_effects(lab):
    st, ctx = lab
    open_ctx = replace(ctx, closed_loop=False)
    hyps = H.library(replace(st, design=None), open_ctx)
    chans = {(h.effect, h.location["channel"]) for h in hyps if h.effect in CHAIN}
    # only the excited coil carries force open loop: one actuator lag and one saturation, for all channels
    assert ("actuator_lag", "all") in chans and ("saturation", "all") in chans
    assert not any(e in ("actuator_lag", "saturation") and c != "all" for e, c in chans)
    assert ("actuator_gain", "all") not in chans


def test_per_channel_hypothesis_changes_only_its_channel(lab):
    st, ctx = lab
    ch = st.actuators[0]
    cases = [(H.LoopDelay(channel=ch), [4.0 * st.chain.period_s], "channel_delay_periods", 4.0),
             (H.ActuatorLag(channel=ch), [80.0], "channel_actuator_lag_hz", 80.0),
             (H.SensorLag(channel=ch), [80.0], "channel_sensor_lag_hz", 80.0),
             (H.Saturation(channel=ch), [0.3], "channel_limit_n", 0.3)]
    for h, x, field, value in cases:
        chain = h.apply(st, np.array(x), ctx).chain
        assert getattr(chain, field) == pytest.approx({ch: value}), h.label
        # the global settings are untouched
        assert (chain.delay_periods, chain.actuator_lag_hz, chain.sensor_lag_hz, chain.amplifier_limit_n) == \
            (st.chain.delay_periods, st.chain.actuator_lag_hz, st.chain.sensor_lag_hz, st.chain.amplifier_limit_n)
    all_gain = H.SensorGain(channel="all").apply(st, np.array([1.3]), ctx).chain
    assert all_gain.sensor_gain == pytest.approx({p: 1.3 for p in st.actuators})


def test_a_delay_on_one_channel_is_not_a_delay_on_all(lab):
    """The same extra delay on one channel and on all gives different closed-loop FRFs (the model tells them
    apart), and each equals the closed form of its chain: K's row of that channel times e^{-j w tau}."""
    st, ctx = lab
    f, exc = ctx.freq_hz, ctx.excitation_point
    ch = st.actuators[0]
    tau = 1.5 * st.chain.period_s
    one = H.LoopDelay(channel=ch).apply(st, np.array([st.chain.delay_periods * st.chain.period_s + tau]), ctx)
    every = H.LoopDelay().apply(st, np.array([st.chain.delay_periods * st.chain.period_s + tau]), ctx)
    h0, h1, h2 = (predict_frf(s, f, excitation_point=exc, output_points=st.actuators) for s in (st, one, every))
    assert np.max(np.abs(np.log(h1 / h0))) > 0.05
    assert np.max(np.abs(np.log(h1 / h2))) > 0.05


def test_bad_channel_is_refused():
    with pytest.raises(ModelError, match="channel"):
        H.LoopDelay(channel="7")


@pytest.fixture(scope="module")
def delayed_run(tmp_path_factory, lab):
    import test_diagnose as td

    st, _ = lab
    ch = st.actuators[0]
    truth = replace(st, chain=replace(st.chain, channel_delay_periods={ch: st.chain.delay_periods + 1.5}))
    path = td._record(truth, tmp_path_factory.mktemp("chan") / "rec.uff")
    return ch, truth, diagnose("bcc", path, controller="mfdrf", validate_run=False)


def test_extra_delay_on_one_coil_channel_is_named_loop_delay_there(delayed_run):
    ch, truth, r = delayed_run
    assert r.mismatch and r.selected is not None
    assert r.selected.effect == "loop_delay" and r.selected.location == {"channel": ch}
    assert r.selected.params_[0] == pytest.approx(truth.chain.delay_of(ch) * truth.chain.period_s, rel=0.05)
    d = r.as_dict()
    assert d["selected"][0]["location"] == {"channel": ch}


@pytest.fixture(scope="module")
def damping_and_delay(lab):
    """Exact closed-loop FRFs (1 % noise variance) of the BCC with mode 2's damping tripled and 2 extra samples
    of delay on channel 7: a pair of a damping effect and a per-channel controller-path effect."""
    from vlab.diagnose.data.measured import FrfData
    from vlab.diagnose.effects import specedit
    from vlab.diagnose.model.labmodel import natural_frequencies
    from vlab.diagnose.problem.residuals import Problem

    st, _ = lab
    _, zeta, _ = natural_frequencies(st)
    z2 = 3.0 * float(zeta[1])
    delay_s = (st.chain.delay_periods + 2.0) * st.chain.period_s
    truth = replace(st.with_spec(specedit.set_modal_damping(st.spec, 2, z2)),
                    chain=replace(st.chain, channel_delay_periods={7: delay_s / st.chain.period_s}))
    freq = np.arange(10, 500) * 0.05
    exc, outs = st.spec.instrumentation.excitation, tuple(TESTS["bcc"].measured_points)
    h = predict_frf(truth, freq, excitation_point=exc, output_points=outs)
    data = FrfData("bcc.uff", "frf", freq, h, (0.01 * np.abs(h)) ** 2, exc, outs)
    problem = Problem(data, st, context_for(st, TESTS["bcc"].band_hz, data))
    return problem, {"damping(mode=2)": z2, "loop_delay(channel=7)": delay_s}


@pytest.mark.parametrize("first", ("damping", "loop_delay"))
def test_forward_pair_step_finds_a_per_channel_delay_next_to_a_damping_effect_and_back(damping_and_delay, first):
    """Held at its single fit, either part of the pair finds the other among the whole library (every family
    is screened as the second effect: vlab.diagnose.fit.estimate.fit_pairs); the joint fit sizes both."""
    from vlab.diagnose.fit.estimate import fit_hypothesis, fit_pairs

    problem, truth = damping_and_delay
    pool = H.library(problem.base, problem.ctx)
    one = fit_hypothesis(H.ModalDamping(mode=2) if first == "damping" else H.LoopDelay(channel=7), problem)
    best = min(fit_pairs([one], problem, pool, rounds=0), key=lambda c: c.bic_)
    found = {h.label: x for h, x in zip(best.parts, (best.params_[:1], best.params_[1:]))}
    assert set(found) == set(truth)
    for label, value in truth.items():
        assert found[label][0] == pytest.approx(value, rel=1e-3), label
