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

import math

import mujoco
import numpy as np

from ..errors import SimulationError
from ..spec import StructureSpec


#: Largest ``dt * lambda_max(M^-1 C_tendon)`` accepted: the modal tendons' damping is stable even when
#: integrated explicitly (semi-implicit Euler needs < 2).
EXPLICIT_LIMIT = 0.5


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
        Damping ``c_r`` of each modal tendon [N s per unit of the tendon coordinate].
    achieved_ratios : ndarray, shape (n_damped,)
        Ratios of the built plant's linearisation [-] (nan before tuning).
    """

    beta_s: float
    frequencies_hz: np.ndarray
    target_ratios: np.ndarray
    spec_modes: tuple
    beta_ratios: np.ndarray
    tendon_damping: np.ndarray
    achieved_ratios: np.ndarray


def _elastic_stiffness(model: mujoco.MjModel) -> np.ndarray:
    """Diagonal of the spring stiffness of discretisation joints (``*.bend``, ``*.twist``, ``*.shear``), shape (nv,)."""
    k = np.zeros(model.nv)
    for j in range(model.njnt):
        name = model.joint(j).name
        if name.endswith((".bend", ".twist", ".shear")):
            k[model.jnt_dofadr[j]] = model.jnt_stiffness[j]
    return k


def _targets(spec: StructureSpec, plant_modes, n_damped: int | None):
    """Damping targets for the plant modes up to the highest damped spec mode."""
    from ..fe import build_fe_model, modal_analysis
    from .crosscheck import pair_modes

    dmp = spec.damping
    n_spec = n_damped if n_damped is not None else len(dmp.modal_ratios)
    fe = build_fe_model(spec)
    fem = modal_analysis(fe.m, fe.k, n_spec)
    keep = [i for i, p in enumerate(plant_modes.points) if (p, "w") in fe.dofs]
    rows = [fe.dofs.index(plant_modes.points[i], "w") for i in keep]
    pairs = pair_modes(fem.shapes[rows, :], plant_modes.shapes[keep, :])
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
                       n_damped: int | None = None, *, support: int | None = None):
    """Settle and linearise the undamped plant, choose ``beta`` and the modal tendons.

    Each damped mode ``r`` gets a fixed tendon ``b_r^T q`` whose coefficients
    ``b_r`` are bi-orthogonal to the damped modes (``B^T Phi = I``) and live on a
    subset ``J`` of the joints: a pivoted QR of the mass-scaled ``Phi^T`` orders
    the joints, and on ``J`` the solution of least ``M^-1`` norm,
    ``B_J = W Phi_J (Phi_J^T W Phi_J)^-1`` with ``W = ((M^-1)_JJ)^-1``, is taken
    (the dense optimum is ``M Phi``). ``J`` grows until ``dt * lambda_max(M^-1 C)
    <= EXPLICIT_LIMIT``, so the damping stays stable even where the integrator
    treats it explicitly (couplings between branches of the tree). Dense
    coefficients would make every step several times slower: MuJoCo evaluates
    each fixed-tendon coefficient every step. The damping ``c_r = 2 omega_r
    (zeta_r - zeta_beta,r)``; :func:`tune_modal_damping` then corrects the
    coupling through the higher modes.

    Parameters
    ----------
    spec : StructureSpec
    model : mujoco.MjModel
        The plant without damping (``beta = 0``, no modal tendons).
    beta : float or None
        Hinge damping factor [s]; None chooses :func:`default_beta`.
    n_damped : int, optional
        Number of spec modes damped (default: all ratios given).
    support : int, optional
        Joints per tendon (default: the smallest of 1.5 N, 2 N, 3 N, 4 N, nv that
        passes the explicit-stability test).

    Returns
    -------
    beta : float
    tendons : list of (name, {joint name: coefficient}, damping, info)
    report : DampingReport
        Targets before tuning.

    Raises
    ------
    SimulationError
        If no plant mode matches an FE mode, or the plant does not settle.
    """
    import scipy.linalg

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
    n = len(idx)
    beta_part = beta * np.einsum("ir,i,ir->r", phi, k, phi) / (2 * omega)
    c = np.clip(2 * omega * (ratios - beta_part), 0.0, None)
    m = pm.mass_matrix
    minv = np.linalg.inv(m)
    dt = float(model.opt.timestep)
    # joints ordered by how well they observe the damped modes (mass-scaled pivoted QR)
    scale = np.sqrt(np.diag(m))
    _, _, order = scipy.linalg.qr((phi * scale[:, None]).T, pivoting=True)
    sizes = [support] if support is not None else [int(math.ceil(1.5 * n)), 2 * n, 3 * n, 4 * n, model.nv]
    for size in sizes:
        size = min(max(size, n), model.nv)
        joints = np.sort(order[:size])
        w = np.linalg.inv(minv[np.ix_(joints, joints)])
        pj = phi[joints, :]
        bmat = w @ pj @ np.linalg.inv(pj.T @ w @ pj)  # (size, n): B^T Phi = I, least M^-1 norm
        full = np.zeros((model.nv, n))
        full[joints] = bmat
        rho = dt * float(scipy.linalg.eigh(full @ np.diag(c) @ full.T, m, eigvals_only=True,
                                           subset_by_index=(model.nv - 1, model.nv - 1))[0])
        if rho <= EXPLICIT_LIMIT:
            break
    else:
        raise SimulationError(
            f"modal damping: no tendon support keeps the explicit damping stable (h*lambda_max = {rho:.3g}); "
            "reduce the timestep or the number of damped modes"
        )
    names = [model.joint(int(model.dof_jntid[i])).name for i in range(model.nv)]
    tendons = []
    for r in range(n):
        coefs = {names[j]: float(bmat[i, r]) for i, j in enumerate(joints) if abs(bmat[i, r]) > 1e-12}
        tendons.append((f"damping.mode{r + 1}", coefs, float(c[r]),
                        f"modal damping of plant mode {r + 1} ({pm.frequencies_hz[idx[r]]:.4g} Hz, "
                        f"spec mode {spec_modes[r]}): zeta = {ratios[r]:.4g} "
                        f"(hinge damping gives {beta_part[r]:.3g})"))
    report = DampingReport(float(beta), pm.frequencies_hz[idx], ratios, spec_modes, beta_part, c,
                           np.full(n, np.nan))
    return float(beta), tendons, report


def add_modal_tendons(ms: mujoco.MjSpec, tendons) -> list:
    """Add the modal damping tendons to an MjSpec.

    Parameters
    ----------
    ms : mujoco.MjSpec
        The plant's spec (modified).
    tendons : list of (name, {joint: coefficient}, damping, info)
        From :func:`modal_damping_plan`.

    Returns
    -------
    list of mujoco.MjsTendon
    """
    out = []
    for name, coefs, c, info in tendons:
        t = ms.add_tendon(name=name)
        for jn, v in coefs.items():
            t.wrap_joint(jn, v)
        t.damping = [c, 0.0, 0.0]
        t.stiffness = [0.0, 0.0, 0.0]
        t.springlength = [0.0, 0.0]
        t.info = info
        out.append(t)
    return out


def tune_modal_damping(model: mujoco.MjModel, points, report: DampingReport, *, iterations: int = 4,
                       rtol: float = 0.01) -> DampingReport:
    """Correct the modal tendon damping until the linearised ratios meet the targets.

    The damped plant modes are identified by frequency (the damping does not move
    them); each iteration adds ``2 omega_r (zeta_target - zeta_achieved)`` to
    ``c_r`` (clipped at 0) in ``model.tendon_damping`` (tendons ``damping.mode<r>``).

    Parameters
    ----------
    model : mujoco.MjModel
        Plant with modal tendons; modified in place.
    points : sequence of int
        Points for the mode shapes.
    report : DampingReport
        From :func:`modal_damping_plan`.
    iterations : int
        Most corrections.
    rtol : float
        Relative tolerance on the ratios.

    Returns
    -------
    DampingReport
        With ``tendon_damping`` the final values and ``achieved_ratios`` measured.
    """
    from .linearize import modes, settle

    n = len(report.target_ratios)
    ids = [model.tendon(f"damping.mode{r + 1}").id for r in range(n)]
    data = settle(model)
    achieved = np.full(n, np.nan)
    for it in range(iterations + 1):
        pm = modes(model, points, data=data)
        sel = [int(np.argmin(np.abs(pm.frequencies_hz - f))) for f in report.frequencies_hz]
        achieved = pm.damping_ratios[sel]
        err = achieved - report.target_ratios
        if np.all(np.abs(err) <= rtol * report.target_ratios) or it == iterations:
            break
        omega = 2 * np.pi * report.frequencies_hz
        for r, tid in enumerate(ids):
            model.tendon_damping[tid] = max(0.0, model.tendon_damping[tid] - 2 * omega[r] * err[r])
    return DampingReport(report.beta_s, report.frequencies_hz, report.target_ratios, report.spec_modes,
                         report.beta_ratios, np.array([model.tendon_damping[t] for t in ids]), achieved)
