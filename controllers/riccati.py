"""What every Riccati design of Chapter 4 needs: its weights checked, the PBH tests, the solver.

* Weights: ``Q`` (PSD) and ``R`` (PD) of the LQR (Eq. 4.5), or their duals
  ``V1``, ``V2`` of the Kalman filter (Eq. 4.9).
* Stabilisability / detectability by the PBH rank test, so that a failure
  names the offending eigenvalue before the Riccati solver is called (with a
  shift ``alpha`` for the alpha-shifted filter, Eqs. 4.8-4.10).
* The algebraic Riccati equations (Eqs. 4.6, 4.9) are solved with
  :func:`scipy.linalg.solve_continuous_are` (no slycot, no hand-written solver)
  and their scaled residual is reported.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from .errors import (
    RiccatiError,
    StabilizabilityError,
    check_matrix,
    check_positive_definite,
    check_positive_semidefinite,
    check_square,
)

__all__ = ["check_stabilizable", "check_detectable"]


def _riccati_weights(W1, W2, n: int, m: int, names: tuple[str, str] = ("Q", "R"),
                     m_symbol: str = "n_c") -> tuple[np.ndarray, np.ndarray]:
    """The two weights of a Riccati design, checked and symmetrised.

    ``W1`` (2n, 2n) symmetric positive semi-definite, ``W2`` (m, m) symmetric
    positive definite: ``Q`` and ``R`` of the LQR (``m = n_c``), or their duals
    ``V1`` and ``V2`` of the Kalman filter (``m = n_s``); ``names`` name them
    in the messages.
    """
    n1, n2 = names
    W1 = check_positive_semidefinite(n1, check_matrix(n1, W1, (n, n), ("2n", "2n")))
    W2 = check_positive_definite(n2, check_matrix(n2, W2, (m, m), (m_symbol, m_symbol)))
    return W1, W2


def check_stabilizable(A, B, *, shift: float = 0.0, what: str = "(A, B)") -> None:
    """PBH test: every eigenvalue with ``Re(lambda) + shift >= 0`` is controllable.

    Parameters
    ----------
    A : array_like, shape (N, N)
    B : array_like, shape (N, m)
    shift : float
        ``alpha`` of an alpha-shifted design (test ``A + alpha I``).
    what : str
        Name of the pair for the message.

    Raises
    ------
    StabilizabilityError
        If ``rank [A - lambda I, B] < N`` (smallest singular value below
        ``1e-12 * max(|A|, |B|, |lambda|)``: relative to the norm, so that stiff models
        whose fastest modes dominate |A| are not refused) for such an eigenvalue; names it.

    Notes
    -----
    Only eigenvalues with ``Re >= -shift`` (to ``1e-9 |lambda|``) are tested: the
    others are stable already. Undamped structures have all eigenvalues on the
    imaginary axis, so every mode must be reachable.
    """
    A = check_square("A", A, "N")
    n = A.shape[0]
    B = check_matrix("B", B, (n, None), ("N", "m"))
    eigs = scipy.linalg.eigvals(A)
    scale = max(np.linalg.norm(A, 2), np.linalg.norm(B, 2), 1e-300)
    for lam in eigs:
        if lam.imag < 0:
            continue
        if lam.real + shift < -1e-9 * max(1.0, abs(lam)):
            continue
        M = np.hstack([A - lam * np.eye(n), B.astype(complex)])
        smin = np.linalg.svd(M, compute_uv=False)[-1]
        if smin <= 1e-12 * max(scale, abs(lam)):
            region = "Re >= 0" if shift == 0 else f"Re >= -alpha = {-shift:g}"
            raise StabilizabilityError(
                f"{what} is not stabilisable/detectable: eigenvalue {lam:.6g} ({region}) fails the "
                f"PBH rank test (smallest singular value {smin:.2e}); no gain can move it"
            )


def check_detectable(A, C, *, shift: float = 0.0, what: str = "(A, C)") -> None:
    """PBH test for detectability of ``(A + shift I, C)`` (dual of :func:`check_stabilizable`).

    Parameters
    ----------
    A : array_like, shape (N, N)
    C : array_like, shape (p, N)
    shift : float
        ``alpha`` of the alpha-shifted filter.
    what : str
        Name of the pair for the message.

    Raises
    ------
    StabilizabilityError
        If an eigenvalue with ``Re + shift >= 0`` is unobservable; names it.
    """
    A = check_square("A", A, "N")
    C = check_matrix("C", C, (None, A.shape[0]), ("p", "N"))
    check_stabilizable(A.T, C.T, shift=shift, what=what)


def _care(a, b, q, r, name: str) -> np.ndarray:
    """Stabilising solution of ``a^T S + S a - S b r^-1 b^T S + q = 0`` (Eqs. 4.6, 4.9), symmetrised.

    Raises ``RiccatiError`` (naming the design ``name``) when the solver fails or
    returns a non-finite ``S``.
    """
    try:
        S = scipy.linalg.solve_continuous_are(a, b, q, r)
    except (np.linalg.LinAlgError, ValueError) as exc:
        raise RiccatiError(f"{name}: no stabilising Riccati solution ({exc})") from None
    if not np.all(np.isfinite(S)):
        raise RiccatiError(f"{name}: Riccati solution is not finite")
    return 0.5 * (S + S.T)


def _riccati_residual(A, G, Q, S) -> float:
    """Scaled residual ``|A^T S + S A - S G S + Q| / (|A^T S| + |S A| + |S G S| + |Q|)``."""
    t1, t2, t3 = A.T @ S, S @ A, S @ G @ S
    res = t1 + t2 - t3 + Q
    den = sum(np.linalg.norm(x) for x in (t1, t2, t3, Q))
    return float(np.linalg.norm(res) / max(den, 1e-300))
