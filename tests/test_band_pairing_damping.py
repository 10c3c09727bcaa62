"""The modal damping targets and the virtual modal test pair modes one-to-one over a band.

Both used to pair the first n FE modes against more plant modes
(:func:`vlab.sim.pairing.pair_modes` on FE modes 1..n only): a plant mode
whose own FE partner is mode n+1, lying just above, could then be taken by
FE mode n. The synthetic trap is the one of ``tests/test_crosscheck_pairing.py``
(FE modes 2 and 3 16 degrees apart at the points, plant mode 3 between them);
the expected labels come from a brute-force search over all one-to-one
assignments written out in that test module, not from vlab's output.
"""

from __future__ import annotations

import importlib
from types import SimpleNamespace

import numpy as np
import pytest

import vlab.fe
import vlab.models
import vlab.reference
from vlab.errors import SimulationError
from vlab.sim.damping import _targets
from vlab.sim.linearize import SimModes
from vlab.spec import load_spec

from test_crosscheck_pairing import FE_HZ, FE_SHAPES, N_PTS, SIM_HZ, SIM_SHAPES, _brute_force, _fake_fe, _mac

modaltest = importlib.import_module("vlab.sim.modaltest")


def _truth() -> dict[int, int]:
    """One-to-one optimum over FE modes 1-3 (all FE modes below (1 + margin)^2 x FE mode 2)."""
    return _brute_force(FE_SHAPES[:, :3], SIM_SHAPES[:, :3])


def test_the_trap_mislabels_with_the_first_n_fe_modes_only():
    # FE mode 2 alone prefers plant mode 3; the one-to-one optimum over the band gives it plant mode 2
    assert _mac(FE_SHAPES[:, 1], SIM_SHAPES[:, 2]) > _mac(FE_SHAPES[:, 1], SIM_SHAPES[:, 1])
    assert _truth()[1] == 1 and _truth()[2] == 2


@pytest.fixture(scope="module")
def bcc():
    spec = load_spec("bcc")
    fe = vlab.fe.build_fe_model(spec)
    points = [p for p in sorted(spec.points) if (p, "w") in fe.dofs]
    assert len(points) >= N_PTS
    return spec, fe, points


def test_damping_targets_label_the_plant_modes_one_to_one(monkeypatch, bcc):
    """Failed before the fix: plant mode 3 got spec mode 2's ratio, plant mode 2 the default ratio."""
    spec, fe, points = bcc
    pad = np.zeros((len(points) - N_PTS, FE_SHAPES.shape[1]))
    monkeypatch.setattr(vlab.fe, "modal_analysis", _fake_fe(fe, FE_HZ, np.vstack([FE_SHAPES, pad]), points))
    pad_s = np.zeros((len(points) - N_PTS, SIM_SHAPES.shape[1]))
    pm = SimModes(SIM_HZ.copy(), np.zeros(SIM_HZ.size), tuple(points), np.vstack([SIM_SHAPES, pad_s]),
                  np.zeros((1, SIM_HZ.size)), np.eye(1))
    idx, ratios, spec_modes = _targets(spec, pm, 2)
    truth = _truth()
    dmp = spec.damping
    # plant modes up to 1.25 x FE mode 2 (2.5 Hz): 1, 2, 3; mode 3 belongs to FE mode 3, not damped as spec mode 2
    assert list(idx) == [0, 1, 2]
    assert spec_modes == (1, 2, None)
    assert spec_modes[truth[1]] == 2
    np.testing.assert_array_equal(ratios, [dmp.modal_ratios[0], dmp.modal_ratios[1], dmp.default_ratio])


def test_damping_targets_refuse_more_modes_than_the_fe_model_has(monkeypatch, bcc):
    spec, fe, points = bcc
    pad = np.zeros((len(points) - N_PTS, FE_SHAPES.shape[1]))
    monkeypatch.setattr(vlab.fe, "modal_analysis", _fake_fe(fe, FE_HZ, np.vstack([FE_SHAPES, pad]), points))
    pm = SimModes(SIM_HZ.copy(), np.zeros(SIM_HZ.size), tuple(points),
                  np.vstack([SIM_SHAPES, np.zeros((len(points) - N_PTS, SIM_SHAPES.shape[1]))]),
                  np.zeros((1, SIM_HZ.size)), np.eye(1))
    with pytest.raises(SimulationError, match="5 damped modes, but the FE model has 4"):
        _targets(spec, pm, 5)


def test_virtual_measured_modes_pair_one_to_one(monkeypatch, bcc):
    """Failed before the fix: the shapes returned for FE mode 2 were plant mode 3's."""
    spec, fe, points = bcc
    rows = [fe.dofs.index(p, "w") for p in points[:N_PTS]]
    monkeypatch.setattr(vlab.fe, "modal_analysis", _fake_fe(fe, FE_HZ, FE_SHAPES, points[:N_PTS]))
    monkeypatch.setattr(vlab.models, "master_indices", lambda _fe, _method: rows)
    f_exp = np.array([1.01, 2.02])  # two measured frequencies -> n_m = 2
    monkeypatch.setattr(vlab.reference, "column", lambda _file, _name: f_exp)
    calls = []

    def fake_test(_spec, labels, n_modes):
        calls.append(n_modes)
        n = min(n_modes, SIM_HZ.size)
        return SIM_HZ[:n].copy(), SIM_SHAPES[:, :n].copy()

    monkeypatch.setattr(modaltest, "virtual_modal_test", fake_test)
    freq, shapes = modaltest.virtual_measured_modes(fe)
    truth = _truth()
    np.testing.assert_array_equal(freq, f_exp)
    np.testing.assert_array_equal(shapes, SIM_SHAPES[:, [truth[0], truth[1]]])
