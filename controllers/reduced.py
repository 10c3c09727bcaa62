"""A reduced-model LQG controller closed around the full model, and its spillover (Eqs. 4.23-4.29).

``A_E = [[A, -B F_R], [K_R C, A_R - K_R C_R - B_R F_R]]`` on ``[x; x_R,est]``,
``Q_E = diag(Q, F_R^T R F_R)``, ``x_E0 = [x0; 0]``; the spillover report
(:func:`controllers.performance.spillover`) pairs every full-model mode with
a closed-loop eigenvalue and lists the modes the controller destabilises or
damps less.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg

from .errors import check_matrix, check_positive_semidefinite, check_square, readonly
from .lqg import LqgDesign
from .performance import SpilloverReport, _initial_states, modes, performance_index, spillover
from .realization import DiscreteRealization

__all__ = ["ReducedOnFull", "reduced_on_full"]


@dataclass(frozen=True, eq=False)
class ReducedOnFull:
    """A reduced-model LQG controller closed around the full model (Eqs. 4.23-4.29).

    Attributes
    ----------
    controller : LqgDesign
        The reduced-model design (``A_R, B_R, C_R, F_R, K_R``).
    closed_loop_matrix : ndarray, shape (2n + 2n_R, 2n + 2n_R)
        ``A_E`` of Eq. (4.24) on ``[x; x_R,est]``.
    closed_loop_weight : ndarray, shape (2n + 2n_R, 2n + 2n_R)
        ``Q_E`` of Eq. (4.28).
    eigenvalues, damping_ratios, frequencies_hz : ndarray, shape (n_modes,)
        Modes of ``A_E``.
    spillover : SpilloverReport
        Damping of every full-model mode, open vs closed loop.
    time_unit_s : float
    """

    controller: LqgDesign
    closed_loop_matrix: np.ndarray
    closed_loop_weight: np.ndarray
    eigenvalues: np.ndarray
    damping_ratios: np.ndarray
    frequencies_hz: np.ndarray
    spillover: SpilloverReport
    time_unit_s: float

    def performance_index(self, initial_states) -> np.ndarray:
        """``J_i = x_E0^T P_E x_E0`` with ``x_E0 = [x0; 0]`` (Eqs. 4.26-4.29).

        Parameters
        ----------
        initial_states : array_like, shape (2n, n_f)
            Full-model initial states.

        Returns
        -------
        ndarray, shape (n_f,)

        Raises
        ------
        ShapeError
        """
        nE = self.closed_loop_matrix.shape[0]
        nR = self.controller.A.shape[0]
        X0 = _initial_states(initial_states, nE - nR)
        XE = np.vstack([X0, np.zeros((nR, X0.shape[1]))])
        return performance_index(self.closed_loop_matrix, self.closed_loop_weight, XE)

    def realize(self, dt_s: float, *, block_diagonal: bool = False) -> DiscreteRealization:
        """The reduced controller's engine coefficients (see :meth:`LqgDesign.realize`).

        Parameters
        ----------
        dt_s : float
            Sampling period [s].
        block_diagonal : bool
            Use the block-diagonal coordinates of Eqs. (5.6)-(5.12).

        Returns
        -------
        DiscreteRealization
            States of size ``2n_R``.

        Raises
        ------
        MatrixPropertyError
            Non-positive ``dt_s``; defective ``A~`` with ``block_diagonal``.
        """
        return self.controller.realize(dt_s, block_diagonal=block_diagonal)


def reduced_on_full(A, B, C, Q, controller: LqgDesign) -> ReducedOnFull:
    """Close a reduced-model LQG controller around the full model (Eqs. 4.23-4.29).

    ``A_E = [[A, -B F_R], [K_R C, A_R - K_R C_R - B_R F_R]]``,
    ``Q_E = diag(Q, F_R^T R F_R)``; the spillover report pairs each full-model
    mode with a closed-loop eigenvalue (nearest eigenvalue / eigenvector
    overlap) and lists the modes whose damping the controller lowers or
    destroys.

    Parameters
    ----------
    A : array_like, shape (2n, 2n)
        Full model, same time unit as the controller.
    B : array_like, shape (2n, n_c)
        Full-model input matrix (same actuators as ``B_R``).
    C : array_like, shape (n_s, 2n)
        Full-model output matrix (same sensors as ``C_R``).
    Q : array_like, shape (2n, 2n)
        Full-model state weight.
    controller : LqgDesign
        Designed on the reduced model ``(A_R (2n_R, 2n_R), B_R, C_R)``.

    Returns
    -------
    ReducedOnFull

    Raises
    ------
    ShapeError, MatrixPropertyError
        Shapes inconsistent with the controller (actuator or sensor count).

    Notes
    -----
    Source: Eqs. (4.23)-(4.29); spillover as in Sec. 6.2.1.
    """
    A = check_square("A", A, "2n")
    n = A.shape[0]
    nc = controller.B.shape[1]
    ns = controller.C.shape[0]
    B = check_matrix("B", B, (n, nc), ("2n", "n_c"))
    C = check_matrix("C", C, (ns, n), ("n_s", "2n"))
    Q = check_positive_semidefinite("Q", check_matrix("Q", Q, (n, n), ("2n", "2n")))
    F = controller.regulator.gain
    K = controller.estimator.gain
    AE = np.block([[A, -B @ F], [K @ C, controller.controller_matrix]])
    QE = scipy.linalg.block_diag(Q, F.T @ controller.regulator.R @ F)
    t = controller.time_unit_s
    md = modes(AE, time_unit_s=t)
    rep = spillover(A, AE, time_unit_s=t)
    return ReducedOnFull(controller, readonly(AE), readonly(QE), md.eigenvalues,
                         md.damping_ratios, md.frequencies_hz, rep, t)
