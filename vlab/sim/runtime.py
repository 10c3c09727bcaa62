"""Stepping a MuJoCo plant: the runtime object the lab's control loop drives.

:class:`MujocoPlant` implements the plant protocol of :mod:`vlab.lab.loop`
(``timestep_s``, ``actuator_points``, ``set_forces``, ``step``,
``velocities``, ``displacements``) on a compiled vlab plant -- built from a
spec (:func:`vlab.sim.build_plant`) or loaded from an exported MJCF file --
starting from its settled state. It finds everything by name: actuators
``coil<ID>``, sensors ``vel<ID>`` (``actuatorvel``, or ``framelinvel`` /
``velocimeter`` whose z component is used) and sites ``p<ID>``
(:mod:`vlab.sim.contract`). The loop's per-tick access is
:class:`vlab.sim.loopio.LoopIO`.

Measured velocities come from the model's own ``vel<ID>`` sensors
(``MjData.sensordata``), so an edited MJCF is measured as edited: a sensor
moved to another site measures there, and a sensor's ``cutoff`` clips its
reading to ``[-cutoff, cutoff]`` m/s as MuJoCo computes it (a saturating
transducer). What vlab cannot honour is refused when an MJCF is loaded
(:func:`vlab.sim.contract.check_plant_contract`): a missing or renamed ``coil<ID>`` /
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
from pathlib import Path

import mujoco
import numpy as np

from ..errors import ModelError, SimulationError
from ..spec import StructureSpec
from .body_weights import carry_weights
from .builder import build_plant
from .contract import check_plant_contract, check_plant_values, numbered, sensor_rows
from .damping_matrix import load_modal_damping
from .linearize import modes, settle, site_jacobian_w
from .loopio import LoopIO
from .options import SimOptions
from .plant import Plant


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
        coils = numbered(model, mujoco.mjtObj.mjOBJ_ACTUATOR, model.nu, "coil")
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
        self._sites = numbered(model, mujoco.mjtObj.mjOBJ_SITE, model.nsite, "p")
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
        module notes on the sampling instant). ``points`` as in :meth:`velocities`;
        an unknown point id raises :class:`SimulationError`.
        """
        self._sync()
        try:
            ids = [self._sites[p] for p in points]
        except KeyError as exc:
            raise SimulationError(f"unknown point {exc.args[0]}; points are {sorted(self._sites)}") from None
        return self.data.site_xpos[ids, 2] - self._z0[ids]


def load_plant_for_experiment(spec: StructureSpec, *, mjcf: str | Path | None = None, actuators=None,
                              options: SimOptions | None = None, sensors=()) -> tuple[MujocoPlant, dict]:
    """The MuJoCo plant of an experiment, ready for :func:`vlab.lab.loop.run_loop`.

    An MJCF plant is checked against the naming contract first
    (:func:`vlab.sim.contract.check_plant_contract`): a ``coil<ID>`` at every actuator point of
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
        ``damping_ratios`` (targets of the modal tendons, built plants only), ``notes`` (MJCF only: the
        added masses whose weight was carried into the in-plane statics, :mod:`vlab.sim.body_weights`).

    Raises
    ------
    SimulationError
        If the plant cannot be built or settled, or an actuator point has no coil.
    DataFileError
        If ``mjcf`` cannot be loaded.
    ModelError
        If the MJCF breaks the naming contract (names the file and each element)
        or holds non-finite or implausible values (:func:`vlab.sim.contract.check_plant_values`).
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
        try:
            notes = carry_weights(model, spec)  # added masses weigh (vlab.sim.body_weights)
        except ModelError as exc:
            raise ModelError(f"{mjcf}: {exc}") from None
        sim = MujocoPlant(model, actuators=actuators)
        return sim, {"kind": "MuJoCo plant (MJCF)", "source": str(mjcf), "timestep_s": sim.timestep_s,
                     "nv": int(model.nv), "notes": notes}
    plant = build_plant(spec, options)
    sim = MujocoPlant(plant, actuators=actuators)
    info = {"kind": "MuJoCo plant", "source": str(spec.path) if spec.path else spec.name,
            "timestep_s": sim.timestep_s, "nv": int(plant.model.nv),
            "segments_per_element": plant.info.segments_per_element,
            "stiffness_damping_s": plant.info.stiffness_damping_s}
    if plant.damping is not None:
        info["damping_ratios"] = [float(z) for z in plant.damping.target_ratios]
    return sim, info
