"""The gains a controller ran with, from a design file (vlab.design.gains_file), and a diagnosis that uses them.

The closed loop of a given gain is checked against a direct eigen-analysis of the FE model in SI
(M q'' + (C + U D U^T) q' + K q = 0, no design units, no realisation); the diagnosis against recordings made
with gains that a redesign would not give back.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
import scipy.linalg

from vlab.design import design_controller
from vlab.design.controller import drf_of_gain
from vlab.design.gains_file import design_from_file, read_gains_file
from vlab.errors import DataFileError, ModelError
from vlab.experiment.config import ExperimentConfig
from vlab.experiment.runner import measure
from vlab.fe import build_fe_model
from vlab.fe.damping import structural_damping
from vlab.io.uff import write_recording
from vlab.lab.loop import HardwareChain
from vlab.spec import load_spec


@pytest.fixture(scope="module")
def fe():
    return build_fe_model(load_spec("bcc"))


def _si_closed_loop_damping(fe, d_si: np.ndarray, n: int) -> np.ndarray:
    """Damping ratios of the n lowest closed-loop modes of M q'' + (C + U D U^T) q' + K q = 0 (SI)."""
    u = fe.force_input(fe.spec.instrumentation.actuators)
    c = structural_damping(fe, fe.spec) + u @ d_si @ u.T
    m_inv = np.linalg.inv(fe.m)
    a = np.block([[-m_inv @ c, -m_inv @ fe.k], [np.eye(fe.n), np.zeros((fe.n, fe.n))]])
    lam = scipy.linalg.eigvals(a)
    lam = lam[lam.imag > 0]
    lam = lam[np.argsort(np.abs(lam))][:n]
    return -lam.real / np.abs(lam)


def test_a_given_gain_closes_the_loop_as_a_direct_si_eigen_analysis(fe):
    """1.5 times the MFDRF gain on the BCC's full model: the six lowest closed-loop damping ratios as the SI
    eigen-analysis gives them, and the row sum as gamma."""
    d = 1.5 * design_controller(fe, "mfdrf").gain
    g = drf_of_gain(fe, "mfdrf", d, source="a test")
    assert g.converged and "not designed" in g.message
    np.testing.assert_allclose(g.damping_ratios[:6], _si_closed_loop_damping(fe, d, 6), rtol=1e-6)
    np.testing.assert_array_equal(g.f11, -d)
    assert g.gamma_n_s_per_m == pytest.approx(np.abs(d).sum(axis=1).max(), rel=1e-12)


def test_a_redesigned_gain_is_the_design_itself(fe):
    d = design_controller(fe, "lqdrf")
    g = drf_of_gain(fe, "lqdrf", d.gain)
    np.testing.assert_allclose(g.damping_ratios, d.damping_ratios, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(g.performance_index_thesis_units, d.performance_index_thesis_units, rtol=1e-9)


def test_gains_of_another_law_or_shape_are_refused(fe):
    with pytest.raises(ModelError, match="direct rate feedback"):
        drf_of_gain(fe, "lqg", np.eye(3))
    with pytest.raises(ModelError, match=r"\(3, 3\)"):
        drf_of_gain(fe, "mfdrf", np.eye(2))


@pytest.mark.parametrize("doc, match", [
    ({"gain_n_s_per_m": [[1.0]]}, "'controller' missing"),
    ({"controller": "mfdrf"}, "'gain_n_s_per_m' missing"),
    ({"controller": "lqg", "gain_n_s_per_m": [[1.0]]}, "only the gains of a direct rate feedback"),
    ({"controller": "mfdrf", "gain_n_s_per_m": [[1.0, 2.0]]}, "square"),
    ({"controller": "mfdrf", "gain_n_s_per_m": [["a"]]}, "not a matrix of numbers"),
    ({"controller": "mfdrf", "gain_n_s_per_m": [[1.0]], "period_s": -1}, "'period_s'"),
    ([1, 2], "JSON object"),
])
def test_a_malformed_design_file_names_the_file_and_field(tmp_path, doc, match):
    path = tmp_path / "design.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(DataFileError, match=match) as e:
        read_gains_file(path)
    assert str(path) in str(e.value)


def test_a_design_file_of_another_structure_or_controller_is_refused(tmp_path, fe):
    path = tmp_path / "design.json"
    path.write_text(json.dumps({"structure": "grid", "controller": "mfdrf", "gain_n_s_per_m": np.eye(3).tolist()}))
    with pytest.raises(DataFileError, match="structure 'grid'"):
        design_from_file(fe, path)
    path.write_text(json.dumps({"structure": "bcc", "controller": "mfdrf", "gain_n_s_per_m": np.eye(3).tolist()}))
    with pytest.raises(DataFileError, match="recording ran 'lqdrf'"):
        design_from_file(fe, path, controller="lqdrf")
    path.write_text(json.dumps({"structure": "bcc", "controller": "mfdrf", "gain_n_s_per_m": np.eye(2).tolist()}))
    with pytest.raises(DataFileError, match="finite"):
        design_from_file(fe, path)


def test_a_recording_with_the_labs_own_gains_is_diagnosed_with_them(tmp_path, fe):
    """A BCC loop that ran 1.3 times vlab's MFDRF gain (the lab's own tuning), recorded on the linear plant
    with vlab's sidecar: diagnosed with those gains (`--design`), the nominal structure is found; redesigned,
    the loop's difference is a mismatch."""
    from vlab.diagnose import diagnose

    d = 1.3 * design_controller(fe, "mfdrf").gain
    design = drf_of_gain(fe, "mfdrf", d)
    cfg = ExperimentConfig(structure="bcc", controller="mfdrf", plant="linear", chain=HardwareChain(noise_m_s=1e-6))
    meta = {"structure": "bcc", "controller": "mfdrf", "reduction": None, "excitation": "random", "seed": 0,
            "plant": "linear FE model"}
    rec = tmp_path / "rec.uff"
    write_recording(rec, measure(cfg, fe, design, metadata=meta).loop.recording)
    gains = tmp_path / "design.json"
    gains.write_text(json.dumps({"structure": "bcc", "controller": "mfdrf", "gain_n_s_per_m": d.tolist()}))
    with_gains = diagnose("bcc", rec, plant="linear", design=gains, validate_run=False)
    assert not with_gains.mismatch
    assert any("gains from" in n for n in with_gains.notes)
    redesigned = diagnose("bcc", rec, plant="linear", validate_run=False, effects=("actuator_gain",))
    assert redesigned.mismatch


def test_the_design_files_period_is_checked_against_a_recordings(tmp_path, fe):
    """A vlab recording's sample interval is the controller's period: a design file that says another is
    refused; a modal table (open-loop modes) leaves the design file unused, with a note."""
    from vlab.diagnose import diagnose
    from vlab.errors import OptionError

    d = design_controller(fe, "mfdrf")
    cfg = ExperimentConfig(structure="bcc", controller="mfdrf", plant="linear", chain=HardwareChain(noise_m_s=1e-6),
                           duration_s=40.0)
    rec = tmp_path / "rec.uff"
    write_recording(rec, measure(cfg, fe, d, metadata={"structure": "bcc", "controller": "mfdrf"}).loop.recording)
    gains = tmp_path / "design.json"
    gains.write_text(json.dumps({"controller": "mfdrf", "gain_n_s_per_m": d.gain.tolist(), "period_s": 0.001}))
    with pytest.raises(OptionError, match="contradicts the recording's sample interval"):
        diagnose("bcc", rec, plant="linear", design=gains, validate_run=False)
    table = tmp_path / "modes.csv"
    table.write_text("mode,frequency_hz,damping_ratio\n1,1.853,0.004\n2,4.801,0.002\n")
    r = diagnose("bcc", table, design=gains)
    assert any("design file" in n and "not used" in n for n in r.notes)
