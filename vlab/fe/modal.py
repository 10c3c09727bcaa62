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
        """Shapes scaled to a maximum ``|deflection|`` of 1 over ``rows`` and their modal masses.

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


#: An eigenvalue below ``EIGENVALUE_RESOLUTION * n * eps * lambda_max`` is not resolved
#: in double precision (see :func:`unresolved_modes`).
EIGENVALUE_RESOLUTION = 100.0


def _check_matrices(m, k) -> tuple[np.ndarray, np.ndarray]:
    m = np.asarray(m, dtype=float)
    k = np.asarray(k, dtype=float)
    if m.ndim != 2 or m.shape[0] != m.shape[1] or k.shape != m.shape:
        raise ModelError(f"modal analysis needs square m and k of equal shape, got {m.shape} and {k.shape}")
    for name, a in (("mass", m), ("stiffness", k)):
        bad = np.argwhere(~np.isfinite(a))
        if bad.size:
            raise ModelError(f"modal analysis: {len(bad)} non-finite entries in the {name} matrix, "
                             f"first at row {bad[0, 0]}, column {bad[0, 1]}")
    return m, k


def unresolved_modes(m: np.ndarray, k: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Eigenvalues of ``k phi = lambda m phi`` too small to be resolved in double precision.

    ``scipy.linalg.eigh(k, m)`` reduces the problem to the standard form
    ``A = L^-1 k L^-T`` (``m = L L^T``) and is backward stable: the computed
    eigenvalues are exact for ``A + E`` with ``||E|| <= p(n) eps ||A||``,
    ``||A|| = lambda_max``, ``eps = 2.2e-16`` and ``p(n)`` of order ``n``.
    By Weyl's inequality each eigenvalue carries an absolute error up to
    about ``n eps lambda_max``; an eigenvalue below ``floor = 100 n eps
    lambda_max`` thus has a relative error that may exceed 1 % (0.5 % in
    frequency), and one of order ``n eps lambda_max`` or less is
    numerically zero: a rigid-body (mechanism) mode, or a model whose
    stiffnesses span more than double precision resolves (a member's EI
    many decades too large). For ``n = 64`` the floor is ``1.4e-12
    lambda_max``, i.e. a frequency ratio ``f_max / f_min`` of ``8.5e5``.

    Parameters
    ----------
    m, k : ndarray, shape (n, n)
        Symmetric mass (positive definite) and stiffness matrices, finite.

    Returns
    -------
    lam : ndarray, shape (n,)
        All eigenvalues [rad^2/s^2], ascending.
    phi : ndarray, shape (n, n)
        Mass-normalised eigenvectors (columns).
    floor : float
        The resolution floor [rad^2/s^2]; the unresolved modes are
        ``lam < floor``.

    Raises
    ------
    ModelError
        Non-square, mismatched or non-finite matrices; ``m`` not positive
        definite.

    Source: Weyl's inequality and the backward stability of the symmetric
    eigensolver (Golub & Van Loan, Matrix Computations, Sec. 8.1, 8.7).
    """
    m, k = _check_matrices(m, k)
    try:
        lam, phi = scipy.linalg.eigh(k, m)
    except np.linalg.LinAlgError as exc:
        raise ModelError(f"modal analysis failed: mass matrix not positive definite ({exc})") from None
    n = m.shape[0]
    floor = EIGENVALUE_RESOLUTION * n * np.finfo(float).eps * max(abs(lam).max(), 0.0)
    return lam, phi, float(floor)


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
        If the matrices are not square and of equal shape, have non-finite
        entries, or ``m`` is not positive definite. A tiny negative eigenvalue from round-off of a
        rigid-body mode is clipped to zero frequency; a clearly negative one
        (unstable model) raises.

    Source: Eq. (3.4); scipy.linalg.eigh.
    """
    m, k = _check_matrices(m, k)
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
