"""An effect's value on the Student-t likelihood: where a few lines misfit far beyond their stated variance.

A model's form errors that the first-order model-form covariance does not carry -- a lightly damped mode
misplaced by more than its half-power bandwidth, a shape wrong at one point -- leave a few lines with
residuals many times their standard deviation, while most lines lie well within it. On the normal
likelihood each such line pulls every parameter with a sensitivity there, however small: the bias is
``(J^T J)^-1 J^T e`` for the misfit ``e``. An effect whose own information is spread thin (a weak support
spring under a loop that damps the mode it moves heavily: its information lies in the quasi-static lines
below the first resonance) is then fitted to the misfit of modes it hardly moves.

The Student-t likelihood of the residuals, with its scale ``s`` and degrees of freedom ``nu`` estimated by
maximum likelihood with the parameters, bounds each residual's influence,
``psi(r) = (nu + 1) r / (nu s^2 + r^2)``, and becomes least squares where the residuals are normal
(``nu`` large). Its maximum is found by expectation-conditional maximisation: the parameters by a
robust-loss least-squares fit at fixed ``(nu, s)``, then ``(nu, s)`` at fixed parameters, until the
parameters stop moving.

Source: K. L. Lange, R. J. A. Little and J. M. G. Taylor, "Robust statistical modeling using the t
distribution", *J. Amer. Statist. Assoc.* 84 (1989) 881-896 (the likelihood, the joint estimation of
``nu`` and the scale, and the expected information ``(nu + 1) / ((nu + 3) s^2)`` per residual used for
the intervals, where vlab holds ``s`` to at least the stated standard deviations); C. Liu and D. B. Rubin, "ML estimation of the t distribution using EM and its
extensions, ECM and ECME", *Statistica Sinica* 5 (1995) 19-39.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.optimize
from scipy.special import gammaln

from ..effects.hypothesis import Hypothesis
from ..problem.forms import PENALTY
from ..problem.residuals import Problem
from .estimate import ci95_of, from_z, residuals_in_z, to_z

#: The degrees of freedom searched, ``[low, high]``: below 0.5 the t density has no usable scale; at 1e4 its
#: 97.5 % quantile is the normal one to 1.2e-4 (relative).
DOF_RANGE = (0.5, 1.0e4)
#: ECM rounds at most (each a local fit): the parameters settle in two or three.
ROUNDS = 6
#: The parameters count as settled when they move by less than this share of their 95 % interval's width.
SETTLED = 0.01


def t_nll(r2: np.ndarray, nu: float, scale: float) -> float:
    """Negative log-likelihood [1] of residuals with squares ``r2`` (shape (n,)) under the Student-t density
    of ``nu`` degrees of freedom and scale ``scale`` (location 0). Source: Lange et al. (1989), Eq. (1)."""
    n = r2.size
    return float(-n * (gammaln((nu + 1) / 2) - gammaln(nu / 2) - 0.5 * math.log(nu * math.pi) - math.log(scale))
                 + 0.5 * (nu + 1) * np.sum(np.log1p(r2 / (nu * scale * scale))))


def t_dof_scale(r2: np.ndarray) -> tuple[float, float]:
    """Maximum-likelihood ``(nu, scale)`` of residuals with squares ``r2`` (shape (n,), location 0).

    ``nu`` is searched in :data:`DOF_RANGE`, the scale within 15 e-folds of the root-mean-square residual.

    Raises
    ------
    ValueError
        ``r2`` empty or not finite, or a likelihood without an interior maximum: the degrees of freedom at the
        lower end of :data:`DOF_RANGE` or the scale at its lower bound -- residuals of which more than
        ``nu / (nu + 1)`` are (nearly) zero, e.g. noise-free data, have a likelihood unbounded as the scale
        goes to 0, and their "heavy tails" are not evidence of anything.
    """
    r2 = np.asarray(r2, dtype=float)
    if r2.size == 0 or not np.all(np.isfinite(r2)):
        raise ValueError("the t likelihood needs finite residuals")
    u_s = math.log(max(math.sqrt(float(np.mean(r2))), 1e-300))

    def f(u: np.ndarray) -> float:
        return t_nll(r2, math.exp(u[0]), math.exp(u[1]))

    lo, hi = math.log(DOF_RANGE[0]), math.log(DOF_RANGE[1])
    s_bounds = (u_s - 15.0, u_s + 15.0)
    best = min((scipy.optimize.minimize(f, [u0, u_s], method="L-BFGS-B", bounds=[(lo, hi), s_bounds])
                for u0 in (math.log(2.0), math.log(100.0))), key=lambda s: s.fun)
    if best.x[0] <= lo + 1e-6 or best.x[1] <= s_bounds[0] + 1e-6:
        raise ValueError("the t likelihood of these residuals has no interior maximum (most of them are nearly "
                         "zero): no tail to weigh")
    return math.exp(best.x[0]), math.exp(best.x[1])


@dataclass(frozen=True)
class TFit:
    """A hypothesis fitted on the Student-t likelihood (:func:`t_fit`).

    Attributes
    ----------
    params : ndarray, shape (k,)
        The parameters [SI].
    ci95 : ndarray, shape (k, 2)
        Their 95 % intervals [SI] from the expected information (the residuals' own Jacobian; the scale held to
        at least 1), held to the parameters' range (NaN ends where undetermined).
    dof : float
        The residuals' degrees of freedom ``nu`` [1].
    scale : float
        Their scale ``s`` [1] (in units of the problem's standard deviations).
    nll : float
        The negative log-likelihood at the fit [1].
    nll_nominal : float
        That of the problem's nominal lab at its own maximum-likelihood ``nu`` and ``s`` [1] (both profiled).
    """

    params: np.ndarray
    ci95: np.ndarray
    dof: float
    scale: float
    nll: float
    nll_nominal: float

    def describe(self) -> str:
        """One line: the likelihood and its estimated shape."""
        return (f"Student-t likelihood, {self.dof:.3g} degrees of freedom and scale {self.scale:.3g} "
                "estimated with the value (Lange, Little & Taylor 1989)")


def _t_loss(nu: float):
    """``least_squares``' loss ``rho(z) = nu ln(1 + z / nu)`` with its two derivatives (``z = f^2 / s^2``): the
    t likelihood at fixed ``nu`` and scale ``s`` (``f_scale``), up to terms that do not depend on the fit."""
    def rho(z: np.ndarray) -> np.ndarray:
        out = np.empty((3, z.size))
        out[0] = nu * np.log1p(z / nu)
        out[1] = nu / (nu + z)
        out[2] = -nu / (nu + z) ** 2
        return out
    return rho


def t_fit(h: Hypothesis, problem: Problem, x0: np.ndarray, *, max_nfev: int = 40) -> TFit:
    """Fit ``h`` to ``problem`` on the Student-t likelihood of its residuals (module notes), from ``x0``.

    Parameters
    ----------
    h : Hypothesis
        The effect (not changed).
    problem : Problem
        Its data and residuals (:meth:`Problem.residual`, the fits' footing).
    x0 : ndarray, shape (k,)
        Start [SI] (the least-squares fit).
    max_nfev : int
        Evaluation budget of each local fit.

    Returns
    -------
    TFit

    Raises
    ------
    ValueError
        ``x0`` of another length than ``h``'s parameters, residuals that are not finite, a likelihood without an
        interior maximum (:func:`t_dof_scale`: noise-free residuals), or a fit ending on a model that leaves
        lines it cannot predict.
    """
    x = np.asarray(x0, dtype=float)
    if x.shape != (h.n_params,):
        raise ValueError(f"start of shape {x.shape} for {h.n_params} parameter(s)")
    _trials, lo, hi = h.space(problem.base, problem.ctx)
    log = tuple(h.log_scale)
    zlo, zhi = to_z(lo, log), to_z(hi, log)
    span = zhi - zlo

    fun = residuals_in_z(h, problem)

    def interval(z: np.ndarray, nu: float, s: float) -> np.ndarray:
        """95 % intervals [SI] at ``z`` from the t likelihood's expected information, held to the range."""
        ci = ci95_of(_jac(fun, z, zlo, zhi) * math.sqrt(_information(nu, s)), z, 0.0, problem.n_obs, log)
        return np.where(np.isfinite(ci), np.clip(ci, np.asarray(lo)[:, None], np.asarray(hi)[:, None]), ci)

    z = np.clip(to_z(np.clip(x, lo, hi), log), zlo + 1e-6 * span, zhi - 1e-6 * span)
    tol = None  # the settling tolerance [SI]: SETTLED of the 95 % widths at the start (inf where undetermined)
    for _ in range(ROUNDS):
        nu, s = t_dof_scale(fun(z) ** 2)
        if tol is None:
            width = np.diff(interval(z, nu, s), axis=1)[:, 0]
            tol = np.where(np.isfinite(width), SETTLED * width, np.inf)
        sol = scipy.optimize.least_squares(fun, z, bounds=(zlo, zhi), method="trf", loss=_t_loss(nu),
                                           f_scale=s, diff_step=1e-3, max_nfev=max_nfev, x_scale="jac")
        moved = np.abs(from_z(sol.x, log) - from_z(z, log))
        z = sol.x
        if np.all(moved <= tol):
            break
    r = fun(z)
    if np.any(r == PENALTY):
        raise ValueError("the t fit ended on a model with lines it cannot predict")
    nu, s = t_dof_scale(r**2)
    ci = interval(z, nu, s)
    r_nom = problem.residual(problem.base)
    return TFit(from_z(z, log), ci, nu, s, t_nll(r**2, nu, s), t_nll(r_nom**2, *t_dof_scale(r_nom**2)))


def _information(nu: float, s: float) -> float:
    """Expected information per residual for a location parameter of the t density, ``(nu + 1) / ((nu + 3)
    s^2)`` (Lange et al. 1989), with the scale held to at least the problem's stated standard deviations
    (residuals below the model's stated accuracy are not taken as more informative; this floor is vlab's, as
    least squares holds its reduced chi-square to at least 1)."""
    s = max(s, 1.0)
    return (nu + 1) / ((nu + 3) * s * s)


def _jac(fun, z: np.ndarray, zlo: np.ndarray, zhi: np.ndarray) -> np.ndarray:
    """Forward-difference Jacobian of ``fun`` at ``z`` (steps 1e-3 of ``|z|``, at least 1e-6 of the range, taken
    inward at an upper bound), shape (n, k): the residuals' own, not a robust loss's reweighted one."""
    r0 = fun(z)
    cols = []
    for i in range(z.size):
        step = max(1e-3 * abs(z[i]), 1e-3 * (zhi[i] - zlo[i]) * 1e-3)
        if z[i] + step > zhi[i]:
            step = -step
        zi = z.copy()
        zi[i] += step
        cols.append((fun(zi) - r0) / step)
    return np.column_stack(cols)
