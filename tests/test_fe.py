"""FE library against closed forms, and properties of the assembled BCC model."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.special

from vlab.errors import ModelError, SpecError
from vlab.fe import build_fe_model, modal_analysis
from vlab.fe.elements import axial_geometric_stiffness, bending_stiffness
from vlab.spec import load_spec, spec_from_dict


def q(value, unit, source="test"):
    return {"value": value, "unit": unit, "source": source}


def line_spec(n_el, length_m, *, gravity=(0.0, 0.0), ei=10.0, rho_a=1.0, supports=(), strings=(), horizontal=False):
    """A straight member of n_el elements from point 1 (top or left) to point n_el+1."""
    pts = {}
    for i in range(n_el + 1):
        s = length_m * i / n_el
        pts[str(i + 1)] = [s, 0.0] if horizontal else [0.0, length_m - s]
    # section chosen so that mass per length = rho_a (width 0.1 m x thickness 0.01 m)
    area = 0.1 * 0.01
    return {
        "structure": {"name": "t", "title": "t", "source": "test", "dofs": ["w", "rx", "ry"], "gravity": list(gravity)},
        "points": {"unit": "m", "source": "test", "coordinates": pts},
        "sections": {
            "s": {
                "width": q(0.1, "m"), "thickness": q(0.01, "m"),
                "density": q(rho_a / area, "kg/m^3"), "modulus": q(70e9, "Pa"), "shear_modulus": q(26e9, "Pa"),
                "ei": q(ei, "N*m^2"),
            }
        },
        "members": [{"id": "m", "points": list(range(1, n_el + 2)), "section": "s"}],
        "supports": list(supports),
        "strings": list(strings),
    }


def test_cantilever_first_four_frequencies_within_0p1_percent():
    L, ei, rho_a = 2.0, 10.0, 1.0
    doc = line_spec(20, L, ei=ei, rho_a=rho_a, horizontal=True,
                    supports=[{"point": 1, "fixed": ["w", "rx", "ry"], "inplane": "clamped"}])
    fe = build_fe_model(spec_from_dict(doc))
    # bending modes of a cantilever: beta_n L; torsion modes are also present: select by bending participation
    beta_l = np.array([1.8751040687, 4.6940911330, 7.8547574382, 10.9955407349])
    f_exact = beta_l**2 * np.sqrt(ei / (rho_a * L**4)) / (2 * np.pi)
    modes = modal_analysis(fe.m, fe.k, 30)
    w_rows = [fe.dofs.index(p, "w") for p in range(2, 22)]
    bending = [i for i in range(30) if np.linalg.norm(modes.shapes[w_rows, i]) > 1e-6]
    f = modes.frequencies_hz[bending][:4]
    np.testing.assert_allclose(f, f_exact, rtol=1e-3)


def test_pinned_beam_under_tension_matches_exact_formula():
    """A pinned-pinned beam with axial tension T: f_n = n/(2L) sqrt(T/rhoA) sqrt(1 + n^2 pi^2 EI/(T L^2))."""
    L, ei, rho_a, T = 1.5, 0.5, 0.8, 200.0
    doc = line_spec(
        40, L, ei=ei, rho_a=rho_a,
        supports=[{"point": 1, "fixed": ["w", "ry"], "inplane": "pinned"}, {"point": 41, "fixed": ["w", "ry"]}],
        strings=[{"id": "pull", "point": 41, "direction": [0, -1], "tension": q(T, "N"),
                  "length": q(1.0, "m"), "diameter": q(1e-3, "m"), "density": q(1.0, "kg/m^3")}],
    )
    fe = build_fe_model(spec_from_dict(doc))
    n = np.arange(1, 5)
    f_exact = n / (2 * L) * np.sqrt(T / rho_a) * np.sqrt(1 + n**2 * np.pi**2 * ei / (T * L**2))
    f = modal_analysis(fe.m, fe.k, 4).frequencies_hz
    np.testing.assert_allclose(f, f_exact, rtol=1e-3)


def test_hanging_chain_with_gravity():
    """A flexible member hanging under its own weight: omega_n = (j0_n / 2) sqrt(g / L)."""
    L = 1.0
    doc = line_spec(60, L, ei=1e-6, rho_a=1.0, gravity=(0.0, -1.0),
                    supports=[{"point": 1, "fixed": ["w", "ry"], "inplane": "pinned"}])
    fe = build_fe_model(spec_from_dict(doc))
    j0 = scipy.special.jn_zeros(0, 3)
    f_exact = j0 / 2 * np.sqrt(9.80665 / L) / (2 * np.pi)
    f = modal_analysis(fe.m, fe.k, 3).frequencies_hz
    np.testing.assert_allclose(f, f_exact, rtol=5e-3)


def test_axial_geometric_stiffness_uniform_closed_form():
    L, N = 0.3, 12.0
    expected = N / (30 * L) * np.array(
        [[36, 3 * L, -36, 3 * L], [3 * L, 4 * L**2, -3 * L, -L**2],
         [-36, -3 * L, 36, -3 * L], [3 * L, -L**2, -3 * L, 4 * L**2]])
    np.testing.assert_allclose(axial_geometric_stiffness(N, N, L), expected, rtol=1e-12)


def test_shear_flexible_element_reduces_cantilever_stiffness():
    L, ei, kga = 1.0, 2.0, 50.0
    k = bending_stiffness(ei, L, kga)
    # tip flexibility of a cantilever: L^3/(3EI) + L/kGA
    kff = k[2:, 2:]
    flex = np.linalg.inv(kff)[0, 0]
    assert flex == pytest.approx(L**3 / (3 * ei) + L / kga, rel=1e-12)


def test_bcc_matrices_symmetric_definite_and_dof_count():
    fe = build_fe_model(load_spec("bcc"))
    assert fe.n == 19  # 9 points x (w, rx) + crosspiece oscillator
    np.testing.assert_allclose(fe.m, fe.m.T, atol=0)
    np.testing.assert_allclose(fe.k, fe.k.T, atol=0)
    assert np.linalg.eigvalsh(fe.m).min() > 0
    assert np.linalg.eigvalsh(fe.k).min() > 0  # held by the strings: no rigid-body mode
    # the top cable carries the bottom tension plus the weight of everything
    t = fe.gravity.string_tensions
    spec = fe.spec
    weight = 9.80665 * (
        spec.sections["steel_beam"].rho_a * 80 * 0.0254
        + sum(m.mass.si for m in spec.masses)
        + sum(2 * (spec.sections[c.section].rho_a * c.arm_length.si + c.tip_mass.si) + c.clamp_mass.si
              for c in spec.crosspieces)
    )
    assert t["top_cables"] - t["bottom_cables"] == pytest.approx(weight, rel=1e-9)


def test_bcc_reproduces_table1_analytical_within_1p5_percent():
    from vlab.reference import column

    fe = build_fe_model(load_spec("bcc"))
    f = modal_analysis(fe.m, fe.k, 6).frequencies_hz
    ref = column("table1_bcc_frequencies.csv", "analytical_hz")
    assert np.max(np.abs(f / ref - 1)) < 0.015


def test_bcc_table8_damping_with_table7_gains_within_20_percent():
    from vlab.calibration import bcc_residuals

    _, _, _, rel = bcc_residuals(build_fe_model(load_spec("bcc")))
    assert np.max(np.abs(rel)) < 0.20


def test_unknown_point_in_force_input_names_point():
    fe = build_fe_model(load_spec("bcc"))
    with pytest.raises(ModelError, match="42"):
        fe.force_input([42])


def test_bad_spec_errors_name_field(tmp_path):
    src = load_spec("bcc").path.read_text()
    bad = tmp_path / "bad.toml"
    bad.write_text(src.replace("value = 9060.0", "value = -9060.0"))
    with pytest.raises(SpecError, match=r"bad.toml.*sections.steel_beam.ei.value.*positive"):
        load_spec(bad)
    bad.write_text(src.replace("point = 9\n", "point = 99\n", 1))
    with pytest.raises(SpecError, match="unknown point id 99"):
        load_spec(bad)
    bad.write_text(src.replace('[structure]', '[structure]\ncolour = "red"'))
    with pytest.raises(SpecError, match="structure.colour.*unknown field"):
        load_spec(bad)
    bad.write_text(src.replace('unit = "lbf*in^2"', 'unit = "furlong"', 1))
    with pytest.raises(SpecError, match="furlong"):
        load_spec(bad)
    bad.write_text(src + "\n[[[broken")
    with pytest.raises(SpecError, match="not valid TOML"):
        load_spec(bad)
    with pytest.raises(SpecError, match="unknown structure"):
        load_spec("bridge")


def _fine_cantilever(ei, length, arm_mass, tip_mass, n=120):
    """Euler-Bernoulli cantilever with a tip mass: n cubic elements, base w as DOF 0."""
    le = length / n
    ke = ei / le**3 * np.array([[12, 6 * le, -12, 6 * le], [6 * le, 4 * le**2, -6 * le, 2 * le**2],
                                [-12, -6 * le, 12, -6 * le], [6 * le, 2 * le**2, -6 * le, 4 * le**2]])
    me = arm_mass / n / 420 * np.array([[156, 22 * le, 54, -13 * le], [22 * le, 4 * le**2, 13 * le, -3 * le**2],
                                        [54, 13 * le, 156, -22 * le], [-13 * le, -3 * le**2, -22 * le, 4 * le**2]])
    size = 2 * (n + 1)
    k, m = np.zeros((size, size)), np.zeros((size, size))
    for e in range(n):
        s = slice(2 * e, 2 * e + 4)
        k[s, s] += ke
        m[s, s] += me
    m[-2, -2] += tip_mass
    return k, m


def test_crosspiece_sdof_matches_a_fine_cantilever_under_base_motion():
    """The SDOF's spring and participating mass reproduce the dynamic mass of the arm near its resonance."""
    from vlab.fe.crosspiece import cantilever_tip_mass_sdof

    ei, length, arm, tip = 7.69, 0.381, 0.167, 0.102  # the BCC arm, SI
    k1, m1, rest = cantilever_tip_mass_sdof(ei, length, arm, tip)
    k, m = _fine_cantilever(ei, length, arm, tip)
    free = np.arange(2, k.shape[0])  # base translation (0) driven, base slope (1) clamped
    for f_hz in (4.0, 8.0, 9.5):  # the old tip-free shape was 3 % off at 8-9.5 Hz
        w2 = (2 * np.pi * f_hz) ** 2
        d = k - w2 * m
        dyn = d[0, 0] - d[0, free] @ np.linalg.solve(d[np.ix_(free, free)], d[free, 0])  # base force / base motion
        exact = -dyn / w2
        sdof = rest + m1 * k1 / (k1 - w2 * m1)
        assert sdof == pytest.approx(exact, rel=2e-3), f_hz
    assert m1 + rest == pytest.approx(arm + tip)


def test_gravity_memo_follows_every_in_plane_input():
    """The memoised in-plane statics is reused for an out-of-plane change only; a mass, a string tension or
    an in-plane rigidity gives a new solution (the same as a cold solve)."""
    import dataclasses

    from vlab.diagnose.effects import specedit
    from vlab.fe import statics
    from vlab.fe.mesh import build_mesh
    from vlab.spec import load_spec

    spec = load_spec("grid")
    mesh = build_mesh(spec)
    base = statics.solve_gravity(spec, mesh)
    soft = specedit.soften_joint(spec, 18, 5000.0)
    assert statics.solve_gravity(soft, build_mesh(soft)) is base
    heavy = specedit.add_mass(spec, 5, 0.3)
    got = statics.solve_gravity(heavy, build_mesh(heavy))
    assert got is not base
    cold = statics._solve(heavy, build_mesh(heavy))
    assert [f.axial for f in got.element_forces] == [f.axial for f in cold.element_forces]
    assert got.element_forces[0].axial != base.element_forces[0].axial
    sec_id = mesh.elements[0].section
    sec = spec.sections[sec_id]
    stiffer = dataclasses.replace(spec, sections={**spec.sections, sec_id: dataclasses.replace(
        sec, ei_inplane=2.0 * sec.ei_inplane)})
    assert statics._inputs(stiffer, build_mesh(stiffer)) != statics._inputs(spec, mesh)
