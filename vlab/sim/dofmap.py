"""The DOFs of two plants of one structure matched by place: how a changed structure keeps its damping matrix.

A change written into a structure file (a member's rigidity, a joint's flexibility) cuts a member into
pieces with the same points, inserts and hinge layout (:mod:`vlab.spec.changes`): its plant has the same
joints at the same places, under other names. :func:`dof_permutation` pairs them by their anchor and axis
at the reference configuration and accepts the pairing only where the paired coordinates mean the same
motion: a configuration moved along every paired coordinate puts every joint of both plants at the same
place again (added bodies or masses do not matter: the coordinates do). The unchanged structure's damping
matrix (a fixed ``C`` in joint space, as :func:`vlab.fe.damping.structural_damping` keeps it in the FE
model) then carries over row by row. A plant with a joint more (a released support, a freed clamp) is not
paired: the plant's joint coordinates are relative and the FE model's DOFs absolute, so the same matrix
carried into each with the new DOF undamped damps the new motion differently (the cantilever example with
its clamp released: plant ratios 0.008-0.012 against the FE model's 0.0107-0.0108); such a plant's
damping is designed on its own modes.

Source: MuJoCo's joint anchors and axes (``mjData.xanchor``, ``xaxis``) and ``mj_kinematics``
(``doc/APIreference``); the fixed damping matrix of a changed structure as in Sec. 2.1.2 of the
dissertation (modal damping of the measured structure).
"""

from __future__ import annotations

import mujoco
import numpy as np

#: Anchors closer than this [m] are the same place (the plants are built from the same numbers: their
#: anchors agree to rounding, ~1e-15 m; the BCC's hinges are >= 27 mm apart).
PLACE_TOL_M = 1e-9
#: Largest ``1 - cos`` of the angle between the axes of two joints that are the same joint.
AXIS_TOL = 1e-9
#: Rotation [rad] or slide [m] given every paired hinge or slide joint in the kinematic check: the same
#: coordinates move the joints to the same places (to rounding); other coordinates move them ~1e-3 apart.
PROBE_DQ = 1e-3


def _places(model: mujoco.MjModel, qpos_offsets: dict[int, float] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Joint anchors and axes (world frame), shape (njnt, 3) each, at ``qpos0`` moved by ``qpos_offsets``."""
    data = mujoco.MjData(model)
    data.qpos[:] = model.qpos0
    for adr, dq in (qpos_offsets or {}).items():
        data.qpos[adr] += dq
    mujoco.mj_kinematics(model, data)
    return np.array(data.xanchor), np.array(data.xaxis)


def dof_permutation(base: mujoco.MjModel, model: mujoco.MjModel) -> np.ndarray | None:
    """Indices ``perm`` with ``base`` DOF ``perm[i]`` the same DOF as ``model`` DOF ``i``, or None.

    Parameters
    ----------
    base, model : mujoco.MjModel
        Plants of a structure and of a changed version of it.

    Returns
    -------
    ndarray of int, shape (model.nv,), or None
        None where the DOF counts differ, a joint of ``model`` has no joint of ``base`` of the same
        type at its anchor (within PLACE_TOL_M) along its axis, or the paired coordinates do not move the
        joints alike (:data:`PROBE_DQ`): the plants are not the same joints under other names.
    """
    if base.nv != model.nv or base.njnt != model.njnt:
        return None
    (pb, ab), (pm, am) = _places(base), _places(model)
    tb, tm = np.asarray(base.jnt_type), np.asarray(model.jnt_type)
    perm = np.empty(model.nv, dtype=int)
    used = np.zeros(base.njnt, dtype=bool)
    pairs = []
    for j in range(model.njnt):
        near = np.flatnonzero((np.linalg.norm(pb - pm[j], axis=1) <= PLACE_TOL_M) & (tb == tm[j]) & ~used
                              & (np.abs(np.sum(ab * am[j], axis=1) - 1.0) <= AXIS_TOL))
        if near.size != 1:
            return None
        used[near[0]] = True
        pairs.append((j, int(near[0])))
        n = _dofs(model, j)
        if n != _dofs(base, near[0]):
            return None
        a0, a1 = int(model.jnt_dofadr[j]), int(base.jnt_dofadr[near[0]])
        perm[a0:a0 + n] = np.arange(a1, a1 + n)
    return perm if _same_motion(base, model, pairs) else None


def _same_motion(base: mujoco.MjModel, model: mujoco.MjModel, pairs: list[tuple[int, int]]) -> bool:
    """Every paired hinge or slide coordinate moved by a distinct multiple of PROBE_DQ in both plants:
    do all joints land at the same places along the same axes?"""
    scalar = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))
    off_b, off_m = {}, {}
    for k, (j, jb) in enumerate(pairs):
        if int(model.jnt_type[j]) in scalar:
            dq = PROBE_DQ * (1.0 + 0.5 * np.sin(k + 1.0))
            off_m[int(model.jnt_qposadr[j])] = dq
            off_b[int(base.jnt_qposadr[jb])] = dq
    pb, ab = _places(base, off_b)
    pm, am = _places(model, off_m)
    jm, jb = np.array([p[0] for p in pairs]), np.array([p[1] for p in pairs])
    return bool(np.max(np.abs(pb[jb] - pm[jm])) <= PLACE_TOL_M and np.max(np.abs(ab[jb] - am[jm])) <= AXIS_TOL)


def _dofs(model: mujoco.MjModel, joint: int) -> int:
    return {int(mujoco.mjtJoint.mjJNT_FREE): 6, int(mujoco.mjtJoint.mjJNT_BALL): 3}.get(int(model.jnt_type[joint]), 1)
