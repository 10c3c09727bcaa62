"""A structure of one's own through the whole pipeline: examples/cantilever_tip_mass.toml.

Modes against the Euler-Bernoulli closed form of a cantilever with a tip mass (scipy brentq, independent of
vlab's FE), the MuJoCo plant against the FE model (`vlab crosscheck`), an MFDRF design checked by the
closed-loop eigenvalues computed here, a short closed-loop experiment, and the diagnosis of a concealed
added mass (`vlab diagnose` against the nominal file).
"""

from __future__ import annotations

import csv
import io
import json
import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg
from scipy.optimize import brentq
from typer.testing import CliRunner

from vlab.cli import app

EXAMPLE = Path(__file__).resolve().parent.parent / "examples" / "cantilever_tip_mass.toml"
runner = CliRunner()


def _cli(*args: str):
    res = runner.invoke(app, [str(a) for a in args])
    assert res.exit_code == 0, (res.stdout, res.stderr if res.stderr_bytes is not None else "")
    return res.stdout


def _closed_form_hz(ei: float, rho_a: float, length: float, tip_mass: float, n: int) -> np.ndarray:
    """Euler-Bernoulli clamped-free beam with a tip point mass: roots of
    1 + cos(bL) cosh(bL) + mu bL (cos(bL) sinh(bL) - sin(bL) cosh(bL)) = 0, mu = m_tip / (rho A L);
    f = (bL)^2 / (2 pi L^2) sqrt(EI / (rho A))."""
    mu = tip_mass / (rho_a * length)

    def g(x):
        return 1 + np.cos(x) * np.cosh(x) + mu * x * (np.cos(x) * np.sinh(x) - np.sin(x) * np.cosh(x))

    xs = np.linspace(0.05, 20.0, 4000)
    v = g(xs)
    roots = [brentq(g, xs[i], xs[i + 1]) for i in range(len(xs) - 1) if v[i] * v[i + 1] < 0][:n]
    return np.array(roots) ** 2 / (2 * np.pi * length**2) * np.sqrt(ei / rho_a)


def test_modes_against_the_closed_form_of_a_cantilever_with_tip_mass(tmp_path):
    # the closed form has the tip mass only: the same file without the 20 g coil at point 4, through the CLI
    text = EXAMPLE.read_text()
    block = re.search(r"\[\[masses\]\]\nid = \"coil4\"\n[^\n]*\n[^\n]*\n", text)
    assert block is not None
    tip_only = tmp_path / "tip_only.toml"
    tip_only.write_text(text.replace(block.group(0), ""))
    out = json.loads(_cli("modes", tip_only, "--n", "3", "--format", "json"))
    f_vlab = np.array(out["frequencies_hz"])
    # section properties from the file's own numbers (25 x 3 mm steel, 600 mm, 100 g at the tip)
    b, t, rho, e, length, m_tip = 0.025, 0.003, 7850.0, 200e9, 0.6, 0.100
    f_cf = _closed_form_hz(e * b * t**3 / 12, rho * b * t, length, m_tip, 3)
    assert np.allclose(f_vlab, f_cf, rtol=5e-3), (f_vlab, f_cf)
    # the check can fail: without its tip mass the closed form is 30 % higher
    f_bare = _closed_form_hz(e * b * t**3 / 12, rho * b * t, length, 0.0, 3)
    assert f_bare[0] > 1.3 * f_vlab[0]


def test_mujoco_plant_matches_the_fe_model():
    rows = list(csv.DictReader(io.StringIO(_cli("crosscheck", EXAMPLE, "--n", "3", "--format", "csv"))))
    assert len(rows) == 3
    for r in rows:
        assert abs(float(r["error_thesis_mesh_pct"])) < 1.0 and float(r["mac_thesis_mesh"]) > 0.99, r
        assert float(r["mujoco_hz"]) > 0


def _fe():
    from vlab.fe import build_fe_model
    from vlab.spec import load_spec

    return build_fe_model(load_spec(EXAMPLE))


def test_mfdrf_design_damps_the_test_modes_to_the_file_s_zeta_min():
    out = json.loads(_cli("design", EXAMPLE, "--controller", "mfdrf", "--format", "json"))
    assert out["converged"] and out["structure"] == "cantilever_tip_mass"
    d = np.asarray(out["gain_n_s_per_m"])
    assert d.shape == (2, 2)
    # independent check: eigenvalues of m q'' + (c + U D U^T) q' + k q = 0 with the file's 1 % modal damping
    fe = _fe()
    lam, phi = scipy.linalg.eigh(fe.k, fe.m)
    w = np.sqrt(lam)
    c = fe.m @ phi @ np.diag(2 * 0.01 * w) @ phi.T @ fe.m  # modal damping, phi mass-normalised
    u = np.zeros((fe.n, 2))
    for j, p in enumerate((6, 4)):  # [instrumentation] actuators
        u[fe.dofs.index(p, "w"), j] = 1.0
    ct = c + u @ d @ u.T
    a = np.block([[np.zeros((fe.n, fe.n)), np.eye(fe.n)],
                  [-np.linalg.solve(fe.m, fe.k), -np.linalg.solve(fe.m, ct)]])
    ev = np.linalg.eigvals(a)
    ev = ev[ev.imag > 0]
    ev = ev[np.argsort(np.abs(ev))]
    zeta = -ev.real / np.abs(ev)
    assert np.all(zeta[:2] >= 0.03 - 1e-4), zeta[:3]  # [design] zeta_min = 0.03 on n_modes = 2
    assert np.min(zeta[:2]) < 0.031  # MFDRF is the least gain: the constraint is active


def test_short_closed_loop_experiment_on_the_mujoco_plant():
    import vlab

    r = vlab.run_experiment(str(EXAMPLE), "mfdrf", duration_s=4.0)
    assert len(r.modes) == 2 and not r.warnings
    for m in r.modes:
        assert abs(m.frequency_measured_hz / m.frequency_predicted_hz - 1) < 0.01
        assert abs(m.peak_level_ratio - 1) < 0.1
    assert r.modes[1].damping_measured > 0.025  # open loop: 1 % ([damping]); closed loop: 3 % designed


@pytest.mark.slow
def test_diagnosis_names_a_concealed_added_mass(tmp_path):
    from vlab.design import design_controller
    from vlab.fe import build_fe_model
    from vlab.io.uff import write_recording
    from vlab.experiment.config import ExperimentConfig
    from vlab.experiment.runner import make_plant, measure
    from vlab.spec import LumpedMass, Quantity, load_spec

    nominal = load_spec(EXAMPLE)
    # a mass attached to the real strip leaves its damping matrix as it was (vlab.fe.damping): the hidden
    # structure's damping basis is the nominal one
    hidden = nominal.replace(masses=nominal.masses + (LumpedMass("concealed", 3, Quantity(0.04, "hidden")),),
                             damping=replace(nominal.damping, basis=nominal))
    fe_nom = build_fe_model(nominal)
    cfg = ExperimentConfig(structure=nominal.name, controller="mfdrf", duration_s=4.0)
    design = design_controller(fe_nom, "mfdrf")  # the lab's controller: designed on the nominal model
    plant = make_plant(cfg, build_fe_model(hidden), tuple(nominal.instrumentation.actuators))
    m = measure(cfg, fe_nom, design, plant=plant)
    rec = tmp_path / "hidden.uff"
    write_recording(rec, m.loop.recording, overwrite=False)
    d = json.loads(_cli("diagnose", "--structure", EXAMPLE, "--recording", rec, "--controller", "mfdrf",
                        "--out", tmp_path / "diag", "--format", "json"))
    assert d["mismatch"]
    sel = d["selected"]
    assert len(sel) == 1 and sel[0]["effect"] == "added_mass" and sel[0]["location"] == {"point": 3}, sel
    assert sel[0]["parameters"]["mass_kg"] == pytest.approx(0.04, rel=0.1)
    # the CSV form of the same diagnosis: one line per ranked hypothesis, units in the column names
    from vlab.cli.diagnose import diagnosis_csv

    buf = io.StringIO()
    diagnosis_csv(d, out=buf)
    rows = list(csv.DictReader(io.StringIO(buf.getvalue())))
    assert len(rows) == len(d["ranked"]) and rows[0]["effect"] == "added_mass"
    assert "misfit_after_decades" in rows[0] and rows[0]["location"] == "point 3"


# ------------------------------------------------------------------------ structures written by a new user ---

DOCS = Path(__file__).resolve().parent.parent / "docs"


def _tutorial_strip(tmp_path: Path) -> Path:
    """The tutorial's strip.toml (docs/tutorials/your-own-structure.md), as a reader copies it: no [design] table."""
    text = (DOCS / "tutorials" / "your-own-structure.md").read_text()
    block = re.search(r"```toml\n(# A steel strip.*?)```", text, re.S)
    assert block is not None and "[design]" not in block.group(1)
    path = tmp_path / "strip.toml"
    path.write_text(block.group(1))
    return path


def _invoke(*args):
    return runner.invoke(app, [str(a) for a in args])


def test_design_without_a_design_table_takes_the_defaults_capped_at_the_model_s_dofs(tmp_path):
    strip = _tutorial_strip(tmp_path)
    out = json.loads(_cli("design", strip, "--controller", "mfdrf", "--format", "json"))
    assert out["reduction"] == "exact" and out["converged"]
    # three masters: three modes held to the default zeta_min = 0.03, three modal initial conditions
    assert len(out["performance_index_si_1m_ic_s"]) == 3 and min(out["damping_ratios"][:3]) >= 0.03 - 1e-6
    # a structure of one's own gets SI only: no key in the dissertation's units
    assert not [k for k in out if "thesis" in k or "lb" in k.split("_")], sorted(out)
    # the same design as a [design] table with the defaults written out and the counts at the 3 masters
    explicit = tmp_path / "strip_explicit.toml"
    explicit.write_text(strip.read_text() + "\n[design]\nsource = \"test\"\nzeta_min = 0.03\nn_modes = 3\nn_f = 3\n")
    ref = json.loads(_cli("design", explicit, "--controller", "mfdrf", "--format", "json"))
    assert np.array_equal(out["gain_n_s_per_m"], ref["gain_n_s_per_m"])
    # a count beyond the design model is refused, naming the file, the field and the value
    beyond = tmp_path / "strip_beyond.toml"
    beyond.write_text(strip.read_text() + "\n[design]\nsource = \"test\"\nn_f = 4\n")
    res = _invoke("design", beyond, "--controller", "mfdrf")
    assert res.exit_code == 2, res.output
    assert "strip_beyond.toml" in res.output and "design.n_f" in res.output and "4" in res.output


def test_a_beam_along_x_needs_ry_and_then_has_the_modes_of_the_beam_along_y(tmp_path):
    along_y = tmp_path / "along_y.toml"
    _cli("init", "beam", along_y)
    text = along_y.read_text()
    coords = re.search(r"coordinates = \{.*\}", text).group(0)
    turned = text.replace(coords, re.sub(r"\[0, (\d+)\]", r"[\1, 0]", coords))  # the same beam along x
    assert turned != text
    along_x = tmp_path / "along_x.toml"
    along_x.write_text(turned)
    res = _invoke("modes", along_x)
    assert res.exit_code == 2
    message = " ".join(res.output.split())
    assert "structure.dofs" in message and "'strip'" in message and "along x" in message and "'ry'" in message
    fixed = tmp_path / "along_x_ry.toml"
    fixed.write_text(turned.replace('dofs = ["w", "rx"]', 'dofs = ["w", "ry"]')
                     .replace('fixed = ["w", "rx"]', 'fixed = ["w", "ry"]'))
    f_y = json.loads(_cli("modes", along_y, "--n", "4", "--format", "json"))["frequencies_hz"]
    f_x = json.loads(_cli("modes", fixed, "--n", "4", "--format", "json"))["frequencies_hz"]
    assert np.allclose(f_x, f_y, rtol=1e-9)  # turning a structure in its plane leaves its modes


def test_crosscheck_beyond_its_tolerance_says_so(tmp_path):
    from vlab.sim.crosscheck import MIN_MAC, TOL_PCT

    frame = tmp_path / "frame.toml"
    _cli("init", "frame", frame)
    out = json.loads(_cli("crosscheck", frame, "--json"))
    worst = {k: max(abs(p["error_pct"]) for p in r["pairs"]) for k, r in out["references"].items()}
    assert max(worst.values()) > TOL_PCT  # the frame's mode 6: about 10 %
    assert out["within_tolerance"] is False
    assert out["tolerance"] == {"max_abs_error_pct": TOL_PCT, "min_mac": MIN_MAC, "source": out["tolerance"]["source"]}
    assert "Ewins" in out["tolerance"]["source"]
    assert {k for k, v in worst.items() if v > TOL_PCT} == set(out["beyond_tolerance"])
    for key, b in out["beyond_tolerance"].items():
        assert b["max_abs_error_pct"] == worst[key]
    table = " ".join(_cli("crosscheck", frame).split())
    assert "BEYOND TOLERANCE (file mesh)" in table and f"{worst['thesis_mesh']:.2f} %" in table
