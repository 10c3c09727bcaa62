"""A structure of one's own through the robustness study and the detectability thresholds, in SI.

The beam of ``vlab init beam`` (a 400 mm aluminium strip, two voice coils) is studied with a few samples.
Numbers are checked against references computed here: the Wilson interval's closed form at zero events,
the damping change recomputed from the per-sample arrays, the closed-loop damping on the MuJoCo plant's
linearisation against the FE loop's (two independent plant constructions) and against the time
simulation (the loop's unstable pole against the self-excited line), and the SI performance index of
``vlab design`` against a Lyapunov equation solved here in SI with the unit factors written out.
"""

from __future__ import annotations

import json
import re

import numpy as np
import pytest
import scipy.linalg
from typer.testing import CliRunner

from vlab.cli import app

from _si_models import si_state_space

runner = CliRunner()
Z95 = 1.959963984540054   # two-sided 95 % normal quantile
IN_M = 0.0254             # 1 in [m]
LBF_N = 4.4482216152605   # 1 lbf [N]
CS_S = 0.01               # 1 cs [s]


def _invoke(*args):
    res = runner.invoke(app, [str(a) for a in args])
    assert res.exit_code == 0, (res.stdout, res.stderr)
    return res


@pytest.fixture(scope="module")
def beam(tmp_path_factory):
    path = tmp_path_factory.mktemp("own") / "beam.toml"
    _invoke("init", "beam", path)
    return path


def test_robustness_of_a_structure_file(beam, tmp_path):
    """`vlab robustness FILE` runs, says its estimate before the samples, writes SI-only sources, and its
    statistics are those of its own per-sample arrays."""
    out = tmp_path / "rob"
    res = _invoke("robustness", beam, "--samples", "4", "--chunk-size", "4", "--scheduler", "none",
                  "--controllers", "mfdrf,lqdrf", "--simulate", "0", "--simulate-random", "0", "--out", out)
    err = res.stderr
    assert err.index("estimate: about") < err.index("4 perturbed plants")
    assert "Clamped-free beam" in res.stdout and "Sec. 7" not in res.stdout
    data = json.loads((out / "robustness.json").read_text())
    assert data["structure_name"] == "beam" and data["dissertation_structure"] is False
    assert data["structure"] == str(beam)
    for u in data["uncertainties"]:
        assert not re.search(r"Table|Sec\.", u["source"]), u
    md = (out / "robustness.md").read_text()
    assert md.startswith("# Robustness of the controllers to modelling errors: Clamped-free beam")
    assert "Table 10" not in md and "thesis settings" not in md
    fe = data["per_plant"]["fe_sampled_loop"]
    npz = np.load(out / "samples.npz")
    for c in ("mfdrf", "lqdrf"):
        v = fe[c]
        assert v["probability_unstable"] == 0.0 and v["working_loop_at_nominal"] is True
        assert v["probability_unstable_ci95"] == pytest.approx([0.0, Z95 ** 2 / (4 + Z95 ** 2)], rel=1e-9)
        zeta = npz[f"{c}/damping_ratio"]
        nominal = np.array(data["per_controller"][c]["nominal_damping_ratio"])
        dz = np.median(np.abs(zeta / nominal - 1).mean(axis=1))
        assert v["damping_change_relative_median"] == pytest.approx(dz, rel=1e-12)


@pytest.fixture(scope="module")
def beam_study(beam):
    from vlab.robust.study import StudyConfig, nominal_analysis

    cfg = StudyConfig(structure=str(beam), n_samples=2, chunk_size=2, controllers=("mfdrf", "lqdrf-diag"))
    return cfg, nominal_analysis(cfg)


@pytest.mark.slow
def test_mujoco_damping_of_a_working_loop(beam_study):
    """MFDRF on the beam's MuJoCo plant: the unperturbed plant's closed-loop damping (its linearisation)
    equals the FE loop's within the two models' difference (modes 1-2 within 0.01 %, `vlab crosscheck`),
    a stable run has a stable linearised loop, and the MuJoCo damping change is recomputed here."""
    from vlab.robust.plants import mujoco_statistics
    from vlab.robust.simulate import simulate_samples

    cfg, nominal = beam_study
    ch = simulate_samples(cfg, nominal, "mfdrf", [0], worst=[False], random=[True], seed=1, resolution_hz=2.0,
                          records=3)
    assert not ch.unstable_on_plant[0] and not ch.nominal.unstable
    assert ch.linear_spectral_radius[0] < 1.0 and ch.nominal_linear_spectral_radius < 1.0
    assert ch.nominal_damping_ratio == pytest.approx(nominal.zeta["mfdrf"], rel=1e-3)
    st = mujoco_statistics(ch, seed=0, nominal_zeta=nominal.zeta["mfdrf"])
    dz = np.abs(ch.damping_ratio[0] / nominal.zeta["mfdrf"] - 1).mean()
    assert st["damping_change_relative_median"] == pytest.approx(dz, rel=1e-12)
    assert st["damping_samples"] == 1 and st["damping_modes_compared"] == [1, 2]
    assert st["linearised_unstable_random_samples"] == 0
    assert st["nominal_plant_damping_change_relative"] < 1e-3


@pytest.mark.slow
def test_mujoco_self_excitation_is_the_linearised_loops_unstable_pole(beam_study):
    """LQDRF-diag self-excites on the beam's MuJoCo plant (its mode 4 near 262 Hz keeps the hinge chain's
    own damping, 0.0036, against the FE model's 0.01): the time check's line is the frequency of the
    linearised loop's pole outside the unit circle, and no damping is reported for the run."""
    from vlab.robust.plant_loop import mujoco_modal_plant
    from vlab.robust.sampled_loop import sampled_loop
    from vlab.robust.simulate import simulate_samples
    from vlab.sim import build_plant

    cfg, nominal = beam_study
    ch = simulate_samples(cfg, nominal, "lqdrf-diag", [0], worst=[False], random=[True], seed=1,
                          resolution_hz=2.0, records=3)
    assert ch.nominal.unstable and ch.nominal_linear_spectral_radius > 1.0
    assert np.all(np.isnan(ch.nominal_damping_ratio))
    assert ch.unstable_on_plant[0] and ch.linear_spectral_radius[0] > 1.0 and np.all(np.isnan(ch.damping_ratio[0]))
    chain = nominal.chains["lqdrf-diag"]
    plant = mujoco_modal_plant(build_plant(nominal.spec), nominal.actuators, nominal.response_point)
    ones = np.ones(len(nominal.actuators))
    loop = sampled_loop(plant, nominal.designs["lqdrf-diag"], period_s=chain.period_s,
                        delay_periods=chain.delay_periods, filter_hz=chain.filter_hz, actuator_gain=ones,
                        sensor_gain=ones, excitation=nominal.excitation)
    z = loop.poles[np.abs(loop.poles) > 1.0]
    f_pole = np.abs(np.angle(z)) / (2 * np.pi * chain.period_s)
    assert np.min(np.abs(f_pole - ch.nominal.frequency_hz)) < 3.0


def test_detectability_of_a_structure_file_says_its_progress(beam):
    """`vlab detectability FILE`: an estimate after the first hypothesis and a line at the end of each loop."""
    res = _invoke("detectability", beam, "--effect", "added_mass", "--no-naming", "--model-form", "none")
    err = res.stderr
    assert re.search(r"estimate: about \S+ (s|min) for the detection thresholds \(the first of 9 took", err)
    assert "detection thresholds: 9 of 9 done" in err
    assert "added_mass" in res.stdout


def test_eta_lines():
    """The progress helper's estimate and time left, on a clock advanced by hand (3 s per item)."""
    from vlab.diagnose.detectability import Eta

    lines = []
    eta = Eta(lines.append, 10, "detection thresholds", "hypotheses")
    t = [0.0]
    eta._clock = lambda: t[0]
    eta.t0 = eta.last = 0.0
    for i in range(10):
        t[0] += 3.0
        eta.step(i, f"h{i}")
    assert lines[0] == "detection thresholds: 10 hypotheses"
    assert lines[1] == "estimate: about 30 s for the detection thresholds (the first of 10 took 3 s)"
    assert lines[2] == "detection thresholds: 5 of 10 done (h4), about 15 s left"  # 12 s after the first line
    assert lines[-1] == "detection thresholds: 10 of 10 done (h9), about 0 s left"


def _modal_ic_si(m, k, n_f, w_rows):
    """Initial states [0; phi_i], shape (2n, n_f): the first n_f modes with their largest |w| = 1 m, positive."""
    _, phi = scipy.linalg.eigh(k, m)
    x0 = np.zeros((2 * m.shape[0], n_f))
    for i in range(n_f):
        v = phi[:, i] / phi[w_rows[np.argmax(np.abs(phi[w_rows, i]))], i]
        x0[m.shape[0]:, i] = v / np.max(np.abs(v[w_rows]))
    return x0


def test_design_of_a_structure_file_prints_si(beam):
    """`vlab design FILE` prints gamma and D in N*s/m (D the JSON's SI gain) and J [s] for modal initial
    conditions of 1 m peak deflection, equal to the Lyapunov solution in SI computed here; no thesis unit."""
    from vlab.design import design_settings
    from vlab.fe import build_fe_model
    from vlab.spec import load_spec

    text = _invoke("design", beam).stdout
    assert "lb" not in text and "thesis" not in text and "(default for mfdrf)" in text
    out = json.loads(_invoke("design", beam, "--json").stdout)
    d = np.array(out["gain_n_s_per_m"])
    gamma = float(re.search(r"gamma = (\S+) N\*s/m", text).group(1))
    assert gamma == pytest.approx(np.abs(d).sum(axis=1).max(), rel=1e-3)
    printed = np.array([float(x) for x in re.findall(r"-?\d+\.\d*", text.split("m/s):")[1].split("closed")[0])])
    assert printed == pytest.approx(d.ravel(), abs=1e-4)
    fe = build_fe_model(load_spec(beam))
    dm, a, b, cv = si_state_space(fe)
    st = design_settings(fe.spec)
    s = np.array([IN_M if dof == "w" else 1.0 for _p, dof in dm.labels])
    sx = np.concatenate([s / CS_S, s])                       # SI value of one thesis state unit
    q_si = np.diag(st.q_scale / sx ** 2)
    r_si = st.r / LBF_N ** 2 * np.eye(b.shape[1])
    a_cl = a - b @ d @ cv
    q_cl = q_si + cv.T @ d.T @ r_si @ d @ cv
    p = scipy.linalg.solve_continuous_lyapunov(a_cl.T, -q_cl)
    # one step of iterative refinement: the SI system is ill-conditioned (cond(A_cl) ~ 7e10), and the first
    # solve leaves a relative residual near 1e-4
    p += scipy.linalg.solve_continuous_lyapunov(a_cl.T, -(a_cl.T @ p + p @ a_cl + q_cl))
    x0 = _modal_ic_si(dm.m, dm.k, st.n_f, np.array([i for i, (_p, dof) in enumerate(dm.labels) if dof == "w"]))
    j_si = np.einsum("ij,ik,kj->j", x0, p, x0)
    assert out["performance_index_si_1m_ic_s"] == pytest.approx(j_si, rel=1e-6)
    rows = re.findall(r"│\s+(\d)\s+│\s+\S+\s+│\s+\S+\s+│\s+(\S+)\s+│", text)
    assert [float(j) for _m, j in rows[:st.n_f]] == pytest.approx(j_si, rel=1e-3)


def test_period_source_names_the_thesis_only_for_its_structures():
    from vlab.experiment.config import dissertation_structure, period_source

    assert dissertation_structure("bcc") and dissertation_structure("grid")
    assert not dissertation_structure("beam") and not dissertation_structure("examples/beam.toml")
    assert period_source("lqg", 1e-3) == "thesis value for lqg (Sec. 5.3)"
    assert period_source("lqg", 1e-3, "grid") == "thesis value for lqg (Sec. 5.3)"
    assert period_source("lqg", 1e-3, "beam") == "default for lqg"
    assert period_source("none", 5e-4, "beam") == "default for the open loop"
    assert period_source("mfdrf", 1e-3, "beam") == "set by the user (default for mfdrf: 0.5 ms)"


@pytest.mark.long
def test_robustness_of_a_structure_file_end_to_end(beam, tmp_path):
    """`vlab robustness FILE --samples 20` with every default (four controllers, the MuJoCo check of the
    worst and of random samples, the limit cycle's sensitivity): every plant's damping change is reported
    for a controller that works there, and the linearised MuJoCo loop agrees with the time verdicts (measured:
    50 of 52 runs, the other two with a pole within 1e-4 of the unit circle)."""
    out = tmp_path / "rob"
    res = _invoke("robustness", beam, "--samples", "20", "--out", out)
    assert "estimate: about" in res.stderr
    data = json.loads((out / "robustness.json").read_text())
    for c, v in data["per_plant"]["mujoco_time_simulation"].items():
        if v["simulated_random_samples"] > v["unstable_random_samples"]:
            assert v["damping_change_relative_median"] is not None
            assert v["damping_change_relative_median_ci95"][0] <= v["damping_change_relative_median"]
    for ch in data["time_simulation_checks"]:
        rho = np.array([np.nan if r is None else r for r in ch["spectral_radius_linearised_mujoco"]])
        # a mode within 1e-3 of the unit circle (damping ratio ~1e-5) rings steadily under the noise: the time
        # check may call it self-excited
        agree = (rho >= 1.0) == np.array(ch["unstable_on_mujoco"])
        assert np.all(agree | (np.abs(rho - 1.0) < 1e-3)), ch["controller"]


def test_detectability_json_of_a_structure_file(beam, tmp_path):
    """`vlab detectability FILE --out` writes its JSON with the structure's name (keys with units)."""
    res = _invoke("detectability", beam, "--effect", "sensor_gain", "--no-naming", "--model-form", "none",
                  "--out", tmp_path / "det")
    data = json.loads((tmp_path / "det" / "detectability.json").read_text())
    assert data["structure"] == "beam" and data["noise_m_s"] == 1e-6
    assert {t["effect"] for t in data["thresholds"]} == {"sensor_gain"}
    assert "sensor_gain" in res.stdout


def test_a_study_with_its_own_spreads_says_so_in_its_title(beam, tmp_path):
    """A study run with ``--uncertainty`` is titled as such, so that its page is not taken for the default one."""
    spreads = tmp_path / "spreads.toml"
    spreads.write_text('[parameters.member_ei]\nspread = 0.1\nsource = "test: twice the default"\n')
    out = tmp_path / "rob"
    _invoke("robustness", beam, "--samples", "2", "--chunk-size", "2", "--scheduler", "none", "--controllers",
            "mfdrf", "--simulate", "0", "--simulate-random", "0", "--uncertainty", spreads, "--out", out)
    title = (out / "robustness.md").read_text().splitlines()[0]
    assert title.endswith("(the spreads of the command's --uncertainty file)"), title
    data = json.loads((out / "robustness.json").read_text())
    ei = next(u for u in data["uncertainties"] if "member_ei" in json.dumps(u))
    assert "twice the default" in json.dumps(ei)
