"""Starting points of the DRF designs: reachability, the ``c I`` scan, random starts, phase one.

* Every mode that must gain damping has to be reachable from the actuators
  and the sensors (else no ``D > 0`` can meet ``zeta_L``:
  :class:`controllers.errors.InfeasibleDampingError`).
* The first start is ``c I`` with the smallest ``c`` on a log grid that
  meets the damping constraints of Eqs. (4.32), (4.38); if none does, a
  phase-one SLSQP problem maximises the worst damping margin over ``D > 0``.
* Further starts are random symmetric positive definite perturbations
  ``D0^1/2 M D0^1/2`` with ``M`` drawn from the seeded generator.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.linalg
from scipy.optimize import minimize

from .drf_problem import _damping_constraint, _definiteness_constraint, _Problem
from .errors import InfeasibleDampingError
from .performance import _damping_and_gradient, select_modes

__all__: list[str] = []  # helpers of controllers.mfdrf and controllers.lqdrf only


def _check_reachable(A, B, C, zeta_min, n_modes, time_unit_s):
    """Raise InfeasibleDampingError for a mode that must gain damping but cannot.

    Returns, for each of the first ``n_modes`` open-loop modes, ``(lambda, zeta,
    d lambda / d c)`` with ``d lambda / d c = -(w^H B)(C v) / (w^H v)`` the
    eigenvalue derivative along ``D = c I`` (input of :func:`_first_start`).
    """
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

    cons = [_damping_constraint(prob, c, p + 1, slack=p)]
    if prob.off.size:
        cons.append(_definiteness_constraint(prob, c, eps, p + 1))
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


class _Base(NamedTuple):
    """The base start of a design: scale ``c``, eigenvalue bound ``eps`` of ``D``, gain parameters ``d``,
    and ``note``: empty when ``d`` meets the damping bounds, else why none was found."""

    c: float
    eps: float
    d: np.ndarray
    note: str


def _base_start(prob: _Problem, sens, diagonal: bool, min_eig, maxiter: int, time_unit_s: float,
                rng: np.random.Generator, n_starts: int) -> _Base:
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
        return _Base(c, eps, d, "")
    best_d, best_m = d, margin
    for s in range(max(int(n_starts), 1)):
        d0 = d if s == 0 else _random_start(prob, rng, d, diagonal)
        d1, m1, _ = _phase_one(prob, d0, c, eps, maxiter)
        if m1 > best_m:
            best_d, best_m = d1, m1
        if m1 >= 0:
            return _Base(c, eps, d1, "")
    ev = prob.evaluate(best_d)
    zeta = ev["zeta"]
    _, _, lam = _damping_and_gradient(prob.A, prob.B, prob.C, ev["D"], prob.nm)
    worst = [f"mode {j + 1} ({abs(lam[j]) / (2 * np.pi * time_unit_s):.4g} Hz) zeta = {zeta[j]:.4g}"
             for j in np.flatnonzero(zeta < prob.zl)]
    note = (f"no D > 0 found that meets zeta_L = {prob.zl:g} on the first {prob.nm} modes "
            f"from {max(int(n_starts), 1)} phase-one starts (best reaches: {', '.join(worst)}); "
            "the bound is probably beyond what these actuators can give")
    return _Base(c, eps, best_d, note)


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
