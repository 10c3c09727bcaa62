"""Modal analysis of an undamped model ``m q'' + k q = 0`` (Eq. 3.4)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg

from ..errors import ModelError


@dataclass(frozen=True)
class Modes:
    """Natural frequencies and mode shapes, sorted by frequency.

    Attributes
    ----------
    frequencies_hz : ndarray, shape (n_modes,)
        Natural frequencies [Hz].
    shapes : ndarray, shape (n, n_modes)
        Mass-normalised shapes: ``shapes.T @ m @ shapes = I``.
    omega : ndarray, shape (n_modes,)
        Circular frequencies [rad/s].
    """

    frequencies_hz: np.ndarray
    shapes: np.ndarray
    omega: np.ndarray

    def unit_max(self, rows: list[int] | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Shapes scaled to a maximum |deflection| of 1 over ``rows`` and their modal masses.

        Sec. 4.1.1 and 5.4.1 normalise each mode to a unit maximum deflection.

        Returns
        -------
        shapes : ndarray, shape (n, n_modes)
        modal_masses : ndarray, shape (n_modes,)
            ``M_i = phi_i^T m phi_i`` of the scaled shapes [kg].
        """
        sel = self.shapes if rows is None else self.shapes[rows, :]
        j = np.argmax(np.abs(sel), axis=0)
        peak = sel[j, np.arange(sel.shape[1])]
        scaled = self.shapes / peak
        return scaled, 1.0 / peak**2


def modal_analysis(m: np.ndarray, k: np.ndarray, n_modes: int | None = None) -> Modes:
    """Solve the generalized symmetric eigenproblem ``k phi = omega^2 m phi``.

    Parameters
    ----------
    m, k : ndarray, shape (n, n)
        Symmetric mass (positive definite) and stiffness matrices.
    n_modes : int, optional
        Number of lowest modes to return (all by default).

    Returns
    -------
    Modes

    Raises
    ------
    ModelError
        If the matrices are not square and of equal shape, or ``m`` is not
        positive definite. A tiny negative eigenvalue from round-off of a
        rigid-body mode is clipped to zero frequency; a clearly negative one
        (unstable model) raises.

    Source: Eq. (3.4); scipy.linalg.eigh.
    """
    m = np.asarray(m, dtype=float)
    k = np.asarray(k, dtype=float)
    if m.ndim != 2 or m.shape[0] != m.shape[1] or k.shape != m.shape:
        raise ModelError(f"modal analysis needs square m and k of equal shape, got {m.shape} and {k.shape}")
    n = m.shape[0]
    try:
        # all pairs with the default driver: the subset drivers lose accuracy on the
        # lowest modes of stiff-and-soft models (grid pendulum mode: 1e-6 relative)
        lam, phi = scipy.linalg.eigh(k, m)
    except np.linalg.LinAlgError as exc:
        raise ModelError(f"modal analysis failed: mass matrix not positive definite ({exc})") from None
    if n_modes is not None:
        lam, phi = lam[: min(n_modes, n)], phi[:, : min(n_modes, n)]
    # Rayleigh-quotient refinement of the eigenvalues (second-order accurate in the vector error)
    lam = np.sum(phi * (k @ phi), axis=0) / np.sum(phi * (m @ phi), axis=0)  # diag(phi^T k phi) / diag(phi^T m phi)
    scale = max(abs(lam).max(), 1e-300)
    if lam.min() < -1e-8 * scale:
        raise ModelError(f"model is unstable: eigenvalue {lam.min():.3g} < 0 (negative stiffness)")
    lam = np.clip(lam, 0.0, None)
    omega = np.sqrt(lam)
    # deterministic sign: largest component positive
    j = np.argmax(np.abs(phi), axis=0)
    phi = phi * np.sign(phi[j, np.arange(phi.shape[1])])
    return Modes(omega / (2 * np.pi), phi, omega)
