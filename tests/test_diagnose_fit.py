"""Pairs of effects in vlab.diagnose.fit: forward selection alone keeps a wrong first effect; sequential
replacement (Miller 2002, Sec. 3.3) corrects it. Modal data of the linear BCC model, exact (no noise)."""

from __future__ import annotations

import pytest

from vlab.calibration import open_loop_ratios
from vlab.diagnose import specedit
from vlab.diagnose.data import read_modal_csv
from vlab.diagnose.fit import fit_hypothesis, fit_pairs
from vlab.diagnose.hypotheses import AddedMass, JointFlexibility, library
from vlab.diagnose.labmodel import LabState
from vlab.diagnose.nominal import context_for
from vlab.diagnose.problem import Problem
from vlab.fe import build_fe_model, modal_analysis
from vlab.lab.experiment import TESTS
from vlab.lab.loop import HardwareChain
from vlab.models import nominal_fe_model


@pytest.fixture(scope="module")
def two_effects(tmp_path_factory):
    """0.5 kg at point 7 and a 150 N/m spring at point 8, seen in six modes with shapes."""
    fe = nominal_fe_model("bcc")
    truth = build_fe_model(specedit.add_spring(specedit.add_mass(fe.spec, 7, 0.5), 8, "w", 150.0))
    modes = modal_analysis(truth.m, truth.k, 6)
    zeta = open_loop_ratios(fe.spec, fe.n)[:6]
    pts = [p for p in sorted(fe.spec.points) if (p, "w") in truth.dofs]
    rows = [truth.dofs.index(p, "w") for p in pts]
    csv = tmp_path_factory.mktemp("pairs") / "modes.csv"
    lines = ["mode,frequency_hz,damping_ratio," + ",".join(f"phi_{p}" for p in pts)]
    for i in range(6):
        lines.append(f"{i + 1},{modes.frequencies_hz[i]:.8f},{zeta[i]},"
                     + ",".join(f"{modes.shapes[r, i]:.8f}" for r in rows))
    csv.write_text("\n".join(lines) + "\n")
    data = read_modal_csv(csv, fe.spec)
    nominal = LabState(fe.spec, fe, HardwareChain(), None)
    ctx = context_for(nominal, TESTS["bcc"].band_hz, data)
    problem = Problem(data, nominal, ctx)
    pool = library(nominal, ctx, effects=("added_mass", "support_stiffness"))
    wrong_first = fit_hypothesis(AddedMass(point=6), problem)  # a neighbour of the true mass point
    return problem, pool, wrong_first


def test_forward_selection_keeps_the_wrong_first_effect(two_effects):
    problem, pool, first = two_effects
    best = min(fit_pairs([first], problem, pool, rounds=0), key=lambda c: c.bic_)
    assert best.parts[0].label == first.label
    assert best.chi2_ > 1.0


def test_sequential_replacement_finds_both_effects(two_effects):
    problem, pool, first = two_effects
    best = min(fit_pairs([first], problem, pool), key=lambda c: c.bic_)
    found = {h.label: x for h, x in zip(best.parts, (best.params_[:1], best.params_[1:]))}
    assert set(found) == {"added_mass(point=7)", "support_stiffness(point=8, dof=w)"}
    assert found["added_mass(point=7)"][0] == pytest.approx(0.5, rel=1e-3)
    assert found["support_stiffness(point=8, dof=w)"][0] == pytest.approx(150.0, rel=1e-3)


# ---------------------------------------------------------------- coarse scan of a mode-moving effect


@pytest.fixture(scope="module")
def softened_grid_joint():
    """FRFs of the linear grid with the joint at point 18 (top beam / bar 18-2) softened to 6000 N m/rad:
    two top-beam modes fall into the band, between the hypothesis's own trial values (0.3, 1, 3, ... x k_ref)."""
    import numpy as np

    from vlab.diagnose.data import FrfData
    from vlab.diagnose.labmodel import predict_frf

    fe = nominal_fe_model("grid")
    nominal = LabState(fe.spec, fe, HardwareChain(), None)
    truth = nominal.with_spec(specedit.soften_joint(fe.spec, 18, 6000.0))
    test = TESTS["grid"]
    freq = np.arange(4, 201) * 0.05
    exc = fe.spec.instrumentation.excitation
    outs = tuple(test.measured_points)
    h = predict_frf(truth, freq, excitation_point=exc, output_points=outs)
    data = FrfData("grid-joint18.uff", "frf", freq, h, (0.01 * np.abs(h)) ** 2, exc, outs)
    ctx = context_for(nominal, test.band_hz, data)
    return Problem(data, nominal, ctx), JointFlexibility


def test_coarse_scan_finds_the_narrow_chi2_well(softened_grid_joint):
    """The chi-square well is ~ +-12 % wide in k: a local fit from the trial values alone misses it."""
    problem, cls = softened_grid_joint
    h = fit_hypothesis(cls(point=18), problem)
    assert h.params_[0] == pytest.approx(6000.0, rel=0.01)
    trials, _, _ = cls(point=18).space(problem.base, problem.ctx)
    old = fit_hypothesis(cls(point=18), problem, starts=trials)  # the trial values only, as before the scan
    assert old.chi2_ > 100 * h.chi2_
