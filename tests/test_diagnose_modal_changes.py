"""One-parameter modal changes computed together (vlab.diagnose.model.modal_changes) against the lab's own
prediction made once per change (predict_frf), open and closed loop and with a dashpot (the per-change path);
the model-form profile with that Jacobian against scipy's own finite differences."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import scipy.optimize

from vlab.diagnose.data.measured import FrfData
from vlab.diagnose.model.labmodel import LabState, PointModes, natural_frequencies, predict_frf
from vlab.diagnose.model.modal_changes import changed_mode_frfs, moved_modes
from vlab.diagnose.model.modelform import ModelFormUncertainty, frf_model_form
from vlab.diagnose.model.nominal import nominal_design
from vlab.diagnose.problem import nuisance
from vlab.diagnose.problem.context import context_for
from vlab.diagnose.problem.residuals import Problem
from vlab.lab.loop import HardwareChain
from vlab.models import nominal_fe_model

PTS = (3, 5, 6, 7, 9)  # outputs and the BCC's actuators 5, 7, 9
F = np.arange(20, 241) * 0.05
CHANGES = [("f", 0, None, 0.01), ("zeta", 2, None, -0.3), ("phi", 3, 1, 0.05), ("phi", 1, 4, -0.02),
           ("f", 5, None, -0.004)]


def _lab(closed: bool, dashpot: bool = False):
    fe = nominal_fe_model("bcc")
    design = nominal_design(fe, "mfdrf", 0) if closed else None
    st = LabState(fe.spec, fe, HardwareChain(noise_m_s=0.0), design,
                  dashpots=((3, 2.0),) if dashpot else ())
    fr, zeta, phi = natural_frequencies(st)
    pm = PointModes(2 * np.pi * fr, np.asarray(zeta, dtype=float), phi[fe.dofs.indices(PTS, "w"), :], PTS, "FE")
    return st, pm


@pytest.mark.parametrize("closed, dashpot", [(False, False), (True, False), (True, True)])
def test_the_changes_together_equal_each_change_predicted_on_its_own(closed, dashpot):
    st, pm = _lab(closed, dashpot)
    kw = {"excitation_point": 9, "output_points": (3, 6, 9)}
    h0, hs = changed_mode_frfs(st, pm, CHANGES, F, **kw)
    np.testing.assert_allclose(h0, predict_frf(replace(st, point_modes=pm), F, **kw), rtol=1e-10, atol=0)
    for c, h in zip(CHANGES, hs):
        one = predict_frf(replace(st, point_modes=moved_modes(pm, [c])), F, **kw)
        np.testing.assert_allclose(h, one, rtol=1e-9, atol=1e-15 * np.abs(one).max())


def test_moved_modes_scale_the_frequency_and_move_the_shape_by_the_reference_rms():
    _st, pm = _lab(False)
    ref = replace(pm, shapes=2.0 * pm.shapes)
    new = moved_modes(pm, [("f", 2, None, 0.1), ("f", 2, None, -0.05), ("phi", 1, 0, 0.5)], ref)
    assert new.omega[2] == pytest.approx(pm.omega[2] * np.exp(0.05), rel=1e-14)
    rms = np.sqrt(np.mean((2.0 * pm.shapes[:, 1]) ** 2))
    assert new.shapes[0, 1] == pytest.approx(pm.shapes[0, 1] + 0.5 * rms, rel=1e-14)
    assert pm.shapes[0, 1] != new.shapes[0, 1]  # a copy: the input is not changed
    with pytest.raises(ValueError, match="kind"):
        moved_modes(pm, [("mass", 0, None, 0.1)])


def _profile_problem():
    """Closed-loop FRFs of modes moved by a few of their standard uncertainties (frequencies, damping, a
    shape), against the lab's point modes with a model form of every in-band parameter."""
    st, pm = _lab(True)
    st = replace(st, point_modes=pm)
    true = moved_modes(pm, [("f", 2, None, 2.5e-3), ("zeta", 1, None, 0.1), ("phi", 3, 2, 0.03)])
    h = predict_frf(replace(st, point_modes=true), F, excitation_point=9, output_points=(3, 6))
    rng = np.random.default_rng(7)
    h = h * (1 + 1e-3 * (rng.standard_normal(h.shape) + 1j * rng.standard_normal(h.shape)))
    data = FrfData("moved.uff", "frf", F, h, (1e-3 * np.abs(h)) ** 2, 9, (3, 6))
    n = len(pm.omega)
    unc = ModelFormUncertainty(np.full(n, 1e-3), np.full(n, 0.05), {}, {})
    mf = frf_model_form(st, F, excitation_point=9, output_points=(3, 6), uncertainty=unc, modes=pm,
                        shape_rel=np.full(n, 0.01))
    return Problem(data, st, context_for(st, (1.0, 12.0), data), floor=0.0, model_form_frf=mf), st


def test_the_profile_with_the_batched_jacobian_finds_scipys_optimum(monkeypatch):
    problem, st = _profile_problem()
    r, x = nuisance.profile(problem, st, st.point_modes)
    least_squares = scipy.optimize.least_squares

    def finite_differences(fun, x0, jac=None, **kw):  # scipy's own '2-point' Jacobian instead
        return least_squares(fun, x0, diff_step=nuisance.DIFF_STEP, **kw)

    monkeypatch.setattr(nuisance.scipy.optimize, "least_squares", finite_differences)
    r_fd, x_fd = nuisance.profile(problem, st, st.point_modes)
    cost, cost_fd = r @ r + x @ x, r_fd @ r_fd + x_fd @ x_fd
    assert len(x) > 20  # frequencies, damping ratios and shapes of the in-band modes
    assert cost == pytest.approx(cost_fd, rel=1e-6)
    np.testing.assert_allclose(x, x_fd, atol=1e-2)


def test_reference_modes_moved_like_the_fe_modes():
    """With the nominal FE modes as the reference, the moved reference is the changed lab's FE modes themselves
    (in band, paired, signs aligned); a reference mode the FE model lacks keeps its values."""
    from vlab.diagnose.model.labmodel import point_modes_of
    from vlab.diagnose.model.modal_changes import MOVED_REFERENCE, moved_like

    st, _pm = _lab(False)
    from vlab.diagnose.effects.hypotheses import library
    from vlab.diagnose.problem.context import context_for as ctx_of

    data = FrfData("x.uff", "frf", F, np.ones((F.size, 1), dtype=complex), np.ones((F.size, 1)), 9, (6,))
    ctx = ctx_of(st, (1.0, 12.0), data)
    spring = next(h for h in library(st, ctx) if h.effect == "support_stiffness" and h.location.get("point") == 6)
    after_lab = spring.apply(st, np.array([20.0]), ctx)
    before = point_modes_of(st, PTS)
    after = point_modes_of(after_lab, PTS)
    moved = moved_like(before, before, after, top_hz=30.0)
    assert moved.source == MOVED_REFERENCE and len(moved.omega) == len(before.omega)
    inband = np.flatnonzero(before.omega <= 2 * np.pi * 30.0)
    assert np.max(np.abs(after.omega[inband] / before.omega[inband] - 1)) > 1e-3  # the spring moves them
    np.testing.assert_allclose(moved.omega[inband], after.omega[inband], rtol=1e-12)
    np.testing.assert_allclose(moved.zeta[inband], after.zeta[inband], rtol=1e-12)
    sign = np.sign(np.sum(moved.shapes[:, inband] * after.shapes[:, inband], axis=0))
    np.testing.assert_allclose(moved.shapes[:, inband], after.shapes[:, inband] * sign, atol=1e-12)
    # a second reference mode beside mode 3 (as a plant's second crosspiece arm): mode 3 pairs with its own
    # FE mode first (MAC 1), the extra one has no partner left
    extra = np.linalg.svd(before.shapes[:, inband])[0][:, -1]
    ref = replace(before, omega=np.append(before.omega, before.omega[2] * 0.99), zeta=np.append(before.zeta, 0.01),
                  shapes=np.column_stack([before.shapes, extra]))
    moved = moved_like(ref, before, after, top_hz=30.0)
    assert moved.omega[-1] == ref.omega[-1] and moved.zeta[-1] == 0.01
    np.testing.assert_array_equal(moved.shapes[:, -1], extra)


def test_changes_in_several_blocks_equal_each_change_predicted_on_its_own(monkeypatch):
    """More changes than one block holds (the block made 2 long): the same FRFs as each change alone."""
    from vlab.diagnose.model import modal_changes

    monkeypatch.setattr(modal_changes, "BLOCK", 2)
    st, pm = _lab(True)
    kw = {"excitation_point": 9, "output_points": (3, 6, 9)}
    _h0, hs = changed_mode_frfs(st, pm, CHANGES, F, **kw)
    assert hs.shape == (len(CHANGES), F.size, 3)
    for c, h in zip(CHANGES, hs):
        one = predict_frf(replace(st, point_modes=moved_modes(pm, [c])), F, **kw)
        np.testing.assert_allclose(h, one, rtol=1e-9, atol=1e-15 * np.abs(one).max())
    with pytest.raises(ValueError, match="point row"):
        moved_modes(pm, [("phi", 1, None, 0.1)])


def test_a_changed_structure_moves_the_reference_modes_from_the_lab_they_stand_for():
    """own_modes: with the nominal FE modes as the reference, a lab with a grounded spring moves them into its
    own FE modes (in band); with the model form anchored at that lab, its reference modes are moved by nothing.
    Both against point_modes_of of the spring's lab (the FE eigen solve), not against the moving code."""
    from vlab.diagnose.effects.hypotheses import library
    from vlab.diagnose.model.labmodel import point_modes_of
    from vlab.diagnose.problem.nuisance import own_modes

    st, _pm = _lab(False)
    h = predict_frf(st, F, excitation_point=9, output_points=(3, 6))
    data = FrfData("x.uff", "frf", F, h, (1e-3 * np.abs(h)) ** 2, 9, (3, 6))
    ctx = context_for(st, (1.0, 12.0), data)
    spring = next(h for h in library(st, ctx) if h.effect == "support_stiffness" and h.location.get("point") == 6)
    lab = spring.apply(st, np.array([20.0]), ctx)
    n = len(_pm.omega)
    unc = ModelFormUncertainty(np.full(n, 1e-3), np.full(n, 0.05), {}, {})
    mf = frf_model_form(st, F, excitation_point=9, output_points=(3, 6), uncertainty=unc)
    problem = Problem(data, st, ctx, floor=0.0, model_form_frf=mf)
    pm0, scale = own_modes(problem, lab)
    truth = point_modes_of(lab, mf.modes.points)
    inband = np.flatnonzero(truth.omega <= 2 * np.pi * F.max())
    assert np.max(np.abs(truth.omega[inband] / mf.modes.omega[inband] - 1)) > 1e-3
    np.testing.assert_allclose(pm0.omega[inband], truth.omega[inband], rtol=1e-10)
    # the scale carries what the moved modes leave out (modes above the band kept at the nominal lab's,
    # the changed structure's damping coupling): small on the lines
    assert np.median(np.abs(scale - 1)) < 1e-3 and np.max(np.abs(scale - 1)) < 0.02
    problem.model_form_frf = replace(mf, modes=truth, anchor=lab)
    pm1, _ = own_modes(problem, spring.apply(st, np.array([20.0]), ctx))  # the same lab, built again
    np.testing.assert_allclose(pm1.omega[inband], truth.omega[inband], rtol=1e-10)
