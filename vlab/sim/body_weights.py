"""Masses added to an exported plant carry their weight into its in-plane statics.

vlab's MuJoCo plant moves out of its plane only. The structure's in-plane statics under gravity -- the
tensions of its cables and strings, the axial forces of its members -- are solved when the plant is built
(:mod:`vlab.sim.planner`, from the FE statics) and written into the model as numbers: a string's tendon
stiffness (its tension over its length), the constant forces of the ``prestress`` actuators, the hinges'
stiffness. A body added to an exported file (a mass welded at a point's site, ``docs/mjcf.md``) has
inertia, but its weight reaches none of those numbers: MuJoCo has no in-plane degree of freedom to carry
it. On a real structure a mass weighs: on the BCC, which hangs on its cross-cable, 0.05 kg at point 5 adds
its 0.49 N to the upper cable (+0.14 % of its tension, modes 1 and 2 +2e-4 in frequency), and a plant
without it differs from the structure with the mass by as much as a 4 % softer beam segment would.

So a loaded MJCF's added masses are found (:func:`added_masses`: bodies without joints that vlab does not
build, each at the site of a structure point) and the statics are redone with them
(:func:`carry_weights`): the plant is built from the spec with and without those masses as lumped masses
of their points, and the difference of every statics number, matched by element name, is added to the
loaded model. What the file itself changed (its masses, springs, gains) stays as it is.

Source: the statics as in :mod:`vlab.fe.statics`; MuJoCo's model fields ``tendon_stiffness``,
``jnt_stiffness``, ``actuator_gainprm``/``actuator_biasprm`` (``doc/APIreference``).
"""

from __future__ import annotations

import mujoco
import numpy as np

from ..errors import ModelError
from ..spec import LumpedMass, Quantity, StructureSpec
from ..spec.changes import damping_of
from .contract import numbered
from .options import SimOptions

#: Largest distance [m] between an added body and the site of the point it is attached to.
AT_SITE_M = 1e-6

#: Model fields that carry the in-plane statics, with the MuJoCo object type that names their rows.
STATICS_FIELDS = (("tendon_stiffness", mujoco.mjtObj.mjOBJ_TENDON), ("tendon_lengthspring", mujoco.mjtObj.mjOBJ_TENDON),
                  ("jnt_stiffness", mujoco.mjtObj.mjOBJ_JOINT), ("actuator_gainprm", mujoco.mjtObj.mjOBJ_ACTUATOR),
                  ("actuator_biasprm", mujoco.mjtObj.mjOBJ_ACTUATOR))


def added_masses(model: mujoco.MjModel, spec: StructureSpec) -> list[tuple[str, int, float]]:
    """The bodies of ``model`` that vlab did not build: ``(body name, point, mass [kg])`` each.

    A body without a joint is welded to its parent. One with mass that vlab's builder does not plan for
    ``spec`` (:func:`vlab.sim.planner.plan_structure`; its jointless bodies are those of clamped points, and
    they are named by point whatever the plant's resolution) is an added mass, at the structure point whose
    site ``p<ID>`` it sits on (at the model's reference configuration, ``qpos0``).

    Raises
    ------
    ModelError
        An added body that sits on no point's site (within :data:`AT_SITE_M`): where its weight goes is not
        known.
    """
    from .planner import plan_structure

    plan, _ = plan_structure(spec, SimOptions().resolved(spec))
    d = mujoco.MjData(model)
    mujoco.mj_kinematics(model, d)
    sites = numbered(model, mujoco.mjtObj.mjOBJ_SITE, model.nsite, "p")
    out = []
    for b in range(1, model.nbody):
        if model.body_jntnum[b] != 0 or model.body_mass[b] <= 0.0:
            continue
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) or f"body {b}"
        if name in plan.bodies:
            continue
        pos = d.xipos[b]
        near = [(float(np.linalg.norm(d.site_xpos[s] - pos)), p) for p, s in sites.items()]
        dist, point = min(near) if near else (np.inf, None)
        if dist > AT_SITE_M:
            raise ModelError(f"body {name!r} ({model.body_mass[b]:g} kg, no joint) is at no structure point's site "
                             f"(the nearest, p{point}, is {dist:.3g} m away): an added mass must sit on a site "
                             "p<ID> for its weight to be carried into the statics")
        out.append((name, int(point), float(model.body_mass[b])))
    return out


def carry_weights(model: mujoco.MjModel, spec: StructureSpec, options: SimOptions | None = None) -> list[str]:
    """Add the weight of ``model``'s added masses to its in-plane statics, in place.

    Parameters
    ----------
    model : mujoco.MjModel
        A loaded plant (an exported MJCF, edited).
    spec : StructureSpec
        The structure it was exported from (without the added masses).
    options : SimOptions, optional
        Build options of the plants compared (default: vlab's defaults, those of ``vlab export-mjcf``).

    Returns
    -------
    list of str
        One note naming the added masses and the fields changed (empty: no added mass, or no in-plane
        gravity).

    Notes
    -----
    Costs two builds of the plant from the spec (BCC about 1 s each, grid a few seconds) per load of a file
    with added masses; a file without them costs only the search for them.

    Raises
    ------
    ModelError
        As :func:`added_masses`.
    """
    from .builder import build_plant

    if not any(spec.gravity_direction):
        return []
    added = added_masses(model, spec)
    if not added:
        return []
    masses = tuple(LumpedMass(f"mjcf_{name}", point, Quantity(m, f"MJCF body {name}")) for name, point, m in added)
    loaded = damping_of(spec.replace(masses=spec.masses + masses), spec)
    before, after = build_plant(spec, options).model, build_plant(loaded, options).model
    changed, unmatched = [], 0
    for field, obj in STATICS_FIELDS:
        target, a, b = getattr(model, field), getattr(before, field), getattr(after, field)
        for i in range(a.shape[0]):
            delta = b[i] - a[i]
            if not np.any(delta != 0.0):
                continue
            name = mujoco.mj_id2name(before, obj, i)
            j = mujoco.mj_name2id(model, obj, name) if name else -1
            if j < 0:  # a file exported at another resolution names its hinges otherwise
                unmatched += 1
                continue
            target[j] += delta
            changed.append(field)
    what = ", ".join(sorted(set(changed))) or "nothing"
    if unmatched:
        what += f"; {unmatched} changed values had no element of that name in the file, left as they were"
    many = len(added) > 1
    return [f"the MJCF's added mass{'es' if many else ''} "
            + ", ".join(f"{name} ({m:g} kg at point {p})" for name, p, m in added)
            + f" carried into the in-plane statics ({'their' if many else 'its'} weight; changed: {what})"]
