"""The reduced model: :class:`ReducedModel`, the immutable result of a reduction (``m_R``, ``k_R``, ``c_R``, ``T``)."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import ModelError
from .checks import frozen, natural_frequencies_hz, real_array, symmetric

@dataclass(frozen=True, eq=False)
class ReducedModel:
    """A structural model reduced to master DOFs (immutable).

    Parameters
    ----------
    m : ndarray, shape (n_R, n_R)
        Reduced mass matrix ``m_R`` [kg].
    k : ndarray, shape (n_R, n_R)
        Reduced stiffness matrix ``k_R`` [N/m].
    T : ndarray, shape (n, n_R)
        Basis ``q = T q_R``; its master rows are the identity.
    master : tuple of int, length n_R
        Indices of the master DOFs in the full model, in the order of ``q_R``.
    labels : tuple, length n_R, optional
        Labels of the master DOFs (e.g. ``(point_id, "w")``).
    c : ndarray, shape (n_R, n_R), optional
        Reduced damping matrix ``c_R`` [N*s/m].
    method : str
        ``"guyan"``, ``"exact"`` or a note added by a later step.

    Notes
    -----
    Arrays are stored as read-only copies. Changed copies come from
    :meth:`with_`; a model changed that way (e.g. corrected by
    :func:`vlab.correction.baruch_correction`) keeps its ``T``, which then
    maps displacements back but no longer satisfies ``m = T' m_full T``.
    """

    m: np.ndarray
    k: np.ndarray
    T: np.ndarray
    master: tuple[int, ...]
    labels: tuple[Any, ...] | None = None
    c: np.ndarray | None = None
    method: str = ""

    def __post_init__(self) -> None:
        m = symmetric("ReducedModel.m", self.m)
        n_r = m.shape[0]
        k = symmetric("ReducedModel.k", self.k, n_r)
        c = None if self.c is None else symmetric("ReducedModel.c", self.c, n_r)
        t = real_array("ReducedModel.T", self.T, 2)
        if t.shape[1] != n_r:
            raise ModelError(f"ReducedModel.T has shape {t.shape}, expected (n, {n_r})")
        master = tuple(int(i) for i in self.master)
        if len(master) != n_r:
            raise ModelError(f"ReducedModel.master has {len(master)} entries, expected {n_r}")
        labels = None if self.labels is None else tuple(self.labels)
        if labels is not None and len(labels) != n_r:
            raise ModelError(f"ReducedModel.labels has {len(labels)} entries, expected {n_r}")
        object.__setattr__(self, "m", frozen(m))
        object.__setattr__(self, "k", frozen(k))
        object.__setattr__(self, "c", frozen(c))
        object.__setattr__(self, "T", frozen(t))
        object.__setattr__(self, "master", master)
        object.__setattr__(self, "labels", labels)

    @property
    def n_R(self) -> int:  # noqa: N802 - the dissertation's symbol
        """Number of reduced DOFs ``n_R``."""
        return self.m.shape[0]

    @property
    def n(self) -> int:
        """Number of DOFs of the full model."""
        return self.T.shape[0]

    def with_(self, **changes: Any) -> "ReducedModel":
        """Return a copy with the given fields replaced (e.g. ``m=..., k=...``).

        Parameters
        ----------
        **changes
            Field name -> new value (``m``, ``k``, ``T``, ``master``, ``labels``,
            ``c``, ``method``); the copy is checked and frozen like a new model.

        Returns
        -------
        ReducedModel

        Raises
        ------
        ModelError
            If the changed fields are inconsistent (shapes, symmetry, finiteness).
        TypeError
            For a name that is not a field.
        """
        return dataclasses.replace(self, **changes)

    def natural_frequencies_hz(self) -> np.ndarray:
        """Undamped natural frequencies of the reduced model, shape (n_R,) [Hz], ascending."""
        return natural_frequencies_hz(self.m, self.k)

    def reconstruct(self, q_r: Any) -> np.ndarray:
        """Full-model displacements ``q = T q_R``: :func:`vlab.reduction.model.reconstruct_from` with this model's basis ``T``.

        Parameters ``q_r`` (reduced coordinates, the master displacements,
        shape (n_R,) or (n_R, n_t)), the result and the errors: as
        :func:`vlab.reduction.model.reconstruct_from`.
        """
        return reconstruct_from(self.T, q_r)


def reconstruct_from(t: np.ndarray, q_r: Any) -> np.ndarray:
    """Full-model displacements ``q = T q_R`` of a basis ``t``.

    Parameters
    ----------
    t : ndarray, shape (n, n_R)
        Reduction basis.
    q_r : array_like, shape (n_R,) or (n_R, n_t)
        Reduced coordinates.

    Returns
    -------
    ndarray, shape (n,) or (n, n_t)

    Raises
    ------
    ModelError
        If the leading dimension of ``q_r`` is not ``n_R``.
    """
    arr = np.asarray(q_r)
    if arr.ndim not in (1, 2) or arr.shape[0] != t.shape[1]:
        raise ModelError(f"q_R has shape {arr.shape}, expected ({t.shape[1]},) or ({t.shape[1]}, n_t)")
    return t @ arr
