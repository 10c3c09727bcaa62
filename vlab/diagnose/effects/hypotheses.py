"""The library of physics hypotheses: named, parametrised modifications of the laboratory.

Each hypothesis is one small class with the habits of a scikit-learn
estimator (scikit-learn's "Developing estimators"): a keyword-only constructor that fixes *where* the
effect is (point, DOF, member, mode, channel), :meth:`Hypothesis.fit` that
estimates *how large* it is and returns ``self``, fitted values ending in
``_`` (``params_``, ``ci95_``, ``bic_``, ...) and :meth:`Hypothesis.score`
returning one comparable number (the BIC, lower is better).

A hypothesis changes the laboratory only through public functions:

- structural effects build a modified :class:`~vlab.spec.StructureSpec`
  (:mod:`vlab.diagnose.effects.specedit`), from which both the FE model and the
  MuJoCo plant are built;
- chain effects build a modified :class:`~vlab.lab.loop.HardwareChain`;
- ``gravity_prestress`` rescales the geometric stiffness of the FE model
  (``k = k_0 + (g / g_0) (k - k_0)`` with ``k_0`` the model built without
  gravity), and ``damping`` at a point and ``friction`` add a dashpot to
  the linear model: these two cannot be expressed in a spec and are
  validated on the linear plant.

Names (used as-is in the output): ``added_mass``, ``support_stiffness``,
``joint_flexibility``, ``member_stiffness``, ``damping``, ``loop_delay``,
``actuator_lag``, ``sensor_lag``, ``actuator_gain``, ``sensor_gain``,
``gravity_prestress``, ``friction``, ``saturation``.

Parameters are in SI (see each class); those spanning decades (stiffness,
damping coefficient, corner frequency, gain, force) are fitted as
``log10`` of the value.
"""

from __future__ import annotations

from ...errors import ModelError
from ...units import G_SI
from ..model.labmodel import LabState, natural_frequencies
from ..problem.context import Context
from . import specedit
from .beyond_spec import Friction, GravityPrestress, PointDamping
from .chain import ActuatorGain, ActuatorLag, LoopDelay, Saturation, SensorGain, SensorLag
from .hypothesis import Combination, Hypothesis
from .structural import AddedMass, JointFlexibility, MemberStiffness, ModalDamping, SupportStiffness

__all__ = ["EFFECTS", "Context", "Hypothesis", "Combination", "library", "AddedMass", "SupportStiffness",
           "JointFlexibility", "MemberStiffness", "ModalDamping", "PointDamping", "Friction", "GravityPrestress",
           "LoopDelay", "ActuatorLag", "SensorLag", "ActuatorGain", "SensorGain", "Saturation", "G_SI"]


#: The effect names, in the issue's order.
EFFECTS = ("added_mass", "support_stiffness", "joint_flexibility", "member_stiffness", "damping", "loop_delay",
           "actuator_lag", "sensor_lag", "actuator_gain", "sensor_gain", "gravity_prestress", "friction",
           "saturation")


def library(state: LabState, ctx: Context, *, effects: tuple[str, ...] | None = None) -> list[Hypothesis]:
    """Every hypothesis of the library that can show in the data, at every location of the structure.

    Locations: points with a free out-of-plane DOF (added mass, point damping,
    friction, grounded spring), all actuator points together (the same mass
    or spring at each: attachments every coil has, such as its wires), every
    DOF fixed by a support (released to a spring), points where two or more member segments meet (joint
    flexibility), every member and every segment of a multi-segment member
    (stiffness), every mode in the band (modal damping), the controller
    path on every actuator/sensor channel and on all channels together
    (delay, actuator and sensor lags, gains, saturation; the per-channel
    ones on closed-loop data only, since open loop only the excited coil
    carries force), and gravity pre-stress.

    Parameters
    ----------
    state : LabState
        The nominal lab.
    ctx : Context
    effects : tuple of str, optional
        Restrict to these effect names.

    Returns
    -------
    list of Hypothesis
        Unfitted, in library order.
    """
    spec = state.spec
    free = [p for p in sorted(spec.points) if (p, "w") in state.fe.dofs]
    out: list[Hypothesis] = []
    out += [AddedMass(point=p) for p in free]
    acts = tuple(p for p in state.actuators if p in free)
    if len(acts) > 1:
        out.append(AddedMass(points=acts))
    out += [SupportStiffness(point=p, dof="w") for p in free]
    if len(acts) > 1:
        out.append(SupportStiffness(points=acts, dof="w"))
    out += [SupportStiffness(point=s.point, dof=d) for s in spec.supports for d in s.fixed if d in spec.active_dofs]
    out += [JointFlexibility(point=p) for p in sorted(spec.points) if len(specedit.joint_segments(spec, p)) >= 2]
    for m in spec.members:
        out.append(MemberStiffness(member=m.id))
        if len(m.points) > 2:
            out += [MemberStiffness(member=m.id, segment=(a, b)) for a, b in zip(m.points[:-1], m.points[1:])]
    f, _, _ = natural_frequencies(state)
    lo, hi = ctx.band_hz
    out += [ModalDamping(mode=i + 1) for i in range(len(f)) if lo <= f[i] <= hi]
    out += [PointDamping(point=p) for p in free]
    chans = ("all",) + tuple(state.actuators)
    out += [cls(channel=c) for cls in (LoopDelay, ActuatorLag, SensorLag) for c in chans]
    out += [ActuatorGain(channel=c) for c in chans]
    out += [SensorGain(channel=c) for c in chans]
    out += [GravityPrestress()]
    out += [Friction(point=p) for p in free]
    out += [Saturation(channel=c) for c in chans]
    out = [h for h in out if h.applies_to(ctx)]
    if effects is not None:
        unknown = set(effects) - set(EFFECTS)
        if unknown:
            raise ModelError(f"unknown effect(s) {sorted(unknown)}; the library has {EFFECTS}")
        out = [h for h in out if h.effect in effects]
    return out
