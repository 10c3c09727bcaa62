"""Mode shapes identified from the FRFs of one excitation point, and their correlation with a model's.

A test with one excitation point ``k`` measures one column ``H_jk(omega)`` of the FRF matrix. Written as
receptance [m/N] in partial fractions over the modes ``r`` with poles ``lambda_r = -sigma_r + i omega_dr``::

    H_jk(omega) = sum_r ( R_jkr / (i omega - lambda_r) + conj(R_jkr) / (i omega - conj(lambda_r)) )

and for viscous proportional damping with mass-normalised shapes ``phi_r`` the modal constant
``A_jkr = 2 i omega_dr R_jkr = phi_jr phi_kr`` [1/kg] is real: the column of residues of one mode over
the response points ``j`` is its shape, scaled by ``phi_kr``, and the driving-point constant
``A_kkr = phi_kr^2`` gives the scale: ``phi_jr = A_jkr / sqrt(A_kkr)`` [1/sqrt(kg)].

:func:`identify_shapes` does this in two steps, as the global-pole, local-residue methods do:

1. the poles: each response point's FRF is curve-fitted near the expected modes
   (:func:`vlab.measure.modal_fit.fit_each_mode`); each mode takes the pole of the FRF whose measured
   magnitude peaks highest in the mode's band (the best signal-to-noise ratio);
2. the residues: with the poles fixed, each FRF is a linear least-squares fit in the residues (LSFD,
   least-squares frequency domain) over the bands around the modes, modes whose bands overlap fitted
   together, with the real residual terms ``s^-2, s^-1, 1, s`` (``s = i omega``) for the modes outside
   the band.

A measured mode is complex when the damping is not proportional (a closed loop; noise): the column of
constants is turned by the angle that makes it most nearly real (``theta = arg(sum_j A_j^2) / 2``) and its
real part kept; the modal phase collinearity ``MPC = |sum_j A_j^2|^2 / (sum_j |A_j|^2)^2`` (1 for a real
mode, 0 for a travelling one) says how much was dropped.

Sources: Ewins, *Modal Testing: Theory, Practice and Application*, 2nd ed. (2000), Ch. 2 (the modal
constants of a column of the FRF matrix, ``A_jkr = phi_jr phi_kr``), Ch. 4 (modal parameter extraction)
and Sec. 8.2 (MAC); Peeters,
Van der Auweraer, Guillaume & Leuridan, Shock and Vibration 11 (2004) 395-409, Sec. 3 (LSFD: residues by
linear least squares with the poles fixed, residual terms); Pappa, Elliott & Schenk, J. Guidance Control
Dyn. 16 (1993) 852-858 (modal phase collinearity, here in its uncentred form).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import MeasurementError
from ..fe.point_shapes import normalise_shapes
from .mac import mac, pair_modes
from .modal_fit import band_lines, fit_each_mode, fit_half_bands, overlapping_bands

#: How a shape is identified, as written in results.
SHAPE_METHOD = ("modal constants A_jk = 2 i omega_d R_jk of the receptance's residues, by least squares with "
                "the poles fixed (LSFD); poles from a rational-fraction fit of each point's FRF")


@dataclass(frozen=True)
class IdentifiedShapes:
    """Mode shapes identified from the FRFs of one excitation point (:func:`identify_shapes`).

    Attributes
    ----------
    point_ids : tuple of int, length n_points
        Response points, in row order.
    reference_point : int
        The excitation (driving) point ``k``.
    modes : tuple of int, length n_modes
        1-based index into the expected modes of each identified mode (a mode not found at any point is
        left out).
    freq_hz : ndarray, shape (n_modes,)
        Undamped natural frequency ``|lambda| / 2 pi`` [Hz].
    damping_ratio : ndarray, shape (n_modes,)
        ``-Re(lambda) / |lambda|`` [-].
    pole_rad_s : ndarray, complex, shape (n_modes,)
        Pole ``lambda`` [rad/s], ``Im > 0``.
    modal_constants_per_kg : ndarray, complex, shape (n_points, n_modes)
        ``A_jkr = 2 i omega_dr R_jkr`` [1/kg] (``= phi_jr phi_kr`` for mass-normalised real modes).
    shapes : ndarray, shape (n_points, n_modes)
        Real shapes, largest entry +1 per mode [-].
    shapes_mass_normalised : ndarray, shape (n_points, n_modes)
        ``A_jkr / sqrt(A_kkr)`` [1/sqrt(kg)] with the sign of ``shapes``; NaN when the driving point is not
        among the response points or its constant is not positive.
    mpc : ndarray, shape (n_modes,)
        Modal phase collinearity [-] of each column of constants (1 = real mode).
    method : str
        :data:`SHAPE_METHOD`.
    """

    point_ids: tuple[int, ...]
    reference_point: int
    modes: tuple[int, ...]
    freq_hz: np.ndarray
    damping_ratio: np.ndarray
    pole_rad_s: np.ndarray
    modal_constants_per_kg: np.ndarray
    shapes: np.ndarray
    shapes_mass_normalised: np.ndarray
    mpc: np.ndarray
    method: str = SHAPE_METHOD


def _receptance(freq_hz: np.ndarray, frfs: np.ndarray, response: str) -> np.ndarray:
    """The FRFs as receptance [m/N], shape (n_points, n_f): mobility / (i omega), accelerance / (i omega)^2."""
    iw = 2j * np.pi * freq_hz
    powers = {"displacement": 0, "velocity": 1, "acceleration": 2}
    if response not in powers:
        raise MeasurementError(f"unknown response {response!r}; use one of {sorted(powers)}")
    return frfs / iw ** powers[response]


def _poles(f, hx, modes_hz, halves, weights, names) -> list[complex | None]:
    """Each expected mode's pole [rad/s] from the fit of the point whose measured ``|H|`` peaks highest
    within the mode's band; a fit with a non-negative real part or a frequency outside the band is
    not used."""
    best: list[tuple[float, complex] | None] = [None] * len(modes_hz)
    for j in range(hx.shape[0]):
        w = None if weights is None else weights[j]
        fits = fit_each_mode(f, hx[j], modes_hz, halves, response="displacement", weights=w, name=names[j])
        for r, fit in enumerate(fits):
            if fit is None or not (fit.pole.real < 0) or abs(fit.freq_hz - modes_hz[r]) > halves[r]:
                continue
            near = np.abs(f - fit.freq_hz) <= halves[r]
            height = float(np.max(np.abs(hx[j][near]))) if near.any() else 0.0
            if best[r] is None or height > best[r][0]:
                best[r] = (height, fit.pole)
    return [None if b is None else b[1] for b in best]


def lsfd_residues(freq_hz, hx, poles_rad_s, *, weights=None) -> np.ndarray:
    """Residues of receptance FRFs at fixed poles by linear least squares (LSFD), with residual terms.

    Model of each FRF ``j`` on the lines given::

        H_j(omega) = sum_r ( R_jr / (s - lambda_r) + conj(R_jr) / (s - conj(lambda_r)) )
                     + a_j / s^2 + b_j / s + c_j + d_j s,        s = i omega

    with real ``a_j .. d_j`` (the modes outside the lines, lower and upper residuals).

    Parameters
    ----------
    freq_hz : array_like, shape (n_f,)
        Frequency lines [Hz], > 0, at least ``n_modes + 2``.
    hx : array_like, complex, shape (n_points, n_f)
        Receptance FRFs [m/N] (any FRF unit gives residues in that unit x rad/s).
    poles_rad_s : array_like, complex, shape (n_modes,)
        The poles ``lambda_r`` [rad/s], ``Im > 0``.
    weights : array_like, shape (n_points, n_f), optional
        Non-negative weights per point and line (e.g. the coherence); uniform by default.

    Returns
    -------
    ndarray, complex, shape (n_points, n_modes)
        ``R_jr`` [m/N x rad/s = m/(N s)].

    Raises
    ------
    MeasurementError
        Mismatched shapes, non-positive or too few lines, a pole with ``Im <= 0``, non-finite values.

    Source: Peeters et al., Shock and Vibration 11 (2004) 395-409, Sec. 3 (LSFD).
    """
    f = np.asarray(freq_hz, dtype=float)
    h = np.atleast_2d(np.asarray(hx, dtype=complex))
    lam = np.atleast_1d(np.asarray(poles_rad_s, dtype=complex))
    n = lam.size
    if f.ndim != 1 or h.shape[1] != f.size or np.any(f <= 0) or f.size < n + 2:
        raise MeasurementError(f"lsfd_residues: need {n + 2} or more positive lines matching the FRFs "
                               f"(shape {h.shape}), got {f.size}")
    if np.any(lam.imag <= 0) or not (np.all(np.isfinite(h)) and np.all(np.isfinite(lam))):
        raise MeasurementError("lsfd_residues: poles need Im > 0 and every value finite")
    w = np.ones(h.shape) if weights is None else np.broadcast_to(np.asarray(weights, dtype=float), h.shape)
    s = 2j * np.pi * f
    w0 = float(np.mean(2 * np.pi * f))
    cols = [1 / (s[:, None] - lam) + 1 / (s[:, None] - lam.conj()),          # Re R
            1j / (s[:, None] - lam) - 1j / (s[:, None] - lam.conj()),        # Im R
            np.stack([(s / w0) ** p for p in (-2, -1, 0, 1)], axis=1)]       # residual terms
    basis = np.hstack(cols)
    scale = np.linalg.norm(basis, axis=0)
    out = np.empty((h.shape[0], n), dtype=complex)
    for j in range(h.shape[0]):
        a = basis / scale * w[j][:, None]
        theta = np.linalg.lstsq(np.vstack([a.real, a.imag]),
                                np.concatenate([(h[j] * w[j]).real, (h[j] * w[j]).imag]), rcond=None)[0] / scale
        out[j] = theta[:n] + 1j * theta[n:2 * n]
    return out


def _realise(a: np.ndarray, ref: int | None) -> tuple[np.ndarray, float]:
    """A complex column of modal constants turned most nearly real: (its real part, MPC); the driving
    point's entry (row ``ref``) made positive when given."""
    total = np.sum(a**2)
    power = float(np.sum(np.abs(a) ** 2))
    mpc = float(abs(total) ** 2 / power**2) if power > 0 else float("nan")
    real = np.real(a * np.exp(-0.5j * np.angle(total)))
    if ref is not None and real[ref] < 0:
        real = -real
    return real, mpc


def identify_shapes(freq_hz, frfs, point_ids, modes_hz, *, reference_point: int, damping_hint=None,
                    response: str = "velocity", weights=None) -> IdentifiedShapes:
    """Identify the mode shapes at the response points from the FRFs of one excitation point.

    The poles come from a curve fit of every point's FRF near the expected modes (each mode from the
    FRF whose measured magnitude peaks highest in its band), the residues from a least-squares fit of every FRF with those poles
    fixed (:func:`lsfd_residues`, modes whose bands overlap together); see the module docstring for the
    modal constants, their realisation and the mass normalisation.

    Parameters
    ----------
    freq_hz : array_like, shape (n_f,)
        Frequency lines [Hz], increasing, > 0.
    frfs : array_like, complex, shape (n_points, n_f)
        The FRFs ``H_jk`` from the force at ``reference_point`` [N] to each response point's
        ``response`` (SI: [m/N], [(m/s)/N] or [(m/s^2)/N]).
    point_ids : sequence of int, length n_points
        Response point of each row.
    modes_hz : array_like, shape (n_modes,)
        Expected natural frequencies [Hz] (e.g. the model's, or the predicted closed loop's).
    reference_point : int
        The excitation point ``k``; when it is among ``point_ids`` the shapes are also mass-normalised.
    damping_hint : array_like, shape (n_modes,), optional
        Expected damping ratios [-], which size the fitted bands
        (:func:`~vlab.measure.modal_fit.fit_half_bands`); default 0.01.
    response : {"velocity", "displacement", "acceleration"}
        Quantity of the FRFs' numerator.
    weights : array_like, shape (n_points, n_f), optional
        Non-negative weights of each point's lines (e.g. the coherence); uniform by default.

    Returns
    -------
    IdentifiedShapes
        The modes found at one point at least, in the order of ``modes_hz``.

    Raises
    ------
    MeasurementError
        Mismatched shapes, an unknown ``response``, repeated point ids, no expected mode found in any FRF.

    Source: module docstring (Ewins 2000, Ch. 2 and 4; Peeters et al. 2004, Sec. 3).
    """
    f = np.asarray(freq_hz, dtype=float)
    ids = tuple(int(p) for p in point_ids)
    h = np.atleast_2d(np.asarray(frfs, dtype=complex))
    if h.shape != (len(ids), f.size) or len(set(ids)) != len(ids):
        raise MeasurementError(f"identify_shapes: FRFs of shape {h.shape} need one row per distinct point "
                               f"{ids} and one column per line ({f.size})")
    modes = np.atleast_1d(np.asarray(modes_hz, dtype=float))
    zeta = np.full(modes.shape, 0.01) if damping_hint is None else np.asarray(damping_hint, dtype=float)
    wts = None if weights is None else np.broadcast_to(np.asarray(weights, dtype=float), h.shape)
    hx = _receptance(f, h, response)
    halves = fit_half_bands(f, modes, zeta)
    poles = _poles(f, hx, modes, halves, wts, [f"H{p},{reference_point}" for p in ids])
    found = [r for r, lam in enumerate(poles) if lam is not None]
    if not found:
        raise MeasurementError(f"identify_shapes: none of the modes near {np.round(modes, 3).tolist()} Hz "
                               "was found in any FRF")
    lam = np.array([poles[r] for r in found])
    res = np.empty((len(ids), lam.size), dtype=complex)
    fn = np.abs(lam) / (2 * np.pi)
    for g in overlapping_bands(fn, halves[found]):
        sel = band_lines(f, min(fn[i] - halves[found][i] for i in g), max(fn[i] + halves[found][i] for i in g),
                         2 * len(g) + 6)
        res[:, g] = lsfd_residues(f[sel], hx[:, sel], lam[g], weights=None if wts is None else wts[:, sel])
    const = 2j * lam.imag * res
    ref = ids.index(reference_point) if reference_point in ids else None
    real = np.empty(const.shape)
    mpc = np.empty(lam.size)
    for r in range(lam.size):
        real[:, r], mpc[r] = _realise(const[:, r], ref)
    unit, sign = normalise_shapes(real)
    mass = np.full(real.shape, np.nan)
    if ref is not None:
        ok = real[ref] > 0
        mass[:, ok] = real[:, ok] / np.sqrt(real[ref, ok]) * np.sign(sign[ok])
    return IdentifiedShapes(ids, int(reference_point), tuple(r + 1 for r in found), fn, -lam.real / np.abs(lam),
                            lam, const, unit, mass, mpc)


@dataclass(frozen=True)
class ShapeComparison:
    """Identified shapes against a model's at the same points (:func:`compare_shapes`).

    Attributes
    ----------
    mac_matrix : ndarray, shape (n_model, n_identified)
        MAC of every model mode (rows) with every identified mode (columns) [-].
    pairs : list of dict
        One per paired mode, by descending MAC (:func:`~vlab.measure.mac.pair_modes`), in the order of the
        identified modes: ``identified_mode`` and ``model_mode`` (1-based), ``mac``,
        ``frequency_identified_hz``, ``frequency_model_hz``, ``frequency_error_pct``,
        ``damping_ratio_identified``, ``damping_ratio_model`` (NaN if not given).
    model_freq_hz : ndarray, shape (n_model,)
        The model's natural frequencies [Hz].
    model_damping : ndarray, shape (n_model,)
        The model's damping ratios [-] (NaN if not given).
    """

    mac_matrix: np.ndarray
    pairs: list[dict]
    model_freq_hz: np.ndarray
    model_damping: np.ndarray


def compare_shapes(identified: IdentifiedShapes, model_shapes, model_freq_hz, model_damping=None,
                   *, threshold: float = 0.0) -> ShapeComparison:
    """MAC of the identified shapes against a model's at the same points, and the modes paired by it.

    Parameters
    ----------
    identified : IdentifiedShapes
        From :func:`identify_shapes`.
    model_shapes : array_like, shape (n_points, n_model)
        The model's shapes at ``identified.point_ids`` in the same order (any scaling).
    model_freq_hz : array_like, shape (n_model,)
        The model's natural frequencies [Hz].
    model_damping : array_like, shape (n_model,), optional
        The model's damping ratios [-].
    threshold : float
        Pairs with a MAC below this are not made.

    Returns
    -------
    ShapeComparison

    Raises
    ------
    MeasurementError
        Shapes or frequencies whose sizes do not match; as :func:`~vlab.measure.mac.mac`.

    Source: Allemang & Brown, IMAC 1 (1982) 110-116; Ewins (2000), Sec. 8.2.
    """
    phi = np.asarray(model_shapes, dtype=float)
    fm = np.atleast_1d(np.asarray(model_freq_hz, dtype=float))
    zm = np.full(fm.shape, np.nan) if model_damping is None else np.asarray(model_damping, dtype=float)
    if phi.ndim != 2 or phi.shape[1] != fm.size or zm.shape != fm.shape:
        raise MeasurementError(f"compare_shapes: model shapes {phi.shape}, frequencies {fm.shape} and "
                               f"damping {zm.shape} must agree in the number of modes")
    m = mac(phi, identified.shapes)
    pairs = []
    for i, j, v in sorted(pair_modes(m, threshold=threshold), key=lambda p: p[1]):
        fi = float(identified.freq_hz[j])
        pairs.append({"identified_mode": identified.modes[j], "model_mode": i + 1, "mac": v,
                      "frequency_identified_hz": fi, "frequency_model_hz": float(fm[i]),
                      "frequency_error_pct": 100 * (fi / fm[i] - 1),
                      "damping_ratio_identified": float(identified.damping_ratio[j]),
                      "damping_ratio_model": float(zm[i])})
    return ShapeComparison(m, pairs, fm, zm)
