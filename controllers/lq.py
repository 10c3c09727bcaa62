"""Linear quadratic designs: LQR, alpha-shifted Kalman filter, LQG, reduced controller on the full model.

Equations of Chapter 4 of the dissertation:

* LQR (Eqs. 4.4-4.7): ``F = R^-1 B^T S``, ``A^T S + S A - S B R^-1 B^T S + Q = 0``,
  ``J_min = x0^T S x0``.
* Kalman filter with stability margin alpha (Eqs. 4.8-4.10):
  ``(A + aI) S_f + S_f (A + aI)^T - S_f C^T V2^-1 C S_f + V1 = 0``,
  ``K = S_f C^T V2^-1``; every eigenvalue of ``A - K C`` has ``Re < -alpha``.
* LQG (Eqs. 4.11-4.22): closed loop ``Abar = [[A - BF, BF], [0, A - KC]]`` on
  ``[x; e]``, cost weight ``Qbar``, ``J = xbar0^T Pbar xbar0`` with ``xbar0 = [x0; x0]``.
* Reduced-model controller on the full model (Eqs. 4.23-4.29):
  ``A_E = [[A, -B F_R], [K_R C, A_R - K_R C_R - B_R F_R]]``, ``Q_E = diag(Q, F_R^T R F_R)``,
  ``x_E0 = [x0; 0]``, plus a spillover report.

Riccati equations are solved with :func:`scipy.linalg.solve_continuous_are`
(no slycot, no hand-written solver). Stabilisability and detectability are
checked first by the PBH test so that failures name the offending eigenvalue.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg
from scipy.optimize import brentq

from .errors import (
    MatrixPropertyError,
    RiccatiError,
    StabilizabilityError,
    check_matrix,
    check_positive_definite,
    check_positive_scalar,
    check_positive_semidefinite,
    check_square,
    readonly,
)
from .performance import SpilloverReport, modes, performance_index, spillover
from .realization import DiscreteRealization, estimator_realization, state_feedback_realization

__all__ = [
    "check_stabilizable",
    "check_detectable",
    "LqrDesign",
    "lqr",
    "LqrWeightSearch",
    "lqr_weight_for_damping",
    "KalmanDesign",
    "kalman_filter",
    "LqgDesign",
    "lqg",
    "ReducedOnFull",
    "reduced_on_full",
]


# --------------------------------------------------------------------------- checks
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


def _initial_states(initial_states, n_states: int) -> np.ndarray:
    """The initial states ``x0_i`` of the performance indices as columns: shape (2n, n_f), ``2n = n_states``."""
    return check_matrix("initial_states", initial_states, (n_states, None), ("2n", "n_f"))


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


# --------------------------------------------------------------------------- LQR
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
    A = check_square("A", A, "2n")
    n = A.shape[0]
    B = check_matrix("B", B, (n, None), ("2n", "n_c"))
    Q, R = _riccati_weights(Q, R, n, B.shape[1])
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


@dataclass(frozen=True, eq=False)
class LqrWeightSearch:
    """Result of :func:`lqr_weight_for_damping`.

    Attributes
    ----------
    r : float
        Scalar of ``R = r I``.
    design : LqrDesign
        The LQR design at ``r``.
    min_damping : float
        Smallest damping ratio over the first ``n_modes`` closed-loop modes.
    converged : bool
    message : str
    iterations : int
        Number of LQR designs evaluated.
    """

    r: float
    design: LqrDesign
    min_damping: float
    converged: bool
    message: str
    iterations: int


def lqr_weight_for_damping(
    A,
    B,
    Q,
    *,
    zeta_min: float,
    n_modes: int,
    r_bounds: tuple[float, float] = (1e-10, 1e10),
    log10_tol: float = 1e-10,
    time_unit_s: float = 1.0,
) -> LqrWeightSearch:
    """Find ``r`` in ``R = r I`` so that the first ``n_m`` LQR modes have ``min zeta = zeta_L``.

    Root of ``g(log10 r) = min_{j <= n_m} zeta_j(r) - zeta_L`` by Brent's method
    (:func:`scipy.optimize.brentq`) on ``log10 r`` in ``r_bounds``; closed-loop
    modes are sorted by frequency and mode ``j`` is the ``j``-th (see
    :func:`controllers.performance.select_modes`). Large ``r`` (expensive
    control) gives little damping, small ``r`` much; the largest ``r`` meeting
    the requirement is the intent (Sec. 4.1.1: "Q and R ... selected so as to
    insure a minimum value zeta_L").

    Parameters
    ----------
    A : array_like, shape (2n, 2n)
    B : array_like, shape (2n, n_c)
    Q : array_like, shape (2n, 2n)
    zeta_min : float
        ``zeta_L`` [-], in (0, 1).
    n_modes : int
        ``n_m``.
    r_bounds : (float, float)
        Search interval for ``r``.
    log10_tol : float
        Tolerance on ``log10 r``.
    time_unit_s : float

    Returns
    -------
    LqrWeightSearch
        ``converged=False`` (with the reason) when the bracket holds no root;
        the design then is the one at the end of the interval closest to
        meeting the requirement.

    Raises
    ------
    ShapeError, MatrixPropertyError, StabilizabilityError, RiccatiError
        As :func:`lqr`.

    Notes
    -----
    Source: Sec. 4.1.1, Sec. 6.1 (BCC: Q = I, R = 0.22 I gives 3 %), Sec. 6.2.1
    (grid: Q = 0.01 I, R = 0.84 I).
    """
    zl = check_positive_scalar("zeta_min", zeta_min)
    if zl >= 1.0:
        raise MatrixPropertyError(f"zeta_min: expected 0 < zeta_L < 1, found {zeta_min}")
    if int(n_modes) < 1:
        raise MatrixPropertyError(f"n_modes: expected >= 1, found {n_modes}")
    r_lo, r_hi = (check_positive_scalar("r_bounds", v) for v in r_bounds)
    if r_lo >= r_hi:
        raise MatrixPropertyError(f"r_bounds: expected r_lo < r_hi, found {r_bounds}")
    A = check_square("A", A, "2n")
    B = check_matrix("B", B, (A.shape[0], None), ("2n", "n_c"))
    eye = np.eye(B.shape[1])
    count = [0]
    cache: dict[float, LqrDesign] = {}

    def design(s: float) -> LqrDesign:
        if s not in cache:
            count[0] += 1
            cache[s] = lqr(A, B, Q, 10.0**s * eye, time_unit_s=time_unit_s)
        return cache[s]

    def g(s: float) -> float:
        d = design(s)
        return float(np.min(d.damping_ratios[: _n_entries(d.eigenvalues, n_modes)])) - zl

    s_lo, s_hi = np.log10(r_lo), np.log10(r_hi)
    g_lo, g_hi = g(s_lo), g(s_hi)
    if g_hi >= 0.0:
        d = design(s_hi)
        return LqrWeightSearch(r_hi, d, g_hi + zl, True,
                               f"already met at the upper bound r = {r_hi:g}", count[0])
    if g_lo < 0.0:
        d = design(s_lo)
        return LqrWeightSearch(
            r_lo, d, g_lo + zl, False,
            f"zeta_L = {zl:g} not reached on the first {n_modes} modes even at r = {r_lo:g} "
            f"(min zeta = {g_lo + zl:.4g})", count[0],
        )
    s = brentq(g, s_lo, s_hi, xtol=log10_tol, rtol=4 * np.finfo(float).eps, maxiter=200)
    # step to the feasible side of the root
    while g(s) < 0.0 and s > s_lo:
        s -= log10_tol
    d = design(s)
    return LqrWeightSearch(10.0**s, d, g(s) + zl, True, "root found (brentq on log10 r)", count[0])


def _n_entries(eigs: np.ndarray, n_modes: int) -> int:
    weights = np.where(np.asarray(eigs).imag > 0, 1.0, 0.5)
    before = np.concatenate([[0.0], np.cumsum(weights)[:-1]])
    return int(np.count_nonzero(before < n_modes - 1e-12))


# --------------------------------------------------------------------------- Kalman
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


# --------------------------------------------------------------------------- LQG
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


# --------------------------------------------------------------------------- reduced on full
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
