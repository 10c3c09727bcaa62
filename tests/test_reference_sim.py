"""The independent reference simulator (benchmarks/reference_sim) against vlab and itself.

The simulator never imports vlab; this test does, to compare: natural frequencies and
mode shapes with ``vlab.modes("bcc")``, the sign of the DRF gain with a vlab design's
closed-loop damping. The loop is checked against an exact sampled-data frequency
response computed here by another route (matrix exponentials of the real state
space, not the simulator's eigen-coordinates).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import scipy.linalg

from benchmarks.reference_sim.acquisition import Frontend, input_range, quantise
from benchmarks.reference_sim.cases import Case, CaseError, apply_effects
from benchmarks.reference_sim.fe import assemble, modes
from benchmarks.reference_sim.loop import Controller, split_delay
from benchmarks.reference_sim.params import load_bcc
from benchmarks.reference_sim.plant import build_plant, modal_damping_matrix
from benchmarks.reference_sim.run import Settings, simulate
from benchmarks.reference_sim.uff58 import Channel, write_uff58

FREQ_TOL = 0.003
"""Stated discretisation difference on modes 1-6 (own mesh 4 elements per segment,
6 per arm, arm torsional inertia; vlab: 1 element per segment, single-DOF crosspiece)."""


@pytest.fixture(scope="module")
def params():
    return load_bcc()


@pytest.fixture(scope="module")
def vlab_modes():
    vlab = pytest.importorskip("vlab")
    from vlab.models import build_fe_model

    freq, shapes = vlab.modes("bcc", 8)
    labels = build_fe_model(vlab.load_spec("bcc")).dofs.labels
    rows = [labels.index((q, "w")) for q in range(1, 10)]
    return freq, shapes[rows]


def _mac(a, b):
    return np.abs(np.sum(a * b, 0)) ** 2 / np.sum(a * a, 0) / np.sum(b * b, 0)


def test_frequencies_and_shapes_agree_with_vlab(params, vlab_modes):
    fv, sv = vlab_modes
    model = assemble(params)
    f, phi = modes(model, 8)
    rows = [model.index(q, "w") for q in range(1, 10)]
    err = f[:6] / fv[:6] - 1
    assert np.all(np.abs(err) < FREQ_TOL), err
    assert np.all(_mac(phi[rows, :6], sv[:, :6]) > 0.999)
    act = [q - 1 for q in params.actuators]
    scale = np.sign(np.sum(phi[rows, :6] * sv[:, :6], 0))
    amp = phi[rows][act, :6] * scale / sv[act, :6]
    big = np.abs(sv[act, :6]) > 0.2 * np.abs(sv[:, :6]).max(0)
    assert np.all(np.abs(amp[big] - 1) < 0.01), amp


def test_difference_is_the_mesh_and_the_arm_inertia(params, vlab_modes):
    fv, _ = vlab_modes
    coarse = dataclasses.replace(params, arm_width_m=0.0, arm_thickness_m=0.0)
    f, _ = modes(assemble(coarse, elements_per_segment=1, arm_elements=1), 6)
    assert np.all(np.abs(f / fv[:6] - 1) < 5e-4)
    f2, _ = modes(assemble(params, elements_per_segment=8, arm_elements=12), 6)
    f4, _ = modes(assemble(params), 6)
    assert np.all(np.abs(f4 / f2 - 1) < 2e-4)


def test_added_mass_and_effects(params):
    f0, _ = modes(assemble(params), 6)
    ap = apply_effects(params, [{"type": "added_mass", "point": 6, "mass_kg": 0.12},
                                {"type": "actuator_gain", "point": 7, "factor": 0.9},
                                {"type": "loop_delay", "delay_periods": 2.0}])
    changed = assemble(ap.params)
    f1, _ = modes(changed, 6)
    assert f1[0] < f0[0]  # mode 2 rises: the mass also stiffens the beam above it by its weight
    top0 = assemble(params).top_tension_n
    assert changed.top_tension_n - top0 == pytest.approx(0.12 * params.gravity_m_s2)
    assert ap.amp_gains == (1.0, 0.9, 1.0) and ap.delay_periods == 2.0
    with pytest.raises(CaseError):
        apply_effects(params, [{"type": "added_mass", "point": 42, "mass_kg": 0.1}])
    assert split_delay(1.35) == (1, pytest.approx(0.35))


def test_drf_sign_gives_the_designs_damping(params, tmp_path):
    pytest.importorskip("vlab")
    import json

    from _designs import bcc_design

    design = bcc_design("mfdrf")  # = vlab.design("bcc", "mfdrf"), shared with other test files
    gain = np.asarray(design.gain, float)
    target = np.asarray(design.damping_ratios)[:6]
    path = tmp_path / "d.json"
    path.write_text(json.dumps({"period_s": 0.0005, "gain_n_s_per_m": gain.tolist()}))
    ctrl = Controller.from_design_json(path)
    assert np.allclose(ctrl.f11, np.asarray(design.f11))
    model = assemble(params)
    c = modal_damping_matrix(model, params.damping_ratios, params.default_damping_ratio)
    b = np.zeros((len(model.labels), 3))
    for j, q in enumerate(params.actuators):
        b[model.index(q, "w"), j] = 1.0
    n = len(model.labels)
    a = np.block([[np.zeros((n, n)), np.eye(n)],
                  [-np.linalg.solve(model.m, model.k), -np.linalg.solve(model.m, c - b @ ctrl.f11 @ b.T)]])
    lam = np.linalg.eigvals(a)
    lam = lam[lam.imag > 0]
    lam = lam[np.argsort(np.abs(lam))][:6]
    zeta = -lam.real / np.abs(lam)
    assert np.allclose(zeta, target, rtol=0.02)


def _sampled_frf(plant, ctrl, delay, freqs_hz, out_row):
    """Exact sampled-data FRF excitation -> output at t_k, by matrix exponentials."""
    a, b = plant.a, plant.b
    nx, nu = b.shape
    dt = ctrl.period_s
    m, f = split_delay(delay)

    def gamma(tau):
        big = np.zeros((nx + nu, nx + nu))
        big[:nx, :nx], big[:nx, nx:] = a * tau, b * tau
        e = scipy.linalg.expm(big)
        return e[:nx, :nx], e[:nx, nx:]

    phi, g_full = gamma(dt)
    phi_late, g_late = gamma((1 - f) * dt)
    _, g_early = gamma(f * dt)
    n_act = ctrl.f11.shape[0]
    g1, g2, ge = phi_late @ g_early[:, :n_act], g_late[:, :n_act], g_full[:, n_act]
    cs = plant.c[:n_act]
    out = []
    for fr in freqs_hz:
        z = np.exp(2j * np.pi * fr * dt)
        loop = (g1 * z ** (-m - 1) + g2 * z ** (-m)) @ ctrl.f11 @ cs
        x = np.linalg.solve(z * np.eye(nx) - phi - loop, ge)
        out.append(plant.c[out_row] @ x)
    return np.array(out)


@pytest.mark.parametrize("dynamic", [False, True])
def test_loop_matches_an_exact_sampled_data_frf(params, dynamic):
    gain = np.array([[8.6, 0.0, 0.05], [0.0, 6.2, -2.5], [0.05, -2.5, 3.9]])
    static = Controller(-gain, np.zeros((3, 0)), np.zeros((0, 3)), np.zeros((0, 0)), 0.0005)
    # the dynamic form x+ = -gain y, u = x is the static DRF one period later
    ctrl = Controller(np.zeros((3, 3)), np.eye(3), -gain, np.zeros((3, 3)), 0.0005) if dynamic else static
    exc = {"kind": "multisine", "rms_n": 0.5, "band_hz": [1.0, 25.0], "period_s": 2.0,
           "periods": 1, "settle_periods": 3}
    quiet = Settings(elements_per_segment=2, arm_elements=2,
                     frontend=Frontend(velocity_noise=0.0, force_noise=0.0))
    res = simulate(Case(controller="test", excitation=exc, seed=3), ctrl, params, quiet)
    v6, f9 = res["compat"]["vel6"][2], res["compat"]["force9"][2]
    spec_v, spec_f = np.fft.rfft(v6), np.fft.rfft(f9)
    lines = np.flatnonzero(np.abs(spec_f) > 1e-3 * np.abs(spec_f).max())
    h_sim = spec_v[lines] / spec_f[lines]
    model = assemble(params, elements_per_segment=2, arm_elements=2)
    c = modal_damping_matrix(model, params.damping_ratios, params.default_damping_ratio)
    plant = build_plant(model, c, params.actuators, params.excitation,
                        [(q, "vel") for q in params.actuators] + [(6, "vel")])
    h_ref = _sampled_frf(plant, static, 2.35 if dynamic else 1.35, lines / 2.0, 3)
    assert np.max(np.abs(h_sim / h_ref - 1)) < 1e-3


def test_uff58_reads_back_with_pyuff(tmp_path):
    pyuff = pytest.importorskip("pyuff")
    data = np.sin(np.arange(10) * 0.3)
    write_uff58(tmp_path / "r.uff", [Channel("9+Z", 9, "Z", "acceleration", 2e-4, data, "acc"),
                                     Channel("9+Z", 9, "Z", "force", 2e-4, 2 * data, "force")])
    sets = pyuff.UFF(str(tmp_path / "r.uff")).read_sets()
    assert [s["ordinate_spec_data_type"] for s in sets] == [12, 13]
    assert sets[0]["rsp_node"] == 9 and sets[0]["rsp_dir"] == 3
    assert sets[0]["ordinate_axis_units_lab"].strip() == "m/s^2"
    assert np.allclose(sets[1]["data"], 2 * data, rtol=1e-11)
    assert sets[0]["abscissa_inc"] == pytest.approx(2e-4)


def test_quantiser_range_and_step():
    x = np.array([0.3, -0.7, 0.01])
    full = input_range(x)
    assert full == 1.0
    q = quantise(x, full, 16)
    assert np.max(np.abs(q - x)) <= full / 2**16


def test_lab_accelerations_agree_with_the_controller_rate_velocities(params):
    exc = {"kind": "multisine", "rms_n": 0.5, "band_hz": [1.0, 25.0], "period_s": 1.0,
           "periods": 1, "settle_periods": 1}
    quiet = Settings(elements_per_segment=2, arm_elements=2,
                     frontend=Frontend(velocity_noise=0.0, force_noise=0.0, accel_noise=0.0))
    res = simulate(Case(excitation=exc, seed=5, mode="both"), Controller.zero(3), params, quiet)
    assert res["dt_s"]["lab"] == pytest.approx(2e-4) and len(res["lab"]) == 10
    acc, f_lab = res["lab"]["acc6"][2], res["lab"]["force9"][2]
    step = 2 * res["ranges"]["acc6"] / 2**16
    assert np.allclose(acc / step, np.round(acc / step))
    vel, f_c = res["compat"]["vel6"][2], res["compat"]["force9"][2]
    lines = np.arange(1, 26)
    h_lab = np.fft.rfft(acc)[lines] / np.fft.rfft(f_lab)[lines]
    h_vel = np.fft.rfft(vel)[lines] / np.fft.rfft(f_c)[lines]
    w = 2 * np.pi * lines
    zoh = np.exp(-0.5j * w * 5e-4) * np.sinc(lines * 5e-4)
    assert np.max(np.abs(h_lab / (1j * w) * zoh / h_vel - 1)) < 0.005


def test_case_files_are_checked(tmp_path):
    from benchmarks.reference_sim.__main__ import main
    from benchmarks.reference_sim.cases import load_case

    good = tmp_path / "c.json"
    good.write_text('{"controller": "none", "effects": [{"type": "support_spring", "point": 7, '
                    '"dof": "w", "stiffness": 100.0}], "excitation": {"period_s": 2}}')
    case = load_case(good)
    assert case.effects[0]["stiffness"] == 100.0 and case.excitation["period_s"] == 2
    bad = tmp_path / "b.json"
    bad.write_text('{"controller": "none", "effects": [{"type": "added_mass", "point": 6}]}')
    with pytest.raises(CaseError, match="mass_kg"):
        load_case(bad)
    bad.write_text('{"controler": "none"}')
    with pytest.raises(CaseError, match="controler"):
        load_case(bad)
    assert main(["--case", str(bad), "--out", str(tmp_path / "o")]) == 2


def test_tier3_scoring():
    from benchmarks.reference_sim.tier3 import draw_effect, score

    sel = {"mismatch": True, "selected": [{"effect": "added_mass", "location": {"point": 6},
                                           "parameters": {"mass_kg": 0.134}, "ci95": {"mass_kg": [0.133, 0.135]}}]}
    res = score(("added_mass", {"point": 6}, "mass_kg", 0.12), sel)
    assert res["right"] and res["in_ci"] is False and res["error"] == pytest.approx(0.134 / 0.12 - 1)
    assert not score(("added_mass", {"point": 5}, "mass_kg", 0.12), sel)["right"]
    assert not score(None, sel)["right"] and score(None, {"mismatch": False, "selected": []})["right"]
    rng = np.random.default_rng(0)
    drawn = [draw_effect(rng, 26.0, 5e-4) for _ in range(40)]
    assert any(e is None for e, _ in drawn) and any(e is not None for e, _ in drawn)


def test_the_excitation_channel_gain_scales_the_excitation(params):
    """The excitation enters at the amplifier input (Sec. 5.3): the gain of the coil at the excitation
    point scales it as it scales that coil's control force; the other coils' gains do not."""
    model = assemble(params, elements_per_segment=1, arm_elements=1)
    c = modal_damping_matrix(model, params.damping_ratios, params.default_damping_ratio)
    out = [(6, "vel")]
    ref = build_plant(model, c, params.actuators, params.excitation, out)
    k = list(params.actuators).index(params.excitation)
    gains = [1.0] * len(params.actuators)
    gains[k] = 0.8
    at_exc = build_plant(model, c, params.actuators, params.excitation, out, amp_gains=gains)
    np.testing.assert_allclose(at_exc.b[:, -1], 0.8 * ref.b[:, -1])
    other = [0.8 if i != k else 1.0 for i in range(len(params.actuators))]
    np.testing.assert_allclose(build_plant(model, c, params.actuators, params.excitation, out,
                                           amp_gains=other).b[:, -1], ref.b[:, -1])
