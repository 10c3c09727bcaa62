"""Joint calibration of the BCC model's unknown parameters.

The dissertation gives the BCC's beam rigidity, dimensions and the crosspiece
rigidity (Sec. 2.1) but not the cable tension and length, coil, clamp or tip
masses. They are fitted jointly, within physically plausible bounds, to two
published data sets:

1. Table 1's analytical frequencies (the thesis's own FE model, six modes);
2. Table 8's MFDRF and LQDRF closed-loop damping ratios, obtained by applying
   the Table 7 gain matrices at points 5, 7, 9 with the Table 1 experimental
   open-loop damping (12 numbers).

Table 8 constrains the mode shapes at the actuators and the modal masses,
which Table 1 alone does not: low-tension parameter sets also match Table 1
but fail Table 8. Run ``python -m vlab.calibration bcc`` to repeat the fit and
print the values written into ``assets/structures/bcc.toml`` (marked
"calibrated").
"""

from __future__ import annotations

import sys
from dataclasses import dataclass

import numpy as np
import scipy.optimize

from .fe import FEModel, build_fe_model, modal_analysis
from .fe.damping import modal_damping_matrix, open_loop_ratios, structural_damping  # noqa: F401 (the first two: re-exported)
from .reference import bcc_gain, column
from .spec import StructureSpec, load_spec, with_quantity
from .units import G_SI, INCH_M, LBF_N

#: (path in the spec, lower bound, upper bound, unit factor to SI, unit name)
BCC_PARAMETERS: tuple[tuple[str, float, float, float, str], ...] = (
    ("strings.bottom_cables.tension", 20.0, 150.0, LBF_N, "lbf"),
    ("strings.bottom_cables.length", 20.0, 60.0, INCH_M, "in"),
    ("strings.top_cables.length", 20.0, 60.0, INCH_M, "in"),
    ("masses.coil.mass", 0.1, 1.0, LBF_N / G_SI, "lbf (weight)"),
    ("crosspieces.crosspiece.tip_mass", 0.05, 1.0, LBF_N / G_SI, "lbf (weight)"),
    ("crosspieces.crosspiece.clamp_mass", 0.05, 1.0, LBF_N / G_SI, "lbf (weight)"),
    ("masses.end_fitting1.mass", 0.01, 1.0, LBF_N / G_SI, "lbf (weight)"),
    ("masses.end_fitting9.mass", 0.01, 1.0, LBF_N / G_SI, "lbf (weight)"),
)

#: Starting points of the multi-start fit (thesis units, order of BCC_PARAMETERS).
_STARTS = (
    (71.0, 39.0, 39.0, 0.42, 0.14, 0.30, 0.10, 0.10),
    (60.0, 30.0, 45.0, 0.30, 0.30, 0.50, 0.30, 0.30),
    (90.0, 45.0, 30.0, 0.50, 0.20, 0.20, 0.05, 0.20),
)


def drf_damping_ratios(fe: FEModel, d: np.ndarray, n_modes: int) -> np.ndarray:
    """Closed-loop damping ratios of the first modes under direct rate feedback.

    ``m q'' + (c + U D U^T) q' + k q = 0`` with the spec's open-loop modal
    damping in ``c`` and ``U`` the forces at the spec's actuators (Eq. 4.30 with
    collocated velocity sensors). Eigenvalues are sorted by modulus (the
    undamped natural frequency of each closed-loop mode).

    Returns
    -------
    ndarray, shape (n_modes,)
    """
    acts = fe.spec.instrumentation.actuators
    c = structural_damping(fe)
    u = fe.force_input(acts)
    ct = c + u @ d @ u.T
    n = fe.n
    minv = np.linalg.inv(fe.m)
    a = np.block([[-minv @ ct, -minv @ fe.k], [np.eye(n), np.zeros((n, n))]])
    lam = np.linalg.eigvals(a)
    lam = lam[lam.imag > 1e-9]
    lam = lam[np.argsort(np.abs(lam))][:n_modes]
    return -lam.real / np.abs(lam)


def _apply(spec: StructureSpec, x: np.ndarray) -> StructureSpec:
    for (path, *_rest, scale, _u), v in zip(BCC_PARAMETERS, x):
        if path == "masses.coil.mass":
            for coil in ("coil5", "coil7", "coil9"):
                spec = with_quantity(spec, f"masses.{coil}.mass", v * scale)
        else:
            spec = with_quantity(spec, path, v * scale)
    return spec


@dataclass(frozen=True)
class BccFit:
    """Result of :func:`calibrate_bcc`: parameter values (thesis units) and the fit.

    Attributes
    ----------
    values : dict[str, float]
        Spec path (see :data:`BCC_PARAMETERS`) -> fitted value in thesis units
        (lbf, in, or lbf of weight for masses).
    frequencies_hz : ndarray, shape (6,)
        First six natural frequencies of the fitted model [Hz] (vs Table 1, analytical).
    damping_mfdrf : ndarray, shape (6,)
        Closed-loop damping ratios [-] with the Table 7 MFDRF gains (vs Table 8).
    damping_lqdrf : ndarray, shape (6,)
        Closed-loop damping ratios [-] with the Table 7 LQDRF gains (vs Table 8).
    on_bound : tuple of str
        Spec paths of the parameters that ended on a bound of the fit.
    """

    values: dict[str, float]
    frequencies_hz: np.ndarray
    damping_mfdrf: np.ndarray
    damping_lqdrf: np.ndarray
    on_bound: tuple[str, ...]


def bcc_residuals(fe: FEModel) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Relative errors against Table 1 (analytical) and Table 8 (MFDRF, LQDRF).

    Parameters
    ----------
    fe : FEModel
        An FE model of the BCC (the spec's actuators must be points 5, 7, 9,
        the order of Table 7).

    Returns
    -------
    freq_err : ndarray, shape (6,)
        ``f / f_Table1_analytical - 1``.
    zeta_mfdrf, zeta_lqdrf : ndarray, shape (6,)
        Closed-loop damping ratios with the Table 7 gains.
    zeta_err : ndarray, shape (12,)
        ``zeta / zeta_Table8 - 1`` for MFDRF then LQDRF.

    Raises
    ------
    DataFileError
        If a published table is missing or malformed.
    """
    f_ref = column("table1_bcc_frequencies.csv", "analytical_hz")
    z_mf = column("table8_bcc_damping.csv", "mfdrf")
    z_lq = column("table8_bcc_damping.csv", "lqdrf")
    f = modal_analysis(fe.m, fe.k, 6).frequencies_hz
    zm = drf_damping_ratios(fe, bcc_gain("mfdrf"), 6)
    zl = drf_damping_ratios(fe, bcc_gain("lqdrf"), 6)
    return f / f_ref - 1.0, zm, zl, np.concatenate([zm / z_mf - 1.0, zl / z_lq - 1.0])


def calibrate_bcc(spec: StructureSpec | None = None, *, weight_damping: float = 0.05) -> BccFit:
    """Fit the BCC's unknown parameters to Tables 1 and 8 (bounded least squares).

    Residuals: frequency errors relative to Table 1 (analytical) and, weighted
    by ``weight_damping``, damping-ratio errors relative to Table 8.

    Parameters
    ----------
    spec : StructureSpec, optional
        The BCC spec to start from (default: the shipped ``bcc.toml``); the
        parameters of :data:`BCC_PARAMETERS` are replaced in it.
    weight_damping : float
        Weight [-] of the 12 relative damping errors against the 6 relative
        frequency errors.

    Returns
    -------
    BccFit

    Source: Sec. 2.1; Tables 1, 7, 8.
    """
    spec = spec or load_spec("bcc")
    lo = np.array([p[1] for p in BCC_PARAMETERS])
    hi = np.array([p[2] for p in BCC_PARAMETERS])

    def resid(x: np.ndarray) -> np.ndarray:
        ef, _, _, ez = bcc_residuals(build_fe_model(_apply(spec, x)))
        return np.concatenate([ef, weight_damping * ez])

    sol = min(
        (scipy.optimize.least_squares(resid, np.array(x0), bounds=(lo, hi), x_scale=(hi - lo) / 10)
         for x0 in _STARTS),
        key=lambda s: s.cost,
    )
    fe = build_fe_model(_apply(spec, sol.x))
    ef, zm, zl, _ = bcc_residuals(fe)
    f = modal_analysis(fe.m, fe.k, 6).frequencies_hz
    on_bound = tuple(
        p[0] for p, v in zip(BCC_PARAMETERS, sol.x) if min(v - p[1], p[2] - v) < 1e-3 * (p[2] - p[1])
    )
    return BccFit({p[0]: float(v) for p, v in zip(BCC_PARAMETERS, sol.x)}, f, zm, zl, on_bound)


def main(argv: list[str] | None = None) -> int:
    """``python -m vlab.calibration bcc``: fit and print the values and the fit.

    Parameters
    ----------
    argv : list of str, optional
        Command-line arguments without the program name (default
        ``sys.argv[1:]``); must be ``["bcc"]``.

    Returns
    -------
    int
        Exit status: 0 on success, 2 (usage printed to stderr) for other arguments.
    """
    argv = sys.argv[1:] if argv is None else argv
    if argv != ["bcc"]:
        print("usage: python -m vlab.calibration bcc", file=sys.stderr)
        return 2
    fit = calibrate_bcc()
    for (path, _lo, _hi, _s, unit), v in zip(BCC_PARAMETERS, fit.values.values()):
        print(f"{path:40s} {v:10.4f} {unit}")
    f_ref = column("table1_bcc_frequencies.csv", "analytical_hz")
    print("mode  f_Hz   Table1  err%   zeta_MF  Table8  zeta_LQ  Table8")
    z_mf = column("table8_bcc_damping.csv", "mfdrf")
    z_lq = column("table8_bcc_damping.csv", "lqdrf")
    for i in range(6):
        print(
            f"{i + 1:4d} {fit.frequencies_hz[i]:6.3f} {f_ref[i]:6.3f} {100 * (fit.frequencies_hz[i] / f_ref[i] - 1):+5.2f}"
            f"   {fit.damping_mfdrf[i]:.4f}  {z_mf[i]:.4f}  {fit.damping_lqdrf[i]:.4f}  {z_lq[i]:.4f}"
        )
    print("parameters on a bound:", list(fit.on_bound) or "none")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
