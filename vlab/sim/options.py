"""How a MuJoCo plant is discretised and simulated: :class:`SimOptions` and the integrators it names.

The options are read by the planner (:mod:`vlab.sim.planner`), the MjSpec
emitter (:mod:`vlab.sim.emit`) and the builder (:mod:`vlab.sim.builder`);
``None`` fields take the spec's ``[mujoco]`` value (:meth:`SimOptions.resolved`).

Sources: MuJoCo documentation
(``doc/computation/index.rst``: integrators).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import mujoco

from ..errors import SimulationError
from ..spec import StructureSpec

#: MuJoCo integrator of each :attr:`SimOptions.integrator` name.
INTEGRATORS = {
    "implicitfast": mujoco.mjtIntegrator.mjINT_IMPLICITFAST,
    "implicit": mujoco.mjtIntegrator.mjINT_IMPLICIT,
    "euler": mujoco.mjtIntegrator.mjINT_EULER,
    "explicit": mujoco.mjtIntegrator.mjINT_EULER,  # with mjDSBL_EULERDAMP: every damping force explicit
    "rk4": mujoco.mjtIntegrator.mjINT_RK4,
}


@dataclass(frozen=True)
class SimOptions:
    """How a plant is discretised and simulated. ``None`` fields take the spec's
    ``[mujoco]`` value, else the module default.

    Attributes
    ----------
    segments_per_element : int, optional
        Hinge-chain links per member segment (between consecutive points).
        ``[mujoco] segments_per_element``; default automatic (:func:`vlab.sim.hinges.auto_links`:
        ``max(MIN_LINKS, ceil(L_f / LINK_LENGTH_M))``, 2 on the BCC, 3-4 on the
        grid's bars, 2-4 on its shear-flexible top beam; 1 on a shear-flexible
        segment short against its shear length, ``12 EI / (kGA L_f^2) >
        SHEAR_SHORT_PHI``, the grid's 22 mm top-beam segments; see
        :mod:`vlab.sim.planner`).
    member_segments : dict of str to int, optional
        Links per segment for individual members (member id -> n), over
        ``[mujoco] segments = { <member id> = n }`` and ``segments_per_element``.
    crosspiece_segments : int, optional
        Links per crosspiece arm. ``[mujoco] crosspiece_segments``; default
        automatic: the fewest that place the tip-loaded arm's own bending
        resonance within :data:`vlab.sim.hinges.ARM_FREQUENCY_TOL`
        (:func:`vlab.sim.hinges.arm_links`; 3 on the BCC).
    timestep_s : float, optional
        Integration step [s]. ``[mujoco] timestep``; default automatic: the
        largest ``LAB_PERIOD_S / k`` (k = 1, 2, ...) with ``omega_max * dt <=
        AUTO_LIMIT``, so that the lab's 2 kHz sample is a whole number of steps.
    integrator : str
        ``"implicitfast"`` (joint and modal-tendon damping integrated
        implicitly, see :mod:`vlab.sim.damping`), ``"implicit"``, ``"euler"``
        (MuJoCo's Euler: joint damping still implicit; modal tendons then sized
        for explicit stability), ``"explicit"`` (semi-implicit Euler with every
        damping force explicit, ``mjDSBL_EULERDAMP``), ``"rk4"`` or ``"auto"``
        (default): ``"explicit"`` in the forest topology, ``"implicitfast"`` in
        the tree. The hinge damping ``beta k`` is light (``dt beta omega_max^2
        ~ 0.07`` on the grid), so its implicit treatment buys no stability;
        explicit, the step skips the factorisation of ``M + dt D`` (about 8 % of
        the grid's forest step; ``benchmarks/grid_speed.py --steps``) with the
        same modes and pulse response.
    hinge_layout : str
        ``"gauss"`` (default) or ``"uniform"``; see :func:`vlab.sim.hinges.hinge_layout`.
    stiffness_damping_s : float, optional
        ``beta`` [s] of the hinge damping ``beta * k``. ``[mujoco]
        stiffness_damping``; default: chosen so that it gives at most 20 % of
        the smallest target damping ratio at the highest damped mode.
    modal_damping : bool
        Impose the spec's modal damping ratios (default True).
    damping_method : str
        ``"applied"`` (default: exact modal damping force set before each step by
        :class:`~vlab.sim.runtime.MujocoPlant`, stored in the model as custom
        numerics) or ``"tendons"`` (fixed tendons, native but slow); see
        :mod:`vlab.sim.damping`.
    n_damped_modes : int, optional
        Modes given their damping ratio; default ``len(spec.damping.modal_ratios)``
        (ratios beyond those use ``default_ratio``).
    inplane_redundants : bool
        Apply the FE statics' in-plane redundant forces at loop cuts and extra
        in-plane supports (default True; no effect on determinate structures;
        off when gravity is off, as they are gravity loads).
    gravity : bool
        Gravity on (default). Off removes the gravity geometric stiffness.
    check_timestep : bool
        Raise :class:`SimulationError` before running when ``omega_max * dt``
        exceeds :data:`vlab.sim.timestep.STABILITY_LIMIT` (default True).
    max_substeps : int
        Automatic timestep: the step is at least ``LAB_PERIOD_S / max_substeps``
        (default 1: the lab's 0.5 ms period. On the grid the scaled hinges leave the
        first 12 cross-check frequencies unchanged within 0.01 %, and the FRFs after
        a force pulse differ from those at 0.125 ms by 0.2 dB rms in 1-20 Hz,
        measured with ``benchmarks/sim_speed.py --accuracy``; at 0.25 ms the grid
        ran below real time, 0.67x).
    topology : str
        How the plant's bodies are joined (:mod:`vlab.sim.planner`, "Topology").
        ``"tree"``: one kinematic tree grown breadth first from the root point;
        a member segment that closes a loop is welded to its far junction
        through an in-plane release. ``"forest"``: junctions hung from the
        world by their own joints, members as chains between them, a member's
        end that reaches a junction held there by linear equalities (fixed
        tendons with the first-order kinematics at the flat state, held at
        zero length), the in-plane FE statics' end forces of every such end as
        ``prestress*`` loads. ``"auto"`` (default): ``"forest"`` for a
        structure with loops, else ``"tree"``. On the grid the forest needs
        one Newton factorisation of a sparse Hessian per step where the loop
        welds coupled every joint around their loops (docs/plants.md, speed).
    torsion_hinges : str
        ``"middle"`` (default): a segment's torsion compliance ``L_f / GJ``
        on one hinge, its middle one (exact for the end torques a segment
        carries; its rotary inertia about the member axis, small in these
        sections, is lumped in two halves); ``"all"``: a torsion hinge at
        every Gauss point with the Gauss weight's share. On the grid
        ``"middle"`` saves 50 of 215 DOFs and moves none of the 12
        cross-check frequencies by more than 0.06 %.
    mass_scaling : bool
        When the stiffest hinges would need a smaller step than chosen
        (very short stiff segments), give those hinges an ``armature`` (added
        rotary inertia on the hinge coordinate, "selective mass scaling") that
        brings their frequency down to ``AUTO_LIMIT / dt`` -- but only if that
        lowers none of the first 15 modes by more than ``MASS_SCALING_TOL``
        (:func:`vlab.sim.timestep.armature_effect`); otherwise the small step is taken. Default
        True; the added inertias are in :attr:`vlab.sim.plant.BuildInfo.armature`.
    """

    segments_per_element: int | None = None
    member_segments: dict[str, int] | None = None
    crosspiece_segments: int | None = None
    timestep_s: float | None = None
    integrator: str = "auto"
    hinge_layout: str = "gauss"
    stiffness_damping_s: float | None = None
    modal_damping: bool = True
    damping_method: str = "applied"
    n_damped_modes: int | None = None
    inplane_redundants: bool = True
    gravity: bool = True
    check_timestep: bool = True
    max_substeps: int = 1
    mass_scaling: bool = True
    topology: str = "auto"
    torsion_hinges: str = "middle"

    def resolved(self, spec: StructureSpec) -> "SimOptions":
        """Options with every ``None`` replaced by the spec's [mujoco] value or the default.

        Raises
        ------
        SimulationError
            A non-positive segment count or timestep, an unknown integrator, damping
            method, topology or torsion_hinges, or a [mujoco] value of the wrong
            type (the message names the key).
        """
        mj = spec.mujoco

        def pick(name: str, key: str, default: Any, kind: type) -> Any:
            v = getattr(self, name)
            if v is None:
                v = mj.get(key, default)
                if v is not None and (isinstance(v, bool) or not isinstance(v, (int, float) if kind is float else int)):
                    raise SimulationError(f"{spec._file()}: [mujoco] {key} = {v!r}: expected a {kind.__name__}")
            return v if v is None else kind(v)

        out = dataclasses.replace(
            self,
            segments_per_element=pick("segments_per_element", "segments_per_element", None, int),
            crosspiece_segments=pick("crosspiece_segments", "crosspiece_segments", None, int),
            timestep_s=pick("timestep_s", "timestep", None, float),
            stiffness_damping_s=pick("stiffness_damping_s", "stiffness_damping", None, float),
        )
        if (out.segments_per_element is not None and out.segments_per_element < 1) or (
                out.crosspiece_segments is not None and out.crosspiece_segments < 1):
            raise SimulationError(
                f"segments_per_element and crosspiece_segments must be >= 1, got "
                f"{out.segments_per_element} and {out.crosspiece_segments}"
            )
        if out.timestep_s is not None and not (math.isfinite(out.timestep_s) and out.timestep_s > 0):
            raise SimulationError(f"timestep_s must be a positive time [s], got {out.timestep_s!r}")
        if out.integrator not in INTEGRATORS and out.integrator != "auto":
            raise SimulationError(f"unknown integrator {out.integrator!r}; use one of {sorted(INTEGRATORS)} "
                                  "or 'auto'")
        if out.torsion_hinges not in ("middle", "all"):
            raise SimulationError(f"unknown torsion_hinges {out.torsion_hinges!r}; use 'middle' or 'all'")
        if out.topology not in ("auto", "tree", "forest"):
            raise SimulationError(f"unknown topology {out.topology!r}; use 'auto', 'tree' or 'forest'")
        if out.damping_method not in ("applied", "tendons"):
            raise SimulationError(f"unknown damping_method {out.damping_method!r}; use 'applied' or 'tendons'")
        if out.stiffness_damping_s is not None and not out.stiffness_damping_s >= 0:
            raise SimulationError(f"stiffness_damping_s must be >= 0, got {out.stiffness_damping_s!r}")
        return out

