"""One-to-one MAC pairing of FE and plant modes over a common band.

The trap (found on the grid): FE modes n and n+1 look alike at the measured
points, plant mode n+1 resembles FE mode n slightly better than plant mode n
does, and FE mode n+1 -- the true partner of plant mode n+1 -- lies just
above the compared modes. An assignment of FE modes 1..n against all plant
modes then hands plant mode n+1 to FE mode n. The references here are a
brute-force search over all one-to-one assignments and a MAC written out in
the test, not vlab's own output.
"""

from __future__ import annotations

import importlib
import itertools
import math

import numpy as np
import pytest

import vlab.fe
from vlab.fe.modal import Modes
from vlab.sim import SimOptions, build_plant
from vlab.sim.crosscheck import crosscheck
from vlab.sim.linearize import SimModes
from vlab.sim.pairing import pair_band, pair_modes
from vlab.spec import load_spec

xc = importlib.import_module("vlab.sim.crosscheck")  # the module (vlab.sim.crosscheck is the function)
N_PTS = 6


def _unit(deg: float) -> np.ndarray:
    """A shape in the plane of points 2 and 3 at ``deg`` degrees (points 1, 4.. zero)."""
    v = np.zeros(N_PTS)
    v[1], v[2] = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    return v


def _e(i: int) -> np.ndarray:
    v = np.zeros(N_PTS)
    v[i] = 1.0
    return v


# FE modes 2 and 3 are 16 degrees apart at the points; plant mode 3 lies between them, plant mode 2 on the far side
# of FE mode 2. MAC = cos^2 of the angle: FE2-P2 0.915, FE2-P3 0.970, FE3-P3 0.989, FE3-P2 0.703 (the grid's FE
# modes 12/13 and plant modes 12/13: 0.914, 0.973, 0.988, 0.713).
FE_HZ = np.array([1.0, 2.0, 2.06, 4.0])
FE_SHAPES = np.column_stack([_e(0), _unit(0.0), _unit(16.0), _e(3)])
SIM_HZ = np.array([1.0, 1.94, 2.03, 4.1])
SIM_SHAPES = np.column_stack([_e(0), _unit(-17.0), _unit(10.0), _e(3)])


def _mac(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.dot(a, b) ** 2 / (np.dot(a, a) * np.dot(b, b)))


def _brute_force(fe: np.ndarray, sim: np.ndarray) -> dict[int, int]:
    """Best one-to-one assignment (FE column -> plant column) by total MAC, over all permutations."""
    best, arg = -1.0, None
    for perm in itertools.permutations(range(sim.shape[1]), fe.shape[1]):
        tot = sum(_mac(fe[:, r], sim[:, c]) for r, c in enumerate(perm))
        if tot > best:
            best, arg = tot, perm
    return dict(enumerate(arg))


def test_synthetic_case_is_the_trap():
    # FE mode 2 alone resembles plant mode 3 more than plant mode 2 ...
    assert _mac(FE_SHAPES[:, 1], SIM_SHAPES[:, 2]) > _mac(FE_SHAPES[:, 1], SIM_SHAPES[:, 1])
    # ... but over FE modes 2 and 3 together the one-to-one optimum is 2-2, 3-3
    assert _brute_force(FE_SHAPES, SIM_SHAPES) == {0: 0, 1: 1, 2: 2, 3: 3}


def test_pair_band_pairs_one_to_one_over_the_band():
    bp = pair_band(FE_HZ, FE_SHAPES, SIM_HZ, SIM_SHAPES, 2)
    best = _brute_force(FE_SHAPES[:, :3], SIM_SHAPES[:, :3])  # everything below (1 + margin)^2 x 2 Hz
    assert bp.fe_to_sim[:3] == tuple(best[r] for r in range(3))
    assert bp.fe_to_sim[1] == 1
    assert bp.macs[1] == pytest.approx(math.cos(math.radians(17.0)) ** 2, rel=1e-12)
    assert bp.unpaired == ()


def _fake_fe(fe, hz, shapes_at_points, points):
    """modal_analysis stand-in: ``hz`` and ``shapes_at_points`` at the points' w rows, zero elsewhere."""
    rows = [fe.dofs.index(p, "w") for p in points]

    def modal_analysis(m, k, n_modes=None):
        n = hz.size if n_modes is None else min(n_modes, hz.size)
        full = np.zeros((m.shape[0], hz.size))
        full[rows, :] = shapes_at_points
        return Modes(hz[:n].copy(), full[:, :n], 2 * np.pi * hz[:n])

    return modal_analysis


def _fake_modes(hz, shapes):
    def modes(model, points, n_modes=None, **_kw):
        n = hz.size if n_modes is None else min(n_modes, hz.size)
        z = np.zeros(n)
        return SimModes(hz[:n].copy(), z, tuple(points), shapes[:, :n].copy(), np.zeros((model.nv, n)),
                        np.eye(model.nv))

    return modes


@pytest.fixture(scope="module")
def bcc_plant():
    return build_plant(load_spec("bcc"), SimOptions(modal_damping=False))


def _synthetic_crosscheck(monkeypatch, plant, fe_hz, fe_shapes, sim_hz, sim_shapes, n_modes):
    """``crosscheck`` on the BCC plant with its FE and plant modes replaced by the synthetic ones."""
    fe = xc.fe_reference(plant.spec)
    points = [p for p in sorted(plant.spec.points) if (p, "w") in fe.dofs]
    assert len(points) >= N_PTS
    pad = np.zeros((len(points) - N_PTS, fe_shapes.shape[1]))
    pad_s = np.zeros((len(points) - N_PTS, sim_shapes.shape[1]))
    monkeypatch.setattr(vlab.fe, "modal_analysis", _fake_fe(fe, fe_hz, np.vstack([fe_shapes, pad]), points))
    monkeypatch.setattr(xc, "modes", _fake_modes(sim_hz, np.vstack([sim_shapes, pad_s])))
    return crosscheck(plant, n_modes)


def test_crosscheck_does_not_hand_the_next_modes_partner_to_the_last_mode(monkeypatch, bcc_plant):
    """Failed before the fix: FE mode 2 was paired with plant mode 3 (+1.5 %) while FE mode 3 was left out."""
    cc = _synthetic_crosscheck(monkeypatch, bcc_plant, FE_HZ, FE_SHAPES, SIM_HZ, SIM_SHAPES, 2)
    assert [p.sim_mode for p in cc.pairs] == [1, 2]
    assert cc.pairs[1].error_pct == pytest.approx(100 * (1.94 - 2.0) / 2.0, rel=1e-12)
    assert cc.pairs[1].mac == pytest.approx(math.cos(math.radians(17.0)) ** 2, rel=1e-12)
    assert cc.unpaired == ()


def test_unpaired_plant_mode_is_reported(monkeypatch, bcc_plant):
    """A plant mode in the band with a shape no FE mode has (point 5 alone) is listed, with its frequency."""
    sim_hz = np.array([1.0, 1.5, 1.94, 2.03, 4.1])
    sim_shapes = np.column_stack([_e(0), _e(4), _unit(-17.0), _unit(10.0), _e(3)])
    cc = _synthetic_crosscheck(monkeypatch, bcc_plant, FE_HZ, FE_SHAPES, sim_hz, sim_shapes, 2)
    assert [p.sim_mode for p in cc.pairs] == [1, 3]
    assert len(cc.unpaired) == 1
    u = cc.unpaired[0]
    assert (u.sim_mode, u.sim_hz, u.best_mac) == (2, 1.5, 0.0)
    assert "does not have" in u.reason
    assert "plant mode 2 (1.5000 Hz)" in cc.table()


def test_low_mac_pair_is_not_forced():
    """FE mode 2 resembles its only candidate at MAC 0.25 < 0.5: unpaired, and the plant mode is reported."""
    fe_shapes = np.column_stack([_e(0), _unit(0.0)])
    sim_shapes = np.column_stack([_e(0), _unit(60.0)])
    assert _mac(fe_shapes[:, 1], sim_shapes[:, 1]) == pytest.approx(0.25)
    bp = pair_band(np.array([1.0, 2.0]), fe_shapes, np.array([1.0, 2.05]), sim_shapes, 2)
    assert bp.fe_to_sim == (0, None)
    assert bp.macs[1] == pytest.approx(0.25)
    assert [u.sim_mode for u in bp.unpaired] == [2]
    assert pair_modes(fe_shapes, sim_shapes)[1] == (None, pytest.approx(0.25))


def test_second_plant_mode_like_a_paired_fe_mode_is_reported_with_its_rival():
    """Two plant modes resemble one FE mode (the BCC crosspiece arms): the better one pairs, the other is named."""
    fe_shapes = np.column_stack([_e(0), _unit(0.0)])
    sim_shapes = np.column_stack([_e(0), _unit(30.0), _unit(5.0)])
    bp = pair_band(np.array([1.0, 2.0]), fe_shapes, np.array([1.0, 1.9, 2.02]), sim_shapes, 2)
    assert bp.fe_to_sim == (0, 2)
    (u,) = bp.unpaired
    assert (u.sim_mode, u.best_fe_mode) == (2, 2)
    assert u.best_mac == pytest.approx(0.75)
    assert "paired with plant mode 3" in u.reason


def test_pair_band_bad_input():
    with pytest.raises(xc.SimulationError, match="n_modes = 5"):
        pair_band(FE_HZ, FE_SHAPES, SIM_HZ, SIM_SHAPES, 5)
    with pytest.raises(xc.SimulationError, match="FE shapes"):
        pair_band(FE_HZ[:3], FE_SHAPES, SIM_HZ, SIM_SHAPES, 2)
    with pytest.raises(xc.SimulationError, match="mesh = 'fine'"):
        crosscheck(load_spec("bcc"), 2, mesh="fine")
