"""Hypotheses in the structure that a spec cannot express: damping at a point, friction, gravity pre-stress.

``gravity_prestress`` rescales the geometric stiffness of the FE model (``k = k_0 + (g / g_0)
(k - k_0)``, ``k_0`` built without gravity); ``damping`` at a point and
``friction`` add to the linear model: these cannot be expressed in a spec
and are validated on the linear plant (``spec_level`` false). The effects
that edit the spec are in :mod:`vlab.diagnose.effects.structural`.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ...errors import ModelError
from ...fe import build_fe_model
from ...units import G_SI
from ..model.labmodel import natural_frequencies
from . import specedit
from .hypothesis import Hypothesis, _AtPoint, _log_trials


def critical_dashpot(state, ctx, point: int) -> float:
    """The dashpot to ground at ``point`` [N*s/m] that critically damps the band's mode it damps most:
    ``min_r 2 omega_r / phi_r(p)^2`` over the modes of ``state`` in ``ctx.band_hz`` (mass-normalised shapes).

    A larger dashpot no longer damps that mode: it holds the point still, a support rather than damping. On
    the MuJoCo grid a dashpot of 6.1e11 N s/m at the top beam's point 15, next
    to its bearing (modal mass there about 8 t), and a friction force of 39 N there stood for a spring
    further along the beam and were selected; as damping they can only be validated on the linear plant.
    Infinity when no mode of the band moves the point."""
    f, _, phi = natural_frequencies(state)
    i = state.fe.dofs.index(point, "w")
    lo, hi = ctx.band_hz
    band = (f >= lo) & (f <= hi)
    if not band.any():
        band = f > 0
    ph2 = phi[i, band] ** 2
    moved = ph2 > 0
    if not moved.any():
        return math.inf
    return float(np.min(2 * (2 * math.pi * f[band][moved]) / ph2[moved]))


class PointDamping(_AtPoint):
    """``damping`` at a point: a viscous dashpot to ground on the out-of-plane DOF.

    Parameter: ``c_n_s_per_m`` [N*s/m] (log10), at most :func:`critical_dashpot`.
    Non-proportional; added to the linear model (not expressible in a spec).
    """

    effect = "damping"
    param_names = ("c_n_s_per_m",)
    log_scale = (True,)
    spec_level = False
    order = 6

    def _cref(self, ctx) -> float:
        return ctx.point_damping.get(self.point, 0.02 * 2 * math.pi * ctx.f1_hz * ctx.total_mass_kg)

    def _space(self, state, ctx):
        c = self._cref(ctx)
        hi = min(c * 1e3, critical_dashpot(state, ctx, self.point))  # beyond it: a support, not damping
        trials = _log_trials(c, (0.03, 0.1, 0.3, 1.0, 3.0, 10.0))
        return np.minimum(trials, hi), np.array([min(c * 1e-4, hi * 1e-3)]), np.array([hi])

    def _apply(self, state, x, ctx):
        state.fe.dofs.index(self.point, "w")
        return replace(state, dashpots=state.dashpots + ((self.point, float(x[0])),))

    def _null(self, state, ctx):
        return np.array([0.0])


class Friction(_AtPoint):
    """``friction``: Coulomb friction at a point, as its equivalent viscous damping.

    Parameter: ``friction_force_n`` [N] (log10). Under random excitation the
    statistically linearised friction force is ``c_eq v`` with
    ``c_eq = sqrt(2 / pi) F / sigma_v`` (Caughey, J. Acoust. Soc. Am. 35
    (1963) 1706-1711), ``sigma_v`` the RMS velocity at the point: measured
    where it was recorded, else predicted with the friction in place
    (``c_eq`` and ``sigma_v`` iterated to a fixed point, as statistical
    linearisation does), at most the force whose equivalent dashpot at the
    nominal velocity level is :func:`critical_dashpot`. At one excitation level it fits exactly like
    ``damping`` at the point; a rerun with the friction force itself
    separates them (:func:`vlab.diagnose.fit.selection.tie_break_by_rerun`).
    """

    effect = "friction"
    param_names = ("friction_force_n",)
    log_scale = (True,)
    needs = "signals"
    spec_level = False
    order = 12

    def _sigma(self, state, ctx) -> float:
        s = ctx.predicted_velocity_rms(state, self.point)
        if not s > 0:
            raise ModelError(f"friction at point {self.point}: no velocity level known")
        return s

    def _space(self, state, ctx):
        c = ctx.point_damping.get(self.point, 0.02 * 2 * math.pi * ctx.f1_hz * ctx.total_mass_kg)
        to_force = self._sigma(state, ctx) * math.sqrt(math.pi / 2)
        f = c * to_force
        # at most the force whose equivalent dashpot, at the nominal velocity level, is critical (a support beyond)
        hi = min(f * 1e3, critical_dashpot(state, ctx, self.point) * to_force)
        trials = _log_trials(f, (0.03, 0.1, 0.3, 1.0, 3.0, 10.0))
        return np.minimum(trials, hi), np.array([min(f * 1e-4, hi * 1e-3)]), np.array([hi])

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
