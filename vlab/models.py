"""The analysis models of a structure: FE model and its reduced models.

Glue between :mod:`vlab.spec`, :mod:`vlab.fe` and :mod:`vlab.reduction`: the
master DOFs of each reduction come from the spec's ``[reduction]`` table
(grid: Sec. 3.3 -- 12 joint translations for the exact reduction; joints
1-9, 12 and the bearing rotations for Guyan).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from .errors import ModelError, ReductionError
from .fe import FEModel, build_fe_model
from .fe.modal import unresolved_modes
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
    return check_fe_model(build_fe_model(load_spec(name)))


def _dominant_dofs(fe: FEModel, vectors: np.ndarray, n_max: int = 3) -> str:
    """The DOF labels with the largest summed |component| over the columns of ``vectors``."""
    weight = np.abs(vectors).sum(axis=1)
    order = np.argsort(weight)[::-1][:n_max]
    return ", ".join(f"{fe.dofs.labels[i][1]} at {fe.dofs.labels[i][0]}" for i in order)


def check_fe_model(fe: FEModel) -> FEModel:
    """Refuse an FE model whose modes double precision cannot resolve.

    A structure definition whose values are each plausible can still give a
    meaningless model (EI x 1e30 gives modes at 0.000 Hz and 3.3e15 Hz). The shipped structures are held (BCC by its cables, the
    grid by its bearings), so every mode has a positive frequency; a mode with an eigenvalue below the resolution
    floor of :func:`vlab.fe.modal.unresolved_modes` (``100 n eps
    lambda_max``) is either a rigid-body (mechanism) mode -- a support or a
    connection is missing -- or a sign that the stiffnesses span more
    decades than double precision resolves.

    Parameters
    ----------
    fe : FEModel
        The assembled model. Its spec's ``supports`` and ``strings`` (each
        string runs to a ground anchor) tell whether it is held: a spec
        with neither is free-free and its rigid-body modes are allowed
        (only non-finite or negative eigenvalues beyond round-off are
        refused).

    Returns
    -------
    FEModel
        ``fe`` unchanged.

    Raises
    ------
    ModelError
        Naming the structure, the unresolved modes (number, frequency [Hz]),
        the DOFs where they move and the DOFs of the stiffest mode:
        non-finite matrices; an eigenvalue below ``-floor`` (negative
        stiffness beyond round-off); an eigenvalue in ``[-floor, floor)`` in
        a structure with supports.

    Source: Eq. (3.4); resolution bound in :func:`vlab.fe.modal.unresolved_modes`.
    """
    name = fe.spec.name
    try:
        lam, phi, floor = unresolved_modes(fe.m, fe.k)
    except ModelError as exc:
        raise ModelError(f"structure {name!r}: {exc}") from None
    lam_max = float(lam[-1])
    neg = np.flatnonzero(lam < -floor)
    if neg.size:
        raise ModelError(
            f"structure {name!r}: {neg.size} mode(s) with negative eigenvalue beyond round-off "
            f"(lowest {lam[0]:.3g} rad^2/s^2; negative stiffness, e.g. a compressive pre-stress above "
            f"buckling), moving mostly {_dominant_dofs(fe, phi[:, neg])}")
    low = np.flatnonzero(lam < floor)
    if low.size and (fe.spec.supports or fe.spec.strings):
        f_hz = np.sqrt(np.clip(lam[low], 0.0, None)) / (2 * np.pi)
        f_max = np.sqrt(lam_max) / (2 * np.pi)
        raise ModelError(
            f"structure {name!r}: {low.size} mode(s) that double precision cannot resolve to 1 % "
            f"(eigenvalue < {floor / lam_max:.2g} x the largest; mode(s) {', '.join(str(i + 1) for i in low[:6])} "
            f"at {', '.join(f'{f:.3g}' for f in f_hz[:6])} Hz, highest mode {f_max:.3g} Hz) although the "
            f"structure is held by supports or strings: a rigid-body mode (support or connection missing) "
            f"or stiffnesses spanning too many decades (a value with a wrong unit or exponent?). The unresolved modes move mostly {_dominant_dofs(fe, phi[:, low])}; "
            f"the stiffest mode is at {_dominant_dofs(fe, phi[:, -1:], 2)}")
    return fe


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
