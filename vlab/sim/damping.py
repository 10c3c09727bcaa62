"""Damping of the MuJoCo plant: hinge damping for stability plus the spec's modal damping.

Two parts:

1. **Stiffness-proportional hinge damping** ``c_j = beta * k_j`` on every hinge
   spring of the discretisation (joint ``damping``, integrated implicitly). It
   damps the chain's high, unphysical modes; for a mode ``r`` it adds
   ``zeta_beta,r = phi_r^T C_beta phi_r / (2 omega_r)`` (``phi_r``
   mass-normalised), which grows with frequency. The default ``beta`` keeps this
   at most 20 % of the smallest target ratio at the highest damped mode.

2. **Modal damping** of the spec (Table 1 / Table 3 experimental ratios). A
   diagonal joint damping cannot reproduce given modal ratios (it is diagonal
   in relative joint angles, the modes are not), so each damped mode ``r`` gets
   one *fixed tendon* whose length is the modal coordinate ``eta_r = (M
   phi_r)^T q`` and whose damping is ``c_r = 2 zeta_r omega_r - zeta_beta,r 2
   omega_r`` (clipped at 0). The damping matrix becomes
   ``C = C_beta + sum_r c_r (M phi_r)(M phi_r)^T``, so
   ``phi_s^T C phi_r = 2 zeta_r omega_r delta_rs`` for the damped modes
   (plus the small cross terms of ``C_beta``): the target ratios are met
   exactly in the linear range around the settled state, and the modes are
   unchanged. Modes above the damped set keep ``beta`` damping only.

Which plant mode is "mode r" of the spec is decided by pairing with the FE
modes (MAC at the structure points, :func:`vlab.sim.crosscheck.pair_modes`):
plant modes with no FE partner (the crosspiece arms' anti-symmetric bending,
which the FE's single-DOF crosspiece lacks) get the spec's ``default_ratio``.

Source: modal damping as in Sec. 2.1.2 ("proportional damping equivalent to
the measured open loop inherent damping"); MuJoCo fixed tendons
(``doc/XMLreference.rst``, tendon/fixed) and implicit damping
(``doc/computation/index.rst``).
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from ..errors import SimulationError
from ..spec import StructureSpec


@dataclass(frozen=True)
class DampingReport:
    """How the plant's damping was set.

    Attributes
    ----------
    beta_s : float
        Stiffness-proportional factor of the hinge damping [s].
    frequencies_hz : ndarray, shape (n_damped,)
        Undamped frequencies of the damped plant modes [Hz].
    target_ratios : ndarray, shape (n_damped,)
        Damping ratio imposed on each [-].
    spec_modes : tuple of int or None
        Spec (FE) mode number of each damped plant mode (None: unpaired, default ratio).
    beta_ratios : ndarray, shape (n_damped,)
        Part of the ratio already given by the hinge damping [-].
    tendon_damping : ndarray, shape (n_damped,)
        Damping ``c_r`` of each modal tendon [1/s for a mass-normalised coordinate].
    """

    beta_s: float
    frequencies_hz: np.ndarray
    target_ratios: np.ndarray
    spec_modes: tuple
    beta_ratios: np.ndarray
    tendon_damping: np.ndarray


def _elastic_stiffness(model: mujoco.MjModel) -> np.ndarray:
    """Diagonal of the hinge-spring stiffness of discretisation joints (``*.bend``/``*.twist``), shape (nv,)."""
    k = np.zeros(model.nv)
    for j in range(model.njnt):
        name = model.joint(j).name
        if name.endswith(".bend") or name.endswith(".twist"):
            k[model.jnt_dofadr[j]] = model.jnt_stiffness[j, 0] if model.jnt_stiffness.ndim == 2 else model.jnt_stiffness[j]
    return k


def _targets(spec: StructureSpec, plant_modes, n_damped: int | None):
    """Damping targets for the plant modes up to the highest damped spec mode."""
    from ..fe import build_fe_model, modal_analysis
    from .crosscheck import pair_modes

    dmp = spec.damping
    n_spec = n_damped if n_damped is not None else len(dmp.modal_ratios)
    fe = build_fe_model(spec)
    fem = modal_analysis(fe.m, fe.k, n_spec)
    pts = [p for p in plant_modes.points]
    rows = [fe.dofs.index(p, "w") for p in pts]
    pairs = pair_modes(fem.shapes[rows, :], plant_modes.shapes)
    ratio_of = {}
    for r, (j, _mac) in enumerate(pairs):
        if j is not None:
            ratio_of[j] = (r + 1, dmp.modal_ratios[r] if r < len(dmp.modal_ratios) else dmp.default_ratio)
    paired = [j for j, _ in pairs if j is not None]
    if not paired:
        raise SimulationError(f"{spec._file()}: no plant mode pairs with an FE mode: cannot place modal damping")
    top = max(paired)
    idx = list(range(top + 1))
    spec_modes = tuple(ratio_of[j][0] if j in ratio_of else None for j in idx)
    ratios = np.array([ratio_of[j][1] if j in ratio_of else dmp.default_ratio for j in idx])
    return np.array(idx), ratios, spec_modes


def default_beta(ratios: np.ndarray, omega: np.ndarray, fraction: float = 0.2) -> float:
    """Default hinge damping factor ``beta`` [s].

    ``beta = fraction * 2 * min(zeta) / max(omega)``: pure stiffness-proportional
    damping would give ``zeta = beta omega / 2``, so at the highest damped mode
    the hinge damping stays below ``fraction`` of the smallest target ratio.

    Parameters
    ----------
    ratios : ndarray, shape (k,)
        Target damping ratios [-].
    omega : ndarray, shape (k,)
        Their natural frequencies [rad/s].
    fraction : float
        Share of the smallest target allowed.

    Returns
    -------
    float
    """
    return float(fraction * 2.0 * np.min(ratios) / np.max(omega))


def modal_damping_plan(spec: StructureSpec, model: mujoco.MjModel, beta: float | None,
                       n_damped: int | None = None):
    """Settle and linearise the undamped plant, choose ``beta`` and the modal tendons.

    Parameters
    ----------
    spec : StructureSpec
    model : mujoco.MjModel
        The plant without damping (``beta = 0``, no modal tendons).
    beta : float or None
        Hinge damping factor [s]; None chooses :func:`default_beta`.
    n_damped : int, optional
        Number of spec modes damped (default: all ratios given).

    Returns
    -------
    beta : float
    tendons : list of (name, coefficients (nv,), damping, info)
    report : DampingReport

    Raises
    ------
    SimulationError
        If no plant mode matches an FE mode, or the plant does not settle.
    """
    from .linearize import modes, settle

    data = settle(model)
    pts = sorted(spec.points)
    pm = modes(model, pts, data=data)
    idx, ratios, spec_modes = _targets(spec, pm, n_damped)
    omega = pm.omega[idx]
    if beta is None:
        beta = default_beta(ratios, omega)
    k = _elastic_stiffness(model)
    phi = pm.joint_shapes[:, idx]
    beta_part = beta * np.einsum("ir,i,ir->r", phi, k, phi) / (2 * omega)
    c = np.clip(2 * omega * (ratios - beta_part), 0.0, None)
    mphi = pm.mass_matrix @ phi
    tendons = []
    for r in range(len(idx)):
        coef = mphi[:, r]
        tendons.append((f"damping.mode{r + 1}", coef, float(c[r]),
                        f"modal damping of plant mode {r + 1} ({pm.frequencies_hz[idx[r]]:.4g} Hz, "
                        f"spec mode {spec_modes[r]}): zeta = {ratios[r]:.4g} "
                        f"(hinge damping gives {beta_part[r]:.3g})"))
    report = DampingReport(float(beta), pm.frequencies_hz[idx], ratios, spec_modes, beta_part, c)
    return float(beta), tendons, report


def add_modal_tendons(ms: mujoco.MjSpec, model: mujoco.MjModel, tendons) -> None:
    """Add the modal damping tendons to an MjSpec (joint names from ``model``)."""
    names = [model.joint(int(model.dof_jntid[i])).name for i in range(model.nv)]
    for name, coef, c, info in tendons:
        t = ms.add_tendon(name=name)
        cmax = float(np.max(np.abs(coef)))
        for i, v in enumerate(coef):
            if abs(v) > 1e-9 * cmax:
                t.wrap_joint(names[i], float(v))
        t.damping = [c, 0.0, 0.0]
        t.stiffness = [0.0, 0.0, 0.0]
        t.springlength = [0.0, 0.0]
        t.info = info
