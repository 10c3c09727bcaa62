"""The library of physics hypotheses: named, parametrised modifications of the laboratory.

Each hypothesis is one small class with the habits of a scikit-learn
estimator (DESIGN.md): a keyword-only constructor that fixes *where* the
effect is (point, DOF, member, mode, channel), :meth:`Hypothesis.fit` that
estimates *how large* it is and returns ``self``, fitted values ending in
``_`` (``params_``, ``ci95_``, ``bic_``, ...) and :meth:`Hypothesis.score`
returning one comparable number (the BIC, lower is better).

A hypothesis changes the laboratory only through public functions:

- structural effects build a modified :class:`~vlab.spec.StructureSpec`
  (:mod:`vlab.diagnose.specedit`), from which both the FE model and the
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

import math
from dataclasses import dataclass, field, replace
from typing import ClassVar

import numpy as np

from ..errors import ModelError, SpecError
from ..fe import build_fe_model
from ..units import G_SI
from . import specedit
from .labmodel import LabState, natural_frequencies, predict_frf


@dataclass
class Context:
    """Scales and signals a hypothesis needs besides the lab state (filled in by the problem).

    Attributes
    ----------
    band_hz : (float, float)
        Analysed band [Hz].
    closed_loop : bool
        A controller was running.
    total_mass_kg : float
        Translational mass of the structure [kg].
    f1_hz : float
        First natural frequency of the nominal model [Hz].
    point_stiffness : dict
        Point -> static driving-point stiffness of the nominal model from its modes [N/m].
    point_mass : dict
        Point -> smallest modal mass seen at the point over the modes in the band,
        ``1 / max_r phi_r(p)^2`` (mass-normalised shapes) [kg]: the added mass that
        would shift the most affected mode by about 30 %.
    point_damping : dict
        Point -> dashpot ``min_r 2 zeta_r omega_r / phi_r(p)^2`` [N*s/m] that would
        double the damping of the most affected mode in the band.
    freq_hz : ndarray or None
        Excited lines [Hz] (recordings).
    force_amplitude : ndarray or None
        Excitation amplitude per line [N] (recordings).
    velocity_rms : dict
        Point -> measured RMS velocity [m/s] (recordings).
    excitation_point : int or None
    """

    band_hz: tuple[float, float]
    closed_loop: bool
    total_mass_kg: float
    f1_hz: float
    point_stiffness: dict
    point_mass: dict = field(default_factory=dict)
    point_damping: dict = field(default_factory=dict)
    freq_hz: np.ndarray | None = None
    force_amplitude: np.ndarray | None = None
    velocity_rms: dict = field(default_factory=dict)
    excitation_point: int | None = None
    command_rms: dict = field(default_factory=dict)
    _k_no_gravity: dict = field(default_factory=dict, repr=False)

    @property
    def has_signals(self) -> bool:
        """True when excitation amplitudes are known (time-history input)."""
        return self.force_amplitude is not None

    def predicted_velocity_rms(self, state: LabState, point: int) -> float:
        """RMS velocity [m/s] at ``point`` predicted for the recorded excitation (measured value if recorded)."""
        if point in self.velocity_rms:
            return self.velocity_rms[point]
        if not self.has_signals:
            return float("nan")
        h = predict_frf(state, self.freq_hz, excitation_point=self.excitation_point, output_points=(point,))
        v = float(np.sqrt(0.5 * np.sum(np.abs(h[:, 0] * self.force_amplitude) ** 2)))
        self.velocity_rms[point] = v
        return v


class Hypothesis:
    """Base class: one physics effect at one location.

    Subclasses set the class attributes and implement :meth:`space` and
    :meth:`apply`.

    Class attributes
    ----------------
    effect : str
        Name in the output.
    param_names : tuple of str
        SI parameter names (with the unit in the name).
    log_scale : tuple of bool
        Fit ``log10`` of the parameter.
    needs : str
        ``"any"``, ``"closed"`` (only visible with a controller running) or
        ``"signals"`` (needs the excitation amplitude: time histories).
    spec_level : bool
        True when the effect is a spec/chain change a MuJoCo plant can carry.

    Fitted attributes (after :meth:`fit`)
    --------------------------------------
    params_ : ndarray, shape (k,)
        Parameter values [SI].
    ci95_ : ndarray, shape (k, 2)
        95 % confidence intervals [SI] (from the Jacobian at the optimum).
    chi2_ : float
        Weighted sum of squared residuals at the optimum.
    aic_, bic_ : float
        Akaike and Schwarz criteria ``chi2 + 2k``, ``chi2 + k ln N``.
    misfit_ : float
        Misfit of the problem (FRF: weighted RMS log10 magnitude error [decades];
        modal: RMS relative frequency error) at the optimum.
    n_evaluations_ : int
    success_ : bool
    """

    effect: ClassVar[str] = ""
    param_names: ClassVar[tuple[str, ...]] = ()
    log_scale: ClassVar[tuple[bool, ...]] = ()
    needs: ClassVar[str] = "any"
    spec_level: ClassVar[bool] = True
    order: ClassVar[int] = 0
    #: Application stage: 0 rebuilds the FE model from a spec, 1 edits the FE model, 2 adds to it.
    stage: ClassVar[int] = 2

    # -- description
    @property
    def location(self) -> dict:
        """Where the effect is (JSON-ready)."""
        return {}

    @property
    def label(self) -> str:
        """``effect(location)`` for reports."""
        loc = ", ".join(f"{k}={v}" for k, v in self.location.items())
        return f"{self.effect}({loc})" if loc else self.effect

    @property
    def n_params(self) -> int:
        """Number of fitted parameters."""
        return len(self.param_names)

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.label}>"

    # -- to implement
    def space(self, state: LabState, ctx: Context) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Trial values and bounds [SI].

        Returns
        -------
        trials : ndarray, shape (n_trials, k)
        lower, upper : ndarray, shape (k,)
        """
        raise NotImplementedError

    def apply(self, state: LabState, x: np.ndarray, ctx: Context) -> LabState:
        """The lab with the effect of size ``x`` [SI, shape (k,)]. Raises ModelError/SpecError if impossible."""
        raise NotImplementedError

    def null(self, state: LabState, ctx: Context) -> np.ndarray | None:
        """Parameter values [SI] at which the effect vanishes (None if only as a limit)."""
        return None

    def applies_to(self, ctx: Context) -> bool:
        """Whether the effect can show in data of this kind (open/closed loop, signals)."""
        if self.needs == "closed":
            return ctx.closed_loop
        if self.needs == "signals":
            return ctx.has_signals
        return True

    # -- estimator interface
    def fit(self, problem, *, starts: np.ndarray | None = None) -> "Hypothesis":
        """Fit the parameters to ``problem`` (:class:`vlab.diagnose.problem.Problem`); returns self.

        Bounded nonlinear least squares on the weighted residuals, started
        from the best trial value (:func:`vlab.diagnose.fit.fit_hypothesis`).
        """
        from .fit import fit_hypothesis

        fit_hypothesis(self, problem, starts=starts)
        return self

    def score(self, problem=None) -> float:
        """The Bayesian information criterion of the fit (lower is better).

        Raises
        ------
        ModelError
            If the hypothesis has not been fitted.
        """
        if not hasattr(self, "bic_"):
            raise ModelError(f"{self.label}: call fit() before score()")
        if problem is None:
            return float(self.bic_)
        chi2 = problem.chi2(problem.state_for(self, self.params_))
        return float(chi2 + self.n_params * math.log(problem.n_obs))

    def parameters_dict(self) -> dict:
        """Fitted parameters ``{name: value}`` [SI]."""
        return {n: float(v) for n, v in zip(self.param_names, self.params_)}

    def ci95_dict(self) -> dict:
        """Confidence intervals ``{name: [low, high]}`` [SI]."""
        return {n: [float(a), float(b)] for n, (a, b) in zip(self.param_names, self.ci95_)}


def _log_trials(ref: float, factors) -> np.ndarray:
    return np.array([[ref * f] for f in factors])


# ----------------------------------------------------------------------------- structure
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
    """

    effect = "added_mass"
    param_names = ("mass_kg",)
    log_scale = (False,)
    order = 1
    stage = 0

    def space(self, state, ctx):
        m = min(ctx.point_mass.get(p, ctx.total_mass_kg) for p in self.points)
        return (np.array([[m * f] for f in (0.005, 0.015, 0.04, 0.1, 0.25, 0.6)]),
                np.array([0.0]), np.array([max(5.0 * m, 0.5 * ctx.total_mass_kg)]))

    def apply(self, state, x, ctx):
        spec = state.spec
        for p in self.points:
            spec = specedit.add_mass(spec, p, float(x[0]))
        return state.with_spec(spec)

    def null(self, state, ctx):
        return np.array([0.0])


class SupportStiffness(_PointSet):
    """``support_stiffness``: a grounded spring on one DOF of a point (or the same spring at several points).

    On a DOF fixed by a support the support is released and the spring
    replaces it (a support of finite stiffness); on a free DOF the spring is
    added (an attachment to ground such as a cable or wire). Parameter:
    ``stiffness`` [N/m for w, N*m/rad for rotations] per point, fitted in
    log10. Applied with :func:`specedit.add_spring`.
    """

    effect = "support_stiffness"
    log_scale = (True,)
    order = 2
    stage = 0

    def __init__(self, *, point: int | None = None, points: tuple[int, ...] | None = None, dof: str = "w"):
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

    def space(self, state, ctx):
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

    def apply(self, state, x, ctx):
        spec = state.spec
        for p in self.points:
            spec = specedit.add_spring(spec, p, self.dof, float(x[0]))
        return state.with_spec(spec)

    def null(self, state, ctx):
        return None if self._released(state) else np.array([0.0])


class JointFlexibility(Hypothesis):
    """``joint_flexibility``: a semi-rigid connection at a point where members meet.

    Parameter: ``rotational_stiffness_n_m_per_rad`` [N*m/rad] (log10); each
    segment at the joint gets ``EI' = EI / (1 + EI / (k_j L))``
    (:func:`specedit.soften_joint`).
    """

    effect = "joint_flexibility"
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

    def space(self, state, ctx):
        k = self._kref(state)
        return _log_trials(k, (0.3, 1.0, 3.0, 10.0, 30.0)), np.array([k * 1e-3]), np.array([k * 1e5])

    def apply(self, state, x, ctx):
        return state.with_spec(specedit.soften_joint(state.spec, self.point, float(x[0])))


class MemberStiffness(Hypothesis):
    """``member_stiffness``: the bending (and torsional) rigidity of a member or of one member segment.

    Parameter: ``ei_n_m2`` [N*m^2] (log10), the new out-of-plane rigidity; GJ
    scales with it (:func:`specedit.scale_segments`).
    """

    effect = "member_stiffness"
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

    def space(self, state, ctx):
        ei = self._ei0(state)
        return _log_trials(ei, (0.5, 0.7, 0.85, 0.95, 1.05, 1.2, 1.6)), np.array([ei * 0.02]), np.array([ei * 50.0])

    def apply(self, state, x, ctx):
        segs, ei = self._nominal(state)
        factor = float(x[0]) / ei
        return state.with_spec(specedit.scale_segments(state.spec, {s: factor for s in segs}))

    def null(self, state, ctx):
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

    def space(self, state, ctx):
        z0 = max(self._zeta0(state), 1e-4)
        return (np.array([[z0 * f] for f in (0.3, 0.6, 1.6, 3.0)]), np.array([1e-5]), np.array([0.5]))

    def apply(self, state, x, ctx):
        return state.with_spec(specedit.set_modal_damping(state.spec, self.mode, float(x[0])))

    def null(self, state, ctx):
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

    def space(self, state, ctx):
        c = self._cref(ctx)
        return _log_trials(c, (0.03, 0.1, 0.3, 1.0, 3.0, 10.0)), np.array([c * 1e-4]), np.array([c * 1e3])

    def apply(self, state, x, ctx):
        state.fe.dofs.index(self.point, "w")
        return replace(state, dashpots=state.dashpots + ((self.point, float(x[0])),))

    def null(self, state, ctx):
        return np.array([0.0])


class Friction(Hypothesis):
    """``friction``: Coulomb friction at a point, as its equivalent viscous damping.

    Parameter: ``friction_force_n`` [N] (log10). Under random excitation the
    statistically linearised friction force is ``c_eq v`` with
    ``c_eq = sqrt(2 / pi) F / sigma_v`` (Caughey, J. Acoust. Soc. Am. 35
    (1963) 1706-1711), ``sigma_v`` the RMS velocity at the point (measured or
    predicted). At one excitation level it fits exactly like ``damping`` at
    the point; a second level would separate them.
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

    def space(self, state, ctx):
        c = ctx.point_damping.get(self.point, 0.02 * 2 * math.pi * ctx.f1_hz * ctx.total_mass_kg)
        f = c * self._sigma(state, ctx) * math.sqrt(math.pi / 2)
        return _log_trials(f, (0.03, 0.1, 0.3, 1.0, 3.0, 10.0)), np.array([f * 1e-4]), np.array([f * 1e3])

    def apply(self, state, x, ctx):
        c = math.sqrt(2 / math.pi) * float(x[0]) / self._sigma(state, ctx)
        state.fe.dofs.index(self.point, "w")
        return replace(state, frictions=state.frictions + ((self.point, float(x[0]), c),))

    def null(self, state, ctx):
        return np.array([0.0])


class GravityPrestress(Hypothesis):
    """``gravity_prestress``: the geometric stiffness of the gravity pre-stress, as if gravity were ``g``.

    Parameter: ``g_m_per_s2`` [m/s^2]; ``k(g) = k_0 + (g / 9.81) (k - k_0)``
    with ``k_0`` the FE stiffness built without gravity (strings keep their
    given tensions; reaction tensions vanish with gravity). The MuJoCo plant
    takes its pre-stress from its own gravity: validated on the linear plant.
    """

    effect = "gravity_prestress"
    param_names = ("g_m_per_s2",)
    log_scale = (False,)
    spec_level = False
    order = 11
    stage = 1

    def space(self, state, ctx):
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

    def apply(self, state, x, ctx):
        k0 = self._k0(state, ctx)
        k = k0 + (float(x[0]) / G_SI) * (state.fe.k - k0)
        return replace(state, fe=replace(state.fe, k=k))

    def null(self, state, ctx):
        return np.array([G_SI])


# ----------------------------------------------------------------------------- chain
class LoopDelay(Hypothesis):
    """``loop_delay``: the computation delay from sample to DAC output.

    Parameter: ``delay_s`` [s] (total; the nominal chain has 1.35 periods,
    Sec. 5.3). Sets ``HardwareChain.delay_periods``.
    """

    effect = "loop_delay"
    param_names = ("delay_s",)
    log_scale = (False,)
    needs = "closed"
    order = 7

    def space(self, state, ctx):
        t = state.chain.period_s
        return (np.array([[t * f] for f in (0.0, 0.6, 2.5, 4.0, 7.0, 12.0)]), np.array([0.0]), np.array([60 * t]))

    def apply(self, state, x, ctx):
        return replace(state, chain=replace(state.chain, delay_periods=float(x[0]) / state.chain.period_s))

    def null(self, state, ctx):
        return np.array([state.chain.delay_periods * state.chain.period_s])


class _Lag(Hypothesis):
    param_names = ("corner_hz",)
    log_scale = (True,)
    attr = ""

    @property
    def location(self) -> dict:
        return {"channel": "all"}

    def space(self, state, ctx):
        hi = ctx.band_hz[1]
        return _log_trials(hi, (1.0, 3.0, 10.0, 30.0, 100.0)), np.array([0.1 * hi]), np.array([1e4 * hi])

    def apply(self, state, x, ctx):
        return replace(state, chain=replace(state.chain, **{self.attr: float(x[0])}))


class ActuatorLag(_Lag):
    """``actuator_lag``: a first-order lag of the coil force on every channel (coil inductance, amplifier bandwidth).

    Parameter: ``corner_hz`` [Hz] (log10). Sets ``HardwareChain.actuator_lag_hz``
    (one corner for all channels: the chain has no per-channel lag). It also
    acts on the excitation, so it shows open loop too.
    """

    effect = "actuator_lag"
    attr = "actuator_lag_hz"
    order = 8


class SensorLag(_Lag):
    """``sensor_lag``: a first-order lag of the velocity sensors fed back (all channels).

    Parameter: ``corner_hz`` [Hz] (log10). Sets ``HardwareChain.sensor_lag_hz``;
    the recorded velocities are not filtered, so it shows only closed loop.
    """

    effect = "sensor_lag"
    attr = "sensor_lag_hz"
    needs = "closed"
    order = 9


class _Gain(Hypothesis):
    param_names = ("gain",)
    log_scale = (True,)
    attr = ""

    def __init__(self, *, channel: int):
        self.channel = channel

    @property
    def location(self) -> dict:
        return {"channel": self.channel}

    def space(self, state, ctx):
        return _log_trials(1.0, (0.4, 0.65, 0.85, 1.2, 1.6, 2.5)), np.array([0.02]), np.array([50.0])

    def apply(self, state, x, ctx):
        gains = dict(getattr(state.chain, self.attr))
        gains[self.channel] = gains.get(self.channel, 1.0) * float(x[0])
        return replace(state, chain=replace(state.chain, **{self.attr: gains}))

    def null(self, state, ctx):
        return np.array([1.0])


class ActuatorGain(_Gain):
    """``actuator_gain``: force per command of one coil channel (amplifier or coil constant off).

    Parameter: ``gain`` [1] (log10) multiplying ``HardwareChain.actuator_gain[channel]``.
    Open loop it shows only on the excitation channel.
    """

    effect = "actuator_gain"
    attr = "actuator_gain"
    order = 10

    def applies_to(self, ctx):
        return ctx.closed_loop or self.channel == ctx.excitation_point


class SensorGain(_Gain):
    """``sensor_gain``: sensitivity of one feedback velocity sensor.

    Parameter: ``gain`` [1] (log10) multiplying ``HardwareChain.sensor_gain[channel]``;
    only closed loop (the recorded velocities are not affected).
    """

    effect = "sensor_gain"
    attr = "sensor_gain"
    needs = "closed"
    order = 10


class Saturation(Hypothesis):
    """``saturation``: the amplifiers limit the coil force.

    Parameter: ``limit_n`` [N] (log10), ``HardwareChain.amplifier_limit_n``
    (one limit for all channels, as the chain has). Fitted with the
    Gaussian-input describing function: channel ``i`` passes
    ``erf(L / (sqrt(2) sigma_i))`` of its command, ``sigma_i`` the RMS of
    excitation plus control on it (:func:`vlab.diagnose.labmodel.with_command_rms`).
    """

    effect = "saturation"
    param_names = ("limit_n",)
    log_scale = (True,)
    needs = "signals"
    order = 13

    @property
    def location(self) -> dict:
        return {"channel": "all"}

    def _ref(self, state, ctx) -> float:
        if not ctx.command_rms:
            from .labmodel import with_command_rms

            st = with_command_rms(replace(state, chain=replace(state.chain, amplifier_limit_n=1e30)), ctx.freq_hz,
                                  ctx.force_amplitude, excitation_point=ctx.excitation_point, iterations=1)
            ctx.command_rms.update(st.rms_force_n)
        return max(ctx.command_rms.values())

    def space(self, state, ctx):
        r = self._ref(state, ctx)
        return _log_trials(r, (0.5, 1.0, 2.0, 4.0)), np.array([0.02 * r]), np.array([100.0 * r])

    def apply(self, state, x, ctx):
        from .labmodel import with_command_rms

        st = replace(state, chain=replace(state.chain, amplifier_limit_n=float(x[0])))
        return with_command_rms(st, ctx.freq_hz, ctx.force_amplitude, excitation_point=ctx.excitation_point)


# ----------------------------------------------------------------------------- pairs
class Combination(Hypothesis):
    """Two effects at once (``effect = "a+b"``): parameters of the first, then of the second."""

    order = 20

    def __init__(self, *, first: Hypothesis, second: Hypothesis):
        self.parts = (first, second)

    @property
    def effect(self):  # type: ignore[override]
        return "+".join(h.effect for h in self.parts)

    @property
    def param_names(self):  # type: ignore[override]
        return tuple(f"{tag}.{n}" for tag, h in zip(("first", "second"), self.parts) for n in h.param_names)

    @property
    def log_scale(self):  # type: ignore[override]
        return tuple(b for h in self.parts for b in h.log_scale)

    @property
    def spec_level(self):  # type: ignore[override]
        return all(h.spec_level for h in self.parts)

    @property
    def location(self) -> dict:
        return {"first": self.parts[0].location, "second": self.parts[1].location}

    @property
    def label(self) -> str:
        return " + ".join(h.label for h in self.parts)

    def _split(self, x):
        k = self.parts[0].n_params
        return np.asarray(x[:k]), np.asarray(x[k:])

    def space(self, state, ctx):
        t1, l1, u1 = self.parts[0].space(state, ctx)
        t2, l2, u2 = self.parts[1].space(state, ctx)
        trials = np.array([np.concatenate([a, b]) for a in t1 for b in t2])
        return trials, np.concatenate([l1, l2]), np.concatenate([u1, u2])

    def apply(self, state, x, ctx):
        a, b = self._split(x)
        (h1, x1), (h2, x2) = sorted(((self.parts[0], a), (self.parts[1], b)), key=lambda t: t[0].stage)
        return h2.apply(h1.apply(state, x1, ctx), x2, ctx)

    def null(self, state, ctx):
        n1, n2 = self.parts[0].null(state, ctx), self.parts[1].null(state, ctx)
        return None if n1 is None or n2 is None else np.concatenate([n1, n2])


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
    (stiffness), every mode in the band (modal damping), every actuator
    channel (gains), and the chain as a whole (delay, lags, saturation,
    gravity pre-stress).

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
    out += [LoopDelay(), ActuatorLag(), SensorLag()]
    out += [ActuatorGain(channel=p) for p in state.actuators]
    out += [SensorGain(channel=p) for p in state.actuators]
    out += [GravityPrestress()]
    out += [Friction(point=p) for p in free]
    out += [Saturation()]
    out = [h for h in out if h.applies_to(ctx)]
    if effects is not None:
        unknown = set(effects) - set(EFFECTS)
        if unknown:
            raise ModelError(f"unknown effect(s) {sorted(unknown)}; the library has {EFFECTS}")
        out = [h for h in out if h.effect in effects]
    return out
