"""The model-error floor of an FRF line where the modes' terms cancel.

The diagnosis allows every FRF line a relative model error, the floor
(:class:`vlab.diagnose.problem.residuals.Problem`, ``floor``): the model is a
sum of modal terms, and what the floor stands for -- a mode's effective mass,
its shape at a point, the far modes' residual, each known to a fraction of a
per cent -- is an error of each *term*. Where one term dominates the sum (at
a resonance) the line's relative error is the term's. Where terms of
opposite sign cancel (an antiresonance, the valley between two modes, the
residual of the modes above the band against the one below) the same term
errors make a far larger relative error of their small sum. With an
independent relative error ``epsilon`` of each term ``t_g`` (first-order
propagation, GUM JCGM 100:2008 Eq. (10))::

    sigma_rel(f) = epsilon * kappa(f),   kappa(f) = sqrt(sum_g |dH/d ln c_g|^2) / |H(f)|

``kappa`` is the cancellation ratio: 1 for a single term, ``sqrt(sum |t_g|^2) / |sum t_g|`` in open loop,
large in a valley. ``c_g`` scales the contribution of a group of modes (their shapes by ``sqrt(c_g)``
at every point, a modal-mass error), and ``dH/d ln c_g`` is taken through the whole prediction, the
loop included (:func:`vlab.diagnose.model.labmodel.predict_frf`). Each mode within
:data:`vlab.diagnose.model.modelform.BAND_MARGIN` of the lines is its own term; the modes below and
above are each one term (the residual of the modes outside the band, Ewins, *Modal Testing*, 2nd ed.,
2000, Sec. 4.3.4: one residual per side, not a mode each). The floor of a line is then
``floor * max(1, kappa)``: never below the floor itself, which also stands for the errors common to all
terms (a sensor's calibration).

Why it matters: two models of the same structure that agree within a fraction of a per cent on every
mode (an independent simulator's BCC: modes 1-6 within 0.15 %) differ by 5-50 % at the valleys of
points far from the excitation, where their terms cancel; a floor of the line alone calls that a
mismatch, one of the terms does not.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from .labmodel import LabState, point_modes_of, predict_frf
from .modelform import BAND_MARGIN

#: Relative change of a group's contribution for its finite-difference sensitivity [-].
STEP = 1e-4
#: Cancellation ratios kept for the last lab states and line grids (the nominal lab is asked many times).
CACHE_SIZE = 8

_CACHE: list = []


def mode_groups(natural_hz: np.ndarray, freq_hz: np.ndarray) -> list[np.ndarray]:
    """The terms whose errors are independent: each mode within :data:`BAND_MARGIN` of the lines alone, the
    modes below and those above as one group each.

    Parameters
    ----------
    natural_hz : ndarray, shape (n_modes,)
        Natural frequencies [Hz].
    freq_hz : ndarray, shape (n_f,)
        The lines [Hz].

    Returns
    -------
    list of ndarray of int
        Mode indices of each group (empty groups left out).
    """
    fn = np.asarray(natural_hz, dtype=float)
    lo, hi = float(np.min(freq_hz)) / BAND_MARGIN, float(np.max(freq_hz)) * BAND_MARGIN
    inside = np.flatnonzero((fn >= lo) & (fn <= hi))
    groups = [np.array([r]) for r in inside] + [np.flatnonzero(fn < lo), np.flatnonzero(fn > hi)]
    return [g for g in groups if g.size]


def cancellation_ratio(state: LabState, freq_hz: np.ndarray, *, excitation_point: int,
                       output_points) -> np.ndarray:
    """``kappa``, the relative error of each FRF line per unit relative error of each modal term (module notes).

    Parameters
    ----------
    state : LabState
        The lab the data are compared with (its point modes when set, else its FE model's modes).
    freq_hz : ndarray, shape (n_f,)
        The lines [Hz].
    excitation_point : int
    output_points : sequence of int, length n_o

    Returns
    -------
    ndarray, shape (n_f, n_o)
        ``kappa`` [1]; 1 where the prediction is zero or not finite.

    Raises
    ------
    ModelError
        As :func:`vlab.diagnose.model.labmodel.predict_frf`.
    """
    f = np.asarray(freq_hz, dtype=float)
    outs = tuple(output_points)
    key = (id(state), f.tobytes(), int(excitation_point), outs)
    for k, held, value in _CACHE:
        if k == key and held is state:
            return value
    pts = tuple(dict.fromkeys(outs + tuple(state.actuators) + tuple(p for p, _ in state.dashpots)
                              + tuple(p for p, _f, _c in state.frictions)))
    pm0 = point_modes_of(state, pts)
    kw = {"excitation_point": excitation_point, "output_points": outs}
    h0 = predict_frf(replace(state, point_modes=pm0), f, **kw)
    total = np.zeros(h0.shape)
    for g in mode_groups(pm0.omega / (2 * np.pi), f):
        shapes = pm0.shapes.copy()
        shapes[:, g] *= np.sqrt(1.0 + STEP)
        h = predict_frf(replace(state, point_modes=replace(pm0, shapes=shapes)), f, **kw)
        total += np.abs((h - h0) / STEP) ** 2
    with np.errstate(divide="ignore", invalid="ignore"):
        kappa = np.sqrt(total) / np.abs(h0)
    kappa = np.where(np.isfinite(kappa), kappa, 1.0)
    _CACHE.insert(0, (key, state, kappa))
    del _CACHE[CACHE_SIZE:]
    return kappa


def line_floor(state: LabState, freq_hz: np.ndarray, floor: float, *, excitation_point: int,
               output_points) -> np.ndarray:
    """The relative model error allowed each line: ``floor * max(1, kappa)`` (module notes).

    Parameters
    ----------
    state, freq_hz, excitation_point, output_points
        As :func:`cancellation_ratio`.
    floor : float
        The relative error of one modal term [1].

    Returns
    -------
    ndarray, shape (n_f, n_o)
        [1].

    Raises
    ------
    ModelError
        As :func:`cancellation_ratio`.
    """
    if floor == 0:
        return np.zeros((len(freq_hz), len(tuple(output_points))))
    kappa = cancellation_ratio(state, freq_hz, excitation_point=excitation_point, output_points=output_points)
    return float(floor) * np.maximum(1.0, kappa)
