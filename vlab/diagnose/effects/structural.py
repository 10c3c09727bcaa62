"""Hypotheses in the structure: mass, supports, joints, members, damping, friction, gravity pre-stress.

Structural effects build a modified :class:`~vlab.spec.StructureSpec`
(:mod:`vlab.diagnose.effects.specedit`), from which both the FE model and the MuJoCo
plant are built (a spring on a free DOF and a damping ratio also edit the
FE model or keep it, exactly as rebuilding would). ``gravity_prestress``
rescales the geometric stiffness of the FE model (``k = k_0 + (g / g_0)
(k - k_0)``, ``k_0`` built without gravity); ``damping`` at a point and
``friction`` add to the linear model: these cannot be expressed in a spec
and are validated on the linear plant.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ...errors import ModelError, SpecError
from ...fe import build_fe_model
from ...units import G_SI
from ..model.labmodel import natural_frequencies
from . import specedit
from .hypothesis import Hypothesis, _log_trials


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


class JointFlexibility(Hypothesis):
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

    def __init__(self, *, point: int):
        self.point = point

    @property
    def location(self) -> dict:
        return {"point": self.point}

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
        return (np.array([[z0 * f] for f in (0.3, 0.6, 1.6, 3.0)]), np.array([1e-5]), np.array([0.5]))

    def _apply(self, state, x, ctx):
        # the FE matrices do not depend on the damping table: keep them
        return replace(state, spec=specedit.set_modal_damping(state.spec, self.mode, float(x[0])))

    def _null(self, state, ctx):
        return np.array([self._zeta0(state)])


class PointDamping(Hypothesis):
    """``damping`` at a point: a viscous dashpot to ground on the out-of-plane DOF.

    Parameter: ``c_n_s_per_m`` [N*s/m] (log10). Non-proportional; added to the
    linear model (not expressible in a spec).
    """

    effect = "damping"
    param_names = ("c_n_s_per_m",)
    log_scale = (True,)
    spec_level = False
    order = 6

    def __init__(self, *, point: int):
        self.point = point

    @property
    def location(self) -> dict:
        return {"point": self.point}

    def _cref(self, ctx) -> float:
        return ctx.point_damping.get(self.point, 0.02 * 2 * math.pi * ctx.f1_hz * ctx.total_mass_kg)

    def _space(self, state, ctx):
        c = self._cref(ctx)
        return _log_trials(c, (0.03, 0.1, 0.3, 1.0, 3.0, 10.0)), np.array([c * 1e-4]), np.array([c * 1e3])

    def _apply(self, state, x, ctx):
        state.fe.dofs.index(self.point, "w")
        return replace(state, dashpots=state.dashpots + ((self.point, float(x[0])),))

    def _null(self, state, ctx):
        return np.array([0.0])


class Friction(Hypothesis):
    """``friction``: Coulomb friction at a point, as its equivalent viscous damping.

    Parameter: ``friction_force_n`` [N] (log10). Under random excitation the
    statistically linearised friction force is ``c_eq v`` with
    ``c_eq = sqrt(2 / pi) F / sigma_v`` (Caughey, J. Acoust. Soc. Am. 35
    (1963) 1706-1711), ``sigma_v`` the RMS velocity at the point: measured
    where it was recorded, else predicted with the friction in place
    (``c_eq`` and ``sigma_v`` iterated to a fixed point, as statistical
    linearisation does). At one excitation level it fits exactly like
    ``damping`` at the point; a rerun with the friction force itself
    separates them (:func:`vlab.diagnose.fit.selection.tie_break_by_rerun`).
    """

    effect = "friction"
    param_names = ("friction_force_n",)
    log_scale = (True,)
    needs = "signals"
    spec_level = False
    order = 12

    def __init__(self, *, point: int):
        self.point = point

    @property
    def location(self) -> dict:
        return {"point": self.point}

    def _sigma(self, state, ctx) -> float:
        s = ctx.predicted_velocity_rms(state, self.point)
        if not s > 0:
            raise ModelError(f"friction at point {self.point}: no velocity level known")
        return s

    def _space(self, state, ctx):
        c = ctx.point_damping.get(self.point, 0.02 * 2 * math.pi * ctx.f1_hz * ctx.total_mass_kg)
        f = c * self._sigma(state, ctx) * math.sqrt(math.pi / 2)
        return _log_trials(f, (0.03, 0.1, 0.3, 1.0, 3.0, 10.0)), np.array([f * 1e-4]), np.array([f * 1e3])

    def equivalent_damping(self, state, force_n: float, ctx) -> float:
        """``c_eq`` [N*s/m] of friction force ``force_n`` [N] at the point of ``state`` (self-consistent with
        the velocity level it produces; ``ctx`` gives the excitation)."""
        k = math.sqrt(2 / math.pi) * force_n
        c = k / self._sigma(state, ctx)
        if self.point in ctx.velocity_rms:
            return c
        for _ in range(4):
            s = ctx.velocity_rms_of(replace(state, dashpots=state.dashpots + ((self.point, c),)), self.point)
            if not s > 0:
                break
            c = k / s
        return c

    def _apply(self, state, x, ctx):
        state.fe.dofs.index(self.point, "w")
        c = self.equivalent_damping(state, float(x[0]), ctx)
        return replace(state, frictions=state.frictions + ((self.point, float(x[0]), c),))

    def _null(self, state, ctx):
        return np.array([0.0])


class GravityPrestress(Hypothesis):
    """``gravity_prestress``: the geometric stiffness of the gravity pre-stress, as if gravity were ``g``.

    Parameter: ``g_m_per_s2`` [m/s^2]; ``k(g) = k_0 + (g / 9.81) (k - k_0)``
    with ``k_0`` the FE stiffness built without gravity (strings keep their
    given tensions; reaction tensions vanish with gravity). The MuJoCo plant
    takes its pre-stress from its own gravity: validated on the linear plant.
    """

    effect = "gravity_prestress"
    moves_modes = True
    param_names = ("g_m_per_s2",)
    log_scale = (False,)
    spec_level = False
    order = 11
    stage = 1

    def _space(self, state, ctx):
        return (np.array([[G_SI * f] for f in (0.0, 0.5, 1.5, 2.0)]), np.array([0.0]), np.array([4.0 * G_SI]))

    def _k0(self, state, ctx) -> np.ndarray:
        key = id(state.spec)
        hit = ctx._k_no_gravity.get(key)
        if hit is None or hit[0] is not state.spec:
            fe0 = build_fe_model(specedit.without_gravity(state.spec))
            if fe0.dofs.labels != state.fe.dofs.labels:
                raise ModelError("gravity_prestress: the model without gravity has other DOFs")
            hit = (state.spec, fe0.k)
            ctx._k_no_gravity[key] = hit
        return hit[1]

    def _apply(self, state, x, ctx):
        k0 = self._k0(state, ctx)
        k = k0 + (float(x[0]) / G_SI) * (state.fe.k - k0)
        return replace(state, fe=replace(state.fe, k=k), point_modes=None)

    def _null(self, state, ctx):
        return np.array([G_SI])
