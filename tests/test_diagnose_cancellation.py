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
