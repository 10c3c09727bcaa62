"""Named exceptions of the controller design module, and the input checkers.

Every error raised for bad input subclasses :class:`ControllerError` and
``ValueError`` so callers may catch either. Messages name the matrix (``"m"``,
``"R"``, ``"initial_states"``, ...) and, for shapes, show the expected shape in
symbols and numbers next to the shape found.

One shape checker, :func:`check_matrix`, is used by every public function; the
property checkers (:func:`check_symmetric`, :func:`check_positive_definite`,
...) run after it.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

__all__ = [
    "ControllerError",
    "ShapeError",
    "MatrixPropertyError",
    "StabilizabilityError",
    "RiccatiError",
    "InfeasibleDampingError",
    "check_matrix",
    "check_square",
    "check_symmetric",
    "check_positive_definite",
    "check_positive_semidefinite",
    "check_positive_scalar",
    "check_damping_bound",
    "readonly",
]


class ControllerError(Exception):
    """Base class of all errors raised by :mod:`controllers`."""


class ShapeError(ControllerError, ValueError):
    """An array has the wrong number of dimensions or the wrong shape.

    The message names the matrix and shows the expected shape (in symbols and
    numbers) next to the shape found.
    """


class MatrixPropertyError(ControllerError, ValueError):
    """A matrix has the right shape but lacks a required property.

    Non-symmetric mass/stiffness matrix, weighting matrix not positive
    (semi-)definite, non-finite entries, complex entries, non-positive scalar.
    """


class StabilizabilityError(ControllerError, ValueError):
    """A pair (A, B) is not stabilisable or a pair (A, C) is not detectable.

    Found by the PBH test on the eigenvalues that need to move (Re >= 0, or
    Re >= -alpha for the alpha-shifted Kalman filter); the message names the
    eigenvalue.
    """


class RiccatiError(ControllerError, ValueError):
    """An algebraic Riccati equation has no stabilising solution (e.g. a weighting
    that leaves an imaginary-axis mode unobservable)."""


class InfeasibleDampingError(ControllerError, ValueError):
    """A damping requirement no feedback from the given actuators/sensors can meet.

    Raised before optimisation when a mode that must gain damping is
    (numerically) uncontrollable from the actuators or unobservable from the
    sensors, e.g. a mode whose shape is zero at every actuator,
    ``|U^T phi_j| ~ 0``. The message names the mode (1-based, sorted by
    frequency).
    """


def _shape_text(expected: Sequence[int | None], labels: Sequence[str] | None) -> str:
    nums = ", ".join("any" if e is None else str(e) for e in expected)
    if labels is None:
        return f"({nums}{',' if len(expected) == 1 else ''})"
    syms = ", ".join(labels)
    return f"({syms}{',' if len(labels) == 1 else ''}) = ({nums}{',' if len(expected) == 1 else ''})"


def check_matrix(
    name: str,
    value,
    expected: Sequence[int | None],
    labels: Sequence[str] | None = None,
) -> np.ndarray:
    """Return ``value`` as a real float array after checking its shape.

    Parameters
    ----------
    name : str
        Name of the matrix in the caller's signature (used in the message).
    value : array_like
        The input. Lists are accepted; complex or non-numeric input is not.
    expected : sequence of int or None
        Expected shape; ``None`` accepts any length along that axis.
    labels : sequence of str, optional
        The same shape in symbols, e.g. ``("n_dof", "n_dof")``.

    Returns
    -------
    numpy.ndarray
        A new float64 array (a copy, so the caller's data is never aliased).

    Raises
    ------
    ShapeError
        Wrong number of dimensions or wrong size along an axis.
    MatrixPropertyError
        Complex, non-numeric or non-finite entries.
    """
    arr = np.asarray(value)
    if np.iscomplexobj(arr):
        raise MatrixPropertyError(f"{name}: expected a real matrix, found complex entries")
    try:
        arr = np.array(arr, dtype=float)
    except (TypeError, ValueError) as exc:
        raise MatrixPropertyError(f"{name}: expected a numeric matrix ({exc})") from None
    want = _shape_text(expected, labels)
    if arr.ndim != len(expected) or any(
        e is not None and s != e for s, e in zip(arr.shape, expected)
    ):
        raise ShapeError(f"{name}: expected shape {want}, found {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise MatrixPropertyError(f"{name}: contains non-finite entries (nan or inf)")
    return arr


def check_square(name: str, value, symbol: str = "N") -> np.ndarray:
    """:func:`check_matrix` for a square matrix of any size.

    Parameters
    ----------
    name, value
        As :func:`check_matrix`.
    symbol : str
        Its size in symbols, e.g. ``"2n"``: the message shows ``(2n, 2n)``.

    Returns
    -------
    numpy.ndarray, shape (N, N)
        A new float64 array, as :func:`check_matrix`.

    Raises
    ------
    ShapeError
        Not 2-D, or not square.
    MatrixPropertyError
        As :func:`check_matrix`.
    """
    a = check_matrix(name, value, (None, None), (symbol, symbol))
    if a.shape[0] != a.shape[1]:
        raise ShapeError(f"{name}: expected shape ({symbol}, {symbol}) (square), found {a.shape}")
    return a


def check_symmetric(name: str, a: np.ndarray, *, rtol: float = 1e-10) -> np.ndarray:
    """Check that square ``a`` is symmetric to ``rtol`` (relative to max |a_ij|).

    Parameters
    ----------
    name : str
        Name of the matrix for the message.
    a : ndarray, shape (N, N)
    rtol : float
        Allowed asymmetry relative to ``max |a_ij|``.

    Returns
    -------
    ndarray, shape (N, N)
        The exactly symmetrised matrix ``(a + a.T) / 2``.

    Raises
    ------
    MatrixPropertyError
        If ``max|a - a^T| > rtol * max|a|``; the message gives the worst entry.
    """
    scale = float(np.max(np.abs(a))) if a.size else 0.0
    asym = np.abs(a - a.T)
    worst = float(asym.max()) if a.size else 0.0
    if worst > rtol * max(scale, np.finfo(float).tiny):
        i, j = np.unravel_index(int(np.argmax(asym)), a.shape)
        raise MatrixPropertyError(
            f"{name}: expected a symmetric matrix; |{name}[{i},{j}] - {name}[{j},{i}]| = "
            f"{worst:.3e} exceeds {rtol:.0e} * max|{name}| = {rtol * scale:.3e}"
        )
    return 0.5 * (a + a.T)


def _symmetric_spectrum(name: str, a: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
    """``a`` checked symmetric and symmetrised, with its eigenvalues in ascending order (None if ``a`` is empty)."""
    a = check_symmetric(name, a)
    return a, (np.linalg.eigvalsh(a) if a.size else None)


def check_positive_definite(name: str, a: np.ndarray, *, rtol: float = 1e-12) -> np.ndarray:
    """Check that symmetric ``a`` is positive definite; return it symmetrised.

    Parameters
    ----------
    name, a
        As :func:`check_symmetric`.
    rtol : float
        ``min eig(a)`` must exceed ``rtol * max |eig(a)|``.

    Raises
    ------
    MatrixPropertyError
        If not symmetric, or if ``min eig(a) <= rtol * max |eig(a)|``.
    """
    a, ev = _symmetric_spectrum(name, a)
    if ev is not None and ev[0] <= rtol * max(abs(ev[-1]), np.finfo(float).tiny):
        raise MatrixPropertyError(
            f"{name}: expected a positive definite matrix, smallest eigenvalue is {ev[0]:.3e} "
            f"(largest {ev[-1]:.3e})"
        )
    return a


def check_positive_semidefinite(name: str, a: np.ndarray, *, rtol: float = 1e-10) -> np.ndarray:
    """Check that symmetric ``a`` is positive semi-definite; return it symmetrised.

    Parameters
    ----------
    name, a
        As :func:`check_symmetric`.
    rtol : float
        ``min eig(a)`` may be as low as ``-rtol * max |eig(a)|`` (round-off).

    Raises
    ------
    MatrixPropertyError
        If not symmetric, or if ``min eig(a) < -rtol * max |eig(a)|``.
    """
    a, ev = _symmetric_spectrum(name, a)
    if ev is not None and ev[0] < -rtol * max(abs(ev[-1]), np.finfo(float).tiny):
        raise MatrixPropertyError(
            f"{name}: expected a positive semi-definite matrix, smallest eigenvalue is {ev[0]:.3e}"
        )
    return a


def check_positive_scalar(name: str, value, *, allow_zero: bool = False) -> float:
    """Return ``value`` as a float after checking it is finite and > 0 (or >= 0).

    Parameters
    ----------
    name : str
        Name of the parameter for the message.
    value : float
    allow_zero : bool
        Accept 0.

    Raises
    ------
    MatrixPropertyError
        If not a finite real number of the required sign.
    """
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise MatrixPropertyError(f"{name}: expected a real number, found {value!r}") from None
    ok = v >= 0.0 if allow_zero else v > 0.0
    if not np.isfinite(v) or not ok:
        rel = ">= 0" if allow_zero else "> 0"
        raise MatrixPropertyError(f"{name}: expected a finite number {rel}, found {value!r}")
    return v


def check_damping_bound(name: str, value) -> float:
    """Return a prescribed damping ratio ``zeta_L`` as a float after checking ``0 < zeta_L < 1``.

    Parameters
    ----------
    name : str
        Name of the parameter for the message.
    value : float
        ``zeta_L`` [-], the lower bound on the closed-loop damping ratios
        (Sec. 4.1.1; Eqs. 4.32, 4.38).

    Raises
    ------
    MatrixPropertyError
        If not a finite number in (0, 1).
    """
    z = check_positive_scalar(name, value)
    if z >= 1.0:
        raise MatrixPropertyError(f"{name}: expected 0 < zeta_L < 1, found {value}")
    return z


def readonly(a: np.ndarray) -> np.ndarray:
    """Return a read-only copy of ``a`` (for the fields of frozen result objects).

    Parameters
    ----------
    a : array_like
        Any array.

    Raises
    ------
    Nothing beyond NumPy's own errors for non-array input.
    """
    out = np.array(a, copy=True)
    out.setflags(write=False)
    return out
