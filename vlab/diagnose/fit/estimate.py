"""Fitting hypotheses, confidence intervals, and ranking by information criteria.

Each hypothesis is fitted by bounded nonlinear least squares on the weighted
residuals of :class:`~vlab.diagnose.problem.residuals.Problem`
(:func:`scipy.optimize.least_squares`, trust-region reflective, finite
difference Jacobian), started from the best of a few trial values (the
residual of a lightly damped structure is not convex in a frequency shift).
A one-parameter effect that moves the modes is scanned first at
:data:`COARSE_POINTS` values spanning its trial range; the value with the least
*smoothed* error (:meth:`~vlab.diagnose.problem.residuals.Problem.scores`: the broad
basin around the narrow chi-square well) is then refined by a finer scan of
the chi-square around it (:data:`LOCAL_POINTS` values within
:data:`LOCAL_SPAN`), and the best of all is a start of the local fit.
Scale parameters are fitted in ``log10``; every parameter is normalised to
order one.

Confidence intervals come from the Jacobian ``J`` at the optimum:
``cov = s^2 (J^T J)^-1`` with ``s^2 = max(1, chi2 / (N - k))`` (the
residuals are already divided by the noise; a misfit larger than the noise
widens the intervals), and ``x +- 1.96 sqrt(cov_ii)`` mapped back to SI
(asymmetric for log parameters).

Ranking: Akaike's ``AIC = chi2 + 2k`` and Schwarz's ``BIC = chi2 + k ln N``
(N residuals, k parameters); BIC is the score (lower is better) because it
penalises extra parameters more and is consistent. A difference of 10 is
"very strong" evidence (Kass & Raftery, J. Am. Stat. Assoc. 90 (1995) 773-795).
The selection among the ranked fits (:func:`vlab.diagnose.fit.rules.select`) and
its thresholds are in :mod:`vlab.diagnose.fit.rules`.

Sources: Akaike, IEEE Trans. Autom. Control 19 (1974) 716-723; Schwarz,
Ann. Statist. 6 (1978) 461-464; Seber & Wild, *Nonlinear Regression*, 1989,
Sec. 5.1 (linearised confidence regions).
"""

from __future__ import annotations

import math

import numpy as np
import scipy.optimize

from ...errors import ModelError, VlabError
from ..data.measured import FrfData
from ..effects.hypotheses import Combination, Hypothesis
from ..problem.misfits import noise_misfit
from ..problem.residuals import PENALTY, Problem
from .confirm import remainder_resolved

#: Values of the coarse scan of a one-parameter, mode-moving effect (log-spaced for a log parameter).
COARSE_POINTS = 12
#: Values of the chi-square scan around the coarse scan's best and their span: a factor
#: ``exp(+-LOCAL_SPAN)`` for a log parameter, ``+-LOCAL_SPAN`` of the trial range otherwise.
#: Chosen, not fitted: the chi-square well of a softened grid joint is about +-12 % wide.
LOCAL_POINTS = 9
LOCAL_SPAN = 0.3


def to_z(x: np.ndarray, log: tuple[bool, ...]) -> np.ndarray:
    """The fit's coordinates of parameters ``x`` [SI] (shape (k,)): log10 where ``log`` says, else as given."""
    x = np.asarray(x, dtype=float)
    return np.array([math.log10(max(v, 1e-300)) if lg else v for v, lg in zip(x, log)])


def from_z(z: np.ndarray, log: tuple[bool, ...]) -> np.ndarray:
    """Parameters [SI] of the fit's coordinates ``z`` (shape (k,)) with ``log`` as :func:`to_z`'s: its inverse."""
    return np.array([10.0**v if lg else v for v, lg in zip(z, log)])


def residuals_in_z(h: Hypothesis, problem: Problem, scale: np.ndarray | float = 1.0):
    """The residuals of ``problem`` (shape (n_obs,)) as a function of the fit's coordinates ``z / scale`` of
    ``h`` (:func:`to_z`); a model the structure cannot carry (:class:`ModelError`, e.g. buckling) gives
    :data:`~vlab.diagnose.problem.residuals.PENALTY` on every residual, so that a local fit steps back."""
    log = tuple(h.log_scale)

    def fun(u: np.ndarray) -> np.ndarray:
        try:
            return problem.residual(problem.state_for(h, from_z(u * scale, log)))
        except ModelError:
            return np.full(problem.n_obs, PENALTY)

    return fun


def trials_for(h: Hypothesis, problem: Problem) -> np.ndarray:
    """Trial values [SI] of ``h`` on ``problem`` (its nominal lab and context), shape (n, k): the
    hypothesis's own, or for a one-parameter effect that moves the modes (``h.moves_modes``)
    :data:`COARSE_POINTS` values spanning them (log-spaced for a log parameter).

    Raises
    ------
    ModelError
        From the hypothesis's ``space`` (a lab it cannot apply to).
    """
    trials, _, _ = h.space(problem.base, problem.ctx)
    if not (h.moves_modes and h.n_params == 1 and len(trials) > 1):
        return trials
    a, b = float(np.min(trials)), float(np.max(trials))
    grid = np.geomspace(a, b, COARSE_POINTS) if (h.log_scale[0] and a > 0) else np.linspace(a, b, COARSE_POINTS)
    return grid[:, None]


def _around(h: Hypothesis, problem: Problem, x: np.ndarray) -> np.ndarray:
    """:data:`LOCAL_POINTS` values around ``x`` [SI] (one parameter) within the bounds, shape (n, 1)."""
    trials, lo, hi = h.space(problem.base, problem.ctx)
    u = np.linspace(-LOCAL_SPAN, LOCAL_SPAN, LOCAL_POINTS)
    if h.log_scale[0] and x[0] > 0:
        v = x[0] * np.exp(u)
    else:
        v = x[0] + u * float(np.ptp(trials))
    return np.clip(v, lo[0], hi[0])[:, None]


def screen(h: Hypothesis, problem: Problem, trials: np.ndarray | None = None) -> list[tuple[float, np.ndarray]]:
    """Chi-square at each trial value of ``h`` on ``problem``, best first.

    ``trials`` (shape (n, k), SI) default to :func:`trials_for`. Sets
    ``h.coarse_``: the trial with the least smoothed error
    (:meth:`Problem.scores`), and ``h.coarse_error_``, that error.

    A trial the structure cannot carry (:class:`ModelError` from the FE
    model: a mass that buckles the hanging grid) scores infinity.

    Returns
    -------
    list of (chi2, x)
        ``x`` [SI], shape (k,).

    Raises
    ------
    ModelError
        When no trial value gives a model the structure can carry.
    """
    if trials is None:
        trials = trials_for(h, problem)
    out = []
    smooth = []

    def evaluate(x) -> None:
        try:
            c, sm = problem.scores(problem.state_for(h, x))
        except ModelError:
            c, sm = math.inf, math.inf
        out.append((c, np.asarray(x, dtype=float)))
        smooth.append(sm)

    for x in trials:
        evaluate(x)
    if not np.isfinite(min(c for c, _ in out)):
        raise ModelError(f"{h.label}: no trial value gives a model the structure can carry")
    vertex = _parabolic_step(h, problem, out)
    if vertex is not None:
        evaluate(vertex)
    i = int(np.argmin(smooth))
    h.coarse_, h.coarse_error_ = out[i][1], float(smooth[i])
    out.sort(key=lambda t: t[0])
    return out


def _parabolic_step(h: Hypothesis, problem: Problem, scored: list[tuple[float, np.ndarray]]) -> np.ndarray | None:
    """One step of successive parabolic interpolation on the screened chi-square of a one-parameter ``h``.

    A trial grid can step over a chi-square well narrower than its spacing: a channel gain changed by 1 %
    between trials at 0.97 and 1.03 scores worse there than the nominal lab does. For a small change the
    residuals are linear in the parameter, so the chi-square is a parabola in it; its vertex through the
    best value and its two neighbours (the effect's null value counting as one, scored as the nominal lab,
    :meth:`~vlab.diagnose.problem.residuals.Problem.base_scores`) is where Gauss-Newton's first step would go
    (Press et al., *Numerical Recipes*, 3rd ed., 2007, Sec. 10.3; Brent, *Algorithms for Minimization
    without Derivatives*, 1973, Ch. 5).

    Parameters
    ----------
    h : Hypothesis
    problem : Problem
    scored : list of (chi2, x)
        The trials scored so far, ``x`` [SI] of shape (k,).

    Returns
    -------
    ndarray of shape (1,) or None
        The vertex [SI] when the best point is bracketed and the parabola opens upward; None for a
        hypothesis with more than one parameter or without a bracket.
    """
    if h.n_params != 1:
        return None
    log = tuple(h.log_scale)
    pts = [(float(to_z(x, log)[0]), c) for c, x in scored if np.isfinite(c) and (not log[0] or x[0] > 0)]
    null = h.null(problem.base, problem.ctx)
    if null is not None and np.all(np.isfinite(null)) and (not log[0] or null[0] > 0):
        pts.append((float(to_z(np.asarray(null, dtype=float), log)[0]), problem.base_scores()[0]))
    best_at: dict[float, float] = {}
    for z, c in pts:  # one point per value (the null may be a trial too)
        best_at[z] = min(c, best_at.get(z, math.inf))
    pts = sorted(best_at.items())
    i = int(np.argmin([c for _, c in pts]))
    if i == 0 or i == len(pts) - 1:
        return None
    (za, ca), (zb, cb), (zc, cc) = pts[i - 1], pts[i], pts[i + 1]
    den = (zb - za) * (cb - cc) - (zb - zc) * (cb - ca)
    if not np.isfinite(den) or den >= 0.0:  # negative for three points bracketing a minimum
        return None
    zv = zb - 0.5 * ((zb - za) ** 2 * (cb - cc) - (zb - zc) ** 2 * (cb - ca)) / den
    if not (za < zv < zc) or zv in (za, zb, zc):
        return None
    _, lo, hi = h.space(problem.base, problem.ctx)
    return np.clip(from_z(np.array([zv]), log), lo, hi)


def fit_hypothesis(h: Hypothesis, problem: Problem, *, starts: np.ndarray | None = None,
                   max_nfev: int = 40, n_starts: int = 2) -> Hypothesis:
    """Fit ``h`` to ``problem``; sets ``params_``, ``ci95_``, ``chi2_``, ``aic_``, ``bic_``, ``misfit_``.

    Parameters
    ----------
    h : Hypothesis
    problem : Problem
    starts : ndarray, shape (n, k), optional
        Starting values [SI]; default: :func:`trials_for`, screened, and for a
        mode-moving effect a chi-square scan around the coarse scan's best.
    max_nfev : int
        Evaluation budget of each local fit.
    n_starts : int
        Local fits from the best screened starts (those within a factor 3 of
        the best chi-square).

    Returns
    -------
    Hypothesis
        ``h``, fitted.
    """
    base, ctx = problem.base, problem.ctx
    trials, lo, hi = h.space(base, ctx)
    n0 = problem.n_evaluations
    if starts is not None:
        trials = np.atleast_2d(np.asarray(starts, dtype=float))
        screened = screen(h, problem, trials)
    else:
        trials = trials_for(h, problem)
        screened = screen(h, problem, trials)
        if h.moves_modes and h.n_params == 1:
            coarse = h.coarse_, h.coarse_error_
            local = screen(h, problem, _around(h, problem, h.coarse_))
            h.coarse_, h.coarse_error_ = coarse
            screened = sorted(screened + local, key=lambda t: t[0])
            trials = np.vstack([trials, [x for _, x in local]])
    log = tuple(h.log_scale)
    best_chi2 = screened[0][0]
    picks = [x for c, x in screened[:n_starts] if c <= 3.0 * best_chi2 + 1.0]
    zlo, zhi = to_z(lo, log), to_z(hi, log)
    tz = np.array([to_z(np.clip(t, lo, hi), log) for t in trials])
    scale = np.maximum(np.max(np.abs(tz), axis=0), 1e-12)
    scale = np.where(np.array(log), 1.0, scale)
    best = None
    for x0 in picks:
        z0 = to_z(np.clip(x0, lo, hi), log)
        span = zhi - zlo
        z0 = np.clip(z0, zlo + 1e-6 * span, zhi - 1e-6 * span)

        fun = residuals_in_z(h, problem, scale)

        try:
            sol = scipy.optimize.least_squares(fun, z0 / scale, bounds=(zlo / scale, zhi / scale), method="trf",
                                               diff_step=1e-3, max_nfev=max_nfev, x_scale=1.0)
        except ValueError:
            continue
        if best is None or sol.cost < best.cost:
            best = sol
    if best is None:
        x = screened[0][1]
        h.params_ = x
        h.ci95_ = np.column_stack([x, x]) * np.nan
        h.chi2_ = best_chi2
        h.success_ = False
    else:
        z = best.x * scale
        x = from_z(z, log)
        chi2 = 2.0 * best.cost
        if chi2 > best_chi2:
            x, chi2 = screened[0][1], best_chi2
            z = to_z(x, log)
        h.params_ = x
        h.chi2_ = float(chi2)
        h.success_ = bool(best.success or best.status > 0)
        # the linearised interval held to the parameter's own range (a damping ratio is not negative); an
        # end the data do not bound (inf, NaN) stays so
        ci = ci95_of(best.jac / scale[None, :], z, chi2, problem.n_obs, log)
        h.ci95_ = np.where(np.isfinite(ci), np.clip(ci, np.asarray(lo)[:, None], np.asarray(hi)[:, None]), ci)
    k = h.n_params
    h.aic_, h.bic_ = problem.information(h.chi2_, k)
    h.misfit_ = problem.misfit(problem.fitted_state(h))
    h.n_evaluations_ = problem.n_evaluations - n0
    return h


#: A log-scaled parameter whose linearised 95 % half-width exceeds this many decades is not bounded by the data:
#: its interval is reported as undetermined (NaN) rather than as, say, [1e-145, 1e+135].
UNBOUNDED_DECADES = 2.0


def ci95_of(jac: np.ndarray, z: np.ndarray, chi2: float, n: int, log: tuple[bool, ...]) -> np.ndarray:
    """95 % intervals [SI], shape (k, 2), from the Jacobian ``jac`` (shape (n, k)) of the residuals w.r.t. ``z``
    (log10 or linear parameters, shape (k,)), the covariance ``s2 (J^T J)^-1`` with ``s2 = max(1, chi2 / (n - k))``
    (the reduced chi-square where it exceeds 1); NaN ends for a log parameter the data do not bound
    (half-width above :data:`UNBOUNDED_DECADES` decades), infinite ones for a direction the data do not
    determine. Source: the linearised (Gauss-Newton) covariance of least squares, e.g. Seber & Wild,
    *Nonlinear Regression*, 1989, Sec. 5.1."""
    k = z.size
    s2 = max(1.0, chi2 / max(n - k, 1))
    jtj = jac.T @ jac
    try:
        # the covariance on the directions the data determine; a parameter with a share in a direction they do
        # not (an eigenvalue below 1e-12 of the largest) has no finite interval -- a pseudo-inverse would give
        # it a falsely narrow one
        w, v = np.linalg.eigh(jtj)
        kept = w > 1e-12 * max(w.max(initial=0.0), 0.0)
        cov = s2 * (v[:, kept] / w[kept]) @ v[:, kept].T
        sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
        sd = np.where(np.any(np.abs(v[:, ~kept]) > 1e-6, axis=1), np.inf, sd)
    except np.linalg.LinAlgError:
        sd = np.full(k, np.inf)
    sd = np.where(np.diag(jtj) > 0, sd, np.inf)
    lo_z, hi_z = z - 1.96 * sd, z + 1.96 * sd
    lo = np.array([10.0 ** min(a, 300.0) if lg else a for a, lg in zip(lo_z, log)])
    hi = np.array([10.0 ** min(b, 300.0) if lg else b for b, lg in zip(hi_z, log)])
    unbounded = np.array(log, dtype=bool) & ~(1.96 * sd <= UNBOUNDED_DECADES)
    lo[unbounded], hi[unbounded] = np.nan, np.nan
    return np.column_stack([lo, hi])


def rank(hyps: list[Hypothesis]) -> list[Hypothesis]:
    """Fitted hypotheses ``hyps`` sorted by BIC (ties: fewer parameters, then library order)."""
    return sorted(hyps, key=lambda h: (round(h.bic_, 6), h.n_params, h.order))


def equivalent(a: Hypothesis, b: Hypothesis) -> bool:
    """True when hypotheses ``a`` and ``b`` are the same linear model (damping and friction at one point)."""
    pair = {a.effect, b.effect}
    return pair == {"damping", "friction"} and a.location == b.location


def _screen_pairs(kept: Hypothesis, x_kept: np.ndarray, pool: list[Hypothesis], problem: Problem,
                  skip: set, coarse: bool = True) -> list[tuple[float, np.ndarray, int]]:
    """Pairs of ``kept`` (held at ``x_kept`` [SI]) with each hypothesis of ``pool`` screened at that one's trial
    values, its coarse scan when it is a one-parameter mode-moving effect (:func:`trials_for`; with ``coarse``)
    and its single fit, where it has one: ``(chi2, x, index into pool)``, best first. Pairs of ``skip`` (label sets), of ``kept``
    with itself or with an equivalent are left out.

    The coarse scan, as for a single effect: the chi-square well of a second effect that moves lightly
    damped modes is narrower than the spacing of its own trial values (a spring's are 3.3x apart). On the
    MuJoCo grid (joint 7 softened to 23 N m/rad and a 790 N/m spring at the top beam's point 17) the spring at 17 screened at its trial values (885 N/m the nearest) was not among
    the 12 best partners of the joint; scanned, it was 2nd, and fitted it gave the best pair (chi-square
    19 240, against 20 667 for the spring at 16 and 27 965 for the pair selected before, the joint with a
    friction force at point 15 that pinned the beam there)."""
    scored = []
    for i, b in enumerate(pool):
        if b.label == kept.label or equivalent(kept, b) or frozenset((kept.label, b.label)) in skip:
            continue
        c = Combination(first=kept, second=b)
        try:
            tb, _, _ = b.space(problem.base, problem.ctx)
            if coarse and b.moves_modes and b.n_params == 1:  # and its coarse scan: the narrow wells between
                tb = np.vstack([tb, trials_for(b, problem)])
            if hasattr(b, "params_"):
                tb = np.vstack([tb, [b.params_]])
            trials = np.array([np.concatenate([x_kept, t]) for t in tb])
            chi2, x = screen(c, problem, trials)[0]
        except (VlabError, ValueError, np.linalg.LinAlgError):
            continue
        scored.append((chi2, x, i))
    scored.sort(key=lambda t: t[0])
    return scored


def _fit_screened(kept: Hypothesis, scored: list, pool: list[Hypothesis], problem: Problem, *, n_fit: int,
                  max_nfev: int, skip: set) -> list[Combination]:
    """The ``n_fit`` best of the screened pairs ``scored`` (:func:`_screen_pairs`) fitted jointly from their
    screened values; ``skip`` receives their label sets."""
    out: list[Combination] = []
    for _chi2, x, i in scored:
        if len(out) >= n_fit:
            break
        c = Combination(first=kept, second=pool[i])
        if frozenset((kept.label, c.parts[1].label)) in skip:
            continue  # fitted meanwhile (screened in another process)
        if any(equivalent(c.parts[1], o.parts[1]) for o in out):
            continue  # damping and friction at one point: the same linear model, fitted once
        try:
            fit_hypothesis(c, problem, starts=np.array([x]), max_nfev=max_nfev, n_starts=1)
        except (VlabError, ValueError, np.linalg.LinAlgError):
            continue
        skip.add(frozenset((kept.label, c.parts[1].label)))
        out.append(c)
    return out


def _pairs_with(kept: Hypothesis, x_kept: np.ndarray, pool: list[Hypothesis], problem: Problem, *, n_fit: int,
                max_nfev: int, skip: set, coarse: bool = False) -> list[Combination]:
    """Pairs of ``kept`` (held at ``x_kept`` [SI] while screening) with each hypothesis of ``pool``: all screened
    (in two processes, :func:`_screen_held`), the ``n_fit`` best fitted jointly. ``skip`` holds the label sets
    of pairs already fitted (updated). ``coarse``: mode-moving candidates over their coarse scan too."""
    scored, = _screen_held([(kept, np.asarray(x_kept, dtype=float))], pool, problem, skip, coarse=coarse)
    return _fit_screened(kept, scored, pool, problem, n_fit=n_fit, max_nfev=max_nfev, skip=skip)


def _screen_job(problem: Problem, held: list, pool: list[Hypothesis], skip: set, coarse: bool = True) -> list[list]:
    """Worker of :func:`_screen_held`: :func:`_screen_pairs` of each ``(hypothesis, value)`` of ``held``."""
    return [_screen_pairs(a, x, pool, problem, skip, coarse) for a, x in held]


def _screen_held(held: list, pool: list[Hypothesis], problem: Problem, skip: set, *, coarse: bool = True,
                 workers: int = 2) -> list[list]:
    """:func:`_screen_pairs` of each ``(hypothesis, value [SI])`` of ``held`` with the whole ``pool``, the pool
    split over ``workers`` processes (interleaved, so that each screens alike); one process where a pool
    cannot start or the problem cannot be sent to one. Returns one screened list per held pair, indices
    into ``pool``."""
    if workers > 1 and len(pool) > 1:
        import pickle
        from concurrent.futures import ProcessPoolExecutor
        from concurrent.futures.process import BrokenProcessPool

        chunks = [pool[j::workers] for j in range(workers)]
        try:
            with ProcessPoolExecutor(workers) as ex:
                parts = list(ex.map(_screen_job, [problem] * workers, [held] * workers, chunks, [skip] * workers,
                                    [coarse] * workers))
        except (OSError, BrokenProcessPool, pickle.PicklingError, AttributeError, TypeError):
            parts = None  # no process pool here (or a problem that cannot be sent): one process
        if parts is not None:
            merged = []
            for k in range(len(held)):
                rows = [(c, x, i * workers + j) for j, part in enumerate(parts) for c, x, i in part[k]]
                merged.append(sorted(rows, key=lambda t: t[0]))
            return merged
    return _screen_job(problem, held, pool, skip, coarse)


#: Mode-moving single effects tried as the first effect of a pair besides the best single one (the
#: forward step's "basin" firsts, :func:`fit_pairs`): the best by smoothed error, each held at the centre
#: of its broad basin. Chosen, not fitted (each costs a screen of the mode-moving pool, about 900 FE
#: evaluations on the grid, 4-8 s). On the MuJoCo grid (joint 9 softened to
#: 22 N m/rad with bar 2-6 stiffened 1.42x) the joint's single fit, 49 N m/rad, absorbs the bar's opposite
#: frequency shifts; held there, the bar ranks 8th of the partners screened; held at its basin's centre,
#: 35 N m/rad, 2nd, and the joint fit reaches the drawn pair (chi-square 1.6e4 against 5.5e5 for the
#: best pair found before, two members at joint 9). The joint is 5th of the single fits by chi-square,
#: 3rd by smoothed error.
N_BASIN_FIRSTS = 3


def _basin_firsts(singles: list[Hypothesis], n: int) -> list[Hypothesis]:
    """The ``n`` one-parameter mode-moving fits of ``singles`` with the least smoothed error (``coarse_error_``,
    set by :func:`screen`), best first."""
    movers = [h for h in singles if not isinstance(h, Combination) and h.moves_modes and h.n_params == 1
              and getattr(h, "coarse_", None) is not None and np.isfinite(getattr(h, "coarse_error_", np.nan))
              and getattr(h, "success_", True)]
    return sorted(movers, key=lambda h: h.coarse_error_)[:n]


def fit_pairs(singles: list[Hypothesis], problem: Problem, candidates: list[Hypothesis] | None = None, *,
              n_first: int = 1, n_second: int = 3, max_nfev: int = 40, rounds: int = 2,
              n_replace: int = 20, n_basin: int = N_BASIN_FIRSTS) -> list[Combination]:
    """Pairs of effects by forward selection and sequential replacement.

    Forward step: with the best single effect in the model, every other
    hypothesis is screened on top of it (a mode-moving one over its coarse
    scan too, :func:`_screen_pairs`) and the most promising pairs are
    fitted jointly. Replacement step: each part of the best pair in turn is
    held at its fitted size while hypotheses are screened in place of the
    other part (the ``n_replace`` first of ``candidates`` and every one of the
    replaced part's effect), and the most promising are fitted jointly
    (a first effect chosen alone can be the wrong one of two neighbouring
    points, or a look-alike, once the second effect is in the model);
    repeated while the best pair changes, at most ``rounds`` times.

    Basin step, when no fit so far explains the data fully on the linear
    model (:func:`_explained`: within the noise, or a remainder not resolved from
    the noise, :func:`vlab.diagnose.fit.confirm.remainder_resolved`): two
    effects that both move modes compensate each other's frequency shifts,
    so the single fit of either is biased toward a value the pair does not
    have, and the best single effect may be neither of them. The ``n_basin``
    one-parameter mode-moving single effects with the least smoothed error
    (:meth:`~vlab.diagnose.problem.residuals.Problem.scores`: the broad basin
    a chi-square well lies in) are tried as the first effect, held at the
    centre of that basin (``coarse_``), with every mode-moving hypothesis
    screened as the second (a second effect that moves no mode leaves the
    first's frequencies, hence its single fit, unbiased: the forward step
    covers it); the best of these pairs, where it beats the best so far, is
    improved by the replacement step too (these screens at the trial values
    alone: the coarse scan doubles a screen's cost). The basin step only adds pairs:
    what the steps before found is kept (run on the linear grid, a basin pair
    that replaced the forward step's best as the start of the replacement
    step led it away from the drawn pair that the forward path reached).

    Parameters
    ----------
    singles : list of Hypothesis
        Fitted single effects.
    problem : Problem
    candidates : list of Hypothesis, optional
        Unfitted hypotheses for the second effect, most promising first
        (default: ``singles``).
    n_first : int
        Number of best single effects tried as the first effect.
    n_second : int
        Pairs fitted jointly per held effect (best screened; damping and
        friction at one point count once).
    max_nfev : int
        Evaluation budget of each joint fit.
    rounds : int
        Most replacement rounds.
    n_replace : int
        Candidates screened in a replacement besides those of the replaced effect.
    n_basin : int
        Mode-moving single effects tried as the first effect at the centre of their smoothed-error basin
        (default :data:`N_BASIN_FIRSTS`; 0: only the forward step from the best single effect).

    Returns
    -------
    list of Combination
        Fitted. Pairs of the same hypothesis, equivalent pairs
        (:func:`equivalent`) and pairs already fitted (in either order) are skipped.

    Notes
    -----
    Forward stepwise selection and sequential replacement (Miller, *Subset
    Selection in Regression*, 2nd ed., 2002, Secs. 3.2 and 3.3): the second
    effect is judged with the first one already explaining its part of the
    data, so an effect masked by a larger one is still found, and the first
    is judged again with the second in the model.
    """
    firsts = [h for h in rank(singles) if getattr(h, "success_", True)][:n_first]
    pool = candidates if candidates is not None else singles
    out: list[Combination] = []
    skip: set = set()
    for a in firsts:
        out += _pairs_with(a, np.asarray(a.params_, dtype=float), pool, problem, n_fit=n_second,
                           max_nfev=max_nfev, skip=skip, coarse=True)
    best = _replace(min(out, key=lambda c: c.bic_, default=None), pool, problem, out, n_fit=n_second,
                    max_nfev=max_nfev, skip=skip, rounds=rounds, n_replace=n_replace)
    # the basin firsts only where nothing found so far is a full explanation; a search of its own, replaced
    # from its best pair, so that it adds to the step above and never changes it
    if best is None or _explained(problem, list(singles) + out):
        return out
    movers = [h for h in pool if h.moves_modes and h.n_params == 1]
    held = [(a, np.asarray(a.coarse_, dtype=float)) for a in _basin_firsts(singles, n_basin)]
    basin: list[Combination] = []
    for (a, _x), scored in zip(held, _screen_held(held, movers, problem, skip, coarse=False) if held else []):
        basin += _fit_screened(a, scored, movers, problem, n_fit=n_second, max_nfev=max_nfev, skip=skip)
    out += basin
    top = min(basin, key=lambda c: c.bic_, default=None)
    if top is not None and top.bic_ < best.bic_:
        _replace(top, pool, problem, out, n_fit=n_second, max_nfev=max_nfev, skip=skip, rounds=rounds,
                 n_replace=n_replace)
    return out


def _explained(problem: Problem, fitted: list[Hypothesis]) -> bool:
    """Whether one of the ``fitted`` hypotheses explains the data of ``problem`` fully on the linear model: it
    leaves them within the noise (:meth:`~vlab.diagnose.problem.residuals.Problem.within_noise`), or leaves a
    misfit not resolved from the one the noise alone leaves (:func:`vlab.diagnose.fit.confirm.remainder_resolved`)."""
    fits = [h for h in fitted if np.isfinite(getattr(h, "misfit_", np.nan))]
    if not fits:
        return False
    best = min(fits, key=lambda h: h.chi2_)
    if problem.within_noise(problem.fitted_state(best)):
        return True
    noise = None
    if isinstance(problem.data, FrfData):
        m = problem.mask
        noise = noise_misfit(problem.data.h[m], problem.data.var[m], problem.weight_mag[m])
    return noise is not None and not remainder_resolved(min(h.misfit_ for h in fits), noise)


def _replace(best: Combination | None, pool: list[Hypothesis], problem: Problem, out: list, *, n_fit: int,
             max_nfev: int, skip: set, rounds: int, n_replace: int) -> Combination | None:
    """Sequential replacement from the pair ``best`` (the replacement step of :func:`fit_pairs`): the pairs
    fitted are appended to ``out``; returns the best pair reached (``best`` when none beat it)."""
    for _ in range(rounds):
        if best is None:
            break
        k = best.parts[0].n_params
        held = ((best.parts[0], best.params_[:k]), (best.parts[1], best.params_[k:]))
        new = []
        for (part, x), (other, _) in zip(held, held[::-1]):
            rpool = pool[:n_replace] + [h for h in pool[n_replace:] if h.effect == other.effect]
            new += _pairs_with(part, np.asarray(x, dtype=float), rpool, problem, n_fit=n_fit,
                               max_nfev=max_nfev, skip=skip)
        out += new
        better = min(new, key=lambda c: c.bic_, default=None)
        if better is None or better.bic_ >= best.bic_:
            break
        best = better
    return best
