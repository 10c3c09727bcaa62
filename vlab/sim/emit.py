"""Emit a planned plant into a :class:`mujoco.MjSpec` (bodies, joints, tendons, equalities, actuators, sensors).

:func:`build_mjspec` plans a structure (:func:`vlab.sim.planner.plan_structure`)
and emits the plan: bodies with their explicit inertia, joints with their
stiffness, hinge damping and armature, strings as spatial tendons, welds
and connects as rigid equalities, voice coils, the ``prestress*`` loads and
the velocity sensors (the naming is described in :mod:`vlab.sim.builder`).
The forest topology's closures and the grounded springs away from the root
need the compiled model's first-order kinematics at the flat state
(``mj_jacSite``): the spec is compiled once for them.

Sources: MuJoCo documentation
(``doc/XMLreference.rst``: tendon, equality, actuator/general refsite;
``doc/APIreference/functions.rst``: ``mj_jacSite``).
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from ..errors import SimulationError
from ..spec import StructureSpec, input_gains
from ..units import G_SI
from .options import INTEGRATORS, SimOptions
from .plan import Plan, combine_items
from .planner import plan_structure
from .timestep import LAB_PERIOD_S

#: Weld/connect constraint impedance that makes a weld behave as rigid (``d = 0.9999``, the largest impedance
#: MuJoCo's constraint regularisation allows).
RIGID_SOLIMP = (0.9999, 0.9999, 0.001, 0.5, 2.0)

#: Newton solver tolerance of the forest topology (MuJoCo's default 1e-8). At rest, the forest's warm-started
#: solver took no iteration for a coil force below about 1e-4 N (its cost change is below the line search's
#: threshold): the force was lost, and so were the finite-difference linearisation's input and applied-damping
#: columns (the grid's modal damping read 7-65 % of its target, the simulated free decay 100 %). At 1e-12
#: forces down to 1e-9 N move the plant, at no measurable cost (one Newton iteration per step either way).
FOREST_TOLERANCE = 1e-12


def _quat_z(angle: float) -> list[float]:
    return [math.cos(angle / 2), 0.0, 0.0, math.sin(angle / 2)]


def _options(spec: StructureSpec, plan: Plan, opts: SimOptions, beta: float) -> mujoco.MjSpec:
    """A new MjSpec with the plant's compiler settings, physics options and comment."""
    ms = mujoco.MjSpec()
    ms.modelname = f"vlab_{spec.name}"
    ms.compiler.degree = False  # radians everywhere (compiler angle="radian")
    ms.compiler.autolimits = True
    ms.option.timestep = opts.timestep_s
    ms.option.integrator = INTEGRATORS[opts.integrator]
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
    return ms


def _bodies(ms: mujoco.MjSpec, plan: Plan, beta: float) -> None:
    """The world sites, then every body (parent before child) with its inertia, joints, visuals and sites."""
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
        mass, ipos, inertia = combine_items(b.items, b.origin, b.name)
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


def _strings_and_equalities(ms: mujoco.MjSpec, plan: Plan, dt: float) -> None:
    """The strings as spatial tendons, then the welds and the connects as rigid equalities (``solref = (2 dt, 1)``)."""
    for name, ws, bs, k, tension, info in plan.strings:
        t = ms.add_tendon(name=name)
        t.wrap_site(ws)
        t.wrap_site(bs)
        t.stiffness = [k, 0.0, 0.0]
        t.springlength = [0.0, 0.0]
        t.width = 0.0015
        t.info = info
    for kind, equalities in ((mujoco.mjtEq.mjEQ_WELD, plan.welds), (mujoco.mjtEq.mjEQ_CONNECT, plan.connects)):
        for name, s1, s2, info in equalities:
            eq = ms.add_equality(name=name, type=kind, objtype=mujoco.mjtObj.mjOBJ_SITE, name1=s1, name2=s2)
            eq.solref = [2 * dt, 1.0]
            eq.solimp = list(RIGID_SOLIMP)
            eq.info = info


def _actuators_and_sensors(ms: mujoco.MjSpec, spec: StructureSpec, plan: Plan) -> None:
    """The voice coils ``coil<ID>``, the constant ``prestress*`` loads, then the velocity sensors ``vel<ID>``."""
    ins = spec.instrumentation
    if ins is not None:
        gains = input_gains(spec, ins.actuators)  # the [hardware] table's coil gains: force per command
        for p, gain in zip(ins.actuators, gains):
            a = ms.add_actuator(name=f"coil{p}", trntype=mujoco.mjtTrn.mjTRN_SITE, target=f"coil{p}",
                                refsite=f"coil{p}_ref")
            a.gear = [0.0, 0.0, 1.0, 0.0, 0.0, 0.0]
            a.gaintype = mujoco.mjtGain.mjGAIN_FIXED
            a.gainprm[0] = float(gain)
            a.biastype = mujoco.mjtBias.mjBIAS_NONE
            a.dyntype = mujoco.mjtDyn.mjDYN_NONE
            a.info = (f"spec: voice-coil actuator at point {p}: ctrl = force [N] along world +z" if gain == 1.0 else
                      f"spec: voice-coil actuator at point {p}: force = {gain:.7g} x ctrl [N] along world +z "
                      "([hardware] actuator_gain)")
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


def _emit(spec: StructureSpec, plan: Plan, opts: SimOptions, beta: float) -> mujoco.MjSpec:
    """The MjSpec of a plan, without the closures and grounded springs that need the compiled model."""
    ms = _options(spec, plan, opts, beta)
    _bodies(ms, plan, beta)
    _strings_and_equalities(ms, plan, opts.timestep_s)
    _actuators_and_sensors(ms, spec, plan)
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


def _add_linear_closures(ms: mujoco.MjSpec, model: mujoco.MjModel, data: mujoco.MjData, plan: Plan,
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
        For a spec the plant cannot represent (see :func:`vlab.sim.builder.build_plant`).

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
        model = compile_plant(ms, spec)
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


def compile_plant(ms: mujoco.MjSpec, spec: StructureSpec) -> mujoco.MjModel:
    """Compile a plant's MjSpec.

    Parameters
    ----------
    ms : mujoco.MjSpec
        The plant's spec (:func:`build_mjspec`).
    spec : StructureSpec
        The structure it was built from, named in the error.

    Returns
    -------
    mujoco.MjModel

    Raises
    ------
    SimulationError
        MuJoCo's compiler refused it (its message is kept).
    """
    try:
        return ms.compile()
    except Exception as exc:  # mujoco raises ValueError with the compiler message
        raise SimulationError(f"{spec._file()}: MuJoCo could not compile the plant: {exc}") from exc

