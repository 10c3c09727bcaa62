"""The closed loop's per-tick access to a running MuJoCo plant: :class:`LoopIO`.

``mj_step1`` followed by ``mj_step2`` is ``mj_step`` split where a user sets
forces, so the state at the sampling instant is computed once per tick
(see :class:`LoopIO`). Made by :meth:`vlab.sim.runtime.MujocoPlant.loop_io`.

Source: MuJoCo documentation (``doc/APIreference/functions.rst``:
``mj_step1``, ``mj_step2``).
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

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
    """The closed loop's access to a :class:`~vlab.sim.runtime.MujocoPlant`, one physics step at a time, without per-call checks.

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

    def __init__(self, plant, sensors: tuple[int, ...], shape_points: tuple[int, ...]) -> None:
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
