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
  converged start is returned; each start is recorded.
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
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np
import scipy.linalg
from scipy.optimize import minimize

from .errors import (
    InfeasibleDampingError,
    MatrixPropertyError,
    check_positive_scalar,
    readonly,
)
from .lq import _initial_states, _riccati_weights, lqr
from .performance import (
    _check_plant,
    _damping_and_gradient,
    _perf_and_gradient,
    modes,
    select_modes,
)
from .realization import DiscreteRealization, output_feedback_realization

__all__ = [
    "DrfStart",
    "DrfDesign",
    "mfdrf",
    "lqdrf",
]

_ACTIVE_TOL = 1e-5  # scaled constraint value below which a constraint is reported active
_FEAS_TOL = 1e-7  # allowed violation of zeta_j >= zeta_L in the verification


# --------------------------------------------------------------------------- results
@dataclass(frozen=True, eq=False)
class DrfStart:
    """One optimiser start of a DRF design.

    Attributes
    ----------
    start : int
        0-based start number (0: the ``c I`` start).
    objective : float
        ``gamma`` or ``beta`` reached (design units).
    success : bool
        SLSQP's own success flag.
    feasible : bool
        All constraints hold at the end (independent check).
    iterations : int
    evaluations : int
        Function + gradient evaluations.
    message : str
    """

    start: int
    objective: float
    success: bool
    feasible: bool
    iterations: int
    evaluations: int
    message: str


@dataclass(frozen=True, eq=False)
class DrfDesign:
    """Result of an MFDRF or LQDRF design (Eqs. 4.30-4.38).

    Attributes
    ----------
    kind : str
        ``"MFDRF"``, ``"LQDRF"``, ``"LQDRF-diagonal"``, ``"LQDRF-LQR-normalised"``
        or ``"LQDRF-diagonal-LQR-normalised"``.
    gain : ndarray, shape (n_c, n_c)
        ``D`` of ``u = -D y`` [force / (length per time unit)], symmetric.
    objective : float
        The minimised ``gamma`` (MFDRF) or ``beta`` (LQDRF), recomputed from ``gain``.
    gamma : float
        ``max_i sum_j |d_ij|`` (Eq. 4.31) [force / (length per time unit)].
    row_sums : ndarray, shape (n_c,)
        ``f_i = sum_j |d_ij|``.
    beta : float or None
        ``max_i J_i`` (or ``max_i J_i / J_i^LQR``) for LQDRF; None for MFDRF.
    constrained_damping : ndarray, shape (n_m',)
        Damping ratios of the constrained (first ``n_m``) modes.
    eigenvalues, damping_ratios, frequencies_hz : ndarray, shape (n_modes,)
        All modes of ``A - B D C`` sorted by frequency.
    zeta_min : float
    n_modes : int
    min_eig : float
        Lower bound imposed on the eigenvalues of ``D``.
    performance_index : ndarray, shape (n_f,) or None
        ``J_i`` (Eqs. 4.33-4.36) for the given initial states.
    performance_ratio : ndarray, shape (n_f,) or None
        ``J_i / J_i^LQR`` when LQR-normalised.
    converged : bool
        Optimiser success *and* every constraint verified.
    message : str
        Reason, start used, or what failed.
    iterations : int
        SLSQP iterations of the returned start.
    evaluations : int
        Distinct gains analysed (eigen-decompositions), all starts, the start
        scan and phase one included.
    active_constraints : tuple of str
        Constraints within ``1e-5`` (scaled) of their bound.
    starts : tuple of DrfStart
    wall_time_s : float
    time_unit_s : float
        Seconds per design time unit.
    """

    kind: str
    gain: np.ndarray
    objective: float
    gamma: float
    row_sums: np.ndarray
    beta: float | None
    constrained_damping: np.ndarray
    eigenvalues: np.ndarray
    damping_ratios: np.ndarray
    frequencies_hz: np.ndarray
    zeta_min: float
    n_modes: int
    min_eig: float
    performance_index: np.ndarray | None
    performance_ratio: np.ndarray | None
    converged: bool
    message: str
    iterations: int
    evaluations: int
    active_constraints: tuple[str, ...]
    starts: tuple[DrfStart, ...]
    wall_time_s: float
    time_unit_s: float

    @property
    def gain_per_s(self) -> np.ndarray:
        """``D`` for velocities per second, ``T D`` (Table 7 units: lbf*s/in), shape (n_c, n_c)."""
        return self.time_unit_s * self.gain

    def realize(self, dt_s: float) -> DiscreteRealization:
        """Engine coefficients of Eq. (5.1): ``F11 = -T D``, no state (Sec. 5.3).

        ``y_k`` in length per second, ``u_k`` actuator force; see
        :func:`controllers.realization.output_feedback_realization`, which
        documents ``dt_s`` [s] and the errors (a non-positive ``dt_s``).

        Returns
        -------
        DiscreteRealization
            ``F11 (n_c, n_c)``, no internal state.
        """
        return output_feedback_realization(self.gain, dt_s, time_unit_s=self.time_unit_s)


# --------------------------------------------------------------------------- problem setup
class _Problem:
    """Evaluations shared by the objective and constraints (cached per point)."""

    def __init__(self, A, B, C, *, zeta_min, n_modes, diagonal, Q=None, R=None, X0=None):
        self.A, self.B, self.C = A, B, C
        self.nc = B.shape[1]
        self.zl = zeta_min
        self.nm = n_modes
        nc = self.nc
        if diagonal:
            self.pairs = [(i, i) for i in range(nc)]
        else:
            self.pairs = [(i, j) for i in range(nc) for j in range(i, nc)]
        self.p = len(self.pairs)
        self.pi = np.array([p[0] for p in self.pairs])
        self.pj = np.array([p[1] for p in self.pairs])
        self.off = np.flatnonzero(self.pi != self.pj)
        self.diag = np.flatnonzero(self.pi == self.pj)
        self.Q, self.R, self.X0 = Q, R, X0
        self._cache_key = None
        self._cache = None
        self._pcache_key = None
        self._pcache = None
        self.n_eval = 0

    def D(self, d: np.ndarray) -> np.ndarray:
        D = np.zeros((self.nc, self.nc))
        D[self.pi, self.pj] = d
        D[self.pj, self.pi] = d
        return D

    def to_params(self, G: np.ndarray) -> np.ndarray:
        """Gradient w.r.t. the symmetric parameters from a full-matrix gradient (..., nc, nc)."""
        Gp = G[..., self.pi, self.pj] + G[..., self.pj, self.pi]
        Gp[..., self.diag] *= 0.5
        return Gp

    def evaluate(self, d: np.ndarray) -> dict:
        """Damping ratios, eigenvalues of D and their gradients (parameters), cached."""
        key = d.tobytes()
        if key == self._cache_key:
            return self._cache
        self.n_eval += 1
        D = self.D(d)
        zeta, dz, _ = _damping_and_gradient(self.A, self.B, self.C, D, self.nm)
        mu, U = np.linalg.eigh(D)
        dmu = np.einsum("ik,jk->kij", U, U)
        out = {"D": D, "zeta": zeta, "dzeta": self.to_params(dz), "mu": mu,
               "dmu": self.to_params(dmu)}
        self._cache_key, self._cache = key, out
        return out

    def perf(self, d: np.ndarray) -> dict:
        """Performance indices J_i and their parameter gradients, cached."""
        key = d.tobytes()
        if key == self._pcache_key:
            return self._pcache
        J, dJ = _perf_and_gradient(self.A, self.B, self.C, self.D(d), self.Q, self.R, self.X0)
        out = {"J": J, "dJ": self.to_params(dJ)}
        self._pcache_key, self._pcache = key, out
        return out


def _check_reachable(A, B, C, zeta_min, n_modes, time_unit_s):
    """Raise InfeasibleDampingError for a mode that must gain damping but cannot."""
    lam, vl, vr = scipy.linalg.eig(A, left=True, right=True)
    idx = select_modes(lam, n_modes)
    nB = np.linalg.norm(B, 2)
    nC = np.linalg.norm(C, 2)
    sens = []
    for r, k in enumerate(idx):
        lk = lam[k]
        z = -lk.real / abs(lk) if abs(lk) > 0 else 0.0
        w, v = vl[:, k], vr[:, k]
        g = w.conj() @ B
        h = C @ v
        s = w.conj() @ v
        sens.append((lk, z, -(g @ h) / s))
        if lk.imag <= 0 or z >= zeta_min:
            continue
        fhz = abs(lk) / (2 * np.pi * time_unit_s)
        b = np.linalg.norm(g) / (np.linalg.norm(w) * nB)
        c = np.linalg.norm(h) / (np.linalg.norm(v) * nC)
        if b < 1e-8:
            raise InfeasibleDampingError(
                f"mode {r + 1} ({fhz:.4g} Hz, open-loop zeta {z:.3g} < zeta_L {zeta_min:g}) "
                f"cannot be damped: its shape is ~0 at every actuator (|U^T phi_{r + 1}| "
                f"relative {b:.1e}); no positive definite D can meet zeta_L"
            )
        if c < 1e-8:
            raise InfeasibleDampingError(
                f"mode {r + 1} ({fhz:.4g} Hz, open-loop zeta {z:.3g} < zeta_L {zeta_min:g}) "
                f"cannot be damped: its shape is ~0 at every sensor (|Cv phi_{r + 1}| "
                f"relative {c:.1e}); no positive definite D can meet zeta_L"
            )
    return sens


def _first_start(prob: _Problem, sens) -> tuple[float, str]:
    """Scale c of the start D = c I: the smallest c on a log grid meeting the damping bounds."""
    need = []
    for lk, z, dl in sens:
        if lk.imag > 0 and -dl.real > 0:
            need.append(max(prob.zl - z, 0.1 * prob.zl) * abs(lk) / (-dl.real))
    c0 = float(np.median(need)) if need else 1.0
    best_c, best_margin = c0, -np.inf
    for c in c0 * np.logspace(-2, 2.5, 46):
        zeta = prob.evaluate(_diag_vector(prob, c))["zeta"]
        margin = float(np.min(zeta)) - prob.zl
        if margin >= 1e-3 * prob.zl:
            return float(c), "c I meets the damping bounds"
        if margin > best_margin:
            best_c, best_margin = float(c), margin
    return best_c, f"no c I meets the damping bounds (best margin {best_margin:.3g})"


def _diag_vector(prob: _Problem, c: float) -> np.ndarray:
    d = np.zeros(prob.p)
    d[prob.diag] = c
    return d


def _random_start(prob: _Problem, rng: np.random.Generator, d_base: np.ndarray,
                  diagonal: bool) -> np.ndarray:
    """A random symmetric positive definite gain around ``D_base``: ``D_base^1/2 M D_base^1/2``."""
    nc = prob.nc
    M = np.diag(np.exp(rng.normal(0.0, 0.5, nc)))
    if not diagonal:
        E = rng.normal(0.0, 0.25, (nc, nc))
        M = M + 0.5 * (E + E.T) - np.diag(np.diag(E))
        mu = np.linalg.eigvalsh(M)[0]
        if mu < 0.2:
            M = M + (0.2 - mu) * np.eye(nc)
    mu, V = np.linalg.eigh(prob.D(d_base))
    half = (V * np.sqrt(np.clip(mu, 0.0, None))) @ V.T
    D = half @ M @ half
    return D[prob.pi, prob.pj]


def _phase_one(prob: _Problem, d0: np.ndarray, c: float, eps: float, maxiter: int):
    """Maximise the worst scaled damping margin ``s`` (capped at 0.01) keeping ``D > 0``.

    Returns ``(d, s, nit)``; ``s >= 0`` means a feasible start was found.
    """
    p = prob.p
    zl = prob.zl

    def fun(x):
        g = np.zeros(p + 1); g[p] = -1.0
        return -float(x[p]), g

    def zfun(x):
        return (prob.evaluate(c * x[:p])["zeta"] - zl) / zl - x[p]

    def zjac(x):
        ev = prob.evaluate(c * x[:p])
        out = np.zeros((ev["zeta"].size, p + 1))
        out[:, :p] = ev["dzeta"] * c / zl
        out[:, p] = -1.0
        return out

    cons = [{"type": "ineq", "fun": zfun, "jac": zjac}]
    if prob.off.size:
        cons.append({"type": "ineq",
                     "fun": lambda x: (prob.evaluate(c * x[:p])["mu"] - eps) / c,
                     "jac": lambda x: np.hstack([prob.evaluate(c * x[:p])["dmu"],
                                                 np.zeros((prob.nc, 1))])})
        bounds = [(None, None)] * p + [(None, 0.01)]
    else:
        bounds = [(eps / c, None)] * p + [(None, 0.01)]
    x0 = np.concatenate([d0 / c, [float(np.min(prob.evaluate(d0)["zeta"]) - zl) / zl]])
    res = minimize(fun, x0, jac=True, method="SLSQP", constraints=cons, bounds=bounds,
                   options={"maxiter": int(maxiter), "ftol": 1e-10})
    d = c * res.x[:p]
    ev = prob.evaluate(d)
    if np.linalg.eigvalsh(ev["D"])[0] < 0.5 * eps:
        return d0, float(np.min(prob.evaluate(d0)["zeta"]) - zl) / zl, int(res.nit)
    return d, float(np.min(ev["zeta"]) - zl) / zl, int(res.nit)


def _base_start(prob: _Problem, sens, diagonal: bool, min_eig, maxiter: int, time_unit_s: float,
                rng: np.random.Generator, n_starts: int):
    """Scale ``c``, bound ``eps``, a base gain and a note on feasibility of the damping bounds.

    ``c I`` from the scan of :func:`_first_start`; if no ``c I`` meets the bounds a
    phase-one problem (:func:`_phase_one`) from ``c I`` and from ``n_starts - 1``
    random gains looks for a ``D > 0`` that does. ``note`` is empty when a
    feasible base was found, else it names the modes that fall short.
    """
    c, _ = _first_start(prob, sens)
    eps = 1e-6 * c if min_eig is None else float(min_eig)
    d = _diag_vector(prob, c)
    margin = float(np.min(prob.evaluate(d)["zeta"]) - prob.zl) / prob.zl
    if margin >= 0:
        return c, eps, d, ""
    best_d, best_m = d, margin
    for s in range(max(int(n_starts), 1)):
        d0 = d if s == 0 else _random_start(prob, rng, d, diagonal)
        d1, m1, _ = _phase_one(prob, d0, c, eps, maxiter)
        if m1 > best_m:
            best_d, best_m = d1, m1
        if m1 >= 0:
            return c, eps, d1, ""
    ev = prob.evaluate(best_d)
    zeta = ev["zeta"]
    _, _, lam = _damping_and_gradient(prob.A, prob.B, prob.C, ev["D"], prob.nm)
    worst = [f"mode {j + 1} ({abs(lam[j]) / (2 * np.pi * time_unit_s):.4g} Hz) zeta = {zeta[j]:.4g}"
             for j in np.flatnonzero(zeta < prob.zl)]
    note = (f"no D > 0 found that meets zeta_L = {prob.zl:g} on the first {prob.nm} modes "
            f"from {max(int(n_starts), 1)} phase-one starts (best reaches: {', '.join(worst)}); "
            "the bound is probably beyond what these actuators can give")
    return c, eps, best_d, note


def _infeasible_design(prob, kind, d_base, eps, c, t, t0, note, active_fn, objective_of):
    """The design returned when phase one found no feasible gain: converged=False, best effort gain."""
    D = prob.D(d_base)
    viol, _ = _violations(prob, D, eps, c)
    md = modes(prob.A - prob.B @ D @ prob.C, time_unit_s=t)
    zeta_c, _, _ = _damping_and_gradient(prob.A, prob.B, prob.C, D, prob.nm)
    rows = np.sum(np.abs(D), axis=1)
    return DrfDesign(
        kind=kind, gain=readonly(D), objective=float(objective_of(D)), gamma=float(np.max(rows)),
        row_sums=readonly(rows), beta=None, constrained_damping=readonly(zeta_c),
        eigenvalues=md.eigenvalues, damping_ratios=md.damping_ratios,
        frequencies_hz=md.frequencies_hz, zeta_min=prob.zl, n_modes=prob.nm, min_eig=float(eps),
        performance_index=None, performance_ratio=None, converged=False,
        message=f"infeasible: {note}; violated: {'; '.join(viol)}", iterations=0,
        evaluations=prob.n_eval, active_constraints=tuple(active_fn(D)), starts=(),
        wall_time_s=time.perf_counter() - t0, time_unit_s=t,
    )


def _validate_common(A, B, C, zeta_min, n_modes, min_eig, n_starts, time_unit_s):
    A, B, C = _check_plant(A, B, C)
    zl = check_positive_scalar("zeta_min", zeta_min)
    if zl >= 1.0:
        raise MatrixPropertyError(f"zeta_min: expected 0 < zeta_L < 1, found {zeta_min}")
    nm = int(n_modes)
    if not 1 <= nm <= A.shape[0] // 2:
        raise MatrixPropertyError(f"n_modes: expected 1 <= n_m <= n = {A.shape[0] // 2}, found {n_modes}")
    if min_eig is not None:
        check_positive_scalar("min_eig", min_eig)
    if int(n_starts) < 1:
        raise MatrixPropertyError(f"n_starts: expected >= 1, found {n_starts}")
    t = check_positive_scalar("time_unit_s", time_unit_s)
    return A, B, C, zl, nm, t


def _start_vectors(prob, rng, d_base, diagonal, n_starts, n_var, c, fill):
    """SLSQP start vectors ``x = [d / c, ...]``: ``d_base`` first, then random starts (:func:`_random_start`);
    ``fill(x, d)`` sets the variables after the ``p`` gains."""
    x0s = []
    for s in range(int(n_starts)):
        d = d_base if s == 0 else _random_start(prob, rng, d_base, diagonal)
        x = np.zeros(n_var)
        x[:prob.p] = d / c
        fill(x, d)
        x0s.append(x)
    return x0s


def _solve(x0s, fun, cons, bounds, maxiter, ftol):
    """Run SLSQP from every start; return [(start, OptimizeResult)]."""
    records = []
    for s, x0 in enumerate(x0s):
        res = minimize(fun, x0, jac=True, method="SLSQP", constraints=cons, bounds=bounds,
                       options={"maxiter": int(maxiter), "ftol": float(ftol)})
        records.append((s, res))
    return records


def _bound_objective(i_bound: int, n_var: int):
    """SLSQP objective of the bound form (MFDRF's ``gamma``, LQDRF's ``beta``): ``x[i_bound]`` and its gradient."""
    def fun(x):
        g = np.zeros(n_var); g[i_bound] = 1.0
        return float(x[i_bound]), g

    return fun


def _damping_constraint(prob: _Problem, scale: float, n_var: int) -> dict:
    """SLSQP constraint ``(zeta_j - zeta_L) / zeta_L >= 0`` on the constrained modes, gain ``d = scale * x[:p]``."""
    p, zl = prob.p, prob.zl

    def zfun(x):
        return (prob.evaluate(scale * x[:p])["zeta"] - zl) / zl

    def zjac(x):
        ev = prob.evaluate(scale * x[:p])
        out = np.zeros((ev["zeta"].size, n_var))
        out[:, :p] = ev["dzeta"] * scale / zl
        return out

    return {"type": "ineq", "fun": zfun, "jac": zjac}


def _definiteness_constraint(prob: _Problem, scale: float, min_eig: float, n_var: int) -> dict:
    """SLSQP constraint ``(mu_k(D) - min_eig) / scale >= 0`` on every eigenvalue ``mu_k`` of ``D`` (``D > 0``)."""
    p = prob.p

    def mfun(x):
        return (prob.evaluate(scale * x[:p])["mu"] - min_eig) / scale

    def mjac(x):
        out = np.zeros((prob.nc, n_var))
        out[:, :p] = prob.evaluate(scale * x[:p])["dmu"]
        return out

    return {"type": "ineq", "fun": mfun, "jac": mjac}


def _violations(prob: _Problem, D: np.ndarray, min_eig: float, scale: float) -> tuple[list[str], float]:
    """Independent check of a gain: (descriptions of violated constraints, scaled total violation)."""
    out = []
    zeta, _, _ = _damping_and_gradient(prob.A, prob.B, prob.C, D, prob.nm)
    for j in np.flatnonzero(zeta < prob.zl - _FEAS_TOL):
        out.append(f"zeta[{j + 1}] = {zeta[j]:.6g} < zeta_L = {prob.zl:g}")
    mu = np.linalg.eigvalsh(D)[0]
    if mu < 0.5 * min_eig or mu <= 0:
        out.append(f"min eig(D) = {mu:.3g} < min_eig = {min_eig:.3g}")
    unstable = np.max(scipy.linalg.eigvals(prob.A - prob.B @ D @ prob.C).real) >= 0
    if unstable:
        out.append("closed loop A - B D C is not asymptotically stable")
    size = (np.sum(np.clip(prob.zl - zeta, 0.0, None)) / prob.zl
            + max(min_eig - mu, 0.0) / scale + float(unstable))
    return out, float(size)


def _finish(prob, kind, records, x_to_D, objective_of, min_eig, scale, t, t0, active_fn):
    """Pick the best start, verify it, and build the DrfDesign.

    Ranking: converged and feasible < feasible < infeasible (by total violation).
    """
    starts = []
    best = None
    for s, res in records:
        D = x_to_D(res.x)
        viol, size = _violations(prob, D, min_eig, scale)
        obj = objective_of(D)
        starts.append(DrfStart(s, obj, bool(res.success), not viol, int(res.nit),
                               int(res.nfev) + int(getattr(res, "njev", 0)), str(res.message)))
        rank = (0, obj) if (res.success and not viol) else (1, obj) if not viol else (2, size)
        if best is None or rank < best[0]:
            best = (rank, s, res, D, viol)
    _, s, res, D, viol = best
    iterations = int(res.nit)
    converged = bool(res.success) and not viol
    if converged:
        msg = f"SLSQP: {res.message} (start {s} of {len(records)})"
    elif not viol:
        msg = (f"feasible but the optimiser did not report convergence: {res.message} "
               f"(start {s} of {len(records)})")
    else:
        msg = (f"no start reached a feasible point (best start {s}: {res.message}); "
               f"violated: {'; '.join(viol)}")
    md = modes(prob.A - prob.B @ D @ prob.C, time_unit_s=t)
    zeta_c, _, _ = _damping_and_gradient(prob.A, prob.B, prob.C, D, prob.nm)
    rows = np.sum(np.abs(D), axis=1)
    return DrfDesign(
        kind=kind,
        gain=readonly(D),
        objective=float(objective_of(D)),
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
        message=msg,
        iterations=iterations,
        evaluations=prob.n_eval,
        active_constraints=tuple(active_fn(D)),
        starts=tuple(starts),
        wall_time_s=time.perf_counter() - t0,
        time_unit_s=t,
    )


def _damping_active(prob, D, min_eig, scale):
    names = []
    zeta, _, _ = _damping_and_gradient(prob.A, prob.B, prob.C, D, prob.nm)
    for j in np.flatnonzero((zeta - prob.zl) / prob.zl <= _ACTIVE_TOL):
        names.append(f"zeta[{j + 1}] >= zeta_min")
    mu = np.linalg.eigvalsh(D)
    for k in np.flatnonzero((mu - min_eig) / scale <= _ACTIVE_TOL):
        names.append(f"eig[{k + 1}](D) >= min_eig")
    return names


# --------------------------------------------------------------------------- MFDRF
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
    c, eps, d_base, note = _base_start(prob, sens, False, min_eig, maxiter, t, rng, n_starts)
    p, off, nc = prob.p, prob.off, prob.nc
    n_off = off.size
    n_var = p + n_off + 1
    ig = n_var - 1
    # x = [d/c (p), t/c (n_off), gamma/c]
    lin_rows = []
    for k, q in enumerate(off):  # t_k - d_q >= 0 and t_k + d_q >= 0
        r1 = np.zeros(n_var); r1[p + k] = 1.0; r1[q] = -1.0
        r2 = np.zeros(n_var); r2[p + k] = 1.0; r2[q] = 1.0
        lin_rows += [r1, r2]
    for i in range(nc):  # gamma - d_ii - sum_j t_ij >= 0
        r = np.zeros(n_var); r[ig] = 1.0
        r[prob.diag[i]] = -1.0
        for k, q in enumerate(off):
            if prob.pi[q] == i or prob.pj[q] == i:
                r[p + k] = -1.0
        lin_rows.append(r)
    G = np.array(lin_rows)
    fun = _bound_objective(ig, n_var)
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

    def gamma_of(D):
        return float(np.max(np.sum(np.abs(D), axis=1)))

    if note:
        design = _infeasible_design(prob, "MFDRF", d_base, eps, c, t, t0, note, active, gamma_of)
    else:
        def fill(x, d):
            x[p:p + n_off] = np.abs(d[off]) / c
            x[ig] = gamma_of(prob.D(d)) / c

        x0s = _start_vectors(prob, rng, d_base, False, n_starts, n_var, c, fill)
        records = _solve(x0s, fun, cons, bounds, maxiter, ftol)
        design = _finish(prob, "MFDRF", records, lambda x: prob.D(c * x[:p]), gamma_of, eps, c, t,
                         t0, active)
    if perf is not None:
        Qm, Rm, X0 = perf
        J = _safe_perf(A, B, C, design.gain, Qm, Rm, X0)
        design = replace(design, performance_index=readonly(J))
    return design


def _optional_perf(A, B, Q, R, X0):
    if Q is None and R is None and X0 is None:
        return None
    if Q is None or R is None or X0 is None:
        raise MatrixPropertyError("give all of Q, R and initial_states, or none of them")
    n, nc = B.shape
    Q, R = _riccati_weights(Q, R, n, nc)
    return Q, R, _initial_states(X0, n)


def _safe_perf(A, B, C, D, Q, R, X0):
    if np.max(scipy.linalg.eigvals(A - B @ D @ C).real) >= 0:
        return np.full(X0.shape[1], np.inf)
    return _perf_and_gradient(A, B, C, D, Q, R, X0)[0]


# --------------------------------------------------------------------------- LQDRF
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
    if lqr_normalised:
        ref = lqr(A, B, Q, R, time_unit_s=t).performance_index(X0)
    prob = _Problem(A, B, C, zeta_min=zl, n_modes=nm, diagonal=diagonal, Q=Q, R=R, X0=X0)
    rng = np.random.default_rng(seed)
    c, eps, d_base, note = _base_start(prob, sens, diagonal, min_eig, maxiter, t, rng, n_starts)
    p = prob.p
    if not lqr_normalised:
        j0 = prob.perf(d_base)["J"]
        ref = np.full(X0.shape[1], float(np.max(j0)) if np.all(np.isfinite(j0)) else 1.0)
    n_var = p + 1
    ib = p
    fun = _bound_objective(ib, n_var)

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
    def objective_of(D):
        J = _safe_perf(A, B, C, D, Q, R, X0)
        return float(np.max(J / ref)) * (1.0 if lqr_normalised else float(ref[0]))

    def active(D):
        names = _damping_active(prob, D, eps, c)
        J = _safe_perf(A, B, C, D, Q, R, X0) / ref
        b = J.max()
        if np.isfinite(b):
            names += [f"J[{i + 1}] <= beta" for i in np.flatnonzero((b - J) / b <= _ACTIVE_TOL)]
        return names

    kind = "LQDRF" + ("-diagonal" if diagonal else "") + ("-LQR-normalised" if lqr_normalised else "")
    if note:
        design = _infeasible_design(prob, kind, d_base, eps, c, t, t0, note, active, objective_of)
    else:
        def fill(x, d):
            J = prob.perf(d)["J"]
            x[ib] = float(np.max(J / ref)) if np.all(np.isfinite(J)) else 10.0

        x0s = _start_vectors(prob, rng, d_base, diagonal, n_starts, n_var, c, fill)
        records = _solve(x0s, fun, cons, bounds, maxiter, ftol)
        design = _finish(prob, kind, records, lambda x: prob.D(c * x[:p]), objective_of, eps, c,
                         t, t0, active)
    J = _safe_perf(A, B, C, design.gain, Q, R, X0)
    return replace(
        design,
        performance_index=readonly(J),
        performance_ratio=readonly(J / ref) if lqr_normalised else None,
        beta=design.objective,
    )
