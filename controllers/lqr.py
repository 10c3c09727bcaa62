"""Linear quadratic regulator (Eqs. 4.4-4.7).

``u = -F x`` with ``F = R^-1 B^T S`` and ``S`` the stabilising solution of
``A^T S + S A - S B R^-1 B^T S + Q = 0``; the cost from ``x0`` is
``J_min = x0^T S x0``. How the weight ``R = r I`` is chosen for a damping
bound: :mod:`controllers.lqr_weight`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import check_positive_scalar, readonly
from .performance import _check_state_input, _initial_states, modes
from .realization import DiscreteRealization, state_feedback_realization
from .riccati import _care, _riccati_residual, _riccati_weights, check_stabilizable

__all__ = ["LqrDesign", "lqr"]


@dataclass(frozen=True, eq=False)
class LqrDesign:
    """Result of an LQR design (Eqs. 4.4-4.7).

    Attributes
    ----------
    gain : ndarray, shape (n_c, 2n)
        ``F`` of ``u = -F x`` [force per state unit].
    riccati : ndarray, shape (2n, 2n)
        ``S`` of Eq. (4.6).
    Q : ndarray, shape (2n, 2n)
    R : ndarray, shape (n_c, n_c)
    eigenvalues, damping_ratios, frequencies_hz : ndarray, shape (n_modes,)
        Modes of ``A - B F`` sorted by frequency (see :mod:`controllers.performance`).
    riccati_residual : float
        Scaled residual of Eq. (4.6).
    time_unit_s : float
        Seconds per model time unit.
    """

    gain: np.ndarray
    riccati: np.ndarray
    Q: np.ndarray
    R: np.ndarray
    eigenvalues: np.ndarray
    damping_ratios: np.ndarray
    frequencies_hz: np.ndarray
    riccati_residual: float
    time_unit_s: float

    def performance_index(self, initial_states) -> np.ndarray:
        """``J_min,i = x0_i^T S x0_i`` (Eq. 4.7).

        Parameters
        ----------
        initial_states : array_like, shape (2n, n_f)
            Initial states ``x0_i``, one per column.

        Returns
        -------
        ndarray, shape (n_f,)
            ``J_min,i`` of the regulator, one per initial state.

        Raises
        ------
        ShapeError
        """
        X0 = _initial_states(initial_states, self.riccati.shape[0])
        return np.einsum("ij,ik,kj->j", X0, self.riccati, X0)

    def realize(self, dt_s: float) -> DiscreteRealization:
        """Full-state feedback for the engine of Eq. (5.1): ``F11 = -F S``.

        ``y_k`` must be the whole structural state ``[q'; q]`` with velocities
        per *second* (``S = diag(T I, I)``, ``T = time_unit_s``); see
        :func:`controllers.realization.state_feedback_realization`, which
        documents ``dt_s`` [s] and the errors (a non-positive ``dt_s``).

        Returns
        -------
        DiscreteRealization
            ``F11 (n_c, 2n)``, no internal state.
        """
        return state_feedback_realization(self.gain, dt_s, time_unit_s=self.time_unit_s)


def lqr(A, B, Q, R, *, time_unit_s: float = 1.0) -> LqrDesign:
    """Linear quadratic regulator (Eqs. 4.4-4.7).

    Parameters
    ----------
    A : array_like, shape (2n, 2n)
        System matrix [1/time unit].
    B : array_like, shape (2n, n_c)
        Input matrix.
    Q : array_like, shape (2n, 2n)
        Symmetric positive semi-definite state weight.
    R : array_like, shape (n_c, n_c)
        Symmetric positive definite control weight.
    time_unit_s : float
        Seconds per time unit (for Hz and the realisation).

    Returns
    -------
    LqrDesign

    Raises
    ------
    ShapeError
        Mismatched shapes.
    MatrixPropertyError
        ``Q`` not symmetric PSD, ``R`` not symmetric PD.
    StabilizabilityError
        ``(A, B)`` not stabilisable (PBH).
    RiccatiError
        No stabilising solution (e.g. ``(Q, A)`` has an unobservable mode on
        the imaginary axis).

    Notes
    -----
    Source: Eqs. (4.4)-(4.7); solved by :func:`scipy.linalg.solve_continuous_are`.
    """
    A, B = _check_state_input(A, B)
    Q, R = _riccati_weights(Q, R, *B.shape)
    t = check_positive_scalar("time_unit_s", time_unit_s)
    check_stabilizable(A, B, what="(A, B)")
    S = _care(A, B, Q, R, "LQR")
    F = np.linalg.solve(R, B.T @ S)
    md = modes(A - B @ F, time_unit_s=t)
    res = _riccati_residual(A, B @ np.linalg.solve(R, B.T), Q, S)
    return LqrDesign(
        readonly(F), readonly(S), readonly(Q), readonly(R),
        md.eigenvalues, md.damping_ratios, md.frequencies_hz, res, t,
    )
