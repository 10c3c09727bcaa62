"""controllers: the dissertation's control design module (Chapter 4, Sec. 5.3).

Depends on numpy, scipy and python-control only -- never on mujoco or
vlab -- and takes plain matrices (m, c, k, U, sensor selection). No design is
a quadratic programme (the DRF designs constrain closed-loop damping ratios,
eigenvalue functions of the gain: :mod:`controllers.drf` solves them with
SLSQP), so no QP solver is used.

Modules (import them directly; nothing is imported here, so importing the
package has no side effects and costs nothing):

* :mod:`controllers.statespace`  -- (m, c, k, U) -> A, B, C (Eqs. 3.2-3.3), time scaling,
  modal initial states
* :mod:`controllers.lq`          -- the LQ designs' public names, from
  :mod:`~controllers.riccati` (weights, PBH tests, Riccati solver),
  :mod:`~controllers.lqr` (Eqs. 4.4-4.7), :mod:`~controllers.lqr_weight` (R for a damping
  bound, Sec. 4.1.1), :mod:`~controllers.kalman` (alpha-shifted filter, Eqs. 4.8-4.10),
  :mod:`~controllers.lqg` (Eqs. 4.11-4.22), :mod:`~controllers.reduced` (reduced
  controller on the full model, Eq. 4.24, spillover)
* :mod:`controllers.drf`         -- the DRF designs' public names, from
  :mod:`~controllers.mfdrf` (Eqs. 4.30-4.32), :mod:`~controllers.lqdrf` (Eqs. 4.37-4.38:
  coupled, diagonal, LQR-normalised), :mod:`~controllers.drf_result`, and their steps
  :mod:`~controllers.drf_problem` (constraints, gradients, verification),
  :mod:`~controllers.drf_start` (starting points), :mod:`~controllers.drf_solve` (SLSQP multi-start)
* :mod:`controllers.performance` -- performance index by Lyapunov equations, damping ratios
* :mod:`controllers.realization` -- discrete F11/F12/F21/F22 (Eqs. 5.1-5.13)
* :mod:`controllers.pycontrol`   -- the plant, controllers and loops as python-control ``StateSpace``
* :mod:`controllers.errors`      -- exceptions (all subclass ValueError) and input checks
"""
