"""Modal damping at the reduced DOFs and the exact reduction in the dissertation's form (Eqs. 3.6-3.8)."""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np
import scipy.linalg as sla

from ..errors import ModelError
from .checks import check_shape, damping_ratios, frequencies, real_array, square_modal_matrix

def _phi_diag_phi_inv(phi: np.ndarray, d: np.ndarray) -> np.ndarray:
    """``Phi diag(d) Phi^{-1}`` (Eqs. 3.6, 3.7): modal values ``d`` back at the reduced DOFs, by a solve."""
    return sla.solve(phi.T, (phi * d[None, :]).T).T


def modal_damping(phi: Any, freq_hz: Any, zeta: Any) -> np.ndarray:
    r"""``m^{-1} c`` for modal damping in a square modal matrix (Eqs. 3.6 and 3.20).

        m^{-1} c = Phi diag(2 zeta_i w_i) Phi^{-1},   w_i = 2 pi f_i.

    Parameters
    ----------
    phi : array_like, shape (n_R, n_R)
        Modal matrix at the reduced DOFs (``Phi_R`` of Eq. 3.6 or the
        corrected shapes of Eq. 3.20); any column normalisation.
    freq_hz : array_like, shape (n_R,)
        Natural frequencies [Hz].
    zeta : float or array_like, shape (n_R,)
        Damping ratios [-] (a scalar applies to every mode).

    Returns
    -------
    ndarray, shape (n_R, n_R)
        ``m^{-1} c`` [1/s]. Multiply by ``m`` on the left for ``c`` [N*s/m].

    Raises
    ------
    ModelError
        If ``phi`` is not square or is singular, or a frequency or damping
        ratio is negative, non-finite or of the wrong length.
    """
    phi = square_modal_matrix("phi", phi)
    n = phi.shape[0]
    w = 2.0 * np.pi * frequencies("freq_hz", freq_hz, n)
    z = damping_ratios(zeta, n)
    return _phi_diag_phi_inv(phi, 2.0 * z * w)


class ExactForm(NamedTuple):
    """The exact reduction in the dissertation's form (Eqs. 3.6-3.8).

    Attributes
    ----------
    minv_k : ndarray, shape (n_R, n_R)
        ``m_R^{-1} k_R = Phi_R diag(w_i^2) Phi_R^{-1}`` [1/s^2] (Eq. 3.7).
    minv : ndarray, shape (n_R, n_R)
        ``m_R^{-1} = Phi_R diag(1/M_i) Phi_R'`` [1/kg]; ``minv @ U_R`` is
        ``m_R^{-1} U_R`` of Eq. 3.8.
    minv_c : ndarray, shape (n_R, n_R) or None
        ``m_R^{-1} c_R = Phi_R diag(2 zeta_i w_i) Phi_R^{-1}`` [1/s] (Eq. 3.6),
        ``None`` without damping ratios.
    """

    minv_k: np.ndarray
    minv: np.ndarray
    minv_c: np.ndarray | None


def exact_reduction_form(phi_r: Any, freq_hz: Any, modal_mass: Any, zeta: Any = None) -> ExactForm:
    r"""The exact reduction as the dissertation writes it (Eqs. 3.6-3.8).

    Parameters
    ----------
    phi_r : array_like, shape (n_R, n_R)
        ``Phi_R``: master rows of the first ``n_R`` modes (Eq. 3.5), in the
        normalisation that defines ``modal_mass``.
    freq_hz : array_like, shape (n_R,)
        Natural frequencies of those modes [Hz].
    modal_mass : array_like, shape (n_R,)
        Modal masses ``M_i = phi_i' m phi_i`` [kg] (1 for mass-normalised shapes).
    zeta : float or array_like, shape (n_R,), optional
        Damping ratios [-] for Eq. 3.6.

    Returns
    -------
    ExactForm
        ``minv_k``, ``minv`` and ``minv_c``, each (n_R, n_R). They equal
        ``m_R^{-1} k_R``, ``m_R^{-1}`` and ``m_R^{-1} c_R`` of
        :meth:`ExactReduction.reduce`.

    Raises
    ------
    ModelError
        If ``phi_r`` is not square or is singular, or a frequency, modal mass
        or damping ratio is invalid (negative, non-finite, wrong length).

    Source: Eqs. 3.6-3.8 of the dissertation.
    """
    phi = square_modal_matrix("phi_r", phi_r)
    n = phi.shape[0]
    w = 2.0 * np.pi * frequencies("freq_hz", freq_hz, n)
    mi = real_array("modal_mass", modal_mass, 1)
    check_shape("modal_mass", mi, (n,))
    if np.any(mi <= 0.0):
        raise ModelError(f"modal masses must be > 0, got {mi.tolist()}")
    minv_k = _phi_diag_phi_inv(phi, w**2)
    minv = (phi / mi[None, :]) @ phi.T
    minv_c = None if zeta is None else modal_damping(phi, freq_hz, zeta)
    return ExactForm(minv_k=minv_k, minv=0.5 * (minv + minv.T), minv_c=minv_c)
