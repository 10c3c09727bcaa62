"""Settle a plant under gravity, linearise it and extract its out-of-plane modes.

The plant's reference configuration is flat; gravity acts in the plane, so
the settled state is the flat one up to round-off -- but the geometric
stiffness of gravity and of the string tensions only appears in a
linearisation *around the loaded state*, which is why the state is settled
first.

The linearisation is :func:`mujoco.mjd_transitionFD` (forward finite
differences of one step by default): ``x_{k+1} = A x_k + B u_k``, ``y_k = C x_k + D u_k``
with ``x = (dq, v)`` (``dq`` the position tangent, ``v = qvel``; size ``2 nv``).
For one mode of a semi-implicit Euler step with implicit damping ``c`` (per
unit mass) the eigenvalue pair ``lambda`` satisfies::

    |lambda|^2 = 1 / (1 + h c)
    2 Re(lambda) = 1 + |lambda|^2 - h^2 omega^2 |lambda|^2

which is inverted here for the continuous natural frequency ``omega`` and
damping ratio ``zeta = c / (2 omega)`` -- exact for an undamped or
implicitly damped mode, so the frequencies carry no discretisation bias
``O((omega h)^2)`` of a plain ``log(lambda)/h``.

Sources: ``doc/computation/index.rst`` (semi-implicit Euler, implicit
damping), ``doc/APIreference/functions.rst`` (``mjd_transitionFD``).
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass

import mujoco
import numpy as np

from ..errors import SimulationError
from .damping_matrix import load_modal_damping


@dataclass(frozen=True)
class LinearModel:
    """Discrete-time linearisation ``x+ = A x + B u``, ``y = C x + D u`` of one step.

    Attributes
    ----------
    A : ndarray, shape (2 nv + na, 2 nv + na)
    B : ndarray, shape (2 nv + na, nu)
    C : ndarray, shape (nsensordata, 2 nv + na)
    D : ndarray, shape (nsensordata, nu)
    dt : float
        Step [s].
    qpos : ndarray, shape (nq,)
        Linearisation point (settled configuration).
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    dt: float
    qpos: np.ndarray


@dataclass(frozen=True)
class SimModes:
    """Out-of-plane modes of a plant, sorted by natural frequency.

    Attributes
    ----------
    frequencies_hz : ndarray, shape (n_modes,)
        Undamped natural frequencies [Hz].
    damping_ratios : ndarray, shape (n_modes,)
        Modal damping ratios [-].
    points : tuple of int
        Point ids of the rows of ``shapes``.
    shapes : ndarray, shape (n_points, n_modes)
        Real out-of-plane displacement shapes ``w`` at the ``p<ID>`` sites,
        scaled to unit maximum ``|w|``, largest entry positive.
    joint_shapes : ndarray, shape (nv, n_modes)
        Real shapes in joint coordinates, mass-normalised (``phi^T M phi = 1``).
    mass_matrix : ndarray, shape (nv, nv)
        Joint-space mass matrix at the settled state [kg, kg m, kg m^2].
    """

    frequencies_hz: np.ndarray
    damping_ratios: np.ndarray
    points: tuple[int, ...]
    shapes: np.ndarray
    joint_shapes: np.ndarray
    mass_matrix: np.ndarray

    @property
    def omega(self) -> np.ndarray:
        """Circular natural frequencies [rad/s], shape (n_modes,)."""
        return 2 * np.pi * self.frequencies_hz


def _check_state(model: mujoco.MjModel, data: mujoco.MjData, what: str) -> None:
    bad = [w for w in ("mjWARN_BADQACC", "mjWARN_BADQPOS", "mjWARN_BADQVEL")
           if data.warning[int(getattr(mujoco.mjtWarning, w))].number > 0]
    if bad or not (np.all(np.isfinite(data.qpos)) and np.all(np.isfinite(data.qvel))):
        raise SimulationError(
            f"{what}: the simulation diverged (MuJoCo warnings {bad or 'none'}, non-finite state: "
            f"{not np.all(np.isfinite(data.qvel))}); the timestep is likely too large for the hinge "
            "chain (see vlab.sim.timestep.check_timestep)"
        )


def _qacc_at(model: mujoco.MjModel, d: mujoco.MjData, qpos: np.ndarray) -> np.ndarray:
    d.qpos[:] = qpos
    d.qvel[:] = 0.0
    mujoco.mj_forward(model, d)
    return d.qacc.copy()


def settle(model: mujoco.MjModel, data: mujoco.MjData | None = None, *, max_iterations: int = 30,
           tol_qacc: float = 1e-7, eps: float = 1e-7) -> mujoco.MjData:
    """Bring a plant to rest under gravity: the static equilibrium nearest to the given state.

    At zero velocity the acceleration ``qacc(q)`` must vanish; Newton's method
    solves ``qacc(q) = 0`` with a finite-difference Jacobian (one ``mj_forward``
    per DOF). A plant already at rest (the flat reference state of a vlab plant)
    returns at once.

    Parameters
    ----------
    model : mujoco.MjModel
    data : mujoco.MjData, optional
        Initial state; a fresh one at qpos0 by default. Not modified.
    max_iterations : int
        Newton iterations before giving up.
    tol_qacc : float
        Rest criterion: ``max |qacc|`` [m/s^2 or rad/s^2].
    eps : float
        Finite-difference step of the Jacobian [m or rad].

    Returns
    -------
    mujoco.MjData
        Settled state (qvel = 0), forward-evaluated.

    Raises
    ------
    SimulationError
        If no equilibrium is found (no stable equilibrium under gravity, e.g. a
        mechanism or a member in compression beyond buckling) or the state is
        not finite.
    """
    d = mujoco.MjData(model)
    if data is not None:
        d.qpos[:] = data.qpos
        d.act[:] = data.act
        d.ctrl[:] = data.ctrl
    q = d.qpos.copy()
    acc = _qacc_at(model, d, q)
    nv = model.nv
    for _ in range(max_iterations):
        if not np.all(np.isfinite(acc)):
            break
        if np.max(np.abs(acc), initial=0.0) <= tol_qacc:
            return d
        jac = np.empty((nv, nv))
        for j in range(nv):
            qj = q.copy()
            dv = np.zeros(nv)
            dv[j] = eps
            mujoco.mj_integratePos(model, qj, dv, 1.0)
            jac[:, j] = (_qacc_at(model, d, qj) - acc) / eps
        try:
            step = np.linalg.lstsq(jac, -acc, rcond=None)[0]
        except np.linalg.LinAlgError:
            break
        norm = np.linalg.norm(acc)
        for _ in range(20):  # backtracking: accept the first step that reduces |qacc|
            trial = q.copy()
            mujoco.mj_integratePos(model, trial, step, 1.0)
            new = _qacc_at(model, d, trial)
            if np.all(np.isfinite(new)) and np.linalg.norm(new) < norm:
                break
            step = 0.5 * step
        q, acc = trial, new
    _qacc_at(model, d, q)
    raise SimulationError(
        f"the plant did not settle (max |qacc| = {np.max(np.abs(acc)):.3g} after {max_iterations} Newton "
        "steps): no stable equilibrium under gravity near this state"
    )


def linearize(model: mujoco.MjModel, data: mujoco.MjData, *, eps: float = 1e-6,
              applied_damping: bool = True, centred: bool = False) -> LinearModel:
    """Linearise one step around ``data`` with :func:`mujoco.mjd_transitionFD`.

    The differences are taken on a copy of the model whose constraint solver
    runs to convergence (``opt.tolerance = 0``): a perturbation of ``eps`` must
    not fall below the solver's stopping threshold.

    Parameters
    ----------
    model : mujoco.MjModel
    data : mujoco.MjData
        Linearisation point (normally from :func:`settle`); not modified.
    eps : float
        Finite-difference step.
    applied_damping : bool
        Include the applied modal damping stored in the model (custom numerics,
        :mod:`vlab.sim.damping_matrix`), which ``mjd_transitionFD`` cannot see because it
        is set as ``qfrc_applied`` by the stepper (default True).
    centred : bool
        Centred differences (twice the steps). Forward differences are the
        default: on the settled grid and BCC plants (eps 1e-6) they give the
        same structural frequencies and damping ratios to 1e-10 relative
        (A to 1e-6 of its largest entry) in 0.14 s instead of 0.34 s for the
        grid (measured 2026-11-23; ``tests/test_sim_grid.py`` compares both).

    Returns
    -------
    LinearModel

    Raises
    ------
    SimulationError
        If the matrices are not finite.
    """
    if model.opt.tolerance > 0.0:
        # eps-sized perturbations change the constraint solver's cost by less than its tolerance: with
        # MuJoCo's default (1e-8) the grid's forest plant took no solver iteration for them and lost whole
        # columns (spurious unstable eigenvalues near 40-500 Hz, input and damping columns of zero)
        model = copy.copy(model)
        model.opt.tolerance = 0.0
    d = copy.copy(data)
    nx = 2 * model.nv + model.na
    A = np.zeros((nx, nx))
    B = np.zeros((nx, model.nu))
    C = np.zeros((model.nsensordata, nx))
    D = np.zeros((model.nsensordata, model.nu))
    mujoco.mjd_transitionFD(model, d, eps, centred, A, B, C, D)
    if applied_damping:
        md = load_modal_damping(model)
        if md is not None:
            # the force -C_m qvel is set as qfrc_applied before each step: x+ = A x + Bq (-C_m v)
            bq = _qfrc_response(model, data)
            A[:, model.nv: 2 * model.nv] -= bq @ md.matrix()
    if not (np.all(np.isfinite(A)) and np.all(np.isfinite(B))):
        raise SimulationError("linearisation produced non-finite matrices: the state is not valid")
    return LinearModel(A, B, C, D, float(model.opt.timestep), data.qpos.copy())


def _qfrc_response(model: mujoco.MjModel, data: mujoco.MjData, eps: float = 1e-6) -> np.ndarray:
    """Response of one step to ``qfrc_applied``, shape (2 nv + na, nv) (forward differences; linear)."""
    nv = model.nv
    out = np.zeros((2 * nv + model.na, nv))
    d0 = copy.copy(data)
    mujoco.mj_step(model, d0)
    dq = np.zeros(nv)
    for j in range(nv):
        d = copy.copy(data)
        d.qfrc_applied[j] += eps
        mujoco.mj_step(model, d)
        mujoco.mj_differentiatePos(model, dq, 1.0, d0.qpos, d.qpos)
        out[:nv, j] = dq / eps
        out[nv: 2 * nv, j] = (d.qvel - d0.qvel) / eps
        if model.na:
            out[2 * nv:, j] = (d.act - d0.act) / eps
    return out


def discrete_to_modal(lam: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Continuous natural frequency and damping ratio of one-step eigenvalues.

    Parameters
    ----------
    lam : ndarray, shape (k,)
        Eigenvalues of ``A`` (one of each complex pair).
    dt : float
        Step [s].

    Returns
    -------
    omega : ndarray, shape (k,)
        Natural circular frequencies [rad/s].
    zeta : ndarray, shape (k,)
        Damping ratios [-].

    Source: the one-mode semi-implicit Euler map with implicit damping (module docstring).
    """
    rho = np.abs(lam) ** 2
    hc = 1.0 / rho - 1.0
    w2 = (1.0 + rho - 2.0 * lam.real) / (rho * dt**2)
    omega = np.sqrt(np.clip(w2, 0.0, None))
    with np.errstate(divide="ignore", invalid="ignore"):
        zeta = np.where(omega > 0, hc / dt / (2.0 * omega), 1.0)
    return omega, zeta


def site_jacobian_w(model: mujoco.MjModel, data: mujoco.MjData, sites: list[str]) -> np.ndarray:
    """Rows ``dw/dv`` of the out-of-plane (world z) velocity at ``sites``.

    Parameters
    ----------
    model : mujoco.MjModel
    data : mujoco.MjData
        State (kinematics computed).
    sites : list of str
        Site names.

    Returns
    -------
    ndarray, shape (len(sites), nv)
    """
    jac = np.zeros((len(sites), model.nv))
    jacp = np.zeros((3, model.nv))
    for i, name in enumerate(sites):
        mujoco.mj_jacSite(model, data, jacp, None, model.site(name).id)
        jac[i] = jacp[2]
    return jac


def modes(model: mujoco.MjModel, points: list[int] | tuple[int, ...], n_modes: int | None = None, *,
          data: mujoco.MjData | None = None, linear: LinearModel | None = None,
          max_zeta: float = 0.5) -> SimModes:
    """Out-of-plane modes of a plant from its linearisation around the settled state.

    Rigid-body motions are not modes: real eigenvalues, and complex pairs within
    1e-6 rad per step of 1 (a rigid motion's double eigenvalue split by rounding).

    Parameters
    ----------
    model : mujoco.MjModel
        A vlab plant (sites ``p<ID>``).
    points : sequence of int
        Point ids whose ``w`` forms the shapes.
    n_modes : int, optional
        Number of lowest modes returned (all structural modes by default).
    data : mujoco.MjData, optional
        Settled state; :func:`settle` is called when omitted.
    linear : LinearModel, optional
        A linearisation at ``data`` (computed when omitted).
    max_zeta : float
        Eigenvalues with a larger damping ratio are dropped: they belong to the
        critically damped weld constraints (``solref = (2 dt, 1)``), not to the
        structure.

    Returns
    -------
    SimModes

    Raises
    ------
    SimulationError
        If the plant does not settle or has an unstable (``|lambda| > 1``) mode
        -- a timestep too large for the hinge chain or a structure beyond buckling.
    """
    if data is None:
        data = settle(model)
    if linear is None:
        linear = linearize(model, data)
    nv = model.nv
    lam, vec = np.linalg.eig(linear.A)
    unstable = np.abs(lam) > 1.0 + 1e-6
    if np.any(unstable):
        i = int(np.argmax(np.abs(lam)))
        raise SimulationError(
            f"the linearised plant is unstable (|lambda| = {abs(lam[i]):.6f} > 1, "
            f"f ~ {abs(np.angle(lam[i])) / (2 * math.pi * linear.dt):.4g} Hz): the timestep is too large for "
            "the hinge chain or the structure is beyond buckling"
        )
    # a pair within 1e-6 rad per step of 1 (below 0.3 mHz at 0.5 ms) is a rigid-body motion's double
    # eigenvalue split by rounding (the grid's swing about its bearings without gravity: 2e-5 Hz), not a mode
    keep = lam.imag > 1e-6
    lam, vec = lam[keep], vec[:, keep]
    omega, zeta = discrete_to_modal(lam, linear.dt)
    ok = (zeta < max_zeta) & (omega > 0)
    lam, vec, omega, zeta = lam[ok], vec[:, ok], omega[ok], zeta[ok]
    order = np.argsort(omega)
    if n_modes is not None:
        order = order[:n_modes]
    omega, zeta, vec = omega[order], zeta[order], vec[:, order]
    pos = vec[:nv, :]
    # real shapes: rotate each complex vector so that its largest entry is real
    j = np.argmax(np.abs(pos), axis=0)
    phase = pos[j, np.arange(pos.shape[1])]
    real = (pos / (phase / np.abs(phase))).real
    m = np.zeros((nv, nv))
    mujoco.mj_fullM(model, data, m)
    mass = np.einsum("ir,ij,jr->r", real, m, real)
    joint_shapes = real / np.sqrt(mass)
    sites = [f"p{p}" for p in points]
    w = site_jacobian_w(model, data, sites) @ joint_shapes
    k = np.argmax(np.abs(w), axis=0)
    peak = w[k, np.arange(w.shape[1])]
    with np.errstate(divide="ignore", invalid="ignore"):
        shapes = np.where(np.abs(peak) > 0, w / np.where(peak == 0, 1.0, peak), 0.0)
    sign = np.sign(np.where(peak == 0, 1.0, peak))
    joint_shapes = joint_shapes * sign
    return SimModes(omega / (2 * np.pi), zeta, tuple(points), shapes, joint_shapes, m)
