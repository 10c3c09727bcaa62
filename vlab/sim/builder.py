"""Build the MuJoCo plant of a structure from its :class:`~vlab.spec.StructureSpec`.

The plant is assembled with :class:`mujoco.MjSpec` (never string XML) and
models the **out-of-plane** motion only: the structure lies in the world
plane (x, y), ``w`` is the world z translation, and every joint is a hinge
about an in-plane axis or a slide along z. Gravity (magnitude 9.80665 m/s^2)
acts in the plane along the spec's gravity direction, so its geometric
stiffness comes out of the simulation itself.

Discretisation (a hinge chain with Gauss-placed hinges)
-------------------------------------------------------
Each member segment between two consecutive points, of flexible length
``L_f = L - a_1 - a_2`` (rigid inserts ``a`` at its ends, Sec. 2.1.1), gets
``n`` hinges (``segments_per_element``). Hinge ``k`` sits at ``a_1 + s_k L_f``
and has the compliance share ``c_k`` (:func:`vlab.sim.planner.hinge_layout`):

* bending stiffness ``EI / (c_k L_f)`` about the in-plane axis perpendicular to
  the member, ``(e_y, -e_x, 0)`` (a positive angle is a positive slope dw/ds);
* torsion stiffness ``GJ / (c_k L_f)`` about the member axis ``e``, where the
  spec's active DOFs contain the rotation about that axis;
* for a shear-flexible section (``shear_stiffness`` kGA, the grid's sandwich
  top beam, Sec. 2.2.1) also a slide along z of stiffness ``kGA / (c_k L_f)``.

With the default ``"gauss"`` layout ``s_k``, ``c_k`` are the n-point
Gauss-Legendre abscissae and weights: the chain's end flexibility is then
*exact* for end loads and uniform loads (n >= 2), i.e. a cantilever's tip
stiffness and a frame member's sway stiffness ``12 EI/L^3`` come out right
with two hinges. The ``"uniform"`` layout (hinges at the link midpoints, ``c_k
= 1/n``: ``EI/l`` per hinge, ``2EI/l`` equivalent at a clamp) is stiffer by
``1/(4 n^2)`` (cantilever) to ``1/n^2`` (double curvature) and needs about
twice the links for the same accuracy (README: convergence study).

Every structure point is a rigid **junction body** carrying the pieces of all
members up to their first hinge (with rigid inserts), its lumped masses, its
sites and its actuator. A clamped end is therefore no special case: the clamp
side of the first hinge is rigid. Link inertia comes from the section: mass
``rho_a l``, torsional inertia ``rho_ip l`` about the member axis,
``m (l^2 + t^2)/12`` about the bending axis, combined with point masses by the
parallel-axis theorem into one explicit inertia per body.

Topology
--------
The kinematic tree (or, for a structure with loops, the forest of chains and
their linear closures), its loop-closing welds, the in-plane releases and the
redundant in-plane forces are planned in :mod:`vlab.sim.planner` (see there).
The forest's closures are emitted here (:func:`build_mjspec`), as they need the
compiled model's first-order kinematics.

Other elements
--------------
* Strings (cables) are spatial tendons from a world anchor at the string
  length ``L`` along the string direction, with stiffness ``T/L`` and zero rest
  length: the tendon pulls with exactly ``T`` and its transverse stiffness is
  exactly ``T/L`` at any deflection. The tension is carried into the beam,
  whose hinge chain gets its geometric stiffness from it. ``"reaction"``
  tensions come from the FE statics. A third of the string mass is lumped at
  its point, as in the FE string element.
* Crosspieces are two flexible cantilever arms (bending only; rigid in
  torsion) with tip masses, clamped to the junction at the crosspiece point,
  starting ``crosspiece_root_offset`` from its centre (default: the rigid
  insert length at that point, i.e. half the clamp).
* Grounded springs become joint stiffness at the root, a *pendulum plate*
  (the plate's lumped mass hung ``Y = k / W`` below its point, so that gravity
  gives ``W Y``, Sec. 2.2.1; see :meth:`vlab.sim.planner._Planner._plates` for how plates are
  recognised, ``[mujoco] pendulum_plates`` overrides), or otherwise a fixed
  tendon with the first-order kinematic coefficients of that DOF.
* Voice coils: ``general`` actuator ``coil<ID>`` on site ``coil<ID>`` with the
  world-fixed refsite ``coil<ID>_ref``, gear along +z: ``ctrl`` is the force in N
  along world +z. Velocity sensors ``vel<ID>``: ``actuatorvel`` at actuator
  points, ``framelinvel`` (world frame; its z component is the velocity) at
  the other measured points. Site ``p<ID>`` at every point.

Damping
-------
Hinge springs get a stiffness-proportional damping ``beta * k`` (``beta``
small, for the discretisation's high modes). The spec's modal damping ratios
are imposed exactly with the modal damping matrix of the damped modes,
applied as a generalized force before every step (stored in the model's
custom numerics) or as fixed tendons; see :mod:`vlab.sim.damping`.

Timestep
--------
Chosen in :func:`build_plant` with the functions of :mod:`vlab.sim.timestep`
(the hinge chain's highest frequency, the automatic step, selective mass
scaling, the stability check).

Spec keys read from ``[mujoco]`` (all optional)
-----------------------------------------------
``segments_per_element`` (int), ``segments`` (table member id -> int),
``crosspiece_segments`` (int), ``timestep`` [s], ``stiffness_damping``
(``beta`` [s]), ``crosspiece_root_offset`` [m], ``pendulum_plates`` (table
spring id -> mass id, or false). :class:`SimOptions` fields override them.

Sources: DESIGN.md ("MuJoCo facts"); Sec. 2.1, 2.1.1, 2.2, 2.2.1 of the
dissertation; MuJoCo documentation (``doc/XMLreference.rst``: tendon,
equality, actuator/general refsite; ``doc/computation/index.rst``:
integrators).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from ..errors import SimulationError
from ..spec import StructureSpec
from ..units import G_SI
from .planner import _combine, _Plan, plan_structure
from .timestep import (AUTO_LIMIT, LAB_PERIOD_S, MASS_SCALING_TOL, armature_effect, auto_timestep, check_timestep,
                       hinge_omega_max, mass_scaling_armature)

#: Weld/connect constraint impedance that makes a weld behave as rigid (DESIGN.md).
RIGID_SOLIMP = (0.9999, 0.9999, 0.001, 0.5, 2.0)

#: Newton solver tolerance of the forest topology (MuJoCo's default 1e-8). At rest, the forest's warm-started
#: solver took no iteration for a coil force below about 1e-4 N (its cost change is below the line search's
#: threshold): the force was lost, and so were the finite-difference linearisation's input and applied-damping
#: columns (the grid's modal damping read 7-65 % of its target, the simulated free decay 100 %). At 1e-12
#: forces down to 1e-9 N move the plant, at no measurable cost (one Newton iteration per step either way).
FOREST_TOLERANCE = 1e-12

_INTEGRATORS = {
    "implicitfast": mujoco.mjtIntegrator.mjINT_IMPLICITFAST,
    "implicit": mujoco.mjtIntegrator.mjINT_IMPLICIT,
    "euler": mujoco.mjtIntegrator.mjINT_EULER,
    "explicit": mujoco.mjtIntegrator.mjINT_EULER,  # with mjDSBL_EULERDAMP: every damping force explicit
    "rk4": mujoco.mjtIntegrator.mjINT_RK4,
}


# ------------------------------------------------------------------ options ---


@dataclass(frozen=True)
class SimOptions:
    """How a plant is discretised and simulated. ``None`` fields take the spec's
    ``[mujoco]`` value, else the module default.

    Attributes
    ----------
    segments_per_element : int, optional
        Hinge-chain links per member segment (between consecutive points).
        ``[mujoco] segments_per_element``; default automatic (:func:`auto_links`:
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
        automatic as for members (2 on the BCC).
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
        ``"gauss"`` (default) or ``"uniform"``; see :func:`vlab.sim.planner.hinge_layout`.
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
        exceeds :data:`STABILITY_LIMIT` (default True).
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
        (:func:`armature_effect`); otherwise the small step is taken. Default
        True; the added inertias are in :attr:`BuildInfo.armature`.
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
        if out.integrator not in _INTEGRATORS and out.integrator != "auto":
            raise SimulationError(f"unknown integrator {out.integrator!r}; use one of {sorted(_INTEGRATORS)} "
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


# --------------------------------------------------------------------- emit ---


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


def _quat_z(angle: float) -> list[float]:
    return [math.cos(angle / 2), 0.0, 0.0, math.sin(angle / 2)]


def _emit(spec: StructureSpec, plan: _Plan, opts: SimOptions, beta: float) -> mujoco.MjSpec:
    ms = mujoco.MjSpec()
    ms.modelname = f"vlab_{spec.name}"
    ms.compiler.degree = False  # radians everywhere (compiler angle="radian")
    ms.compiler.autolimits = True
    ms.option.timestep = opts.timestep_s
    ms.option.integrator = _INTEGRATORS[opts.integrator]
    if opts.integrator == "explicit":
        ms.option.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_EULERDAMP)
    g = np.array([*spec.gravity_direction, 0.0]) * G_SI if opts.gravity else np.zeros(3)
    ms.option.gravity = g.tolist()
    ms.option.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
    if plan.topology == "forest":
        ms.option.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_ISLAND)  # one island: its bookkeeping ~6 % of a step
        ms.option.tolerance = FOREST_TOLERANCE
    ms.comment = (
        f"vlab MuJoCo plant of '{spec.title}' ({spec.name}) built from "
        f"{Path(spec.path).name if spec.path else 'an in-memory spec'} by vlab.sim.builder "
        f"(segments_per_element={opts.segments_per_element}, crosspiece_segments={opts.crosspiece_segments}, "
        f"timestep={opts.timestep_s}, beta={beta:.3g} s). Out-of-plane motion only; SI units."
    )
    ms.stat.extent = 2.5
    made: dict[str, Any] = {"": ms.worldbody}
    for name, pos, info in plan.world_sites:
        s = ms.worldbody.add_site(name=name, pos=pos.tolist(), size=[0.004, 0, 0], group=4)
        s.info = info
    for b in plan.bodies.values():
        parent = made[b.parent] if b.parent is not None else ms.worldbody
        porigin = plan.bodies[b.parent].origin if b.parent is not None else np.zeros(3)
        body = parent.add_body(name=b.name, pos=(b.origin - porigin).tolist())
        body.info = b.info
        made[b.name] = body
        mass, ipos, inertia = _combine(b.items, b.origin, b.name)
        body.explicitinertial = True
        body.mass = mass
        body.ipos = ipos.tolist()
        body.fullinertia = [inertia[0, 0], inertia[1, 1], inertia[2, 2], inertia[0, 1], inertia[0, 2], inertia[1, 2]]
        for j in b.joints:
            jt = mujoco.mjtJoint.mjJNT_HINGE if j.kind == "hinge" else mujoco.mjtJoint.mjJNT_SLIDE
            joint = body.add_joint(name=j.name, type=jt, axis=j.axis.tolist(), pos=(j.pos - b.origin).tolist())
            joint.stiffness = [j.stiffness, 0.0, 0.0]
            joint.damping = [beta * j.stiffness if j.elastic else 0.0, 0.0, 0.0]
            joint.armature = j.armature
            joint.info = j.info
        for v in b.visuals:
            if v.kind == "box":
                geom = body.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=list(v.size),
                                     pos=(v.pos - b.origin).tolist(), quat=_quat_z(v.angle), rgba=list(v.rgba))
            else:
                geom = body.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[v.size[0], 0, 0],
                                     pos=(v.pos - b.origin).tolist(), rgba=list(v.rgba))
            geom.contype = 0
            geom.conaffinity = 0
            geom.group = 1
            geom.density = 0.0
        for name, pos, info in b.sites:
            s = body.add_site(name=name, pos=(pos - b.origin).tolist(), size=[0.004, 0, 0], group=3)
            s.info = info
    for name, ws, bs, k, tension, info in plan.strings:
        t = ms.add_tendon(name=name)
        t.wrap_site(ws)
        t.wrap_site(bs)
        t.stiffness = [k, 0.0, 0.0]
        t.springlength = [0.0, 0.0]
        t.width = 0.0015
        t.info = info
    dt = opts.timestep_s
    for name, s1, s2, info in plan.welds:
        eq = ms.add_equality(name=name, type=mujoco.mjtEq.mjEQ_WELD, objtype=mujoco.mjtObj.mjOBJ_SITE,
                             name1=s1, name2=s2)
        eq.solref = [2 * dt, 1.0]
        eq.solimp = list(RIGID_SOLIMP)
        eq.info = info
    for name, s1, s2, info in plan.connects:
        eq = ms.add_equality(name=name, type=mujoco.mjtEq.mjEQ_CONNECT, objtype=mujoco.mjtObj.mjOBJ_SITE,
                             name1=s1, name2=s2)
        eq.solref = [2 * dt, 1.0]
        eq.solimp = list(RIGID_SOLIMP)
        eq.info = info
    ins = spec.instrumentation
    if ins is not None:
        for p in ins.actuators:
            a = ms.add_actuator(name=f"coil{p}", trntype=mujoco.mjtTrn.mjTRN_SITE, target=f"coil{p}",
                                refsite=f"coil{p}_ref")
            a.gear = [0.0, 0.0, 1.0, 0.0, 0.0, 0.0]
            a.gaintype = mujoco.mjtGain.mjGAIN_FIXED
            a.gainprm[0] = 1.0
            a.biastype = mujoco.mjtBias.mjBIAS_NONE
            a.dyntype = mujoco.mjtDyn.mjDYN_NONE
            a.info = f"spec: voice-coil actuator at point {p}: ctrl = force [N] along world +z"
    for name, site, ref, wrench, info in plan.prestress:
        mag = float(np.linalg.norm(wrench))
        a = ms.add_actuator(name=name, trntype=mujoco.mjtTrn.mjTRN_SITE, target=site, refsite=ref)
        a.gear = (wrench / mag).tolist()
        a.gainprm[0] = 0.0
        a.biastype = mujoco.mjtBias.mjBIAS_AFFINE
        a.biasprm[0] = mag
        a.ctrllimited = False
        a.group = 5
        a.info = info + f" (constant {mag:.6g})"
    if ins is not None:
        for p in ins.actuators:
            s = ms.add_sensor(name=f"vel{p}", type=mujoco.mjtSensor.mjSENS_ACTUATORVEL,
                              objtype=mujoco.mjtObj.mjOBJ_ACTUATOR, objname=f"coil{p}")
            s.info = f"spec: collocated velocity sensor at point {p} [m/s], +z"
        for p in ins.sensors:
            if p in ins.actuators:
                continue
            s = ms.add_sensor(name=f"vel{p}", type=mujoco.mjtSensor.mjSENS_FRAMELINVEL,
                              objtype=mujoco.mjtObj.mjOBJ_SITE, objname=f"p{p}")
            s.info = f"spec: velocity sensor at point {p}: world-frame velocity, z component = w' [m/s]"
    return ms


def _site_rows(model: mujoco.MjModel, data: mujoco.MjData, site: str, dofs: tuple[str, ...]) -> np.ndarray:
    """First-order kinematics d(dof at site)/dq, one row per dof of ``"w"``, ``"rx"``, ``"ry"``, shape (len(dofs), nv)."""
    jacp = np.zeros((3, model.nv))
    jacr = np.zeros((3, model.nv))
    mujoco.mj_jacSite(model, data, jacp, jacr, model.site(site).id)
    return np.array([jacp[2] if d == "w" else jacr[0 if d == "rx" else 1] for d in dofs])


def _joint_coefs(model: mujoco.MjModel, row: np.ndarray) -> dict[str, float]:
    """Joint name -> coefficient of the nonzero entries of a row over the DOFs (hinge/slide joints only)."""
    out = {}
    for j in range(model.njnt):
        c = row[model.jnt_dofadr[j]]
        if abs(c) > 1e-12:
            out[model.joint(j).name] = float(c)
    return out


def _add_linear_closures(ms: mujoco.MjSpec, model: mujoco.MjModel, data: mujoco.MjData, plan: _Plan,
                         dt: float) -> None:
    """Hold each closure's two sites together in w and the active rotations, to first order.

    One fixed tendon per DOF with the coefficients of ``d(dof at site1 - dof at
    site2)/dq`` at the flat state (``data``), held at zero length by a tendon
    equality as rigid as the welds (``solref = (2 dt, 1)``, :data:`RIGID_SOLIMP`).
    The equalities carry no force in the flat state (no out-of-plane load), so
    their curvature adds no stiffness to the linearised plant; at second order
    they leave the in-plane gap free, as the in-plane release does for a weld.
    """
    for name, s1, s2, dofs, info in plan.closures:
        rows = _site_rows(model, data, s1, dofs) - _site_rows(model, data, s2, dofs)
        for d, row in zip(dofs, rows):
            t = ms.add_tendon(name=f"{name}.{d}")
            for jn, c in _joint_coefs(model, row).items():
                t.wrap_joint(jn, c)
            t.info = f"{info}: {d} of {s1} minus {d} of {s2} (first order)"
            eq = ms.add_equality(name=f"{name}.{d}", type=mujoco.mjtEq.mjEQ_TENDON,
                                 objtype=mujoco.mjtObj.mjOBJ_TENDON, name1=t.name)
            eq.solref = [2 * dt, 1.0]
            eq.solimp = list(RIGID_SOLIMP)
            eq.info = f"{info}: equal {d}"


# --------------------------------------------------------------------- plant ---


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
        """The applied modal damping (:class:`vlab.sim.damping.ModalDamping`) or None."""
        from .damping import load_modal_damping

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


def _sensor_rows(model: mujoco.MjModel, points: tuple[int, ...], actuators: tuple[int, ...]) -> dict[int, int]:
    rows = {}
    for p in points:
        s = model.sensor(f"vel{p}")
        adr = int(s.adr[0])
        rows[p] = adr if p in actuators else adr + 2  # framelinvel: z component
    return rows


def build_mjspec(spec: StructureSpec, options: SimOptions | None = None, *,
                 beta: float = 0.0, armature: dict[str, float] | None = None) -> tuple[mujoco.MjSpec, dict[str, Any]]:
    """Build the MjSpec of ``spec`` without modal-damping tendons.

    Parameters
    ----------
    spec : StructureSpec
    options : SimOptions, optional
    beta : float
        Stiffness-proportional hinge damping factor [s].
    armature : dict of str to float, optional
        Joint name -> armature [kg m^2 or kg] (mass scaling, see :class:`SimOptions`).

    Returns
    -------
    mjspec : mujoco.MjSpec
    extra : dict
        ``"plan"``, ``"options"`` (resolved, with the topology and integrator
        that ``"auto"`` chose), ``"root"``, ``"string_tensions"``.

    Raises
    ------
    SimulationError
        For a spec the plant cannot represent (see :func:`build_plant`).

    Notes
    -----
    Grounded springs away from the root and the forest's closures need the
    first-order kinematics of the flat state: the spec is compiled once, their
    fixed tendons (and the closures' tendon equalities) are added, and the
    returned spec holds them.
    """
    opts = (options or SimOptions()).resolved(spec)
    if opts.timestep_s is None:
        opts = dataclasses.replace(opts, timestep_s=LAB_PERIOD_S)
    plan, planner = plan_structure(spec, opts)
    integrator = opts.integrator
    if integrator == "auto":
        integrator = "explicit" if plan.topology == "forest" else "implicitfast"
    opts = dataclasses.replace(opts, topology=plan.topology, integrator=integrator)
    ms = _emit(spec, plan, opts, beta)
    for name, a in (armature or {}).items():
        ms.joint(name).armature = float(a)
    if planner.pending_springs or plan.closures:
        # grounded springs away from the root and the forest's closures: fixed tendons with
        # first-order coefficients
        model = _compile(ms, spec)
        data = mujoco.MjData(model)
        mujoco.mj_forward(model, data)
        _add_linear_closures(ms, model, data, plan, opts.timestep_s)
        for sp in planner.pending_springs:
            coefs = _joint_coefs(model, _site_rows(model, data, f"p{sp.point}", (sp.dof,))[0])
            if not coefs:
                raise SimulationError(f"{spec._file()}: spring {sp.id!r}: DOF {sp.dof} of point {sp.point} "
                                      "does not move in the plant")
            t = ms.add_tendon(name=f"spring.{sp.id}")
            for jn, c in coefs.items():
                t.wrap_joint(jn, c)
            t.stiffness = [sp.stiffness.si, 0.0, 0.0]
            t.springlength = [0.0, 0.0]
            t.info = f"spec: spring {sp.id} at point {sp.point} on {sp.dof} (first-order kinematics)"
    extra = {"plan": plan, "options": opts, "root": planner.root, "links": planner.links,
             "string_tensions": dict(planner.gs.string_tensions)}
    return ms, extra


def _compile(ms: mujoco.MjSpec, spec: StructureSpec) -> mujoco.MjModel:
    try:
        return ms.compile()
    except Exception as exc:  # mujoco raises ValueError with the compiler message
        raise SimulationError(f"{spec._file()}: MuJoCo could not compile the plant: {exc}") from exc


#: Plants of unchanged structures (damping bases), by the identity of the spec and its ratios.
_BASIS_PLANTS: dict = {}


def _basis_damping(spec: StructureSpec, options: SimOptions | None, model0: mujoco.MjModel):
    """The damping of the unchanged structure that ``spec`` names as its basis (:attr:`vlab.spec.Damping.basis`):
    ``(beta, ModalDamping, DampingReport, dof_damping)``, or None when there is none or its plant's joints
    differ from ``model0``'s (then the changed plant's damping is designed on its own modes)."""
    d = spec.damping
    if d is None or d.basis is None:
        return None
    key = (id(d.basis), d.modal_ratios, d.default_ratio, repr(options))
    hit = _BASIS_PLANTS.get(key)
    if hit is None or hit[0] is not d.basis:
        base = build_plant(d.basis.replace(damping=dataclasses.replace(d, basis=None)), options)
        if len(_BASIS_PLANTS) >= 8:
            _BASIS_PLANTS.pop(next(iter(_BASIS_PLANTS)))
        hit = _BASIS_PLANTS[key] = (d.basis, base)
    base = hit[1]
    names = [base.model.joint(i).name for i in range(base.model.njnt)]
    if base.model.nv != model0.nv or names != [model0.joint(i).name for i in range(model0.njnt)]:
        return None
    md = base.modal_damping
    if md is None:
        return None
    return base.options.stiffness_damping_s or 0.0, md, base.damping, np.array(base.model.dof_damping)


def _set_joint_damping(ms: mujoco.MjSpec, model0: mujoco.MjModel, dof_damping: np.ndarray) -> None:
    """Give every joint of ``ms`` the damping of its DOF in ``dof_damping`` (joints matched by name with
    ``model0``, whose DOF layout ``dof_damping`` follows)."""
    for j in ms.joints:
        jid = model0.joint(j.name).id
        adr = int(model0.jnt_dofadr[jid])
        v = np.array(j.damping, dtype=float)
        v[0] = dof_damping[adr]
        j.damping = v


def build_plant(spec: StructureSpec, options: SimOptions | None = None) -> Plant:
    """Build and compile the MuJoCo plant of a structure.

    Parameters
    ----------
    spec : StructureSpec
        The structure (``load_spec("bcc")``).
    options : SimOptions, optional
        Discretisation, timestep, damping; defaults from the spec's [mujoco] table.

    Returns
    -------
    Plant
        Compiled model with its MjSpec, actuator/sensor maps and build info.

    Raises
    ------
    SimulationError
        For a spec the plant cannot represent (no in-plane root, members that bend
        about an inactive rotation, a partial support away from the root, rigid
        inserts longer than a segment, an unreachable point), a failed
        compilation, a plant that does not settle, or -- with ``check_timestep``
        -- a timestep too large for the stiffest hinge (:func:`check_timestep`).

    Notes
    -----
    With ``modal_damping`` the model is built twice: once undamped, to settle
    and linearise it (:mod:`vlab.sim.linearize`) and compute the modal damping
    (:mod:`vlab.sim.damping`), then with hinge damping and modal damping.
    """
    from .damping import add_modal_tendons, modal_damping_plan, projected_modes, store_modal_damping

    opts = (options or SimOptions()).resolved(spec)
    armature: dict[str, float] = {}
    probe, _ = build_mjspec(spec, dataclasses.replace(opts, timestep_s=opts.timestep_s or LAB_PERIOD_S), beta=0.0)
    probe_model = _compile(probe, spec)
    omega, _ = hinge_omega_max(probe_model)
    dt = opts.timestep_s
    if dt is None:
        dt = max(auto_timestep(omega), LAB_PERIOD_S / opts.max_substeps) if opts.mass_scaling else auto_timestep(omega)
    if omega * dt > AUTO_LIMIT and opts.mass_scaling:
        trial = mass_scaling_armature(probe_model, AUTO_LIMIT / dt)
        if armature_effect(probe_model, trial) <= MASS_SCALING_TOL:
            armature = trial
        elif opts.timestep_s is None:
            dt = auto_timestep(omega)  # scaling would move the low modes: take the small step
    opts = dataclasses.replace(opts, timestep_s=dt)
    ms0, extra = build_mjspec(spec, opts, beta=0.0, armature=armature)
    opts = dataclasses.replace(opts, topology=extra["options"].topology, integrator=extra["options"].integrator)
    model0 = _compile(ms0, spec)
    omega, _ = hinge_omega_max(model0)
    if opts.check_timestep:
        check_timestep(model0)
    beta = opts.stiffness_damping_s
    report = None
    md = None
    designed = None
    kept = _basis_damping(spec, options, model0) if opts.modal_damping and opts.damping_method == "applied" else None
    if kept is not None:  # a changed structure keeps the unchanged one's damping (vlab.fe.damping)
        beta, md, report, dof_damping = kept
        ms, extra = build_mjspec(spec, opts, beta=beta, armature=armature)
        _set_joint_damping(ms, model0, dof_damping)
        designed = projected_modes(spec, model0, dof_damping, md)
    elif spec.damping is not None and (opts.modal_damping or beta is None):
        beta, md, report, designed = modal_damping_plan(spec, model0, beta, opts.n_damped_modes,
                                                        method=opts.damping_method)
        if not opts.modal_damping:
            md, report, designed = None, None, None
    beta = float(beta or 0.0)
    if kept is not None:
        pass
    elif beta > 0.0:
        ms, extra = build_mjspec(spec, opts, beta=beta, armature=armature)
    else:
        ms = ms0
    if md is not None:
        if opts.damping_method == "tendons":
            add_modal_tendons(ms, model0, md, report)
        else:
            store_modal_damping(ms, md)
    model = _compile(ms, spec)
    ins = spec.instrumentation
    acts = tuple(ins.actuators) if ins else ()
    sens = tuple(dict.fromkeys(list(acts) + (list(ins.sensors) if ins else [])))
    info = BuildInfo(
        n_bodies=model.nbody - 1,
        n_joints=model.njnt,
        n_loops=extra["plan"].n_loops,
        root=extra["root"],
        segments_per_element=opts.segments_per_element,
        crosspiece_segments=opts.crosspiece_segments,
        links=dict(extra["links"]),
        timestep_s=opts.timestep_s,
        omega_max=omega,
        stiffness_damping_s=beta,
        string_tensions_n=extra["string_tensions"],
        n_prestress=len(extra["plan"].prestress),
        armature=armature,
        topology=extra["plan"].topology,
    )
    return Plant(spec, dataclasses.replace(opts, stiffness_damping_s=beta), ms, model, acts, sens,
                 _sensor_rows(model, sens, acts), info, report, designed)
