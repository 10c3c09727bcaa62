"""The plant's timestep: the hinge chain's highest frequency, the automatic step, selective mass scaling
and the stability check.

By default the step is the largest ``LAB_PERIOD_S / k`` with ``omega_max * dt
<= AUTO_LIMIT`` (``omega_max`` of the joint springs with the full mass matrix,
:func:`hinge_omega_max`), at least ``LAB_PERIOD_S / max_substeps`` when very
short stiff segments can be mass-scaled without moving the low modes
(:func:`mass_scaling_armature`, :func:`armature_effect`); the choice itself is
made in :func:`vlab.sim.builder.build_plant`. A step that violates ``omega_max
* dt <= STABILITY_LIMIT`` is refused before running (:func:`check_timestep`).

Source: ``doc/computation/index.rst`` of MuJoCo ("Numerical integration":
semi-implicit Euler is stable for ``omega * dt < 2``).
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from ..errors import SimulationError

#: The lab's controller sample period (2 kHz, Sec. 5.3); automatic timesteps divide it.
LAB_PERIOD_S = 5e-4
#: Target omega_max * dt of the automatic timestep (margin below STABILITY_LIMIT).
AUTO_LIMIT = 1.5
#: Mass scaling is used only if it lowers none of the first modes by more than this fraction.
MASS_SCALING_TOL = 5e-4
#: Largest allowed omega_max * dt (semi-implicit Euler is stable for omega*dt < 2).
STABILITY_LIMIT = 1.8


def linear_constraint_basis(model: mujoco.MjModel) -> np.ndarray | None:
    """Basis of the joint motions that keep the model's linear equality constraints, or None if it has none.

    The linear constraints are the active tendon equalities that hold one fixed
    tendon (a linear combination of joint coordinates, ``wrap_joint``) at its
    reference length, as the forest topology's closures
    (:attr:`vlab.sim.SimOptions.topology`). The analyses of this module then work
    on the constrained system ``(N' K N, N' M N)``: the forest's junctions,
    free without their closures, would have rigid-body modes and their chains
    free ends. MuJoCo's solver holds the equalities at every step (impedance
    0.9999), so the constrained system is what the integrator sees. Other
    equalities (the tree's welds) are left out, as before.

    Parameters
    ----------
    model : mujoco.MjModel

    Returns
    -------
    ndarray, shape (nv, nv - rank) or None
        Orthonormal columns ``N`` with ``C N = 0`` for the constraint rows ``C``
        (the tendons' coefficients [m or rad per joint unit]); None when the
        model has no such constraint.

    Source: MuJoCo ``doc/XMLreference.rst`` (equality/tendon, tendon/fixed);
    the null space by SVD (``scipy.linalg.null_space``).
    """
    import scipy.linalg

    rows = []
    for e in range(model.neq):
        if model.eq_type[e] != mujoco.mjtEq.mjEQ_TENDON or model.eq_obj2id[e] >= 0 or not model.eq_active0[e]:
            continue
        t = int(model.eq_obj1id[e])
        adr, num = int(model.tendon_adr[t]), int(model.tendon_num[t])
        if any(model.wrap_type[adr + i] != mujoco.mjtWrap.mjWRAP_JOINT for i in range(num)):
            continue
        row = np.zeros(model.nv)
        for i in range(adr, adr + num):
            row[model.jnt_dofadr[model.wrap_objid[i]]] += model.wrap_prm[i]
        rows.append(row)
    if not rows:
        return None
    return scipy.linalg.null_space(np.array(rows))


def _reduced(mat: np.ndarray, basis: np.ndarray | None) -> np.ndarray:
    return mat if basis is None else basis.T @ mat @ basis


def hinge_omega_max(model: mujoco.MjModel) -> tuple[float, str]:
    """Highest natural frequency of the joint springs with the full mass matrix, at qpos0.

    Parameters
    ----------
    model : mujoco.MjModel

    Returns
    -------
    omega_max : float
        Largest ``omega`` [rad/s] of ``K_hinge phi = omega^2 M phi`` (``K_hinge`` the
        diagonal of joint stiffnesses; geometric and cable stiffness, which are
        far softer, are left out), on the motions that keep the linear
        equality constraints (:func:`linear_constraint_basis`).
    joint : str
        Name of the joint with the largest share of that mode.

    Source: semi-implicit Euler is stable for ``omega * dt < 2``
    (``doc/computation/index.rst``, "Numerical integration").
    """
    import scipy.linalg

    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    m = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, m)
    k = np.zeros(model.nv)
    for j in range(model.njnt):
        k[model.jnt_dofadr[j]] = model.jnt_stiffness[j]
    if not np.any(k > 0):
        return 0.0, ""
    basis = linear_constraint_basis(model)
    n = model.nv if basis is None else basis.shape[1]
    lam, vec = scipy.linalg.eigh(_reduced(np.diag(k), basis), _reduced(m, basis), subset_by_index=(n - 1, n - 1))
    if basis is not None:
        vec = basis @ vec
    share = k * vec[:, 0] ** 2
    dof = int(np.argmax(share))
    return float(math.sqrt(max(lam[0], 0.0))), model.joint(int(model.dof_jntid[dof])).name


def auto_timestep(omega_max: float, *, period_s: float = LAB_PERIOD_S, limit: float = AUTO_LIMIT) -> float:
    """Largest ``period_s / k`` (k = 1, 2, ...) with ``omega_max * dt <= limit``.

    Parameters
    ----------
    omega_max : float
        Highest natural frequency of the hinge springs [rad/s] (:func:`hinge_omega_max`).
    period_s : float
        Sample period the step must divide [s] (the lab's 2 kHz).
    limit : float
        Target ``omega_max * dt``.

    Returns
    -------
    float
        Timestep [s].
    """
    k = max(1, math.ceil(omega_max * period_s / limit))
    return period_s / k


def mass_scaling_armature(model: mujoco.MjModel, omega_target: float, *, iterations: int = 30) -> dict[str, float]:
    """Armatures that bring the joint springs' highest frequency down to ``omega_target``.

    Each joint ``j`` whose local frequency ``sqrt(k_j (M^-1)_jj)`` exceeds
    ``0.9 omega_target`` gets ``a_j = k_j / (0.9 omega_target)^2 - 1/(M^-1)_jj``
    (with the armature already added); repeated until the largest generalized
    eigenvalue of ``(K_joint, M + diag(a))`` is below ``omega_target^2``. With
    linear equality constraints (:func:`linear_constraint_basis`, basis ``N``)
    ``M^-1`` is the constrained one, ``N (N' M N)^-1 N'``, and the eigenvalue
    that of the constrained system.

    Parameters
    ----------
    model : mujoco.MjModel
        The plant (not modified).
    omega_target : float
        Largest allowed frequency [rad/s].
    iterations : int
        Most passes.

    Returns
    -------
    dict of str to float
        Joint name -> armature [kg m^2 for hinges, kg for slides]; empty if none is needed.

    Raises
    ------
    SimulationError
        If the target is not reached.

    Source: selective mass scaling (e.g. Olovsson, Simonsson & Unosson,
    IJNME 63 (2005) 1436): added inertia only on the stiff, short hinges, which barely
    move in the low modes.
    """
    import copy

    import scipy.linalg

    m = copy.copy(model)
    d = mujoco.MjData(m)
    k = np.array([model.jnt_stiffness[model.dof_jntid[i]] for i in range(model.nv)])
    base = model.dof_armature.copy()
    arm = np.zeros(model.nv)
    full = np.zeros((model.nv, model.nv))

    def mass() -> np.ndarray:
        m.dof_armature[:] = base + arm
        mujoco.mj_forward(m, d)
        mujoco.mj_fullM(m, d, full)
        return full

    basis = linear_constraint_basis(model)
    kr = _reduced(np.diag(k), basis)

    def top(mm: np.ndarray) -> float:
        return float(scipy.linalg.eigh(kr, _reduced(mm, basis), eigvals_only=True,
                                       subset_by_index=(kr.shape[0] - 1, kr.shape[0] - 1))[0])

    def inverse_diagonal(mm: np.ndarray) -> np.ndarray:
        if basis is None:
            return np.diag(np.linalg.inv(mm))
        return np.einsum("ir,rs,is->i", basis, np.linalg.inv(_reduced(mm, basis)), basis)

    done = top(mass()) <= omega_target**2
    for margin in (0.9, 0.8, 0.7, 0.6, 0.5, 0.4):
        if done:
            break
        target2 = (margin * omega_target) ** 2
        for _ in range(iterations):  # local rule: each stiff joint's own frequency down to the margin
            dinv = inverse_diagonal(mass())
            need = k * dinv > target2 * (1 + 1e-9)
            if not np.any(need):
                break
            arm[need] += k[need] / target2 - 1.0 / dinv[need]
        done = top(mass()) <= omega_target**2
    if not done:
        raise SimulationError(f"mass scaling did not bring the hinge chain below {omega_target:.4g} rad/s")
    return {model.joint(int(model.dof_jntid[i])).name: float(arm[i]) for i in range(model.nv) if arm[i] > 0}


def armature_effect(model: mujoco.MjModel, armature: dict[str, float], n_modes: int = 15) -> float:
    """Largest relative frequency drop of the first modes caused by ``armature`` (first-order estimate).

    For mass-normalised modes ``phi_r`` of ``(K_joint, M)`` (on the motions
    that keep the linear equality constraints, :func:`linear_constraint_basis`)
    the added kinetic energy share is ``s_r = sum_j a_j phi_jr^2`` and
    ``omega_r`` drops by about ``s_r / 2``.

    Parameters
    ----------
    model : mujoco.MjModel
        The plant without the armature.
    armature : dict of str to float
        Joint name -> armature.
    n_modes : int
        Modes considered (the lowest of the joint springs with the full mass).

    Returns
    -------
    float
        ``max_r s_r / 2`` [-]; 0 for an empty ``armature``.
    """
    import scipy.linalg

    if not armature:
        return 0.0
    d = mujoco.MjData(model)
    mujoco.mj_forward(model, d)
    m = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, d, m)
    k = np.array([model.jnt_stiffness[model.dof_jntid[i]] for i in range(model.nv)])
    basis = linear_constraint_basis(model)
    n = min(n_modes, model.nv if basis is None else basis.shape[1])
    _, phi = scipy.linalg.eigh(_reduced(np.diag(k), basis), _reduced(m, basis), subset_by_index=(0, n - 1))
    if basis is not None:
        phi = basis @ phi
    a = np.zeros(model.nv)
    for name, v in armature.items():
        a[model.jnt_dofadr[model.joint(name).id]] = v
    return float(np.max(a @ phi**2) / 2.0)


def check_timestep(model: mujoco.MjModel, *, limit: float = STABILITY_LIMIT) -> float:
    """Raise if the timestep is too large for the stiffest hinge of the chain.

    Parameters
    ----------
    model : mujoco.MjModel
    limit : float
        Largest allowed ``omega_max * dt`` (default :data:`STABILITY_LIMIT`).

    Returns
    -------
    float
        ``omega_max * dt`` [-].

    Raises
    ------
    SimulationError
        When ``omega_max * dt > limit``; names the stiffest joint, the largest
        stable timestep and the remedy (fewer links or a smaller timestep).
    """
    omega, joint = hinge_omega_max(model)
    dt = float(model.opt.timestep)
    ratio = omega * dt
    if ratio > limit:
        raise SimulationError(
            f"timestep {dt:.3g} s is too large for the hinge chain: the stiffest mode "
            f"({omega / (2 * math.pi):.4g} Hz, mostly joint {joint!r}) needs dt < {limit / omega:.3g} s "
            f"(omega*dt = {ratio:.3g} > {limit}); use fewer segments per element or a smaller timestep"
        )
    return ratio
