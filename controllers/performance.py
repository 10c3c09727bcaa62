"""Closed-loop modes (damping ratios, frequencies) and quadratic performance indices.

Modes
-----
The eigenvalues of a real closed-loop matrix are listed as *modes*: one entry
per complex-conjugate pair (the one with ``Im > 0``) and one entry per real
eigenvalue, sorted by undamped natural frequency ``|lambda|``. The damping
ratio is ``zeta = -Re(lambda) / |lambda|`` (1 for a stable real eigenvalue,
negative when unstable). When counting "the first n_m modes" a real
eigenvalue counts as half a mode, so an over-damped mode (two real
eigenvalues) never pushes a lightly damped one out of the set.

Performance index
-----------------
For a stable closed loop ``x' = A_cl x`` and cost ``J = int_0^inf x^T Q_cl x dt``,
``J = x0^T P x0`` with ``A_cl^T P + P A_cl + Q_cl = 0`` (Eqs. 4.33-4.36,
4.18-4.22, 4.26-4.29). Lyapunov equations are solved by
:func:`scipy.linalg.solve_continuous_lyapunov`.

Sensitivities (used by the DRF optimisers, :mod:`controllers.drf`)
-----------------------------------------------------------------
For velocity feedback ``u = -D y``, ``A_cl = A - B D C``:

* damping ratios: ``d lambda / dD = -(w^H B)^T (C v) / (w^H v)`` with the
  left/right eigenvectors ``w, v`` of ``lambda = sigma + i w``, and
  ``d zeta = (-w^2 d sigma + sigma w d w) / |lambda|^3``
  (:func:`closed_loop_damping`);
* performance index: with the adjoint ``A_cl L + L A_cl^T + x0 x0^T = 0``,
  ``dJ/dD = -2 B^T P L C^T + 2 R D C L C^T`` (:func:`performance_gradient`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg
from scipy.optimize import linear_sum_assignment

from .errors import (
    MatrixPropertyError,
    ShapeError,
    check_matrix,
    check_positive_scalar,
    check_positive_semidefinite,
    check_square,
    readonly,
)

__all__ = [
    "Modes",
    "modes",
    "select_modes",
    "lyapunov_cost_matrix",
    "performance_index",
    "feedback_performance",
    "SpilloverReport",
    "pair_modes",
    "spillover",
    "closed_loop_damping",
    "performance_gradient",
]


# --------------------------------------------------------------------------- input checks
def _check_state_input(A, B) -> tuple[np.ndarray, np.ndarray]:
    """``A`` (2n, 2n) and ``B`` (2n, n_c) checked (:func:`controllers.errors.check_matrix`) as float arrays."""
    A = check_square("A", A, "2n")
    B = check_matrix("B", B, (A.shape[0], None), ("2n", "n_c"))
    return A, B


def _check_plant(A, B, C) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``A`` (2n, 2n), ``B`` (2n, n_c) and ``C`` (n_c, 2n) of a DRF loop ``u = -D C x``, checked."""
    A, B = _check_state_input(A, B)
    n, nc = B.shape
    C = check_matrix("C", C, (nc, n), ("n_c", "2n"))
    return A, B, C


def _cost_weights(Q, R, n: int, nc: int) -> tuple[np.ndarray, np.ndarray]:
    """``Q`` (2n, 2n) and ``R`` (n_c, n_c) of a performance index (Eq. 4.33), checked symmetric PSD; ``n`` is 2n."""
    Q = check_positive_semidefinite("Q", check_matrix("Q", Q, (n, n), ("2n", "2n")))
    R = check_positive_semidefinite("R", check_matrix("R", R, (nc, nc), ("n_c", "n_c")))
    return Q, R


def _initial_states(initial_states, n_states: int, symbol: str = "2n") -> np.ndarray:
    """The initial states ``x0_i`` of the performance indices as columns: shape (n_states, n_f)."""
    return check_matrix("initial_states", initial_states, (n_states, None), (symbol, "n_f"))


# --------------------------------------------------------------------------- modes
def _mode_order(eigs: np.ndarray) -> np.ndarray:
    """Indices of the mode entries of ``eigs`` (Im > 0 or Im == 0), sorted by |lambda|."""
    eigs = np.asarray(eigs)
    # LAPACK returns exact conjugate pairs and exactly real (Im == 0) eigenvalues
    # for real matrices, so "Im > 0 or Im == 0" keeps one entry per mode.
    keep = np.flatnonzero(eigs.imag >= 0)
    order = np.lexsort((eigs.real[keep], np.abs(eigs[keep])))
    return keep[order]


def _zeta(lam: np.ndarray) -> np.ndarray:
    r = np.abs(lam)
    with np.errstate(invalid="ignore", divide="ignore"):
        z = np.where(r > 0, -lam.real / np.where(r > 0, r, 1.0), 0.0)
    return z


def select_modes(eigs, n_modes: int | None = None) -> np.ndarray:
    """Indices into ``eigs`` of the first ``n_modes`` modes (see module notes).

    Parameters
    ----------
    eigs : array_like of complex, shape (N,)
        Eigenvalues of a real matrix.
    n_modes : int, optional
        ``n_m``; a real eigenvalue counts one half. ``None``: all mode entries.

    Returns
    -------
    ndarray of int
        Indices sorted by ``|lambda|``.

    Raises
    ------
    ShapeError
        ``eigs`` not one-dimensional.
    MatrixPropertyError
        Negative ``n_modes``.
    """
    eigs = np.asarray(eigs)
    if eigs.ndim != 1:
        raise ShapeError(f"eigs: expected shape (N,), found {eigs.shape}")
    if n_modes is not None and n_modes < 0:
        raise MatrixPropertyError(f"n_modes: expected >= 0, found {n_modes}")
    order = _mode_order(eigs)
    if n_modes is None:
        return order
    weights = np.where(eigs[order].imag > 0, 1.0, 0.5)
    before = np.concatenate([[0.0], np.cumsum(weights)[:-1]])
    return order[before < n_modes - 1e-12]


@dataclass(frozen=True, eq=False)
class Modes:
    """Modes of a (closed-loop) system matrix.

    Attributes
    ----------
    eigenvalues : ndarray of complex, shape (n_modes,)
        One per mode, ``Im >= 0``, sorted by ``|lambda|`` [1/time unit].
    damping_ratios : ndarray, shape (n_modes,)
        ``zeta = -Re(lambda)/|lambda|`` [-].
    frequencies_hz : ndarray, shape (n_modes,)
        Undamped natural frequencies ``|lambda| / (2 pi time_unit_s)`` [Hz].
    """

    eigenvalues: np.ndarray
    damping_ratios: np.ndarray
    frequencies_hz: np.ndarray


def modes(A, *, n_modes: int | None = None, time_unit_s: float = 1.0) -> Modes:
    """Damping ratios and frequencies of the eigenvalues of ``A``.

    Parameters
    ----------
    A : array_like, shape (N, N)
        Real system matrix (open or closed loop) [1/time unit].
    n_modes : int, optional
        Keep the first ``n_m`` modes only (by frequency).
    time_unit_s : float
        Seconds per time unit of ``A`` (0.01 for cs) to report Hz.

    Returns
    -------
    Modes

    Raises
    ------
    ShapeError, MatrixPropertyError
        Non-square or non-finite ``A``; non-positive ``time_unit_s``.
    """
    A = check_square("A", A)
    t = check_positive_scalar("time_unit_s", time_unit_s)
    eigs = scipy.linalg.eigvals(A)
    idx = select_modes(eigs, n_modes)
    lam = eigs[idx]
    return Modes(
        readonly(lam), readonly(_zeta(lam)), readonly(np.abs(lam) / (2 * np.pi * t))
    )


#: Largest residual of the cost's Lyapunov equation accepted, relative to the weight: a residual ``R``
#: means the solution is the cost of the weight ``Q + R``, so ``||R|| <= 1e-4 ||Q||`` keeps ``J`` to about
#: four significant digits, more than the performance tables print.
LYAPUNOV_RESIDUAL = 1e-4


def _solve_lyapunov(A, Q) -> tuple[np.ndarray, float]:
    """``A X + X A^T = Q`` by :func:`scipy.linalg.solve_continuous_lyapunov` (Bartels-Stewart).

    Where LAPACK had to perturb the problem (its warning: an eigenvalue pair of ``A`` summing to nearly zero
    against its norm, as a slow, lightly damped pole beside fast ones), the solution is also computed through
    ``A``'s eigenvectors, ``A = V L V^-1``: ``X = V Y V^T`` with ``Y_ij = (V^-1 Q V^-T)_ij / (l_i + l_j)``;
    the one with the smaller residual is returned with its relative residual ``||A X + X A^T - Q||_F /
    ||Q||_F`` (0 where LAPACK solved it unperturbed).
    """
    import warnings

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", RuntimeWarning)
        X = scipy.linalg.solve_continuous_lyapunov(A, Q)
    if not any(issubclass(w.category, RuntimeWarning) for w in caught):
        return X, 0.0
    lam, V = np.linalg.eig(A)
    Vinv = np.linalg.inv(V)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        X2 = (V @ ((Vinv @ Q @ Vinv.T) / (lam[:, None] + lam[None, :])) @ V.T).real
        q = max(float(np.linalg.norm(Q)), np.finfo(float).tiny)
        res = [float(np.linalg.norm(A @ Z + Z @ A.T - Q)) / q for Z in (X, X2)]
    res = [r if np.isfinite(r) else np.inf for r in res]
    return (X, res[0]) if res[0] <= res[1] else (X2, res[1])


def lyapunov_cost_matrix(A_cl, Q_cl) -> np.ndarray:
    """Solve ``A_cl^T P + P A_cl + Q_cl = 0`` (Eqs. 4.21, 4.27, 4.34).

    Parameters
    ----------
    A_cl : array_like, shape (N, N)
        Closed-loop matrix; must be asymptotically stable.
    Q_cl : array_like, shape (N, N)
        Symmetric positive semi-definite cost weight.

    Returns
    -------
    ndarray, shape (N, N)
        Symmetric ``P``.

    Raises
    ------
    ShapeError, MatrixPropertyError
        Bad shapes, non-symmetric or indefinite ``Q_cl``; or a closed loop so close to marginal (an
        eigenvalue pair summing to nearly zero against its norm) that no solution of the equation leaves a
        residual below :data:`LYAPUNOV_RESIDUAL` (:func:`_solve_lyapunov`).
    """
    A_cl = check_square("A_cl", A_cl)
    n = A_cl.shape[0]
    Q_cl = check_matrix("Q_cl", Q_cl, (n, n), ("N", "N"))
    Q_cl = check_positive_semidefinite("Q_cl", Q_cl)
    P, err = _solve_lyapunov(A_cl.T, -Q_cl)
    if err > LYAPUNOV_RESIDUAL:
        slow = scipy.linalg.eigvals(A_cl)
        slow = slow[np.argmax(slow.real)]
        raise MatrixPropertyError(f"A_cl: the Lyapunov equation of the cost cannot be solved to working precision "
                                  f"(relative residual {err:.2g}; least-damped pole {slow:.4g} 1/s)")
    return 0.5 * (P + P.T)


def performance_index(A_cl, Q_cl, initial_states) -> np.ndarray:
    """Quadratic performance index ``J_i = x0_i^T P x0_i`` for each initial state.

    Parameters
    ----------
    A_cl : array_like, shape (N, N)
        Closed-loop matrix.
    Q_cl : array_like, shape (N, N)
        Cost weight, ``J = int_0^inf x^T Q_cl x dt``.
    initial_states : array_like, shape (N, n_f)
        One initial state per column.

    Returns
    -------
    ndarray, shape (n_f,)
        ``J_i`` [cost unit * time unit]; ``inf`` where the closed loop is not
        asymptotically stable (the integral diverges).

    Raises
    ------
    ShapeError, MatrixPropertyError
        Bad shapes or weights; a stable loop so close to marginal that its Lyapunov equation cannot be
        solved to :data:`LYAPUNOV_RESIDUAL` (:func:`lyapunov_cost_matrix`).

    Notes
    -----
    Source: Eqs. (4.20)-(4.21), (4.26)-(4.27), (4.33)-(4.34).
    """
    A_cl = check_square("A_cl", A_cl)
    n = A_cl.shape[0]
    X0 = _initial_states(initial_states, n, "N")
    Q_cl = check_positive_semidefinite("Q_cl", check_matrix("Q_cl", Q_cl, (n, n), ("N", "N")))
    if np.max(scipy.linalg.eigvals(A_cl).real) >= 0.0:
        return np.full(X0.shape[1], np.inf)
    P = lyapunov_cost_matrix(A_cl, Q_cl)
    return np.einsum("ij,ik,kj->j", X0, P, X0)


def feedback_performance(A, B, F, Q, R, initial_states) -> np.ndarray:
    """Performance index of a static feedback ``u = -F x`` (Eqs. 4.33-4.36).

    ``A~ = A - B F``, ``Q~ = Q + F^T R F``, ``J_i = x0_i^T P~ x0_i``. For direct
    rate feedback ``F = F_D = D C`` (Eq. 4.35: D at the sensor DOFs).

    Parameters
    ----------
    A : array_like, shape (2n, 2n)
    B : array_like, shape (2n, n_c)
    F : array_like, shape (n_c, 2n)
        Feedback gain [force per state unit].
    Q : array_like, shape (2n, 2n)
        State weight (positive semi-definite).
    R : array_like, shape (n_c, n_c)
        Control weight (positive semi-definite here; definite for LQR).
    initial_states : array_like, shape (2n, n_f)

    Returns
    -------
    ndarray, shape (n_f,)
        ``J_i``; ``inf`` if ``A - B F`` is not asymptotically stable.

    Raises
    ------
    ShapeError, MatrixPropertyError
    """
    A, B = _check_state_input(A, B)
    n, nc = B.shape
    F = check_matrix("F", F, (nc, n), ("n_c", "2n"))
    Q, R = _cost_weights(Q, R, n, nc)
    return performance_index(A - B @ F, Q + F.T @ R @ F, initial_states)


def pair_modes(eig_open, vec_open, eig_closed, vec_closed) -> np.ndarray:
    """Pair each open-loop mode with one closed-loop eigenvalue.

    Cost of a pair = ``(1 - overlap) + 0.1 * |lambda_cl - lambda_ol| / |lambda_ol|``
    where ``overlap = |v_ol^H v_cl[:N]|^2 / (|v_ol|^2 |v_cl|^2)`` compares the
    open-loop eigenvector with the plant part (first ``N`` rows) of the
    closed-loop eigenvector normalised over *all* its rows, so controller/
    estimator eigenvalues (small plant part) do not grab structural modes. The
    assignment minimises the total cost (Hungarian method).

    Parameters
    ----------
    eig_open : array_like of complex, shape (n_o,)
    vec_open : array_like of complex, shape (N, n_o)
    eig_closed : array_like of complex, shape (n_k,), n_k >= n_o
    vec_closed : array_like of complex, shape (N_cl, n_k), N_cl >= N

    Returns
    -------
    ndarray of int, shape (n_o,)
        Index into ``eig_closed`` for each open-loop mode.

    Raises
    ------
    ShapeError
        Inconsistent sizes or fewer closed-loop than open-loop candidates.
    """
    lo = np.asarray(eig_open).ravel()
    vo = np.asarray(vec_open)
    lc = np.asarray(eig_closed).ravel()
    vc = np.asarray(vec_closed)
    if vo.ndim != 2 or vo.shape[1] != lo.size:
        raise ShapeError(f"vec_open: expected shape (N, n_o) with n_o = {lo.size}, found {vo.shape}")
    if vc.ndim != 2 or vc.shape[1] != lc.size or vc.shape[0] < vo.shape[0]:
        raise ShapeError(
            f"vec_closed: expected shape (N_cl >= {vo.shape[0]}, n_k = {lc.size}), found {vc.shape}"
        )
    if lc.size < lo.size:
        raise ShapeError(f"eig_closed: need at least n_o = {lo.size} candidates, found {lc.size}")
    n = vo.shape[0]
    num = np.abs(vo.conj().T @ vc[:n]) ** 2
    den = np.outer(np.sum(np.abs(vo) ** 2, axis=0), np.sum(np.abs(vc) ** 2, axis=0))
    overlap = num / np.where(den > 0, den, 1.0)
    dist = np.abs(lc[None, :] - lo[:, None]) / np.maximum(np.abs(lo)[:, None], 1e-300)
    cost = (1.0 - overlap) + 0.1 * np.minimum(dist, 10.0)
    rows, cols = linear_sum_assignment(cost)
    out = np.empty(lo.size, dtype=int)
    out[rows] = cols
    return out


@dataclass(frozen=True, eq=False)
class SpilloverReport:
    """Open- vs closed-loop damping of every plant mode (spillover check, Sec. 6.2.1).

    Attributes
    ----------
    frequencies_hz : ndarray, shape (n_o,)
        Open-loop undamped frequencies [Hz], ascending; mode ``j`` is entry ``j-1``.
    open_loop_damping : ndarray, shape (n_o,)
    closed_loop_damping : ndarray, shape (n_o,)
        Damping of the paired closed-loop eigenvalue (see :func:`pair_modes`).
    closed_loop_eigenvalues : ndarray of complex, shape (n_o,)
    lowered : tuple of int
        1-based mode numbers whose damping the controller lowers.
    destabilised : tuple of int
        1-based mode numbers driven to zero or negative damping.
    """

    frequencies_hz: np.ndarray
    open_loop_damping: np.ndarray
    closed_loop_damping: np.ndarray
    closed_loop_eigenvalues: np.ndarray
    lowered: tuple[int, ...]
    destabilised: tuple[int, ...]


def spillover(A_open, A_closed, *, time_unit_s: float = 1.0, rtol: float = 1e-6) -> SpilloverReport:
    """Compare the damping of each open-loop plant mode with its closed-loop partner.

    Parameters
    ----------
    A_open : array_like, shape (N, N)
        Open-loop plant matrix (e.g. the full model ``A``).
    A_closed : array_like, shape (N_cl, N_cl), N_cl >= N
        Closed-loop matrix whose first ``N`` states are the plant states
        (e.g. ``A_E`` of Eq. (4.24), ``A - B D C``).
    time_unit_s : float
        Seconds per time unit, to report Hz.
    rtol : float
        A mode counts as "lowered" when ``zeta_cl < zeta_ol - rtol * max(zeta_ol, 1e-3)``.

    Returns
    -------
    SpilloverReport

    Raises
    ------
    ShapeError, MatrixPropertyError
        Non-square or too small ``A_closed``.

    Notes
    -----
    Source: Sec. 4.1.3 and Sec. 6.2.1 (modes 25, 26, 33 of the grid were
    "partially destabilized" by the reduced-model LQG controller).
    """
    Ao = check_square("A_open", A_open)
    Ac = check_square("A_closed", A_closed, "N_cl")
    if Ac.shape[0] < Ao.shape[0]:
        raise ShapeError(f"A_closed: expected at least {Ao.shape[0]} states, found {Ac.shape[0]}")
    t = check_positive_scalar("time_unit_s", time_unit_s)
    lo, vo = scipy.linalg.eig(Ao)
    io = select_modes(lo)
    lc, vc = scipy.linalg.eig(Ac)
    ic = select_modes(lc)
    pair = pair_modes(lo[io], vo[:, io], lc[ic], vc[:, ic])
    lam_c = lc[ic][pair]
    zo = _zeta(lo[io])
    zc = _zeta(lam_c)
    lowered = tuple(int(j + 1) for j in np.flatnonzero(zc < zo - rtol * np.maximum(zo, 1e-3)))
    destab = tuple(int(j + 1) for j in np.flatnonzero(zc <= 0.0))
    return SpilloverReport(
        readonly(np.abs(lo[io]) / (2 * np.pi * t)),
        readonly(zo),
        readonly(zc),
        readonly(lam_c),
        lowered,
        destab,
    )


# --------------------------------------------------------------------------- sensitivities
def _damping_and_gradient(A, B, C, D, n_modes):
    """zeta (n_m,), dzeta/dD (n_m, n_c, n_s), eigenvalues (n_m,) of the first n_m modes of A - B D C.

    Always exactly ``n_m`` slots: a pair of real eigenvalues (an over-damped
    mode, each counting one half) shares one slot, whose value is the smaller
    damping ratio of the entries in it.
    """
    Acl = A - B @ D @ C
    lam, vl, vr = scipy.linalg.eig(Acl, left=True, right=True)
    idx = select_modes(lam, n_modes)
    weights = np.where(lam[idx].imag > 0, 1.0, 0.5)
    slot_of = np.floor(np.concatenate([[0.0], np.cumsum(weights)[:-1]]) + 1e-12).astype(int)
    zeta = np.full(n_modes, np.inf)
    grad = np.zeros((n_modes, B.shape[1], C.shape[0]))
    lam_out = np.zeros(n_modes, dtype=complex)
    for k, slot in zip(idx, slot_of):
        lk = lam[k]
        mag = abs(lk)
        sig, om = lk.real, lk.imag
        z = -sig / mag if mag > 0 else 0.0
        if z >= zeta[slot]:
            continue
        zeta[slot] = z
        lam_out[slot] = lk
        grad[slot] = 0.0
        if om <= 0.0 or mag == 0.0:  # real eigenvalue: zeta = +-1, locally constant
            continue
        w, v = vl[:, k], vr[:, k]
        g = w.conj() @ B
        h = C @ v
        s = w.conj() @ v
        dlam = -np.outer(g, h) / s
        grad[slot] = (-(om**2) * dlam.real + sig * om * dlam.imag) / mag**3
    zeta[~np.isfinite(zeta)] = 1.0  # fewer eigenvalues than slots (cannot happen for n_m <= n)
    return zeta, grad, lam_out


def closed_loop_damping(A, B, C, D, *, n_modes: int) -> tuple[np.ndarray, np.ndarray]:
    """Damping ratios of the first ``n_m`` modes of ``A - B D C`` and their derivatives.

    ``d zeta / dD_ij`` from the eigenvalue derivative
    ``d lambda / dD = -(w^H B)^T (C v) / (w^H v)`` and
    ``d zeta = (-w^2 d sigma + sigma w d w) / |lambda|^3`` for ``lambda = sigma + i w``.

    Parameters
    ----------
    A : array_like, shape (2n, 2n)
    B : array_like, shape (2n, n_c)
    C : array_like, shape (n_c, 2n)
    D : array_like, shape (n_c, n_c)
        Any (not necessarily symmetric) gain.
    n_modes : int
        ``n_m`` (modes sorted by frequency, see :func:`controllers.performance.select_modes`).

    Returns
    -------
    zeta : ndarray, shape (n_m,)
        A pair of real eigenvalues (over-damped mode) fills one entry with
        the smaller of their damping ratios (1 when stable).
    dzeta_dD : ndarray, shape (n_m, n_c, n_c)
        Zero for real eigenvalues (``zeta = 1``, locally constant).

    Raises
    ------
    ShapeError, MatrixPropertyError

    Notes
    -----
    Source: the constraints ``g_j = zeta_j - zeta_L`` of Eqs. (4.32), (4.38).
    """
    A, B, C = _check_plant(A, B, C)
    nc = B.shape[1]
    D = check_matrix("D", D, (nc, nc), ("n_c", "n_c"))
    z, g, _ = _damping_and_gradient(A, B, C, D, int(n_modes))
    return z, g


def _perf_and_gradient(A, B, C, D, Q, R, X0):
    Acl = A - B @ D @ C
    F = D @ C
    Qt = Q + F.T @ R @ F
    P = _solve_lyapunov(Acl.T, -Qt)[0]  # an optimiser's iterate: the final design's J is checked on its own
    P = 0.5 * (P + P.T)
    nf = X0.shape[1]
    J = np.einsum("ij,ik,kj->j", X0, P, X0)
    grad = np.empty((nf, B.shape[1], C.shape[0]))
    BtP = B.T @ P
    RD = R @ D
    for i in range(nf):
        x = X0[:, i:i + 1]
        L = _solve_lyapunov(Acl, -(x @ x.T))[0]
        L = 0.5 * (L + L.T)
        LCt = L @ C.T
        grad[i] = -2.0 * BtP @ LCt + 2.0 * RD @ (C @ LCt)
    return J, grad


def performance_gradient(A, B, C, D, Q, R, initial_states) -> tuple[np.ndarray, np.ndarray]:
    """Performance indices ``J_i`` of ``u = -D C x`` and their derivatives w.r.t. ``D``.

    ``J_i = x0_i^T P x0_i``, ``A_cl^T P + P A_cl + Q + C^T D^T R D C = 0``
    (Eqs. 4.33-4.36, ``F_D = D C``); the gradient uses the adjoint
    ``A_cl L_i + L_i A_cl^T + x0_i x0_i^T = 0``:
    ``dJ_i/dD = -2 B^T P L_i C^T + 2 R D C L_i C^T``.

    Parameters
    ----------
    A, B, C, D
        As :func:`closed_loop_damping`.
    Q : array_like, shape (2n, 2n)
    R : array_like, shape (n_c, n_c)
    initial_states : array_like, shape (2n, n_f)

    Returns
    -------
    J : ndarray, shape (n_f,)
    dJ_dD : ndarray, shape (n_f, n_c, n_c)

    Raises
    ------
    ShapeError, MatrixPropertyError
        Bad shapes; ``A - B D C`` not asymptotically stable (J infinite).
    """
    A, B, C = _check_plant(A, B, C)
    n, nc = B.shape
    D = check_matrix("D", D, (nc, nc), ("n_c", "n_c"))
    Q, R = _cost_weights(Q, R, n, nc)
    X0 = _initial_states(initial_states, n)
    if np.max(scipy.linalg.eigvals(A - B @ D @ C).real) >= 0:
        raise MatrixPropertyError("A - B D C is not asymptotically stable; J is infinite")
    return _perf_and_gradient(A, B, C, D, Q, R, X0)
