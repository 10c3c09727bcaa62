"""Pairs of effects in vlab.diagnose.fit: forward selection alone keeps a wrong first effect; sequential
replacement (Miller 2002, Sec. 3.3) corrects it. Modal data of the linear BCC model, exact (no noise)."""

from __future__ import annotations

import pytest

from vlab.calibration import open_loop_ratios
from vlab.diagnose import specedit
from vlab.diagnose.data import read_modal_csv
from vlab.diagnose.fit import fit_hypothesis, fit_pairs
from vlab.diagnose.hypotheses import AddedMass, library
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
