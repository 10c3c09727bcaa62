"""Mode shapes at the structure's points: the out-of-plane displacement ``w`` of each mode at each point id.

A modal test measures a mode shape as the out-of-plane displacement at the instrumented points (UFF
dataset 55, direction 3). This module reads the same numbers off the FE mode shapes: the ``w`` row of each
point (zero at a point whose ``w`` is constrained, e.g. a clamped or pinned support), for a reduced model
after expansion to the full DOF set with its basis ``q = T q_R`` (Eq. 3.5: for the exact reduction the
expanded shapes are the full model's). Each mode is scaled so that its largest displacement is +1 (the
usual display normalisation of a measured shape; the sign of a mode shape is arbitrary).

Source: Ewins, *Modal Testing* (2nd ed., Research Studies Press, 2000), Sec. 4.1 (mode shapes at the
measured points); Eq. (3.5) for the expansion of a reduced model's shapes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ModelError

#: Unit of the normalised shapes, as written in results.
SHAPE_UNITS = "1 (w / largest |w| of the mode)"


@dataclass(frozen=True)
class PointShapes:
    """Normalised out-of-plane mode shapes at the structure's points.

    Attributes
    ----------
    point_ids : tuple of int, length n_points
        The spec's point ids, in the spec's order.
    w : ndarray, shape (n_points, n_modes)
        Out-of-plane displacement of each mode at each point [1]: column ``r`` divided by its entry of
        largest magnitude, so that its largest displacement is +1 (zero at constrained points).
    scale : ndarray, shape (n_modes,)
        The divisor of each mode: its largest ``w`` at the points before normalisation, in the units of
        the shapes given (m per unit modal coordinate for mass-normalised shapes); 1.0 for a mode that
        does not move any point.
    constrained : tuple of int
        Point ids without a free ``w`` DOF (their rows are zero).
    units : str
        :data:`SHAPE_UNITS`.
    """

    point_ids: tuple[int, ...]
    w: np.ndarray
    scale: np.ndarray
    constrained: tuple[int, ...]
    units: str = SHAPE_UNITS


def normalise_shapes(w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Scale each column so that its entry of largest magnitude is +1.

    Parameters
    ----------
    w : array_like, shape (n_points, n_modes)
        Real mode shapes at points.

    Returns
    -------
    normalised : ndarray, shape (n_points, n_modes)
        ``w[:, r] / s[r]``.
    s : ndarray, shape (n_modes,)
        The signed largest entry of each column (1.0 for an all-zero column).

    Raises
    ------
    ModelError
        ``w`` not 2-D or not finite.
    """
    w = np.asarray(w, dtype=float)
    if w.ndim != 2 or not np.all(np.isfinite(w)):
        raise ModelError(f"mode shapes must be a finite (n_points, n_modes) array, got shape {w.shape}")
    if w.shape[0] == 0:
        return w.copy(), np.ones(w.shape[1])
    rows = np.argmax(np.abs(w), axis=0)
    s = w[rows, np.arange(w.shape[1])]
    s = np.where(s == 0.0, 1.0, s)
    return w / s, s


def point_mode_shapes(fe, shapes: np.ndarray, *, basis: np.ndarray | None = None) -> PointShapes:
    """The ``w`` of each mode at each of the spec's points, normalised to a largest displacement of +1.

    Parameters
    ----------
    fe : FEModel
        The full FE model (its spec's points and its DOF map).
    shapes : ndarray, shape (n_dof, n_modes) or (n_R, n_modes)
        Mode shapes over ``fe``'s DOFs, or over a reduced model's masters when ``basis`` is given.
    basis : ndarray, shape (n_dof, n_R), optional
        Reduction basis ``T`` (``q = T q_R``, Eq. 3.5; :attr:`vlab.reduction.ReducedModel.T`) that expands
        reduced shapes to ``fe``'s DOFs.

    Returns
    -------
    PointShapes

    Raises
    ------
    ModelError
        Shapes or basis whose row count does not match ``fe``'s DOFs, or non-finite values.
    """
    phi = np.asarray(shapes, dtype=float)
    if basis is not None:
        t = np.asarray(basis, dtype=float)
        if t.ndim != 2 or t.shape[0] != fe.n or phi.ndim != 2 or t.shape[1] != phi.shape[0]:
            raise ModelError(f"basis must be ({fe.n}, n_R) and shapes (n_R, n_modes); got {t.shape} and {phi.shape}")
        phi = t @ phi
    if phi.ndim != 2 or phi.shape[0] != fe.n:
        raise ModelError(f"shapes must be ({fe.n}, n_modes) over the model's DOFs, got {phi.shape}")
    ids = tuple(int(p) for p in fe.spec.points)
    w = np.zeros((len(ids), phi.shape[1]))
    constrained = []
    for i, p in enumerate(ids):
        if (p, "w") in fe.dofs:
            w[i] = phi[fe.dofs.index(p, "w")]
        else:
            constrained.append(p)
    normalised, s = normalise_shapes(w)
    return PointShapes(ids, normalised, s, tuple(constrained))

