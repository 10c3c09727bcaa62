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
corrections, and the loop is closed around them in batched solves of
:data:`BLOCK` changes (:func:`vlab.diagnose.model.labmodel.closed_loop_frf`). Where the plant is not
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
from ...measure.mac import mac, pair_modes
from .labmodel import LabState, PointModes, closed_loop_frf, frequencies, modal_receptance, predict_frf

KINDS = ("f", "zeta", "phi")
#: ``PointModes.source`` of reference modes moved as a lab's FE modes move (:func:`moved_like`): their modes
#: are the reference's, one for one, in its order.
MOVED_REFERENCE = "the reference modes, moved as the lab's FE modes move"
#: Modes are paired where their shapes at the points are more alike than not (MAC at least this) ...
PAIR_MAC = 0.5
#: ... and their frequencies lie within this ratio (the pairing of a model form's parameters with a lab's modes).
PAIR_RATIO = 1.2
#: Changes whose plants are held in memory together (each block holds BLOCK x n_f x n_p x n_act complex numbers).
BLOCK = 32


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
        An unknown kind, or a shape change without its point row.
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
            if j is None:
                raise ValueError(f"a shape change of mode {r} needs its point row, got None")
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
    g0 = 1j * w[:, None, None] * modal_receptance(pm.omega, pm.zeta, rows, w)[:, :, len(outs):]
    h0 = closed_loop_frf(state, f, g0, **kw)
    hs = [_changed_block(state, pm, changes[i:i + BLOCK], ref, f, w, g0, rows, cols, kw)
          for i in range(0, len(changes), BLOCK)]
    return h0, np.concatenate(hs) if hs else np.zeros((0,) + h0.shape, dtype=complex)


def _changed_block(state, pm, changes, ref, f, w, g0, rows, cols, kw) -> np.ndarray:
    """:func:`changed_mode_frfs`' FRFs of the changes ``changes`` (the plant ``g0`` with one mode's term
    replaced each), shape (len(changes), n_f, n_o)."""
    outs, acts = kw["output_points"], state.actuators
    r = np.array([c[1] for c in changes])
    new = [moved_modes(pm, [c], ref) for c in changes]
    om1, ze1 = np.array([m.omega[i] for m, i in zip(new, r)]), np.array([m.zeta[i] for m, i in zip(new, r)])
    rows1 = np.stack([m.rows(outs + acts)[:, i] for m, i in zip(new, r)])  # (k, n_p)
    cols1 = np.stack([m.rows(acts)[:, i] for m, i in zip(new, r)])         # (k, n_a)
    delta = (_mode_terms(om1, ze1, rows1, cols1, w)
             - _mode_terms(pm.omega[r], pm.zeta[r], rows[:, r].T, cols[:, r].T, w))
    return closed_loop_frf(state, f, g0[None] + 1j * w[None, :, None, None] * delta, **kw)


def _mode_terms(omega, zeta, rows, cols, w) -> np.ndarray:
    """The terms of the classical modal sum (:func:`~vlab.diagnose.model.labmodel.modal_receptance`) of ``k``
    modes (``omega``, ``zeta`` shape (k,), ``rows`` (k, n_p), ``cols`` (k, n_a)), each on its own, shape
    (k, n_f, n_p, n_a) [m/N]."""
    den = omega[:, None] ** 2 - w[None, :] ** 2 + 2j * (zeta * omega)[:, None] * w[None, :]   # (k, n_f)
    return (rows[:, :, None] * cols[:, None, :])[:, None, :, :] / den[:, :, None, None]


def moved_like(ref: PointModes, before: PointModes, after: PointModes, top_hz: float) -> PointModes:
    """The reference modes ``ref`` changed as the FE modes ``before`` change into ``after``: each mode of ``ref``
    below ``top_hz`` paired with a mode of ``before``, and that with a mode of ``after`` (one to one, by MAC at
    the points, at least :data:`PAIR_MAC`, within :data:`PAIR_RATIO` in frequency), takes the FE mode's change:
    its angular frequency and damping ratio the ratio ``after / before``, its shape the difference (signs
    aligned). A reference mode without a pair (one the FE model lacks, such as a plant's second crosspiece
    arm) keeps its values.

    Why: a model form's parameters are modes of the reference (the plant the data were referred through); a
    lab of a changed structure moved within them is on the nominal lab's footing only if its modes are the
    reference's as changed by the lab's change (first order in the change).

    Parameters
    ----------
    ref : PointModes
        The reference modes (a model form's ``modes``).
    before, after : PointModes
        The FE modes of the nominal and of the changed lab at ``ref.points``.
    top_hz : float
        Reference modes above this frequency [Hz] keep their values.

    Returns
    -------
    PointModes
        ``ref``'s modes in its order (source :data:`MOVED_REFERENCE`, classical damping).

    Raises
    ------
    ModelError
        ``before`` or ``after`` not at ``ref.points``.
    """
    if tuple(before.points) != tuple(ref.points) or tuple(after.points) != tuple(ref.points):
        raise ModelError(f"modes at {before.points} and {after.points} cannot move the reference's at {ref.points}")
    band = 2 * np.pi * top_hz
    r_in = np.flatnonzero(ref.omega <= band)
    b_in = np.flatnonzero(before.omega <= PAIR_RATIO * band)
    a_in = np.flatnonzero(after.omega <= PAIR_RATIO**2 * band)
    to_before = _pairs(ref, before, r_in, b_in)
    to_after = _pairs(before, after, b_in, a_in)
    om, ze, sh = ref.omega.copy(), ref.zeta.copy(), ref.shapes.copy()
    for r, n in to_before.items():
        if n not in to_after:
            continue
        s = to_after[n]
        pb, pa = before.shapes[:, n], after.shapes[:, s]
        om[r] *= after.omega[s] / before.omega[n]
        ze[r] *= after.zeta[s] / before.zeta[n] if before.zeta[n] > 0 else 1.0
        sh[:, r] += np.sign(ref.shapes[:, r] @ pb) * (np.sign(pa @ pb) * pa - pb)
    return replace(ref, omega=om, zeta=ze, shapes=sh, coupling=None, source=MOVED_REFERENCE)


def _pairs(a: PointModes, b: PointModes, ia: np.ndarray, ib: np.ndarray) -> dict:
    """Modes ``ia`` of ``a`` paired one to one with modes ``ib`` of ``b`` (:func:`moved_like`): index -> index."""
    ia = ia[(np.linalg.norm(a.shapes[:, ia], axis=0) > 0) & (a.omega[ia] > 0)]  # a mode seen at the points
    ib = ib[(np.linalg.norm(b.shapes[:, ib], axis=0) > 0) & (b.omega[ib] > 0)]
    if not ia.size or not ib.size:
        return {}
    m = mac(a.shapes[:, ia], b.shapes[:, ib])
    far = np.abs(np.log(a.omega[ia][:, None] / b.omega[ib][None, :])) > np.log(PAIR_RATIO)
    m[far] = 0.0
    return {int(ia[i]): int(ib[j]) for i, j, _v in pair_modes(m, threshold=PAIR_MAC)}
