"""LQG controller: the LQR gain on the state of an alpha-shifted Kalman filter (Eqs. 4.11-4.22).

Closed loop ``Abar = [[A - BF, BF], [0, A - KC]]`` on ``[x; e]`` with
``e = x - x_est``, cost weight ``Qbar`` (Eq. 4.19) and
``J = xbar0^T Pbar xbar0`` with ``xbar0 = [x0; x0]`` (the estimate starts at
the true state). The regulator is :func:`controllers.lqr.lqr`, the filter
:func:`controllers.kalman.kalman_filter`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import check_matrix, readonly
from .kalman import KalmanDesign, kalman_filter
from .lqr import LqrDesign, lqr
from .performance import _initial_states, modes, performance_index
from .realization import DiscreteRealization, estimator_realization

__all__ = ["LqgDesign", "lqg"]


@dataclass(frozen=True, eq=False)
class LqgDesign:
    """LQG controller: LQR gain plus alpha-shifted Kalman filter (Eqs. 4.11-4.22).

    Attributes
    ----------
    regulator : LqrDesign
    estimator : KalmanDesign
    A : ndarray, shape (2n, 2n)
    B : ndarray, shape (2n, n_c)
    C : ndarray, shape (n_s, 2n)
        The (design) model the controller was built for.
    closed_loop_matrix : ndarray, shape (4n, 4n)
        ``Abar`` of Eq. (4.16) on ``[x; e]``, ``e = x - x_est``.
    closed_loop_weight : ndarray, shape (4n, 4n)
        ``Qbar`` of Eq. (4.19).
    eigenvalues, damping_ratios, frequencies_hz : ndarray, shape (n_modes,)
        Modes of ``Abar`` = modes of ``A - BF`` and of ``A - KC``.
    time_unit_s : float
    """

    regulator: LqrDesign
    estimator: KalmanDesign
    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    closed_loop_matrix: np.ndarray
    closed_loop_weight: np.ndarray
    eigenvalues: np.ndarray
    damping_ratios: np.ndarray
    frequencies_hz: np.ndarray
    time_unit_s: float

    @property
    def controller_matrix(self) -> np.ndarray:
        """``A~ = A - B F - K C`` (Eq. 5.5), shape (2n, 2n): ``x_est' = A~ x_est + K y``."""
        return (self.A - self.B @ self.regulator.gain - self.estimator.gain @ self.C)

    def performance_index(self, initial_states) -> np.ndarray:
        """``J_i = xbar0^T Pbar xbar0`` with ``xbar0 = [x0; x0]`` (Eqs. 4.18-4.22).

        Parameters
        ----------
        initial_states : array_like, shape (2n, n_f)
            Structural initial states ``x0_i``, one per column; the estimate
            starts at the same state.

        Returns
        -------
        ndarray, shape (n_f,)
            ``J_i`` of the closed loop with the estimator, one per initial state.

        Raises
        ------
        ShapeError
        """
        X0 = _initial_states(initial_states, self.A.shape[0])
        return performance_index(self.closed_loop_matrix, self.closed_loop_weight,
                                 np.vstack([X0, X0]))

    def realize(self, dt_s: float, *, block_diagonal: bool = False) -> DiscreteRealization:
        """Discrete controller for the engine of Eq. (5.1) (Eqs. 5.2-5.5, or 5.6-5.12).

        See :func:`controllers.realization.estimator_realization`; ``y_k`` is in
        length per second, ``u_k`` the actuator force.

        Parameters
        ----------
        dt_s : float
            Sampling period [s] (0.0005 at 2000 samples/s).
        block_diagonal : bool
            Use the block-diagonal coordinates of Eqs. (5.6)-(5.12).

        Returns
        -------
        DiscreteRealization
            ``F11 (n_c, n_s) = 0``, ``F12 (n_c, 2n)``, ``F21 (2n, n_s)``, ``F22 (2n, 2n)``.

        Raises
        ------
        MatrixPropertyError
            Non-positive ``dt_s``; defective ``A~`` with ``block_diagonal``.
        """
        return estimator_realization(
            self.controller_matrix, self.estimator.gain, self.regulator.gain, dt_s,
            time_unit_s=self.time_unit_s, block_diagonal=block_diagonal,
        )


def lqg(A, B, C, Q, R, V1, V2, *, alpha: float = 0.0, time_unit_s: float = 1.0) -> LqgDesign:
    """LQG controller ``u = -F x_est`` with a Kalman filter (Eqs. 4.8-4.22).

    Parameters
    ----------
    A : array_like, shape (2n, 2n)
    B : array_like, shape (2n, n_c)
    C : array_like, shape (n_s, 2n)
    Q : array_like, shape (2n, 2n)
    R : array_like, shape (n_c, n_c)
    V1 : array_like, shape (2n, 2n)
    V2 : array_like, shape (n_s, n_s)
    alpha : float
        Filter stability margin [1/time unit].
    time_unit_s : float

    Returns
    -------
    LqgDesign

    Raises
    ------
    ShapeError, MatrixPropertyError, StabilizabilityError, RiccatiError
        As :func:`lqr` and :func:`kalman_filter`.

    Notes
    -----
    Source: Eqs. (4.11)-(4.22). With the thesis values for the BCC:
    ``Q = I, R = 0.22 I, V1 = 1e-6 I, V2 = 5e-4 I, alpha = 0.2`` (in cs).
    """
    reg = lqr(A, B, Q, R, time_unit_s=time_unit_s)
    est = kalman_filter(A, C, V1, V2, alpha=alpha, time_unit_s=time_unit_s)
    A = np.asarray(A, dtype=float)
    B = np.asarray(B, dtype=float)
    C = check_matrix("C", C, (None, A.shape[0]), ("n_s", "2n"))
    F, K = reg.gain, est.gain
    n = A.shape[0]
    BF = B @ F
    Abar = np.block([[A - BF, BF], [np.zeros((n, n)), A - K @ C]])
    FRF = F.T @ reg.R @ F
    Qbar = np.block([[reg.Q + FRF, -FRF], [-FRF, FRF]])
    md = modes(Abar, time_unit_s=reg.time_unit_s)
    return LqgDesign(reg, est, readonly(A), readonly(B), readonly(C), readonly(Abar),
                     readonly(Qbar), md.eigenvalues, md.damping_ratios, md.frequencies_hz,
                     reg.time_unit_s)
