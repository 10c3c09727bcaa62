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
        far softer, are left out).
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
    lam, vec = scipy.linalg.eigh(np.diag(k), m, subset_by_index=(model.nv - 1, model.nv - 1))
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
    eigenvalue of ``(K_joint, M + diag(a))`` is below ``omega_target^2``.

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

    def top(mm: np.ndarray) -> float:
        return float(scipy.linalg.eigh(np.diag(k), mm, eigvals_only=True,
                                       subset_by_index=(model.nv - 1, model.nv - 1))[0])

    done = top(mass()) <= omega_target**2
    for margin in (0.9, 0.8, 0.7, 0.6, 0.5, 0.4):
        if done:
            break
        target2 = (margin * omega_target) ** 2
        for _ in range(iterations):  # local rule: each stiff joint's own frequency down to the margin
            dinv = np.diag(np.linalg.inv(mass()))
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

    For mass-normalised modes ``phi_r`` of ``(K_joint, M)`` the added kinetic
    energy share is ``s_r = sum_j a_j phi_jr^2`` and ``omega_r`` drops by
    about ``s_r / 2``.

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
    n = min(n_modes, model.nv)
    _, phi = scipy.linalg.eigh(np.diag(k), m, subset_by_index=(0, n - 1))
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
