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
and has the compliance share ``c_k`` (:func:`vlab.sim.hinges.hinge_layout`):

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
  gives ``W Y``, Sec. 2.2.1; see :meth:`vlab.sim.attachments.AttachmentPlanner._plates` for how plates are
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

Sources: Sec. 2.1, 2.1.1, 2.2, 2.2.1 of the dissertation; docs/plants.md; MuJoCo
documentation (``doc/XMLreference.rst``: tendon, equality, actuator/general refsite;
``doc/computation/index.rst``: integrators).
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np

from ..spec import StructureSpec
from .damping import add_modal_tendons, modal_damping_plan, projected_modes
from .damping_matrix import ModalDamping, store_modal_damping
from .dofmap import dof_permutation
from .emit import build_mjspec, compile_plant
from .options import SimOptions
from .plant import BuildInfo, Plant
from .timestep import (AUTO_LIMIT, LAB_PERIOD_S, MASS_SCALING_TOL, armature_effect, auto_timestep, check_timestep,
                       hinge_omega_max, mass_scaling_armature)


def _sensor_rows(model: mujoco.MjModel, points: tuple[int, ...], actuators: tuple[int, ...]) -> dict[int, int]:
    rows = {}
    for p in points:
        s = model.sensor(f"vel{p}")
        adr = int(s.adr[0])
        rows[p] = adr if p in actuators else adr + 2  # framelinvel: z component
    return rows


#: Plants of unchanged structures (damping bases), by the identity of the spec and its ratios.
_BASIS_PLANTS: dict = {}


def _basis_damping(spec: StructureSpec, options: SimOptions | None, model0: mujoco.MjModel):
    """The damping of the unchanged structure that ``spec`` names as its basis (:attr:`vlab.spec.Damping.basis`):
    ``(beta, ModalDamping, DampingReport, dof_damping)`` in ``model0``'s DOF order, or None when there is
    none or its plant's DOFs are not ``model0``'s under other names (:func:`vlab.sim.dofmap.dof_permutation`:
    then the changed plant's damping is designed on its own modes)."""
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
    md = base.modal_damping
    perm = dof_permutation(base.model, model0)
    if md is None or perm is None:
        return None
    md = ModalDamping(np.ascontiguousarray(md.A[perm]), md.c)
    return base.options.stiffness_damping_s or 0.0, md, base.damping, np.array(base.model.dof_damping)[perm]


def _set_joint_damping(ms: mujoco.MjSpec, model0: mujoco.MjModel, dof_damping: np.ndarray) -> None:
    """Give every joint of ``ms`` the damping of its DOF in ``dof_damping`` (joints matched by name with
    ``model0``, whose DOF layout ``dof_damping`` follows)."""
    for j in ms.joints:
        jid = model0.joint(j.name).id
        adr = int(model0.jnt_dofadr[jid])
        v = np.array(j.damping, dtype=float)
        v[0] = dof_damping[adr]
        j.damping = v


def _timestep_and_armature(spec: StructureSpec, opts: SimOptions) -> tuple[SimOptions, dict[str, float]]:
    """The resolved options with the physics step chosen, and the armature of selective mass scaling.

    An undamped probe plant gives the hinge chain's highest frequency
    (:func:`hinge_omega_max`); the step is the given one or the automatic one
    (:func:`auto_timestep`, at least ``LAB_PERIOD_S / max_substeps`` with mass
    scaling). Where the stiffest hinges need a smaller step, they get an
    armature (:func:`mass_scaling_armature`) if it moves the low modes by at
    most ``MASS_SCALING_TOL``; else the automatic step is made small enough.
    """
    armature: dict[str, float] = {}
    probe, _ = build_mjspec(spec, dataclasses.replace(opts, timestep_s=opts.timestep_s or LAB_PERIOD_S), beta=0.0)
    probe_model = compile_plant(probe, spec)
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
    return dataclasses.replace(opts, timestep_s=dt), armature


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
    opts, armature = _timestep_and_armature(spec, (options or SimOptions()).resolved(spec))
    ms0, extra = build_mjspec(spec, opts, beta=0.0, armature=armature)
    opts = dataclasses.replace(opts, topology=extra["options"].topology, integrator=extra["options"].integrator)
    model0 = compile_plant(ms0, spec)
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
    model = compile_plant(ms, spec)
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
