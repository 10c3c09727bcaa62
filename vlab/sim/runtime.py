"""Stepping a MuJoCo plant: the runtime object the lab's control loop drives.

:class:`MujocoPlant` implements the plant protocol of :mod:`vlab.lab.loop`
(``timestep_s``, ``actuator_points``, ``set_forces``, ``step``,
``velocities``, ``displacements``) on a compiled :class:`~vlab.sim.builder.Plant`,
starting from its settled state. Sign conventions: a positive force on
``coil<ID>`` pushes point ``ID`` along world +z, and the velocity sensor
``vel<ID>`` reads +z velocity positive -- so collocated rate feedback
``u = -D y`` with ``D`` positive definite removes energy.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from ..errors import SimulationError
from .builder import Plant
from .linearize import settle


class MujocoPlant:
    """A running MuJoCo plant.

    Parameters
    ----------
    plant : Plant
        Built plant (:func:`vlab.sim.build_plant`).
    settle_first : bool
        Start from the settled state (default) instead of the reference one.

    Attributes
    ----------
    timestep_s : float
        Physics step [s].
    actuator_points : tuple of int
        Points of the voice coils, order of :meth:`set_forces`.
    model : mujoco.MjModel
    data : mujoco.MjData

    Raises
    ------
    SimulationError
        If the plant does not settle.
    """

    def __init__(self, plant: Plant, *, settle_first: bool = True):
        self.plant = plant
        self.model = plant.model
        self.timestep_s = float(plant.model.opt.timestep)
        self.actuator_points = tuple(plant.actuator_points)
        self._act_ids = np.array([self.model.actuator(f"coil{p}").id for p in self.actuator_points], dtype=int)
        self._rows = dict(plant.sensor_rows)
        self._sites = {p: self.model.site(f"p{p}").id for p in plant.spec.points}
        self._ref = settle(self.model) if settle_first else plant.make_data()
        self._z0 = self._ref.site_xpos[:, 2].copy()
        self.data = mujoco.MjData(self.model)
        self.reset()

    # -- state
    def reset(self) -> None:
        """Back to the settled state at rest, time 0, forces 0."""
        d = self.data
        mujoco.mj_resetData(self.model, d)
        d.qpos[:] = self._ref.qpos
        d.qvel[:] = 0.0
        mujoco.mj_forward(self.model, d)

    @property
    def time_s(self) -> float:
        """Simulated time since :meth:`reset` [s]."""
        return float(self.data.time)

    # -- loop protocol
    def set_forces(self, forces) -> None:
        """Coil forces [N] along world +z, shape (n_actuators,), order ``actuator_points``.

        Raises
        ------
        SimulationError
            For a wrong shape or non-finite values.
        """
        f = np.asarray(forces, dtype=float)
        if f.shape != (len(self._act_ids),):
            raise SimulationError(f"set_forces: expected shape ({len(self._act_ids)},) for actuators "
                                  f"{list(self.actuator_points)}, got {f.shape}")
        if not np.all(np.isfinite(f)):
            raise SimulationError(f"set_forces: non-finite force {f.tolist()}")
        self.data.ctrl[self._act_ids] = f

    def step(self, n: int = 1) -> None:
        """Advance ``n`` physics steps with the forces last set.

        Raises
        ------
        SimulationError
            When the state turns non-finite or MuJoCo flags a bad acceleration
            (divergence: timestep too large for the hinge chain); the message
            gives the time.
        """
        d = self.data
        mujoco.mj_step(self.model, d, nstep=n)
        if d.warning[mujoco.mjtWarning.mjWARN_BADQACC].number or not math.isfinite(d.qvel[0] + d.qvel[-1]):
            raise SimulationError(
                f"the MuJoCo plant diverged at t = {d.time:.4f} s (bad acceleration / non-finite state): "
                f"the timestep {self.timestep_s:.3g} s is likely too large for the hinge chain"
            )

    def velocities(self, points) -> np.ndarray:
        """Out-of-plane velocities [m/s] at ``points``, shape (len(points),).

        Sensor points read their ``vel<ID>`` sensor; other points the ``p<ID>``
        site's world z velocity.

        Raises
        ------
        SimulationError
            For an unknown point id.
        """
        out = np.empty(len(points))
        d = self.data
        for i, p in enumerate(points):
            row = self._rows.get(p)
            if row is not None:
                out[i] = d.sensordata[row]
            else:
                out[i] = self._site_vel(p)
        return out

    def _site_vel(self, p: int) -> float:
        if p not in self._sites:
            raise SimulationError(f"unknown point {p}; points are {sorted(self._sites)}")
        v = np.zeros(6)
        mujoco.mj_objectVelocity(self.model, self.data, mujoco.mjtObj.mjOBJ_SITE, self._sites[p], v, 0)
        return float(v[5])

    def displacements(self, points) -> np.ndarray:
        """Out-of-plane displacements [m] from the settled state at ``points``, shape (len(points),).

        Raises
        ------
        SimulationError
            For an unknown point id.
        """
        try:
            ids = [self._sites[p] for p in points]
        except KeyError as exc:
            raise SimulationError(f"unknown point {exc.args[0]}; points are {sorted(self._sites)}") from None
        return self.data.site_xpos[ids, 2] - self._z0[ids]
