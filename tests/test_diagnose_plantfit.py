"""vlab.diagnose.fit.plantfit: a parameter refitted on another model's modes (the MuJoCo plant's linearisation)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from vlab.fe.damping import modal_damping_matrix, open_loop_ratios
from vlab.diagnose.data.measured import FrfData, refer_to_model
from vlab.diagnose.effects import specedit
from vlab.diagnose.effects.hypotheses import JointFlexibility, library
from vlab.diagnose.effects.hypothesis import Combination
from vlab.diagnose.fit.estimate import fit_hypothesis
from vlab.diagnose.fit.plantfit import map_on_plant, plant_modes, refit_index, refit_on_plant
from vlab.diagnose.model.labmodel import LabState, PointModes, natural_frequencies, plant_frf, predict_frf
from vlab.diagnose.problem.context import context_for
from vlab.diagnose.problem.residuals import Problem
from vlab.errors import ModelError
from vlab.fe import build_fe_model, modal_analysis
from vlab.experiment.config import TESTS
from vlab.lab.loop import HardwareChain
from vlab.models import nominal_fe_model

#: The "other model": the FE model with 2 % less mass everywhere (all frequencies 1 % higher).
MASS_FACTOR = 0.98


def other_model_modes(spec, points) -> PointModes:
    """Modes of a second model of ``spec`` whose frequencies are all 1 % above the FE model's. A changed
    structure keeps the unchanged one's damping matrix (that of the second model of the unchanged structure,
    built here from its own matrices): its ratios and the modes' coupling follow from it."""
    fe = build_fe_model(spec)
    md = modal_analysis(MASS_FACTOR * fe.m, fe.k)
    rows = fe.dofs.indices(list(points), "w")
    if spec.damping is None or spec.damping.basis is None:
        return PointModes(md.omega, open_loop_ratios(spec, len(md.omega)), md.shapes[rows, :], tuple(points), "test")
    base = build_fe_model(spec.damping.basis)
    assert base.dofs.labels == fe.dofs.labels
    c0 = modal_damping_matrix(MASS_FACTOR * base.m, base.k, open_loop_ratios(spec, base.n))
    cm = md.shapes.T @ c0 @ md.shapes
    zeta = np.diag(cm) / (2 * md.omega)
    np.fill_diagonal(cm, 0.0)
    return PointModes(md.omega, zeta, md.shapes[rows, :], tuple(points), "test", cm)


def _referred_problem(edit, name: str) -> Problem:
    """FRFs of the *other* model of the grid changed by ``edit`` (spec -> spec), 1 % noise, referred to the FE
    model through a baseline recording of the unchanged other model (as ``vlab diagnose --baseline`` does)."""
    fe = nominal_fe_model("grid")
    nominal = LabState(fe.spec, fe, HardwareChain(), None)
    truth = nominal.with_spec(edit(fe.spec))
    test = TESTS["grid"]
    exc = fe.spec.instrumentation.excitation
    outs = tuple(test.measured_points)
    pts = tuple(dict.fromkeys(outs + nominal.actuators))
    freq = np.arange(4, 201) * 0.05

    def recorded(st: LabState, source: str) -> FrfData:
        h = predict_frf(replace(st, point_modes=other_model_modes(st.spec, pts)), freq, excitation_point=exc,
                        output_points=outs)
        return FrfData(source, "frf", freq, h, (0.01 * np.abs(h)) ** 2, exc, outs)

    data = refer_to_model(recorded(truth, name), recorded(nominal, "baseline.uff"),
                          predict_frf(nominal, freq, excitation_point=exc, output_points=outs))
    return Problem(data, nominal, context_for(nominal, test.band_hz, data))


@pytest.fixture(scope="module")
def joint_on_other_model():
    """Joint 18 softened to 6000 N m/rad on the other model, referred to the FE model through a baseline."""
    return _referred_problem(lambda spec: specedit.soften_joint(spec, 18, 6000.0), "grid-joint18-other.uff")


def test_refit_on_the_other_model_recovers_the_drawn_stiffness(joint_on_other_model):
    """The baseline removes the other model's 1 % offset where the modes are, not where the joint moves two
    of them to: the FE fit absorbs what is left into the stiffness; the refit on that model's modes removes it."""
    problem = joint_on_other_model
    h = fit_hypothesis(JointFlexibility(point=18), problem)
    assert abs(h.params_[0] / 6000.0 - 1.0) > 0.02  # the FE value is biased (the test has something to fix)
    r = refit_on_plant(problem, h, modes_of=other_model_modes)
    assert r is not None and r.fe_value == h.params_[0]
    assert r.value == pytest.approx(6000.0, rel=0.005)
    assert r.chi2 < 0.01 * r.chi2_fe_value
    assert r.state.spec.sections != problem.base.spec.sections  # the lab to rerun carries the refitted joint
    assert r.params[0] == r.value


def test_refit_index_picks_the_one_mode_moving_parameter(joint_on_other_model):
    problem = joint_on_other_model
    pool = {h.label: h for h in library(problem.base, problem.ctx)}
    joint = pool["joint_flexibility(point=18)"]
    damping = next(h for lab, h in pool.items() if lab.startswith("damping(mode="))
    lag = next(h for lab, h in pool.items() if lab.startswith("actuator_lag"))
    assert refit_index(joint) == 0
    assert refit_index(damping) is None  # moves no mode
    assert refit_index(Combination(first=damping, second=joint)) == damping.n_params
    assert refit_index(Combination(first=joint, second=lag)) == 0  # the chain is in the MuJoCo rerun's loop
    dashpot = next(h for lab, h in pool.items() if lab.startswith("damping(point="))
    assert refit_index(Combination(first=dashpot, second=joint)) is None  # not spec-level: no MuJoCo rerun
    assert refit_index(Combination(first=joint, second=pool["joint_flexibility(point=9)"])) is None  # two movers


def test_with_spec_drops_the_other_models_modes(joint_on_other_model):
    base = joint_on_other_model.base
    st = replace(base, point_modes=other_model_modes(base.spec, base.actuators))
    assert st.with_spec(specedit.soften_joint(base.spec, 18, 6000.0)).point_modes is None


def test_mujoco_plant_modes_give_the_fe_receptance_between_resonances():
    """Mass-normalised MuJoCo shapes at the points: the receptance agrees with the FE model's within a few
    per cent away from the resonances (the two models' crosscheck, here through the FRF)."""
    pytest.importorskip("mujoco")
    fe = nominal_fe_model("bcc")
    st = LabState(fe.spec, fe, HardwareChain(), None)
    pts = st.actuators
    pm = plant_modes(fe.spec, pts)
    f, _, _ = natural_frequencies(st, 2)
    freq = np.array([0.5 * f[0], 0.5 * (f[0] + f[1])])
    a = plant_frf(st, freq, pts, pts)
    b = plant_frf(replace(st, point_modes=pm), freq, pts, pts)
    assert np.allclose(np.abs(b / a), 1.0, atol=0.03)
    with pytest.raises(Exception, match="not among the points"):
        plant_frf(replace(st, point_modes=pm), freq, (fe.spec.instrumentation.excitation, 999), pts)


# ---------------------------------------------------------------- the pair rule again on the plant


def _pair_and_singles(problem, second):
    """The joint alone, ``second`` alone and the pair, fitted on the FE model (the pair from the joint's value)."""
    from vlab.diagnose.fit.plantfit import PlantModel

    joint = fit_hypothesis(JointFlexibility(point=18), problem)
    other = fit_hypothesis(second, problem)
    starts = np.array([[joint.params_[0], x] for x in other.params_[0] * np.array([0.1, 0.3, 1.0, 3.0])])
    pair = fit_hypothesis(Combination(first=JointFlexibility(point=18), second=second), problem, starts=starts)
    return PlantModel(problem, modes_of=other_model_modes), pair, [pair, joint, other]


def test_a_second_effect_that_only_absorbs_the_model_difference_is_dropped_on_the_plant(joint_on_other_model):
    """On the FE model an added mass at 18 lowers the chi-square next to the biased joint (it absorbs part of
    the other model's offset); on the other model's modes the joint alone fits, and the pair is reduced to it."""
    from vlab.diagnose.effects.hypotheses import AddedMass
    from vlab.diagnose.fit.plantchoice import reduce_pair_on_plant

    problem = joint_on_other_model
    model, pair, ranked = _pair_and_singles(problem, AddedMass(point=18))
    assert pair.chi2_ < ranked[1].chi2_  # on the FE model the second effect helps
    chosen, refit, note = reduce_pair_on_plant(model, pair, ranked)
    assert chosen is ranked[1] and note is not None and "alone fits" in note
    assert refit.value == pytest.approx(6000.0, rel=0.005)


def test_a_real_second_effect_keeps_the_pair_on_the_plant():
    """Joint 18 and a real 0.5 kg mass at point 3, both in the other model's data: the pair stays."""
    from vlab.diagnose.effects.hypotheses import AddedMass
    from vlab.diagnose.fit.plantchoice import reduce_pair_on_plant

    problem = _referred_problem(lambda spec: specedit.add_mass(specedit.soften_joint(spec, 18, 6000.0), 3, 0.5),
                                "grid-joint18-mass3-other.uff")
    model, pair, ranked = _pair_and_singles(problem, AddedMass(point=3))
    chosen, refit, note = reduce_pair_on_plant(model, pair, ranked)
    assert chosen is pair and note is None
    assert refit is not None  # the part that explains more alone, refitted in the pair, then the other
    assert refit.params == pytest.approx([6000.0, 0.5], rel=0.02)
    assert refit.chi2 < 0.01 * refit.chi2_fe_value


def test_a_look_alike_that_fits_better_on_the_plant_is_chosen(joint_on_other_model):
    """A selected joint 19 with joint 18 as its look-alike: on the other model's modes joint 18 (the drawn one)
    fits far better, is chosen and refitted; joint 19, no longer a look-alike there, leaves the alternatives."""
    from vlab.diagnose.fit.plantchoice import choose_on_plant
    from vlab.diagnose.fit.plantfit import PlantModel

    problem = joint_on_other_model
    wrong = fit_hypothesis(JointFlexibility(point=19), problem)
    right = fit_hypothesis(JointFlexibility(point=18), problem)
    model = PlantModel(problem, modes_of=other_model_modes)
    chosen, refit, alts, note = choose_on_plant(model, wrong, [right])
    assert chosen is right and refit.value == pytest.approx(6000.0, rel=0.005)
    assert alts == [] and "joint_flexibility(point=18) is selected" in note
    same, refit2, alts2, note2 = choose_on_plant(model, right, [])  # nothing to compare: the refit alone
    assert same is right and note2 is None and refit2.value == pytest.approx(6000.0, rel=0.005)


def _mass(point: int, kg: float, chi2: float):
    from vlab.diagnose.effects.hypotheses import AddedMass

    h = AddedMass(point=point)
    h.params_, h.chi2_ = np.array([kg]), chi2
    return h


class _TablePlant:
    """A stand-in for :class:`PlantModel`: plant chi-squares from tables (at the FE value; refitted)."""

    def __init__(self, at_fe: dict, refitted: dict):
        from types import SimpleNamespace

        from vlab.diagnose.policy import DEFAULT_POLICY

        self.at_fe, self.refitted = at_fe, refitted
        self.problem = SimpleNamespace(policy=DEFAULT_POLICY)
        self.chain_refit = False

    def chi2(self, h, x) -> float:
        return self.at_fe[h.label]

    def refit(self, h, x0):
        from vlab.diagnose.fit.plantfit import PlantRefit, refit_index

        if refit_index(h, chain=self.chain_refit) is None:  # as PlantModel.refit: nothing to refit
            return None
        x = np.asarray(x0, dtype=float)
        return PlantRefit(h.param_names[0], float(x[0]), float(x[0]), x, None, self.at_fe[h.label],
                          self.refitted[h.label], 1, 0.0)


def _spring(point: int, n_per_m: float, chi2: float):
    from vlab.diagnose.effects.hypotheses import SupportStiffness

    h = SupportStiffness(point=point, dof="w")
    h.params_, h.chi2_ = np.array([n_per_m]), chi2
    return h


def test_fits_closer_than_the_fe_plant_difference_are_compared_on_the_plant():
    """The numbers of grid benchmark seed 1, case 2 (1.05 kg at point 20): the FE fit put the mass at 21
    (chi-square 765) before 20 (797), 32 apart, not a look-alike (dBIC >= 10). The chosen effect's own
    chi-square moves by 114 from the FE model to the plant, so 20 is compared there, where it fits better
    (603 refitted, against 641) and is chosen. A fit of another kind further than that difference (a spring
    at 16, 1166) is not compared, however well it would fit on the plant; with a small FE/plant difference 20
    is still compared, as the best fit of the chosen kind elsewhere (the next test)."""
    from vlab.diagnose.fit.plantchoice import choose_on_plant

    at21, at20, sp16 = _mass(21, 2.06, 765.0), _mass(20, 0.80, 797.0), _spring(16, 5.0, 1166.0)
    refitted = {at21.label: 641.0, at20.label: 603.0, sp16.label: 10.0}
    model = _TablePlant({at21.label: 651.0, at20.label: 631.0, sp16.label: 10.0}, refitted)
    chosen, refit, alts, note = choose_on_plant(model, at21, [], [at21, at20, sp16])
    assert chosen is at20 and refit.chi2 == 603.0
    assert "within 114" in note and sp16.label not in note
    assert alts == []  # 21 is 38 worse on the plant: not a look-alike there
    close = _TablePlant({at21.label: 760.0, at20.label: 631.0, sp16.label: 10.0}, refitted)
    same, _, alts2, note2 = choose_on_plant(close, at21, [], [at21, at20, sp16])
    # a small FE/plant difference on 21 (5): 20 is not within it, but the best of its kind elsewhere: compared
    assert same is at20 and "within 5" in note2 and sp16.label not in note2


def test_the_best_fits_of_the_same_kind_are_compared_on_the_plant_however_far_behind():
    """The numbers of tier-2 BCC benchmark seed 10808, case 9 (an 18.1 N/m spring at point 9): the FE fit put
    it at point 8 (chi-square 4340) before point 9 (4460), 120 apart; the chosen spring's own FE/plant
    difference was only 80, but at point 9 it was 1400: on the plant point 9 scores 3053 (3042 refitted,
    18.11 N/m) against point 8's 4420 (4402). The best fits of the chosen kind at other places are scored
    on the plant whatever their FE distance (up to SAME_KIND_COMPARED of them); a mass elsewhere is not."""
    from vlab.diagnose.fit.plantchoice import SAME_KIND_COMPARED, choose_on_plant

    at8, at9, at7, at6, at5 = (_spring(8, 14.36, 4340.0), _spring(9, 17.64, 4460.0), _spring(7, 11.6, 5613.0),
                               _spring(6, 10.7, 6298.0), _spring(5, 10.8, 7022.0))
    mass = _mass(2, 0.0055, 8600.0)
    at_fe = {at8.label: 4420.0, at9.label: 3053.0, at7.label: 5506.0, at6.label: 6298.0, at5.label: 1.0,
             mass.label: 1.0}
    refitted = {at8.label: 4402.0, at9.label: 3042.0, at7.label: 5400.0, at6.label: 6200.0, at5.label: 1.0,
                mass.label: 1.0}
    ranked = [at8, at9, at7, at6, at5, mass]
    chosen, refit, alts, note = choose_on_plant(_TablePlant(at_fe, refitted), at8, [], ranked)
    assert SAME_KIND_COMPARED == 3
    assert chosen is at9 and refit.chi2 == 3042.0 and alts == []
    assert "within 80" in note and at7.label in note and at6.label in note
    assert at5.label not in note and mass.label not in note  # beyond the three best of the kind; another kind


def test_refit_index_takes_a_single_chain_effect_only_with_chain():
    """With ``chain`` a single one-parameter effect of the hardware chain is refitted on the plant (index 0); a
    nonlinear one (saturation), a pair of chain effects and anything without ``chain`` keep their former
    answer: a mode-moving structural parameter only."""
    from vlab.diagnose.effects.hypotheses import (ActuatorGain, ActuatorLag, AddedMass, Combination, LoopDelay,
                                                  Saturation, SensorLag)
    from vlab.diagnose.fit.plantfit import refit_index

    for h in (LoopDelay(channel=7), ActuatorLag(channel="all"), SensorLag(channel=5), ActuatorGain(channel=9)):
        assert refit_index(h, chain=True) == 0 and refit_index(h) is None, h.label
    assert refit_index(Saturation(), chain=True) is None
    assert refit_index(Combination(first=LoopDelay(channel=7), second=ActuatorLag(channel=5)), chain=True) is None
    assert refit_index(AddedMass(point=3)) == 0 and refit_index(AddedMass(point=3), chain=True) == 0


def test_a_chain_effect_is_compared_on_the_plant_only_for_a_recording_the_plant_made():
    """A hidden 139.2 Hz actuator lag on channel 7 under LQDRF, recorded on the MuJoCo plant: on the FE model a
    delay of 1.81 ms on that channel fits (chi-square 72.5) better than the lag (94.6): the loop the data were
    referred through is the plant's, whose FRFs differ from the FE model's by tens of per cent at the peaks,
    and a delay's phase absorbs that second-order difference better than a lag's magnitude does. On the
    plant's linearisation the lag fits (0.46) and the delay does not (109): chosen there when the recording is
    the plant's own (``chain_refit``); otherwise a chain effect is not compared on the plant at all."""
    from vlab.diagnose.effects.hypotheses import ActuatorLag, LoopDelay
    from vlab.diagnose.fit.plantchoice import choose_on_plant

    delay, lag = LoopDelay(channel=7), ActuatorLag(channel=7)
    for h, x, chi2 in ((delay, 0.00181, 72.5), (lag, 139.9, 94.6)):
        h.params_, h.chi2_ = np.array([x]), chi2
    model = _TablePlant({delay.label: 109.4, lag.label: 0.5}, {delay.label: 109.1, lag.label: 0.46})
    chosen, refit, _alts, note = choose_on_plant(model, delay, [], [delay, lag])
    assert chosen is delay and refit is None and note is None
    model.chain_refit = True
    chosen, refit, alts, note = choose_on_plant(model, delay, [], [delay, lag])
    assert chosen is lag and refit.chi2 == 0.46 and alts == []
    assert "within 36.9" in note and f"{lag.label}: 0.46" in note


def test_plant_resolution_brings_the_grid_top_beam_mode_to_the_mujoco_plant():
    """The thesis mesh's grid mode 7 (top-beam bending) lies > 1 % above the MuJoCo plant's; two elements per
    top-beam segment (:func:`vlab.diagnose.model.nominal.plant_resolution`) bring it within 0.5 % (measured 0.41 %
    against the plant with two or more links per 0.37-0.75 m top-beam segment, 0.19 % against the former
    one-link plant).
    The BCC (no shear-flexible section) is returned as it is."""
    pytest.importorskip("mujoco")
    from vlab.diagnose.model.nominal import plant_resolution
    from vlab.spec import load_spec

    bcc = load_spec("bcc")
    assert plant_resolution(bcc) is bcc
    grid = load_spec("grid")
    fine = plant_resolution(grid)
    assert {m.id: m.elements_per_segment for m in fine.members if m.elements_per_segment > 1} == {"top_beam": 2}
    f_plant = plant_modes(grid, (17,)).omega[6]
    f_thesis, f_fine = (modal_analysis(fe.m, fe.k).omega[6] for fe in map(build_fe_model, (grid, fine)))
    assert f_thesis / f_plant - 1 > 0.01
    assert abs(f_fine / f_plant - 1) < 0.005


def _scaled_or_fail(model: float, x: float) -> float:
    """A job of map_on_plant: ``model * x``, a plant error for negative ``x``."""
    if x < 0:
        raise ModelError("no plant for a negative value")
    return model * x


def test_map_on_plant_keeps_the_order_in_processes_and_gives_none_for_a_plant_error():
    jobs = [(1.0,), (-1.0,), (3.0,)]
    assert map_on_plant(_scaled_or_fail, 2.0, jobs) == [2.0, None, 6.0]
    assert map_on_plant(_scaled_or_fail, 2.0, jobs, workers=1) == [2.0, None, 6.0]
    # a job that cannot be sent to a process (a local function) runs in this one
    assert map_on_plant(lambda m, x: m + x, 1.0, [(1.0,), (2.0,)]) == [2.0, 3.0]


def test_the_answer_is_the_refitted_value_with_the_fe_fit_beside_it():
    """``selected`` reports a refitted parameter at its refitted value, its interval scaled by refit / FE, and the
    FE fit as ``fe_fit``; the other part of a pair is reported as fitted."""
    from types import SimpleNamespace

    from vlab.diagnose.effects.hypotheses import AddedMass
    from vlab.diagnose.report.result import DiagnosisResult

    pair = Combination(first=JointFlexibility(point=18), second=AddedMass(point=3))
    pair.params_, pair.ci95_ = np.array([5000.0, 0.5]), np.array([[4000.0, 6000.0], [0.4, 0.6]])
    res = SimpleNamespace(selected=pair, plant_refit=SimpleNamespace(params=np.array([6000.0, 0.5])),
                          structure_fit=None)
    joint, mass = DiagnosisResult._selected_entries(res)
    name = JointFlexibility.param_names[0]
    assert joint["parameters"][name] == 6000.0 and joint["fe_fit"] == {name: 5000.0}
    assert joint["ci95"][name] == pytest.approx([4800.0, 7200.0])
    assert mass["parameters"] == {"mass_kg": 0.5} and "fe_fit" not in mass
    res.plant_refit = None
    joint, _ = DiagnosisResult._selected_entries(res)
    assert joint["parameters"][name] == 5000.0 and "fe_fit" not in joint


def test_a_recording_of_unknown_source_is_answered_on_the_structure_with_the_plant_value_in_its_interval():
    """With a fit on the structure's own model, ``selected`` reports its values, each interval widened to hold the
    plant's value (which is reported as ``plant_fit``), and no ``fe_fit``."""
    from types import SimpleNamespace

    from vlab.diagnose.effects.hypotheses import AddedMass
    from vlab.diagnose.fit.onstructure import StructureFit
    from vlab.diagnose.report.result import DiagnosisResult

    pair = Combination(first=JointFlexibility(point=18), second=AddedMass(point=3))
    pair.params_, pair.ci95_ = np.array([5000.0, 0.5]), np.array([[4000.0, 6000.0], [0.4, 0.6]])
    sf = StructureFit(np.array([5200.0, 0.45]), np.array([[5100.0, 5300.0], [0.44, 0.46]]), 10.0, "its replay", 0.1)
    res = SimpleNamespace(selected=pair, plant_refit=SimpleNamespace(params=np.array([6000.0, 0.5])),
                          structure_fit=sf)
    joint, mass = DiagnosisResult._selected_entries(res)
    name = JointFlexibility.param_names[0]
    assert joint["parameters"][name] == 5200.0 and joint["ci95"][name] == [5100.0, 6000.0]
    assert joint["plant_fit"] == {name: 6000.0} and "fe_fit" not in joint
    assert mass["parameters"] == {"mass_kg": 0.45} and mass["ci95"]["mass_kg"] == [0.44, 0.5]
    assert mass["plant_fit"] == {"mass_kg": 0.5}
    # the structure's model rejected by its own data (chi-square 10 beyond a limit of 5) where the plant's passes
    # (4 within 5): the plant's values, each interval widened to hold the structure's value
    bad = StructureFit(sf.params, sf.ci95, 10.0, "its replay", 0.1, chi2_limit=5.0)
    plant = SimpleNamespace(params=np.array([6000.0, 0.5]), chi2=4.0, plant_problem=SimpleNamespace(noise_chi2=lambda: 5.0))
    res = SimpleNamespace(selected=pair, plant_refit=plant, structure_fit=bad)
    joint, mass = DiagnosisResult._selected_entries(res)
    assert joint["parameters"][name] == 6000.0 and joint["ci95"][name] == [4800.0, 7200.0]  # FE's, scaled 6000/5000
    assert joint["structure_fit"] == {name: 5200.0} and "plant_fit" not in joint
    assert mass["parameters"] == {"mass_kg": 0.5} and mass["ci95"]["mass_kg"] == [0.4, 0.6]
    assert mass["structure_fit"] == {"mass_kg": 0.45}
    plant.chi2 = 6.0  # both rejected: the structure's model stands
    assert DiagnosisResult._selected_entries(res)[0]["parameters"][name] == 5200.0


def test_the_chosen_effect_is_refitted_on_the_plant_however_far_off_its_fe_value_lies_there():
    """Tier-3 seed 57057, case 20 (the bottom segment 8-9 stiffened): the FE fit's value put the chosen segment at
    a plant chi-square of 1.43e5, far behind other segments scored at their FE values; refitted on the plant
    it is the best (its plant value lies 19 % from its FE value). Scored only at its FE value it lost to a
    refitted neighbour. The chosen effect is refitted whatever its rank at the FE values."""
    from vlab.diagnose.fit.plantchoice import choose_on_plant
    from vlab.diagnose.effects.hypotheses import MemberStiffness

    def seg(lo, ei, chi2):
        h = MemberStiffness(member="beam", segment=(lo, lo + 1))
        h.params_, h.chi2_ = np.array([ei]), chi2
        return h

    s89, s12, s67 = seg(8, 57.65, 5000.0), seg(1, 28.0, 5200.0), seg(6, 30.0, 5300.0)
    at_fe = {s89.label: 1.428e5, s12.label: 2.2e4, s67.label: 1.65e4}
    refitted = {s89.label: 4845.0, s12.label: 2.08e4, s67.label: 1.6e4}
    chosen, refit, alts, note = choose_on_plant(_TablePlant(at_fe, refitted), s89, [s12, s67], [s89, s12, s67])
    assert chosen is s89 and refit.chi2 == 4845.0 and alts == []


def test_a_minimum_beyond_the_scan_edge_is_followed_to_within_a_step():
    """A parabola in ln p with its minimum at +0.31 (outside the +-0.12 scan): the scan point of least value
    is followed outward to the step nearest the minimum; within the parameter's range only; a minimum inside
    the scan is left where the scan found it."""
    from vlab.diagnose.fit.plantfit import _bracketed

    grid = np.array([-0.12, -0.06, 0.0, 0.06, 0.12])
    u = _bracketed(lambda x: (x - 0.31) ** 2, grid, 0.06, (-np.inf, np.inf))
    assert u == pytest.approx(0.30) and abs(u - 0.31) <= 0.03
    assert _bracketed(lambda x: (x - 0.31) ** 2, grid, 0.06, (-np.inf, 0.2)) == pytest.approx(0.18)
    assert _bracketed(lambda x: (x + 0.05) ** 2, grid, 0.06, (-np.inf, np.inf)) == pytest.approx(-0.06)


def test_a_plant_override_is_undone_where_the_structures_own_model_rejects_it(monkeypatch):
    """Rule 5 on a recording no vlab plant made: the plant's linearisation preferred a joint at 2 to the FE
    model's softer segment 1-2. Both fitted on the structure's own problem: the FE model's choice is restored
    only where it passes the mismatch test's total chi-square there and the plant's does not (the chi-squares
    and the limit 1.063e4 of the case that showed it); otherwise the plant's choice stands."""
    from types import SimpleNamespace

    import vlab.diagnose.pipeline as pipeline
    from vlab.diagnose.effects.hypotheses import MemberStiffness

    seg, joint = MemberStiffness(member="beam", segment=(1, 2)), JointFlexibility(point=2)
    seg.misfit_ = 0.01
    on_fe = SimpleNamespace(noise_chi2=lambda: 1.063e4)
    monkeypatch.setattr(pipeline, "threshold_of", lambda *a, **k: None)

    def run(chi2s: dict):
        monkeypatch.setattr(pipeline, "fit_hypothesis", lambda h, problem: SimpleNamespace(chi2_=chi2s[h.label]))
        res = SimpleNamespace(selected=joint, fe_choice=seg, loop="closed", alternatives=["x"], plant_refit="refit",
                              misfit_selected=0.5, nominal=None, threshold=None)
        notes = []
        pipeline._plant_override_on_structure(res, SimpleNamespace(ctx=None), on_fe, notes)
        return res, notes

    res, notes = run({joint.label: 5.606e6, seg.label: 5243.0})
    assert res.selected is seg and res.alternatives == [] and res.plant_refit is None and "restored" in notes[0]
    for chi2s in ({joint.label: 9000.0, seg.label: 5243.0}, {joint.label: 5.6e6, seg.label: 2e4}):
        res, notes = run(chi2s)
        assert res.selected is joint and notes == []
