"""The batched lab (vlab.lab.batch on mujoco.batch) against the single loop (run_loop on MujocoPlant).

The reference is the one-experiment path: :func:`vlab.lab.loop.run_loop` with
one ``MjData`` per run. Both loops run the chain of Fig. 21 with the same code
(:class:`vlab.lab.batch_chain.ChainRun`; the single loop with N = 1), so they
agree bit for bit: what is tested here is the vectorisation over N
simulations (per-simulation gains, chains, seeds, excitations and plant
parameters) and the batch plant (``mujoco.batch`` against ``MjData``). The
chain's arithmetic itself is checked against the block objects of
:mod:`vlab.lab.blocks` in tests/test_loop_reference.py.
"""

from __future__ import annotations

import copy
import dataclasses

import mujoco
import numpy as np
import pytest

from vlab.design import design_controller
from vlab.errors import ModelError
from vlab.lab.batch import run_batch
from vlab.lab.batch_chain import BatchChain
from vlab.lab.engine import ControllerEngine
from vlab.lab.loop import HardwareChain, run_loop
from vlab.models import nominal_fe_model
from vlab.reference import bcc_gain
from vlab.sim import MujocoPlant, SimOptions, build_plant
from vlab.sim.batch_plant import MujocoBatchPlant

ACTS = (5, 7, 9)
MEAS = (5, 7, 9, 6)
PERIOD = 0.5e-3


@pytest.fixture(scope="module")
def bcc():
    fe = nominal_fe_model("bcc")
    plant = build_plant(fe.spec)
    lqg = design_controller(fe, "lqg", period_s=PERIOD)
    return fe, plant, lqg


def _lqg(design):
    return ControllerEngine(design.f11, design.f12, design.f21, design.f22, period_s=PERIOD)


def _single(sim, engine, exc, seed, chain, duration):
    sim.reset()
    return run_loop(sim, engine, feedback_points=ACTS, measured_points=MEAS, excitation_point=9, excitation=exc,
                    duration_s=duration, chain=chain, seed=seed)


def _signals(res):
    return res.recording.as_array()


def _excitations(n_sim, n_ticks):
    return np.random.default_rng(11).standard_normal((n_sim, n_ticks))


def test_bit_identical_to_run_loop_without_rc_filter(bcc):
    """Same seed, same excitation, same gains: every sample equal, bit for bit.

    LQG (12 controller states) in one simulation and MFDRF in another is not
    possible in one batch (one controller size), so two batches: LQG with
    different seeds/excitations per simulation, and DRF gains that differ per
    simulation. Chain: integer delay (1 period), no RC filter, sensor noise
    and a sensor gain -- every vectorised block but the RC filter (the next
    test has it).
    """
    fe, plant, lqg = bcc
    sim = MujocoPlant(plant)
    chain = HardwareChain(delay_periods=1.0, filter_hz=None, noise_m_s=2e-5, sensor_gain={7: 1.05},
                          amplifier_limit_n=0.8)
    dur = 0.15
    n_ticks = int(round(dur / PERIOD))
    exc = _excitations(3, n_ticks)
    seeds = [4, 9, 4]
    bp = MujocoBatchPlant(sim, 3, nthread=2)
    rb = run_batch(bp, _lqg(lqg), feedback_points=ACTS, measured_points=MEAS, excitation_point=9, excitation=exc,
                   duration_s=dur, chain=chain, seeds=seeds)
    for i in range(3):
        ref = _single(sim, _lqg(lqg), exc[i], seeds[i], chain, dur)
        got = rb.result(i)
        assert np.array_equal(_signals(ref), _signals(got))
        assert np.array_equal(ref.commands, got.commands)
    gains = [bcc_gain("mfdrf"), bcc_gain("lqdrf"), 2.0 * bcc_gain("mfdrf")]
    engines = [ControllerEngine.from_gain(g, period_s=PERIOD) for g in gains]
    rb = run_batch(MujocoBatchPlant(sim, 3, nthread=1), engines, feedback_points=ACTS, measured_points=MEAS,
                   excitation_point=9, excitation=exc[0], duration_s=dur, chain=chain, seeds=7)
    for i, g in enumerate(gains):
        ref = _single(sim, ControllerEngine.from_gain(g, period_s=PERIOD), exc[0], 7, chain, dur)
        assert np.array_equal(_signals(ref), _signals(rb.result(i)))


def test_pc1000_chain_matches_run_loop_bit_for_bit(bcc):
    """The PC-1000 chain (1.35-period delay, 677 Hz RC filter): bit for bit, two simulations with their own seeds.

    (Until run_loop ran the shared chain, its RC filter recomputed the held
    pieces from absolute times and the two agreed to 1e-12 only; the blocks'
    version is now the reference of tests/test_loop_reference.py.)
    """
    fe, plant, lqg = bcc
    sim = MujocoPlant(plant)
    chain = HardwareChain(noise_m_s=1e-5)
    dur = 0.1
    exc = _excitations(2, int(round(dur / PERIOD)))
    rb = run_batch(MujocoBatchPlant(sim, 2, nthread=1), [_lqg(lqg), _lqg(lqg)], feedback_points=ACTS,
                   measured_points=MEAS, excitation_point=9, excitation=exc, duration_s=dur, chain=chain,
                   seeds=[1, 2])
    for i in range(2):
        ref = _signals(_single(sim, _lqg(lqg), exc[i], i + 1, chain, dur))
        got = _signals(rb.result(i))
        assert np.array_equal(got, ref)


@pytest.mark.parametrize("form", ["dense", "factored"])
def test_both_forms_of_the_modal_damping_match_run_loop_bit_for_bit(bcc, form, monkeypatch):
    """The applied modal damping in one product with -C_m (ModalDamping.dense, the BCC's) or in the factored
    form (a larger plant's, forced here on the BCC): the batch and run_loop give the same bits within a form,
    and the force equals -C_m qvel (the matrix formed in full) to rounding."""
    from vlab.sim.damping_matrix import ModalDamping

    fe, plant, _ = bcc
    if form == "factored":
        monkeypatch.setattr(ModalDamping, "dense", property(lambda self: None))
    sim = MujocoPlant(plant)
    md = sim.modal_damping
    assert (md.dense is not None) == (form == "dense")
    qvel = np.random.default_rng(3).standard_normal(md.A.shape[0])
    np.testing.assert_allclose(md.force(qvel), -md.matrix() @ qvel, rtol=0, atol=1e-12 * np.abs(md.force(qvel)).max())
    chain = HardwareChain(noise_m_s=1e-6)
    dur = 0.1
    exc = _excitations(2, int(round(dur / PERIOD)))
    engine = ControllerEngine.from_gain(bcc_gain("mfdrf"), period_s=PERIOD)
    rb = run_batch(MujocoBatchPlant(sim, 2, nthread=1), engine, feedback_points=ACTS, measured_points=MEAS,
                   excitation_point=9, excitation=exc, duration_s=dur, chain=chain, seeds=[1, 2])
    for i in range(2):
        assert np.array_equal(_signals(_single(sim, engine, exc[i], i + 1, chain, dur)), _signals(rb.result(i)))


def test_substeps_and_fractional_delay_match_run_loop():
    """Two physics steps per period (0.25 ms): the switch 0.35 T falls inside the first step; bit for bit."""
    fe = nominal_fe_model("bcc")
    plant = build_plant(fe.spec, SimOptions(timestep_s=0.25e-3))
    sim = MujocoPlant(plant)
    eng = ControllerEngine.from_gain(bcc_gain("lqdrf"), period_s=PERIOD)
    chain = HardwareChain(filter_hz=None)
    dur = 0.1
    exc = _excitations(1, int(round(dur / PERIOD)))
    rb = run_batch(MujocoBatchPlant(sim, 1, nthread=1), eng, feedback_points=ACTS, measured_points=MEAS,
                   excitation_point=9, excitation=exc, duration_s=dur, chain=chain)
    ref = _signals(_single(sim, eng, exc[0], 0, chain, dur))
    assert np.array_equal(_signals(rb.result(0)), ref)


def test_per_simulation_mass_equals_a_plant_with_that_mass(bcc):
    """``fields={'body_mass': ...}`` in one simulation = run_loop on a model with that mass (settled anew)."""
    fe, plant, _ = bcc
    m = plant.model
    coil = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "J5")
    masses = np.tile(m.body_mass, (2, 1))
    masses[1, coil] *= 1.3
    chain = HardwareChain(delay_periods=1.0, filter_hz=None)
    eng = ControllerEngine.from_gain(bcc_gain("mfdrf"), period_s=PERIOD)
    dur = 0.1
    exc = _excitations(1, int(round(dur / PERIOD)))[0]
    sim = MujocoPlant(plant)
    rb = run_batch(MujocoBatchPlant(sim, 2, nthread=1, fields={"body_mass": masses}), eng, feedback_points=ACTS,
                   measured_points=MEAS, excitation_point=9, excitation=exc, duration_s=dur, chain=chain)
    m2 = copy.deepcopy(m)
    m2.body_mass[coil] *= 1.3
    mujoco.mj_setConst(m2, mujoco.MjData(m2))
    ref_heavy = _signals(_single(MujocoPlant(m2), eng, exc, 0, chain, dur))
    ref_nominal = _signals(_single(sim, eng, exc, 0, chain, dur))
    assert np.array_equal(_signals(rb.result(0)), ref_nominal)
    assert np.array_equal(_signals(rb.result(1)), ref_heavy)
    assert not np.array_equal(ref_heavy, ref_nominal)


def test_diverging_simulation_stops_alone(bcc):
    """A destabilising gain (positive feedback) stops its simulation; the other runs on, unchanged."""
    fe, plant, _ = bcc
    sim = MujocoPlant(plant)
    good = ControllerEngine.from_gain(bcc_gain("mfdrf"), period_s=PERIOD)
    bad = ControllerEngine.from_gain(-400.0 * np.eye(3), period_s=PERIOD)
    chain = HardwareChain(delay_periods=1.0, filter_hz=None)
    dur = 2.0
    exc = np.zeros(int(round(dur / PERIOD)))
    exc[0] = 1.0
    rb = run_batch(MujocoBatchPlant(sim, 2, nthread=1), [bad, good], feedback_points=ACTS, measured_points=MEAS,
                   excitation_point=9, excitation=exc, duration_s=dur, chain=chain)
    assert 0 < rb.done[0] < exc.size and rb.done[1] == exc.size
    assert "diverged" in rb.failures[0] and 1 not in rb.failures
    ref = _signals(_single(sim, good, exc, 0, chain, dur))
    assert np.array_equal(_signals(rb.result(1)), ref)


def test_per_channel_chain_settings():
    """Dicts keyed by point id (the per-channel HardwareChain to come) give per-channel pieces and gains."""
    chain = dataclasses.replace(HardwareChain(), delay_periods={5: 1.15, 7: 2.5}, filter_hz={9: 300.0},
                                amplifier_limit_n={7: 2.0})
    hw = BatchChain.from_chains([chain, HardwareChain()], timestep_s=PERIOD, actuators=ACTS, feedback=ACTS,
                                n_sensors=4)
    # point 9 has no delay entry: 0 periods (the dict lists every delayed channel)
    np.testing.assert_array_equal(hw.delay_int, [[1, 2, 0], [1, 1, 1]])
    np.testing.assert_allclose(hw.d_old_s[0], PERIOD * np.array([[0.15, 0.5, 0.0], [0.35, 0.35, 0.35]]), rtol=1e-12)
    tau9 = 1 / (2 * np.pi * 300.0)
    np.testing.assert_allclose(hw.e_new[0, 0, 2], np.exp(-PERIOD / tau9), rtol=1e-14)
    assert hw.e_new[0, 0, 0] == 0.0  # channel 5: no filter entry -> unfiltered
    np.testing.assert_array_equal(hw.amp_limit_n, [[np.inf, 2.0, np.inf], [np.inf] * 3])


def test_bad_inputs(bcc):
    fe, plant, lqg = bcc
    sim = MujocoPlant(plant)
    bp = MujocoBatchPlant(sim, 2, nthread=1)
    kw = dict(feedback_points=ACTS, measured_points=MEAS, excitation_point=9, duration_s=0.01)
    with pytest.raises(ModelError, match="expected 2 controller engines"):
        run_batch(bp, [_lqg(lqg)], excitation=np.zeros(20), **kw)
    with pytest.raises(ModelError, match=r"excitation must have one value per tick.*\(3, 20\)"):
        run_batch(bp, None, excitation=np.zeros((3, 20)), **kw)
    with pytest.raises(ModelError, match="expected 2 seeds"):
        run_batch(bp, None, excitation=np.zeros(20), seeds=[1, 2, 3], **kw)
    with pytest.raises(ModelError, match="unknown MjModel field 'body_massx'"):
        MujocoBatchPlant(sim, 2, fields={"body_massx": np.zeros((2, 3))})
    with pytest.raises(ModelError, match=r"fields\['body_mass'\]: expected shape"):
        MujocoBatchPlant(sim, 2, fields={"body_mass": np.zeros((3, 3))})
    with pytest.raises(ModelError, match="n_sim must be a positive integer"):
        MujocoBatchPlant(sim, 0)


def test_displacements_sampled_as_run_loop(bcc):
    """``shape_points`` on a plant made with ``sample_sites``: the deformed shape equals run_loop's, bit for bit."""
    fe, plant, _ = bcc
    sim = MujocoPlant(plant)
    eng = ControllerEngine.from_gain(bcc_gain("mfdrf"), period_s=PERIOD)
    chain = HardwareChain(delay_periods=1.0, filter_hz=None)
    dur = 0.05
    exc = _excitations(1, int(round(dur / PERIOD)))[0]
    pts = (1, 3, 6, 8)
    rb = run_batch(MujocoBatchPlant(sim, 1, nthread=1, sample_sites=True), eng, feedback_points=ACTS,
                   measured_points=MEAS, excitation_point=9, excitation=exc, duration_s=dur, chain=chain,
                   shape_points=pts)
    sim.reset()
    ref = run_loop(sim, eng, feedback_points=ACTS, measured_points=MEAS, excitation_point=9, excitation=exc,
                   duration_s=dur, chain=chain, shape_points=pts)
    assert np.array_equal(rb.result(0).displacements, ref.displacements)
    assert np.abs(ref.displacements).max() > 0


def test_per_channel_hardware_chain_matches_run_loop(bcc):
    """HardwareChain's per-channel entries (a delay, a lag, a force limit on one coil channel, a lag on
    one sensor) are read by the batch as run_loop applies them: the same signals, bit for bit."""
    fe, plant, lqg = bcc
    sim = MujocoPlant(plant)
    chain = HardwareChain(channel_delay_periods={7: 2.85}, channel_actuator_lag_hz={5: 300.0},
                          channel_limit_n={9: 0.05}, channel_sensor_lag_hz={7: 400.0})
    dur = 0.1
    exc = 3.0 * _excitations(1, int(round(dur / PERIOD)))
    rb = run_batch(MujocoBatchPlant(sim, 1, nthread=1), [_lqg(lqg)], feedback_points=ACTS, measured_points=MEAS,
                   excitation_point=9, excitation=exc, duration_s=dur, chain=chain, seeds=[0])
    ref = _signals(_single(sim, _lqg(lqg), exc[0], 0, chain, dur))
    nominal = _signals(_single(sim, _lqg(lqg), exc[0], 0, HardwareChain(), dur))
    assert np.max(np.abs(ref - nominal)) > 1e-3 * np.max(np.abs(ref))  # the entries change the run
    assert np.array_equal(_signals(rb.result(0)), ref)
