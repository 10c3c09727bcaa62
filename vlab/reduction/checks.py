"""Input checks of the reduction and correction steps: real, finite, symmetric matrices; master lists.

Each check raises :class:`vlab.errors.ModelError` (or
:class:`vlab.errors.ReductionError` for a master list) with a message that
names the matrix and the offending entry or DOF. Also the undamped natural
frequencies of ``(m, k)`` and the checks of modal data (frequencies, damping
ratios, a square modal matrix), shared with :mod:`vlab.correction`.
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np
import scipy.linalg as sla

from ..errors import ModelError, ReductionError

_SYM_RTOL = 1e-10  # relative asymmetry accepted in input matrices (round-off)
_MAX_NAMES = 12  # DOF names listed in one error message


def dof_name(index: int, labels: Sequence[Any] | None) -> str:
    """Name of DOF ``index`` in messages: ``"DOF 3"`` or, with labels, ``"DOF 3 (5, 'w')"``.

    Parameters
    ----------
    index : int
        Index into the full DOF list.
    labels : sequence or None
        One label per DOF (e.g. ``(point_id, "w")``).
    """
    if labels is None:
        return f"DOF {index}"
    return f"DOF {index} {labels[index]!r}"


def dof_names(indices: Sequence[int], labels: Sequence[Any] | None) -> str:
    """Names of DOFs ``indices`` (see :func:`dof_name`), comma-separated, the first 12 then a count.

    Parameters
    ----------
    indices : sequence of int
        Indices into the full DOF list.
    labels : sequence or None
        One label per DOF.
    """
    idx = [int(i) for i in indices]
    names = [dof_name(i, labels) for i in idx[:_MAX_NAMES]]
    more = len(idx) - len(names)
    text = ", ".join(names)
    if more > 0:
        text += f" and {more} more"
    return text


def mode_names(modes: Sequence[int], freq_hz: np.ndarray | None = None) -> str:
    """``"mode 1 (3.2 Hz), mode 4 (...)"`` for 0-based mode indices, with frequencies when given.

    Parameters
    ----------
    modes : sequence of int
        0-based mode indices.
    freq_hz : ndarray, optional
        Natural frequencies [Hz] indexed like the modes.
    """
    parts = []
    for j in modes:
        if freq_hz is not None:
            parts.append(f"mode {j + 1} ({freq_hz[j]:.6g} Hz)")
        else:
            parts.append(f"mode {j + 1}")
    return ", ".join(parts)


def real_array(name: str, a: Any, ndim: int) -> np.ndarray:
    """``a`` as a float array of ``ndim`` dimensions after checking it is real, numeric and finite.

    Parameters
    ----------
    name : str
        Name of the array in messages.
    a : array_like
        The array.
    ndim : int
        Required number of dimensions.

    Returns
    -------
    ndarray
        A float copy.

    Raises
    ------
    ModelError
        A complex or non-numeric array, another number of dimensions, NaN or inf.
    """
    arr = np.asarray(a)
    if np.iscomplexobj(arr):
        raise ModelError(f"{name} must be real, got a complex array")
    if arr.dtype.kind not in "biuf":
        raise ModelError(f"{name} must be numeric, got dtype {arr.dtype}")
    if arr.ndim != ndim:
        raise ModelError(f"{name} must have {ndim} dimension(s), got shape {arr.shape}")
    arr = np.array(arr, dtype=float)
    if not np.all(np.isfinite(arr)):
        raise ModelError(f"{name} contains NaN or inf")
    return arr


def check_shape(name: str, arr: np.ndarray, expected: tuple[int, ...]) -> None:
    """Raise ModelError unless ``arr`` has shape ``expected``.

    Parameters
    ----------
    name : str
        Name of the array in the message.
    arr : ndarray
        The array.
    expected : tuple of int
        Required shape.
    """
    if arr.shape != expected:
        raise ModelError(f"{name} has shape {arr.shape}, expected {expected}")


def symmetric(name: str, a: Any, n: int | None = None) -> np.ndarray:
    """Return ``a`` as a float (n, n) array after checking it is square and symmetric.

    Parameters
    ----------
    name : str
        Name of the matrix in messages.
    a : array_like, shape (n, n)
        The matrix; an asymmetry up to 1e-10 of its largest entry (round-off) is averaged away.
    n : int, optional
        Required size.

    Returns
    -------
    ndarray, shape (n, n)
        ``(a + a') / 2``.

    Raises
    ------
    ModelError
        A matrix that is not real, finite, square (of size ``n``) or symmetric; the message names the entry.
    """
    arr = real_array(name, a, 2)
    if arr.shape[0] != arr.shape[1]:
        raise ModelError(f"{name} must be square, got shape {arr.shape}")
    if n is not None:
        check_shape(name, arr, (n, n))
    scale = np.max(np.abs(arr)) if arr.size else 0.0
    asym = np.max(np.abs(arr - arr.T)) if arr.size else 0.0
    if asym > _SYM_RTOL * scale:
        i, j = np.unravel_index(np.argmax(np.abs(arr - arr.T)), arr.shape)
        raise ModelError(
            f"{name} must be symmetric: {name}[{i}, {j}] = {arr[i, j]:.6g} but "
            f"{name}[{j}, {i}] = {arr[j, i]:.6g}"
        )
    return 0.5 * (arr + arr.T)


def frozen(a: np.ndarray | None) -> np.ndarray | None:
    """A read-only float copy of ``a`` (None stays None).

    Parameters
    ----------
    a : ndarray or None
        The array.
    """
    if a is None:
        return None
    out = np.array(a, dtype=float, copy=True)
    out.flags.writeable = False
    return out


def check_labels(labels: Sequence[Any] | None, n: int) -> tuple[Any, ...] | None:
    """``labels`` as a tuple of one label per DOF (None stays None).

    Parameters
    ----------
    labels : sequence or None
        DOF labels.
    n : int
        Number of DOFs.

    Raises
    ------
    ModelError
        Another number of labels.
    """
    if labels is None:
        return None
    labels = tuple(labels)
    if len(labels) != n:
        raise ModelError(f"labels has {len(labels)} entries, expected one per DOF ({n})")
    return labels


def check_master(master: Any, n: int, labels: Sequence[Any] | None) -> tuple[int, ...]:
    """The master DOF indices as a tuple, checked.

    Parameters
    ----------
    master : sequence of int
        Indices of the master DOFs.
    n : int
        Number of DOFs of the full model.
    labels : sequence or None
        DOF labels, for the messages.

    Returns
    -------
    tuple of int

    Raises
    ------
    ReductionError
        A list that is not 1-D, empty, not of integers, out of range, or repeats a DOF.
    """
    arr = np.asarray(master)
    if arr.ndim != 1:
        raise ReductionError(f"master must be a 1-D sequence of DOF indices, got shape {arr.shape}")
    if arr.size == 0:
        raise ReductionError("master is empty: at least one master DOF is needed")
    if arr.dtype.kind not in "iu":
        raise ReductionError(f"master must hold integer DOF indices, got dtype {arr.dtype}: {list(master)!r}")
    idx = [int(i) for i in arr]
    bad = [i for i in idx if i < 0 or i >= n]
    if bad:
        raise ReductionError(f"master DOF indices {bad} are out of range for a model with {n} DOFs (0..{n - 1})")
    seen: set[int] = set()
    dup: list[int] = []
    for i in idx:
        if i in seen and i not in dup:
            dup.append(i)
        seen.add(i)
    if dup:
        raise ReductionError(f"master DOFs listed more than once: {dof_names(dup, labels)}")
    return tuple(idx)


def natural_frequencies_hz(m: Any, k: Any) -> np.ndarray:
    """Undamped natural frequencies of ``m q'' + k q = 0``, ascending.

    Parameters
    ----------
    m, k : array_like, shape (n, n)
        Symmetric mass [kg] (positive definite) and stiffness [N/m] matrices.

    Returns
    -------
    ndarray, shape (n,)
        Frequencies [Hz]; eigenvalues below zero from round-off (rigid-body
        modes) are returned as 0.

    Raises
    ------
    ModelError
        If a matrix is not square, symmetric and finite, or ``m`` is not
        positive definite.
    """
    m = symmetric("m", m)
    k = symmetric("k", k, m.shape[0])
    lam = generalized_eigh(k, m, eigvals_only=True)
    return np.sqrt(np.clip(lam, 0.0, None)) / (2.0 * np.pi)


def generalized_eigh(k: np.ndarray, m: np.ndarray, **kwargs: Any) -> Any:
    """``scipy.linalg.eigh(k, m, **kwargs)``, a mass matrix that is not positive definite named as such.

    Parameters
    ----------
    k, m : ndarray, shape (n, n)
        Stiffness and mass matrices (checked symmetric).
    **kwargs
        Passed to :func:`scipy.linalg.eigh` (``eigvals_only``, ``subset_by_index``).

    Raises
    ------
    ModelError
        If ``m`` is not positive definite.
    """
    try:
        return sla.eigh(k, m, **kwargs)
    except np.linalg.LinAlgError as exc:
        raise ModelError(f"mass matrix m is not positive definite; modal analysis impossible ({exc})") from exc


# --------------------------------------------------------------------------- #


def damping_ratios(zeta: Any, n: int) -> np.ndarray:
    """Damping ratios as an (n,) float array (a scalar applies to every mode).

    Parameters
    ----------
    zeta : float or array_like, shape (n,)
        Damping ratios [-].
    n : int
        Number of modes.

    Raises
    ------
    ModelError
        Complex, non-numeric, negative or non-finite values, or another length.
    """
    if np.iscomplexobj(zeta):
        raise ModelError("damping ratios zeta must be real")
    try:
        z = np.asarray(zeta, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ModelError(f"damping ratios zeta must be numbers, got {zeta!r}") from exc
    if z.ndim == 0:
        z = np.full(n, float(z))
    if z.shape != (n,):
        raise ModelError(f"zeta has shape {z.shape}, expected ({n},) or a scalar")
    if not np.all(np.isfinite(z)) or np.any(z < 0.0):
        raise ModelError(f"damping ratios zeta must be finite and >= 0, got {z.tolist()}")
    return z


def square_modal_matrix(name: str, phi: Any) -> np.ndarray:
    """A square, non-singular modal matrix as a float array.

    Parameters
    ----------
    name : str
        Name in messages.
    phi : array_like, shape (n_R, n_R)
        Mode shapes as columns.

    Raises
    ------
    ModelError
        A matrix that is not square, or singular (linearly dependent shapes).
    """
    phi = real_array(name, phi, 2)
    if phi.shape[0] != phi.shape[1]:
        raise ModelError(f"{name} must be square (n_R, n_R), got shape {phi.shape}")
    if np.linalg.cond(phi) > 1.0 / np.finfo(float).eps:
        raise ModelError(f"{name} is singular: its columns (mode shapes) are linearly dependent")
    return phi


def frequencies(name: str, freq_hz: Any, n: int) -> np.ndarray:
    """Natural frequencies as an (n,) float array, checked finite and >= 0.

    Parameters
    ----------
    name : str
        Name in messages.
    freq_hz : array_like, shape (n,)
        Frequencies [Hz].
    n : int
        Required length.

    Raises
    ------
    ModelError
        Non-finite or negative values, or another length.
    """
    f = real_array(name, freq_hz, 1)
    check_shape(name, f, (n,))
    if np.any(f < 0.0):
        raise ModelError(f"{name} must be >= 0 Hz, got {f.tolist()}")
    return f
