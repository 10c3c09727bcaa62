"""Minimised maximum force direct rate feedback, MFDRF (Eqs. 4.30-4.32).

``minimise gamma  s.t.  sum_j |d_ij| <= gamma (all i),  zeta_j >= zeta_L (j <= n_m),
D = D^T, D > 0`` for ``u = -D y``. ``|d_ij|`` is handled exactly and smoothly
by epigraph variables ``t_ij >= d_ij, t_ij >= -d_ij`` (linear constraints)
and the row constraint ``d_ii + sum_{j != i} t_ij <= gamma``; the
dissertation replaced ``|d|`` by a quartic polynomial near zero, which
perturbs the optimum. Diagonal entries need no ``t``: ``D > 0`` makes them
positive. How the problem is solved: :mod:`controllers.drf`.
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from .drf_problem import (
    _ACTIVE_TOL,
    _bound_objective,
    _damping_active,
    _damping_constraint,
    _definiteness_constraint,
    _optional_perf,
    _Problem,
    _safe_perf,
    _validate_common,
)
from .drf_result import DrfDesign
from .drf_solve import _Program, _run
from .drf_start import _Base, _base_start, _check_reachable
from .errors import readonly

__all__ = ["mfdrf"]


def mfdrf(
    A,
    B,
    C,
    *,
    zeta_min: float,
    n_modes: int,
    n_starts: int = 4,
    seed: int = 0,
    min_eig: float | None = None,
    maxiter: int = 500,
    ftol: float = 1e-10,
    Q=None,
    R=None,
    initial_states=None,
    time_unit_s: float = 1.0,
) -> DrfDesign:
    """Minimised maximum force direct rate feedback (MFDRF, Eqs. 4.30-4.32).

    ``minimise gamma  s.t.  sum_j |d_ij| <= gamma (all i),  zeta_j >= zeta_L (j <= n_m),
    D = D^T, eig(D) >= min_eig``, solved as described in the module notes.

    Parameters
    ----------
    A : array_like, shape (2n, 2n)
        Plant, state ``[q'; q]`` [1/time unit].
    B : array_like, shape (2n, n_c)
    C : array_like, shape (n_c, 2n)
        Velocity sensors paired with the actuators (``[U^T, 0]`` when
        collocated; a general ``[Cv, 0]`` is accepted, stability is then
        verified rather than guaranteed).
    zeta_min : float
        ``zeta_L`` in (0, 1).
    n_modes : int
        ``n_m``: constrained modes (lowest by frequency).
    n_starts : int
        Number of optimiser starts (first: ``c I``; others random, seeded).
    seed : int
        Seed of :func:`numpy.random.default_rng` for the random starts.
    min_eig : float, optional
        Lower bound on the eigenvalues of ``D``; default ``1e-6 c`` with ``c``
        the first start's gain [force / (length per time unit)].
    maxiter, ftol : int, float
        SLSQP options.
    Q, R, initial_states : array_like, optional
        ``(2n, 2n)``, ``(n_c, n_c)``, ``(2n, n_f)``: if given, the performance
        index of the result is reported (Eqs. 4.33-4.36).
    time_unit_s : float
        Seconds per time unit (Hz and :meth:`DrfDesign.realize`).

    Returns
    -------
    DrfDesign
        ``kind="MFDRF"``, ``objective = gamma``.

    Raises
    ------
    ShapeError, MatrixPropertyError
        Bad shapes or parameters.
    InfeasibleDampingError
        A mode below ``zeta_L`` that the actuators (or sensors) cannot reach.

    Notes
    -----
    Source: Eqs. (4.30)-(4.32); BCC result in Table 7 (gamma = 0.050 lb*s/in
    for zeta_L = 0.03 on six modes), grid in Tables 11 and 15.
    """
    t0 = time.perf_counter()
    A, B, C, zl, nm, t = _validate_common(A, B, C, zeta_min, n_modes, min_eig, n_starts, time_unit_s)
    perf = _optional_perf(A, B, Q, R, initial_states)
    sens = _check_reachable(A, B, C, zl, nm, t)
    prob = _Problem(A, B, C, zeta_min=zl, n_modes=nm, diagonal=False)
    rng = np.random.default_rng(seed)
    base = _base_start(prob, sens, False, min_eig, maxiter, t, rng, n_starts)
    design = _run(prob, _mfdrf_program(prob, base), base, rng=rng, diagonal=False, n_starts=n_starts,
                  maxiter=maxiter, ftol=ftol, time_unit_s=t, t0=t0)
    if perf is not None:
        Qm, Rm, X0 = perf
        J = _safe_perf(A, B, C, design.gain, Qm, Rm, X0)
        design = replace(design, performance_index=readonly(J))
    return design


def _gamma(D: np.ndarray) -> float:
    """``gamma = max_i sum_j |d_ij|`` of Eq. (4.31) [force / (length per time unit)]."""
    return float(np.max(np.sum(np.abs(D), axis=1)))


def _row_sum_rows(prob: _Problem, n_var: int) -> np.ndarray:
    """Rows ``G`` of the linear constraints ``G x >= 0`` of the epigraph form of Eq. (4.31).

    ``x = [d/c (p), t/c (n_off), gamma/c]``: ``t_k - d_q >= 0`` and
    ``t_k + d_q >= 0`` for each off-diagonal entry ``q``, then
    ``gamma - d_ii - sum_j t_ij >= 0`` for each actuator ``i``.
    """
    p, off = prob.p, prob.off
    ig = n_var - 1
    lin_rows = []
    for k, q in enumerate(off):  # t_k - d_q >= 0 and t_k + d_q >= 0
        r1 = np.zeros(n_var); r1[p + k] = 1.0; r1[q] = -1.0
        r2 = np.zeros(n_var); r2[p + k] = 1.0; r2[q] = 1.0
        lin_rows += [r1, r2]
    for i in range(prob.nc):  # gamma - d_ii - sum_j t_ij >= 0
        r = np.zeros(n_var); r[ig] = 1.0
        r[prob.diag[i]] = -1.0
        for k, q in enumerate(off):
            if prob.pi[q] == i or prob.pj[q] == i:
                r[p + k] = -1.0
        lin_rows.append(r)
    return np.array(lin_rows)


def _mfdrf_program(prob: _Problem, base: _Base) -> _Program:
    """MFDRF as an SLSQP problem in ``x = [d/c (p), t/c (n_off), gamma/c]`` (Eqs. 4.31-4.32)."""
    c, eps = base.c, base.eps
    p, off = prob.p, prob.off
    n_off = off.size
    n_var = p + n_off + 1
    ig = n_var - 1
    G = _row_sum_rows(prob, n_var)
    cons = [
        {"type": "ineq", "fun": lambda x: G @ x, "jac": lambda x: G},
        _damping_constraint(prob, c, n_var),
        _definiteness_constraint(prob, c, eps, n_var),
    ]
    bounds = [(None, None)] * p + [(0.0, None)] * n_off + [(0.0, None)]

    def active(D):
        names = _damping_active(prob, D, eps, c)
        rows = np.sum(np.abs(D), axis=1)
        gam = rows.max()
        names += [f"row[{i + 1}]: sum|d| <= gamma"
                  for i in np.flatnonzero((gam - rows) / gam <= _ACTIVE_TOL)]
        return names

    def fill(x, d):
        x[p:p + n_off] = np.abs(d[off]) / c
        x[ig] = _gamma(prob.D(d)) / c

    return _Program("MFDRF", n_var, _bound_objective(ig, n_var), cons, ig, bounds, fill, _gamma, active)
