"""A lab's modes changed one parameter at a time, and the FRFs of all those changes computed together.

The uncertain modal parameters of the model form
(:class:`vlab.diagnose.model.modelform.FrfModelForm`) are a mode's angular
frequency and damping ratio, moved by a factor ``exp(u)``, and its shape at
one point, moved by ``u`` times the RMS of the shape over the points. Their
sensitivities and the model-form profile's Jacobian
(:mod:`vlab.diagnose.problem.nuisance`) need the FRFs of the lab with each
parameter changed on its own. A change of mode ``r`` changes only the
``r``-th term of the classical modal sum (Eq. (3.1))::

    alpha_c(w) = alpha(w) + phi'_r phi'_r^T / (w'_r^2 - w^2 + 2 j zeta'_r w'_r w)
                          - phi_r  phi_r^T  / (w_r^2  - w^2 + 2 j zeta_r  w_r  w)

so the plants of ``k`` changes are the nominal sum plus ``k`` one-mode
corrections, and the loop is closed around all of them in one batched solve
(:func:`vlab.diagnose.model.labmodel.closed_loop_frf`). Where the plant is not
a classical modal sum (a damping coupling of the modes, point dashpots or
friction) each change is predicted on its own with
:func:`~vlab.diagnose.model.labmodel.predict_frf` (the same FRFs, ``k`` times
the cost).

Source: Eq. (3.1) (modal superposition); the loop as in :mod:`.labmodel`
(Fig. 21).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ...errors import ModelError
from .labmodel import LabState, PointModes, closed_loop_frf, frequencies, predict_frf

KINDS = ("f", "zeta", "phi")


def moved_modes(pm: PointModes, changes, ref: PointModes | None = None) -> PointModes:
    """``pm`` with every change of ``changes`` applied: ``(kind, r, j, u)`` scales mode ``r``'s angular frequency
    (``"f"``) or damping ratio (``"zeta"``) by ``exp(u)``, or moves its shape at the ``j``-th point (row of
    ``pm.shapes``, ``"phi"``) by ``u`` times the RMS over the points of the shape of mode ``r`` in ``ref``
    (default ``pm`` itself). The changes commute (products and sums).

    Parameters
    ----------
    pm : PointModes
    changes : sequence of (str, int, int or None, float)
        Kind, mode index (from 0), point row (``"phi"`` only) and the relative change ``u`` [1].
    ref : PointModes, optional
        The modes whose shapes' RMS scales a shape change.

    Returns
    -------
    PointModes
        A copy (the arrays of ``pm`` are not changed).

    Raises
    ------
    ValueError
        An unknown kind.
    """
    om, ze, sh = pm.omega.copy(), pm.zeta.copy(), pm.shapes
    ref_sh = (pm if ref is None else ref).shapes
    copied = False
    for kind, r, j, u in changes:
        if kind == "f":
            om[r] *= math.exp(u)
        elif kind == "zeta":
            ze[r] *= math.exp(u)
        elif kind == "phi":
            if not copied:
                sh, copied = sh.copy(), True
            sh[j, r] += u * float(np.sqrt(np.mean(ref_sh[:, r] ** 2)))
        else:
            raise ValueError(f"unknown modal parameter kind {kind!r} (one of {KINDS})")
    return replace(pm, omega=om, zeta=ze, shapes=sh)


def _classical(state: LabState, pm: PointModes) -> bool:
    """Whether the plant of ``state`` with modes ``pm`` is the classical modal sum alone."""
    return (pm.coupling is None and not any(c > 0.0 for _p, c in state.dashpots)
            and not any(c > 0.0 for _p, _f, c in state.frictions))


def changed_mode_frfs(state: LabState, pm: PointModes, changes, freq_hz: np.ndarray, *, excitation_point: int,
                      output_points, ref: PointModes | None = None) -> tuple[np.ndarray, np.ndarray]:
    """FRFs of the lab ``state`` with the modes ``pm``, and with each change of ``changes`` made on its own.

    Parameters
    ----------
    state : LabState
        The lab (its chain, controller, dashpots); its structure's modes are replaced by ``pm``.
    pm : PointModes
        Modes at (at least) the output and actuator points.
    changes : sequence of (str, int, int or None, float)
        One-parameter changes as in :func:`moved_modes`, length k.
    freq_hz : ndarray, shape (n_f,)
        Frequencies [Hz].
    excitation_point : int
    output_points : sequence of int, length n_o
    ref : PointModes, optional
        As in :func:`moved_modes`.

    Returns
    -------
    h0 : ndarray, complex, shape (n_f, n_o)
        :func:`~vlab.diagnose.model.labmodel.predict_frf` of ``state`` with ``pm`` [(m/s)/N].
    h : ndarray, complex, shape (k, n_f, n_o)
        The same with each change made [(m/s)/N].

    Raises
    ------
    ModelError
        As :func:`~vlab.diagnose.model.labmodel.predict_frf` (an excitation point that is not an actuator, a
        point the modes do not carry).
    """
    outs, acts = tuple(output_points), state.actuators
    f = np.asarray(freq_hz, dtype=float)
    kw = {"excitation_point": excitation_point, "output_points": outs}
    if not _classical(state, pm):
        h0 = predict_frf(replace(state, point_modes=pm), f, **kw)
        hs = [predict_frf(replace(state, point_modes=moved_modes(pm, [c], ref)), f, **kw) for c in changes]
        return h0, np.stack(hs) if hs else np.zeros((0,) + h0.shape, dtype=complex)
    if excitation_point not in acts:
        raise ModelError(f"excitation point {excitation_point} is not an actuator point {acts}")
    w = 2 * np.pi * frequencies(f)
    rows, cols = pm.rows(outs + acts), pm.rows(acts)                        # (n_p, n), (n_a, n)
    g0 = 1j * w[:, None, None] * _modal_sum(pm.omega, pm.zeta, rows, cols, w)
    if not changes:
        return closed_loop_frf(state, f, g0, **kw), np.zeros((0,) + (f.size, len(outs)), dtype=complex)
    r = np.array([c[1] for c in changes])
    new = [moved_modes(pm, [c], ref) for c in changes]
    om1, ze1 = np.array([m.omega[i] for m, i in zip(new, r)]), np.array([m.zeta[i] for m, i in zip(new, r)])
    rows1 = np.stack([m.rows(outs + acts)[:, i] for m, i in zip(new, r)])  # (k, n_p)
    cols1 = np.stack([m.rows(acts)[:, i] for m, i in zip(new, r)])         # (k, n_a)
    delta = (_mode_terms(om1, ze1, rows1, cols1, w)
             - _mode_terms(pm.omega[r], pm.zeta[r], rows[:, r].T, cols[:, r].T, w))
    h = closed_loop_frf(state, f, np.concatenate([g0[None], g0[None] + 1j * w[None, :, None, None] * delta]), **kw)
    return h[0], h[1:]


def _modal_sum(omega, zeta, rows, cols, w) -> np.ndarray:
    """Classical receptance ``sum_r rows[:, r] cols[:, r]^T / den_r(w)``, shape (n_f, n_p, n_a) [m/N]."""
    den = omega[None, :] ** 2 - w[:, None] ** 2 + 2j * zeta[None, :] * omega[None, :] * w[:, None]
    pp = (rows[:, None, :] * cols[None, :, :]).reshape(-1, len(omega))   # (n_p n_a, n)
    return ((1.0 / den) @ pp.T).reshape(w.size, rows.shape[0], cols.shape[0])


def _mode_terms(omega, zeta, rows, cols, w) -> np.ndarray:
    """The terms of :func:`_modal_sum` of ``k`` modes (``omega``, ``zeta`` shape (k,), ``rows`` (k, n_p),
    ``cols`` (k, n_a)), each on its own, shape (k, n_f, n_p, n_a) [m/N]."""
    den = omega[:, None] ** 2 - w[None, :] ** 2 + 2j * (zeta * omega)[:, None] * w[None, :]   # (k, n_f)
    return (rows[:, :, None] * cols[:, None, :])[:, None, :, :] / den[:, :, None, None]
