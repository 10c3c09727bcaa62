"""FE models that double precision cannot resolve are refused, not run without a word (e.g. EI x 1e30)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from vlab.errors import ModelError
from vlab.fe import build_fe_model, modal_analysis
from vlab.models import nominal_fe_model
from vlab.spec import load_spec

STRUCTURES = Path(__file__).resolve().parents[1] / "assets" / "structures"
EPS = np.finfo(float).eps


def _eigenvalues(m, k):
    """Independent generalized eigenvalues: Cholesky to standard form, numpy eigvalsh."""
    lmat = np.linalg.cholesky(m)
    li = np.linalg.inv(lmat)
    a = li @ k @ li.T
    return np.linalg.eigvalsh(0.5 * (a + a.T))


def _bcc_with_beam_ei(tmp_path, factor):
    text = (STRUCTURES / "bcc.toml").read_text()
    old = "value = 9060.0,"  # steel beam EI [lbf*in^2], Sec. 2.1
    assert text.count(old) == 1
    path = tmp_path / f"bcc_ei_{factor:g}.toml"
    path.write_text(text.replace(old, f"value = {9060.0 * factor!r},"))
    load_spec(path)  # each value is plausible: the reader accepts it
    return path


@pytest.mark.parametrize("name", ["bcc", "grid"])
def test_shipped_models_pass(name):
    fe = nominal_fe_model(name)
    lam = _eigenvalues(fe.m, fe.k)
    assert lam.min() > 100 * fe.n * EPS * lam.max()  # the bound, computed here


def test_beam_ei_1e8_is_refused(tmp_path):
    path = _bcc_with_beam_ei(tmp_path, 1e8)
    fe = build_fe_model(load_spec(path))
    lam = _eigenvalues(fe.m, fe.k)
    assert lam.min() < 100 * fe.n * EPS * lam.max()  # independent: below the resolution floor
    with pytest.raises(ModelError, match=r"structure 'bcc'.*mode\(s\) 1 at.*stiffest mode"):
        nominal_fe_model(str(path))


def test_beam_ei_1e4_still_runs(tmp_path):
    path = _bcc_with_beam_ei(tmp_path, 1e4)
    fe = nominal_fe_model(str(path))
    lam = _eigenvalues(fe.m, fe.k)
    assert lam.min() > 100 * fe.n * EPS * lam.max()


def test_support_released_gives_rigid_body_error(tmp_path):
    grid = load_spec("grid")
    free_w = grid.replace(supports=tuple(dataclasses.replace(s, fixed=()) for s in grid.supports))
    fe = build_fe_model(free_w)
    # independent: a uniform out-of-plane translation costs no strain energy in bending
    lam = _eigenvalues(fe.m, fe.k)
    assert lam[0] < 100 * fe.n * EPS * lam.max()
    from vlab.models import check_fe_model

    with pytest.raises(ModelError, match=r"structure 'grid'.*rigid-body mode.*w at (13|22)"):
        check_fe_model(fe)


def test_resolution_floor_closed_form():
    from vlab.fe.modal import unresolved_modes

    m = np.eye(2)
    k = np.diag([1.0, 1e20])
    lam, _, floor = unresolved_modes(m, k)
    assert floor == pytest.approx(100 * 2 * EPS * 1e20)
    assert np.flatnonzero(lam < floor).tolist() == [0]
    lam, _, floor = unresolved_modes(m, np.diag([1.0, 1e6]))
    assert not np.any(lam < floor)


def test_non_finite_matrices_named():
    k = np.eye(3)
    k[1, 2] = k[2, 1] = np.nan
    with pytest.raises(ModelError, match="non-finite entries in the stiffness matrix, first at row 1, column 2"):
        modal_analysis(np.eye(3), k)
    with pytest.raises(ModelError, match="mass matrix"):
        modal_analysis(np.diag([1.0, np.inf, 1.0]), np.eye(3))
