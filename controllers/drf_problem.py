"""The DRF optimisation problem: gain parameters, constraint values and their analytic gradients.

``D`` is symmetric and parametrised by its upper triangle ``d`` (only the
diagonal when ``D`` is diagonal). The damping ratios of ``A - B D C`` and
their gradients come from :func:`controllers.performance.closed_loop_damping`'s
eigenvalue derivative ``d lambda / dD = -(w^H B)^T (C v) / (w^H v)``, the
performance indices ``J_i`` (Eqs. 4.33-4.36) and theirs from the adjoint
Lyapunov equation (:func:`controllers.performance.performance_gradient`), the
eigenvalues of ``D`` by ``d mu / dD = u u^T``.

SLSQP sees the variables ``x = [d / c, ...]`` scaled by the gain ``c`` of the
first start and the damping constraints ``zeta_j >= zeta_L`` of Eqs. (4.32),
(4.38) divided by ``zeta_L``. A result is verified independently of the
optimiser (:func:`_violations`).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from .errors import MatrixPropertyError, check_damping_bound, check_positive_scalar
from .performance import _check_plant, _damping_and_gradient, _initial_states, _perf_and_gradient
from .riccati import _riccati_weights

__all__: list[str] = []  # helpers of controllers.mfdrf and controllers.lqdrf only

_ACTIVE_TOL = 1e-5  # scaled constraint value below which a constraint is reported active
_FEAS_TOL = 1e-7  # allowed violation of zeta_j >= zeta_L in the verification


# --------------------------------------------------------------------------- problem
class _Problem:
    """Evaluations shared by the objective and constraints (cached per point).

    ``d`` (shape (p,)) holds the entries ``D[pi[k], pj[k]]`` of the upper
    triangle (``diagonal``: the diagonal only); ``off`` and ``diag`` index its
    off-diagonal and diagonal entries. ``Q, R, X0`` are needed by :meth:`perf`
    only (LQDRF). ``n_eval`` counts the distinct gains :meth:`evaluate` analysed.
    """

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
        """The symmetric gain ``D`` (n_c, n_c) of the parameters ``d`` (p,)."""
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


# --------------------------------------------------------------------------- inputs
def _validate_common(A, B, C, zeta_min, n_modes, min_eig, n_starts, time_unit_s):
    """The inputs MFDRF and LQDRF share, checked: ``(A, B, C, zeta_L, n_m, time_unit_s)``.

    Raises ``ShapeError`` or ``MatrixPropertyError`` as documented by
    :func:`controllers.mfdrf.mfdrf`.
    """
    A, B, C = _check_plant(A, B, C)
    zl = check_damping_bound("zeta_min", zeta_min)
    nm = int(n_modes)
    if not 1 <= nm <= A.shape[0] // 2:
        raise MatrixPropertyError(f"n_modes: expected 1 <= n_m <= n = {A.shape[0] // 2}, found {n_modes}")
    if min_eig is not None:
        check_positive_scalar("min_eig", min_eig)
    if int(n_starts) < 1:
        raise MatrixPropertyError(f"n_starts: expected >= 1, found {n_starts}")
    t = check_positive_scalar("time_unit_s", time_unit_s)
    return A, B, C, zl, nm, t


def _optional_perf(A, B, Q, R, X0):
    """``(Q, R, X0)`` checked (Eqs. 4.33-4.36), or None when none is given; ``MatrixPropertyError`` for some."""
    if Q is None and R is None and X0 is None:
        return None
    if Q is None or R is None or X0 is None:
        raise MatrixPropertyError("give all of Q, R and initial_states, or none of them")
    n, nc = B.shape
    Q, R = _riccati_weights(Q, R, n, nc)
    return Q, R, _initial_states(X0, n)


def _safe_perf(A, B, C, D, Q, R, X0):
    """``J_i`` of ``u = -D C x`` (Eqs. 4.33-4.36), shape (n_f,); ``inf`` where ``A - B D C`` is not stable."""
    if np.max(scipy.linalg.eigvals(A - B @ D @ C).real) >= 0:
        return np.full(X0.shape[1], np.inf)
    return _perf_and_gradient(A, B, C, D, Q, R, X0)[0]


# --------------------------------------------------------------------------- SLSQP functions
def _bound_objective(i_bound: int, n_var: int):
    """SLSQP objective of the bound form (MFDRF's ``gamma``, LQDRF's ``beta``): ``x[i_bound]`` and its gradient."""
    def fun(x):
        g = np.zeros(n_var); g[i_bound] = 1.0
        return float(x[i_bound]), g

    return fun


def _damping_constraint(prob: _Problem, scale: float, n_var: int, slack: int | None = None) -> dict:
    """SLSQP constraint ``(zeta_j - zeta_L) / zeta_L >= 0`` on the constrained modes, gain ``d = scale * x[:p]``.

    With ``slack``, ``(zeta_j - zeta_L) / zeta_L - x[slack] >= 0``: the worst
    damping margin ``x[slack]`` that phase one maximises.
    """
    p, zl = prob.p, prob.zl

    def zfun(x):
        g = (prob.evaluate(scale * x[:p])["zeta"] - zl) / zl
        return g if slack is None else g - x[slack]

    def zjac(x):
        ev = prob.evaluate(scale * x[:p])
        out = np.zeros((ev["zeta"].size, n_var))
        out[:, :p] = ev["dzeta"] * scale / zl
        if slack is not None:
            out[:, slack] = -1.0
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


# --------------------------------------------------------------------------- verification
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


def _damping_active(prob: _Problem, D: np.ndarray, min_eig: float, scale: float) -> list[str]:
    """Names of the damping and definiteness constraints within ``_ACTIVE_TOL`` (scaled) of their bounds at ``D``."""
    names = []
    zeta, _, _ = _damping_and_gradient(prob.A, prob.B, prob.C, D, prob.nm)
    for j in np.flatnonzero((zeta - prob.zl) / prob.zl <= _ACTIVE_TOL):
        names.append(f"zeta[{j + 1}] >= zeta_min")
    mu = np.linalg.eigvalsh(D)
    for k in np.flatnonzero((mu - min_eig) / scale <= _ACTIVE_TOL):
        names.append(f"eig[{k + 1}](D) >= min_eig")
    return names
