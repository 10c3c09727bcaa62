"""Linear quadratic direct rate feedback, LQDRF (Eqs. 4.37-4.38), coupled, diagonal or LQR-normalised.

``minimise beta  s.t.  J_i <= beta (i <= n_f),  zeta_j >= zeta_L (j <= n_m),
D = D^T, D > 0`` with ``J_i`` the quadratic performance index of ``u = -D y``
(Eqs. 4.33-4.36) from the initial state ``x0_i = [0; phi_i]``. Variants:
``D`` diagonal (uncoupled "electric dashpots", Sec. 6.2; ``D > 0`` by simple
bounds) and ``J_i / J_i^LQR <= beta`` (Sec. 6.2.1). SLSQP sees
``J_i / ref_i`` with ``ref_i`` the LQR's ``J_i`` (normalised) or the largest
``J_i`` of the base start. How the problem is solved: :mod:`controllers.drf`.
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
from .lqr import lqr

__all__ = ["lqdrf"]


def lqdrf(
    A,
    B,
    C,
    Q,
    R,
    initial_states,
    *,
    zeta_min: float,
    n_modes: int,
    diagonal: bool = False,
    lqr_normalised: bool = False,
    n_starts: int = 4,
    seed: int = 0,
    min_eig: float | None = None,
    maxiter: int = 500,
    ftol: float = 1e-10,
    time_unit_s: float = 1.0,
) -> DrfDesign:
    """Linear quadratic direct rate feedback (LQDRF, Eqs. 4.37-4.38).

    ``minimise beta  s.t.  J_i <= beta (i <= n_f),  zeta_j >= zeta_L (j <= n_m),
    D = D^T, eig(D) >= min_eig`` with ``J_i`` the quadratic performance index
    (Eqs. 4.33-4.36) for the initial state ``x0_i = [0; phi_i]``. Variants:
    ``diagonal=True`` (uncoupled "electric dashpots", Sec. 6.2) and
    ``lqr_normalised=True`` (``J_i / J_i^LQR <= beta``, Sec. 6.2.1, with the
    LQR design for the same ``Q``, ``R``).

    Parameters
    ----------
    A : array_like, shape (2n, 2n)
    B : array_like, shape (2n, n_c)
    C : array_like, shape (n_c, 2n)
    Q : array_like, shape (2n, 2n)
        State weight (same as the LQ design).
    R : array_like, shape (n_c, n_c)
        Control weight, positive definite.
    initial_states : array_like, shape (2n, n_f)
        Columns ``[0; phi_i]`` (see :func:`controllers.statespace.modal_initial_states`).
    zeta_min : float
    n_modes : int
    diagonal : bool
    lqr_normalised : bool
    n_starts, seed, min_eig, maxiter, ftol, time_unit_s
        As :func:`mfdrf`.

    Returns
    -------
    DrfDesign
        ``objective = beta``; ``performance_index`` = ``J_i``;
        ``performance_ratio`` = ``J_i / J_i^LQR`` when normalised.

    Raises
    ------
    ShapeError, MatrixPropertyError
        Bad shapes or weights.
    InfeasibleDampingError
        A mode below ``zeta_L`` that the actuators (or sensors) cannot reach.
    StabilizabilityError, RiccatiError
        From the LQR reference design when ``lqr_normalised``.

    Notes
    -----
    Source: Eqs. (4.37)-(4.38), Sec. 6.2.1; Tables 7, 11, 13, 15.
    """
    t0 = time.perf_counter()
    A, B, C, zl, nm, t = _validate_common(A, B, C, zeta_min, n_modes, min_eig, n_starts, time_unit_s)
    Q, R, X0 = _optional_perf(A, B, Q, R, initial_states)
    sens = _check_reachable(A, B, C, zl, nm, t)
    ref = lqr(A, B, Q, R, time_unit_s=t).performance_index(X0) if lqr_normalised else None
    prob = _Problem(A, B, C, zeta_min=zl, n_modes=nm, diagonal=diagonal, Q=Q, R=R, X0=X0)
    rng = np.random.default_rng(seed)
    base = _base_start(prob, sens, diagonal, min_eig, maxiter, t, rng, n_starts)
    if not lqr_normalised:
        j0 = prob.perf(base.d)["J"]
        ref = np.full(X0.shape[1], float(np.max(j0)) if np.all(np.isfinite(j0)) else 1.0)
    program = _lqdrf_program(prob, base, ref, diagonal=diagonal, lqr_normalised=lqr_normalised)
    design = _run(prob, program, base, rng=rng, diagonal=diagonal, n_starts=n_starts, maxiter=maxiter,
                  ftol=ftol, time_unit_s=t, t0=t0)
    J = _safe_perf(A, B, C, design.gain, Q, R, X0)
    return replace(
        design,
        performance_index=readonly(J),
        performance_ratio=readonly(J / ref) if lqr_normalised else None,
        beta=design.objective,
    )


def _lqdrf_program(prob: _Problem, base: _Base, ref: np.ndarray, *, diagonal: bool,
                   lqr_normalised: bool) -> _Program:
    """LQDRF as an SLSQP problem in ``x = [d/c (p), beta']`` with ``J_i / ref_i <= beta'`` (Eqs. 4.37-4.38).

    ``ref`` (n_f,) divides the performance indices: ``J_i^LQR`` when
    ``lqr_normalised`` (then ``beta = beta'``), else one common scale (then
    ``beta = ref_0 beta'``).
    """
    c, eps, p = base.c, base.eps, prob.p
    n_var = p + 1
    ib = p

    def jfun(x):
        return x[ib] - prob.perf(c * x[:p])["J"] / ref

    def jjac(x):
        ev = prob.perf(c * x[:p])
        out = np.zeros((ref.size, n_var))
        out[:, :p] = -ev["dJ"] * c / ref[:, None]
        out[:, ib] = 1.0
        return out

    cons = [
        {"type": "ineq", "fun": jfun, "jac": jjac},
        _damping_constraint(prob, c, n_var),
    ]
    if diagonal:
        bounds = [(eps / c, None)] * p + [(None, None)]
    else:
        bounds = None
        cons.append(_definiteness_constraint(prob, c, eps, n_var))

    def ratios(D):
        return _safe_perf(prob.A, prob.B, prob.C, D, prob.Q, prob.R, prob.X0) / ref

    def objective_of(D):
        return float(np.max(ratios(D))) * (1.0 if lqr_normalised else float(ref[0]))

    def active(D):
        names = _damping_active(prob, D, eps, c)
        J = ratios(D)
        b = J.max()
        if np.isfinite(b):
            names += [f"J[{i + 1}] <= beta" for i in np.flatnonzero((b - J) / b <= _ACTIVE_TOL)]
        return names

    def fill(x, d):
        J = prob.perf(d)["J"]
        x[ib] = float(np.max(J / ref)) if np.all(np.isfinite(J)) else 10.0

    kind = "LQDRF" + ("-diagonal" if diagonal else "") + ("-LQR-normalised" if lqr_normalised else "")
    return _Program(kind, n_var, _bound_objective(ib, n_var), cons, ib, bounds, fill, objective_of, active)
