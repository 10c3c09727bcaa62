"""A built MuJoCo plant: the compiled model with its MjSpec, its actuator and sensor maps and build info.

:func:`vlab.sim.builder.build_plant` makes a :class:`Plant`; :class:`BuildInfo`
records what the builder made (counts, timestep, hinge damping, mass scaling).

Source: MuJoCo documentation (``doc/APIreference``: ``MjSpec``, ``MjModel``,
``MjData``, ``mj_step``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import mujoco
import numpy as np

from ..spec import StructureSpec
from .damping_matrix import load_modal_damping
from .options import SimOptions


@dataclass(frozen=True)
class BuildInfo:
    """What the builder made (counts and derived numbers), for reports and tests.

    Attributes
    ----------
    n_bodies, n_joints, n_loops : int
        Moving bodies, joints (= DOFs), independent loops of the structure
        (member segments - points + 1; each closed by a weld in the tree
        topology; the forest holds member ends by equalities instead).
    root : int
        Root point of the kinematic tree.
    segments_per_element, crosspiece_segments : int or None
        Links per member segment and per crosspiece arm as configured (None: automatic).
    links : dict of str to int
        Links per segment actually used, per member / crosspiece id (largest over segments).
    timestep_s : float
        Integration step [s].
    omega_max : float
        Highest natural circular frequency of the joint springs [rad/s]
        (dense eigen-analysis of ``(K_hinge, M)`` at qpos0).
    stiffness_damping_s : float
        ``beta`` [s] used for the hinge damping.
    string_tensions_n : dict
        String id -> tension [N].
    n_prestress : int
        Number of constant in-plane loads (redundant forces).
    armature : dict of str to float
        Joints given an armature by mass scaling -> its value [kg m^2 or kg].
    topology : str
        ``"tree"`` or ``"forest"`` (:attr:`SimOptions.topology` resolved).
    """

    n_bodies: int
    n_joints: int
    n_loops: int
    root: int
    segments_per_element: int | None
    crosspiece_segments: int | None
    links: dict[str, int]
    timestep_s: float
    omega_max: float
    stiffness_damping_s: float
    string_tensions_n: dict[str, float]
    n_prestress: int
    armature: dict[str, float] = field(default_factory=dict)
    topology: str = "tree"


@dataclass(frozen=True)
class Plant:
    """A compiled MuJoCo plant and what it is made of.

    Attributes
    ----------
    spec : StructureSpec
        The structure it was built from.
    options : SimOptions
        Resolved build options.
    mjspec : mujoco.MjSpec
        The editable model definition (compile it again after changes).
    model : mujoco.MjModel
        The compiled model.
    actuator_points : tuple of int
        Point ids of the voice coils, in ``ctrl`` order (actuators ``coil<ID>``
        come first; the ``prestress*`` actuators after them take no control).
    sensor_points : tuple of int
        Point ids of the velocity sensors ``vel<ID>`` (actuator points first).
    sensor_rows : dict of int to int
        Point id -> row in ``MjData.sensordata`` of its out-of-plane velocity [m/s].
    info : BuildInfo
    damping : DampingReport or None
        Modal damping targets and coefficients (None when disabled).
    modes : SimModes or None
        All modes of the plant as its damping was designed (frequencies and
        shapes of the settled, linearised plant; the designed damping ratios),
        a by-product of the modal damping (None when it is disabled): what
        :func:`vlab.sim.modes` of the damped plant would return, without a
        second linearisation.

    The applied modal damping (if any) lives in the model's custom numerics;
    step with :class:`vlab.sim.MujocoPlant` (or :meth:`step`) to have it.
    """

    spec: StructureSpec
    options: SimOptions
    mjspec: mujoco.MjSpec
    model: mujoco.MjModel
    actuator_points: tuple[int, ...]
    sensor_points: tuple[int, ...]
    sensor_rows: dict[int, int]
    info: BuildInfo
    damping: Any = None
    modes: Any = None

    @property
    def timestep_s(self) -> float:
        """Integration step [s]."""
        return float(self.model.opt.timestep)

    def point_sites(self) -> dict[int, int]:
        """Point id -> site id of ``p<ID>``."""
        return {p: self.model.site(f"p{p}").id for p in self.spec.points}

    def make_data(self) -> mujoco.MjData:
        """A fresh MjData at the reference (flat) configuration, forward-evaluated."""
        d = mujoco.MjData(self.model)
        mujoco.mj_forward(self.model, d)
        return d

    @property
    def modal_damping(self):
        """The applied modal damping (:class:`vlab.sim.damping_matrix.ModalDamping`) or None."""
        return load_modal_damping(self.model)

    def step(self, data: mujoco.MjData, n: int = 1) -> None:
        """Advance ``data`` by ``n`` steps with the applied modal damping (if any).

        Parameters
        ----------
        data : mujoco.MjData
        n : int
            Number of steps.
        """
        md = self.modal_damping
        if md is None:
            mujoco.mj_step(self.model, data, nstep=n)
        else:
            md.step(self.model, data, n)

    def velocities(self, data: mujoco.MjData) -> np.ndarray:
        """Out-of-plane velocities [m/s] at ``sensor_points`` read from ``data.sensordata``, shape (n_sensors,)."""
        return np.array([data.sensordata[self.sensor_rows[p]] for p in self.sensor_points])

