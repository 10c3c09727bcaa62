"""Stepping a MuJoCo plant: the runtime object the lab's control loop drives.

:class:`MujocoPlant` implements the plant protocol of :mod:`vlab.lab.loop`
(``timestep_s``, ``actuator_points``, ``set_forces``, ``step``,
``velocities``, ``displacements``) on a compiled vlab plant -- built from a
spec (:func:`vlab.sim.build_plant`) or loaded from an exported MJCF file --
starting from its settled state. It finds everything by name: actuators
``coil<ID>``, sensors ``vel<ID>`` (``actuatorvel``, or ``framelinvel`` /
``velocimeter`` whose z component is used) and sites ``p<ID>``.

Measured velocities come from the model's own ``vel<ID>`` sensors
(``MjData.sensordata``), so an edited MJCF is measured as edited: a sensor
moved to another site measures there, and a sensor's ``cutoff`` clips its
reading to ``[-cutoff, cutoff]`` m/s as MuJoCo computes it (a saturating
transducer). What vlab cannot honour is refused when an MJCF is loaded
(:func:`check_plant_contract`): a missing or renamed ``coil<ID>`` /
``vel<ID>``, a ``vel<ID>`` of another sensor type, and a non-zero ``noise``
(MuJoCo does not apply it; the lab's sensor noise is ``--noise``),
``delay``, ``interval`` or ``nsample``.

Sampling instant: ``mj_step`` evaluates the sensors (and site positions) at
the start of the step, before integrating, so after it ``sensordata`` lags the
state by one physics step. The plant therefore brings the position and
velocity stages (``mj_fwdPosition``, ``mj_fwdVelocity``, ``mj_sensorVel``)
up to date before it is read after a step: :meth:`MujocoPlant.velocities` and
:meth:`MujocoPlant.displacements` give the state at the time
:attr:`MujocoPlant.time_s`. These stages only fill derived quantities that the
next ``mj_step`` recomputes from ``qpos``/``qvel``, so the trajectory is
unchanged (tested bit for bit).

Sign conventions: a positive force on ``coil<ID>`` pushes point ``ID`` along
world +z, and ``vel<ID>`` reads +z velocity positive -- so collocated rate
feedback ``u = -D y`` with ``D`` positive definite removes energy.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import mujoco
import numpy as np

from ..errors import ModelError, SimulationError
from ..spec import StructureSpec
from .builder import Plant, SimOptions, build_plant
from .damping import load_modal_damping
from .linearize import modes, settle, site_jacobian_w


def _numbered(model: mujoco.MjModel, objtype, count: int, prefix: str) -> dict[int, int]:
    out = {}
    pat = re.compile(rf"^{prefix}(\d+)$")
    for i in range(count):
        name = mujoco.mj_id2name(model, objtype, i)
        m = pat.match(name or "")
        if m:
            out[int(m.group(1))] = i
    return out


def sensor_rows(model: mujoco.MjModel) -> dict[int, int]:
    """Point id -> row in ``sensordata`` of the out-of-plane velocity of every ``vel<ID>`` sensor.

    Parameters
    ----------
    model : mujoco.MjModel
        A vlab plant (compiled or loaded from MJCF).

    Returns
    -------
    dict of int to int
        ``actuatorvel`` sensors: their address; ``framelinvel`` and
        ``velocimeter``: address + 2 (the z component, in the sensor's frame).

    Raises
    ------
    SimulationError
        For a ``vel<ID>`` sensor of another type.
    """
    rows = {}
    for p, i in _numbered(model, mujoco.mjtObj.mjOBJ_SENSOR, model.nsensor, "vel").items():
        kind = int(model.sensor_type[i])
        adr = int(model.sensor_adr[i])
        if kind == int(mujoco.mjtSensor.mjSENS_ACTUATORVEL):
            rows[p] = adr
        elif kind in (int(mujoco.mjtSensor.mjSENS_FRAMELINVEL), int(mujoco.mjtSensor.mjSENS_VELOCIMETER)):
            rows[p] = adr + 2
        else:
            raise SimulationError(f"sensor vel{p} has type {mujoco.mjtSensor(kind).name}: not a velocity sensor")
    return rows


#: Velocity sensor types a ``vel<ID>`` sensor may have, with the offset of the out-of-plane component.
VELOCITY_SENSORS = {
    int(mujoco.mjtSensor.mjSENS_ACTUATORVEL): 0,
    int(mujoco.mjtSensor.mjSENS_FRAMELINVEL): 2,
    int(mujoco.mjtSensor.mjSENS_VELOCIMETER): 2,
}


def check_plant_contract(model: mujoco.MjModel, *, actuators, sensors, source: str) -> None:
    """Refuse a plant whose actuators or sensors break vlab's naming contract.

    The contract (as :func:`vlab.sim.build_plant` writes it): a voice-coil
    actuator ``coil<ID>`` at every actuator point, and a velocity sensor
    ``vel<ID>`` of type ``actuatorvel``, ``framelinvel`` or ``velocimeter`` at
    every sensor / measured point. Every ``vel<ID>`` sensor of the model must
    also be one vlab reads as MuJoCo computes it: ``noise`` 0 (MuJoCo 4.0 does
    not apply sensor noise; give the lab's sensor noise with ``--noise``,
    :attr:`vlab.lab.loop.HardwareChain.noise_m_s`), and no ``delay``,
    ``interval`` or ``nsample`` (the loop samples every sensor at each tick;
    the chain's delay and sensor lag model the hardware). A ``cutoff`` is
    honoured (MuJoCo clips the reading to ``[-cutoff, cutoff]`` m/s).

    Parameters
    ----------
    model : mujoco.MjModel
        The plant, e.g. loaded from an edited MJCF.
    actuators : sequence of int
        Points that need a ``coil<ID>`` actuator.
    sensors : sequence of int
        Points that need a ``vel<ID>`` velocity sensor.
    source : str
        Where the model came from (the MJCF file), named in the error.

    Raises
    ------
    ModelError
        Naming ``source`` and every missing, renamed or unsupported element
        (and the model's sensors/actuators outside the naming scheme, which a
        renamed one would be).
    """
    problems = []
    coils = _numbered(model, mujoco.mjtObj.mjOBJ_ACTUATOR, model.nu, "coil")
    vels = _numbered(model, mujoco.mjtObj.mjOBJ_SENSOR, model.nsensor, "vel")
    for p in dict.fromkeys(actuators):
        if p not in coils:
            problems.append(f"actuator coil{p} (voice coil at point {p}) is missing")
    for p in dict.fromkeys(sensors):
        if p not in vels:
            problems.append(f"sensor vel{p} (velocity sensor at point {p}) is missing")
    for p, i in sorted(vels.items()):
        kind = int(model.sensor_type[i])
        if kind not in VELOCITY_SENSORS:
            problems.append(f"sensor vel{p} has type {mujoco.mjtSensor(kind).name}; vlab reads only "
                            "actuatorvel, framelinvel and velocimeter sensors")
        if float(model.sensor_noise[i]) != 0.0:
            problems.append(f"sensor vel{p} has noise=\"{float(model.sensor_noise[i]):g}\", which MuJoCo does not "
                            "apply; remove the attribute and give the sensor noise with --noise "
                            "(HardwareChain.noise_m_s)")
        if float(model.sensor_delay[i]) != 0.0:
            problems.append(f"sensor vel{p} has delay=\"{float(model.sensor_delay[i]):g}\", which vlab does not "
                            "support; use --delay-samples (HardwareChain.delay_periods) or sensor_lag_hz")
        if float(model.sensor_interval[i][0]) != 0.0:
            problems.append(f"sensor vel{p} has interval=\"{float(model.sensor_interval[i][0]):g}\", which vlab "
                            "does not support (the loop samples every sensor each tick)")
        if int(model.sensor_history[i][0]) != 0:
            problems.append(f"sensor vel{p} has nsample=\"{int(model.sensor_history[i][0])}\", which vlab does "
                            "not support")
    if problems:
        others = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_SENSOR, i) or f"#{i}" for i in range(model.nsensor)
                  if i not in vels.values()]
        others += [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_ACTUATOR, i) or f"#{i}" for i in range(model.nu)
                   if i not in coils.values()
                   and not (mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_ACTUATOR, i) or "").startswith("prestress")]
        hint = f" (elements outside the naming scheme: {', '.join(others)})" if others else ""
        raise ModelError(f"{source}: the plant breaks vlab's naming contract (actuators coil<ID>, velocity "
                         f"sensors vel<ID>): " + "; ".join(problems) + hint)


#: Longest physics step an MJCF plant may have [s]: the PC-1000's slowest controller period
#: (2 samples/s, Sec. 5.3); the loop needs whole physics steps per controller period.
MAX_TIMESTEP_S = 0.5
#: Heaviest plausible body of a plant [kg]: the lab structures weigh a few kg to tens of kg
#: (the grid's end plates, 27 kg, are the heaviest parts); 1000 kg is a unit or exponent slip.
MAX_BODY_MASS_KG = 1.0e3

# (MjModel attribute, object type, what it is) of the values checked for finiteness
_FINITE_FIELDS = (
    ("body_mass", mujoco.mjtObj.mjOBJ_BODY, "mass [kg]"),
    ("body_inertia", mujoco.mjtObj.mjOBJ_BODY, "inertia [kg*m^2]"),
    ("body_pos", mujoco.mjtObj.mjOBJ_BODY, "pos [m]"),
    ("jnt_stiffness", mujoco.mjtObj.mjOBJ_JOINT, "stiffness"),
    ("jnt_pos", mujoco.mjtObj.mjOBJ_JOINT, "pos [m]"),
    ("jnt_axis", mujoco.mjtObj.mjOBJ_JOINT, "axis"),
    ("qpos_spring", None, "springref"),
    ("dof_damping", mujoco.mjtObj.mjOBJ_DOF, "damping"),
    ("dof_armature", mujoco.mjtObj.mjOBJ_DOF, "armature"),
    ("actuator_gear", mujoco.mjtObj.mjOBJ_ACTUATOR, "gear"),
    ("actuator_gainprm", mujoco.mjtObj.mjOBJ_ACTUATOR, "gainprm"),
    ("tendon_stiffness", mujoco.mjtObj.mjOBJ_TENDON, "stiffness"),
    ("tendon_damping", mujoco.mjtObj.mjOBJ_TENDON, "damping"),
    ("tendon_lengthspring", mujoco.mjtObj.mjOBJ_TENDON, "springlength [m]"),
    ("site_pos", mujoco.mjtObj.mjOBJ_SITE, "pos [m]"),
)


def check_plant_values(model: mujoco.MjModel, *, source: str) -> None:
    """Refuse an MJCF plant with non-finite or implausible physical values.

    MuJoCo 4.0 loads an MJCF with ``mass="inf"``, ``timestep="nan"`` or
    ``gravity="0 nan 0"`` (it only warns about a NaN on stderr); such a plant
    would run and give NaN or meaningless results. Checked: the physics step
    (finite, positive, at most :data:`MAX_TIMESTEP_S` = 0.5 s, the PC-1000's
    slowest period, Sec. 5.3), gravity (finite), every body mass (finite, at
    most :data:`MAX_BODY_MASS_KG` = 1000 kg), and body inertias and positions,
    joint stiffnesses, positions, axes and spring references, DOF damping and
    armature, actuator gears and gains, tendon stiffnesses, damping and
    spring lengths, site positions and custom numeric data (finite).

    Parameters
    ----------
    model : mujoco.MjModel
        The loaded plant.
    source : str
        Where it came from (the MJCF file), named in the error.

    Raises
    ------
    ModelError
        Naming ``source``, the element (``body 'J1'``), the attribute and the value.
    """
    ts = float(model.opt.timestep)
    if not (math.isfinite(ts) and 0.0 < ts <= MAX_TIMESTEP_S):
        raise ModelError(f"{source}: option timestep=\"{ts:g}\" s must be positive, finite and at most "
                         f"{MAX_TIMESTEP_S:g} s (the PC-1000's slowest controller period, Sec. 5.3)")
    g = np.asarray(model.opt.gravity, dtype=float)
    if not np.all(np.isfinite(g)):
        raise ModelError(f"{source}: option gravity=\"{' '.join(f'{v:g}' for v in g)}\" is not finite")
    for attr, objtype, what in _FINITE_FIELDS:
        arr = np.asarray(getattr(model, attr), dtype=float)
        if arr.size == 0:
            continue
        rows = np.flatnonzero(~np.all(np.isfinite(arr.reshape(arr.shape[0], -1)), axis=1))
        if rows.size:
            i = int(rows[0])
            if objtype is None:
                label = f"{attr}[{i}]"
            elif objtype == mujoco.mjtObj.mjOBJ_DOF:  # DOFs are named by their joint
                j = int(model.dof_jntid[i])
                label = f"joint {mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) or f'#{j}'!r}"
            else:
                label = f"{objtype.name[6:].lower()} {mujoco.mj_id2name(model, objtype, i) or f'#{i}'!r}"
            raise ModelError(f"{source}: {label}: {what} {np.ravel(arr[i]).tolist()} is not finite")
    for i in range(model.nnumeric):  # custom data (vlab's modal damping matrices)
        adr, size = int(model.numeric_adr[i]), int(model.numeric_size[i])
        vals = np.asarray(model.numeric_data[adr:adr + size], dtype=float)
        bad = np.flatnonzero(~np.isfinite(vals))
        if bad.size:
            name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_NUMERIC, i) or f"#{i}"
            raise ModelError(f"{source}: custom numeric {name!r}: value {vals[bad[0]]} at position {bad[0]} "
                             "is not finite")
    heavy = np.flatnonzero(np.asarray(model.body_mass) > MAX_BODY_MASS_KG)
    if heavy.size:
        i = int(heavy[0])
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, i) or f"#{i}"
        raise ModelError(f"{source}: body {name!r}: mass {float(model.body_mass[i]):g} kg is beyond "
                         f"{MAX_BODY_MASS_KG:g} kg, implausible for the lab's structures (a unit slip?)")


class MujocoPlant:
    """A running MuJoCo plant.

    Parameters
    ----------
    plant : Plant or mujoco.MjModel
        Built plant (:func:`vlab.sim.build_plant`) or a model of one (e.g. loaded
        with :func:`vlab.sim.load_mjcf`).
    actuators : sequence of int, optional
        Points whose coils :meth:`set_forces` drives, in order; default all
        ``coil<ID>`` actuators (the plant's order).
    settle_first : bool
        Start from the settled state (default) instead of the reference one.

    Attributes
    ----------
    timestep_s : float
        Physics step [s].
    actuator_points : tuple of int
        Points of the driven coils, order of :meth:`set_forces`.
    sensor_points : tuple of int
        Points with a ``vel<ID>`` sensor.
    site_velocity_fallback : bool
        Whether :meth:`velocities` reads the ``p<ID>`` site's velocity at a
        point without a ``vel<ID>`` sensor (an ideal extra transducer): True
        for a plant built here, False for a bare model (an MJCF), which is
        measured by its own sensors only.
    model : mujoco.MjModel
    data : mujoco.MjData
    modal_damping : ModalDamping or None
        The applied modal damping read from the model (set as ``qfrc_applied``
        before every step).

    Raises
    ------
    SimulationError
        An actuator point without a ``coil<ID>`` actuator, or a plant that does
        not settle.
    """

    def __init__(self, plant: Plant | mujoco.MjModel, *, actuators=None, settle_first: bool = True):
        model = plant.model if isinstance(plant, Plant) else plant
        self.plant = plant if isinstance(plant, Plant) else None
        self.model = model
        self.timestep_s = float(model.opt.timestep)
        coils = _numbered(model, mujoco.mjtObj.mjOBJ_ACTUATOR, model.nu, "coil")
        if actuators is None:
            actuators = (self.plant.actuator_points if self.plant is not None
                         else tuple(sorted(coils, key=lambda p: coils[p])))
        missing = [p for p in actuators if p not in coils]
        if missing:
            raise SimulationError(f"no voice-coil actuator at points {missing}; the plant has coils at {sorted(coils)}")
        self.actuator_points = tuple(actuators)
        self._act_ids = np.array([coils[p] for p in self.actuator_points], dtype=int)
        self._rows = sensor_rows(model)
        self.sensor_points = tuple(sorted(self._rows))
        self._sites = _numbered(model, mujoco.mjtObj.mjOBJ_SITE, model.nsite, "p")
        d0 = mujoco.MjData(model)
        mujoco.mj_forward(model, d0)
        self._ref = settle(model) if settle_first else d0
        self._z0 = self._ref.site_xpos[:, 2].copy()
        self.data = mujoco.MjData(model)
        self._rows_cache: dict[tuple, np.ndarray | None] = {}
        self.site_velocity_fallback = self.plant is not None
        self._fresh = False  # position/velocity stages and sensordata computed at data.time
        self.modal_damping = load_modal_damping(model)
        self._modes = None  # modal model, made on first use (:meth:`modal_model`)
        self.reset()

    # -- state
    def reset(self) -> None:
        """Back to the settled state at rest, time 0, forces 0."""
        d = self.data
        mujoco.mj_resetData(self.model, d)
        d.qpos[:] = self._ref.qpos
        d.qvel[:] = 0.0
        mujoco.mj_forward(self.model, d)
        self._fresh = True
        self._warning = d.warning[int(mujoco.mjtWarning.mjWARN_BADQACC)]

    def _sync(self) -> None:
        """Bring site positions, velocities and velocity sensors to the current state (after ``mj_step``)."""
        if not self._fresh:
            m, d = self.model, self.data
            mujoco.mj_fwdPosition(m, d)
            mujoco.mj_fwdVelocity(m, d)
            mujoco.mj_sensorVel(m, d)
            self._fresh = True

    @property
    def time_s(self) -> float:
        """Simulated time since :meth:`reset` [s]."""
        return float(self.data.time)

    def modal_model(self, points) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The plant's out-of-plane modes around the settled state, as its modal damping was designed.

        The modes of :attr:`vlab.sim.Plant.modes` (those the applied modal
        damping was designed on, with the designed ratios) when the plant was
        built here, else a linearisation of the model (:func:`vlab.sim.modes`).

        Parameters
        ----------
        points : sequence of int
            Points whose out-of-plane displacement is returned.

        Returns
        -------
        omega : ndarray, shape (n_modes,)
            Undamped natural frequencies [rad/s].
        zeta : ndarray, shape (n_modes,)
            Damping ratios [1].
        joint_shapes : ndarray, shape (nv, n_modes)
            Mass-normalised shapes in joint coordinates (``phi^T M phi = 1``).
        w : ndarray, shape (len(points), n_modes)
            Their out-of-plane displacement at ``points`` [m/sqrt(kg)].

        Raises
        ------
        SimulationError
            An unknown point, or a model whose linearisation is unstable.
        """
        pts = list(points)
        missing = [p for p in pts if p not in self._sites]
        if missing:
            raise SimulationError(f"unknown points {missing}; points are {sorted(self._sites)}")
        if self._modes is None:
            sm = self.plant.modes if self.plant is not None and self.plant.modes is not None else None
            if sm is None:
                sm = modes(self.model, pts, data=self._ref)
            self._modes = sm
        sm = self._modes
        w = site_jacobian_w(self.model, self._ref, [f"p{p}" for p in pts]) @ sm.joint_shapes
        return sm.omega, np.asarray(sm.damping_ratios), sm.joint_shapes, w

    def set_periodic_state(self, freq_hz, forces) -> None:
        """Put the plant in the steady state of periodic coil forces, at a period's start (warm start).

        The coil forces ``f(t) = Re sum_k F_k exp(j 2 pi f_k t)`` drive each
        mode ``r`` of :meth:`modal_model`; its steady-state coordinate is
        ``q_r = sum_k Re(w_r . F_k / (omega_r^2 - omega_k^2 + 2 j zeta_r omega_r omega_k))``
        at ``t = 0`` (modal superposition, e.g. Ewins, *Modal Testing*, 2nd
        ed., 2000, Sec. 2.5), and the joint state is the settled one plus
        ``Phi q`` and velocity ``Phi q'``. Modes outside the model (the
        discretisation's highest) and the plant's small nonlinearity leave a
        transient that decays within the lab's settling time.

        Parameters
        ----------
        freq_hz : ndarray, shape (n_f,)
            Frequencies of the force lines [Hz].
        forces : ndarray, complex, shape (n_f, n_act)
            Phasors ``F_k`` per coil, order :attr:`actuator_points` [N].

        Raises
        ------
        SimulationError
            Wrong shapes, non-finite values, or no modal model (see :meth:`modal_model`).
        """
        f = np.asarray(freq_hz, dtype=float)
        F = np.asarray(forces, dtype=complex)
        if F.shape != (f.size, len(self.actuator_points)) or not np.all(np.isfinite(F)):
            raise SimulationError(f"set_periodic_state: forces must be finite, shape ({f.size}, "
                                  f"{len(self.actuator_points)}); got {F.shape}")
        omega, zeta, phi, w = self.modal_model(self.actuator_points)
        wl = 2 * np.pi * f
        den = omega[None, :] ** 2 - wl[:, None] ** 2 + 2j * zeta[None, :] * omega[None, :] * wl[:, None]
        q = (F @ w) / den                                  # (n_f, n_modes) modal phasors
        dq = phi @ np.sum(q, axis=0).real                  # joint displacement at t = 0
        v = phi @ np.sum(1j * wl[:, None] * q, axis=0).real
        self.reset()
        d = self.data
        mujoco.mj_integratePos(self.model, d.qpos, dq, 1.0)
        d.qvel[:] = v
        mujoco.mj_forward(self.model, d)
        self._fresh = True

    # -- loop protocol
    def set_forces(self, forces) -> None:
        """Coil forces [N] along world +z, shape (n_actuators,), order ``actuator_points``.

        Parameters
        ----------
        forces : array_like, shape (n_actuators,)

        Raises
        ------
        SimulationError
            For a wrong shape or non-finite values.
        """
        f = np.asarray(forces, dtype=float)
        if f.shape != self._act_ids.shape:
            raise SimulationError(f"set_forces: expected shape ({len(self._act_ids)},) for actuators "
                                  f"{list(self.actuator_points)}, got {f.shape}")
        if not math.isfinite(f.sum()):
            raise SimulationError(f"set_forces: non-finite force {f.tolist()}")
        self.data.ctrl[self._act_ids] = f

    def step(self, n: int = 1) -> None:
        """Advance ``n`` physics steps with the forces last set (and the applied modal damping).

        Parameters
        ----------
        n : int
            Number of steps.

        Raises
        ------
        SimulationError
            When the state turns non-finite or MuJoCo flags a bad acceleration
            (divergence: timestep too large for the hinge chain); the message
            gives the time.
        """
        d = self.data
        self._fresh = False
        if self.modal_damping is None:
            mujoco.mj_step(self.model, d, nstep=n)
        else:
            self.modal_damping.step(self.model, d, n)
        self._check_step(d.qvel)

    def _check_step(self, qvel: np.ndarray) -> None:
        """Raise SimulationError when MuJoCo flagged a bad acceleration or ``qvel`` (``data.qvel``) is non-finite."""
        if self._warning.number or not math.isfinite(qvel[0] + qvel[-1]):
            raise SimulationError(
                f"the MuJoCo plant diverged at t = {self.data.time:.4f} s (bad acceleration / non-finite state): "
                f"the timestep {self.timestep_s:.3g} s is likely too large for the hinge chain"
            )

    def velocities(self, points) -> np.ndarray:
        """Out-of-plane velocities [m/s] at ``points`` at time :attr:`time_s`, shape (len(points),).

        Sensor points read their ``vel<ID>`` sensor from ``sensordata`` (its
        ``cutoff`` applied by MuJoCo), computed at the current state (see the
        module notes on the sampling instant). Other points read the ``p<ID>``
        site's world z velocity when :attr:`site_velocity_fallback` is set, and
        are refused otherwise.

        Parameters
        ----------
        points : sequence of int

        Raises
        ------
        SimulationError
            For an unknown point id, or a point without a ``vel<ID>`` sensor
            in a plant measured by its own sensors only.
        """
        self._sync()
        key = tuple(points)
        rows = self._rows_cache.get(key, False)
        if rows is False:
            rows = (np.array([self._rows[p] for p in key], dtype=int)
                    if all(p in self._rows for p in key) else None)
            self._rows_cache[key] = rows
        if rows is not None:
            return self.data.sensordata[rows]
        return np.array([self.data.sensordata[self._rows[p]] if p in self._rows else self._site_vel(p)
                         for p in key])

    def loop_io(self, sensors, shape_points) -> LoopIO | None:
        """The control loop's per-tick access to this plant for fixed points, checked once here.

        Parameters
        ----------
        sensors : sequence of int
            Points whose velocity :meth:`LoopIO.sample` returns, in order.
        shape_points : sequence of int
            Points whose displacement :meth:`LoopIO.displacements` returns.

        Returns
        -------
        LoopIO or None
            None when a sensor point has no ``vel<ID>`` sensor (the loop then
            uses :meth:`velocities`, which reads the site or says why not).

        Raises
        ------
        SimulationError
            For an unknown shape point (as :meth:`displacements`).
        """
        if not all(p in self._rows for p in sensors):
            return None
        self.displacements(shape_points)  # the unknown-point check
        return LoopIO(self, tuple(sensors), tuple(shape_points))

    def _site_vel(self, p: int) -> float:
        if not self.site_velocity_fallback:
            raise SimulationError(f"no velocity sensor vel{p} in the plant; its velocity sensors are at points "
                                  f"{list(self.sensor_points)}")
        if p not in self._sites:
            raise SimulationError(f"unknown point {p}; points are {sorted(self._sites)}")
        v = np.zeros(6)
        mujoco.mj_objectVelocity(self.model, self.data, mujoco.mjtObj.mjOBJ_SITE, self._sites[p], v, 0)
        return float(v[5])

    def displacements(self, points) -> np.ndarray:
        """Out-of-plane displacements [m] from the settled state at ``points``, shape (len(points),).

        Site positions at the current state, time :attr:`time_s` (see the
        module notes on the sampling instant).

        Parameters
        ----------
        points : sequence of int

        Raises
        ------
        SimulationError
            For an unknown point id.
        """
        self._sync()
        try:
            ids = [self._sites[p] for p in points]
        except KeyError as exc:
            raise SimulationError(f"unknown point {exc.args[0]}; points are {sorted(self._sites)}") from None
        return self.data.site_xpos[ids, 2] - self._z0[ids]


def as_slice(ids: np.ndarray):
    """The index array ``ids`` (ints) as a ``slice`` when it is a run of consecutive indices, else itself.

    The same elements either way; numpy writes through a slice faster than
    through an index array (the coil columns of ``ctrl``, every physics step).
    """
    if ids.size and np.array_equal(ids, np.arange(ids[0], ids[0] + ids.size)):
        return slice(int(ids[0]), int(ids[0]) + ids.size)
    return ids


# looked up once, not per physics step (LoopIO)
_step1, _step2, _dot, _multiply = mujoco.mj_step1, mujoco.mj_step2, np.dot, np.multiply


class LoopIO:
    """The closed loop's access to a :class:`MujocoPlant`, one physics step at a time, without per-call checks.

    Made by :meth:`MujocoPlant.loop_io` for fixed sensor and shape points
    (checked there, once). One controller tick of
    :func:`vlab.lab.loop.run_loop`::

        v = io.sample()          # mj_step1: positions, velocities and sensors at t_k; the sensors' rows
        io.displacements(z)      # site z minus settled z at the shape points, at t_k, into z
        io.drive(f)              # coil forces, modal damping, mj_step2: the tick's first physics step
        io.drive(f)              # any further step of the tick: modal damping + mj_step

    ``mj_step1`` followed by ``mj_step2`` is ``mj_step`` split where a user
    sets forces (MuJoCo documentation, ``mj_step1``/``mj_step2``), so the
    state at the sampling instant is computed once per tick instead of twice
    (after :meth:`MujocoPlant.step`, :meth:`MujocoPlant.velocities` brings the
    stages up to date and the next ``mj_step`` computes them again). The
    trajectory and the readings are those of the public methods, bit for bit
    (tests/test_loop_reference.py). The plant's divergence check runs after every
    step, as :meth:`MujocoPlant.step` does.

    Parameters
    ----------
    plant : MujocoPlant
    sensors : tuple of int
        Points with a ``vel<ID>`` sensor, order of :meth:`sample`.
    shape_points : tuple of int
        Known site points, order of :meth:`displacements`.
    """

    def __init__(self, plant: MujocoPlant, sensors: tuple[int, ...], shape_points: tuple[int, ...]) -> None:
        self._plant = plant
        self._model, self._data = plant.model, plant.data
        d = self._data
        self._sensordata = d.sensordata
        self._rows = np.array([plant._rows[p] for p in sensors], dtype=int)
        self._site_z = d.site_xpos[:, 2]
        sites = np.array([plant._sites[p] for p in shape_points], dtype=int)
        self._sites, self._z0 = sites, plant._z0[sites]
        self._act_ids = as_slice(plant._act_ids)
        self._ctrl, self._qvel = d.ctrl, d.qvel
        damping = plant.modal_damping
        # ModalDamping.apply's force into buffers made once: its one product with -C_m (ModalDamping.dense), or
        # its -(a @ (c * (a.T @ qvel))) as a @ (-c * (a.T @ qvel)) -- the same numbers (negating a factor negates
        # every product and sum exactly; only a zero's sign may differ)
        self._dense = None if damping is None else damping.dense
        self._damping = None if damping is None or self._dense is not None else (
            damping.A, damping.A.T, -damping.c, np.empty(damping.c.shape), d.qfrc_applied)
        self._qfrc = d.qfrc_applied
        self._warning = plant._warning
        self._half = False  # mj_step1 done, mj_step2 pending

    def sample(self) -> np.ndarray:
        """Velocities [m/s] at the sensor points at the current time, shape (n_sensors,).

        Runs ``mj_step1`` (position and velocity stages, their sensors) at
        the current state; the next :meth:`drive` completes that step.
        """
        _step1(self._model, self._data)
        self._half = True
        self._plant._fresh = True
        return self._sensordata[self._rows]

    def displacements(self, out: np.ndarray | None = None) -> np.ndarray:
        """Displacements [m] from the settled state at the shape points, shape (n_shape,), at the last sample.

        ``out`` (n_shape,), optional, receives them (e.g. the loop's row of recorded displacements).
        """
        return np.subtract(self._site_z[self._sites], self._z0, out=out)

    def drive(self, forces) -> None:
        """Hold the coil forces ``forces`` [N] (n_act finite values, array or list) over one physics step and take it.

        Raises
        ------
        SimulationError
            The plant diverged (as :meth:`MujocoPlant.step`).
        """
        self._ctrl[self._act_ids] = forces
        if self._dense is not None:  # ModalDamping.apply's force, without temporaries
            _dot(self._dense, self._qvel, self._qfrc)
        elif self._damping is not None:
            a, at, neg_c, modal, qfrc = self._damping
            _dot(at, self._qvel, modal)
            _multiply(neg_c, modal, modal)
            _dot(a, modal, qfrc)
        if self._half:
            _step2(self._model, self._data)
            self._half = False
        else:
            mujoco.mj_step(self._model, self._data)
        self._plant._fresh = False
        qvel = self._qvel
        if self._warning.number or not math.isfinite(qvel[0] + qvel[-1]):  # MujocoPlant._check_step's test
            self._plant._check_step(qvel)


def load_plant_for_experiment(spec: StructureSpec, *, mjcf: str | Path | None = None, actuators=None,
                              options: SimOptions | None = None, sensors=()) -> tuple[MujocoPlant, dict]:
    """The MuJoCo plant of an experiment, ready for :func:`vlab.lab.loop.run_loop`.

    An MJCF plant is checked against the naming contract first
    (:func:`check_plant_contract`): a ``coil<ID>`` at every actuator point of
    the spec and of ``actuators``, a supported ``vel<ID>`` sensor at every
    sensor and actuator point of the spec and at ``sensors``; it is then
    measured by its own sensors only (no site-velocity fallback).

    Parameters
    ----------
    spec : StructureSpec
        The structure (used to build the plant when ``mjcf`` is None; its
        instrumentation gives the points an MJCF must have).
    mjcf : str or Path, optional
        An exported plant (:func:`vlab.sim.export_mjcf`) to load instead.
    actuators : sequence of int, optional
        Coil points driven by the loop, in order; default all coils.
    options : SimOptions, optional
        Build options (ignored with ``mjcf``).
    sensors : sequence of int
        Further points whose velocity the experiment records (they need a
        ``vel<ID>`` sensor in an MJCF).

    Returns
    -------
    plant : MujocoPlant
    info : dict
        ``kind``, ``source`` (spec file or MJCF path), ``timestep_s``, ``nv``,
        ``segments_per_element`` and ``stiffness_damping_s`` (built plants only),
        ``damping_ratios`` (targets of the modal tendons, built plants only).

    Raises
    ------
    SimulationError
        If the plant cannot be built or settled, or an actuator point has no coil.
    DataFileError
        If ``mjcf`` cannot be loaded.
    ModelError
        If the MJCF breaks the naming contract (names the file and each element)
        or holds non-finite or implausible values (:func:`check_plant_values`).
    """
    from .export import load_mjcf

    if mjcf is not None:
        model = load_mjcf(mjcf)
        check_plant_values(model, source=str(mjcf))
        ins = spec.instrumentation
        spec_acts = tuple(ins.actuators) if ins is not None else ()
        spec_sens = tuple(ins.sensors) if ins is not None else ()
        check_plant_contract(model, actuators=spec_acts + tuple(actuators or ()),
                             sensors=spec_acts + spec_sens + tuple(sensors), source=str(mjcf))
        sim = MujocoPlant(model, actuators=actuators)
        return sim, {"kind": "MuJoCo plant (MJCF)", "source": str(mjcf), "timestep_s": sim.timestep_s,
                     "nv": int(model.nv)}
    plant = build_plant(spec, options)
    sim = MujocoPlant(plant, actuators=actuators)
    info = {"kind": "MuJoCo plant", "source": str(spec.path) if spec.path else spec.name,
            "timestep_s": sim.timestep_s, "nv": int(plant.model.nv),
            "segments_per_element": plant.info.segments_per_element,
            "stiffness_damping_s": plant.info.stiffness_damping_s}
    if plant.damping is not None:
        info["damping_ratios"] = [float(z) for z in plant.damping.target_ratios]
    return sim, info
