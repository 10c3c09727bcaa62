"""Locating a mismatch (vlab.diagnose.fit.locate): a mode's curve fit that converges onto another resonance is
not that mode's frequency. Exact FRFs of the linear grid, open loop."""

from __future__ import annotations

import numpy as np
import pytest

from vlab.diagnose.effects import specedit
from vlab.diagnose.fit.locate import _at_own_peak, frf_modes, locate

from _grid_frfs import grid_problem


@pytest.fixture(scope="module")
def damped_mode_3():
    """The grid's mode 3 (1.64 Hz) damped to a ratio of 0.13: three half-power bandwidths of its curve fit
    reach from 0.4 to 2.9 Hz, over modes 1, 2 and 4 (2.74 Hz)."""
    return grid_problem(lambda spec: specedit.set_modal_damping(spec, 3, 0.13), "grid-damped-mode3.uff")


def test_a_heavily_damped_mode_keeps_its_own_peak(damped_mode_3):
    """Its single-mode fit converged on mode 4's peak (2.738 Hz, a +67 % 'frequency error' for a change of
    damping only); the picked peak (1.646 Hz) is kept instead, and no frequency error of that size is left
    for the sensitivity ranking to explain (it pruned the drawn spring away on the MuJoCo grid)."""
    problem, nominal = damped_mode_3
    mode3 = next(m for m in frf_modes(problem, nominal) if m.mode == 3)
    assert abs(mode3.freq_error) < 0.01
    assert all(abs(m.freq_error) < 0.01 for m in locate(problem, nominal).modes)


def test_own_peak_is_half_way_to_the_next():
    peaks = np.array([1.0, 1.6, 2.7])
    assert _at_own_peak(1.62, peaks, 1)
    assert not _at_own_peak(2.2, peaks, 1)  # nearer 2.7 than half-way from 1.6
    assert not _at_own_peak(float("nan"), peaks, 1)
    assert _at_own_peak(5.0, np.array([1.6]), 0)  # no other peak to have converged on
