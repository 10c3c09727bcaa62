"""The design model: the full FE model or a reduction of it in SI with its DOF labels
(:func:`design_model`), and its conversion to the thesis unit system (in, lbf, cs; Sec. 3.1).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ReductionError
from ..fe import FEModel
from ..fe.damping import modal_damping_matrix, open_loop_ratios
from ..models import master_indices, reduce_model
from ..units import CS_S, INCH_M, LBF_N
from .settings import DESIGN_MODELS


@dataclass(frozen=True)
class DesignModel:
    """A second-order model in SI with its DOF labels (the design basis).

    ``m q'' + c q' + k q = U u`` (Eq. 3.1) on n_d DOFs: the full FE model or a
    reduced one.

    Attributes
    ----------
    name : str
        ``"full"``, ``"exact"``, ``"guyan"`` or ``"corrected-guyan"``.
    m : ndarray, shape (n_d, n_d)
        Mass matrix [kg] (rotational DOFs [kg*m^2]).
    c : ndarray, shape (n_d, n_d)
        Damping matrix [N*s/m] (open-loop modal damping of the spec).
    k : ndarray, shape (n_d, n_d)
        Stiffness matrix [N/m] (rotational DOFs [N*m/rad]).
    labels : tuple of (node, dof), length n_d
        Label of every DOF, e.g. ``(5, "w")``.
    actuator_rows : tuple of int, length n_c
        Index of each actuator's ``w`` DOF in the model, in actuator order
        (the non-zero rows of U).
    """

    name: str
    m: np.ndarray
    c: np.ndarray
    k: np.ndarray
    labels: tuple
    actuator_rows: tuple[int, ...]


def _unit_scaling(labels) -> np.ndarray:
    """diag S with q_SI = S q_thesis: inch for translations, 1 for rotations."""
    return np.array([INCH_M if dof == "w" else 1.0 for _node, dof in labels])


def state_scaling(labels) -> np.ndarray:
    """SI value of one thesis state unit, shape (2 n_d,): ``x_SI = s_x * x_thesis`` for ``x = [q'; q]``.

    Velocities: 1 in/cs = 0.0254 / 0.01 m/s, 1 rad/cs = 100 rad/s; positions:
    1 in = 0.0254 m, 1 rad = 1 rad (Sec. 3.1 units).

    Parameters
    ----------
    labels : sequence of (node, dof), length n_d
        DOF labels of the design model; ``"w"`` is a translation, any other dof a rotation.
    """
    s = _unit_scaling(labels)
    return np.concatenate([s / CS_S, s])


def state_labels(labels) -> tuple[str, ...]:
    """Names and SI units of the states ``x = [q'; q]`` of a design model (Eqs. 3.2-3.3).

    Parameters
    ----------
    labels : sequence of (node, dof), length n_d
        DOF labels of the design model; ``"w"`` is a translation [m], any
        other dof a rotation [rad].

    Returns
    -------
    tuple of str, length 2 n_d
        ``"d<dof>/dt@<node> [m/s]"`` (or ``[rad/s]``) for the velocities, then
        ``"<dof>@<node> [m]"`` (or ``[rad]``) for the displacements.
    """
    vel = tuple(f"d{d}/dt@{nd} [{'m/s' if d == 'w' else 'rad/s'}]" for nd, d in labels)
    pos = tuple(f"{d}@{nd} [{'m' if d == 'w' else 'rad'}]" for nd, d in labels)
    return vel + pos


def performance_index_si(j_thesis) -> np.ndarray:
    """A performance index of the thesis unit system in SI: initial conditions of 1 m peak deflection, time in s.

    ``J_i`` of a design (Eqs. 4.7, 4.20, 4.33; :attr:`vlab.design.ControllerDesign.performance_index_thesis_units`) is
    ``int (x^T Q x + u^T R u) dtau`` in the thesis states (in/cs, rad/cs, in, rad), lbf and centiseconds,
    from ``x0 = [0; phi_i]`` with a peak deflection of 1 in. With the weights written in SI,
    ``Q_SI = S^-1 Q S^-1`` (``S`` the SI value of one thesis state unit, :func:`state_scaling`) and
    ``R_SI = R / lbf^2``, the integrand keeps its value and ``dtau = dt / 0.01 s``; scaling ``x0`` to a
    peak of 1 m multiplies ``J`` by ``(1 / 0.0254)^2``::

        J_SI = J_thesis * 0.01 s / 0.0254^2

    Parameters
    ----------
    j_thesis : float or array_like
        ``J`` (or the LQDRF bound ``beta``, the same quantity) in thesis units.

    Returns
    -------
    ndarray
        ``J`` [s] for modal initial conditions of 1 m peak deflection and the SI weights, same shape.
    """
    return np.asarray(j_thesis, dtype=float) * CS_S / INCH_M ** 2


def to_thesis_units(a: np.ndarray, labels) -> np.ndarray:
    """Convert a SI mass/damping/stiffness matrix to in-lbf units: ``S a S / (lbf * in)``.

    ``S = diag(s_i)`` with ``s_i`` = 1 in in metres for translations (``w``)
    and 1 for rotations, so that ``q_SI = S q_thesis`` (Sec. 3.1 units; the
    time unit stays the second here, :func:`controllers.statespace.state_space`
    applies the centisecond).

    Parameters
    ----------
    a : ndarray, shape (n_d, n_d)
        Mass [kg], damping [N*s/m] or stiffness [N/m] matrix (rotational DOFs
        in rad).
    labels : sequence of (node, dof), length n_d
        DOF labels; a dof of ``"w"`` is a translation, anything else a rotation.

    Returns
    -------
    ndarray, shape (n_d, n_d)
        The matrix in lbf*s^2/in, lbf*s/in or lbf/in (rotations in rad).
    """
    s = _unit_scaling(labels)
    return a * np.outer(s, s) / (LBF_N * INCH_M)


def design_model(fe: FEModel, model: str, *, measured_modes=None) -> DesignModel:
    """The SI design model of ``fe``: full, exact, guyan or corrected-guyan.

    Damping: the spec's open-loop modal damping ratios (Tables 1, 3), applied
    as proportional damping on the full model and projected (Guyan) or by
    Eq. 3.6 (exact). ``corrected-guyan`` needs ``measured_modes`` =
    (frequencies_hz (n_m,), shapes (n_R, n_m) at the Guyan masters).

    Parameters
    ----------
    fe : FEModel
        The full FE model; its spec gives the actuators, damping and masters.
    model : str
        ``"full"``, ``"exact"``, ``"guyan"`` or ``"corrected-guyan"`` (Sec. 3).
    measured_modes : (ndarray, ndarray), optional
        Measured frequencies [Hz], shape (n_m,), and mode shapes at the Guyan
        masters, shape (n_R, n_m), for the Baruch correction (Eqs. 3.17-3.20).

    Returns
    -------
    DesignModel

    Raises
    ------
    ReductionError
        Unknown model, or corrected-guyan without measured modes, or masters
        that do not include every actuator.
    """
    spec = fe.spec
    acts = spec.instrumentation.actuators
    ratios = open_loop_ratios(spec, fe.n)
    if model == "full":
        c = modal_damping_matrix(fe.m, fe.k, ratios)
        rows = tuple(fe.dofs.index(p, "w") for p in acts)
        return DesignModel("full", fe.m, c, fe.k, fe.dofs.labels, rows)
    if model not in DESIGN_MODELS:
        raise ReductionError(f"unknown design model {model!r}; use one of {DESIGN_MODELS}")
    base = "exact" if model == "exact" else "guyan"
    idx = master_indices(fe, base)
    labels = tuple(fe.dofs.labels[i] for i in idx)
    if model == "exact":
        red = reduce_model(fe, "exact", zeta=ratios[: len(idx)])
        c = np.asarray(red.c)
    else:
        red = reduce_model(fe, "guyan")
        t = np.asarray(red.T)
        c = t.T @ modal_damping_matrix(fe.m, fe.k, ratios) @ t
    m, k = np.asarray(red.m), np.asarray(red.k)
    if model == "corrected-guyan":
        if measured_modes is None:
            raise ReductionError("corrected-guyan needs measured modes (frequencies and shapes at the Guyan masters)")
        from ..correction import baruch_correction

        freq, shapes = measured_modes
        cor = baruch_correction(m, k, shapes, freq, zeta=ratios[: len(freq)])
        m, k = np.asarray(cor.m), np.asarray(cor.k)
        c = np.asarray(cor.c) if cor.c is not None else c
    try:
        rows = tuple(labels.index((p, "w")) for p in acts)
    except ValueError:
        raise ReductionError(f"{spec.name}: the {model} masters {labels} do not include every actuator {acts}") from None
    return DesignModel(model, m, c, k, labels, rows)
