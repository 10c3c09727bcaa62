"""Divergence and energy checks of a MuJoCo plant.

* :func:`vibration_energy`: the mechanical energy of the motion about the
  settled state -- MuJoCo's kinetic + potential energy (gravity, joint and
  tendon springs) plus the potential of the constant in-plane ``prestress*``
  loads, minus its settled value [J].
* :func:`free_run`: a free vibration from a given initial state, energy
  sampled along the way; a run whose energy grows beyond a tolerance, turns
  non-finite or trips MuJoCo's bad-acceleration warning raises
  :class:`~vlab.errors.SimulationError` naming the likely cause.

Source: ``mjENBL_ENERGY`` (``doc/XMLreference.rst``, option/flag/energy).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from ..errors import SimulationError
from .damping_matrix import load_modal_damping
from .linearize import modes, settle, site_jacobian_w
from .plant import Plant


def _prestress_ids(model: mujoco.MjModel) -> np.ndarray:
    return np.array([i for i in range(model.nu) if model.actuator(i).name.startswith("prestress")], dtype=int)


def total_energy(model: mujoco.MjModel, data: mujoco.MjData) -> float:
    """Kinetic + potential energy [J] including the work potential of the constant prestress loads.

    Parameters
    ----------
    model : mujoco.MjModel
        With ``mjENBL_ENERGY`` set (``data.energy`` filled by ``mj_forward``/``mj_step``).
    data : mujoco.MjData

    Returns
    -------
    float
        ``E_kin + E_pot - sum_i f_i L_i`` over the ``prestress*`` actuators (constant
        force ``f_i``, length ``L_i``).
    """
    ids = _prestress_ids(model)
    work = float(np.dot(data.actuator_force[ids], data.actuator_length[ids])) if ids.size else 0.0
    return float(data.energy[0] + data.energy[1]) - work


def vibration_energy(model: mujoco.MjModel, data: mujoco.MjData, reference: float) -> float:
    """Energy of the motion about the settled state [J].

    Parameters
    ----------
    model : mujoco.MjModel
        With ``mjENBL_ENERGY`` set.
    data : mujoco.MjData
    reference : float
        :func:`total_energy` of the settled state [J].

    Returns
    -------
    float
        ``total_energy(model, data) - reference``.
    """
    return total_energy(model, data) - reference


@dataclass(frozen=True)
class FreeRun:
    """Result of :func:`free_run`.

    Attributes
    ----------
    t : ndarray, shape (n,)
        Sample times [s].
    energy : ndarray, shape (n,)
        Vibration energy [J].
    max_growth : float
        ``max(E) / E(0) - 1`` [-] (negative: the energy never rose above its start).
    """

    t: np.ndarray
    energy: np.ndarray
    max_growth: float


def free_run(plant: Plant, duration_s: float, *, mode: int = 1, amplitude_m: float = 1e-3,
             qvel0: np.ndarray | None = None, sample_every: int = 50, growth_tol: float = 0.02,
             model: mujoco.MjModel | None = None) -> FreeRun:
    """Free vibration from a displacement in one mode's shape (or a given velocity); check energy.

    Parameters
    ----------
    plant : Plant
    duration_s : float
        Length of the run [s].
    mode : int
        Plant mode (1-based) of the initial displacement (ignored with ``qvel0``).
    amplitude_m : float
        Largest initial out-of-plane displacement [m].
    qvel0 : ndarray, shape (nv,), optional
        Initial joint velocities instead of a modal displacement.
    sample_every : int
        Steps between energy samples.
    growth_tol : float
        Allowed relative energy growth over the start value (the semi-implicit
        Euler energy oscillates by ``O(omega h)``).
    model : mujoco.MjModel, optional
        A variant of ``plant.model`` to run (e.g. with damping removed).

    Returns
    -------
    FreeRun

    Raises
    ------
    SimulationError
        If the run diverges (non-finite state, MuJoCo warning) or the energy grows
        by more than ``growth_tol``; the message names the time and the likely
        cause (timestep too large for the hinge chain).
    """
    m = model if model is not None else plant.model
    m.opt.enableflags |= int(mujoco.mjtEnableBit.mjENBL_ENERGY)
    try:
        d0 = settle(m)
        ref = total_energy(m, d0)
        d = mujoco.MjData(m)
        d.qpos[:] = d0.qpos
        if qvel0 is not None:
            d.qvel[:] = qvel0
        else:
            pts = sorted(plant.spec.points)
            sm = modes(m, pts, mode, data=d0)
            phi = sm.joint_shapes[:, mode - 1]
            w = sm.shapes[:, mode - 1]
            k = int(np.argmax(np.abs(w)))
            jw = site_jacobian_w(m, d0, [f"p{pts[k]}"])[0]
            mujoco.mj_integratePos(m, d.qpos, phi * (amplitude_m / float(jw @ phi)), 1.0)
        mujoco.mj_forward(m, d)
        n = int(round(duration_s / m.opt.timestep))
        chunks = max(1, n // sample_every)
        t = np.empty(chunks + 1)
        e = np.empty(chunks + 1)
        t[0], e[0] = d.time, total_energy(m, d) - ref
        e0 = e[0]
        if not e0 > 0:
            raise SimulationError("free_run: the initial state carries no vibration energy")
        md = load_modal_damping(m)
        for i in range(1, chunks + 1):
            if md is None:
                mujoco.mj_step(m, d, nstep=sample_every)
            else:
                md.step(m, d, sample_every)
            t[i] = d.time
            e[i] = total_energy(m, d) - ref
            bad = d.warning[mujoco.mjtWarning.mjWARN_BADQACC].number
            if bad or not math.isfinite(e[i]):
                raise SimulationError(
                    f"free run diverged at t = {d.time:.4f} s (MuJoCo bad-acceleration warning or non-finite "
                    f"state): the timestep {m.opt.timestep:.3g} s is likely too large for the hinge chain"
                )
            if e[i] > e0 * (1.0 + growth_tol):
                raise SimulationError(
                    f"energy grew by {100 * (e[i] / e0 - 1):.2f} % by t = {d.time:.3f} s (> {100 * growth_tol} %): "
                    f"the integration is unstable -- timestep {m.opt.timestep:.3g} s too large for the hinge "
                    "chain, or an explicitly integrated damping term too strong"
                )
    finally:
        if model is None:
            m.opt.enableflags &= ~int(mujoco.mjtEnableBit.mjENBL_ENERGY)
    return FreeRun(t, e, float(e.max() / e0 - 1.0))
