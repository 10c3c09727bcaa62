"""The ``[design]`` weights of a structure of one's own in SI: ``units = "SI"`` or ``"thesis"``.

The SI weights are checked against designs made here in SI with scipy alone (no vlab conversion): the
LQR gain from the SI Riccati equation, the Kalman gain of the alpha-shifted SI filter, the LQDRF objective
(a Lyapunov solve in SI) of the design's gain. The thesis-unit weights (in, lbf, cs) and their SI values
written out below (from 1 in = 0.0254 m, 1 lbf = 4.4482216152605 N, 1 cs = 0.01 s) give the same gains.
"""

from __future__ import annotations

import json
import re

import numpy as np
import pytest
import scipy.linalg
from typer.testing import CliRunner

from vlab.cli import app
from vlab.design import design_controller, design_settings
from vlab.errors import SpecError
from vlab.fe import build_fe_model
from vlab.spec import load_spec
from vlab.templates import write_template

from _si_models import si_state_space

IN_M, LBF_N, CS_S = 0.0254, 4.4482216152605, 0.01
runner = CliRunner()

#: The BCC's weights (Sec. 6.1) in the thesis units, and the same in SI converted by hand here.
THESIS = {"q_scale": 1.0, "r": 0.22, "v1": 1e-6, "v2": 5e-4, "alpha": 0.2}
BCC_SI = {"q_displacement": 1.0 / IN_M**2, "q_velocity": (CS_S / IN_M) ** 2, "q_rotation": 1.0,
          "q_rotation_rate": CS_S**2, "r": 0.22 / LBF_N**2,
          # a state noise of intensity V [x'^2 * time]: x' in m/s = (x' in in/cs) * 0.0254 / 0.01 ... per s
          "v1_displacement": 1e-6 * IN_M**2 / CS_S, "v1_velocity": 1e-6 * IN_M**2 / CS_S**3,
          "v1_rotation": 1e-6 / CS_S, "v1_rotation_rate": 1e-6 / CS_S**3,
          "v2": 5e-4 * (IN_M / CS_S) ** 2 * CS_S, "alpha": 0.2 / CS_S}
#: Weights of every kind different, to check each against an SI design.
OTHER_SI = {"q_displacement": 3000.0, "q_velocity": 0.05, "q_rotation": 2.0, "q_rotation_rate": 5e-4,
            "r": 0.02, "v1_displacement": 1e-7, "v1_velocity": 1e-3, "v1_rotation": 3e-4, "v1_rotation_rate": 0.5,
            "v2": 1e-5, "alpha": 15.0}

_WEIGHT_LINE = re.compile(r"^(units|q_\w+|r|r_corrected|v1\w*|v2|alpha)\s*=.*\n", re.M)


def _beam(tmp_path, name: str, units: str | None, weights: dict) -> str:
    """The beam template with its [design] weights replaced by ``weights`` in ``units`` (None: no units)."""
    path = tmp_path / f"{name}.toml"
    write_template("beam", path)
    text = _WEIGHT_LINE.sub("", path.read_text())
    lines = ([f'units = "{units}"'] if units else []) + [f"{k} = {v!r}" for k, v in weights.items()]
    text = text.replace('default_model = "full"', 'default_model = "full"\n' + "\n".join(lines), 1)
    path.write_text(text)
    return str(path)


def _si_model(fe):
    """A, B, C (velocity outputs) of the full design model in SI (states [q'; q] in m/s, rad/s, m, rad)."""
    return si_state_space(fe)


def _diag(w: dict, name: str, labels) -> np.ndarray:
    """Diagonal SI weight per kind of state of ``[q'; q]``."""
    vel = [w[f"{name}_velocity" if d == "w" else f"{name}_rotation_rate"] for _p, d in labels]
    pos = [w[f"{name}_displacement" if d == "w" else f"{name}_rotation"] for _p, d in labels]
    return np.diag(vel + pos)


def _rel(x, ref) -> float:
    return float(np.linalg.norm(np.asarray(x) - ref) / np.linalg.norm(ref))


def test_si_weights_give_the_lqr_and_kalman_gains_of_a_design_made_in_si(tmp_path):
    """LQR: the SI Riccati equation's gain to 1e-9; Kalman filter: the SI alpha-shifted filter's gain (its
    Riccati equation is ill-conditioned: V1 spans 8 decades, so rounding moves the gain by ~1e-8)."""
    fe = build_fe_model(load_spec(_beam(tmp_path, "other", "SI", OTHER_SI)))
    dm, a, b, c = _si_model(fe)
    assert {d for _p, d in dm.labels} == {"w", "rx"}  # translations and rotations: every kind of state
    q, r = _diag(OTHER_SI, "q", dm.labels), OTHER_SI["r"] * np.eye(b.shape[1])
    p = scipy.linalg.solve_continuous_are(a, b, q, r)
    f_ref = np.linalg.solve(r, b.T @ p)
    assert _rel(design_controller(fe, "lqr").gain, f_ref) < 1e-9
    lqg = design_controller(fe, "lqg")
    assert _rel(lqg.gain, f_ref) < 1e-9
    v1, v2 = _diag(OTHER_SI, "v1", dm.labels), OTHER_SI["v2"] * np.eye(c.shape[0])
    s = scipy.linalg.solve_continuous_are((a + OTHER_SI["alpha"] * np.eye(len(a))).T, c.T, v1, v2)
    k_ref = s @ c.T @ np.linalg.inv(v2)
    assert _rel(lqg.continuous["b"], k_ref) < 1e-6
    assert np.max(np.linalg.eigvals(a - k_ref @ c).real) < -OTHER_SI["alpha"]


def test_si_weights_are_the_lqdrf_objective_in_si(tmp_path):
    """J of the LQDRF gain D [N*s/m], computed here in SI (weights as written, modal initial conditions of
    1 m peak, time in s), is the design's J (in, lbf, cs; 1 in peak) times 0.01 s / 0.0254^2: the objective
    is the same function of D, so its minimiser is."""
    fe = build_fe_model(load_spec(_beam(tmp_path, "other", "SI", OTHER_SI)))
    dm, a, b, c = _si_model(fe)
    d = design_controller(fe, "lqdrf", n_starts=1)
    q, r = _diag(OTHER_SI, "q", dm.labels), OTHER_SI["r"] * np.eye(b.shape[1])
    f = d.gain @ c
    # J = int x^T (Q + F^T R F) x dt on the closed loop's modes (scipy's Lyapunov solver loses 1e-7 of it
    # here: the SI states span seven decades)
    lam, vec = np.linalg.eig(a - b @ f)
    g = -(vec.conj().T @ (q + f.T @ r @ f) @ vec) / (lam.conj()[:, None] + lam[None, :])
    n = dm.m.shape[0]
    _lam, phi = scipy.linalg.eigh(dm.k, dm.m)
    w_rows = [i for i, (_p, dof) in enumerate(dm.labels) if dof == "w"]
    x0 = np.zeros((2 * n, 2))
    for i in range(2):  # n_f = 2: the first two mode shapes, 1 m largest deflection (the sign leaves J alone)
        x0[n:, i] = phi[:, i] / np.max(np.abs(phi[w_rows, i]))
    z = np.linalg.solve(vec, x0)
    j_si = np.real(np.einsum("ij,ik,kj->j", z.conj(), g, z))
    np.testing.assert_allclose(j_si, d.performance_index_thesis_units * CS_S / IN_M**2, rtol=1e-9)
    np.testing.assert_allclose(j_si, d.performance_index_s, rtol=1e-9)


def test_thesis_and_si_weights_of_one_file_give_the_same_gains(tmp_path):
    """The BCC's weights in the thesis units and converted to SI (BCC_SI, by hand above): LQR and LQG
    regulator gains [N per SI state] to 1e-9, the MFDRF and LQDRF gains [N*s/m] to the optimiser's accuracy."""
    th = build_fe_model(load_spec(_beam(tmp_path, "thesis", "thesis", THESIS)))
    si = build_fe_model(load_spec(_beam(tmp_path, "si", "SI", BCC_SI)))
    assert design_settings(th.spec).weights_units == "thesis" and design_settings(si.spec).weights_units == "SI"
    for controller in ("lqr", "lqg"):
        assert _rel(design_controller(si, controller).gain, design_controller(th, controller).gain) < 1e-9
    kb = [design_controller(x, "lqg").continuous["b"] for x in (si, th)]
    assert _rel(*kb) < 1e-6
    for controller, tol in (("mfdrf", 1e-9), ("lqdrf", 1e-5)):
        d_si, d_th = (design_controller(x, controller, n_starts=2).gain for x in (si, th))
        assert _rel(d_si, d_th) < tol, controller


def test_the_templates_and_the_example_write_si_weights_equal_to_the_former_defaults(tmp_path):
    """`vlab init beam|frame` and examples/cantilever_tip_mass.toml: units = "SI" and the BCC's weights
    (the defaults they used before, no weight written) to 1e-12."""
    from vlab.design import DEFAULT_SETTINGS

    paths = []
    for kind in ("beam", "frame"):
        paths.append(tmp_path / f"{kind}.toml")
        write_template(kind, paths[-1])
    for path in [*paths, "examples/cantilever_tip_mass.toml"]:
        spec = load_spec(path)
        assert spec.design_settings["units"] == "SI"
        for key, value in BCC_SI.items():
            assert spec.design_settings[key] == pytest.approx(value, rel=1e-12), (path, key)
        st = design_settings(spec)
        assert st.q_by_state == pytest.approx((DEFAULT_SETTINGS.q_scale,) * 4, rel=1e-12)
        assert st.v1_by_state == pytest.approx((DEFAULT_SETTINGS.v1,) * 4, rel=1e-12)
        assert (st.r, st.v2, st.alpha) == pytest.approx((DEFAULT_SETTINGS.r, DEFAULT_SETTINGS.v2,
                                                         DEFAULT_SETTINGS.alpha), rel=1e-12)


def test_init_beam_then_design_reads_si_and_matches_no_weights_written(tmp_path):
    """`vlab init beam` → `vlab design --json` says the weights were read in SI; its gains equal those of the
    same file without weights (the BCC's defaults), as the template designed before its weights were SI."""
    path = tmp_path / "b.toml"
    assert runner.invoke(app, ["init", "beam", str(path)]).exit_code == 0
    bare = tmp_path / "bare.toml"
    bare.write_text(_WEIGHT_LINE.sub("", path.read_text()))
    for controller in ("mfdrf", "lqr"):
        outs = []
        for p in (path, bare):
            res = runner.invoke(app, ["design", str(p), "--controller", controller, "--json"])
            assert res.exit_code == 0, res.output
            outs.append(json.loads(res.stdout))
        assert outs[0]["weights"]["units_read"] == "SI" and outs[1]["weights"]["units_read"] is None
        si = [{k: v for k, v in o["weights"]["si"].items() if v is not None} for o in outs]
        assert si[0] == pytest.approx(si[1], rel=1e-12) and si[0]["alpha_per_s"] == pytest.approx(20.0)
        key = "gain_n_s_per_m" if controller == "mfdrf" else "gain_n_per_si_state"
        assert _rel(outs[0][key], np.asarray(outs[1][key])) < 1e-9
    text = runner.invoke(app, ["design", str(path)]).stdout
    assert "weights read in SI" in text


@pytest.mark.parametrize("units,key,says", [
    (None, "q_scale", 'units = "SI"'), (None, "q_displacement", 'units = "thesis"'), (None, "alpha", '"SI"'),
    ("SI", "q_scale", "q_displacement"), ("thesis", "v1_velocity", "q_scale"), ("metric", "r", '"SI", "thesis"'),
])
def test_weights_without_or_with_the_wrong_units_are_refused(tmp_path, units, key, says):
    """A weight with no `units` (or one of the other unit system, or an unknown `units`) is refused naming the
    file, design.<key> and the two values, exit 2 from the CLI; a table with no weight needs no units."""
    path = _beam(tmp_path, "bad", units, {key: 1.0})
    with pytest.raises(SpecError) as err:
        load_spec(path)
    msg = str(err.value)
    field = "units" if units == "metric" else key
    assert path in msg and f"'design.{field}'" in msg and says in msg, msg
    if units is None:
        assert '"SI"' in msg and '"thesis"' in msg
    res = runner.invoke(app, ["design", path])
    assert res.exit_code == 2 and f"design.{field}" in res.output
    spec = load_spec(_beam(tmp_path, "none", None, {}))
    assert "units" not in spec.design_settings and design_settings(spec).weights_units is None


def test_init_bcc_and_grid_write_thesis_units(tmp_path):
    """The copies of the shipped structures keep the thesis's weights, with units = "thesis"."""
    from vlab.design import THESIS_SETTINGS

    for name in ("bcc", "grid"):
        path = tmp_path / f"{name}.toml"
        assert runner.invoke(app, ["init", name, str(path)]).exit_code == 0
        assert 'units = "thesis"' in path.read_text()
        st = design_settings(load_spec(path))
        assert st.weights_units == "thesis" and st.q_by_state is None
        assert (st.q_scale, st.r, st.v1, st.v2, st.alpha) == (THESIS_SETTINGS[name].q_scale, THESIS_SETTINGS[name].r,
                                                              THESIS_SETTINGS[name].v1, THESIS_SETTINGS[name].v2,
                                                              THESIS_SETTINGS[name].alpha)



def test_gamma_in_si_is_the_largest_row_sum_of_the_si_gain(tmp_path):
    """``ControllerDesign.gamma_n_s_per_m``: the DRF objective in N*s/m beside ``gamma`` in lbf*s/in."""
    from vlab.fe import build_fe_model
    from vlab.spec import load_spec
    from vlab.templates import write_template

    fe = build_fe_model(load_spec(write_template("beam", tmp_path / "b.toml")))
    d = design_controller(fe, "mfdrf", seed=0)
    assert d.gamma_n_s_per_m == pytest.approx(d.gamma_lb_s_per_in * 4.4482216152605 / 0.0254, rel=1e-12)
    assert d.gamma_n_s_per_m == pytest.approx(float(np.max(np.sum(np.abs(d.gain), axis=1))), rel=1e-4)
