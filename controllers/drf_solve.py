"""The SLSQP multi-start driver of the DRF designs, and the verified result.

Each design (:func:`controllers.mfdrf.mfdrf`, :func:`controllers.lqdrf.lqdrf`)
states its problem as a :class:`_Program` in the scaled variables
``x = [d / c, ...]``; :func:`_run` solves it by
:func:`scipy.optimize.minimize` (SLSQP, analytic gradients) from every start
(:func:`controllers.drf_start._start_vectors`), verifies each end point
independently of the optimiser and returns the best start as a
:class:`~controllers.drf_result.DrfDesign`: converged and feasible before
feasible before infeasible. ``converged`` is ``False`` with the reason
whenever the optimiser failed or the answer violates a constraint, so a gain
is never returned silently wrong.

The minimax programs (MFDRF's largest row sum, LQDRF's largest performance
ratio) can have a whole face of optimal gains: on the hanging grid, starts that
reach the same ``gamma`` end at gains whose closed-loop damping ratios differ
by up to 25 %, so the design would depend on the random starts' seed. The
best start is therefore followed by a second, lexicographic stage
(:func:`_least_norm`): among the gains whose objective stays within
:data:`TIE_TOL` of the optimum, the one of least Frobenius norm (the least
feedback among equally good designs; a strictly convex objective, so one gain
where that face is convex). Where the optimum is a single point the stage
still moves the gain, by about the square root of :data:`TIE_TOL` in units of
the objective's curvature: on the BCC's LQDRF, whose largest performance index
is nearly flat in the gain, 1.3 % of the gain (the closed-loop damping of mode
1 0.903 -> 0.891) for a rise of beta by 1e-6; a smaller tolerance leaves the
grid's faces seed-dependent again (LQDRF: 0.8 % between seeds at 1e-8), and a
regularised objective ``t + eps ||D||^2`` either does not move SLSQP off the
face (eps of 1e-6 of ``t``) or moves a nearly flat optimum by more (1.5 % at
1e-4, 11 % at 1e-3). Source: lexicographic optimisation of a degenerate
program (K. Miettinen, *Nonlinear Multiobjective Optimization*, 1999, Sec.
2.6); the minimum-norm choice among minimisers as in least-norm least squares.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
from scipy.optimize import minimize

from .drf_problem import _Problem, _violations
from .drf_result import DrfDesign, DrfStart
from .drf_start import _Base, _start_vectors
from .errors import readonly
from .performance import _damping_and_gradient, modes

__all__: list[str] = []  # helpers of controllers.mfdrf and controllers.lqdrf only

#: Relative rise of the objective (``gamma`` or ``beta``) allowed to the least-norm stage: far below any
#: precision the objective is stated to (the thesis prints 2-4 digits) and above SLSQP's accuracy of the
#: optimum (``ftol`` 1e-10); the gain itself may move by more where the objective is flat (module notes).
TIE_TOL = 1e-6


@dataclass(frozen=True)
class _Program:
    """One DRF design as an SLSQP problem in ``x = [d / c, ...]`` (``c``: the base start's scale).

    Attributes
    ----------
    kind : str
        :attr:`DrfDesign.kind`.
    n_var : int
        Length of ``x``: the ``p`` gain parameters, then the design's own variables.
    fun : callable
        ``x -> (objective, gradient)``.
    constraints : list of dict
        SLSQP inequality constraints ``g(x) >= 0`` with their Jacobians.
    bound : int
        Index in ``x`` of the objective's bound variable (the epigraph form: ``fun(x) = x[bound]``).
    bounds : list of (float or None, float or None), or None
    fill : callable
        ``fill(x, d)`` sets the variables after the ``p`` gains of a start with gain parameters ``d``.
    objective_of : callable
        ``D -> gamma`` or ``beta`` (design units), recomputed from the gain.
    active : callable
        ``D -> list of str``, the constraints active at ``D``.
    """

    kind: str
    n_var: int
    fun: Callable
    constraints: list
    bound: int
    bounds: list | None
    fill: Callable
    objective_of: Callable
    active: Callable


def _run(prob: _Problem, program: _Program, base: _Base, *, rng: np.random.Generator, diagonal: bool,
         n_starts: int, maxiter: int, ftol: float, time_unit_s: float, t0: float) -> DrfDesign:
    """Solve ``program`` from ``base`` and ``n_starts - 1`` random starts; the best verified design, then its
    least-norm stage (:func:`_least_norm`; module notes).

    Where phase one found no gain meeting the damping bounds (``base.note``),
    the design is the best-effort base gain, ``converged=False``. ``t0`` is the
    :func:`time.perf_counter` at the start of the design.
    """
    if base.note:
        return _infeasible_design(prob, program, base, time_unit_s, t0)
    x0s = _start_vectors(prob, rng, base.d, diagonal, n_starts, program.n_var, base.c, program.fill)
    records = _solve(x0s, program.fun, program.constraints, program.bounds, maxiter, ftol)
    design = _finish(prob, program, records, base, time_unit_s, t0)
    if not design.converged:
        return design
    x, note = _least_norm(prob, program, base, design.gain, maxiter, ftol)
    if x is None:
        return replace(design, message=f"{design.message}; {note}")
    D = prob.D(base.c * x[:prob.p])
    return _design_of(prob, program, D, base.eps, converged=True, message=f"{design.message}; {note}",
                      iterations=design.iterations, starts=design.starts, t=time_unit_s, t0=t0)


def _least_norm(prob: _Problem, program: _Program, base: _Base, D_best: np.ndarray, maxiter: int,
                ftol: float) -> tuple[np.ndarray | None, str]:
    """The second stage of :func:`_run` (module notes): from the best gain ``D_best``, the gain of least
    ``||D||_F`` whose objective is within :data:`TIE_TOL` of ``D_best``'s, under every constraint of
    ``program``. Returns its variables ``x`` and a note, or None and the reason when that stage fails or
    its end point does not verify (the best start's gain is then kept)."""
    p, c = prob.p, base.c
    # ||D||_F^2 = sum_q w_q d_q^2: a diagonal entry counts once, an off-diagonal one twice
    w = np.array([np.sum(prob.D(np.eye(p)[q]) ** 2) for q in range(p)])
    obj0 = program.objective_of(D_best)
    x0 = np.zeros(program.n_var)
    x0[:p] = D_best[prob.pi, prob.pj] / c
    program.fill(x0, c * x0[:p])
    cap = x0[program.bound] * (1.0 + TIE_TOL)
    bounds = list(program.bounds) if program.bounds is not None else [(None, None)] * program.n_var
    lo = bounds[program.bound][0]
    bounds[program.bound] = (lo, cap)

    def fun(x):
        g = np.zeros(program.n_var)
        g[:p] = w * x[:p]
        return 0.5 * float(np.sum(w * x[:p] ** 2)), g

    res = minimize(fun, x0, jac=True, method="SLSQP", constraints=program.constraints, bounds=bounds,
                   options={"maxiter": int(maxiter), "ftol": float(ftol)})
    D = prob.D(c * res.x[:p])
    viol, _ = _violations(prob, D, base.eps, c)
    obj = program.objective_of(D)
    if not res.success or viol or not obj <= obj0 * (1.0 + 2.0 * TIE_TOL):
        why = res.message if not res.success else "; ".join(viol) if viol else f"objective {obj:.6g} > {obj0:.6g}"
        return None, f"least-norm stage not taken ({why})"
    n0, n1 = float(np.linalg.norm(D_best)), float(np.linalg.norm(D))
    if n1 > n0:
        return None, "least-norm stage not taken (no smaller gain)"
    return res.x, f"least-norm gain among the optima (||D||_F {n0:.6g} -> {n1:.6g})"


def _solve(x0s, fun, cons, bounds, maxiter, ftol):
    """Run SLSQP from every start; return [(start, OptimizeResult)]."""
    records = []
    for s, x0 in enumerate(x0s):
        res = minimize(fun, x0, jac=True, method="SLSQP", constraints=cons, bounds=bounds,
                       options={"maxiter": int(maxiter), "ftol": float(ftol)})
        records.append((s, res))
    return records


def _finish(prob: _Problem, program: _Program, records, base: _Base, t: float, t0: float) -> DrfDesign:
    """Pick the best start, verify it, and build the DrfDesign.

    Ranking: converged and feasible < feasible < infeasible (by total violation).
    """
    starts = []
    best = None
    for s, res in records:
        D = prob.D(base.c * res.x[:prob.p])
        viol, size = _violations(prob, D, base.eps, base.c)
        obj = program.objective_of(D)
        starts.append(DrfStart(s, obj, bool(res.success), not viol, int(res.nit),
                               int(res.nfev) + int(getattr(res, "njev", 0)), str(res.message)))
        rank = (0, obj) if (res.success and not viol) else (1, obj) if not viol else (2, size)
        if best is None or rank < best[0]:
            best = (rank, s, res, D, viol)
    _, s, res, D, viol = best
    converged = bool(res.success) and not viol
    if converged:
        msg = f"SLSQP: {res.message} (start {s} of {len(records)})"
    elif not viol:
        msg = (f"feasible but the optimiser did not report convergence: {res.message} "
               f"(start {s} of {len(records)})")
    else:
        msg = (f"no start reached a feasible point (best start {s}: {res.message}); "
               f"violated: {'; '.join(viol)}")
    return _design_of(prob, program, D, base.eps, converged=converged, message=msg,
                      iterations=int(res.nit), starts=tuple(starts), t=t, t0=t0)


def _infeasible_design(prob: _Problem, program: _Program, base: _Base, t: float, t0: float) -> DrfDesign:
    """The design returned when phase one found no feasible gain: converged=False, best effort gain."""
    D = prob.D(base.d)
    viol, _ = _violations(prob, D, base.eps, base.c)
    return _design_of(prob, program, D, base.eps, converged=False,
                      message=f"infeasible: {base.note}; violated: {'; '.join(viol)}",
                      iterations=0, starts=(), t=t, t0=t0)


def _design_of(prob: _Problem, program: _Program, D: np.ndarray, min_eig: float, *, converged: bool,
               message: str, iterations: int, starts: tuple[DrfStart, ...], t: float, t0: float) -> DrfDesign:
    """The DrfDesign of gain ``D``: closed-loop modes, row sums ``f_i = sum_j |d_ij|`` (Eq. 4.31), the
    constrained damping ratios (Eqs. 4.32, 4.38), objective and active constraints of ``program``."""
    md = modes(prob.A - prob.B @ D @ prob.C, time_unit_s=t)
    zeta_c, _, _ = _damping_and_gradient(prob.A, prob.B, prob.C, D, prob.nm)
    rows = np.sum(np.abs(D), axis=1)
    return DrfDesign(
        kind=program.kind,
        gain=readonly(D),
        objective=float(program.objective_of(D)),
        gamma=float(np.max(rows)),
        row_sums=readonly(rows),
        beta=None,
        constrained_damping=readonly(zeta_c),
        eigenvalues=md.eigenvalues,
        damping_ratios=md.damping_ratios,
        frequencies_hz=md.frequencies_hz,
        zeta_min=prob.zl,
        n_modes=prob.nm,
        min_eig=float(min_eig),
        performance_index=None,
        performance_ratio=None,
        converged=converged,
        message=message,
        iterations=iterations,
        evaluations=prob.n_eval,
        active_constraints=tuple(program.active(D)),
        starts=starts,
        wall_time_s=time.perf_counter() - t0,
        time_unit_s=t,
    )
