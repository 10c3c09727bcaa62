"""The hypothesis library and the frequency-domain lab model (fast, no time stepping)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from vlab.diagnose import EFFECTS
from vlab.diagnose.effects import specedit
from vlab.diagnose.effects import hypotheses as H
from vlab.diagnose.model.labmodel import LabState, natural_frequencies, predict_frf
from vlab.diagnose.model.nominal import nominal_design
from vlab.diagnose.problem.context import context_for
from vlab.errors import ModelError, SpecError
from vlab.fe import build_fe_model
from vlab.experiment.config import TESTS
from vlab.lab.loop import HardwareChain
from vlab.models import nominal_fe_model


@pytest.fixture(scope="module", params=["bcc", "grid"])
def lab(request):
    fe = nominal_fe_model(request.param)
    st = LabState(fe.spec, fe, HardwareChain(), nominal_design(fe, "mfdrf", 0))
    ctx = context_for(st, TESTS[fe.spec.name].band_hz, None)
    f = np.linspace(*TESTS[fe.spec.name].band_hz, 60)
    ctx.closed_loop, ctx.excitation_point = True, fe.spec.instrumentation.excitation
    ctx.freq_hz, ctx.force_amplitude = f, np.full(f.size, 0.05)
    return st, ctx


def _frf(st, ctx):
    return predict_frf(st, ctx.freq_hz, excitation_point=ctx.excitation_point, output_points=st.actuators)


def test_library_covers_every_effect(lab):
    st, ctx = lab
    hyps = H.library(st, ctx)
    assert {h.effect for h in hyps} == set(EFFECTS)
    for h in hyps:
        trials, lo, hi = h.space(st, ctx)
        assert trials.shape[1] == h.n_params == len(lo) == len(hi)
        assert np.all(lo <= hi)


def test_open_loop_library_has_no_controller_path_effects(lab):
    st, ctx = lab
    open_ctx = replace(ctx, closed_loop=False)
    effects = {h.effect for h in H.library(replace(st, design=None), open_ctx)}
    assert not effects & {"loop_delay", "sensor_lag", "sensor_gain"}
    gains = [h for h in H.library(replace(st, design=None), open_ctx) if h.effect == "actuator_gain"]
    assert [h.channel for h in gains] == [ctx.excitation_point]


def test_null_values_give_the_nominal_lab(lab):
    st, ctx = lab
    h0 = _frf(st, ctx)
    for h in H.library(st, ctx):
        x0 = h.null(st, ctx)
        if x0 is None or h.effect in ("friction",):
            continue
        h1 = _frf(h.apply(st, x0, ctx), ctx)
        np.testing.assert_allclose(h1, h0, rtol=1e-6, atol=1e-12 * np.abs(h0).max(), err_msg=h.label)


def test_fe_edits_equal_rebuilding_from_the_spec(lab):
    st, ctx = lab
    p = st.actuators[0]
    h = H.SupportStiffness(point=p)
    edited = h.apply(st, [123.0], ctx)
    rebuilt = build_fe_model(edited.spec)
    np.testing.assert_allclose(edited.fe.k, rebuilt.k, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(edited.fe.m, rebuilt.m)
    d = H.ModalDamping(mode=2).apply(st, [0.05], ctx)
    _, z, _ = natural_frequencies(d, 3)
    assert z[1] == pytest.approx(0.05)


def test_structural_effects_move_frequencies_the_right_way(lab):
    st, ctx = lab
    f0, _, _ = natural_frequencies(st, 4)
    p = st.actuators[0]
    heavier = H.AddedMass(point=p).apply(st, [0.2], ctx)
    stiffer = H.SupportStiffness(point=p).apply(st, [1e3], ctx)
    joint = next(q for q in sorted(st.spec.points) if len(specedit.joint_segments(st.spec, q)) >= 2)
    softer = H.JointFlexibility(point=joint).apply(st, [1.0], ctx)
    # a mass also adds weight: on a hanging structure the pre-stress may raise a pendulum mode
    assert not np.allclose(natural_frequencies(heavier, 4)[0], f0)
    assert np.all(natural_frequencies(stiffer, 4)[0] >= f0 - 1e-12)
    assert np.all(natural_frequencies(softer, 4)[0] <= f0 + 1e-12)


def test_spec_edits_keep_the_spec_unchanged_and_name_their_source(lab):
    st, _ = lab
    spec = st.spec
    m = spec.members[0]
    seg = (m.points[0], m.points[1])
    new = specedit.scale_segments(spec, {seg: 0.5})
    assert len(spec.members) <= len(new.members)
    assert build_fe_model(new).n == st.fe.n
    assert any(s.ei.source.startswith("diagnosis") for s in new.sections.values())
    assert spec.members[0] is m
    with pytest.raises(SpecError, match="no member segment"):
        specedit.scale_segments(spec, {(seg[0], 10_000): 2.0})
    with pytest.raises(SpecError, match="unknown point"):
        specedit.add_mass(spec, 10_000, 1.0)


def test_pairs_apply_both_effects_in_a_safe_order(lab):
    st, ctx = lab
    g = H.GravityPrestress()
    m = H.AddedMass(point=st.actuators[0])
    pair = H.Combination(first=g, second=m)
    both = pair.apply(st, [H.G_SI * 1.5, 0.1], ctx)
    expect = g.apply(m.apply(st, [0.1], ctx), [H.G_SI * 1.5], ctx)
    np.testing.assert_allclose(both.fe.k, expect.fe.k)
    assert pair.param_names == ("first.g_m_per_s2", "second.mass_kg")


def test_unknown_effect_name(lab):
    st, ctx = lab
    with pytest.raises(ModelError, match="unknown effect"):
        H.library(st, ctx, effects=("added_mas",))
