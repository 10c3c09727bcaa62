"""The robustness study: sampled-data loop against independent references, draws, Dask, the command."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest

import vlab
from vlab.analysis import closed_loop_frf, closed_loop_modes, sampled_data_controller_frf, velocity_frf
from vlab.fe.damping import modal_damping_matrix, open_loop_ratios
from vlab.design import design_controller
from vlab.errors import DataFileError, OptionError
from vlab.fe import build_fe_model
from vlab.lab.engine import ControllerEngine
from vlab.lab.linear_plant import LinearPlant
from vlab.lab.loop import HardwareChain, run_loop
from vlab.models import nominal_fe_model
from vlab.reference import bcc_gain
from vlab.robust.sampled_loop import modal_plant, peak_windows, sampled_loop
from vlab.robust.study import StudyConfig, nominal_analysis, run_study, summarize
from vlab.robust.uncertainty import DEFAULTS, apply_sample, draw_sample, load_uncertainties

from _designs import bcc_design

ACTS = (5, 7, 9)


@pytest.fixture(scope="module")
def bcc():
    fe = nominal_fe_model("bcc")
    plant = modal_plant(fe.m, fe.k, open_loop_ratios(fe.spec, fe.n), fe.force_input(ACTS),
                        fe.force_input((6,))[:, 0])
    return fe, plant


@pytest.fixture(scope="module")
def lqg(bcc):
    return design_controller(bcc[0], "lqg")


def test_sampled_loop_frf_matches_the_frequency_domain_analysis(bcc, lqg):
    """Below 20 Hz the exact discrete loop equals the sampled-data FRF of vlab.analysis (ZOH, delay, RC) to 1e-3.

    The discrete FRF relates sampled response to sampled force, the force
    held over each period (as the lab's H1 sees it): the continuous analysis
    times the hold's ``(1 - exp(-j w T)) / (j w T)``. (Aliasing, which the
    analysis neglects, is below 1e-3 here.)
    """
    fe, plant = bcc
    ga, gs = np.array([1.04, 0.97, 1.02]), np.array([0.95, 1.03, 1.01])
    f = np.linspace(1.0, 20.0, 9)
    c = modal_damping_matrix(fe.m, fe.k, open_loop_ratios(fe.spec, fe.n))
    u = fe.force_input(ACTS)
    g = velocity_frf(fe.m, c, fe.k, u * ga, fe.force_input(ACTS + (6,)).T, f)
    g_fb, g_out = gs[None, :, None] * g[:, :3, :], g[:, 3:, :]
    for d in (lqg, bcc_design("mfdrf")):
        loop = sampled_loop(plant, d, period_s=d.period_s, delay_periods=1.2, filter_hz=677.0, actuator_gain=ga,
                            sensor_gain=gs, excitation=2)
        k = sampled_data_controller_frf(f, d.f11, d.f12, d.f21, d.f22, d.period_s, delay_periods=1.2,
                                        filter_hz=677.0)
        wt = 2 * np.pi * f * d.period_s
        ref = closed_loop_frf(g_fb, g_out, k, 2)[:, 0] * (1 - np.exp(-1j * wt)) / (1j * wt)
        np.testing.assert_allclose(loop.frf(f), ref, rtol=1e-3)


def test_sampled_loop_equals_time_simulation_of_the_linear_plant(bcc, lqg):
    """Iterating A_cl reproduces run_loop on the exactly stepped LinearPlant at every sample (no RC filter).

    With h = T/20 the DAC switch (0.35 T = 7 h) falls on a physics step, so
    the time simulation is exact too; both must agree to rounding. Covers the
    delay buffer, the fractional delay, channel gains and LQG's states.
    """
    fe, plant = bcc
    c = modal_damping_matrix(fe.m, fe.k, open_loop_ratios(fe.spec, fe.n))
    pidx = {p: fe.dofs.index(p, "w") for p in range(1, 10)}
    ga, gs = np.array([1.04, 0.97, 1.02]), np.array([0.95, 1.03, 1.01])
    d = lqg
    period = d.period_s
    lin = LinearPlant(fe.m, c, fe.k, point_index=pidx, actuator_points=ACTS, timestep_s=period / 20)
    chain = HardwareChain(period_s=period, delay_periods=1.35, filter_hz=None,
                          actuator_gain=dict(zip(ACTS, ga)), sensor_gain=dict(zip(ACTS, gs)))
    n = 300
    exc = np.random.default_rng(3).standard_normal(n)
    r = run_loop(lin, ControllerEngine(d.f11, d.f12, d.f21, d.f22, period_s=period), feedback_points=ACTS,
                 measured_points=(6,), excitation_point=9, excitation=exc, duration_s=n * period, chain=chain)
    loop = sampled_loop(plant, d, period_s=period, delay_periods=1.35, filter_hz=None, actuator_gain=ga,
                        sensor_gain=gs, excitation=2)
    x = np.zeros(loop.a_cl.shape[0])
    y = np.empty(n)
    for k in range(n):
        y[k] = loop.c_o @ x
        x = loop.a_cl @ x + loop.b_e * exc[k]
    ref = np.asarray(r.recording["vel6"])
    np.testing.assert_allclose(y, ref, atol=1e-9 * np.abs(ref).max())


def test_damping_tends_to_the_continuous_loop(bcc):
    """With a tiny period, no delay and no filter, the sampled loop's damping is the continuous loop's."""
    fe, plant = bcc
    d = bcc_gain("lqdrf")

    class Drf:
        f11 = -d
        f12, f21, f22 = np.zeros((3, 0)), np.zeros((0, 3)), np.zeros((0, 0))
        continuous = {"d": d}

    ones = np.ones(3)
    loop = sampled_loop(plant, Drf, period_s=1e-6, delay_periods=0.0, filter_hz=None, actuator_gain=ones,
                        sensor_gain=ones, excitation=2)
    from vlab.robust.sampled_loop import mode_damping

    zeta, _ = mode_damping(loop, plant, Drf, 6, actuator_gain=ones, sensor_gain=ones)
    _, z_c = closed_loop_modes(plant.m, plant.c, plant.k, plant.u, plant.u.T, {"d": d})
    np.testing.assert_allclose(zeta, z_c[:6], rtol=1e-3)


def test_unstable_gain_is_found_unstable(bcc):
    """Positive rate feedback (negative damping) makes the loop unstable: spectral radius > 1, J infinite."""
    fe, plant = bcc

    class Bad:
        f11 = 5.0 * np.eye(3)
        f12, f21, f22 = np.zeros((3, 0)), np.zeros((0, 3)), np.zeros((0, 0))

    ones = np.ones(3)
    loop = sampled_loop(plant, Bad, period_s=5e-4, delay_periods=1.35, filter_hz=677.0, actuator_gain=ones,
                        sensor_gain=ones, excitation=2)
    assert loop.spectral_radius > 1.0 and loop.energy_index(6) == np.inf


def test_peak_windows_stop_halfway_to_a_neighbour():
    lo, hi = peak_windows([10.0, 10.6, 20.0], 0.1)
    np.testing.assert_allclose(lo, [9.0, 10.3, 18.0])
    np.testing.assert_allclose(hi, [10.3, 11.66, 22.0])


def test_draws_are_reproducible_per_sample_and_change_the_model():
    spec = nominal_fe_model("bcc").spec
    a = draw_sample(spec, DEFAULTS, seed=5, index=17, n_act=3, nominal_delay_periods=1.35)
    b = draw_sample(spec, DEFAULTS, seed=5, index=17, n_act=3, nominal_delay_periods=1.35)
    c = draw_sample(spec, DEFAULTS, seed=6, index=17, n_act=3, nominal_delay_periods=1.35)
    assert a.factors == b.factors and a.delay_periods == b.delay_periods
    assert a.factors != c.factors
    assert set(a.factors) >= {"sections.steel_beam.ei", "strings.bottom_cables.tension", "masses.coil5.mass",
                              "crosspieces.crosspiece.tip_mass"}
    assert all(0.9 <= f <= 1.1 for f in a.factors.values()) and 1.15 <= a.delay_periods <= 1.55
    stiff = dataclass_replace_factors(a, {k: (1.1 if k.endswith(".ei") else 1.0) for k in a.factors})
    f0 = np.sqrt(np.sort(np.linalg.eigvals(np.linalg.solve(nominal_fe_model("bcc").m, nominal_fe_model("bcc").k)).real))
    fe1 = build_fe_model(apply_sample(spec, stiff))
    f1 = np.sqrt(np.sort(np.linalg.eigvals(np.linalg.solve(fe1.m, fe1.k)).real))
    assert np.all(f1[:6] > f0[:6])  # stiffer members: every low mode goes up


def dataclass_replace_factors(sample, factors):
    import dataclasses

    return dataclasses.replace(sample, factors=factors)


def test_uncertainty_toml(tmp_path):
    good = tmp_path / "u.toml"
    good.write_text('[parameters.member_ei]\nkind = "normal"\nspread = 0.02\nsource = "test"\n')
    u = {x.group: x for x in load_uncertainties(good)}
    assert (u["member_ei"].kind, u["member_ei"].spread, u["member_ei"].source) == ("normal", 0.02, "test")
    assert u["coil_mass"] == {x.group: x for x in DEFAULTS}["coil_mass"]
    bad = tmp_path / "bad.toml"
    bad.write_text('[parameters.member_eii]\nspread = 0.02\n')
    with pytest.raises(DataFileError, match=r"bad.toml: parameters.member_eii: unknown group"):
        load_uncertainties(bad)
    bad.write_text('[parameters.delay_samples]\nspread = -1\n')
    with pytest.raises(DataFileError, match=r"parameters.delay_samples.spread = -1"):
        load_uncertainties(bad)
    old_name = tmp_path / "old.toml"  # the delay group's former name is read as delay_periods
    old_name.write_text('[parameters.delay_samples]\nspread = 0.1\nsource = "old file"\n')
    assert {x.group: x for x in load_uncertainties(old_name)}["delay_periods"].spread == 0.1
    old_name.write_text('[parameters.delay_samples]\nspread = 0.1\n[parameters.delay_periods]\nspread = 0.1\n')
    with pytest.raises(DataFileError, match=r"parameters.delay_periods: group 'delay_periods' given twice"):
        load_uncertainties(old_name)
    with pytest.raises(OptionError, match="--samples must be a positive integer"):
        StudyConfig(n_samples=0)


@pytest.fixture(scope="module")
def small_study():
    cfg = StudyConfig(n_samples=4, chunk_size=2, controllers=("lqdrf-diag", "lqg"), seed=3)
    nominal = nominal_analysis(cfg)
    return cfg, nominal


#: The energy index's own round-off floor: the discrete Lyapunov equation of a loop whose spectral radius is
#: 0.998-0.9993 (2 kHz) turns a one-ulp change of A_cl into a change of J of up to 5.9e-9 (20 random one-ulp
#: perturbations of each of the eight loops of ``small_study``), so 1e-9 is below what a last-bit difference
#: upstream leaves; 1e-7 is twenty times the worst measured.
ENERGY_RTOL = 1e-7


def _same_arrays(got: dict, want: dict) -> None:
    assert got.keys() == want.keys()
    for k in want:
        rtol = ENERGY_RTOL if k.endswith("/energy_j_s") else 1e-9
        np.testing.assert_allclose(got[k], want[k], rtol=rtol, atol=0, err_msg=k)
    assert np.array_equal(got["index"], want["index"])


def test_dask_local_cluster_gives_the_in_process_results(small_study, monkeypatch):
    """Chunks on a 2-process LocalCluster, and on an existing scheduler by its tcp:// address: the same arrays.

    Both sides run with the BLAS threads of a Dask worker: its nanny starts the worker processes with
    ``OPENBLAS_NUM_THREADS=1`` (``distributed.nanny.pre-spawn-environ``), while this process has one thread
    per core unless the conftest set one for a pytest-xdist worker; threaded and single-threaded OpenBLAS
    sum in another order (here from about 90 rows; 8-digit differences have been seen on a machine with more
    cores). Within rtol 1e-9 (:data:`ENERGY_RTOL` for the ill-conditioned
    energy index), not bit for bit: the samples are the same draws, but another process may still differ in
    the last bits.
    """
    import dask
    from dask.distributed import LocalCluster
    from threadpoolctl import threadpool_limits

    cfg, nominal = small_study
    root = str(Path(vlab.__file__).resolve().parent.parent)
    monkeypatch.setenv("PYTHONPATH", root + os.pathsep + os.environ.get("PYTHONPATH", ""))
    spawn_env = dask.config.get("distributed.nanny.pre-spawn-environ", {})
    worker_threads = int(spawn_env.get("OPENBLAS_NUM_THREADS", os.environ.get("OPENBLAS_NUM_THREADS", 0)) or 0)
    with threadpool_limits(limits=worker_threads or None, user_api="blas"):
        _, local = run_study(cfg, nominal=nominal)
        _, dask_local = run_study(cfg, nominal=nominal, scheduler="local", n_workers=2)
        _same_arrays(dask_local, local)
        # an in-process cluster: its worker is a thread of this process, under the same limit
        with LocalCluster(n_workers=1, processes=False, protocol="tcp://", dashboard_address=None) as cluster:
            _, remote = run_study(cfg, nominal=nominal, scheduler=cluster.scheduler_address)
        _same_arrays(remote, local)
    with pytest.raises(OptionError, match="--scheduler 'udp://x'"):
        run_study(cfg, nominal=nominal, scheduler="udp://x")


def test_summary_and_time_simulation(small_study):
    """Nominal analysis equals the design's own damping; a perturbed sample, run in time on the batch, agrees."""
    cfg, nominal = small_study
    _, res = run_study(cfg, nominal=nominal)
    s = summarize(cfg, nominal, res)
    assert set(s.thesis_conclusion) == {"probability_unstable", "peak_ratio_error_db", "damping_change"}
    # the sampled loop at the thesis chain differs from the continuous design by the delay only: a few %
    np.testing.assert_allclose(nominal.zeta["lqdrf-diag"], nominal.designs["lqdrf-diag"].damping_ratios[:6],
                               rtol=0.05)
    from vlab.robust.simulate import simulate_samples

    chk = simulate_samples(cfg, nominal, "lqdrf-diag", [int(res["index"][0])], seed=1, resolution_hz=1.0,
                           records=3)
    assert not chk.diverged.any() and not chk.predicted_unstable.any() and not chk.unstable_on_plant.any()
    assert not chk.nominal.unstable  # LQDRF-diag works on the unperturbed MuJoCo plant
    r = chk.peak_sim_over_linear[np.isfinite(chk.peak_sim_over_linear)]
    assert r.size >= 3 and np.all(np.abs(np.log(r)) < 0.25)


@pytest.mark.slow
def test_command_writes_the_outputs(tmp_path):
    from typer.testing import CliRunner

    from vlab.cli import app

    out = tmp_path / "rob"
    md = tmp_path / "rob.md"
    res = CliRunner().invoke(app, ["robustness", "bcc", "--samples", "2", "--chunk-size", "1", "--scheduler",
                                   "none", "--simulate", "1", "--controllers", "lqdrf-diag,lqg", "--out", str(out),
                                   "--markdown", str(md)])
    assert res.exit_code == 0, res.output
    data = json.loads((out / "robustness.json").read_text())
    assert data["samples"] == 2 and set(data["per_controller"]) == {"lqdrf-diag", "lqg"}
    assert data["thesis_conclusion_sec7"]["probability_unstable"]["verdict"] == "undecided (all equal)"
    assert (out / "robustness.png").stat().st_size > 0 and md.read_text().startswith("# Robustness")
    assert set(np.load(out / "samples.npz").files) >= {"lqg/damping_ratio", "lqg/peak_level_m_per_n"}
    # the probabilities per plant: the FE loop over both samples, MuJoCo over the random ones (both, here)
    fe, mj = data["per_plant"]["fe_sampled_loop"]["lqg"], data["per_plant"]["mujoco_time_simulation"]["lqg"]
    assert fe["samples"] == 2 and fe["probability_unstable_ci95"][1] > 0
    assert mj["simulated_random_samples"] == 2 and mj["probability_unstable"] == 1.0
    assert (out / "worst_time_history.png").stat().st_size > 0 and (out / "worst.rrd").stat().st_size > 0
    res = CliRunner().invoke(app, ["robustness", "bcc", "--samples", "2", "--scheduler", "ftp://x",
                                   "--out", str(tmp_path / "x")])
    assert res.exit_code == 2 and "--scheduler" in res.output
    res = CliRunner().invoke(app, ["robustness", "bcc", "--controllers", "pid", "--out", str(tmp_path / "y")])
    assert res.exit_code == 2 and "--controllers pid" in res.output


def test_verdict_on_sec7_from_known_orderings():
    """Synthetic samples with a known ordering of errors give the expected verdicts."""
    from vlab.robust.study import Nominal

    ctl = ("mfdrf", "lqdrf", "lqdrf-diag", "lqg")
    cfg = StudyConfig(n_samples=50, controllers=ctl)
    n = 50
    ones = np.ones(2)
    nominal = Nominal({}, {}, {c: ones * 0.1 for c in ctl}, {c: ones for c in ctl}, {c: ones for c in ctl},
                      {c: 1.0 for c in ctl}, 2, ACTS, 2, 6, True)

    def res_for(db_error):
        rng = np.random.default_rng(0)
        out = {"index": np.arange(n)}
        for c in ctl:
            out[f"{c}/peaks"] = 10 ** (-(db_error[c] + 0.01 * rng.random((n, 2))) / 20)
            out[f"{c}/zeta"] = np.full((n, 2), 0.1)
            out[f"{c}/spectral_radius"] = np.full(n, 0.99)
            out[f"{c}/energy_j_s"] = np.ones(n)
        return out

    s = summarize(cfg, nominal, res_for({"mfdrf": 0.5, "lqdrf": 0.4, "lqdrf-diag": 0.2, "lqg": 1.0}))
    assert s.thesis_conclusion["peak_ratio_error_db"]["verdict"] == "holds"
    assert s.ranking["peak_ratio_error_db"] == ["lqdrf-diag", "lqdrf", "mfdrf", "lqg"]
    assert s.thesis_conclusion["damping_change"]["verdict"] == "undecided (all equal)"
    s = summarize(cfg, nominal, res_for({"mfdrf": 0.5, "lqdrf": 0.1, "lqdrf-diag": 0.2, "lqg": 1.0}))
    assert s.thesis_conclusion["peak_ratio_error_db"]["verdict"].startswith("partly: LQG is the least robust")
    lo, hi = s.per_controller["lqg"]["peak_ratio_error_db_median_ci95"]
    assert lo <= s.per_controller["lqg"]["peak_ratio_error_db_median"] <= hi


def test_samples_of_another_model_layout_run_in_their_own_batch(small_study, monkeypatch):
    """A perturbed plant of another discretisation (forced here: one BCC sample's beam gets 1 link a
    segment) runs in a batch of its own, and its run equals that plant's run alone (run_loop)."""
    import vlab.robust.simulate as simulate
    from vlab.sim import MujocoPlant, SimOptions

    cfg, nominal = small_study
    built = []
    original = simulate.build_plant

    def build(spec, options=None):
        if options is None:  # the nominal plant
            return original(spec)
        if not built:  # the first perturbed plant: another discretisation
            options = SimOptions(timestep_s=options.timestep_s, member_segments={"beam": 1})
        built.append(original(spec, options))
        return built[-1]

    monkeypatch.setattr(simulate, "build_plant", build)
    idx = [0, 1, 2]
    chk = simulate.simulate_samples(cfg, nominal, "lqdrf-diag", idx, seed=1, resolution_hz=2.0, records=2)
    assert chk.batches == 2 and not chk.diverged.any()
    assert built[0].model.nv != built[1].model.nv == built[2].model.nv
    s = draw_sample(nominal_fe_model(cfg.structure).spec, cfg.uncertainties, seed=cfg.seed, index=0, n_act=len(nominal.actuators),
                    nominal_delay_periods=nominal.chains["lqdrf-diag"].delay_periods)
    chain0, acts = nominal.chains["lqdrf-diag"], nominal.actuators
    design = nominal.designs["lqdrf-diag"]
    eng = ControllerEngine(design.f11, design.f12, design.f21, design.f22, period_s=chain0.period_s)
    chain = HardwareChain(period_s=chain0.period_s, delay_periods=s.delay_periods, filter_hz=chain0.filter_hz,
                          noise_m_s=simulate.CHECK_NOISE_M_S,
                          actuator_gain={p: float(g) for p, g in zip(acts, s.actuator_gain)},
                          sensor_gain={p: float(g) for p, g in zip(acts, s.sensor_gain)})
    rec = chk.recordings[0].recording
    meas = tuple(int(n[3:]) for n in rec.names if n.startswith("vel"))
    single = run_loop(MujocoPlant(built[0]), eng, feedback_points=acts, measured_points=meas,
                      excitation_point=acts[nominal.excitation], excitation=rec[f"force{acts[nominal.excitation]}"],
                      duration_s=rec.duration_s, chain=chain, seed=1 + 1 + idx[0])
    assert np.array_equal(single.recording.as_array(), rec.as_array())


def test_grid_samples_run_in_time():
    """The grid's perturbed plants keep its discretisation (no link count forced on its one-link top-beam
    segments: ``--simulate`` used to fail on every grid sample) and run in one batch."""
    from vlab.robust.simulate import simulate_samples

    cfg = StudyConfig(structure="grid", n_samples=2, seed=0, controllers=("lqdrf-diag",), uncertainties=DEFAULTS)
    nominal = nominal_analysis(cfg)
    chk = simulate_samples(cfg, nominal, "lqdrf-diag", [0, 1], seed=1, resolution_hz=2.0, records=2)
    assert chk.batches == 1 and not chk.diverged.any() and len(chk.recordings) == 2
