"""Detectability: the smallest size of each effect of the library that the mismatch test detects.

For one structure, controller and noise level, the lab's nominal test is recorded once on the linear FE
plant (the 2 kHz loop with the hardware chain and its sensor noise) and read as the diagnosis reads a
recording (:func:`vlab.diagnose.data.readers.read_data`: H1 FRFs on the excited lines, noise from the
period-to-period scatter), referred to the model through its noise-free replay
(:func:`vlab.diagnose.data.reference.replay_reference`), as the diagnosis refers a recording. Then, for every one-parameter hypothesis of the library at every location
(:func:`vlab.diagnose.effects.hypotheses.library`), the effect is grown from its null value towards its
bound and the test of the diagnosis's first rule (:func:`vlab.diagnose.fit.rules.beyond_noise`) is made
on the data the effect would give::

    expected chi2(x) = chi2_noise + lambda(x),   lambda(x) = chi2 of the nominal model against the
                                                  noise-free FRFs of the lab with the effect of size x
    detected: expected chi2(x) > chi2 limit      or  the largest noise-free line residual > peak limit

with ``chi2_noise`` the nominal model's chi-square against the nominal recording itself (what the
noise and the FE model's own small errors contribute) and the limits those of the diagnosis
(:meth:`vlab.diagnose.problem.residuals.Problem.noise_chi2`, ``peak_limit``: the limits of the decision
policy at its false-alarm rate, :mod:`vlab.diagnose.policy`), the model-error floor included. The threshold is where the expected statistic
reaches its limit, found on a grid of 24 sizes geometric in the distance from the null value (from
1e-7 of the range to its bound) and refined by bisection: at the threshold a recording is called a mismatch about half the time; well below it, rarely;
well above it, nearly always. It is a threshold of *detection*; naming the effect among its look-alikes
needs more (the BIC rule, :func:`vlab.diagnose.fit.rules.select`): ``naming=True`` adds the naming
thresholds of :mod:`vlab.diagnose.naming`.

A real measurement (``model_form="derived"``) is compared within the model's own uncertainty, and the
test is then the diagnosis's own in full: the nominal lab's modes are profiled within the model form
(:meth:`~vlab.diagnose.problem.residuals.Problem.nominal_profile`, nonlinear), its chi-square and largest
line taken after the profile, and the nuisance test added (the modes moved beyond their uncertainty;
its statistic's null mean, the number of profiled parameters, added as ``chi2_noise`` is). That test is
searched from the first-order threshold (linear whitening of the model form) on a ladder of factors
:data:`~vlab.diagnose.thresholds.LADDER`, then bisected (:mod:`vlab.diagnose.thresholds`: the test and
the search). A real recording is also referred through the replay on the MuJoCo plant, whose
second-order variance (:func:`vlab.diagnose.data.measured.refer_to_model`) the thresholds carry as its
expected value (:func:`~vlab.diagnose.thresholds.referral_variance`): at the lightly damped peaks it is
far larger than the noise (BCC: 18-36 % of the FRF against 2 %), and masses' thresholds rise 10-30 times.

A recording the vlab MuJoCo plant made itself (``model_form="plant"``: an exported plant with an effect
concealed in it, recorded with its metadata naming that plant) is read by the diagnosis without a model
form -- the replay plant *is* the structure, but for the effect -- referred through that plant's replay
with the referral's second-order variance (:func:`vlab.diagnose.data.measured.refer_to_model`), whose
structure-to-plant term ``e`` is then zero: the test is rule 1 alone (no profile, no nuisance test), with
the noise, the 0.5 % floor and that variance. These are the thresholds of an effect concealed in an
exported plant and recorded there.

Effects with more than one parameter (friction: force and equivalent dashpot) are left out, as are the
pairs. An effect whose null value lies inside its range (a gain of 1) gets a threshold on each side.

Source: the diagnosis's own test (rule 1 of :mod:`vlab.diagnose.fit.rules`); the noncentral
chi-square picture of detection, e.g. Kay, *Fundamentals of Statistical Signal Processing*, Vol. II,
Sec. 7.3.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ..errors import ModelError, VlabError
from ..fe import build_fe_model
from ..experiment.config import ExperimentConfig, default_chain, test_definition
from ..experiment.runner import measure
from ..spec import StructureSpec, load_spec
from ..units import format_duration
from .data.measured import FrfData, refer_to_model
from .data.readers import read_data
from .data.reference import replay_reference
from .data.warmstart import GUARD_DECAY
from .effects.hypotheses import library
from .model.labmodel import LabState, PointModes, natural_frequencies, point_modes_of, predict_frf
from .fit.plantfit import plant_modes
from .model.modelform import damping_by_frequency, frf_model_form, model_form_uncertainty, plant_shape_uncertainty
from .model.nominal import nominal_design, settling_time
from .model.shapemixing import mixing_shape_uncertainty
from .problem.context import context_for
from .problem.residuals import Problem
from .thresholds import N_BISECT_REPORTED, DetectionTest, Threshold, effect_thresholds, referral_variance


#: How the nominal recording is read (:func:`detectability`'s ``model_form``).
MODEL_FORMS = ("derived", "plant", "none")


@dataclass(frozen=True)
class Detectability:
    """Thresholds of every one-parameter effect of the library for one test.

    Attributes
    ----------
    structure, controller : str
    noise_m_s : float
        Sensor noise standard deviation of the recording [m/s].
    chi2_noise : float
        The nominal model's chi-square against the nominal recording (noise and model error).
    chi2_limit, peak_limit : float
        The mismatch test's limits (:meth:`Problem.noise_chi2`, :meth:`Problem.peak_limit`).
    n_obs : int
        Residuals of the test.
    thresholds : tuple of Threshold
    skipped : tuple of str
        Hypotheses left out (more than one parameter), by label.
    model_form : str
        "derived", "plant" or "none" (:func:`detectability`).
    """

    structure: str
    controller: str
    noise_m_s: float
    chi2_noise: float
    chi2_limit: float
    peak_limit: float
    n_obs: int
    thresholds: tuple[Threshold, ...]
    skipped: tuple[str, ...]
    model_form: str = "none"

    def as_dict(self) -> dict:
        """JSON-ready dict (keys carry units)."""
        return {"structure": self.structure, "controller": self.controller, "noise_m_s": self.noise_m_s,
                "chi2_noise": self.chi2_noise, "chi2_limit": self.chi2_limit, "peak_limit": self.peak_limit,
                "n_obs": self.n_obs, "thresholds": [t.as_dict() for t in self.thresholds],
                "skipped": list(self.skipped), "model_form": self.model_form}

    def of(self, effect: str, location: dict) -> list[Threshold]:
        """The thresholds of ``effect`` at ``location`` (one per side of the null value)."""
        return [t for t in self.thresholds if t.effect == effect and t.location == location]


def threshold_of(problem: Problem, nominal: LabState, ctx, h) -> Threshold | None:
    """The detection threshold of a found effect on the diagnosis's own data, on the side of its fitted value,
    to about 5 % (:data:`~vlab.diagnose.thresholds.N_BISECT_REPORTED`).

    Parameters
    ----------
    problem : Problem
        The diagnosis's problem (its data, noise and floor).
    nominal : LabState
    ctx : Context
    h : Hypothesis
        A fitted one-parameter hypothesis (``params_`` set); its residual chi-square ``chi2_`` stands for
        what the noise contributes.

    Returns
    -------
    Threshold or None
        None for a hypothesis with more than one parameter (a pair, friction) or without a fitted value, and
        for a modal table (the thresholds are those of FRF data).
    """
    if h.n_params != 1 or getattr(h, "params_", None) is None or not isinstance(problem.data, FrfData):
        return None
    x = float(np.asarray(h.params_)[0])
    # the side of the fitted value only (a profiled side costs a few seconds)
    sides = effect_thresholds(DetectionTest(problem, nominal, ctx, chi2_noise=getattr(h, "chi2_", None)), h, toward=x,
                              bisections=N_BISECT_REPORTED)
    return (sides or [None])[0]


def frf_model_form_of(nominal: LabState, data: FrfData, reference_plant: str | None, notes: list | None = None):
    """The model-form uncertainty of ``nominal``'s FRFs on ``data``'s lines, as the diagnosis uses it.

    Through a replay on the MuJoCo plant (``reference_plant="mujoco"``) the perturbed modes are that
    plant's own (its linearisation, :func:`vlab.diagnose.fit.plantfit.plant_modes`: it has modes the FE
    model lacks), with their frequencies (calibration residual and the plant's discretisation), damping
    (the spec's printed rounding, by the nearest FE mode) and shapes (``sqrt(1 - MAC)`` of the default
    plant against the converged one, :func:`vlab.diagnose.model.modelform.plant_shape_uncertainty`);
    through another replay or none, the FE model's modes, frequencies, damping and shapes: the mixing that
    the structure's own frequency uncertainty (the calibration residual) implies
    (:func:`_shape_uncertainty`). On the plant's modes the shapes carry both, in quadrature: the plant's
    measured discretisation and the mixing the calibration residual implies among the plant's modes (the
    structure's own uncertainty, whichever model describes it).

    Parameters
    ----------
    nominal : LabState
    data : FrfData
    reference_plant : {"mujoco", "linear"} or None
        The plant the data were referred through (None: compared with the FE model itself).
    notes : list, optional
        Receives a sentence when the MuJoCo plant cannot be linearised (the FE modes are used then).

    Returns
    -------
    (ModelFormUncertainty, FrfModelForm)
    """
    f_nom, _, _ = natural_frequencies(nominal)
    pts = tuple(dict.fromkeys(tuple(data.output_points) + nominal.actuators))
    ref_modes = None
    if reference_plant == "mujoco":
        try:
            ref_modes = plant_modes(nominal.spec, pts)
        except VlabError as exc:
            if notes is not None:
                notes.append(f"the replay plant's modes are not available ({exc}): the model form perturbs the FE "
                             "model's modes")
    if ref_modes is None:
        mf = model_form_uncertainty(nominal.spec, f_nom, compared_with="plant" if reference_plant == "mujoco" else "fe")
        shape_rel = _shape_uncertainty(mf, point_modes_of(nominal, pts, "the nominal FE model"))
    else:
        f_ref = ref_modes.omega / (2 * np.pi)
        mf = damping_by_frequency(model_form_uncertainty(nominal.spec, f_ref, compared_with="plant"), f_nom, f_ref)
        shape_rel = _root_sum_square(plant_shape_uncertainty(nominal.spec, f_ref), _shape_uncertainty(mf, ref_modes))
    return mf, frf_model_form(nominal, data.freq_hz, excitation_point=data.excitation_point,
                              output_points=data.output_points, uncertainty=mf, modes=ref_modes, shape_rel=shape_rel)


def _root_sum_square(*parts) -> np.ndarray | None:
    """Independent relative uncertainties combined in quadrature (GUM, JCGM 100:2008, Eq. (10)), each shape (n,)
    or (n_points, n) (broadcast: a per-mode value holds at every point), or None (absent); None when all are."""
    given = [np.asarray(p, dtype=float) for p in parts if p is not None]
    return np.sqrt(sum(p**2 for p in given)) if given else None


def _shape_uncertainty(mf, modes: PointModes) -> np.ndarray | None:
    """Each mode's relative shape uncertainty at each point, shape (n_points, n) [1], or None where there is none:
    the mixing that the structure's own frequency uncertainty implies
    (:func:`vlab.diagnose.model.shapemixing.mixing_shape_uncertainty`), from ``mf``'s calibration residual,
    the component that describes the structure rather than a mesh or a plant."""
    cal = mf.components.get("calibration")
    if cal is None or not len(cal):
        return None
    n = len(modes.omega)
    cal = np.asarray(cal, dtype=float)
    out = mixing_shape_uncertainty(modes, cal[np.minimum(np.arange(n), len(cal) - 1)], per_point=True)
    return out if np.any(out > 0) else None


def replay_referral(nominal: LabState, data: FrfData, mf) -> np.ndarray | None:
    """``ln(H_model / H_base)`` on ``data``'s lines, shape (n_f, n_o) complex: the nominal model against the
    replay plant, predicted with that plant's own modes (``mf.modes``, :func:`frf_model_form_of`); None without
    them (the referral's term is then not modelled)."""
    if mf is None or mf.modes is None:
        return None
    kw = {"excitation_point": data.excitation_point, "output_points": data.output_points}
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.log(predict_frf(nominal, data.freq_hz, **kw) /
                     predict_frf(replace(nominal, point_modes=mf.modes), data.freq_hz, **kw))
    return np.where(np.isfinite(out), out, 0.0)


def nominal_test(structure: str | StructureSpec, controller: str, *, noise_m_s: float = 1e-6, seed: int = 0):
    """The lab's nominal test recorded on the linear plant and read as the diagnosis reads it.

    Parameters
    ----------
    structure : str or StructureSpec
    controller : str
    noise_m_s : float
        Sensor noise [m/s].
    seed : int

    Returns
    -------
    spec : StructureSpec
    nominal : LabState
        The nominal lab (noise-free chain).
    data : FrfData
        The recording's FRFs referred to the model through its noise-free replay.
    ctx : Context
        Scales and signals for the library (:func:`vlab.diagnose.problem.context.context_for`).

    Raises
    ------
    ModelError, SpecError
        As :func:`detectability`.
    """
    spec = load_spec(structure) if isinstance(structure, str) else structure
    fe = build_fe_model(spec)
    test = test_definition(spec)
    chain = default_chain(controller, noise_m_s=float(noise_m_s))
    design = nominal_design(fe, controller, seed, period_s=chain.period_s)
    cfg = ExperimentConfig(structure=spec.name, controller=controller, plant="linear", chain=chain, seed=seed)
    rec = measure(cfg, fe, design).loop.recording
    nominal = LabState(spec, fe, replace(chain, noise_m_s=0.0), design)
    data = read_data(spec, fe, Path(f"<the nominal {spec.name} test>"), "recording",
                     rec.with_metadata(structure=spec.name), resolution_hz=None, band_hz=test.band_hz,
                     settle_of=lambda: settling_time(nominal, test.band_hz))
    # referred to the model through its noise-free replay on the same plant, as the diagnosis does: what is
    # left is the recording's noise (the loop's own sampled-data and start-up effects cancel)
    base, _run, _kind = replay_reference(data, nominal, "linear",
                                         guard_s=settling_time(nominal, test.band_hz, decay=GUARD_DECAY))
    data = refer_to_model(data, base, predict_frf(nominal, data.freq_hz, excitation_point=data.excitation_point,
                                                  output_points=data.output_points))
    return spec, nominal, data, context_for(nominal, test.band_hz, data)


def detectability(structure: str | StructureSpec = "bcc", controller: str = "none", *,
                  effects: tuple[str, ...] | None = None, noise_m_s: float = 1e-6, seed: int = 0,
                  floor: float = 0.005, model_form: str = "derived", naming: bool = False,
                  look_alikes: tuple[str, ...] | None = None, progress=None, confirm=None) -> Detectability:
    """Detection thresholds of the library's one-parameter effects for the lab's test of ``structure``.

    Parameters
    ----------
    structure : str or StructureSpec
        ``"bcc"``, ``"grid"``, a TOML path or a spec (:func:`vlab.load_spec`).
    controller : {"none", "mfdrf", "lqdrf", "lqdrf-diag", "lqg"}
        Controller running during the test.
    effects : tuple of str, optional
        Restrict to these effect names.
    noise_m_s : float
        Velocity-sensor noise standard deviation [m/s] of the recording (the lab's default 1e-6).
    seed : int
        Seed of the excitation, the noise and the design's multi-start.
    floor : float
        The diagnosis's relative model-error floor (0.5 %).
    model_form : {"derived", "plant", "none"}
        "derived" (default): the thresholds of a real measurement, compared through the plant's replay
        within the model-form uncertainty of :mod:`vlab.diagnose.model.modelform` (calibration residual
        and the plant's discretisation), by the profiled test and with the referral's variance (module
        notes); "plant": of a recording made by the MuJoCo plant itself, compared through its replay
        (the referral's variance, no model form); "none": of a recording made by the model itself.
    naming : bool
        Also the naming thresholds (:mod:`vlab.diagnose.naming`): the detection thresholds of every
        look-alike are needed, so the whole library's are computed (minutes).
    look_alikes : tuple of str, optional
        The effects that count as look-alikes for naming (default: every one-parameter effect of the
        library; fewer only for a quick check -- the thresholds are then lower bounds).
    progress : callable, optional
        Called with a short string per stage.
    confirm : callable, optional
        Called after the first item of each loop with that loop's estimate [s] and the loop in words
        (:class:`Eta`); what it raises stops the run.

    Returns
    -------
    Detectability

    Raises
    ------
    ModelError
        Unknown controller, effect name or model form; a structure without a test definition.
    SpecError
        Unknown structure.

    Notes
    -----
    The method is in the module notes. The recording is made on the linear FE plant; with
    ``model_form="derived"`` it is read as a real recording compared through the MuJoCo plant's replay
    (the model form and the referral's variance added), with ``"plant"`` as the MuJoCo plant's own recording
    compared through its replay (the referral's variance alone), with ``"none"`` as a recording of the model
    itself.
    Cost: about 4 s a place and side with the profiled test, a fraction of a second without.
    """
    say = progress or (lambda s: None)
    if model_form not in MODEL_FORMS:
        raise ModelError(f"model form {model_form!r}: use one of {', '.join(MODEL_FORMS)}")
    say("recording the nominal test on the linear plant")
    spec, nominal, data, ctx = nominal_test(structure, controller, noise_m_s=noise_m_s, seed=seed)
    mf_frf, referral = None, None
    if model_form in ("derived", "plant"):  # referred through the MuJoCo plant's replay
        _mf, mf_plant = frf_model_form_of(nominal, data, "mujoco")
        referral = replay_referral(nominal, data, mf_plant)
        # a real structure is compared within the model form; the plant's own recording is the replay plant
        # itself with the effect (no model form; the referral's second-order term with e = 0)
        mf_frf = mf_plant if model_form == "derived" else None
    var0 = data.var
    if referral is not None:  # the nominal recording as a real one: with the referral's term
        data = replace(data, var=var0 + referral_variance(referral, data.h, data.h, mf_frf) * np.abs(data.h) ** 2)
    tester = DetectionTest(Problem(data, nominal, ctx, floor=floor, model_form_frf=mf_frf), nominal, ctx, referral=referral,
                   var0=var0)
    out, skipped = [], []
    hyps = library(nominal, ctx, effects=effects)
    one = [h for h in hyps if h.n_params == 1]
    skipped = [h.label for h in hyps if h.n_params != 1]
    eta = Eta(say, len(one), "detection thresholds", "hypotheses", later="; the naming follows" if naming else "",
              confirm=confirm)
    for i, h in enumerate(one):
        out.extend(effect_thresholds(tester, h))
        eta.step(i, h.label)
    if naming:
        out = _with_naming(tester, hyps, out, look_alikes, say, confirm)
    return Detectability(spec.name, controller, float(noise_m_s), float(tester.chi2_noise), float(tester.limit),
                         float(tester.peak_limit), int(tester.problem.n_obs), tuple(out), tuple(skipped), model_form)


def _with_naming(tester: DetectionTest, hyps: list, out: list, look_alikes, say, confirm=None) -> list:
    """``out`` with the naming thresholds (:mod:`vlab.diagnose.naming`); the look-alikes' detection thresholds
    are computed where ``out`` lacks them."""
    from .naming import LookAlikes, naming_threshold

    pool = [h for h in library(tester.nominal, tester.ctx, effects=look_alikes) if h.n_params == 1]
    have = {h.label for h in hyps}
    say(f"naming among {len(pool)} look-alikes")
    # the look-alikes serve as directions (their size scales them, the gap test does not depend on it): their
    # first-order thresholds suffice
    todo = [h for h in pool if h.label not in have]
    eta, extra = Eta(say, len(todo), "look-alikes' first-order thresholds", "hypotheses", confirm=confirm), []
    for i, h in enumerate(todo):
        extra.extend(effect_thresholds(tester, h, profiled=False))
        eta.step(i, h.label)
    pooled = {h.label for h in pool}
    directions = LookAlikes(tester, pool + [h for h in hyps if h.label not in pooled], out + extra)
    named = []
    eta = Eta(say, len(out), "naming thresholds", "thresholds", confirm=confirm)
    for i, t in enumerate(out):
        h = next(x for x in hyps if x.effect == t.effect and x.location == t.location)
        n = naming_threshold(directions, h, t)
        named.append(replace(t, named_at=n.threshold, look_alike=n.look_alike, look_alike_chi2=n.gap_chi2))
        eta.step(i, h.label)
    return named


class Eta:
    """Progress of a loop of ``n`` items said through ``say``: after the first item an estimate of the whole
    loop (from that item's time), then a line with the items done and the time left (from the mean time of
    those done) whenever :attr:`EVERY_S` seconds have passed since the last line, and at the end.

    Parameters
    ----------
    say : callable
        Takes one line.
    n : int
        Items in the loop.
    what : str
        The loop, in words (``"detection thresholds"``).
    items : str
        Its items, in words (``"hypotheses"``).
    later : str
        Appended to the estimate (what comes after the loop).
    confirm : callable, optional
        Called after the first item with the loop's estimate [s] and the loop in words; what it raises stops
        the loop there (the command line refuses a long run without ``--yes``).
    """

    #: Least time between two progress lines [s].
    EVERY_S = 10.0

    def __init__(self, say, n: int, what: str, items: str, later: str = "", confirm=None):
        import time

        self._clock = time.perf_counter
        self.say, self.n, self.what, self.later, self.confirm = say, int(n), what, later, confirm
        self.t0 = self.last = self._clock()
        if n:
            say(f"{what}: {n} {items}")

    def step(self, i: int, label: str) -> None:
        """Item ``i`` (0-based) is done; ``label`` names it."""
        now = self._clock()
        done, spent = i + 1, now - self.t0
        if done == 1 and self.n > 1:
            if self.confirm is not None:
                self.confirm(spent * self.n, f"{self.n} {self.what}, the first took {spent:.2g} s")
            self.say(f"estimate: about {format_duration(spent * self.n)} for the {self.what} (the first of "
                     f"{self.n} took {spent:.2g} s){self.later}")
        elif now - self.last >= self.EVERY_S or done == self.n:
            self.say(f"{self.what}: {done} of {self.n} done ({label}), about "
                     f"{format_duration(spent / done * (self.n - done))} left")
        else:
            return
        self.last = now


def figure(result: Detectability, spec: StructureSpec, path, *, effect: str = "added_mass"):
    """Thresholds of a point effect drawn on the structure (:func:`vlab.viz.figures.point_value_map`).

    Parameters
    ----------
    result : Detectability
    spec : StructureSpec
        The structure (its ``points`` [m] and ``members``).
    path : str or Path
        Figure file to write (``.png``, ``.svg`` or ``.pdf``).
    effect : str
        A point-located effect of ``result`` (``added_mass``, ``support_stiffness``, ``damping``,
        ``joint_flexibility``); where it has a threshold on each side of its null value, the smaller
        departure is drawn.

    Returns
    -------
    Path or None
        The file, or None when ``result`` has no threshold of ``effect`` at a single point.

    Raises
    ------
    DataFileError
        An unsupported figure format.
    """
    from ..viz.figures import point_value_map

    rows = [t for t in result.thresholds if t.effect == effect and "point" in t.location
            and t.threshold is not None]
    if not rows:
        return None
    best: dict[int, float] = {}
    for t in rows:
        p, v = int(t.location["point"]), abs(t.threshold - (t.null or 0.0))
        best[p] = min(v, best.get(p, math.inf))
    return point_value_map(spec, best, path, label=f"threshold ({rows[0].parameter})",
                           title=f"{result.structure}, {result.controller}: smallest detectable {effect}")
