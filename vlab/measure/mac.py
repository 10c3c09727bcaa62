"""Mode-shape correlation: MAC matrix, COMAC, mode pairing.

::

    MAC(a_i, b_j) = |a_i^H b_j|^2 / ((a_i^H a_i) (b_j^H b_j))

    COMAC(p) = (sum_r |A_pr B_pr|)^2 / (sum_r |A_pr|^2  sum_r |B_pr|^2)

with the columns of A and B (paired modes) normalised to unit length first.
MAC compares whole shapes (1 = identical up to scale); COMAC points at the
measurement points where paired shapes disagree.

Sources: Allemang & Brown, IMAC 1 (1982) 110-116 (MAC); Lieven & Ewins,
IMAC 6 (1988) 690-695 (COMAC); Ewins, *Modal Testing*, 2nd ed., Sec. 8.2.
The orthogonality matrix ``Phi^T M Phi`` (Tables 4, 6) lives in
:mod:`vlab.correction`.
"""

from __future__ import annotations

import numpy as np

from ..errors import MeasurementError


def _shapes(phi, what: str) -> np.ndarray:
    arr = np.asarray(phi)
    if arr.ndim == 1:
        arr = arr[:, None]
    if arr.ndim != 2 or arr.shape[0] < 1 or arr.shape[1] < 1:
        raise MeasurementError(f"{what}: expected shape (n_points, n_modes), got {np.shape(phi)}")
    if not np.all(np.isfinite(arr)):
        raise MeasurementError(f"{what}: non-finite entries")
    norms = np.linalg.norm(arr, axis=0)
    zero = np.flatnonzero(norms == 0)
    if zero.size:
        raise MeasurementError(f"{what}: mode {zero[0] + 1} is identically zero")
    return arr


def mac(phi_a, phi_b) -> np.ndarray:
    """Modal Assurance Criterion between every pair of columns.

    Parameters
    ----------
    phi_a : array_like, shape (n_points, n_a) or (n_points,)
        Mode shapes (real or complex), one per column, e.g. analysis.
    phi_b : array_like, shape (n_points, n_b) or (n_points,)
        Mode shapes at the same points in the same order, e.g. experiment.

    Returns
    -------
    ndarray, shape (n_a, n_b)
        MAC values in [0, 1].

    Raises
    ------
    MeasurementError
        Different numbers of points, a zero mode, non-finite entries.
    """
    a = _shapes(phi_a, "phi_a")
    b = _shapes(phi_b, "phi_b")
    if a.shape[0] != b.shape[0]:
        raise MeasurementError(f"phi_a has {a.shape[0]} points, phi_b has {b.shape[0]}")
    cross = np.abs(a.conj().T @ b) ** 2
    na = np.real(np.sum(a.conj() * a, axis=0))
    nb = np.real(np.sum(b.conj() * b, axis=0))
    return np.clip(cross / np.outer(na, nb), 0.0, 1.0)


def comac(phi_a, phi_b) -> np.ndarray:
    """Coordinate MAC of paired mode sets, one value per point.

    Parameters
    ----------
    phi_a, phi_b : array_like, shape (n_points, n_modes)
        Paired mode shapes: column ``r`` of both is the same mode. Each
        column is normalised to unit length before use.

    Returns
    -------
    ndarray, shape (n_points,)
        COMAC in [0, 1]; 1 where all paired modes agree at that point.
        A point where both sets are zero in every mode gets NaN.

    Raises
    ------
    MeasurementError
        Shapes differ, a zero mode, non-finite entries.
    """
    a = _shapes(phi_a, "phi_a")
    b = _shapes(phi_b, "phi_b")
    if a.shape != b.shape:
        raise MeasurementError(f"comac needs paired modes: phi_a {a.shape} vs phi_b {b.shape}")
    a = a / np.linalg.norm(a, axis=0)
    b = b / np.linalg.norm(b, axis=0)
    num = np.sum(np.abs(a * b), axis=1) ** 2
    den = np.sum(np.abs(a) ** 2, axis=1) * np.sum(np.abs(b) ** 2, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(den > 0, num / np.where(den > 0, den, 1.0), np.nan)


def pair_modes(mac_matrix, *, threshold: float = 0.0) -> list[tuple[int, int, float]]:
    """Pair modes one-to-one by descending MAC (greedy).

    Parameters
    ----------
    mac_matrix : array_like, shape (n_a, n_b)
        From :func:`mac`.
    threshold : float
        Pairs with MAC below this are not made.

    Returns
    -------
    list of (int, int, float)
        ``(i, j, MAC)`` with 0-based column indices, sorted by ``i``.

    Raises
    ------
    MeasurementError
        If ``mac_matrix`` is not 2-D.
    """
    m = np.array(mac_matrix, dtype=float)
    if m.ndim != 2:
        raise MeasurementError(f"mac_matrix must be 2-D, got shape {m.shape}")
    pairs = []
    work = m.copy()
    for _ in range(min(m.shape)):
        i, j = np.unravel_index(np.argmax(work), work.shape)
        if not work[i, j] >= threshold or work[i, j] < 0:
            break
        pairs.append((int(i), int(j), float(m[i, j])))
        work[i, :] = -1.0
        work[:, j] = -1.0
    return sorted(pairs)
