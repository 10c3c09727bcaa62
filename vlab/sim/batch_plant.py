"""N MuJoCo plants stepped together on one ``mujoco.batch.Batch``: the plant side of the batched lab.

:class:`BatchPlant` is the small interface the batched loop
(:func:`vlab.lab.batch.run_batch`) drives -- step all N simulations, write
their coil forces, read their sensors at the sampling instant, per-simulation
parameters -- so that another backend (e.g. ``mujoco-warp`` on a GPU) can be
put behind it without touching the controller or measurement code.
:class:`MujocoBatchPlant` implements it on ``mujoco.batch.Batch`` (mujoco
4.0: simulations on a thread pool, bit-identical to a loop over single
``MjData``; its module docstring).

Each simulation does what :class:`vlab.sim.runtime.MujocoPlant` does for one:
it starts at rest in its settled state, sets the applied modal damping
``qfrc_applied = -A diag(c) A^T qvel`` (:mod:`vlab.sim.damping`) before every
physics step, and reads its ``vel<ID>`` sensors from ``sensordata`` computed
at the sampling instant (the step that ends a controller period computes the
position and velocity stages at the new state, ``stage=mjSTAGE_VEL``, as
``MujocoPlant`` does with ``mj_fwdPosition``/``mj_fwdVelocity``/``mj_sensorVel``).

Per-simulation parameters come two ways:

* ``fields``: MjModel fields given per simulation with ``Batch.expand``
  (e.g. ``body_mass`` (N, nbody) [kg], ``jnt_stiffness`` (N, njnt) [N*m/rad],
  ``actuator_gainprm`` (N, nu, 10)); ``mj_setConst`` follows
  (``Batch.set_const``) and each simulation is settled again. The modal
  damping matrix stays the nominal model's (a physical damping matrix, not
  re-fitted to the changed modes).
* ``models``: one compiled plant per simulation (``Batch.set_models``), e.g.
  built from perturbed specs; each carries its own modal damping.

Source: mujoco 4.0 ``mujoco.batch`` docstrings; the sampling instant and the
modal damping as in :mod:`vlab.sim.runtime` and :mod:`vlab.sim.damping`.
"""

from __future__ import annotations

from typing import Protocol

import mujoco
import mujoco.batch
import numpy as np

from ..errors import ModelError, SimulationError
from .contract import numbered, sensor_rows
from .damping_matrix import load_modal_damping
from .linearize import settle
from .loopio import as_slice
from .runtime import MujocoPlant

_VEL, _NONE = int(mujoco.mjtStage.mjSTAGE_VEL), int(mujoco.mjtStage.mjSTAGE_NONE)

#: Fields whose change needs ``mj_setConst`` (masses and inertias feed the derived constants).
_SETCONST_FIELDS = frozenset(getattr(mujoco.MjModel, "_setconst_inputs", ()))


#: MjModel sizes that do not shape ``MjData`` (names and the model's own buffers): left out of the layout.
_NOT_LAYOUT = frozenset({"nbuffer", "nnames", "nnames_map", "npaths", "ntext", "ntextdata", "ntuple", "ntupledata",
                         "nuserdata"})


def layout(model) -> tuple:
    """The sizes of a compiled model that shape its ``MjData``: ``((name, size), ...)``, sorted by name.

    Models of one layout can share a :class:`MujocoBatchPlant` (``Batch.set_models``).

    Every integer ``n*`` attribute of ``mujoco.MjModel`` (``nq``, ``nv``, ``nu``,
    ``ngeom``, ``nsensordata``, ...) but the sizes of its names and text
    (:data:`_NOT_LAYOUT`; ``nuserdata`` is kept out too as vlab sets none).

    Parameters
    ----------
    model : mujoco.MjModel

    Returns
    -------
    tuple of (str, int)
    """
    out = []
    for name in dir(model):
        if name.startswith("n") and name not in _NOT_LAYOUT:
            v = getattr(model, name)
            if isinstance(v, int) and not isinstance(v, bool):
                out.append((name, v))
    return tuple(out)


class BatchPlant(Protocol):
    """What the batched loop needs from N plants.

    Attributes
    ----------
    n_sim : int
        Number of simulations N.
    timestep_s : float
        Physics step h [s], common to all simulations.
    actuator_points : tuple of int, length n_act
        Coil points, column order of :meth:`set_forces`.
    alive : ndarray of bool, shape (N,)
        Simulations still stepping (a diverged one is stopped by :meth:`stop`).

    Notes
    -----
    A structural type (``typing.Protocol``), never instantiated; its
    placeholder constructor takes ``*args, **kwargs`` that mean nothing.
    """

    n_sim: int
    timestep_s: float
    actuator_points: tuple[int, ...]
    alive: np.ndarray

    def set_forces(self, forces: np.ndarray) -> None:
        """Coil forces [N], shape (N, n_act), held over the following physics steps."""
        ...

    def step(self, *, sample: bool) -> None:
        """One physics step of every live simulation; ``sample`` makes the sensors current at the new state."""
        ...

    def velocities(self, points: tuple[int, ...]) -> np.ndarray:
        """Out-of-plane velocities [m/s], shape (N, len(points)), at the last sampling instant."""
        ...

    def displacements(self, points: tuple[int, ...]) -> np.ndarray:
        """Out-of-plane displacements from each settled state [m], shape (N, len(points))."""
        ...

    def time_s(self) -> np.ndarray:
        """Simulated time of each simulation [s], shape (N,)."""
        ...

    def stop(self, sims: np.ndarray) -> None:
        """Stop stepping the simulations ``sims`` (indices): they diverged."""
        ...


class MujocoBatchPlant:
    """N vlab MuJoCo plants on one ``mujoco.batch.Batch`` (implements :class:`BatchPlant`).

    Parameters
    ----------
    plant : MujocoPlant
        The nominal plant (its model, actuators, sensors, settled state and
        modal damping).
    n_sim : int
        Number of simulations N >= 1.
    nthread : int
        Threads of the batch (0: all CPUs).
    fields : dict of str to array_like, optional
        Per-simulation MjModel fields, each of shape (N, ...) as
        ``Batch.expand(name)`` returns (see the module notes).
    models : sequence of mujoco.MjModel, optional
        One model per simulation, compiled from the same spec (same sizes);
        exclusive with ``fields``.
    sample_sites : bool
        Whether :meth:`displacements` will be used (binds ``site_xpos``, which
        the batch then copies out after every call).

    Raises
    ------
    ModelError
        ``n_sim`` < 1, an unknown field, a field of the wrong shape or with
        non-finite values, ``models`` of the wrong count, or both ``fields``
        and ``models``.
    SimulationError
        A simulation that does not settle.
    """

    def __init__(self, plant: MujocoPlant, n_sim: int, *, nthread: int = 0, fields: dict | None = None,
                 models=None, sample_sites: bool = False) -> None:
        if isinstance(n_sim, bool) or int(n_sim) != n_sim or n_sim < 1:
            raise ModelError(f"n_sim must be a positive integer, got {n_sim!r}")
        if fields and models is not None:
            raise ModelError("give per-simulation parameters as fields or as models, not both")
        n = int(n_sim)
        m = plant.model
        self.n_sim = n
        self.model = m
        self.timestep_s = plant.timestep_s
        self.actuator_points = tuple(plant.actuator_points)
        self.batch = mujoco.batch.Batch(m, n, nthread=nthread, persistent=True)
        b = self.batch
        refs = None
        dampings = [plant.modal_damping] * n
        if models is not None:
            models = list(models)
            if len(models) != n:
                raise ModelError(f"models: expected {n} models (one per simulation), got {len(models)}")
            b.set_models(models)
            refs = [settle(mi).qpos.copy() for mi in models]
            dampings = [load_modal_damping(mi) for mi in models]
        elif fields:
            setconst = False
            for name, value in fields.items():
                if name not in mujoco.batch.MODEL_FIELDS:
                    raise ModelError(f"fields: unknown MjModel field {name!r}")
                arr = b.expand(name)
                val = np.asarray(value, dtype=float)
                if val.shape != arr.shape:
                    raise ModelError(f"fields[{name!r}]: expected shape {arr.shape}, found {val.shape}")
                if not np.all(np.isfinite(val)):
                    raise ModelError(f"fields[{name!r}]: non-finite values")
                arr[...] = val
                setconst |= name in _SETCONST_FIELDS
            if setconst:
                b.set_const()
            refs = [settle(b.get_model(i)).qpos.copy() for i in range(n)]
        self._qpos_ref = (np.tile(plant._ref.qpos, (n, 1)) if refs is None else np.array(refs))
        self._qpos = b.bind("qpos")
        self._qvel = b.bind("qvel")
        self._ctrl = b.bind("ctrl")
        self._qfrc = b.bind("qfrc_applied")
        self._dense_damping, self._damping = self._stack_damping(dampings)
        self._time = b.bind("time")
        self._sensordata = b.bind("sensordata")
        self._rows = sensor_rows(m)
        self._row_cache: dict = {}
        coils = numbered(m, mujoco.mjtObj.mjOBJ_ACTUATOR, m.nu, "coil")
        self._act_ids = np.array([coils[p] for p in self.actuator_points], dtype=int)
        self._ctrl_shape = (n, self._act_ids.size)
        self._act_cols = as_slice(self._act_ids)
        self._sites = numbered(m, mujoco.mjtObj.mjOBJ_SITE, m.nsite, "p")
        self._site_xpos = b.bind("site_xpos") if sample_sites else None
        self.alive = np.ones(n, dtype=bool)
        self._ids = None
        self.reset()

    def _stack_damping(self, dampings):
        """``(dense, factored)``: the applied modal damping's stacked operands in the form ModalDamping.apply
        takes (:attr:`vlab.sim.damping_matrix.ModalDamping.dense`), the other None; both None without damping."""
        if all(d is None for d in dampings):
            return None, None
        if any(d is None for d in dampings):
            raise ModelError("models: some simulations carry applied modal damping and some do not")
        if all(d.dense is not None for d in dampings):  # one product with -C_m, as ModalDamping.apply
            shared = all(d is dampings[0] for d in dampings)
            dense = dampings[0].dense[None] if shared else np.array([d.dense for d in dampings])
            return (dense, self._qvel[:, :, None], self._qfrc[:, :, None]), None
        if all(d is dampings[0] for d in dampings):
            a, c = dampings[0].A[None], dampings[0].c[None]  # broadcast over the simulations
        else:
            a, c = np.array([d.A for d in dampings]), np.array([d.c for d in dampings])
        # (A, A^T, -c, qvel and qfrc_applied as (N, nv, 1), the modal forces' buffer (N, n_damped, 1)); -c: the
        # damping force -A (c * (A^T qvel)) as A (-c * (A^T qvel)), the same numbers (negation is exact)
        return None, (a, a.transpose(0, 2, 1), -c[:, :, None], self._qvel[:, :, None],
                      np.empty((self.n_sim, a.shape[2], 1)), self._qfrc[:, :, None])

    def reset(self) -> None:
        """Every simulation back to its settled state at rest, time 0, forces 0 (and all alive)."""
        b = self.batch
        b.reset(stage=int(mujoco.mjtStage.mjSTAGE_NONE))
        self._qpos[:] = self._qpos_ref
        self._qvel[:] = 0.0
        self._ctrl[:] = 0.0
        self._qfrc[:] = 0.0
        b.forward()
        z0 = b.bind("site_xpos")[:, :, 2].copy() if self._site_xpos is None else self._site_xpos[:, :, 2].copy()
        self._z0 = z0
        self.alive[:] = True
        self._ids = None

    def set_state(self, qpos: np.ndarray, qvel: np.ndarray) -> None:
        """Every simulation reset (time 0, forces 0, all alive) and then put at its own joint state.

        What :meth:`vlab.sim.runtime.MujocoPlant.set_periodic_state` leaves in one
        ``MjData`` -- a reset, the joint positions and velocities written, the
        stages computed (``mj_forward``) -- done per simulation, so that a
        warm-started run continues as the single plant would: copy each single
        plant's ``data.qpos`` and ``data.qvel`` here. The displacements of
        :meth:`displacements` stay measured from each settled state.

        Parameters
        ----------
        qpos : ndarray, shape (N, nq)
            Joint positions (hinge angles [rad]).
        qvel : ndarray, shape (N, nv)
            Joint velocities [rad/s].

        Raises
        ------
        SimulationError
            Wrong shapes or non-finite values.

        Source: the ``mujoco.batch.Batch.reset`` docstring (``stage=mjSTAGE_NONE``
        followed by writes to the state and ``forward()``).
        """
        qp, qv = np.asarray(qpos, dtype=float), np.asarray(qvel, dtype=float)
        if qp.shape != self._qpos.shape or qv.shape != self._qvel.shape:
            raise SimulationError(f"set_state: expected qpos {self._qpos.shape} and qvel {self._qvel.shape}, "
                                  f"got {qp.shape} and {qv.shape}")
        if not (np.all(np.isfinite(qp)) and np.all(np.isfinite(qv))):
            raise SimulationError("set_state: non-finite joint state")
        self.reset()  # the settled sites' heights (displacements' zero), all alive
        self.batch.reset(stage=_NONE)
        self._qpos[:] = qp
        self._qvel[:] = qv
        self._ctrl[:] = 0.0
        self._qfrc[:] = 0.0
        self.batch.forward()

    def set_forces(self, forces: np.ndarray) -> None:
        """Coil forces [N] along world +z, shape (N, n_act), order :attr:`actuator_points`.

        Raises
        ------
        SimulationError
            Wrong shape.
        """
        f = np.asarray(forces, dtype=float)
        if f.shape != self._ctrl_shape:
            raise SimulationError(f"set_forces: expected shape ({self.n_sim}, {self._act_ids.size}), got {f.shape}")
        self._ctrl[:, self._act_cols] = f

    def step(self, *, sample: bool) -> None:
        """One physics step of every live simulation, with the applied modal damping set first.

        Parameters
        ----------
        sample : bool
            Compute the position and velocity stages (and sensors) at the new
            state: the step ends a controller period.
        """
        if self._dense_damping is not None:  # ModalDamping.dense: one stacked product
            dense, qvel, qfrc = self._dense_damping
            np.matmul(dense, qvel, out=qfrc)
        elif self._damping is not None:
            a, at, neg_c, qvel, modal, qfrc = self._damping
            # stacked matrix-vector products, slice by slice as MujocoPlant's a @ (-c * (a.T @ qvel)), into buffers
            np.matmul(at, qvel, out=modal)
            np.multiply(neg_c, modal, out=modal)
            np.matmul(a, modal, out=qfrc)
        self.batch.step(ids=self._ids, stage=_VEL if sample else _NONE)

    def velocities(self, points) -> np.ndarray:
        """Out-of-plane velocities [m/s] from the ``vel<ID>`` sensors, shape (N, len(points)).

        Raises
        ------
        SimulationError
            A point without a ``vel<ID>`` sensor.
        """
        key = tuple(points)
        rows = self._row_cache.get(key)
        if rows is None:
            try:
                rows = np.array([self._rows[p] for p in key], dtype=int)
            except KeyError as exc:
                raise SimulationError(f"no velocity sensor vel{exc.args[0]}; sensors are at "
                                      f"{sorted(self._rows)}") from None
            self._row_cache[key] = rows
        return self._sensordata[:, rows]

    def displacements(self, points) -> np.ndarray:
        """Out-of-plane displacements [m] from each settled state, shape (N, len(points)).

        Raises
        ------
        SimulationError
            An unknown point, or a plant made without ``sample_sites``.
        """
        if self._site_xpos is None:
            raise SimulationError("displacements need a MujocoBatchPlant made with sample_sites=True")
        try:
            ids = [self._sites[p] for p in points]
        except KeyError as exc:
            raise SimulationError(f"unknown point {exc.args[0]}; points are {sorted(self._sites)}") from None
        return self._site_xpos[:, ids, 2] - self._z0[:, ids]

    def time_s(self) -> np.ndarray:
        """Simulated time of each simulation [s], shape (N,) (a copy)."""
        return self._time.copy()

    def stop(self, sims) -> None:
        """Stop stepping the simulations ``sims`` (indices into 0..N-1)."""
        self.alive[np.asarray(sims, dtype=int)] = False
        self._ids = np.flatnonzero(self.alive).astype(np.int32)
