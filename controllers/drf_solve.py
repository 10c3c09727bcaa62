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
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize

from .drf_problem import _Problem, _violations
from .drf_result import DrfDesign, DrfStart
from .drf_start import _Base, _start_vectors
from .errors import readonly
from .performance import _damping_and_gradient, modes

__all__: list[str] = []  # helpers of controllers.mfdrf and controllers.lqdrf only


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
    bounds: list | None
    fill: Callable
    objective_of: Callable
    active: Callable


def _run(prob: _Problem, program: _Program, base: _Base, *, rng: np.random.Generator, diagonal: bool,
         n_starts: int, maxiter: int, ftol: float, time_unit_s: float, t0: float) -> DrfDesign:
    """Solve ``program`` from ``base`` and ``n_starts - 1`` random starts; the best verified design.

    Where phase one found no gain meeting the damping bounds (``base.note``),
    the design is the best-effort base gain, ``converged=False``. ``t0`` is the
    :func:`time.perf_counter` at the start of the design.
    """
    if base.note:
        return _infeasible_design(prob, program, base, time_unit_s, t0)
    x0s = _start_vectors(prob, rng, base.d, diagonal, n_starts, program.n_var, base.c, program.fill)
    records = _solve(x0s, program.fun, program.constraints, program.bounds, maxiter, ftol)
    return _finish(prob, program, records, base, time_unit_s, t0)


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
