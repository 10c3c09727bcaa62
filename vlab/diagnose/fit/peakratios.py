"""Diagnosis of the BCC's published peak level ratios (Table 10) as real data.

Table 10 lists the ratios *analytical / experimental* of the displacement-FRF
peak levels of the Beam Cross-Cable (force at point 9, displacement at point
6, Sec. 5.4.2) for six modes in four loop configurations: open loop, MFDRF,
LQDRF and LQG. The open-loop ratios of modes 1, 2, 4 and 5 are 0.17-0.55; the
dissertation explains them by "the extremely low inherent damping in the
structure and the frequency spacing of the evaluation points. The peaks are
so sharp that a minor shift away from the actual resonant frequency causes a
large decrease in the peak level" (Sec. 6.1), and the closed-loop agreement
by the added damping. This module tests that explanation against the others
of a small library, on all four columns at once: one explanation has to hold
in every loop configuration.

The analysis side
    The dissertation's analysis: the continuous closed loop on the full BCC
    model (Sec. 6.1) with Table 1's open-loop damping as proportional modal
    damping (Sec. 2.1.2), the Table 7 gains for MFDRF and LQDRF, vlab's LQG
    design for LQG (:func:`vlab.design.design_controller`, as
    :mod:`vlab.reproduce` uses it). The FE model's first six natural
    frequencies are set to Table 1's analytical values by a spectral shift
    that keeps the mode shapes (as :func:`vlab.reproduce.context.lab_structure`
    does with the experimental ones): where the analysis was read relative to
    its resonances matters to 0.001 Hz here, and vlab's model is up to
    0.016 Hz away from the dissertation's. Each configuration's FRF is kept in
    pole-residue form, ``H(f) = sum_k r_k / (j 2 pi f - p_k)`` [m/N]
    (:class:`PoleResidueFRF`), and each mode's peak is the highest local
    maximum of ``|H|`` between the midpoints to the neighbouring closed-loop
    natural frequencies (:func:`find_peaks`). A mode whose FRF has no local
    maximum there (vlab's LQG, mode 3) has no resonance to miss: explanations
    that act by moving the reading frequency predict ratio 1 for it.

The explanations (candidates)
    Each predicts the log ratio of all 24 cells (6 modes x 4 configurations):

    ``none``
        ratio 1 everywhere (0 parameters).
    ``spacing-grid`` (the dissertation's)
        the analysis FRF was evaluated on the grid ``f_n = origin + n Delta``
        and each peak read at the grid point nearest the resonance, i.e.
        ``|H(f_g)| / |H(f_peak)|``, the experiment's peak being the
        resonance's (2 parameters: ``spacing_hz`` Delta, ``origin_hz``).
        For a single mode this is ``1 / sqrt(1 + (delta / (zeta f0))^2)``
        with ``delta`` the distance to the grid.
    ``spacing-grid-origin-marginalised``
        the same with the origin unknown: the likelihood averaged over a
        uniform origin in ``[0, Delta)`` (1 parameter).
    ``spacing-random-offset``
        the same with each peak's distance to its grid point an independent
        uniform offset in ``[-Delta/2, Delta/2]``, the likelihood averaged
        over it (1 parameter). This is the limit the grid model reaches when
        the grid's position relative to each peak is not known: Table 1's
        analytical frequencies are printed to 0.001-0.01 Hz and a change of
        Delta by 1e-4 of itself moves the grid by 0.002 Hz at 22 Hz.
    ``damping``
        the structure's open-loop modal damping is ``structure_damping_factor``
        times the analysis' (Table 1) in every mode, the same controllers
        closed around both (1 parameter); open loop: ratio ~ factor.
    ``frequency-offset``
        the analysis read at the experimental natural frequencies (Table 1):
        each peak read ``f_exp,i - f_ana,i`` away from its resonance, the same
        offset in every configuration (0 parameters).
    ``frequency-error``
        the experiment is the same closed loop on the as-measured structure
        (Table 1 experimental frequencies, same shapes and damping), read at
        its own peaks (0 parameters).

The uncertainty of a published ratio (derived, per cell, in ``ln r``)
    1. Printing: a value printed with ``d`` decimals is uniform within
       ``+-0.5 10^-d`` (Table 10: two decimals), standard deviation
       ``0.5 10^-d / sqrt(3)``, i.e. ``0.0029 / r`` in ``ln r``.
    2. Open-loop damping: Table 1 prints each damping ratio to one significant
       digit (0.001-0.004), so the structure's damping is known to
       ``zeta +- h``, ``h = 0.5 10^-3``: uniform in ``ln zeta`` over
       ``[ln(zeta - h), ln(zeta + h)]``, standard deviation
       ``ln((zeta + h) / (zeta - h)) / sqrt(12)`` (0.073 for 0.004, 0.32 for
       0.001). A peak level scales as ``1/zeta``; here the sensitivity
       ``d ln P / d ln zeta_i`` of every cell's analysis peak to every mode's
       damping is computed by central differences on the analysis model
       (open loop: -1 for its own mode; closed loop: -0.002 to -0.07, the
       added damping dominates), and the contributions are added in squares.
    3. Not included: the experiment's own peak reading at its frequency
       resolution. The dissertation does not give the resolution (Sec. 5.4:
       STI-11/23 FFTs of pseudo-random or incremental sine-sweep data) nor
       how peaks were read, so its size cannot be derived. Also neglected:
       the printing of Table 1's analytical frequencies (+-0.0005 Hz for modes
       1-4, +-0.005 Hz for modes 5 and 6: at most 0.22 of mode 6's half-power
       half-width ``zeta f``), which moves where a grid falls on a peak.

Fit, selection and what is outside
    Each candidate is fitted to all 24 log ratios jointly by weighted least
    squares (scipy.optimize, after a global scan where the statistic has many
    minima) with one rule for cells beyond reach: a cell contributes
    ``min(z^2, c^2)``, ``z = (ln r_published - ln r_predicted) / sigma``,
    ``c = Phi^-1(1 - 0.05 / (2 n))`` the two-sided 95 % bound corrected for
    the ``n = 24`` cells (Bonferroni, ``c = 3.08``). A cell beyond ``c``
    costs the same whatever the parameters, so it cannot pull them: it is
    reported "not explained by the library: outside", never absorbed. For the
    averaged candidates the statistic is the deviance ``-2 ln`` of the
    averaged ``exp(-min(z^2, c^2) / 2)``. BIC = statistic + k ln n. 95 %
    intervals are profile-likelihood sets (statistic within 3.84 of its
    minimum); they are unions of disjoint intervals where the statistic has
    many minima, and "not bounded by the data" when they reach the searched
    range or are not one interval. A candidate is eligible only if no
    column's statistic is worse than with ``none`` by more than 1 (it must
    not trade one configuration for another); the eligible candidate with the
    lowest BIC is selected.

Source: Table 10 (and Table 2, its open-loop column), Table 1, Table 7,
Table 8, Sec. 2.1.2, Sec. 5.4, Sec. 6.1.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy import optimize
from scipy.stats import norm

from ...errors import DataFileError
from ...spec import DATA_DIR
from .peakanalysis import (CONFIGS, DAMPING_FACTOR_RANGE, N_MODES, SPACING_RANGE_HZ, PeakRatioAnalysis,
                           analysis_side, damping_spline, half_unit, read_csv_rows)

#: Table 10's file in ``assets/data``.
TABLE = "table10_bcc_peak_ratios.csv"
#: Readable names of :data:`CONFIGS`.
CONFIG_LABELS = {"open_loop": "open loop", "mfdrf": "MFDRF", "lqdrf": "LQDRF", "lqg": "LQG"}
#: Level of the confidence sets and of the family-wise bound beyond which a cell is outside.
LEVEL = 0.95
#: Increase of the statistic bounding a one-parameter 95 % profile-likelihood set (chi2, 1 dof).
PROFILE_DELTA = 3.841458820694124
#: A column is "worse" than without explanation when its statistic grows by more than this.
COLUMN_TOLERANCE = 1.0
#: Status strings of a cell.
WITHIN, EXPLAINED, OUTSIDE = ("within the data's accuracy", "explained",
                              "not explained by the library: outside")

_SCAN_REL_STEP = 1e-4         # relative step of the spacing scan (the grid moves <= 0.0021 Hz at 22 Hz)
_SCAN_ORIGIN_STEP_HZ = 1e-3   # origin step of the scan (mode 1's half-power half-width: 0.0074 Hz)
_SCAN_CHUNK = 1_000_000


# --------------------------------------------------------------------------- the published table
@dataclass(frozen=True)
class PeakRatioTable:
    """A peak-ratio table as published (Table 10 layout).

    Attributes
    ----------
    path : str
        The file read.
    ratio : ndarray, shape (6, 4)
        Published ratio (analysis / experiment) per mode and configuration [-].
    half_unit : ndarray, shape (6, 4)
        Half a unit of each value's last printed digit [-] (0.005 for two decimals).
    """

    path: str
    ratio: np.ndarray
    half_unit: np.ndarray


def read_peak_ratio_table(table_path: str | Path = TABLE) -> PeakRatioTable:
    """Read and check a peak-ratio table: columns ``mode`` and :data:`CONFIGS`, modes 1-6.

    Rows whose ``mode`` is not a number (Table 10's ``avg_error``) are skipped.

    Parameters
    ----------
    table_path : str or Path
        A path, or a file name in ``assets/data``.

    Returns
    -------
    PeakRatioTable

    Raises
    ------
    DataFileError
        Missing file; a missing column (named); a row with the wrong number
        of fields; modes other than 1-6 once each; a value that is not a
        positive finite number (file, column and mode named).
    """
    p = Path(table_path)
    if not p.exists() and not p.is_absolute():
        p = DATA_DIR / p
    if not p.exists():
        raise DataFileError(f"{p}: peak ratio table not found")
    hdr, rows = read_csv_rows(p)
    for col in ("mode", *CONFIGS):
        if col not in hdr:
            raise DataFileError(f"{p}: no column {col!r}; columns are {hdr}")
    ratio = np.full((N_MODES, len(CONFIGS)), np.nan)
    half = np.full_like(ratio, np.nan)
    seen = []
    for n, row in enumerate(rows, start=2):
        if len(row) != len(hdr):
            raise DataFileError(f"{p}: data row {n} has {len(row)} fields, expected {len(hdr)}")
        mode_txt = row[hdr.index("mode")]
        try:
            mode = float(mode_txt)
        except ValueError:
            continue  # a summary row such as avg_error
        if mode != int(mode) or not 1 <= mode <= N_MODES or int(mode) in seen:
            raise DataFileError(f"{p}: column 'mode', row {n}: {mode_txt!r} is not a new mode number 1-{N_MODES}")
        mode = int(mode)
        seen.append(mode)
        for c, col in enumerate(CONFIGS):
            txt = row[hdr.index(col)]
            try:
                v = float(txt)
                h = half_unit(txt)
            except ValueError:
                raise DataFileError(f"{p}: column {col!r}, mode {mode}: {txt!r} is not a number") from None
            if not (np.isfinite(v) and v > 0):
                raise DataFileError(f"{p}: column {col!r}, mode {mode}: {txt!r} is not a positive ratio")
            ratio[mode - 1, c], half[mode - 1, c] = v, h
    if sorted(seen) != list(range(1, N_MODES + 1)):
        raise DataFileError(f"{p}: column 'mode' must list modes 1-{N_MODES}, found {sorted(seen)}")
    return PeakRatioTable(str(p), ratio, half)


# --------------------------------------------------------------------------- results
@dataclass(frozen=True)
class ConfidenceSet:
    """A profile-likelihood confidence set: a union of intervals within a searched range.

    Attributes
    ----------
    intervals : tuple of (float, float)
        Disjoint intervals, ascending [parameter unit].
    search_range : (float, float)
        The range searched [parameter unit].
    level : float
        Confidence level.
    """

    intervals: tuple
    search_range: tuple
    level: float = LEVEL

    @property
    def lower(self) -> float:
        """Lowest value of the set."""
        return self.intervals[0][0]

    @property
    def upper(self) -> float:
        """Highest value of the set."""
        return self.intervals[-1][1]

    @property
    def bounded(self) -> bool:
        """True if the set is one interval inside the searched range (the data bound the parameter)."""
        lo, hi = self.search_range
        return (len(self.intervals) == 1 and self.lower > lo * (1 + 1e-9) + 1e-12
                and self.upper < hi * (1 - 1e-9))

    def contains(self, x: float) -> bool:
        """Whether ``x`` lies in the set (within 1e-6 relative of an interval).

        Parameters
        ----------
        x : float
            A parameter value.
        """
        return any(a * (1 - 1e-6) - 1e-12 <= x <= b * (1 + 1e-6) + 1e-12 for a, b in self.intervals)

    def describe(self, fmt: str = ".4g") -> str:
        """The set in words, e.g. ``"0.079 .. 0.12"`` or ``"not bounded by the data (...)"``.

        Parameters
        ----------
        fmt : str
            Number format.
        """
        span = f"{self.lower:{fmt}} .. {self.upper:{fmt}}"
        if self.bounded:
            return span
        lo, hi = self.search_range
        why = []
        if len(self.intervals) > 1:
            why.append(f"{len(self.intervals)} disjoint intervals within {span}")
        if self.lower <= lo * (1 + 1e-9) + 1e-12:
            why.append(f"reaches the lower end {lo:{fmt}} of the searched range")
        if self.upper >= hi * (1 - 1e-9):
            why.append(f"reaches the upper end {hi:{fmt}} of the searched range")
        if not why:
            why.append(span)
        return "not bounded by the data (" + "; ".join(why) + ")"


@dataclass(frozen=True)
class Parameter:
    """A fitted parameter.

    Attributes
    ----------
    name : str
        Name with its unit (``spacing_hz``, ``origin_hz``, ``structure_damping_factor``).
    value : float
    ci : ConfidenceSet
        95 % profile-likelihood set.
    """

    name: str
    value: float
    ci: ConfidenceSet


@dataclass(frozen=True)
class CandidateFit:
    """One explanation fitted to the table.

    Attributes
    ----------
    name : str
        Candidate name (module docstring).
    description : str
    parameters : tuple of Parameter
    log_ratio_predicted : ndarray, shape (6, 4)
        Predicted ``ln`` ratio of every cell at the fit.
    z : ndarray, shape (6, 4)
        ``(ln r_published - ln r_predicted) / sigma``.
    statistic : float
        Fitted statistic: sum of ``min(z^2, c^2)``, or the deviance for the averaged candidates.
    statistic_by_config : ndarray, shape (4,)
        Its share per configuration (for ``spacing-grid-origin-marginalised``:
        the truncated chi2 at the reported origin).
    chi2 : float
        Plain ``sum z^2`` over all cells.
    chi2_by_config : ndarray, shape (4,)
    bic : float
        ``statistic + k ln n``.
    outside : ndarray of bool, shape (6, 4)
        Cells beyond the bound ``c`` at the fit.
    column_change : tuple of str, length 4
        Per configuration, against ``none``: "better", "unchanged" or "worse"
        (change of ``statistic_by_config`` beyond :data:`COLUMN_TOLERANCE`).
    """

    name: str
    description: str
    parameters: tuple
    log_ratio_predicted: np.ndarray
    z: np.ndarray
    statistic: float
    statistic_by_config: np.ndarray
    chi2: float
    chi2_by_config: np.ndarray
    bic: float
    outside: np.ndarray
    column_change: tuple = ()

    @property
    def n_parameters(self) -> int:
        """Number of fitted parameters."""
        return len(self.parameters)

    @property
    def eligible(self) -> bool:
        """True if no configuration's column is worse than without explanation."""
        return "worse" not in self.column_change


@dataclass(frozen=True)
class CellResult:
    """One mode in one configuration, before and after the selected explanation.

    Attributes
    ----------
    mode : int
    config : str
    ratio_published : float
    sigma_ln_ratio : float
        Standard deviation of ``ln r`` (derived, module docstring).
    sigma_rounding_ln_ratio, sigma_damping_ln_ratio : float
        Its two parts (printing of the ratio; Table 1's damping).
    ratio_before : float
        1 (no explanation).
    z_before : float
    ratio_predicted : float
        Predicted by the selected explanation.
    z_after : float
    peak_hz : float
        Frequency of the analysis peak [Hz].
    has_peak : bool
        Whether the analysis FRF has a peak for the mode.
    status : str
        :data:`WITHIN`, :data:`EXPLAINED` or :data:`OUTSIDE`.
    """

    mode: int
    config: str
    ratio_published: float
    sigma_ln_ratio: float
    sigma_rounding_ln_ratio: float
    sigma_damping_ln_ratio: float
    ratio_before: float
    z_before: float
    ratio_predicted: float
    z_after: float
    peak_hz: float
    has_peak: bool
    status: str


@dataclass(frozen=True)
class PeakRatioDiagnosis:
    """The diagnosis of a peak-ratio table.

    Attributes
    ----------
    table : str
        File diagnosed.
    structure : str
    ratio_published : ndarray, shape (6, 4)
    sigma_ln_ratio : ndarray, shape (6, 4)
    bound_z : float
        ``c``: a cell with ``|z| > c`` is outside (family-wise 95 %, Bonferroni over the cells).
    candidates : tuple of CandidateFit
        Every candidate, in the order of the module docstring.
    selected : str
        Name of the selected candidate.
    verdict : str
    cells : tuple of CellResult
        24 cells, mode-major.
    chi2_before_by_config, chi2_after_by_config : ndarray, shape (4,)
        Plain chi2 per configuration without explanation and with the selected one (all cells).
    chi2_inside_before_by_config, chi2_inside_after_by_config : ndarray, shape (4,)
        The same over the cells the selected explanation leaves inside.
    closed_loop_zeta : ndarray, shape (6, 4)
        The analysis' closed-loop damping ratios [-].
    table8_zeta : ndarray, shape (6, 3)
        Table 8's (MFDRF, LQDRF, LQG) [-].
    notes : tuple of str
    wall_s : float
        Time taken [s].
    """

    table: str
    structure: str
    ratio_published: np.ndarray
    sigma_ln_ratio: np.ndarray
    bound_z: float
    candidates: tuple
    selected: str
    verdict: str
    cells: tuple
    chi2_before_by_config: np.ndarray
    chi2_after_by_config: np.ndarray
    chi2_inside_before_by_config: np.ndarray
    chi2_inside_after_by_config: np.ndarray
    closed_loop_zeta: np.ndarray
    table8_zeta: np.ndarray
    notes: tuple = field(default_factory=tuple)
    wall_s: float = 0.0

    def candidate(self, name: str) -> CandidateFit:
        """The candidate called ``name``.

        Parameters
        ----------
        name : str
            Candidate name.

        Raises
        ------
        KeyError
            For an unknown name.
        """
        for c in self.candidates:
            if c.name == name:
                return c
        raise KeyError(f"no candidate {name!r}; candidates are {[c.name for c in self.candidates]}")

    @property
    def best(self) -> CandidateFit:
        """The selected candidate."""
        return self.candidate(self.selected)


# --------------------------------------------------------------------------- fitting
class _Problem:
    """Published log ratios, their sigmas and the bound; the statistics of predictions."""

    def __init__(self, an: PeakRatioAnalysis, tab: PeakRatioTable):
        self.an = an
        self.y = np.log(tab.ratio)
        self.sig_round = tab.half_unit / np.sqrt(3.0) / tab.ratio
        self.sig_damp = an.sigma_damping_log
        self.sig = np.sqrt(self.sig_round ** 2 + self.sig_damp ** 2)
        self.n = self.y.size
        self.cap = float(norm.ppf(1 - (1 - LEVEL) / (2 * self.n)))

    def z(self, pred: np.ndarray) -> np.ndarray:
        return (self.y - pred) / self.sig

    def cells(self, pred: np.ndarray) -> np.ndarray:
        """Truncated chi2 of every cell, shape (..., 6, 4)."""
        return np.minimum(self.z(pred) ** 2, self.cap ** 2)

    def fit(self, name, description, params, pred, stat=None, stat_cols=None, z=None) -> CandidateFit:
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


def _fit_damping(pb: _Problem) -> CandidateFit:
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


def _spacing_grid(pb: _Problem) -> tuple[CandidateFit, CandidateFit]:
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


def _fit_random_offset(pb: _Problem) -> CandidateFit:
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


def _candidates(pb: _Problem) -> tuple:
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


def _cell_names(mask: np.ndarray) -> str:
    parts = []
    for c, cfg in enumerate(CONFIGS):
        modes = [str(i + 1) for i in range(N_MODES) if mask[i, c]]
        if modes:
            parts.append(f"{CONFIG_LABELS[cfg]} mode{'s' if len(modes) > 1 else ''} {', '.join(modes)}")
    return "; ".join(parts)


def _param_text(c: CandidateFit) -> str:
    return ", ".join(f"{p.name} = {p.value:.4g} (95 % CI {p.ci.describe()})" for p in c.parameters)


def diagnose_peak_ratios(table_path: str | Path = TABLE, structure: str = "bcc") -> PeakRatioDiagnosis:
    """Diagnose a Table 10 peak-ratio table: which explanation holds in all four loop configurations.

    Parameters
    ----------
    table_path : str or Path
        The table (a path, or a file name in ``assets/data``); columns
        ``mode``, ``open_loop``, ``mfdrf``, ``lqdrf``, ``lqg``; modes 1-6.
    structure : str
        ``"bcc"``.

    Returns
    -------
    PeakRatioDiagnosis
        Every candidate's fit, the selected one, the verdict and the per-cell
        before/after table (see the module docstring for the method).

    Raises
    ------
    DataFileError
        A missing or malformed table (names the file and the column).
    ModelError
        A structure other than ``"bcc"``.

    Source: Table 10, Sec. 6.1; Tables 1, 7, 8.
    """
    t0 = time.perf_counter()
    tab = read_peak_ratio_table(table_path)
    an = analysis_side(structure)
    pb = _Problem(an, tab)
    cands = _candidates(pb)
    none = cands[0]
    eligible = [c for c in cands if c.eligible]
    best = min(eligible, key=lambda c: (c.bic, c.n_parameters))
    z_before, z_after = none.z, best.z
    out_b, out_a = np.abs(z_before) > pb.cap, best.outside
    cells = []
    for i in range(N_MODES):
        for c, cfg in enumerate(CONFIGS):
            status = OUTSIDE if out_a[i, c] else (EXPLAINED if out_b[i, c] else WITHIN)
            cells.append(CellResult(i + 1, cfg, float(tab.ratio[i, c]), float(pb.sig[i, c]),
                                    float(pb.sig_round[i, c]), float(pb.sig_damp[i, c]), 1.0,
                                    float(z_before[i, c]), float(np.exp(best.log_ratio_predicted[i, c])),
                                    float(z_after[i, c]), float(an.peak_hz[i, c]), bool(an.has_peak[i, c]), status))
    n_out = int(out_a.sum())
    if best.name == "none":
        if n_out == 0:
            verdict = "within the data's accuracy: every ratio is 1 within its uncertainty"
        else:
            verdict = (f"outside the library: no explanation fits better than none (BIC) without making a column "
                       f"worse; {n_out} of {pb.n} cells differ from 1 beyond their uncertainty ({_cell_names(out_a)})")
    else:
        n_expl = int((out_b & ~out_a).sum())
        verdict = (f"{best.name} ({_param_text(best)}): explains {n_expl} of the {int(out_b.sum())} cells that differ "
                   f"from 1 beyond their uncertainty, BIC {none.bic - best.bic:.1f} below none")
        verdict += (f"; not explained by the library (outside): {n_out} of {pb.n} cells ({_cell_names(out_a)})"
                    if n_out else "; no cell left outside")
    inside = ~out_a
    chi_in_b = np.where(inside, z_before ** 2, 0.0).sum(0)
    chi_in_a = np.where(inside, z_after ** 2, 0.0).sum(0)
    cl_zeta = np.array([lp.zeta for lp in an.loops]).T
    no_peak = ~an.has_peak
    fr_h = np.array([0.0005] * 4 + [0.005] * 2)
    notes = [
        "Analysis: continuous closed loop on the full BCC model with its first six frequencies set to Table 1's "
        "analytical values; Table 7 gains (MFDRF, LQDRF); vlab's LQG design (reduced-model LQG as Table 8).",
        "Closed-loop damping of the analysis vs Table 8 (MFDRF, LQDRF, LQG), modes 1-6: " + "; ".join(
            f"mode {i + 1}: " + ", ".join(f"{cl_zeta[i, c + 1]:.4f}/{an.table8_zeta[i, c]:.4f}" for c in range(3))
            for i in range(N_MODES)) + ". vlab's LQG differs from the dissertation's (Table 8) most in modes 2 and 4, "
        "so the LQG column's analysis side is vlab's, not the dissertation's.",
        "Uncertainty not included: the experiment's peak reading at its (unpublished) frequency resolution; the "
        "printing of Table 1's analytical frequencies (at most "
        f"{np.max(fr_h / (an.zeta_open_loop * an.f_analysis_hz)):.2f} of a half-power half-width zeta f).",
    ]
    if best.name.startswith("spacing"):
        others = [c for c in cands if c.name.startswith("spacing") and c.name != best.name]
        notes.append("The spacing variants: " + "; ".join(
            f"{c.name} BIC {none.bic - c.bic:.1f} below none ({_param_text(c)})" for c in others)
            + ". spacing-random-offset does not use where the grid falls on each peak, so its margin over none is "
            "the part of the evidence that does not come from tuning the grid's position to the six open-loop peaks.")
    if no_peak.any():
        notes.append(f"No peak in the analysis FRF (read at the closed-loop natural frequency; the spacing and "
                     f"frequency-offset candidates predict 1 there): {_cell_names(no_peak)}.")
    return PeakRatioDiagnosis(tab.path, structure, tab.ratio, pb.sig, pb.cap, cands, best.name, verdict,
                              tuple(cells), (z_before ** 2).sum(0), (z_after ** 2).sum(0), chi_in_b, chi_in_a,
                              cl_zeta, an.table8_zeta, tuple(notes), time.perf_counter() - t0)


# --------------------------------------------------------------------------- output
def _ci_json(ci: ConfidenceSet, unit: str) -> dict:
    return {f"intervals{unit}": [[float(a), float(b)] for a, b in ci.intervals],
            f"lower{unit}": float(ci.lower), f"upper{unit}": float(ci.upper),
            f"search_range{unit}": [float(v) for v in ci.search_range], "bounded": bool(ci.bounded),
            "level": float(ci.level), "text": ci.describe()}


def _unit_of(name: str) -> str:
    return "_hz" if name.endswith("_hz") else ""


def to_json(d: PeakRatioDiagnosis) -> dict:
    """The diagnosis as a JSON-ready dict; every number's unit is in its key (``_hz``; others dimensionless).

    Parameters
    ----------
    d : PeakRatioDiagnosis

    Returns
    -------
    dict
        ``table``, ``verdict``, ``selected``, ``bound_z``, ``candidates``
        (name, parameters with ``ci95``, ``statistic``, ``chi2``, ``bic``,
        per-configuration values, ``outside_cells``), ``cells`` (mode,
        configuration, ``ratio_published``, ``sigma_ln_ratio``,
        ``ratio_before``, ``ratio_predicted``, ``z_before``, ``z_after``,
        ``peak_hz``, ``status``), ``chi2_by_config`` and ``notes``.
    """
    def cfg(v):
        return {c: float(x) for c, x in zip(CONFIGS, v)}

    cands = []
    for c in d.candidates:
        params = {}
        for p in c.parameters:
            u = _unit_of(p.name)
            params[p.name] = {f"value{u}": float(p.value), "ci95": _ci_json(p.ci, u)}
        cands.append({"name": c.name, "description": c.description, "n_parameters": c.n_parameters,
                      "parameters": params, "statistic": c.statistic, "statistic_by_config": cfg(c.statistic_by_config),
                      "chi2": c.chi2, "chi2_by_config": cfg(c.chi2_by_config), "bic": c.bic,
                      "column_change": dict(zip(CONFIGS, c.column_change)), "eligible": c.eligible,
                      "n_outside": int(c.outside.sum()),
                      "ratio_predicted": [[float(np.exp(v)) for v in row] for row in c.log_ratio_predicted]})
    cells = [{"mode": c.mode, "config": c.config, "ratio_published": c.ratio_published,
              "sigma_ln_ratio": c.sigma_ln_ratio, "sigma_rounding_ln_ratio": c.sigma_rounding_ln_ratio,
              "sigma_damping_ln_ratio": c.sigma_damping_ln_ratio, "ratio_before": c.ratio_before,
              "z_before": c.z_before, "ratio_predicted": c.ratio_predicted, "z_after": c.z_after,
              "peak_hz": c.peak_hz, "has_peak": c.has_peak, "status": c.status} for c in d.cells]
    return {"table": d.table, "structure": d.structure, "verdict": d.verdict, "selected": d.selected,
            "bound_z": d.bound_z, "configs": list(CONFIGS), "candidates": cands, "cells": cells,
            "chi2_by_config": {"before": cfg(d.chi2_before_by_config), "after": cfg(d.chi2_after_by_config),
                               "inside_before": cfg(d.chi2_inside_before_by_config),
                               "inside_after": cfg(d.chi2_inside_after_by_config)},
            "closed_loop_zeta": {c: [float(v) for v in d.closed_loop_zeta[:, j]] for j, c in enumerate(CONFIGS)},
            "table8_zeta": {c: [float(v) for v in d.table8_zeta[:, j]] for j, c in enumerate(CONFIGS[1:])},
            "notes": list(d.notes), "wall_s": d.wall_s}


def to_markdown(d: PeakRatioDiagnosis) -> str:
    """A short report: verdict, candidates, per-configuration chi2, per-mode table, what is outside.

    Parameters
    ----------
    d : PeakRatioDiagnosis

    Returns
    -------
    str
        Markdown text.
    """
    best = d.best
    lines = [f"**Verdict.** {d.verdict}.", "",
             f"Table: `{Path(d.table).name}`. Uncertainty of each published ratio: its printing (two decimals) and "
             f"Table 1's one-digit damping propagated through the analysis (module docstring); a cell with "
             f"|z| > {d.bound_z:.2f} (family-wise 95 % over {d.ratio_published.size} cells) is outside and costs "
             f"{d.bound_z ** 2:.2f} whatever the parameters.", "",
             "## Candidates", "",
             "| candidate | k | parameters (95 % CI) | statistic | chi2 (all cells) | BIC | outside "
             "| columns vs none |",
             "|---|---|---|---|---|---|---|---|"]
    for c in d.candidates:
        mark = " **(selected)**" if c.name == d.selected else ""
        cols = ", ".join(f"{CONFIG_LABELS[k]} {v}" for k, v in zip(CONFIGS, c.column_change))
        lines.append(f"| `{c.name}`{mark} | {c.n_parameters} | {_param_text(c) or '-'} | {c.statistic:.1f} | "
                     f"{c.chi2:.4g} | {c.bic:.1f} | {int(c.outside.sum())} | {cols} |")
    lines += ["", "## Chi2 per configuration (before: ratio 1; after: " + f"`{best.name}`)", "",
              "| | " + " | ".join(CONFIG_LABELS[c] for c in CONFIGS) + " |",
              "|---|" + "---|" * len(CONFIGS),
              "| chi2 before, all cells | " + " | ".join(f"{v:.4g}" for v in d.chi2_before_by_config) + " |",
              "| chi2 after, all cells | " + " | ".join(f"{v:.4g}" for v in d.chi2_after_by_config) + " |",
              "| chi2 before, cells inside | " + " | ".join(f"{v:.4g}" for v in d.chi2_inside_before_by_config) + " |",
              "| chi2 after, cells inside | " + " | ".join(f"{v:.4g}" for v in d.chi2_inside_after_by_config) + " |",
              "| statistic before | " + " | ".join(f"{v:.1f}" for v in d.candidates[0].statistic_by_config) + " |",
              "| statistic after | " + " | ".join(f"{v:.1f}" for v in best.statistic_by_config) + " |",
              "", "## Per mode: published / predicted (z before -> z after)", "",
              "Predicted by `" + best.name + "`; before, every ratio is 1. `*` = outside the library, "
              "`+` = explained, no mark = within the data's accuracy; sigma = standard deviation of ln r.", "",
              "| mode | " + " | ".join(CONFIG_LABELS[c] for c in CONFIGS) + " |",
              "|---|" + "---|" * len(CONFIGS)]
    mark = {OUTSIDE: "*", EXPLAINED: "+", WITHIN: ""}
    by = {(c.mode, c.config): c for c in d.cells}
    for i in range(1, N_MODES + 1):
        row = []
        for cfg in CONFIGS:
            c = by[(i, cfg)]
            row.append(f"{c.ratio_published:.2f} / {c.ratio_predicted:.2f}{mark[c.status]} "
                       f"({c.z_before:+.1f} -> {c.z_after:+.1f}; sigma {c.sigma_ln_ratio:.3f})")
        lines.append(f"| {i} | " + " | ".join(row) + " |")
    out = [c for c in d.cells if c.status == OUTSIDE]
    lines += ["", "## Not explained by the library: outside", ""]
    if out:
        lines += [f"- {CONFIG_LABELS[c.config]} mode {c.mode}: published {c.ratio_published:.2f}, predicted "
                  f"{c.ratio_predicted:.3f}, z = {c.z_after:+.1f}" for c in out]
    else:
        lines.append("- none")
    lines += ["", "## Notes", ""] + [f"- {n}" for n in d.notes] + ["", f"Computed in {d.wall_s:.1f} s."]
    return "\n".join(lines) + "\n"


#: Where :func:`main` writes the report.
DOC_PATH = Path(__file__).resolve().parents[3] / "docs" / "diagnose_bcc_table10.md"


def main(out_path: str | Path | None = None) -> Path:
    """Diagnose the published Table 10 and write the markdown report (``docs/diagnose_bcc_table10.md``).

    Parameters
    ----------
    out_path : str or Path, optional
        Where to write; default :data:`DOC_PATH`.

    Returns
    -------
    Path
        The file written.

    Raises
    ------
    DataFileError
        As :func:`diagnose_peak_ratios`.
    """
    d = diagnose_peak_ratios()
    path = Path(out_path) if out_path is not None else DOC_PATH
    head = ("---\norphan: true\n---\n\n# Diagnosis of the BCC's Table 10 peak level ratios\n\n"
            "Generated by `vlab.diagnose.fit.peakratios.to_markdown(diagnose_peak_ratios())` on "
            "`assets/data/table10_bcc_peak_ratios.csv`; regenerate with\n"
            "`python -c \"from vlab.diagnose.fit.peakratios import main; main()\"`. "
            "Method: the docstring of `vlab/diagnose/fit/peakratios.py`.\n\n")
    path.write_text(head + to_markdown(d))
    return path


if __name__ == "__main__":  # pragma: no cover
    print(main())
