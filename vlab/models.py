"""The analysis models of a structure: FE model and its reduced models.

Glue between :mod:`vlab.spec`, :mod:`vlab.fe` and :mod:`vlab.reduction`: the
master DOFs of each reduction come from the spec's ``[reduction]`` table
(grid: Sec. 3.3 -- 12 joint translations for the exact reduction; joints
1-9, 12 and the bearing rotations for Guyan).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from .errors import ReductionError
from .fe import FEModel, build_fe_model
from .reduction import ExactReduction, GuyanReduction, ReducedModel
from .spec import StructureSpec, load_spec

REDUCTIONS = ("full", "exact", "guyan")


@lru_cache(maxsize=8)
def nominal_fe_model(name: str) -> FEModel:
    """FE model of a shipped structure (``"bcc"`` or ``"grid"``), cached. Raises SpecError.

    Parameters
    ----------
    name : str
        Structure name, a file ``assets/structures/<name>.toml``.

    Returns
    -------
    FEModel
        Shared between calls: treat it as read-only.

    Raises
    ------
    SpecError
        For an unknown or invalid structure file.
    ModelError
        If the model cannot be assembled.
    """
    return build_fe_model(load_spec(name))


def master_indices(fe: FEModel, method: str) -> list[int]:
    """Global indices of the spec's master DOFs for ``method`` ("exact" or "guyan").

    Parameters
    ----------
    fe : FEModel
        The full FE model; ``fe.spec.master_dofs`` lists the masters as
        ``(point, dof)`` pairs (grid: Sec. 3.3).
    method : str
        ``"exact"`` or ``"guyan"``.

    Returns
    -------
    list of int, length n_R
        Indices into the model's free DOFs, in the spec's order.

    Raises
    ------
    ReductionError
        If the spec defines no master set for ``method``.
    ModelError
        If a master DOF is not a free DOF of the model.
    """
    spec: StructureSpec = fe.spec
    if method not in spec.master_dofs:
        raise ReductionError(
            f"{spec.name}: no master DOFs for the {method!r} reduction in the spec's [reduction] table"
        )
    return [fe.dofs.index(p, d) for p, d in spec.master_dofs[method]]


def reduce_model(fe: FEModel, method: str, *, zeta: np.ndarray | None = None) -> ReducedModel:
    """Reduce ``fe`` with the spec's master set.

    Parameters
    ----------
    fe : FEModel
        The full FE model, with the spec's master sets.
    method : {"exact", "guyan"}
        Exact reduction (Eqs. 3.5-3.8) or Guyan condensation (Sec. 3.1.2).
    zeta : ndarray, shape (n_R,), optional
        Modal damping ratios for the exact reduction's damping matrix (Eq. 3.6).

    Returns
    -------
    ReducedModel

    Raises
    ------
    ReductionError
        For an unknown method or master set, or a singular partition.
    """
    idx = master_indices(fe, method)
    labels = list(fe.dofs.labels)
    if method == "exact":
        return ExactReduction(fe.m, fe.k, idx, labels=labels, zeta=zeta).reduce()
    if method == "guyan":
        return GuyanReduction(fe.m, fe.k, idx, labels=labels).reduce()
    raise ReductionError(f"unknown reduction {method!r}; use one of {REDUCTIONS[1:]}")
