"""Kalman filter with a prescribed stability margin alpha (Eqs. 4.8-4.10).

``(A + aI) S_f + S_f (A + aI)^T - S_f C^T V2^-1 C S_f + V1 = 0``,
``K = S_f C^T V2^-1``: shifting ``A`` by ``alpha`` before solving the filter
Riccati equation places every eigenvalue of ``A - K C`` at ``Re < -alpha``
(the alpha shift of Refs. 57-58 of the dissertation).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg

from .errors import check_matrix, check_positive_scalar, check_square, readonly
from .riccati import _care, _riccati_residual, _riccati_weights, check_detectable

__all__ = ["KalmanDesign", "kalman_filter"]


@dataclass(frozen=True, eq=False)
class KalmanDesign:
    """Alpha-shifted Kalman filter (Eqs. 4.8-4.10).

    Attributes
    ----------
    gain : ndarray, shape (2n, n_s)
        ``K`` of Eq. (4.10).
    riccati : ndarray, shape (2n, 2n)
        ``S_f`` of Eq. (4.9).
    V1 : ndarray, shape (2n, 2n)
    V2 : ndarray, shape (n_s, n_s)
    alpha : float
        Prescribed stability margin [1/time unit].
    eigenvalues : ndarray of complex, shape (2n,)
        All eigenvalues of ``A - K C``; ``max Re < -alpha``.
    riccati_residual : float
        Scaled residual of Eq. (4.9).
    time_unit_s : float
    """

    gain: np.ndarray
    riccati: np.ndarray
    V1: np.ndarray
    V2: np.ndarray
    alpha: float
    eigenvalues: np.ndarray
    riccati_residual: float
    time_unit_s: float


def kalman_filter(A, C, V1, V2, *, alpha: float = 0.0, time_unit_s: float = 1.0) -> KalmanDesign:
    """Kalman filter with prescribed stability margin ``alpha`` (Eqs. 4.8-4.10).

    Solves ``(A + aI) S_f + S_f (A + aI)^T - S_f C^T V2^-1 C S_f + V1 = 0`` and
    returns ``K = S_f C^T V2^-1``; all eigenvalues of ``A - K C`` then satisfy
    ``Re < -alpha``.

    Parameters
    ----------
    A : array_like, shape (2n, 2n)
    C : array_like, shape (n_s, 2n)
    V1 : array_like, shape (2n, 2n)
        Process noise intensity (symmetric PSD).
    V2 : array_like, shape (n_s, n_s)
        Measurement noise intensity (symmetric PD).
    alpha : float
        Stability margin ``>= 0`` [1/time unit].
    time_unit_s : float

    Returns
    -------
    KalmanDesign

    Raises
    ------
    ShapeError, MatrixPropertyError
        Bad shapes or noise matrices.
    StabilizabilityError
        ``(A + alpha I, C)`` not detectable: an eigenvalue with
        ``Re >= -alpha`` is unobservable (PBH).
    RiccatiError
        No stabilising solution.

    Notes
    -----
    Source: Eqs. (4.8)-(4.10), Refs. 57-58 of the dissertation (alpha shift).
    """
    A = check_square("A", A, "2n")
    n = A.shape[0]
    C = check_matrix("C", C, (None, n), ("n_s", "2n"))
    V1, V2 = _riccati_weights(V1, V2, n, C.shape[0], ("V1", "V2"), "n_s")
    a = check_positive_scalar("alpha", alpha, allow_zero=True)
    t = check_positive_scalar("time_unit_s", time_unit_s)
    check_detectable(A, C, shift=a, what="(A + alpha I, C)")
    As = A + a * np.eye(n)
    Sf = _care(As.T, C.T, V1, V2, "Kalman filter")
    K = Sf @ np.linalg.solve(V2, C).T
    res = _riccati_residual(As.T, C.T @ np.linalg.solve(V2, C), V1, Sf)
    eigs = scipy.linalg.eigvals(A - K @ C)
    return KalmanDesign(readonly(K), readonly(Sf), readonly(V1), readonly(V2), a,
                        readonly(eigs), res, t)
