"""Damping of the MuJoCo plant: hinge damping for stability plus the spec's modal damping.

Two parts:

1. **Stiffness-proportional hinge damping** ``c_j = beta * k_j`` on every hinge
   spring of the discretisation (joint ``damping``, integrated implicitly by
   MuJoCo). It damps the chain's high, unphysical modes; for a mode ``r`` it
   gives ``zeta_beta,r = phi_r^T C_beta phi_r / (2 omega_r)`` (``phi_r``
   mass-normalised), growing with frequency. The default ``beta`` keeps this
   at most 20 % of the smallest target ratio at the highest damped mode.

2. **Modal damping** of the spec (Table 1 / Table 3 experimental ratios). A
   joint damping cannot reproduce given modal ratios: it is diagonal in
   relative joint angles and the modes are not, and a pendulum-like first mode
   barely bends any hinge (a least-squares fit of hinge and grounded dampers
   misses the BCC's and the grid's ratios by 20-60 %). The plant therefore
   carries the exact modal damping matrix of the damped modes,

   ``C_m = sum_r c_r (M phi_r)(M phi_r)^T``,  ``c_r = 2 omega_r (zeta_r - zeta_beta,r)``,

   (``M`` and ``phi_r`` of the settled, undamped plant in joint coordinates),
   so that ``phi_s^T (C_beta + C_m) phi_r = 2 zeta_r omega_r delta_rs`` for
   the damped modes (plus the tiny cross terms of ``C_beta``) and the modes are
   unchanged. Two realisations:

   * ``"applied"`` (default): the force ``-C_m qvel = -A diag(c) A^T qvel``
     (``A = M Phi``, shape (nv, N)) is set as ``qfrc_applied`` before every
     step by :class:`vlab.sim.runtime.MujocoPlant` (and by the checks of
     :mod:`vlab.sim.checks`); ``A`` and ``c`` are stored in the model as the
     custom numerics ``vlab_modal_A`` and ``vlab_modal_c``, so an exported MJCF
     carries them, and :func:`vlab.sim.linearize.linearize` adds them to the
     linearisation. Explicit, and stable while ``dt * max(c) << 2``. Costs two
     (nv x N) products per step, or one (nv x nv) product on a small plant
     (:attr:`vlab.sim.damping_matrix.ModalDamping.dense`; the matrix and its storage live in
     :mod:`vlab.sim.damping_matrix`).
   * ``"tendons"``: one fixed tendon per mode with coefficients ``M phi_r`` and
     damping ``c_r`` -- native MuJoCo, but every coefficient of a fixed tendon
     is evaluated each step at a cost that grows with the square of its count
     (the grid: several times slower than the plant itself).

   Sparse tendons (a few joints, bi-orthogonal to the damped modes) were tried
   and rejected: they couple the damped modes to the chain's high modes and
   miss some ratios by 20-60 %.

Which plant mode is "mode r" of the spec is decided by pairing with the FE
modes (MAC at the structure points, one-to-one over a common band,
:func:`vlab.sim.pairing.pair_band`);
plant modes without FE partner below the highest damped one (the crosspiece
arms' anti-symmetric bending, absent from the FE's single-DOF crosspiece) get
the spec's ``default_ratio``, and so do all plant modes up to
``ABOVE_DAMPED`` times the highest damped FE mode's frequency, as the FE
model gives the default ratio to every mode beyond the listed ones.

Source: modal damping as in Sec. 2.1.2 ("proportional damping equivalent to
the measured open loop inherent damping"); MuJoCo ``qfrc_applied``, custom
numerics and fixed tendons (``doc/XMLreference.rst``); implicit joint damping
(``doc/computation/index.rst``).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import mujoco
import numpy as np

from ..errors import SimulationError
from ..spec import StructureSpec
from .damping_matrix import ModalDamping
from .linearize import modes, settle
from .pairing import pair_band

#: Modal damping realisations.
METHODS = ("applied", "tendons", "none")


@dataclass(frozen=True)
class DampingReport:
    """How the plant's damping was set.

    Attributes
    ----------
    method : str
        ``"applied"`` or ``"tendons"``.
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
    modal_damping : ndarray, shape (n_damped,)
        ``c_r`` [1/s] per mass-normalised modal coordinate.
    """

    method: str
    beta_s: float
    frequencies_hz: np.ndarray
    target_ratios: np.ndarray
    spec_modes: tuple
    beta_ratios: np.ndarray
    modal_damping: np.ndarray


def _elastic_stiffness(model: mujoco.MjModel) -> np.ndarray:
    """Diagonal of the spring stiffness of discretisation joints (``*.bend``, ``*.twist``, ``*.shear``), shape (nv,)."""
    k = np.zeros(model.nv)
    for j in range(model.njnt):
        name = model.joint(j).name
        if name.endswith((".bend", ".twist", ".shear")):
            k[model.jnt_dofadr[j]] = model.jnt_stiffness[j]
    return k


#: Plant modes up to this factor times the highest damped FE mode's frequency are damped (the default ratio
#: if unpaired). A chosen margin, not fitted: it covers the grid's modes 13-14 (10.2-12 Hz, just above its
#: 10 Hz test band) and leaves the BCC's modes above 28 Hz to the hinge damping (README: LQG on the MuJoCo BCC).
ABOVE_DAMPED = 1.25


def _targets(spec: StructureSpec, plant_modes, n_damped: int | None):
    """Damping targets for the plant modes up to the highest damped spec mode.

    The spec's modes 1..n are paired with plant modes one-to-one over a
    common band (:func:`vlab.sim.pairing.pair_band`: the FE modes just
    above mode n take part in the assignment, so that a plant mode whose own
    FE partner is mode n+1 is not labelled mode n).

    Parameters
    ----------
    spec : StructureSpec
        Its ``damping`` gives the ratios; its FE model the modes to pair with.
    plant_modes : SimModes
        All modes of the settled, undamped plant (shapes at ``plant_modes.points``).
    n_damped : int or None
        Spec modes damped (None: as many as ``spec.damping.modal_ratios``).

    Returns
    -------
    idx : ndarray of int, shape (k,)
        Plant modes (0-based) that get modal damping: all up to the highest one needed.
    ratios : ndarray, shape (k,)
        Their target damping ratios [-].
    spec_modes : tuple of (int or None), length k
        The spec mode (1-based, <= n) of each, None where it gets the default ratio.

    Raises
    ------
    SimulationError
        If ``n_damped`` exceeds the FE model's modes or no plant mode pairs with a damped FE mode.
    """
    from ..fe import build_fe_model, modal_analysis

    dmp = spec.damping
    n_spec = n_damped if n_damped is not None else len(dmp.modal_ratios)
    fe = build_fe_model(spec)
    fem = modal_analysis(fe.m, fe.k)
    if not 1 <= n_spec <= fem.frequencies_hz.size:
        raise SimulationError(f"{spec._file()}: {n_spec} damped modes, but the FE model has "
                              f"{fem.frequencies_hz.size}: cannot place modal damping")
    keep = [i for i, p in enumerate(plant_modes.points) if (p, "w") in fe.dofs]
    rows = [fe.dofs.index(plant_modes.points[i], "w") for i in keep]
    bp = pair_band(fem.frequencies_hz, fem.shapes[rows, :], plant_modes.frequencies_hz,
                   plant_modes.shapes[keep, :], n_spec)
    pairs = bp.fe_to_sim[:n_spec]
    f_top = float(fem.frequencies_hz[n_spec - 1])
    ratio_of = {}
    for r, j in enumerate(pairs):
        if j is not None:
            ratio_of[j] = (r + 1, dmp.modal_ratios[r] if r < len(dmp.modal_ratios) else dmp.default_ratio)
    paired = [j for j in pairs if j is not None]
    if not paired:
        raise SimulationError(f"{spec._file()}: no plant mode pairs with an FE mode: cannot place modal damping")
    # every plant mode up to ABOVE_DAMPED x the highest damped FE mode gets at least the default ratio, paired
    # or not, as every FE mode does (vlab.fe.damping.open_loop_ratios): a changed spec can move a mode down into the band
    # from above, or mix two close modes so that the MAC pairing misses one; with the hinge damping alone
    # (~0.1 x the smallest ratio) such a mode would ring far longer than in the FE model
    below = np.flatnonzero(plant_modes.frequencies_hz <= ABOVE_DAMPED * f_top)
    top = max(max(paired), int(below.max()) if below.size else 0)
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
                       n_damped: int | None = None, *, method: str = "applied"):
    """Settle and linearise the undamped plant; choose ``beta`` and the modal damping.

    Parameters
    ----------
    spec : StructureSpec
    model : mujoco.MjModel
        The plant without damping (``beta = 0``).
    beta : float or None
        Hinge damping factor [s]; None chooses :func:`default_beta`.
    n_damped : int, optional
        Number of spec modes damped (default: all ratios given).
    method : str
        ``"applied"`` or ``"tendons"`` (recorded in the report).

    Returns
    -------
    beta : float
    damping : ModalDamping
    report : DampingReport
    modes : SimModes
        All modes of the plant as damped: the undamped plant's frequencies and
        shapes (the modal damping is diagonal in them, the hinge damping nearly
        so) with the designed ratios, ``beta phi^T k phi / (2 omega) + c / (2 omega)``.

    Raises
    ------
    SimulationError
        If no plant mode matches an FE mode, or the plant does not settle.
    """
    data = settle(model)
    pm = modes(model, sorted(spec.points), data=data)
    idx, ratios, spec_modes = _targets(spec, pm, n_damped)
    omega = pm.omega[idx]
    if beta is None:
        beta = default_beta(ratios, omega)
    k = _elastic_stiffness(model)
    phi = pm.joint_shapes[:, idx]
    beta_part = beta * np.einsum("ir,i,ir->r", phi, k, phi) / (2 * omega)
    c = np.clip(2 * omega * (ratios - beta_part), 0.0, None)
    md = ModalDamping(pm.mass_matrix @ phi, c)
    report = DampingReport(method, float(beta), pm.frequencies_hz[idx], ratios, spec_modes, beta_part, c)
    zeta = beta * np.einsum("ir,i,ir->r", pm.joint_shapes, k, pm.joint_shapes) / (2 * pm.omega)
    zeta[idx] += c / (2 * omega)
    return float(beta), md, report, dataclasses.replace(pm, damping_ratios=zeta)


def projected_modes(spec: StructureSpec, model: mujoco.MjModel, dof_damping: np.ndarray, md: ModalDamping):
    """The modes of an undamped plant with the ratios a given damping matrix gives them.

    ``zeta_r = phi_r^T (diag(dof_damping) + A diag(c) A^T) phi_r / (2 omega_r)`` (diagonal projection, the
    cross terms left out): the ratios of a changed structure that kept the unchanged one's hinge damping
    and modal damping matrix (:mod:`vlab.fe.damping`).

    Parameters
    ----------
    spec : StructureSpec
        Its points give the shapes' rows.
    model : mujoco.MjModel
        The changed plant without damping.
    dof_damping : ndarray, shape (nv,)
        Joint damping [N*s/m or N*m*s/rad] per DOF.
    md : ModalDamping
        The modal damping matrix, shape (nv, N) for ``A``.

    Returns
    -------
    SimModes
        As :func:`vlab.sim.linearize.modes`, with ``damping_ratios``.

    Raises
    ------
    SimulationError
        The plant does not settle.
    """
    pm = modes(model, sorted(spec.points), data=settle(model))
    phi = pm.joint_shapes
    c_phi = np.einsum("ir,i,ir->r", phi, np.asarray(dof_damping, dtype=float), phi)
    c_phi += np.sum((md.A.T @ phi) ** 2 * md.c[:, None], axis=0)
    return dataclasses.replace(pm, damping_ratios=c_phi / (2 * pm.omega))


def add_modal_tendons(ms: mujoco.MjSpec, model: mujoco.MjModel, md: ModalDamping, report: DampingReport) -> None:
    """Add one fixed tendon per damped mode (coefficients ``M phi_r``, damping ``c_r``).

    Parameters
    ----------
    ms : mujoco.MjSpec
        The plant's spec (modified).
    model : mujoco.MjModel
        The compiled plant the modes were computed on (joint names, DOF order).
    md : ModalDamping
    report : DampingReport
        For the tendons' ``info``.
    """
    names = [model.joint(int(model.dof_jntid[i])).name for i in range(model.nv)]
    for r in range(md.c.size):
        col = md.A[:, r]
        t = ms.add_tendon(name=f"damping.mode{r + 1}")
        for i, v in enumerate(col):
            if abs(v) > 1e-12 * np.abs(col).max():
                t.wrap_joint(names[i], float(v))
        t.damping = [float(md.c[r]), 0.0, 0.0]
        t.springlength = [0.0, 0.0]
        t.info = (f"modal damping of plant mode {r + 1} ({report.frequencies_hz[r]:.4g} Hz, spec mode "
                  f"{report.spec_modes[r]}): zeta = {report.target_ratios[r]:.4g}")
