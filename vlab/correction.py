"""Correction of a reduced model with measured modes (Sec. 3.2, Eqs. 3.17-3.20).

The measured mode shapes and frequencies are the *reference basis*: the
reduced mass matrix is changed as little as possible (in the norm weighted by
``m_R^{-1/2}``) so that the measured shapes become mass-orthonormal, then the
stiffness matrix is changed as little as possible so that the measured shapes
and frequencies solve the eigenproblem exactly:

    Phi' m^ Phi = I,    k^ phi_i = w_i^2 m^ phi_i    (i = 1..n_m).

Shapes of the ``n_R``-dimensional subspace that is mass-orthogonal to the
measured shapes keep their mass. With ``n_m`` measured modes and ``n_R``
reduced DOFs, ``1 <= n_m <= n_R``.

Units: masses [kg], stiffnesses [N/m], damping [N*s/m] (SI, rotations in rad),
frequencies [Hz]; shapes are dimensionless displacements at the master DOFs
(any scaling; Eq. 3.17 normalises them).

Sources: the dissertation's Eqs. 3.17-3.20 and Tables 4-6; A. Berman,
"Mass matrix correction using an incomplete set of measured modes", AIAA J.
17(10), 1979 and Berman & Nagy, AIAA J. 21(8), 1983 (the mass update, Eq.
3.18); M. Baruch, "Optimization procedure to correct stiffness and flexibility
matrices using vibration tests", AIAA J. 16(11), 1978, and "Optimal correction
of mass and stiffness matrices using measured modes", AIAA J. 20(11), 1982
(the stiffness update, Eq. 3.19); M. Baruch & I. Y. Bar-Itzhack, "Optimal
weighted orthogonalization of measured modes", AIAA J. 16(4), 1978 (Refs. 11
and 12 of the dissertation).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import scipy.linalg as sla

from .errors import ModelError
from .reduction import ReducedModel, natural_frequencies_hz
from .reduction.checks import damping_ratios as _damping_ratios
from .reduction.checks import frequencies as _freqs
from .reduction.checks import frozen as _frozen
from .reduction.checks import mode_names as _mode_names
from .reduction.checks import real_array as _real_array
from .reduction.checks import symmetric as _symmetric

__all__ = [
    "SHAPES_MAX_COND",
    "normalise_shapes",
    "orthogonality_matrix",
    "OrthogonalitySummary",
    "orthogonality_summary",
    "corrected_mass",
    "corrected_stiffness",
    "corrected_damping",
    "CorrectedModel",
    "baruch_correction",
    "correct_model",
    "CorrectionHistory",
    "sequential_correction",
]

#: Largest accepted condition number of the orthogonality matrix
#: ``Phi' m Phi`` of the normalised measured shapes (linear dependence check).
SHAPES_MAX_COND = 1e10

_ORTHO_TOL = 1e-6  # accepted deviation of Phi' m^ Phi from I in corrected_stiffness


def _shapes(phi_x: Any, n_r: int) -> np.ndarray:
    phi = _real_array("phi_x (measured shapes)", phi_x, 2)
    if phi.shape[0] != n_r:
        raise ModelError(f"phi_x (measured shapes) has shape {phi.shape}, expected ({n_r}, n_m)")
    n_m = phi.shape[1]
    if not 1 <= n_m <= n_r:
        raise ModelError(
            f"phi_x (measured shapes) has {n_m} columns; between 1 and n_R = {n_r} measured modes are needed"
        )
    return phi


def _sym(a: np.ndarray) -> np.ndarray:
    return 0.5 * (a + a.T)


def normalise_shapes(phi_x: Any, m: Any) -> np.ndarray:
    r"""Scale each measured shape to unit modal mass (Eq. 3.17).

        phi^_i = phi_i (phi_i' m_R phi_i)^{-1/2}

    Parameters
    ----------
    phi_x : array_like, shape (n_R, n_m)
        Measured mode shapes at the ``n_R`` reduced DOFs, one per column
        (real normal modes; any scaling and sign).
    m : array_like, shape (n_R, n_R)
        The (uncorrected) reduced mass matrix ``m_R`` [kg].

    Returns
    -------
    ndarray, shape (n_R, n_m)
        Shapes with ``phi^_i' m_R phi^_i = 1`` [kg^-1/2]; signs are kept.

    Raises
    ------
    ModelError
        If the shapes are complex, non-finite or of the wrong shape, ``m`` is
        not square and symmetric, or a shape has zero or negative modal mass
        (the message names the mode).
    """
    m = _symmetric("m", m)
    phi = _shapes(phi_x, m.shape[0])
    mi = np.einsum("ij,ik,kj->j", phi, m, phi)
    bad = np.flatnonzero(~(mi > 0.0))
    if bad.size:
        raise ModelError(
            f"measured {_mode_names(bad)} ha(s) zero or negative modal mass phi' m phi "
            f"({mi[bad].tolist()}): the shape is zero or m is not positive definite"
        )
    return phi / np.sqrt(mi)[None, :]


def orthogonality_matrix(phi_x: Any, m: Any) -> np.ndarray:
    r"""Orthogonality matrix of measured shapes with a reduced mass matrix (Tables 4, 6).

        O = Phi^' m_R Phi^,   Phi^ normalised by Eq. 3.17 (so ``O_ii = 1``).

    Parameters
    ----------
    phi_x : array_like, shape (n_R, n_m)
        Measured mode shapes at the reduced DOFs (any scaling).
    m : array_like, shape (n_R, n_R)
        Reduced mass matrix [kg].

    Returns
    -------
    ndarray, shape (n_m, n_m)
        Symmetric, unit diagonal; off-diagonal terms are 0 for shapes that are
        perfectly mass-orthogonal. These terms drive the mass correction
        (the factor ``Phi' m Phi - I`` of Eq. 3.18).

    Raises
    ------
    ModelError
        As :func:`normalise_shapes`.
    """
    m = _symmetric("m", m)
    phi = normalise_shapes(phi_x, m)
    o = _sym(phi.T @ m @ phi)
    np.fill_diagonal(o, 1.0)
    return o


@dataclass(frozen=True)
class OrthogonalitySummary:
    """The two numbers the dissertation quotes for an orthogonality matrix (Sec. 3.3).

    Attributes
    ----------
    max_abs_offdiag : float
        Largest ``|O_ij|``, ``i != j`` (0.80 for Table 4, 0.58 for Table 6).
    mean_abs_offdiag : float
        Mean of ``|O_ij|`` over all off-diagonal entries (0.23 for Table 4,
        0.13 for Table 6).
    n_modes : int
        Order of the matrix.
    """

    max_abs_offdiag: float
    mean_abs_offdiag: float
    n_modes: int


def orthogonality_summary(orth: Any) -> OrthogonalitySummary:
    """Summarise an orthogonality matrix by its off-diagonal terms (Sec. 3.3).

    Parameters
    ----------
    orth : array_like, shape (n_m, n_m)
        An orthogonality matrix, e.g. from :func:`orthogonality_matrix` or a
        published table (which need not be exactly symmetric).

    Returns
    -------
    OrthogonalitySummary
        Max and mean of ``|O_ij|`` over ``i != j`` (both 0 for ``n_m = 1``).

    Raises
    ------
    ModelError
        If ``orth`` is not a finite square real matrix.
    """
    o = _real_array("orth", orth, 2)
    if o.shape[0] != o.shape[1]:
        raise ModelError(f"orth must be square, got shape {o.shape}")
    n = o.shape[0]
    off = np.abs(o[~np.eye(n, dtype=bool)])
    if off.size == 0:
        return OrthogonalitySummary(0.0, 0.0, n)
    return OrthogonalitySummary(float(np.max(off)), float(np.mean(off)), n)


def _check_independent(o: np.ndarray) -> None:
    w, v = np.linalg.eigh(o)
    if w[0] > w[-1] / SHAPES_MAX_COND:
        return
    small = w <= w[-1] / SHAPES_MAX_COND
    weight = np.sqrt(np.sum(v[:, small] ** 2, axis=1))
    modes = np.flatnonzero(weight > 0.2 * np.max(weight))
    cond = w[-1] / max(w[0], np.finfo(float).tiny)
    raise ModelError(
        f"measured shapes are (nearly) linearly dependent: {_mode_names(modes)} "
        f"(condition number of Phi' m Phi = {cond:.3g} > {SHAPES_MAX_COND:.0e}); "
        "the mass correction (Eq. 3.18) needs independent shapes"
    )


def corrected_mass(m: Any, phi_hat: Any) -> np.ndarray:
    r"""Minimum-change mass matrix for which the measured shapes are orthonormal (Eq. 3.18).

        m_a = Phi' m Phi,
        m^  = m + m Phi m_a^{-1} (I - m_a) m_a^{-1} Phi' m,

    so that ``Phi' m^ Phi = I``. The change is zero when ``m_a = I``.

    Parameters
    ----------
    m : array_like, shape (n_R, n_R)
        Reduced mass matrix ``m_R`` [kg], symmetric positive definite.
    phi_hat : array_like, shape (n_R, n_m)
        Measured shapes normalised by Eq. 3.17 (:func:`normalise_shapes`);
        the formula holds for any scaling but the dissertation applies it to
        normalised shapes.

    Returns
    -------
    ndarray, shape (n_R, n_R)
        Corrected mass ``m^_R`` [kg], symmetric; positive definite when ``m``
        is (it equals ``m`` on the ``m``-orthogonal complement of the shapes).

    Raises
    ------
    ModelError
        If shapes are of the wrong shape or (nearly) linearly dependent
        (condition number of ``m_a`` above :data:`SHAPES_MAX_COND`).

    Notes
    -----
    The dissertation writes ``m^ = m - m Phi m_a^{-1} (m_a - I) m_a^{-1} Phi' m``;
    that is the same expression (the sign is consistent). Its wording
    "where Phi^ is the corrected reduced modal matrix" is loose: ``Phi^`` is
    the *measured* modal matrix normalised by Eq. 3.17. The update is the one
    of Berman (1979) / Berman & Nagy (1983), attributed in the dissertation to
    Baruch & Bar-Itzhack (Ref. 11) and Baruch (Ref. 12).
    """
    m = _symmetric("m", m)
    phi = _shapes(phi_hat, m.shape[0])
    ma = _sym(phi.T @ m @ phi)
    _check_independent(ma)
    mphi = m @ phi
    ma_inv_phit_m = sla.solve(ma, mphi.T, assume_a="pos")  # m_a^{-1} Phi' m
    delta = ma_inv_phit_m.T @ (np.eye(ma.shape[0]) - ma) @ ma_inv_phit_m
    return _sym(m + delta)


def corrected_stiffness(k: Any, m_hat: Any, phi_hat: Any, freq_hz: Any) -> np.ndarray:
    r"""Minimum-change stiffness matrix reproducing the measured modes (Eq. 3.19).

        k^ = k - k Phi Phi' m^ - m^ Phi Phi' k
               + m^ Phi Phi' k Phi Phi' m^ + m^ Phi Omega^2 Phi' m^,

    with ``Omega^2 = diag((2 pi f_i)^2)``. For ``Phi' m^ Phi = I`` this gives
    ``k^ Phi = m^ Phi Omega^2`` exactly and leaves ``k`` unchanged on the
    ``m^``-orthogonal complement of the shapes:
    ``k^ = (I - m^ Phi Phi') k (I - Phi Phi' m^) + m^ Phi Omega^2 Phi' m^``.

    Parameters
    ----------
    k : array_like, shape (n_R, n_R)
        Reduced stiffness matrix ``k_R`` [N/m].
    m_hat : array_like, shape (n_R, n_R)
        Corrected mass matrix from :func:`corrected_mass` [kg].
    phi_hat : array_like, shape (n_R, n_m)
        Measured shapes, orthonormal with respect to ``m_hat``.
    freq_hz : array_like, shape (n_m,)
        Measured natural frequencies [Hz].

    Returns
    -------
    ndarray, shape (n_R, n_R)
        Corrected stiffness ``k^_R`` [N/m], symmetric.

    Raises
    ------
    ModelError
        If a matrix has the wrong shape or is not symmetric, a frequency is
        negative, or ``phi_hat' m_hat phi_hat`` differs from ``I`` by more
        than 1e-6 (the shapes were not normalised with this mass matrix).

    Notes
    -----
    The dissertation's Eq. 3.19 ends with ``m^ Phi Omega^2 Phi' m_R`` (the
    uncorrected ``m_R``). That is a typo: it makes ``k^`` unsymmetric and
    breaks ``k^ phi_i = w_i^2 m^ phi_i`` whenever the mass was changed. The
    standard form (Baruch 1978, Berman & Nagy 1983) with ``m^`` on both sides
    is used.
    """
    m_hat = _symmetric("m_hat", m_hat)
    n_r = m_hat.shape[0]
    k = _symmetric("k", k, n_r)
    phi = _shapes(phi_hat, n_r)
    w2 = (2.0 * np.pi * _freqs("freq_hz", freq_hz, phi.shape[1])) ** 2
    ortho = phi.T @ m_hat @ phi
    dev = np.max(np.abs(ortho - np.eye(phi.shape[1])))
    if dev > _ORTHO_TOL:
        raise ModelError(
            f"phi_hat' m_hat phi_hat differs from I by {dev:.3g}: normalise the shapes with "
            "normalise_shapes and correct the mass with corrected_mass first"
        )
    p = m_hat @ phi  # m^ Phi
    kphi = k @ phi
    k_hat = k - kphi @ p.T - p @ kphi.T + p @ (phi.T @ kphi) @ p.T + (p * w2[None, :]) @ p.T
    return _sym(k_hat)


def corrected_damping(m_hat: Any, phi_hat: Any, freq_hz: Any, zeta: Any) -> np.ndarray:
    r"""Damping matrix from measured frequencies, damping ratios and shapes (Eq. 3.20).

        c^ = m^ Phi diag(2 zeta_i w_i) Phi' m^.

    With ``Phi' m^ Phi = I`` and ``n_m = n_R`` this is the dissertation's
    ``m^^{-1} c^ = Phi diag(2 zeta_i w_i) Phi^{-1}`` (as ``Phi^{-1} = Phi' m^``);
    for ``n_m < n_R`` it gives the measured modes their damping and leaves
    the unmeasured (``m^``-orthogonal) part undamped.

    Parameters
    ----------
    m_hat, phi_hat, freq_hz
        As :func:`corrected_stiffness`.
    zeta : float or array_like, shape (n_m,)
        Measured damping ratios [-].

    Returns
    -------
    ndarray, shape (n_R, n_R)
        Corrected damping ``c^_R`` [N*s/m], symmetric positive semi-definite.

    Raises
    ------
    ModelError
        If shapes, frequencies or damping ratios have wrong shapes or values.
    """
    m_hat = _symmetric("m_hat", m_hat)
    phi = _shapes(phi_hat, m_hat.shape[0])
    n_m = phi.shape[1]
    w = 2.0 * np.pi * _freqs("freq_hz", freq_hz, n_m)
    z = _damping_ratios(zeta, n_m)
    p = m_hat @ phi
    return _sym((p * (2.0 * z * w)[None, :]) @ p.T)


@dataclass(frozen=True, eq=False)
class CorrectedModel:
    """A reduced model corrected with measured modes (immutable).

    Attributes
    ----------
    m : ndarray, shape (n_R, n_R)
        Corrected mass ``m^_R`` [kg] (Eq. 3.18).
    k : ndarray, shape (n_R, n_R)
        Corrected stiffness ``k^_R`` [N/m] (Eq. 3.19).
    c : ndarray, shape (n_R, n_R) or None
        Corrected damping ``c^_R`` [N*s/m] (Eq. 3.20) when damping ratios were given.
    shapes : ndarray, shape (n_R, n_m)
        The measured shapes normalised by Eq. 3.17; ``shapes' m shapes = I``.
    freq_hz : ndarray, shape (n_m,)
        The measured frequencies used [Hz].
    """

    m: np.ndarray
    k: np.ndarray
    c: np.ndarray | None
    shapes: np.ndarray
    freq_hz: np.ndarray

    def __post_init__(self) -> None:
        for name in ("m", "k", "c", "shapes", "freq_hz"):
            object.__setattr__(self, name, _frozen(getattr(self, name)))

    @property
    def n_modes(self) -> int:
        """Number of measured modes used, ``n_m``."""
        return self.shapes.shape[1]

    def natural_frequencies_hz(self) -> np.ndarray:
        """Undamped natural frequencies of the corrected model, shape (n_R,) [Hz], ascending."""
        return natural_frequencies_hz(self.m, self.k)


def baruch_correction(m: Any, k: Any, phi_x: Any, freq_hz: Any, *, zeta: Any = None) -> CorrectedModel:
    r"""Correct a reduced model with measured modes (Eqs. 3.17-3.20).

    Steps: normalise the shapes with ``m_R`` (Eq. 3.17), correct the mass
    (Eq. 3.18, :func:`corrected_mass`), the stiffness (Eq. 3.19,
    :func:`corrected_stiffness`) and, given damping ratios, build the damping
    matrix (Eq. 3.20, :func:`corrected_damping`).

    Parameters
    ----------
    m, k : array_like, shape (n_R, n_R)
        Reduced mass [kg] and stiffness [N/m] matrices (e.g. from
        :class:`vlab.reduction.GuyanReduction`).
    phi_x : array_like, shape (n_R, n_m)
        Measured mode shapes at the master DOFs, ``1 <= n_m <= n_R``, in the
        master order of ``m``/``k`` (real; any scaling).
    freq_hz : array_like, shape (n_m,)
        Measured natural frequencies [Hz].
    zeta : float or array_like, shape (n_m,), optional
        Measured damping ratios [-].

    Returns
    -------
    CorrectedModel
        With ``k^ phi^_i = (2 pi f_i)^2 m^ phi^_i`` and ``Phi^' m^ Phi^ = I``.
        If the shapes are already ``m_R``-orthogonal, ``m^ = m_R``.

    Raises
    ------
    ModelError
        For inputs of wrong shape, non-symmetric matrices, complex or
        linearly dependent shapes, a shape of zero modal mass, or negative
        frequencies or damping ratios.
    """
    m = _symmetric("m", m)
    k = _symmetric("k", k, m.shape[0])
    phi = normalise_shapes(phi_x, m)
    f = _freqs("freq_hz", freq_hz, phi.shape[1])
    m_hat = corrected_mass(m, phi)
    k_hat = corrected_stiffness(k, m_hat, phi, f)
    c_hat = None if zeta is None else corrected_damping(m_hat, phi, f, zeta)
    return CorrectedModel(m=m_hat, k=k_hat, c=c_hat, shapes=phi, freq_hz=f)


def correct_model(model: ReducedModel, phi_x: Any, freq_hz: Any, *, zeta: Any = None) -> ReducedModel:
    """:func:`baruch_correction` applied to a :class:`~vlab.reduction.ReducedModel`.

    Parameters
    ----------
    model : ReducedModel
        The reduced model (n_R DOFs).
    phi_x : array_like, shape (n_R, n_m)
        Measured shapes at the model's master DOFs, in ``model.master`` order.
    freq_hz : array_like, shape (n_m,)
        Measured natural frequencies [Hz].
    zeta : float or array_like, shape (n_m,), optional
        Measured damping ratios [-]; without them the model's ``c`` is kept.

    Returns
    -------
    ReducedModel
        A copy with corrected ``m``, ``k`` (and ``c``), ``method`` suffixed
        ``"+baruch"``; ``T`` and the masters are kept.

    Raises
    ------
    ModelError
        As :func:`baruch_correction`, or if ``model`` is not a ReducedModel.
    """
    if not isinstance(model, ReducedModel):
        raise ModelError(f"model must be a ReducedModel, got {type(model).__name__}")
    cm = baruch_correction(model.m, model.k, phi_x, freq_hz, zeta=zeta)
    c = model.c if cm.c is None else cm.c
    return model.with_(m=cm.m, k=cm.k, c=c, method=f"{model.method}+baruch")


@dataclass(frozen=True, eq=False)
class CorrectionHistory:
    """Result of a sequential correction (mode 1, then modes 1-2, ...; Sec. 3.3).

    Attributes
    ----------
    steps : tuple of CorrectedModel, length n_m
        ``steps[j]`` is corrected with measured modes ``1..j+1``.
    freq_hz : ndarray, shape (n_m + 1, n_R)
        Natural frequencies [Hz] of the uncorrected model (row 0) and after
        each step (row j), ascending.
    measured_freq_hz : ndarray, shape (n_m,)
        The measured frequencies [Hz].
    base : str
        ``"original"`` or ``"previous"`` (see :func:`sequential_correction`).
    """

    steps: tuple[CorrectedModel, ...]
    freq_hz: np.ndarray
    measured_freq_hz: np.ndarray
    base: str

    def __post_init__(self) -> None:
        object.__setattr__(self, "freq_hz", _frozen(self.freq_hz))
        object.__setattr__(self, "measured_freq_hz", _frozen(self.measured_freq_hz))
        object.__setattr__(self, "steps", tuple(self.steps))

    @property
    def final(self) -> CorrectedModel:
        """The model corrected with all measured modes."""
        return self.steps[-1]


def sequential_correction(
    m: Any,
    k: Any,
    phi_x: Any,
    freq_hz: Any,
    *,
    zeta: Any = None,
    base: Literal["original", "previous"] = "original",
) -> CorrectionHistory:
    """Apply the correction with modes 1, then 1-2, ..., then 1-n_m (Sec. 3.3).

    The dissertation judges a reduced model by how the frequencies of the
    *unmeasured* modes move as measured modes are added (its Guyan model's
    12th frequency went from 11.32 Hz to 9.84 Hz; its exact reduction was
    "severely altered"). The history makes that visible.

    Parameters
    ----------
    m, k : array_like, shape (n_R, n_R)
        Reduced mass [kg] and stiffness [N/m] matrices.
    phi_x : array_like, shape (n_R, n_m)
        Measured shapes at the master DOFs, in the order they are added.
    freq_hz : array_like, shape (n_m,)
        Measured natural frequencies [Hz].
    zeta : float or array_like, shape (n_m,), optional
        Measured damping ratios [-]; step j uses the first j.
    base : {"original", "previous"}
        ``"original"`` (default): step j corrects the uncorrected ``(m, k)``
        with modes ``1..j``. ``"previous"``: step j corrects the result of
        step j-1 with modes ``1..j`` (shapes renormalised with its mass).
        The dissertation does not say which it used; the two agree at step 1
        and both reproduce modes ``1..j`` after step j.

    Returns
    -------
    CorrectionHistory
        The corrected model of every step and the frequencies after each.

    Raises
    ------
    ModelError
        As :func:`baruch_correction`, or for an unknown ``base``.
    """
    if base not in ("original", "previous"):
        raise ModelError(f"base must be 'original' or 'previous', got {base!r}")
    m = _symmetric("m", m)
    k = _symmetric("k", k, m.shape[0])
    phi = _shapes(phi_x, m.shape[0])
    n_m = phi.shape[1]
    f = _freqs("freq_hz", freq_hz, n_m)
    z = None if zeta is None else _damping_ratios(zeta, n_m)
    steps: list[CorrectedModel] = []
    freqs = [natural_frequencies_hz(m, k)]
    m_j, k_j = m, k
    for j in range(1, n_m + 1):
        if base == "previous" and steps:
            m_j, k_j = steps[-1].m, steps[-1].k
        step = baruch_correction(m_j, k_j, phi[:, :j], f[:j], zeta=None if z is None else z[:j])
        steps.append(step)
        freqs.append(step.natural_frequencies_hz())
    return CorrectionHistory(steps=tuple(steps), freq_hz=np.asarray(freqs), measured_freq_hz=f, base=base)
