"""Hypotheses in the structure's spec: mass, supports, joints, members, modal damping.

Structural effects build a modified :class:`~vlab.spec.StructureSpec`
(:mod:`vlab.diagnose.effects.specedit`), from which both the FE model and the MuJoCo
plant are built (a spring on a free DOF and a damping ratio also edit the
FE model or keep it, exactly as rebuilding would). The structural effects a
spec cannot express (damping at a point, friction, gravity pre-stress) are in
:mod:`vlab.diagnose.effects.beyond_spec`.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ...errors import ModelError, SpecError
from ..model.labmodel import natural_frequencies
from . import specedit
from .hypothesis import Hypothesis, _AtPoint, _log_trials


class _PointSet(Hypothesis):
    """A hypothesis at one point (``point=``) or the same at several points (``points=``, e.g. every actuator)."""

    def __init__(self, *, point: int | None = None, points: tuple[int, ...] | None = None):
        if (point is None) == (points is None):
            raise ModelError(f"{self.effect}: give either point or points")
        self.point = point
        self.points = tuple(points) if points is not None else (point,)

    @property
    def location(self) -> dict:
        return {"point": self.point} if self.point is not None else {"points": list(self.points)}


class AddedMass(_PointSet):
    """``added_mass``: a lumped mass at a point, or the same mass at each of several points
    (e.g. something attached to every actuator).

    Parameters: ``mass_kg`` [kg] >= 0 (per point). Applied with :func:`specedit.add_mass`.
    Trials: 0.5-60 % of the smallest modal mass seen at the point in the band
    (:class:`Context`), capped at the structure's mass; a trial the structure
    cannot carry (buckling) scores infinity (:func:`vlab.diagnose.fit.estimate.screen`).
    """

    effect = "added_mass"
    moves_modes = True
    param_names = ("mass_kg",)
    log_scale = (False,)
    order = 1
    stage = 0

    def _space(self, state, ctx):
        # the modal mass seen at a point next to a support is huge (8 t at the grid's top-beam ends): the
        # trial scale is capped at the structure's own mass, so the trials stay masses one would attach
        m = min(min(ctx.point_mass.get(p, ctx.total_mass_kg), ctx.total_mass_kg) for p in self.points)
        return (np.array([[m * f] for f in (0.005, 0.015, 0.04, 0.1, 0.25, 0.6)]),
                np.array([0.0]), np.array([max(5.0 * m, 0.5 * ctx.total_mass_kg)]))

    def _apply(self, state, x, ctx):
        spec = state.spec
        for p in self.points:
            spec = specedit.add_mass(spec, p, float(x[0]))
        return state.with_spec(spec)

    def _null(self, state, ctx):
        return np.array([0.0])


class SupportStiffness(_PointSet):
    """``support_stiffness``: a grounded spring on one DOF ``dof`` of a point (or the same spring at several points).

    On a DOF fixed by a support the support is released and the spring
    replaces it (a support of finite stiffness); on a free DOF the spring is
    added (an attachment to ground such as a cable or wire). Parameter:
    ``stiffness`` [N/m for w, N*m/rad for rotations] per point, fitted in
    log10. Applied with :func:`specedit.add_spring`.
    """

    effect = "support_stiffness"
    moves_modes = True
    log_scale = (True,)
    order = 2
    stage = 0

    def __init__(self, *, point: int | None = None, points: tuple[int, ...] | None = None, dof: str = "w"):
        """Spring at ``point`` (or the same spring at each of ``points``) on ``dof`` ("w", "rx", "ry").

        Parameters
        ----------
        point : int, optional
        points : tuple of int, optional
        dof : {"w", "rx", "ry"}
        """
        super().__init__(point=point, points=points)
        self.dof = dof

    @property
    def param_names(self):  # type: ignore[override]
        return ("stiffness_n_per_m",) if self.dof == "w" else ("stiffness_n_m_per_rad",)

    @property
    def location(self) -> dict:
        return {**super().location, "dof": self.dof}

    def _released(self, state) -> bool:
        return any(specedit.is_fixed(state.spec, p, self.dof) for p in self.points)

    def _space(self, state, ctx):
        kscale = ctx.total_mass_kg * (2 * math.pi * ctx.f1_hz) ** 2
        if self.dof != "w":
            xy = np.array(list(state.spec.points.values()))
            size = float(np.max(np.ptp(xy, axis=0))) or 1.0
            kscale = kscale * size**2
        if self._released(state):
            return (_log_trials(kscale, (1.0, 10.0, 100.0, 1e3, 1e4)), np.array([kscale * 1e-3]),
                    np.array([kscale * 1e7]))
        kp = min(ctx.point_stiffness.get(p, kscale) for p in self.points) if self.dof == "w" else kscale
        return (_log_trials(kp, (0.003, 0.01, 0.03, 0.1, 0.3, 1.0, 3.0)), np.array([kp * 1e-5]),
                np.array([kp * 1e4]))

    def _apply(self, state, x, ctx):
        spec = state.spec
        for p in self.points:
            spec = specedit.add_spring(spec, p, self.dof, float(x[0]))
        if self._released(state):
            return state.with_spec(spec)
        # a grounded spring on a free DOF adds k to one diagonal term of the FE stiffness (as
        # vlab.fe.build_fe_model assembles it; the in-plane statics do not see it): edit the model
        k = state.fe.k.copy()
        for p in self.points:
            i = state.fe.dofs.index(p, self.dof)
            k[i, i] += float(x[0])
        return replace(state, spec=spec, fe=replace(state.fe, spec=spec, k=k), point_modes=None)

    def _null(self, state, ctx):
        return None if self._released(state) else np.array([0.0])


class JointFlexibility(_AtPoint):
    """``joint_flexibility``: a semi-rigid connection at a point where members meet.

    Parameter: ``rotational_stiffness_n_m_per_rad`` [N*m/rad] (log10); each
    segment at the joint gets ``EI' = EI / (1 + EI / (k_j L))``
    (:func:`specedit.soften_joint`).
    """

    effect = "joint_flexibility"
    moves_modes = True
    param_names = ("rotational_stiffness_n_m_per_rad",)
    log_scale = (True,)
    order = 3
    stage = 0

    def _kref(self, state) -> float:
        segs = specedit.joint_segments(state.spec, self.point)
        return float(np.mean([ei / length for _a, _b, length, ei in segs]))

    def _space(self, state, ctx):
        k = self._kref(state)
        return _log_trials(k, (0.3, 1.0, 3.0, 10.0, 30.0)), np.array([k * 1e-3]), np.array([k * 1e5])

    def _apply(self, state, x, ctx):
        return state.with_spec(specedit.soften_joint(state.spec, self.point, float(x[0])))


class MemberStiffness(Hypothesis):
    """``member_stiffness``: the bending (and torsional) rigidity of a member or of one member segment.

    Parameter: ``ei_n_m2`` [N*m^2] (log10), the new out-of-plane rigidity; GJ
    scales with it (:func:`specedit.scale_segments`).
    """

    effect = "member_stiffness"
    moves_modes = True
    param_names = ("ei_n_m2",)
    log_scale = (True,)
    order = 4
    stage = 0

    def __init__(self, *, member: str, segment: tuple[int, int] | None = None):
        self.member = member
        self.segment = None if segment is None else tuple(segment)

    @property
    def location(self) -> dict:
        loc = {"member": self.member}
        if self.segment is not None:
            loc["segment"] = list(self.segment)
        return loc

    def _nominal(self, state) -> tuple[list[tuple[int, int]], float]:
        """Segments (point pairs, stable under splitting) and nominal EI, fixed at first use."""
        if not hasattr(self, "_segs"):
            m = next((mm for mm in state.spec.members if mm.id == self.member), None)
            if m is None:
                raise SpecError(f"member_stiffness: unknown member {self.member!r}")
            segs = list(zip(m.points[:-1], m.points[1:]))
            if self.segment is not None:
                if frozenset(self.segment) not in {frozenset(s) for s in segs}:
                    raise SpecError(f"member_stiffness: {self.segment} is not a segment of {self.member!r}")
                segs = [self.segment]
            self._segs, self._ei = segs, state.spec.sections[m.section].ei.si
        return self._segs, self._ei

    def _ei0(self, state) -> float:
        return self._nominal(state)[1]

    def _space(self, state, ctx):
        ei = self._ei0(state)
        return _log_trials(ei, (0.5, 0.7, 0.85, 0.95, 1.05, 1.2, 1.6)), np.array([ei * 0.02]), np.array([ei * 50.0])

    def _apply(self, state, x, ctx):
        segs, ei = self._nominal(state)
        factor = float(x[0]) / ei
        return state.with_spec(specedit.scale_segments(state.spec, {s: factor for s in segs}))

    def _null(self, state, ctx):
        return np.array([self._ei0(state)])


#: Trial multiples of a mode's nominal damping ratio in the screening (:class:`ModalDamping`).
TRIAL_FACTORS_MODAL_DAMPING = (0.3, 0.6, 0.85, 0.93, 1.07, 1.18, 1.6, 3.0)


class ModalDamping(Hypothesis):
    """``damping`` of one mode: its open-loop damping ratio.

    Parameter: ``damping_ratio`` [1]. Applied with :func:`specedit.set_modal_damping`.
    """

    effect = "damping"
    param_names = ("damping_ratio",)
    log_scale = (False,)
    order = 5
    stage = 0

    def __init__(self, *, mode: int):
        self.mode = mode

    @property
    def location(self) -> dict:
        return {"mode": self.mode}

    def _zeta0(self, state) -> float:
        _, z, _ = natural_frequencies(state, self.mode)
        return float(z[self.mode - 1])

    def _space(self, state, ctx):
        z0 = max(self._zeta0(state), 1e-4)
        # a lightly damped peak resolves a few per cent of its damping (vlab detectability: BCC mode 3, -2.9 %
        # and +3 %): trials near the nominal value too, or the screening's chi-square well is missed
        return (np.array([[z0 * f] for f in TRIAL_FACTORS_MODAL_DAMPING]), np.array([1e-5]), np.array([0.5]))

    def _apply(self, state, x, ctx):
        # the FE matrices do not depend on the damping table: keep them
        return replace(state, spec=specedit.set_modal_damping(state.spec, self.mode, float(x[0])))

    def _null(self, state, ctx):
        return np.array([self._zeta0(state)])
