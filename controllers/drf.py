"""Direct rate feedback: MFDRF and LQDRF (coupled, diagonal, LQR-normalised).

Closed loop: ``u = -D y`` with ``y = C x`` the (collocated) sensor velocities
(Eq. 4.30), so ``A_cl = A - B D C``. ``D`` is symmetric positive definite,
which with collocated pairs (``C = [U^T, 0]``) only dissipates energy and
keeps the loop stable (Sec. 4.2.1).

* MFDRF (Eqs. 4.31-4.32): minimise ``gamma`` s.t. ``sum_j |d_ij| <= gamma``
  for every actuator ``i``, ``zeta_j >= zeta_L`` on the first ``n_m`` modes,
  ``D > 0``.
* LQDRF (Eqs. 4.37-4.38): minimise ``beta`` s.t. ``J_i <= beta`` for the
  initial states ``x0 = [0; phi_i]`` of the first ``n_f`` modes, with the same
  damping and definiteness constraints; optionally ``D`` diagonal (Sec. 6.2)
  and/or the LQR-normalised form ``J_i / J_i^LQR <= beta`` (Sec. 6.2.1).

How the problems are solved (differences from the thesis' NEWSUMT-A)
-------------------------------------------------------------------
* :func:`scipy.optimize.minimize` with SLSQP, analytic gradients throughout:
  damping ratios by the eigenvalue derivative
  ``d lambda / dD = -(w^H B)^T (C v) / (w^H v)`` (left/right eigenvectors
  ``w, v``), the performance index by the adjoint Lyapunov equation
  (``A_cl L + L A_cl^T + x0 x0^T = 0``, ``dJ/dD = -2 B^T P L C^T + 2 R D C L C^T``),
  the eigenvalues of ``D`` by ``d mu / dD = u u^T``.
* ``|d_ij|`` is handled *exactly and smoothly* by epigraph variables
  ``t_ij >= d_ij, t_ij >= -d_ij`` (linear constraints) and the row constraint
  ``d_ii + sum_{j != i} t_ij <= gamma``; the thesis replaced ``|d|`` by a
  quartic polynomial near zero, which perturbs the optimum. (Diagonal entries
  need no ``t``: ``D > 0`` makes them positive.)
* ``D > 0`` is imposed as ``mu_k(D) >= min_eig`` for every eigenvalue of ``D``
  (``min_eig`` small and positive); diagonal ``D`` uses simple bounds.
* Several starts: ``c I`` with the smallest ``c`` on a log grid that meets the
  damping constraints (if none does, a phase-one SLSQP problem maximises the
  worst damping margin over ``D > 0``; if that stays negative the design is
  reported infeasible with the limiting modes), then random symmetric
  positive definite perturbations ``D0^1/2 M D0^1/2`` with ``M`` drawn from
  ``numpy.random.default_rng(seed)`` (reproducible). The best feasible
  converged start is kept (each start is recorded) and followed by a
  least-norm stage: among the gains whose objective is within a relative
  1e-6 of it, the one of least Frobenius norm, so that a face of optima gives
  one gain whatever the seed (:mod:`controllers.drf_solve`).
* "The first n_m modes" are the closed-loop eigenvalues sorted by ``|lambda|``
  with a real eigenvalue counting one half (see
  :func:`controllers.performance.select_modes`); an over-damped mode whose
  fast real eigenvalue moves above mode ``n_m`` makes the next mode
  constrained too (conservative: never fewer constraints than asked).
* The result is verified independently (damping, definiteness, stability) and
  ``converged`` is ``False`` with the reason whenever the optimiser failed or
  the answer violates a constraint: a gain is never returned silently wrong.

Variables are scaled by the gain of the first start so SLSQP sees O(1)
numbers; damping constraints are divided by ``zeta_L``.

Modules, one step each: :mod:`controllers.drf_result` (the result types),
:mod:`controllers.drf_problem` (gain parameters, constraints and their
gradients, the verification), :mod:`controllers.drf_start` (reachability,
the ``c I`` scan, phase one, random starts), :mod:`controllers.drf_solve`
(the SLSQP multi-start driver), :mod:`controllers.mfdrf` and
:mod:`controllers.lqdrf` (the two designs). This module gathers their public
names, so that ``from controllers.drf import mfdrf`` works as it always has.
"""

from __future__ import annotations

from .drf_result import DrfDesign, DrfStart
from .lqdrf import lqdrf
from .mfdrf import mfdrf

__all__ = ["DrfStart", "DrfDesign", "mfdrf", "lqdrf"]
