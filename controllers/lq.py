"""Linear quadratic designs: LQR, alpha-shifted Kalman filter, LQG, reduced controller on the full model.

Equations of Chapter 4 of the dissertation, one module each:

* LQR (Eqs. 4.4-4.7, :mod:`controllers.lqr`): ``F = R^-1 B^T S``,
  ``A^T S + S A - S B R^-1 B^T S + Q = 0``, ``J_min = x0^T S x0``; the weight
  ``R = r I`` for a damping bound (Sec. 4.1.1, :mod:`controllers.lqr_weight`).
* Kalman filter with stability margin alpha (Eqs. 4.8-4.10, :mod:`controllers.kalman`):
  ``(A + aI) S_f + S_f (A + aI)^T - S_f C^T V2^-1 C S_f + V1 = 0``,
  ``K = S_f C^T V2^-1``; every eigenvalue of ``A - K C`` has ``Re < -alpha``.
* LQG (Eqs. 4.11-4.22, :mod:`controllers.lqg`): closed loop
  ``Abar = [[A - BF, BF], [0, A - KC]]`` on ``[x; e]``, cost weight ``Qbar``,
  ``J = xbar0^T Pbar xbar0`` with ``xbar0 = [x0; x0]``.
* Reduced-model controller on the full model (Eqs. 4.23-4.29, :mod:`controllers.reduced`):
  ``A_E = [[A, -B F_R], [K_R C, A_R - K_R C_R - B_R F_R]]``, ``Q_E = diag(Q, F_R^T R F_R)``,
  ``x_E0 = [x0; 0]``, plus a spillover report.

Riccati equations are solved with :func:`scipy.linalg.solve_continuous_are`
(no slycot, no hand-written solver). Stabilisability and detectability are
checked first by the PBH test so that failures name the offending eigenvalue
(:mod:`controllers.riccati`).

This module gathers the public names of those modules, so that
``from controllers.lq import lqg`` works as it always has.
"""

from __future__ import annotations

from .kalman import KalmanDesign, kalman_filter
from .lqg import LqgDesign, lqg
from .lqr import LqrDesign, lqr
from .lqr_weight import LqrWeightSearch, lqr_weight_for_damping
from .reduced import ReducedOnFull, reduced_on_full
from .riccati import check_detectable, check_stabilizable

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
