"""The model-error floor of a line where the modes' terms cancel (vlab.diagnose.model.cancellation).

Checked against the modal sum written out here (open loop: ``kappa = sqrt(sum |t_g|^2) / |sum t_g|``), against
its limits (one dominant term: 1; a valley: large), and on the decision it changes: a second model of the
same structure that differs by a small error of each mode's term is no mismatch, a changed structure still is.
"""

from __future__ import annotations

import numpy as np
import pytest

from vlab.diagnose.model.cancellation import cancellation_ratio, line_floor, mode_groups
from vlab.diagnose.model.labmodel import LabState, natural_frequencies
from vlab.diagnose.model.modelform import BAND_MARGIN
from vlab.lab.loop import HardwareChain
from vlab.models import nominal_fe_model


@pytest.fixture(scope="module")
def open_loop():
    fe = nominal_fe_model("bcc")
    return LabState(fe.spec, fe, HardwareChain(noise_m_s=0.0), None)


def _terms(st: LabState, f: np.ndarray, out: int, exc: int) -> tuple[np.ndarray, np.ndarray]:
    """Open-loop velocity terms ``j w phi_o phi_i / D_r`` per mode, shape (n_f, n_modes), and the natural
    frequencies [Hz]."""
    fr, zeta, phi = natural_frequencies(st)
    w, wr = 2 * np.pi * f, 2 * np.pi * fr
    a = phi[st.fe.dofs.index(out, "w"), :] * phi[st.fe.dofs.index(exc, "w"), :]
    d = wr[None, :] ** 2 - w[:, None] ** 2 + 2j * zeta[None, :] * wr[None, :] * w[:, None]
    return 1j * w[:, None] * a[None, :] / d, fr


def test_groups_are_the_band_modes_alone_and_each_side_together():
    fn = np.array([0.5, 1.5, 3.0, 6.0, 20.0, 40.0, 80.0])
    groups = mode_groups(fn, np.array([2.0, 10.0]))
    lo, hi = 2.0 / BAND_MARGIN, 10.0 * BAND_MARGIN
    assert [g.tolist() for g in groups] == [[1], [2], [3], [0], [4, 5, 6]]
    assert fn[1] >= lo and fn[3] <= hi and fn[0] < lo and fn[4] > hi


def test_open_loop_ratio_is_the_written_out_modal_sum(open_loop):
    f = np.linspace(3.0, 25.0, 300)
    kappa = cancellation_ratio(open_loop, f, excitation_point=9, output_points=(2, 6))
    for j, out in enumerate((2, 6)):
        t, fr = _terms(open_loop, f, out, 9)
        parts = [t[:, g].sum(axis=1) for g in mode_groups(fr, f)]
        expect = np.sqrt(sum(np.abs(p) ** 2 for p in parts)) / np.abs(t.sum(axis=1))
        np.testing.assert_allclose(kappa[:, j], expect, rtol=1e-3)


def test_one_at_a_resonance_and_large_in_a_valley(open_loop):
    fr, _zeta, _phi = natural_frequencies(open_loop)
    f = np.linspace(2.0, 25.0, 2000)
    kappa = cancellation_ratio(open_loop, f, excitation_point=9, output_points=(9,))[:, 0]
    at = [int(np.argmin(np.abs(f - x))) for x in fr if 2.5 < x < 24.0]
    assert at and np.all(np.abs(kappa[at] - 1.0) < 0.1)  # one term dominates at its resonance
    t, _ = _terms(open_loop, f, 9, 9)
    valley = int(np.argmin(np.abs(t.sum(axis=1))))  # the deepest antiresonance of the driving point
    assert kappa[valley] > 10.0


def test_line_floor_is_never_below_the_floor_and_zero_without_one(open_loop):
    f = np.linspace(3.0, 25.0, 50)
    fl = line_floor(open_loop, f, 0.005, excitation_point=9, output_points=(2, 5))
    assert fl.shape == (50, 2) and np.all(fl >= 0.005)
    assert np.any(fl > 0.01)
    assert np.all(line_floor(open_loop, f, 0.0, excitation_point=9, output_points=(2, 5)) == 0.0)


def test_closed_loop_ratio_is_finite_and_one_where_the_loop_leaves_one_term():
    from _designs import bcc_design

    fe = nominal_fe_model("bcc")
    design = bcc_design("mfdrf")
    st = LabState(fe.spec, fe, HardwareChain(noise_m_s=0.0), design)
    f = np.linspace(3.0, 25.0, 200)
    kappa = cancellation_ratio(st, f, excitation_point=9, output_points=(5, 9))
    assert np.all(np.isfinite(kappa)) and np.all(kappa > 0)
    assert np.median(kappa) < 5.0


def _another_model(st: LabState, f: np.ndarray, out: tuple, rel: float, seed: int) -> np.ndarray:
    """The FRFs of a second model of the structure: every term of the modal sum (each band mode, the modes
    below and above) off by an independent relative error of standard deviation ``rel``."""
    from dataclasses import replace

    from vlab.diagnose.model.labmodel import point_modes_of
    from vlab.diagnose.model.labmodel import predict_frf

    pm = point_modes_of(st, tuple(dict.fromkeys(out + st.actuators)))
    rng = np.random.default_rng(seed)
    shapes = pm.shapes.copy()
    for g in mode_groups(pm.omega / (2 * np.pi), f):
        shapes[:, g] *= np.sqrt(1.0 + rel * rng.standard_normal())
    return predict_frf(replace(st, point_modes=replace(pm, shapes=shapes)), f, excitation_point=9,
                       output_points=out)


@pytest.mark.parametrize("seed", (1, 2, 3))
def test_small_term_errors_are_no_mismatch_a_changed_structure_is(open_loop, seed):
    """Data of a second model (each term 0.3 % off, 1e-4 relative noise): within the model's accuracy with the
    floor of each term, a mismatch with the floor of each line alone (its valleys stand out); the same data with
    the beam's stiffness 1 % higher stand out with either floor."""
    from dataclasses import replace

    from vlab.diagnose.data.measured import FrfData
    from vlab.diagnose.model.labmodel import predict_frf
    from vlab.diagnose.problem.context import context_for
    from vlab.diagnose.problem.residuals import Problem
    from vlab.experiment.config import TESTS

    st = open_loop
    f = np.arange(55, 500) * 0.05
    out = (1, 2, 3, 4, 5, 6, 7, 8, 9)
    h = _another_model(st, f, out, 0.003, seed)
    noise = 1e-4 * np.abs(h) * np.random.default_rng(seed + 10).standard_normal(h.shape)
    data = FrfData("other.uff", "frf", f, h + noise, (1e-4 * np.abs(h)) ** 2, 9, out)
    ctx = context_for(st, TESTS["bcc"].band_hz, data)
    terms = Problem(data, st, ctx, floor=0.005)
    lines = Problem(data, st, ctx, floor=0.005, line_floor=np.full(h.shape, 0.005))
    assert terms.within_noise(st)
    assert not lines.within_noise(st)
    stiff = replace(st, fe=replace(st.fe, k=st.fe.k * 1.01))
    h2 = predict_frf(stiff, f, excitation_point=9, output_points=out)
    changed = replace(data, h=h2 * (h / predict_frf(st, f, excitation_point=9, output_points=out)))
    assert not Problem(changed, st, ctx, floor=0.005).within_noise(st)


def test_a_line_floor_of_another_shape_is_refused(open_loop):
    from vlab.diagnose.data.measured import FrfData
    from vlab.diagnose.problem.context import context_for
    from vlab.diagnose.problem.residuals import Problem
    from vlab.experiment.config import TESTS

    f = np.arange(55, 100) * 0.05
    h = _another_model(open_loop, f, (5, 9), 0.0, 0)
    data = FrfData("x.uff", "frf", f, h, (1e-4 * np.abs(h)) ** 2, 9, (5, 9))
    ctx = context_for(open_loop, TESTS["bcc"].band_hz, data)
    with pytest.raises(ValueError, match=r"line_floor has shape \(45, 1\), the data's FRFs \(45, 2\)"):
        Problem(data, open_loop, ctx, line_floor=np.full((45, 1), 0.005))
