"""The published peak-ratio table of the Table 10 diagnosis and the diagnosis's result types.

A peak-ratio table lists, per mode (1-6) and loop configuration (open loop, MFDRF, LQDRF, LQG), the
ratio *analytical / experimental* of a displacement-FRF peak level, printed to a few decimals: half a
unit of a value's last printed digit bounds its printing error. The results of the diagnosis are
profile-likelihood confidence sets of the fitted parameters, one fit per candidate explanation, the
outcome of every cell before and after the selected explanation, and the diagnosis itself. The method
is described in :mod:`vlab.reproduce.peakratios`.

Source: Table 10 (and Table 2, its open-loop column).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import DataFileError
from ..spec import DATA_DIR
from .peakanalysis import CONFIGS, N_MODES, half_unit, read_csv_rows

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


# --------------------------------------------------------------------------- text
def cell_names(mask: np.ndarray) -> str:
    """The cells marked in ``mask`` in words, per configuration (e.g. ``"open loop modes 1, 2; LQG mode 4"``).

    Parameters
    ----------
    mask : ndarray of bool, shape (6, 4)
        Cells per mode and configuration (:data:`CONFIGS`).

    Returns
    -------
    str
    """
    parts = []
    for c, cfg in enumerate(CONFIGS):
        modes = [str(i + 1) for i in range(N_MODES) if mask[i, c]]
        if modes:
            parts.append(f"{CONFIG_LABELS[cfg]} mode{'s' if len(modes) > 1 else ''} {', '.join(modes)}")
    return "; ".join(parts)


def param_text(c: CandidateFit) -> str:
    """A candidate's fitted parameters with their 95 % sets, e.g. ``"spacing_hz = 0.0625 (95 % CI ...)"``.

    Parameters
    ----------
    c : CandidateFit
        A fitted candidate.

    Returns
    -------
    str
        Empty for a candidate without parameters.
    """
    return ", ".join(f"{p.name} = {p.value:.4g} (95 % CI {p.ci.describe()})" for p in c.parameters)
