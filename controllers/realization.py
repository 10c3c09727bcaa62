"""Discrete-time realisation of a design for the controller engine of Eq. (5.1).

The PC-1000 of Sec. 5.3 evaluates, once per sampling period ``dt``::

    u_k       = F11 y_k + F12 x_k
    x_{k+1}   = F21 y_k + F22 x_k                                  (Eq. 5.1)

with ``y_k`` the sensor signals, ``u_k`` the actuator commands and ``x_k`` the
controller's internal state. Conventions of this module:

* ``y_k`` are sensor velocities in the model's length unit **per second**,
  ``u_k`` actuator forces in the model's force unit, ``dt`` in seconds. A design
  made in another time unit (``time_unit_s = T``, e.g. 0.01 s for the thesis'
  cs) is converted here: velocity feedback ``F11 = -T D``; the estimator runs
  on ``x' = (A~/T) x + K y``.
* Direct rate feedback ``u = -D y`` (Eq. 4.30) is ``F11 = -D`` (the minus sign
  is in ``F11``: the engine output is the actuator command itself), no state.
* LQG (Eqs. 5.2-5.5): ``F12 = -F_R``, ``F21 = (e^{A~ dt} - I) A~^-1 K_R``,
  ``F22 = e^{A~ dt}``, ``A~ = A_R - B_R F_R - K_R C_R``. ``F21`` and ``F22``
  come from one matrix exponential of the augmented matrix
  ``[[A~, K_R], [0, 0]] dt`` (Van Loan), whose top-right block is
  ``int_0^dt e^{A~ s} ds K_R``, so ``A~`` need not be invertible. This is a
  zero-order hold on ``y`` over the period, as the thesis' "integration of the
  observer equations over one sample period".
* Block-diagonal form (Eqs. 5.6-5.12): ``x_est = T x'``,
  ``T = [Re phi_1, Im phi_1, ...]`` from the eigenvectors of ``A~``;
  ``T^-1 A~ T`` is block diagonal with 2x2 blocks ``[[s, w], [-w, s]]`` for
  ``lambda = s + i w``. Then ``F22 = e^{T^-1 A~ T dt}`` (block diagonal),
  ``F21 = (F22 - I)(T^-1 A~ T)^-1 T^-1 K_R`` and ``F12 = -F_R T`` (Eq. 5.10).
  The thesis prints Eq. (5.13) as ``F12 = -T F_R``, which is a typo: ``T`` is
  ``(2n_R, 2n_R)`` and ``F_R`` is ``(n_c, 2n_R)``, and ``u = -F_R T x'`` by
  Eq. (5.10).
* Pole check (Eq. 5.13, ``z = e^{s dt}``): ``s = ln(z) / dt`` of the
  eigenvalues of ``F22`` must equal the eigenvalues of ``A~`` (per second);
  the principal logarithm is exact while ``|Im s| dt < pi``.

Non-zero count: for ``n_s`` sensors, ``n_c`` actuators and ``2n_R`` states the
plain form has ``n_c 2n_R + 2n_R n_s + (2n_R)^2`` entries (816 for the grid:
5, 5, 24); the block form has ``n_c 2n_R + 2n_R n_s + 4 n_pairs + n_real``
(288 when all 12 eigenvalue pairs of ``A~`` are complex, as Sec. 5.3 reports;
each pair that splits into two real eigenvalues saves two more).
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
    check_square,
    readonly,
)

__all__ = [
    "Eq51Sizes",
    "DiscreteRealization",
    "output_feedback_realization",
    "state_feedback_realization",
    "estimator_realization",
    "block_diagonal_transform",
    "z_to_s",
    "pole_mapping_error",
]


class Eq51Sizes:
    """The sizes of an Eq. (5.1) engine, read off its ``F11`` and ``F22`` (a mixin).

    A class that has ``F11`` (shape (n_u, n_y)) and ``F22`` (shape
    (n_x, n_x)) gets ``n_inputs``, ``n_outputs`` and ``n_states``.
    """

    @property
    def n_inputs(self) -> int:
        """``n_y``: number of sensor signals."""
        return self.F11.shape[1]

    @property
    def n_outputs(self) -> int:
        """``n_u``: number of actuator commands."""
        return self.F11.shape[0]

    @property
    def n_states(self) -> int:
        """``n_x``: number of internal states."""
        return self.F22.shape[0]


@dataclass(frozen=True, eq=False)
class DiscreteRealization(Eq51Sizes):
    """Coefficients of the controller engine of Eq. (5.1).

    ``u_k = F11 y_k + F12 x_k``, ``x_{k+1} = F21 y_k + F22 x_k``.

    Attributes
    ----------
    F11 : ndarray, shape (n_u, n_y)
        Direct feedthrough [force / (length/s)].
    F12 : ndarray, shape (n_u, n_x)
    F21 : ndarray, shape (n_x, n_y)
    F22 : ndarray, shape (n_x, n_x)
    dt_s : float
        Sampling period [s].
    continuous_matrix_s : ndarray, shape (n_x, n_x)
        The continuous controller matrix (``A~ / T`` [1/s]) in the coordinates
        of ``x`` (for the pole check).
    transform : ndarray, shape (n_x, n_x) or None
        ``T`` of Eq. (5.7) when the block-diagonal form is used
        (``x_est = T x``), else ``None``.
    """

    F11: np.ndarray
    F12: np.ndarray
    F21: np.ndarray
    F22: np.ndarray
    dt_s: float
    continuous_matrix_s: np.ndarray
    transform: np.ndarray | None = None

    def initial_state(self) -> np.ndarray:
        """Zero controller state, shape (n_x,) (Eq. 4.22: ``x_est,0 = 0``)."""
        return np.zeros(self.n_states)

    def output(self, y, x) -> np.ndarray:
        """``u_k = F11 y_k + F12 x_k``; ``y`` shape (n_y,), ``x`` shape (n_x,) -> (n_u,)."""
        return self.F11 @ np.asarray(y, dtype=float) + self.F12 @ np.asarray(x, dtype=float)

    def update(self, y, x) -> np.ndarray:
        """``x_{k+1} = F21 y_k + F22 x_k`` -> shape (n_x,)."""
        return self.F21 @ np.asarray(y, dtype=float) + self.F22 @ np.asarray(x, dtype=float)

    def step(self, y, x) -> tuple[np.ndarray, np.ndarray]:
        """One sampling period: ``(u_k, x_{k+1})``."""
        return self.output(y, x), self.update(y, x)

    def coefficient_matrix(self) -> np.ndarray:
        """The full ``[[F11, F12], [F21, F22]]``, shape (n_u + n_x, n_y + n_x)."""
        return np.block([[self.F11, self.F12], [self.F21, self.F22]])

    def nonzero_count(self, *, rtol: float = 0.0) -> int:
        """Number of coefficients with ``|f| > rtol * max|f|`` (exact non-zeros by default)."""
        M = self.coefficient_matrix()
        if M.size == 0:
            return 0
        return int(np.count_nonzero(np.abs(M) > rtol * np.max(np.abs(M))))

    def s_plane_poles(self) -> np.ndarray:
        """``s = ln(z) / dt`` for the eigenvalues ``z`` of ``F22`` [1/s], shape (n_x,)."""
        return z_to_s(scipy.linalg.eigvals(self.F22), self.dt_s) if self.n_states else np.zeros(0)

    def pole_mapping_error(self) -> float:
        """Largest relative mismatch between :meth:`s_plane_poles` and ``eig(A~/T)``."""
        return pole_mapping_error(self.F22, self.continuous_matrix_s, self.dt_s)


def _dt(dt_s) -> float:
    return check_positive_scalar("dt_s", dt_s)


def output_feedback_realization(D, dt_s: float, *, time_unit_s: float = 1.0) -> DiscreteRealization:
    """Direct rate feedback ``u = -D y`` (Eq. 4.30) as ``F11 = -T D``, no state (Sec. 5.3).

    Parameters
    ----------
    D : array_like, shape (n_c, n_s)
        Gain in design units [force / (length per time unit)].
    dt_s : float
        Sampling period [s].
    time_unit_s : float
        ``T``: seconds per design time unit; ``F11 = -T D`` takes ``y`` in length/s.

    Returns
    -------
    DiscreteRealization
        ``F11 (n_c, n_s)``; ``F12, F21, F22`` empty.

    Raises
    ------
    ShapeError, MatrixPropertyError
    """
    D = check_matrix("D", D, (None, None), ("n_c", "n_s"))
    t = check_positive_scalar("time_unit_s", time_unit_s)
    nu, ny = D.shape
    return DiscreteRealization(
        readonly(-t * D), readonly(np.zeros((nu, 0))), readonly(np.zeros((0, ny))),
        readonly(np.zeros((0, 0))), _dt(dt_s), readonly(np.zeros((0, 0))),
    )


def state_feedback_realization(F, dt_s: float, *, time_unit_s: float = 1.0) -> DiscreteRealization:
    """Full-state feedback ``u = -F x`` as ``F11 = -F S``, ``S = diag(T I_n, I_n)``.

    ``y_k`` must be the structural state ``[q'; q]`` with velocities per second.

    Parameters
    ----------
    F : array_like, shape (n_c, 2n)
        Gain in design units (state ``[q' per time unit; q]``).
    dt_s : float
    time_unit_s : float

    Returns
    -------
    DiscreteRealization
        ``F11 (n_c, 2n)``, no state.

    Raises
    ------
    ShapeError
        Odd number of columns.
    """
    F = check_matrix("F", F, (None, None), ("n_c", "2n"))
    if F.shape[1] % 2:
        raise ShapeError(f"F: expected shape (n_c, 2n) with even 2n, found {F.shape}")
    t = check_positive_scalar("time_unit_s", time_unit_s)
    n = F.shape[1] // 2
    s = np.concatenate([np.full(n, t), np.ones(n)])
    nu, ny = F.shape
    return DiscreteRealization(
        readonly(-F * s[None, :]), readonly(np.zeros((nu, 0))), readonly(np.zeros((0, ny))),
        readonly(np.zeros((0, 0))), _dt(dt_s), readonly(np.zeros((0, 0))),
    )


def block_diagonal_transform(A_tilde) -> tuple[np.ndarray, np.ndarray]:
    """Real block-diagonalising similarity of Eqs. (5.6)-(5.9).

    Parameters
    ----------
    A_tilde : array_like, shape (N, N)
        Real, diagonalisable matrix.

    Returns
    -------
    T : ndarray, shape (N, N)
        Columns ``[Re phi_i, Im phi_i]`` for each eigenvalue with ``Im > 0`` and
        ``[phi_i]`` for each real one, modes sorted by ``|lambda|``, each
        eigenvector scaled to unit norm.
    Lambda : ndarray, shape (N, N)
        Block diagonal, ``[[s, w], [-w, s]]`` per pair ``s + i w`` and ``[s]``
        per real eigenvalue, so that ``A_tilde T = T Lambda`` (to round-off).

    Raises
    ------
    ShapeError
        Non-square input.
    MatrixPropertyError
        ``A_tilde`` (numerically) defective: ``T`` singular.

    Notes
    -----
    Source: Eqs. (5.6)-(5.9).
    """
    A = check_square("A_tilde", A_tilde, "N")
    n = A.shape[0]
    lam, V = scipy.linalg.eig(A)
    keep = np.flatnonzero(lam.imag >= 0)
    keep = keep[np.lexsort((lam.real[keep], np.abs(lam[keep])))]
    T = np.zeros((n, n))
    L = np.zeros((n, n))
    col = 0
    for i in keep:
        v = V[:, i] / np.linalg.norm(V[:, i])
        s, w = lam[i].real, lam[i].imag
        if w > 0:
            # phase that makes Re and Im parts as orthogonal as possible (better conditioning)
            theta = 0.5 * np.angle(np.sum(v * v))
            v = v * np.exp(-1j * theta)
            T[:, col], T[:, col + 1] = v.real, v.imag
            L[col:col + 2, col:col + 2] = [[s, w], [-w, s]]
            col += 2
        else:
            T[:, col] = v.real / np.linalg.norm(v.real)
            L[col, col] = s
            col += 1
    if col != n:
        raise MatrixPropertyError(f"A_tilde: eigenvalues do not pair up ({col} of {n} columns)")
    cond = np.linalg.cond(T)
    if not np.isfinite(cond) or cond > 1e12:
        raise MatrixPropertyError(
            f"A_tilde: eigenvector matrix is singular (cond {cond:.2e}); defective matrix, "
            "no block-diagonal form"
        )
    return T, L


def estimator_realization(
    A_tilde,
    K,
    F,
    dt_s: float,
    *,
    time_unit_s: float = 1.0,
    block_diagonal: bool = False,
) -> DiscreteRealization:
    """Discrete LQG controller for Eq. (5.1) (Eqs. 5.2-5.5, or 5.6-5.12 with ``block_diagonal``).

    Continuous controller (design time unit ``T``): ``x' = A~ x + K y_T``,
    ``u = -F x``. With ``y_T = T y`` (``y`` per second) and ``t = T tau`` it is
    ``dx/dt = (A~/T) x + K y`` in seconds, discretised with a zero-order hold::

        F22 = e^{(A~/T) dt},  F21 = int_0^dt e^{(A~/T) s} ds K,  F12 = -F,  F11 = 0

    Parameters
    ----------
    A_tilde : array_like, shape (2n_R, 2n_R)
        ``A~ = A_R - B_R F_R - K_R C_R`` (Eq. 5.5) [1/time unit].
    K : array_like, shape (2n_R, n_s)
        Kalman gain ``K_R``.
    F : array_like, shape (n_c, 2n_R)
        Regulator gain ``F_R``.
    dt_s : float
        Sampling period [s] (Sec. 5.3: 0.5 ms at 2000 samples/s).
    time_unit_s : float
        ``T`` [s per design time unit].
    block_diagonal : bool
        Use the real block-diagonal coordinates ``x_est = T x'`` (Eqs. 5.6-5.12)
        with ``F12 = -F_R T`` (the thesis' Eq. (5.13) ``-T F_R`` is a typo).

    Returns
    -------
    DiscreteRealization
        ``F11 (n_c, n_s) = 0``, ``F12 (n_c, 2n_R)``, ``F21 (2n_R, n_s)``,
        ``F22 (2n_R, 2n_R)``; ``transform`` set in block form.

    Raises
    ------
    ShapeError, MatrixPropertyError
        Bad shapes; defective ``A~`` in block form.

    Notes
    -----
    Source: Eqs. (5.1)-(5.13). The matrix exponential is
    :func:`scipy.linalg.expm` (Pade with scaling and squaring, as the thesis).
    """
    At = check_square("A_tilde", A_tilde, "2n_R")
    nx = At.shape[0]
    K = check_matrix("K", K, (nx, None), ("2n_R", "n_s"))
    F = check_matrix("F", F, (None, nx), ("n_c", "2n_R"))
    h = _dt(dt_s)
    t = check_positive_scalar("time_unit_s", time_unit_s)
    ny, nu = K.shape[1], F.shape[0]
    transform = None
    if block_diagonal:
        transform, Lam = block_diagonal_transform(At)
        Ac = Lam / t
        G = np.linalg.solve(transform, K)
        F12 = -F @ transform
    else:
        Ac = At / t
        G = K
        F12 = -F
    M = np.zeros((nx + ny, nx + ny))
    M[:nx, :nx] = Ac * h
    M[:nx, nx:] = G * h
    E = scipy.linalg.expm(M)
    F22 = E[:nx, :nx].copy()
    F21 = E[:nx, nx:].copy()
    if block_diagonal:
        F22[~_block_pattern(Ac)] = 0.0  # exact zeros outside the 2x2 blocks
    return DiscreteRealization(
        readonly(np.zeros((nu, ny))), readonly(F12), readonly(F21), readonly(F22), h,
        readonly(Ac), None if transform is None else readonly(transform),
    )


def _block_pattern(L: np.ndarray) -> np.ndarray:
    """Boolean mask of the diagonal blocks of a block-diagonal matrix ``L``."""
    n = L.shape[0]
    mask = np.zeros((n, n), dtype=bool)
    i = 0
    while i < n:
        if i + 1 < n and (L[i, i + 1] != 0 or L[i + 1, i] != 0):
            mask[i:i + 2, i:i + 2] = True
            i += 2
        else:
            mask[i, i] = True
            i += 1
    return mask


def z_to_s(z, dt_s: float) -> np.ndarray:
    """Map discrete poles to the s-plane, ``s = ln(z) / dt`` (inverse of Eq. 5.13, Ref. 65).

    Parameters
    ----------
    z : array_like of complex, shape (N,)
    dt_s : float
        Sampling period [s].

    Returns
    -------
    ndarray of complex, shape (N,)
        [1/s]; principal branch, exact for ``|Im s| dt < pi``.

    Raises
    ------
    MatrixPropertyError
        Non-positive ``dt_s``.
    """
    h = _dt(dt_s)
    return np.log(np.asarray(z, dtype=complex)) / h


def pole_mapping_error(F22, A_continuous_s, dt_s: float) -> float:
    """Largest relative gap between ``ln(eig(F22))/dt`` and ``eig(A_continuous_s)``.

    Poles are paired by minimum total distance (Hungarian method).

    Parameters
    ----------
    F22 : array_like, shape (N, N)
    A_continuous_s : array_like, shape (N, N)
        Continuous matrix in 1/s.
    dt_s : float

    Returns
    -------
    float
        ``max |s_i - lambda_i| / max(|lambda_i|, 1e-300)``; 0 for ``N = 0``.

    Raises
    ------
    ShapeError
        Different sizes.
    """
    F22 = np.asarray(F22, dtype=float)
    Ac = np.asarray(A_continuous_s, dtype=float)
    if F22.shape != Ac.shape or F22.ndim != 2:
        raise ShapeError(f"F22 and A_continuous_s: expected equal (N, N) shapes, found "
                         f"{F22.shape} and {Ac.shape}")
    if F22.shape[0] == 0:
        return 0.0
    s = z_to_s(scipy.linalg.eigvals(F22), dt_s)
    lam = scipy.linalg.eigvals(Ac)
    cost = np.abs(s[:, None] - lam[None, :])
    r, c = linear_sum_assignment(cost)
    return float(np.max(cost[r, c] / np.maximum(np.abs(lam[c]), 1e-300)))
