"""The analysis side of the Table 10 diagnosis (:mod:`vlab.reproduce.peakratios`).

The dissertation's analysis of the Beam Cross-Cable's peak levels: the continuous closed loop on the full
BCC model (Sec. 6.1) with Table 1's open-loop damping as proportional modal damping (Sec. 2.1.2), the
Table 7 gains for MFDRF and LQDRF, vlab's LQG design for LQG; each configuration's FRF in pole-residue
form, its peaks, how a peak read on a frequency grid falls short of it, and the sensitivities of every
peak to the open-loop damping that the published rounding of Table 1 leaves uncertain. The method is
described in :mod:`vlab.reproduce.peakratios`.

Source: Tables 1, 7, 8 and 10; Sec. 2.1.2, Sec. 5.4.2, Sec. 6.1.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np
from scipy import optimize
from scipy.interpolate import CubicSpline

from ..analysis import closed_loop_modes
from ..fe.damping import modal_damping_matrix, open_loop_ratios
from ..design import design_controller
from ..diagnose.model.modelform import printed_resolution
from ..errors import DataFileError, ModelError
from ..fe import build_fe_model, modal_analysis
from ..reference import bcc_gain
from ..spec import DATA_DIR, load_spec

#: Loop configurations, in Table 10's column order (column names of the CSV).
CONFIGS = ("open_loop", "mfdrf", "lqdrf", "lqg")
#: Number of modes of Table 10.
N_MODES = 6
#: Response point of the test (Sec. 5.4.2: displacement at grid point 6, force at point 9).
RESPONSE_POINT = 6
#: Searched range of the grid spacing [Hz]: from a spacing at which no peak is missed to 0.5 Hz, beyond
#: which the grid would not resolve modes 3 and 4 (0.69 Hz apart) as the separate peaks of Fig. 22.
SPACING_RANGE_HZ = (0.001, 0.5)
#: Searched range of the structure's damping relative to the analysis' [-].
DAMPING_FACTOR_RANGE = (0.1, 10.0)
_OFFSET_STEP_HZ = 2.5e-5      # resolution of the tabulated FRF around each peak


# --------------------------------------------------------------------------- FRF in pole-residue form
@dataclass(frozen=True)
class PoleResidueFRF:
    """A scalar FRF ``H(f) = sum_k r_k / (j 2 pi f - p_k)`` (no direct term).

    Attributes
    ----------
    poles_rad_s : ndarray, complex, shape (n_p,)
        Poles ``p_k`` [rad/s].
    residues : ndarray, complex, shape (n_p,)
        Residues ``r_k`` [FRF unit * rad/s] (displacement per force here: m/N * rad/s).
    """

    poles_rad_s: np.ndarray
    residues: np.ndarray

    def __call__(self, freq_hz) -> np.ndarray:
        """``H`` at ``freq_hz`` (any shape) [FRF unit]; complex, same shape as ``freq_hz``.

        Parameters
        ----------
        freq_hz : array_like
            Frequencies [Hz].
        """
        s = 2j * np.pi * np.asarray(freq_hz, dtype=float)[..., None]
        return (self.residues / (s - self.poles_rad_s)).sum(-1)

    def level(self, freq_hz) -> np.ndarray:
        """``|H|`` at ``freq_hz`` [FRF unit], same shape as ``freq_hz``.

        Parameters
        ----------
        freq_hz : array_like
            Frequencies [Hz].
        """
        return np.abs(self(freq_hz))


def state_space_frf(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> PoleResidueFRF:
    """Pole-residue form of the SISO system ``x' = a x + b u``, ``y = c x``.

    Parameters
    ----------
    a : ndarray, shape (n, n)
        State matrix [1/s] (diagonalisable).
    b : ndarray, shape (n,) or (n, 1)
        Input vector.
    c : ndarray, shape (n,) or (1, n)
        Output vector.

    Returns
    -------
    PoleResidueFRF
        ``H(s) = c (sI - a)^-1 b`` as ``sum_k r_k / (s - p_k)``.

    Raises
    ------
    ModelError
        If the eigenvector matrix of ``a`` is singular (defective ``a``).
    """
    lam, v = np.linalg.eig(np.asarray(a, dtype=float))
    try:
        vb = np.linalg.solve(v, np.asarray(b, dtype=float).reshape(-1))
    except np.linalg.LinAlgError:
        raise ModelError("state_space_frf: the state matrix is defective (no eigenvector basis)") from None
    r = (np.asarray(c, dtype=float).reshape(-1) @ v) * vb
    return PoleResidueFRF(lam, r)


def grid_reading_ratio(frf: PoleResidueFRF, resonance_hz: float, spacing_hz: float, origin_hz: float = 0.0) -> float:
    """Peak level read on a frequency grid, relative to the level at the resonance.

    The grid is ``f_n = origin_hz + n spacing_hz``; the peak is read at the grid
    point nearest ``resonance_hz``. For a single mode of damping ``zeta`` at
    ``f0`` and a distance ``delta`` to the grid this is
    ``~ 1 / sqrt(1 + (delta / (zeta f0))^2)`` (Sec. 6.1's explanation of Table 10).

    Parameters
    ----------
    frf : PoleResidueFRF
        The analysis FRF.
    resonance_hz : float
        Frequency of the peak [Hz].
    spacing_hz : float
        Grid spacing Delta [Hz], > 0.
    origin_hz : float
        A grid point [Hz].

    Returns
    -------
    float
        ``|H(f_grid)| / |H(resonance_hz)|`` [-].

    Raises
    ------
    ModelError
        If ``spacing_hz`` is not a positive finite number.
    """
    if not (np.isfinite(spacing_hz) and spacing_hz > 0):
        raise ModelError(f"grid_reading_ratio: spacing_hz must be positive, got {spacing_hz!r}")
    g = origin_hz + np.round((resonance_hz - origin_hz) / spacing_hz) * spacing_hz
    return float(frf.level(g) / frf.level(resonance_hz))


def find_peaks(frf: PoleResidueFRF, natural_hz: np.ndarray, lower_hz: float = 0.05
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each mode's peak of ``|H|``: the highest local maximum in the mode's frequency cell.

    The cell of mode ``i`` runs between the midpoints to the neighbouring
    natural frequencies (the first from ``lower_hz``, the last to half a
    spacing above it). Its maximum is located on 2001 points and refined by
    a bounded scalar search. A cell without a local maximum (a heavily
    damped or masked mode) gives the natural frequency and the level there.

    Parameters
    ----------
    frf : PoleResidueFRF
        The FRF.
    natural_hz : ndarray, shape (n_m,)
        Natural frequencies of the modes [Hz] (any order).
    lower_hz : float
        Lower end of the lowest cell [Hz].

    Returns
    -------
    peak_hz : ndarray, shape (n_m,)
        Frequency of each peak [Hz].
    level : ndarray, shape (n_m,)
        ``|H|`` there [FRF unit].
    has_peak : ndarray of bool, shape (n_m,)
        Whether the cell has a local maximum.
    """
    f = np.asarray(natural_hz, dtype=float)
    order = np.argsort(f)
    fs = f[order]
    top = fs[-1] + (0.5 * (fs[-1] - fs[-2]) if len(fs) > 1 else fs[-1])
    edges = np.concatenate([[lower_hz], 0.5 * (fs[1:] + fs[:-1]), [top]])
    peak, level, has = np.empty_like(f), np.empty_like(f), np.zeros(len(f), dtype=bool)
    for pos, i in enumerate(order):
        grid = np.linspace(edges[pos], edges[pos + 1], 2001)
        a = frf.level(grid)
        inner = np.flatnonzero((a[1:-1] > a[:-2]) & (a[1:-1] >= a[2:])) + 1
        if len(inner) == 0:
            peak[i], level[i] = f[i], float(frf.level(f[i]))
            continue
        j = inner[np.argmax(a[inner])]
        res = optimize.minimize_scalar(lambda x: -float(frf.level(x)), bounds=(grid[j - 1], grid[j + 1]),
                                       method="bounded", options={"xatol": 1e-8})
        peak[i], level[i], has[i] = float(res.x), -float(res.fun), True
    return peak, level, has


# --------------------------------------------------------------------------- the analysis side
@dataclass(frozen=True)
class LoopPeaks:
    """One loop configuration's FRF (force at point 9, displacement at point 6) and its peaks.

    Attributes
    ----------
    config : str
        One of :data:`CONFIGS`.
    frf : PoleResidueFRF
        Closed-loop displacement FRF [m/N].
    natural_hz, zeta : ndarray, shape (6,)
        Closed-loop natural frequency [Hz] and damping ratio [-] of each plant mode.
    peak_hz : ndarray, shape (6,)
        Frequency of each mode's peak [Hz] (:func:`find_peaks`).
    peak_m_per_n : ndarray, shape (6,)
        Peak level [m/N].
    has_peak : ndarray of bool, shape (6,)
        Whether the FRF has a local maximum for the mode.
    """

    config: str
    frf: PoleResidueFRF
    natural_hz: np.ndarray
    zeta: np.ndarray
    peak_hz: np.ndarray
    peak_m_per_n: np.ndarray
    has_peak: np.ndarray


def read_csv_rows(path: Path) -> tuple[list[str], list[list[str]]]:
    """Header and body rows (strings, stripped) of a ``#``-commented CSV.

    Parameters
    ----------
    path : Path
        The file.

    Returns
    -------
    (list of str, list of list of str)
        The header's column names and the rows.

    Raises
    ------
    DataFileError
        The file cannot be read or has no header line (names the file).
    """
    try:
        text = path.read_text()
    except OSError as exc:
        raise DataFileError(f"{path}: cannot be read ({exc})") from None
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        raise DataFileError(f"{path}: no header line")
    rows = list(csv.reader(lines))
    return [h.strip() for h in rows[0]], [[v.strip() for v in r] for r in rows[1:]]


def half_unit(text: str) -> float:
    """Half a unit of the last printed digit of ``text`` (0.005 for "0.55", 0.0005 for "0.004"): half of
    :func:`vlab.diagnose.model.modelform.printed_resolution`.

    Raises
    ------
    ValueError
        ``text`` is not a decimal number.
    """
    res = printed_resolution(text)
    if not np.isfinite(res):
        raise ValueError(f"not a decimal number: {text!r}")
    return 0.5 * res


def _shifted_stiffness(m: np.ndarray, k: np.ndarray, f_target_hz: np.ndarray) -> np.ndarray:
    """``k + m Phi diag(w_t^2 - w^2) Phi^T m``: first modes moved to ``f_target_hz``, shapes kept."""
    md = modal_analysis(m, k)
    n = len(f_target_hz)
    mphi = m @ md.shapes[:, :n]
    ks = k + mphi @ np.diag((2 * np.pi * np.asarray(f_target_hz)) ** 2 - md.omega[:n] ** 2) @ mphi.T
    return 0.5 * (ks + ks.T)


@dataclass(frozen=True, eq=False)
class PeakRatioAnalysis:
    """The analysis side of Table 10 and every candidate's table-independent predictions.

    Attributes
    ----------
    structure : str
    f_analysis_hz, f_experimental_hz : ndarray, shape (6,)
        Table 1 analytical and experimental natural frequencies [Hz].
    zeta_open_loop : ndarray, shape (6,)
        Table 1 experimental damping ratios [-] (the analysis' open-loop damping).
    zeta_half_unit : ndarray, shape (6,)
        Half a unit of their last printed digit [-].
    loops : tuple of LoopPeaks, length 4
        The analysis FRF of each configuration (:data:`CONFIGS` order).
    sensitivity : ndarray, shape (6, 4, 6)
        ``d ln P[mode, config] / d ln zeta_open_loop[j]`` [-].
    offsets_hz : ndarray, shape (n_d,)
        Offsets from each peak at which the log level is tabulated [Hz].
    log_level_offset : ndarray, shape (6, 4, n_d)
        ``ln |H(f_peak + offset)| - ln |H(f_peak)|`` [-] (zeros for a mode without peak).
    log_damping_factor : ndarray, shape (n_u,)
        ``ln`` of the structure's damping factor at which ``log_ratio_damping`` is tabulated.
    log_ratio_damping : ndarray, shape (n_u, 6, 4)
        Predicted ``ln`` ratio of the damping candidate [-].
    log_ratio_frequency_offset, log_ratio_frequency_error : ndarray, shape (6, 4)
        Predicted ``ln`` ratios of the zero-parameter frequency candidates [-].
    table8_zeta : ndarray, shape (6, 3)
        Table 8's analytical closed-loop damping (MFDRF, LQDRF, LQG) [-], for comparison.
    """

    structure: str
    f_analysis_hz: np.ndarray
    f_experimental_hz: np.ndarray
    zeta_open_loop: np.ndarray
    zeta_half_unit: np.ndarray
    loops: tuple
    sensitivity: np.ndarray
    offsets_hz: np.ndarray
    log_level_offset: np.ndarray
    log_damping_factor: np.ndarray
    log_ratio_damping: np.ndarray
    log_ratio_frequency_offset: np.ndarray
    log_ratio_frequency_error: np.ndarray
    table8_zeta: np.ndarray

    @property
    def peak_hz(self) -> np.ndarray:
        """Peak frequencies, shape (6, 4) [Hz]."""
        return np.array([lp.peak_hz for lp in self.loops]).T

    @property
    def has_peak(self) -> np.ndarray:
        """Whether each cell's analysis FRF has a peak, shape (6, 4)."""
        return np.array([lp.has_peak for lp in self.loops]).T

    @property
    def sigma_damping_log(self) -> np.ndarray:
        """Standard deviation of ``ln r`` from Table 1's damping rounding, shape (6, 4) (module docstring, 2.)."""
        z, h = self.zeta_open_loop, self.zeta_half_unit
        s_lnz = np.log((z + h) / (z - h)) / np.sqrt(12.0)
        return np.sqrt(np.einsum("mcj,j->mc", self.sensitivity ** 2, s_lnz ** 2))

    def spacing_log_ratios(self, spacing_hz: float, origin_hz: float = 0.0) -> np.ndarray:
        """``ln`` ratios of the ``spacing-grid`` candidate, shape (6, 4).

        Parameters
        ----------
        spacing_hz : float
            Grid spacing [Hz], within :data:`SPACING_RANGE_HZ`.
        origin_hz : float
            A grid point [Hz].

        Returns
        -------
        ndarray, shape (6, 4)
            ``ln(|H(f_grid)| / |H(f_peak)|)`` (0 for a mode without peak).
        """
        pk = self.peak_hz
        x = (pk - origin_hz) / spacing_hz
        return self._lookup(((np.round(x) - x) * spacing_hz)[None])[0]

    def _lookup(self, offsets: np.ndarray) -> np.ndarray:
        """Tabulated log levels at ``offsets`` [Hz], shape (n, 6, 4) -> (n, 6, 4) (linear interpolation)."""
        d0, h = self.offsets_hz[0], self.offsets_hz[1] - self.offsets_hz[0]
        x = np.clip((offsets - d0) / h, 0, len(self.offsets_hz) - 1.000001)
        i = x.astype(np.int64)
        w = x - i
        t = self.log_level_offset
        mi, ci = np.meshgrid(np.arange(N_MODES), np.arange(len(CONFIGS)), indexing="ij")
        return t[mi, ci, i] * (1 - w) + t[mi, ci, i + 1] * w

    def damping_log_ratios(self, factor: float) -> np.ndarray:
        """``ln`` ratios of the ``damping`` candidate, shape (6, 4), from the tabulated factors (cubic spline).

        Parameters
        ----------
        factor : float
            The structure's open-loop damping / the analysis' [-], within :data:`DAMPING_FACTOR_RANGE`.

        Returns
        -------
        ndarray, shape (6, 4)
        """
        return damping_spline(self)(np.log(factor))


def _loop_state_space(m, c, k, u, out_row, controller, exc):
    """Closed loop ``(A, b, c)`` from the force added to actuator channel ``exc`` to the displacement at ``out_row``."""
    n = m.shape[0]
    minv = np.linalg.inv(m)
    a = np.block([[-minv @ c, -minv @ k], [np.eye(n), np.zeros((n, n))]])
    b = np.vstack([minv @ u, np.zeros_like(u)])
    cv = np.hstack([u.T, np.zeros_like(u.T)])
    cd = np.zeros(2 * n)
    cd[n + out_row] = 1.0
    be = b[:, exc]
    if controller is None:
        return a, be, cd
    if "d" in controller:
        return a - b @ controller["d"] @ cv, be, cd
    ac, bc, cc = controller["a"], controller["b"], controller["c"]
    acl = np.block([[a, -b @ cc], [bc @ cv, ac]])
    nc = ac.shape[0]
    return acl, np.concatenate([be, np.zeros(nc)]), np.concatenate([cd, np.zeros(nc)])


def _loops(m, c, k, u, out_row, controllers: dict, exc: int) -> tuple:
    out = []
    for name in CONFIGS:
        ctrl = controllers[name]
        frf = state_space_frf(*_loop_state_space(m, c, k, u, out_row, ctrl, exc))
        fn, zn = closed_loop_modes(m, c, k, u, u.T, ctrl)
        fn, zn = fn[:N_MODES], zn[:N_MODES]
        pk, lv, has = find_peaks(frf, fn)
        out.append(LoopPeaks(name, frf, fn, zn, pk, lv, has))
    return tuple(out)


def _log_peaks(loops: tuple) -> np.ndarray:
    return np.log(np.array([lp.peak_m_per_n for lp in loops]).T)


@lru_cache(maxsize=4)
def analysis_side(structure: str = "bcc") -> PeakRatioAnalysis:
    """Build (once, cached) the analysis side of Table 10 and the table-independent predictions.

    Parameters
    ----------
    structure : str
        ``"bcc"`` (Table 10 is the Beam Cross-Cable's).

    Returns
    -------
    PeakRatioAnalysis

    Raises
    ------
    ModelError
        For a structure other than the BCC.
    DataFileError, SpecError
        If a reference table or the structure file is missing or malformed.
    controllers.errors.ControllerError
        If the LQG design fails.

    Source: Sec. 6.1 (full model, Table 7 gains, LQG), Tables 1, 7, 8.
    """
    if structure != "bcc":
        raise ModelError(f"Table 10 is the BCC's peak level ratios: structure must be 'bcc', got {structure!r}")
    fe = build_fe_model(load_spec(structure))
    hdr, rows = read_csv_rows(DATA_DIR / fe.spec.reference["frequencies"])
    col = {h: [r[i] for r in rows] for i, h in enumerate(hdr)}
    f_ana = np.array([float(v) for v in col["analytical_hz"][:N_MODES]])
    f_exp = np.array([float(v) for v in col["experimental_hz"][:N_MODES]])
    zeta = np.array([float(v) for v in col["damping_experimental"][:N_MODES]])
    zeta_h = np.array([half_unit(v) for v in col["damping_experimental"][:N_MODES]])
    acts = tuple(fe.spec.instrumentation.actuators)
    u = fe.force_input(acts)
    out_row = fe.dofs.index(RESPONSE_POINT, "w")
    exc = acts.index(fe.spec.instrumentation.excitation)
    perm = [(5, 7, 9).index(p) for p in acts]  # Table 7 order (5, 7, 9) -> actuator order
    controllers = {"open_loop": None,
                   "mfdrf": {"d": bcc_gain("mfdrf")[np.ix_(perm, perm)]},
                   "lqdrf": {"d": bcc_gain("lqdrf")[np.ix_(perm, perm)]},
                   "lqg": design_controller(fe, "lqg").continuous}
    m = np.asarray(fe.m)
    k_ana = _shifted_stiffness(m, np.asarray(fe.k), f_ana)
    ratios = open_loop_ratios(fe.spec, fe.n)
    ratios[:N_MODES] = zeta

    def loops_with(k, z):
        return _loops(m, modal_damping_matrix(m, k, z), k, u, out_row, controllers, exc)

    loops = loops_with(k_ana, ratios)
    logp = _log_peaks(loops)
    # sensitivity of every peak to every mode's open-loop damping (central differences in ln zeta)
    eps = 0.02
    sens = np.zeros((N_MODES, len(CONFIGS), N_MODES))
    for j in range(N_MODES):
        zp, zm = ratios.copy(), ratios.copy()
        zp[j] *= np.exp(eps)
        zm[j] *= np.exp(-eps)
        sens[:, :, j] = (_log_peaks(loops_with(k_ana, zp)) - _log_peaks(loops_with(k_ana, zm))) / (2 * eps)
    # tabulated log levels around each peak
    half = 0.5 * SPACING_RANGE_HZ[1] + 4 * _OFFSET_STEP_HZ
    offs = np.arange(-half, half + _OFFSET_STEP_HZ / 2, _OFFSET_STEP_HZ)
    table = np.zeros((N_MODES, len(CONFIGS), len(offs)))
    for c, lp in enumerate(loops):
        for i in range(N_MODES):
            if lp.has_peak[i]:
                table[i, c] = np.log(lp.frf.level(lp.peak_hz[i] + offs)) - np.log(lp.peak_m_per_n[i])
    # damping candidate: the structure's open-loop damping = factor * the analysis'
    u_grid = np.linspace(np.log(DAMPING_FACTOR_RANGE[0]), np.log(DAMPING_FACTOR_RANGE[1]), 47)
    damp = np.array([logp - _log_peaks(loops_with(k_ana, ratios * np.exp(uu))) for uu in u_grid])
    # frequency candidates
    d_exp = f_exp - f_ana
    off = np.zeros((N_MODES, len(CONFIGS)))
    for c, lp in enumerate(loops):
        read = lp.frf.level(lp.peak_hz + d_exp)
        off[:, c] = np.where(lp.has_peak, np.log(read) - np.log(lp.peak_m_per_n), 0.0)
    k_exp = _shifted_stiffness(m, np.asarray(fe.k), f_exp)
    ferr = logp - _log_peaks(loops_with(k_exp, ratios))
    hdr8, rows8 = read_csv_rows(DATA_DIR / "table8_bcc_damping.csv")
    t8 = np.array([[float(r[hdr8.index(cn)]) for cn in ("mfdrf", "lqdrf", "lqg")] for r in rows8[:N_MODES]])
    return PeakRatioAnalysis(structure, f_ana, f_exp, zeta, zeta_h, loops, sens, offs, table, u_grid, damp,
                             off, ferr, t8)


@lru_cache(maxsize=4)
def damping_spline(an: PeakRatioAnalysis):
    """``u -> ln r`` of every cell, shape ``np.shape(u) + (6, 4)``, for ``u = ln(damping factor)``: a cubic
    spline through the analysis' tabulated damping candidate (:class:`PeakRatioAnalysis`)."""
    spl = CubicSpline(an.log_damping_factor, an.log_ratio_damping.reshape(len(an.log_damping_factor), -1))
    return lambda uu: spl(uu).reshape(np.shape(uu) + (N_MODES, len(CONFIGS)))
