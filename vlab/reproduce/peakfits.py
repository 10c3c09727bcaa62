"""The candidate explanations of Table 10's peak level ratios, fitted to the published table.

Each candidate predicts the log ratio of all 24 cells (6 modes x 4 loop configurations) and is fitted
to them jointly by weighted least squares (scipy.optimize, after a global scan where the statistic has
many minima). A cell contributes ``min(z^2, c^2)``, ``z = (ln r_published - ln r_predicted) / sigma``,
``c`` the two-sided 95 % bound corrected for the number of cells (Bonferroni): a cell beyond ``c`` costs
the same whatever the parameters, so it cannot pull them. For the candidates averaged over an unknown
grid origin or unknown offsets the statistic is the deviance ``-2 ln`` of the averaged
``exp(-min(z^2, c^2) / 2)``. 95 % intervals are profile-likelihood sets (statistic within 3.84 of its
minimum). The candidates and the derivation of ``sigma`` are described in :mod:`vlab.reproduce.peakratios`.

Source: Table 10, Sec. 6.1.
"""

from __future__ import annotations

import numpy as np
from scipy import optimize
from scipy.stats import norm

from .peakanalysis import CONFIGS, DAMPING_FACTOR_RANGE, N_MODES, SPACING_RANGE_HZ, PeakRatioAnalysis, damping_spline
from .peaktable import (COLUMN_TOLERANCE, LEVEL, PROFILE_DELTA, CandidateFit, ConfidenceSet, Parameter,
                        PeakRatioTable)

_SCAN_REL_STEP = 1e-4         # relative step of the spacing scan (the grid moves <= 0.0021 Hz at 22 Hz)
_SCAN_ORIGIN_STEP_HZ = 1e-3   # origin step of the scan (mode 1's half-power half-width: 0.0074 Hz)
_SCAN_CHUNK = 1_000_000


# --------------------------------------------------------------------------- fitting
class FitProblem:
    """Published log ratios, their sigmas and the bound; the statistics of predictions.

    Parameters
    ----------
    an : PeakRatioAnalysis
        The analysis side (:func:`vlab.reproduce.peakanalysis.analysis_side`).
    tab : PeakRatioTable
        The published table.

    Attributes
    ----------
    y : ndarray, shape (6, 4)
        Published ``ln`` ratios.
    sig_round, sig_damp, sig : ndarray, shape (6, 4)
        Standard deviation of ``ln r`` from the printing, from Table 1's damping, and both in squares.
    n : int
        Number of cells.
    cap : float
        The bound ``c`` on ``|z|`` (two-sided, family-wise 95 %, Bonferroni over the cells).
    """

    def __init__(self, an: PeakRatioAnalysis, tab: PeakRatioTable):
        self.an = an
        self.y = np.log(tab.ratio)
        self.sig_round = tab.half_unit / np.sqrt(3.0) / tab.ratio
        self.sig_damp = an.sigma_damping_log
        self.sig = np.sqrt(self.sig_round ** 2 + self.sig_damp ** 2)
        self.n = self.y.size
        self.cap = float(norm.ppf(1 - (1 - LEVEL) / (2 * self.n)))

    def z(self, pred: np.ndarray) -> np.ndarray:
        """Normalised residual ``(ln r_published - pred) / sigma`` of every cell, shape (..., 6, 4).

        Parameters
        ----------
        pred : ndarray, shape (..., 6, 4)
            Predicted ``ln`` ratios.
        """
        return (self.y - pred) / self.sig

    def cells(self, pred: np.ndarray) -> np.ndarray:
        """Truncated chi2 ``min(z^2, c^2)`` of every cell, shape (..., 6, 4).

        Parameters
        ----------
        pred : ndarray, shape (..., 6, 4)
            Predicted ``ln`` ratios.
        """
        return np.minimum(self.z(pred) ** 2, self.cap ** 2)

    def fit(self, name, description, params, pred, stat=None, stat_cols=None, z=None) -> CandidateFit:
        """A candidate's fit from its prediction.

        Parameters
        ----------
        name, description : str
            The candidate.
        params : sequence of Parameter
            Its fitted parameters.
        pred : ndarray, shape (6, 4)
            Predicted ``ln`` ratios at the fit.
        stat : float, optional
            The fitted statistic; default the truncated chi2 of ``pred``.
        stat_cols : ndarray, shape (4,), optional
            Its share per configuration; default that of the truncated chi2.
        z : ndarray, shape (6, 4), optional
            Normalised residuals; default those of ``pred``.

        Returns
        -------
        CandidateFit
            Without ``column_change`` (set by :func:`fit_candidates`).
        """
        zz = self.z(pred) if z is None else z
        cells = np.minimum(zz ** 2, self.cap ** 2)
        stat = float(cells.sum()) if stat is None else float(stat)
        stat_cols = cells.sum(0) if stat_cols is None else np.asarray(stat_cols)
        return CandidateFit(name, description, tuple(params), pred, zz, stat, stat_cols, float((zz ** 2).sum()),
                            (zz ** 2).sum(0), stat + len(params) * np.log(self.n), np.abs(zz) > self.cap)


def _runs(x: np.ndarray, ok: np.ndarray) -> tuple:
    """Intervals ``(x_first, x_last)`` of the runs of True in ``ok`` (``x`` ascending)."""
    if not ok.any():
        return ()
    d = np.diff(np.r_[0, ok.astype(int), 0])
    starts, ends = np.flatnonzero(d == 1), np.flatnonzero(d == -1) - 1
    return tuple((float(x[a]), float(x[b])) for a, b in zip(starts, ends))


def _refine_edges(f, intervals, x_grid, level, lo, hi):
    """Move the interior edges of grid-run intervals to the crossings ``f(x) = level`` (brentq)."""
    out = []
    for a, b in intervals:
        ia, ib = np.searchsorted(x_grid, a), np.searchsorted(x_grid, b)
        if ia > 0:
            a = optimize.brentq(lambda t: f(t) - level, x_grid[ia - 1], x_grid[ia], xtol=1e-10)
        if ib < len(x_grid) - 1:
            b = optimize.brentq(lambda t: f(t) - level, x_grid[ib], x_grid[ib + 1], xtol=1e-10)
        out.append((float(np.clip(a, lo, hi)), float(np.clip(b, lo, hi))))
    return tuple(out)


def _fit_damping(pb: FitProblem) -> CandidateFit:
    an = pb.an
    spl = damping_spline(an)
    u_lo, u_hi = an.log_damping_factor[0], an.log_damping_factor[-1]

    def stat(uu):
        return float(pb.cells(spl(uu)).sum())

    ug = np.linspace(u_lo, u_hi, 2001)
    sg = pb.cells(spl(ug)).sum(axis=(1, 2))
    j = int(np.argmin(sg))
    res = optimize.minimize_scalar(stat, bounds=(ug[max(j - 1, 0)], ug[min(j + 1, len(ug) - 1)]), method="bounded",
                                   options={"xatol": 1e-9})
    u_best, s_best = (float(res.x), float(res.fun)) if res.fun <= sg[j] else (float(ug[j]), float(sg[j]))
    level = s_best + PROFILE_DELTA
    iv = _refine_edges(stat, _runs(ug, sg <= level), ug, level, u_lo, u_hi)
    ci = ConfidenceSet(tuple((float(np.exp(a)), float(np.exp(b))) for a, b in iv), DAMPING_FACTOR_RANGE)
    pred = spl(u_best)
    return pb.fit("damping", "the structure's open-loop modal damping is a common factor times the analysis' "
                  "(Table 1); the same controllers closed around both",
                  [Parameter("structure_damping_factor", float(np.exp(u_best)), ci)], pred)


def _spacing_grid(pb: FitProblem) -> tuple[CandidateFit, CandidateFit]:
    """The grid candidates: origin fitted (2 parameters) and origin marginalised (1 parameter)."""
    an = pb.an
    pk = an.peak_hz.ravel()
    has = an.has_peak.ravel()
    y, sig, cap2 = pb.y.ravel(), pb.sig.ravel(), pb.cap ** 2
    tab = an.log_level_offset.reshape(pb.n, -1)
    d0, h = an.offsets_hz[0], an.offsets_hz[1] - an.offsets_hz[0]
    nt = tab.shape[1]
    const = np.where(has, 0.0, np.minimum((y / sig) ** 2, cap2))
    lo, hi = SPACING_RANGE_HZ
    ds = np.exp(np.arange(np.log(lo), np.log(hi), _SCAN_REL_STEP))
    nphi = np.maximum(4, np.ceil(ds / _SCAN_ORIGIN_STEP_HZ)).astype(np.int64)
    prof = np.empty(len(ds))
    marg = np.empty(len(ds))
    arg_phi = np.empty(len(ds))
    nbins = int(np.ceil(hi / _SCAN_ORIGIN_STEP_HZ)) + 1
    prof_phi = np.full(nbins, np.inf)
    cum = np.cumsum(nphi)
    start = 0
    while start < len(ds):
        base = cum[start - 1] if start else 0
        stop = max(int(np.searchsorted(cum, base + _SCAN_CHUNK, side="right")), start + 1)
        n_c = nphi[start:stop]
        dd = np.repeat(ds[start:stop], n_c)
        first = np.r_[0, np.cumsum(n_c)[:-1]]
        k = np.arange(len(dd)) - np.repeat(first, n_c)
        phi = k / np.repeat(n_c, n_c) * dd
        tot = np.full(len(dd), const[~has].sum())
        for c in np.flatnonzero(has):
            x = (pk[c] - phi) / dd
            xi = np.clip(((np.round(x) - x) * dd - d0) / h, 0, nt - 1.000001)
            i = xi.astype(np.int64)
            w = xi - i
            v = tab[c, i] * (1 - w) + tab[c, i + 1] * w
            tot += np.minimum(((y[c] - v) / sig[c]) ** 2, cap2)
        prof[start:stop] = np.minimum.reduceat(tot, first)
        arg = np.array([f + int(np.argmin(tot[f:f + n])) for f, n in zip(first, n_c)])
        arg_phi[start:stop] = phi[arg]
        marg[start:stop] = -2 * (np.logaddexp.reduceat(-0.5 * tot, first) - np.log(n_c))
        np.minimum.at(prof_phi, (phi / _SCAN_ORIGIN_STEP_HZ).astype(np.int64), tot)
        start = stop

    def stat(delta, origin):
        return float(pb.cells(an.spacing_log_ratios(delta, origin)).sum())

    # polish the best few separate minima of the profile (Nelder-Mead in ln(spacing), origin)
    order = np.argsort(prof)
    tried: list[float] = []
    best = (np.inf, None, None)
    for j in order:
        if len(tried) >= 6:
            break
        if any(abs(np.log(ds[j] / t)) < 0.01 for t in tried):
            continue
        tried.append(ds[j])
        res = optimize.minimize(lambda p: stat(np.exp(p[0]), p[1]), [np.log(ds[j]), arg_phi[j]], method="Nelder-Mead",
                                options={"xatol": 1e-7, "fatol": 1e-9,
                                         "initial_simplex": [[np.log(ds[j]), arg_phi[j]],
                                                             [np.log(ds[j]) + _SCAN_REL_STEP, arg_phi[j]],
                                                             [np.log(ds[j]), arg_phi[j] + 0.3 * _SCAN_ORIGIN_STEP_HZ]]})
        cand = (float(res.fun), float(np.exp(res.x[0])), float(res.x[1]))
        if prof[j] < cand[0]:
            cand = (float(prof[j]), float(ds[j]), float(arg_phi[j]))
        if cand[0] < best[0]:
            best = cand
    s_best, d_best, o_best = best
    if not lo <= d_best <= hi:
        d_best = float(np.clip(d_best, lo, hi))
    o_best = float(o_best % d_best)
    level = s_best + PROFILE_DELTA
    half = 0.5 * _SCAN_REL_STEP
    ci_d = ConfidenceSet(tuple((float(a * np.exp(-half)), float(b * np.exp(half))) for a, b in _runs(ds, prof <= level))
                         or ((d_best, d_best),), SPACING_RANGE_HZ)
    phis = (np.arange(nbins) + 0.5) * _SCAN_ORIGIN_STEP_HZ
    okp = np.isfinite(prof_phi) & (prof_phi <= level)
    ci_o = ConfidenceSet(tuple((max(a - 0.5 * _SCAN_ORIGIN_STEP_HZ, 0.0), b + 0.5 * _SCAN_ORIGIN_STEP_HZ)
                               for a, b in _runs(phis, okp)) or ((o_best, o_best),), (0.0, hi))
    grid = pb.fit("spacing-grid", "the analysis FRF evaluated on a grid of spacing Delta through the origin; "
                  "each peak read at the grid point nearest the resonance (Sec. 6.1)",
                  [Parameter("spacing_hz", d_best, ci_d), Parameter("origin_hz", o_best, ci_o)],
                  an.spacing_log_ratios(d_best, o_best), stat=s_best)
    # origin marginalised
    jm = int(np.argmin(marg))
    dm = float(ds[jm])
    res = optimize.minimize_scalar(lambda o: stat(dm, o), bounds=(arg_phi[jm] - _SCAN_ORIGIN_STEP_HZ,
                                                                 arg_phi[jm] + _SCAN_ORIGIN_STEP_HZ),
                                   method="bounded", options={"xatol": 1e-9})
    om = float(res.x % dm) if res.fun <= stat(dm, arg_phi[jm]) else float(arg_phi[jm])
    pred_m = an.spacing_log_ratios(dm, om)
    ci_m = ConfidenceSet(tuple((float(a * np.exp(-half)), float(b * np.exp(half)))
                               for a, b in _runs(ds, marg <= marg[jm] + PROFILE_DELTA)), SPACING_RANGE_HZ)
    margf = pb.fit("spacing-grid-origin-marginalised",
                   "the grid of spacing Delta with its origin unknown: likelihood averaged over a uniform origin "
                   "(predictions shown at the most likely origin for the fitted Delta)",
                   [Parameter("spacing_hz", dm, ci_m)], pred_m, stat=float(marg[jm]))
    return grid, margf


def _fit_random_offset(pb: FitProblem) -> CandidateFit:
    an = pb.an
    offs = an.offsets_hz
    h = offs[1] - offs[0]
    has = an.has_peak
    z2 = np.minimum(((pb.y[..., None] - an.log_level_offset) / pb.sig[..., None]) ** 2, pb.cap ** 2)
    e = np.exp(-0.5 * z2)
    cum = np.concatenate([np.zeros(e.shape[:2] + (1,)), np.cumsum(0.5 * (e[..., 1:] + e[..., :-1]) * h, axis=-1)],
                         axis=-1)
    idx = np.arange(len(offs))

    def cell_dev(delta):
        a = np.interp(-0.5 * delta, offs, idx)
        b = np.interp(0.5 * delta, offs, idx)
        ca = np.array([[np.interp(a, idx, cum[i, c]) for c in range(len(CONFIGS))] for i in range(N_MODES)])
        cb = np.array([[np.interp(b, idx, cum[i, c]) for c in range(len(CONFIGS))] for i in range(N_MODES)])
        lik = np.where(has, (cb - ca) / delta, np.exp(-0.5 * pb.cells(np.zeros_like(pb.y))))
        return -2 * np.log(np.maximum(lik, 1e-300))

    def dev(delta):
        return float(cell_dev(delta).sum())

    lo, hi = SPACING_RANGE_HZ
    lg = np.linspace(np.log(lo), np.log(hi), 1201)
    dg = np.array([dev(np.exp(t)) for t in lg])
    j = int(np.argmin(dg))
    res = optimize.minimize_scalar(lambda t: dev(np.exp(t)), bounds=(lg[max(j - 1, 0)], lg[min(j + 1, len(lg) - 1)]),
                                   method="bounded", options={"xatol": 1e-9})
    t_best, s_best = (float(res.x), float(res.fun)) if res.fun <= dg[j] else (float(lg[j]), float(dg[j]))
    level = s_best + PROFILE_DELTA
    iv = _refine_edges(lambda t: dev(np.exp(t)), _runs(lg, dg <= level), lg, level, lg[0], lg[-1])
    ci = ConfidenceSet(tuple((float(np.exp(a)), float(np.exp(b))) for a, b in iv), SPACING_RANGE_HZ)
    delta = float(np.exp(t_best))
    # per cell: the offset within +-Delta/2 that brings the reading closest to the published value
    inside = np.abs(offs) <= 0.5 * delta
    zz = (pb.y[..., None] - an.log_level_offset) / pb.sig[..., None]
    zz = np.where(inside, zz, np.inf)
    k = np.argmin(np.abs(zz), axis=-1)
    pred = np.take_along_axis(an.log_level_offset, k[..., None], axis=-1)[..., 0]
    pred = np.where(has, pred, 0.0)
    cd = cell_dev(delta)
    return pb.fit("spacing-random-offset",
                  "each peak read off its resonance by an independent uniform offset within +-Delta/2 (the grid's "
                  "position at each peak unknown); likelihood averaged over the offsets (predictions shown at each "
                  "cell's most likely offset)",
                  [Parameter("spacing_hz", delta, ci)], pred, stat=s_best, stat_cols=cd.sum(0))


def fit_candidates(pb: FitProblem) -> tuple:
    """Every candidate fitted, in the order of :mod:`vlab.reproduce.peakratios`'s docstring, with its columns
    compared with ``none``'s (:data:`~vlab.reproduce.peaktable.COLUMN_TOLERANCE`).

    Parameters
    ----------
    pb : FitProblem
        The published table and the analysis side.

    Returns
    -------
    tuple of CandidateFit
        ``none`` first.
    """
    an = pb.an
    zero = np.zeros_like(pb.y)
    none = pb.fit("none", "no explanation: every ratio 1", [], zero)
    grid, marg = _spacing_grid(pb)
    rand = _fit_random_offset(pb)
    damp = _fit_damping(pb)
    foff = pb.fit("frequency-offset", "the analysis read at the experimental natural frequencies of Table 1 "
                  "(each peak read f_exp - f_ana away from its resonance)", [], an.log_ratio_frequency_offset)
    ferr = pb.fit("frequency-error", "the experiment is the same closed loop on the as-measured structure "
                  "(Table 1 experimental frequencies), read at its own peaks", [], an.log_ratio_frequency_error)
    out = []
    for c in (none, grid, marg, rand, damp, foff, ferr):
        diff = c.statistic_by_config - none.statistic_by_config
        change = tuple("worse" if d > COLUMN_TOLERANCE else "better" if d < -COLUMN_TOLERANCE else "unchanged"
                       for d in diff)
        out.append(CandidateFit(c.name, c.description, c.parameters, c.log_ratio_predicted, c.z, c.statistic,
                                c.statistic_by_config, c.chi2, c.chi2_by_config, c.bic, c.outside, change))
    return tuple(out)
