"""The LQR weight ``R = r I`` that gives the first ``n_m`` modes a prescribed damping (Sec. 4.1.1).

The dissertation chose ``Q`` and ``R`` "so as to insure a minimum value
zeta_L" of the closed-loop damping ratios; with ``Q`` fixed, the largest
``r`` that does so is the root of ``min_{j <= n_m} zeta_j(r) - zeta_L`` in
``log10 r``, found by Brent's method.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

from .errors import MatrixPropertyError, check_damping_bound, check_positive_scalar
from .lqr import LqrDesign, lqr
from .performance import _check_state_input, select_modes

__all__ = ["LqrWeightSearch", "lqr_weight_for_damping"]


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
    zl = check_damping_bound("zeta_min", zeta_min)
    if int(n_modes) < 1:
        raise MatrixPropertyError(f"n_modes: expected >= 1, found {n_modes}")
    r_lo, r_hi = (check_positive_scalar("r_bounds", v) for v in r_bounds)
    if r_lo >= r_hi:
        raise MatrixPropertyError(f"r_bounds: expected r_lo < r_hi, found {r_bounds}")
    A, B = _check_state_input(A, B)
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
        return float(np.min(d.damping_ratios[select_modes(d.eigenvalues, n_modes)])) - zl

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
