"""Closed loops of a design applied to any model: damping per plant mode and performance indices.

The dissertation applies controllers to models other than their design model
(Eq. 4.24: a reduced LQG on the full model; Tables 17-18: exact-reduction
controllers on the corrected Guyan model). Here a design's controller is
taken in its transfer form -- ``u = -D y`` (DRF, Eq. 4.30), ``u = -F x``
(LQR, on its own model), or the observer ``x_c' = a x_c + b y``, ``u = -c x_c``
(LQG, Eqs. 4.8-4.11) -- and closed around a plant given as a
:class:`vlab.design.DesignModel`:

- damping ratios of each *plant* mode (open-loop mode paired with its
  closed-loop eigenvalue, :func:`vlab.analysis.closed_loop_modes`), SI;
- performance indices ``J_i = x_E0^T P_E x_E0`` (Eqs. 4.20, 4.26-4.29, 4.33)
  in the thesis's unit system (inch, lbf, centisecond; Sec. 3) with
  ``x_E0 = [x0_i; 0]`` (the observer starts at zero, Eqs. 4.22, 4.29) and
  ``x0_i = [0; phi_i]``, the plant's mode shapes at unit maximum deflection
  (Sec. 4.1.1).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg

from controllers.performance import feedback_performance, performance_index
from controllers.statespace import modal_initial_states, state_space

from ..analysis import closed_loop_modes
from ..design import ControllerDesign, DesignModel, to_thesis_units
from ..errors import ModelError
from ..units import CS_S, INCH_M, LBF_N


@dataclass(frozen=True)
class ThesisPlant:
    """A design model in the thesis's unit system (in, lbf, cs).

    Attributes
    ----------
    A : ndarray, shape (2n, 2n)
    B : ndarray, shape (2n, n_c)
    C : ndarray, shape (n_c, 2n)
        Velocities at the actuators (collocated sensors) [in/cs].
    m, k : ndarray, shape (n, n)
        Mass [lbf*s^2/in] and stiffness [lbf/in] (rotations in rad).
    length_dofs : tuple of int
        Indices of the translational DOFs.
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    m: np.ndarray
    k: np.ndarray
    length_dofs: tuple[int, ...]

    @property
    def n(self) -> int:
        """Number of DOFs."""
        return self.m.shape[0]

    def modal_initial_states(self, n_modes: int) -> np.ndarray:
        """``[0; phi_i]`` for the first ``n_modes`` modes, unit maximum deflection [in], shape (2n, n_modes)."""
        return modal_initial_states(self.m, self.k, n_modes, length_dofs=list(self.length_dofs))


def actuator_input(dm: DesignModel) -> np.ndarray:
    """Load distribution ``U`` of a design model's actuators.

    Parameters
    ----------
    dm : DesignModel

    Returns
    -------
    ndarray, shape (n, n_c)
        ``U[actuator_rows[j], j] = 1``.
    """
    u = np.zeros((dm.m.shape[0], len(dm.actuator_rows)))
    for j, r in enumerate(dm.actuator_rows):
        u[r, j] = 1.0
    return u


def thesis_plant(dm: DesignModel) -> ThesisPlant:
    """State space of ``dm`` in the thesis's units (Eqs. 3.2-3.3, time unit cs).

    Parameters
    ----------
    dm : DesignModel
        SI model; converted with :func:`vlab.design.to_thesis_units`.

    Returns
    -------
    ThesisPlant
    """
    m, c, k = (to_thesis_units(a, dm.labels) for a in (dm.m, dm.c, dm.k))
    ss = state_space(m, c, k, actuator_input(dm), time_unit_s=CS_S)
    length = tuple(i for i, (_p, d) in enumerate(dm.labels) if d == "w")
    return ThesisPlant(np.asarray(ss.A), np.asarray(ss.B), np.asarray(ss.C), m, k, length)


def thesis_controller(design: ControllerDesign) -> dict:
    """A design's controller in the thesis's units (``y`` in in/cs, ``u`` in lbf, time in cs).

    Parameters
    ----------
    design : ControllerDesign

    Returns
    -------
    dict
        ``{"d": D}`` (DRF), ``{"f": F}`` (LQR, state feedback on its own
        design model) or ``{"a", "b", "c"}`` (observer-based controller).

    Notes
    -----
    From the SI controller (seconds): with ``y_SI = y (INCH_M / CS_S)`` and
    ``tau = t / CS_S``: ``D = D_SI INCH_M / (CS_S LBF_N)``,
    ``a = CS_S a_SI``, ``b = INCH_M b_SI``, ``c = c_SI / LBF_N``. The
    controller's state keeps the SI basis of ``design.continuous`` (SI
    estimate of ``[q'; q]``), a similarity transform of the thesis's: the
    transfer function ``K(s)`` and every closed-loop quantity with a zero
    initial controller state are unchanged.
    """
    cont = design.continuous
    if "d" in cont:
        return {"d": np.asarray(cont["d"]) * INCH_M / (CS_S * LBF_N)}
    if {"a", "b", "c"} <= set(cont):
        return {"a": np.asarray(cont["a"]) * CS_S, "b": np.asarray(cont["b"]) * INCH_M,
                "c": np.asarray(cont["c"]) / LBF_N}
    if "gain_thesis_lbf_per_thesis_state" in design.extra:
        return {"f": np.asarray(design.extra["gain_thesis_lbf_per_thesis_state"])}
    raise ModelError(f"design {design.controller} on {design.model} has no controller to close a loop with")


def performance_indices(plant: ThesisPlant, ctrl: dict, q: np.ndarray, r: np.ndarray, n_modes: int,
                        *, initial_states: np.ndarray | None = None) -> np.ndarray:
    """``J_i`` for initial conditions in the shape of the plant's first ``n_modes`` modes (thesis units).

    Parameters
    ----------
    plant : ThesisPlant
    ctrl : dict
        From :func:`thesis_controller`.
    q : ndarray, shape (2n, 2n)
        State weight (Table 13: 0.01 I; Table 14: diag(m, k)).
    r : ndarray, shape (n_c, n_c)
        Control weight.
    n_modes : int
    initial_states : ndarray, shape (2n, n_modes), optional
        Overrides the plant's modal initial states.

    Returns
    -------
    ndarray, shape (n_modes,)
        ``J_i``; ``inf`` where the closed loop is not asymptotically stable.

    Raises
    ------
    ModelError
        A state feedback whose size does not fit the plant.

    Source: static feedback (DRF ``F = D C``, LQR) by
    :func:`controllers.performance.feedback_performance` (Eqs. 4.33-4.36);
    a dynamic (observer) controller on ``[x; x_c]`` with ``Q_E =
    diag(Q, C_c^T R C_c)`` (Eqs. 4.16-4.20, 4.26-4.29).
    """
    x0 = plant.modal_initial_states(n_modes) if initial_states is None else initial_states
    a, b, c = plant.A, plant.B, plant.C
    if "d" in ctrl or "f" in ctrl:
        f = ctrl["d"] @ c if "d" in ctrl else ctrl["f"]
        if f.shape[1] != a.shape[0]:
            raise ModelError(f"state feedback of size {f.shape} cannot close a plant of order {a.shape[0]}")
        return np.asarray(feedback_performance(a, b, f, q, r, x0))
    ac, bc, cc = ctrl["a"], ctrl["b"], ctrl["c"]
    a_e = np.block([[a, -b @ cc], [bc @ c, ac]])
    xe = np.vstack([x0, np.zeros((ac.shape[0], x0.shape[1]))])
    return np.asarray(performance_index(a_e, scipy.linalg.block_diag(q, cc.T @ r @ cc), xe))


def plant_mode_damping(dm: DesignModel, design: ControllerDesign | None, n_modes: int) -> tuple[np.ndarray, np.ndarray]:
    """Closed-loop frequency [Hz] and damping ratio of the plant's first ``n_modes`` modes (SI).

    Parameters
    ----------
    dm : DesignModel
        The plant.
    design : ControllerDesign or None
        None: open loop.
    n_modes : int

    Returns
    -------
    freq_hz, zeta : ndarray, shape (n_modes,)

    Source: Eqs. (4.16), (4.24), (4.35); modes paired by eigenvector overlap.
    """
    u = actuator_input(dm)
    ctrl = None if design is None else design.continuous
    f, z = closed_loop_modes(dm.m, dm.c, dm.k, u, u.T, ctrl)
    return np.asarray(f)[:n_modes], np.asarray(z)[:n_modes]
