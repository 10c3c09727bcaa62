"""The cause of a self-excited oscillation: library effects that destabilise the loop and reproduce it.

A recording whose loop oscillates by itself (:mod:`vlab.measure.instability`)
while the nominal plant's replay of its force does not holds a mismatch that
the FRFs describe badly: its H1 estimates carry the oscillation's leakage,
the loop's effective gain is that of a limit cycle, and the time histories
hold an oscillation of arbitrary phase. A fit to those FRFs can look good
without the cause (a stiffer beam segment), and the right cause can look
poor on them (a recording of a converged, perturbed BCC plant: an 8.2 ms delay on one channel,
fitted to 7.8 ms, lowered the chi-square only from 1622 to 1521 and was
rejected by the FRF rules). The physics of an instability decides instead:

1. **The linear loop must be unstable.** A self-excited oscillation needs
   closed-loop poles in the right half-plane. Every fitted candidate that
   the FRF data support over the nominal lab (quasi-BIC evidence
   the policy's ``evidence``) is checked with the
   generalised Nyquist criterion (:func:`vlab.diagnose.model.nyquist.loop_stability`)
   on the MuJoCo plant's linearisation (:class:`~vlab.diagnose.fit.plantfit.PlantModel`),
   the structure the rerun uses: the FE model damps its unmeasured modes
   at 1 % where the plant has 0.02-0.08 %, and on the FE model the 8.2 ms
   delay above left the loop stable. Without MuJoCo the FE model is used.
   A fit to a limit cycle's FRFs lands near the stability boundary (they
   are the loop at the amplitude where the nonlinearity's describing
   function makes it marginal), so a fitted candidate counts when its loop
   is unstable at all. A hardware-chain candidate whose loop does not grow
   on the recorded mode at its fitted value (stable, or unstable on
   another mode: a limit cycle's FRFs are no linear response) is moved
   (:func:`~vlab.diagnose.fit.boundary.destabilising_value`), if the FRFs still support it there, to
   the nearest value at which a loop pole on that mode
   (:func:`~vlab.diagnose.fit.boundary.recorded_mode_band`, counted by the argument principle,
   :func:`vlab.diagnose.model.nyquist.poles_near`), and no pole elsewhere, grows
   at least as fast as the recording did: an oscillation that grew
   ``r``-fold within a record of ``T`` seconds needs a pole with
   ``Re s >= ln(r) / T`` (saturation only slows the growth the linear loop
   sets, :func:`recorded_growth_rate`), counted on the Nyquist contour
   shifted to that rate; at the bare boundary a rerun would not grow at all.
2. **Its rerun must oscillate on the same branch.** The candidates with an
   unstable loop are rerun -- the whole record from rest, as it was
   recorded, so that the oscillation has the recording's time to grow --
   in the order of their fit (single effects
   first, then pairs; for a recording the MuJoCo plant made, their fit on that plant's linearisation,
   :func:`plant_order`), at most :data:`MAX_RERUNS`. The best-supported
   candidate is rerun even when its linear loop is stable: the loop analysis
   is a screen that saves reruns, and near the stability boundary (a limit
   cycle of small amplitude) the linearisation cannot resolve the sign of
   the least-damped pole's real part (a lag on every LQG channel, fitted at
   its true corner, whose linearised loop was stable while the same plant
   oscillated at 14 Hz); the rerun is the test. So is a nonlinear candidate
   (saturation, friction): its linear loop is a describing function at one
   amplitude, which cannot say where a limit cycle sets in. The first whose rerun
   oscillates by itself on the recording's branch
   (:func:`~vlab.diagnose.fit.identity.reproduces_oscillation` with the plant's
   natural frequencies) is the cause. Above the measured band the model's
   modes are known only to their discretisation error (the default and
   converged MuJoCo BCC plants put two modes at 77.6/80.4 and 88.4/90.8 Hz),
   so there the rerun must oscillate nearest the same natural frequency as
   the recording (the mode the loop drives unstable), not on the same branch.
   Either identity is the recording's only up to the model's frequency
   error: a rerun counts when its identity is one the recording's
   oscillation may have on a structure whose natural frequencies lie within
   their model-form uncertainty of the model's (:mod:`vlab.diagnose.fit.identity`).

Its validation is that rerun; the rules that judge an explanation by the FRF
misfit's fall (a partial explanation, rule 10) do not apply to it, since the
FRFs of a limit cycle are not the lab's linear response; a rerun whose FRF
misfit rises beyond the resolution still rejects it
(:func:`~vlab.diagnose.fit.confirm.worsens` with ``self_excited``).

Source: the describing-function view of a limit cycle in a loop whose
linearisation is unstable (Gelb & Vander Velde, *Multiple-Input Describing
Functions*, 1968, ch. 2); generalised Nyquist criterion (Skogestad &
Postlethwaite, *Multivariable Feedback Control*, 2nd ed., 2005, Theorem 4.9).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import ModelError, SpecError, VlabError
from ..io.recording import Recording
from ..measure.instability import find_instability
from .effects.hypothesis import Combination, Hypothesis
from .fit.boundary import destabilising_value, moved_to, recorded_mode_band
from .fit.plantfit import PlantModel
from .fit.identity import (branch, plausible_branches, plausible_modes, reproduces_oscillation,
                           second_oscillation)
from .fit.rules import NONLINEAR, evidence
from .fit.selection import rerun_key
from .model.labmodel import LabState, structure_modes
from .model.modelform import model_form_uncertainty
from .model.nyquist import loop_stability, poles_near
from .validate import Validation, validate

#: Most candidates rerun in the search for the cause (each a rerun of the analysed record, 1-5 s on the BCC).
MAX_RERUNS = 3


@dataclass
class CauseSearch:
    """What :func:`search_cause` found.

    Attributes
    ----------
    chosen : Hypothesis or None
        The cause: the best-fitting candidate whose rerun reproduces the oscillation, among those whose linear
        loop is unstable and the best-supported one (module notes).
    validation : Validation or None
        Its rerun.
    tried : list of dict
        Each candidate rerun: ``effect``, ``label``, ``unstable_poles`` (of its linear loop), ``rerun_frequencies_hz``
        (the rerun's self-excited lines, strongest first) and ``reproduced``.
    stable : list of str
        Candidates supported by the FRFs whose linear loop is stable (not rerun).
    on : str
        The structure the loops were checked on.
    branch_hz : tuple of float
        The natural frequencies [Hz] bracketing the branches the recorded oscillation may lie on
        (:func:`~vlab.diagnose.fit.identity.plausible_branches`: the lowest and the highest), the branches a
        rerun must oscillate on.
    above_band : bool
        The oscillation lies above the measured band: a rerun's self-excited line counts when its nearest
        natural frequency may be the recording's (:func:`~vlab.diagnose.fit.identity.reproduces_oscillation`,
        ``same_mode``).
    modes_hz : tuple of float
        The natural frequencies [Hz] of the checked structure that may be nearest the recorded oscillation
        (:func:`~vlab.diagnose.fit.identity.plausible_modes`).
    sigma_source : str
        The model-form uncertainty of the natural frequencies, in words (the intervals' source).
    moved : list of (str, float, float)
        Candidates moved from their fitted value to the nearest value at which the loop grows at
        ``growth_1_s`` on the recorded mode: label, fitted and moved values [SI].
    growth_1_s : float
        The least growth rate [1/s] of a moved candidate's loop (:func:`recorded_growth_rate`).
    """

    chosen: Hypothesis | None = None
    validation: Validation | None = None
    tried: list = field(default_factory=list)
    stable: list = field(default_factory=list)
    on: str = ""
    branch_hz: tuple = ()
    moved: list = field(default_factory=list)
    above_band: bool = False
    modes_hz: tuple = ()
    sigma_source: str = ""
    growth_1_s: float = 0.0

    def note(self, frequency_hz: float) -> str:
        """One sentence for the report.

        Parameters
        ----------
        frequency_hz : float
            The recording's self-excited frequency [Hz].
        """
        lo, hi = self.branch_hz if self.branch_hz else (float("nan"), float("nan"))
        head = (f"cause of the self-excited oscillation at {frequency_hz:.2f} Hz searched among the candidates "
                f"whose linear loop is unstable on {self.on} (generalised Nyquist criterion), and the best-supported one, "
                f"and whose rerun "
                + (f"oscillates by itself on the same mode (above the measured band: nearest one of the natural "
                   f"frequencies {', '.join(f'{m:.4g}' for m in self.modes_hz)} Hz"
                   if self.above_band else
                   f"oscillates on the same branch (between the natural frequencies {lo:.4g} and {hi:.4g} Hz")
                + (f"; the structure's natural frequencies within their {self.sigma_source})" if self.sigma_source
                   else ")"))
        runs = "; ".join(f"{t['label']}: "
                         + ("linear loop not checked" if t["unstable_poles"] is None
                            else f"{t['unstable_poles']} unstable poles") + ", rerun oscillating at "
                         + (", ".join(f"{x:.2f}" for x in t["rerun_frequencies_hz"][:2]) + " Hz"
                            if t["rerun_frequencies_hz"] else "nothing")
                         + (f" and a second oscillation at {t['second_oscillation_hz']:.2f} Hz the recording lacks"
                            if t.get("second_oscillation_hz") is not None else "")
                         + (" (reproduced)" if t["reproduced"] else "") for t in self.tried)
        stable = (f"; stable loops, not rerun: {', '.join(self.stable[:4])}"
                  + (f" and {len(self.stable) - 4} more" if len(self.stable) > 4 else "")) if self.stable else ""
        moved = "".join(f"; {lab} moved from {a:.4g} to {b:.4g}, the nearest value at which the loop grows at "
                        f"least at the recorded rate ({self.growth_1_s:.3g} 1/s) on the recorded mode"
                        for lab, a, b in self.moved)
        verdict = (f": {self.chosen.label} reproduces it" if self.chosen is not None
                   else ": none reproduces it (the cause is not identified)")
        return head + (": " + runs if runs else ": no candidate's loop is unstable") + moved + stable + verdict


def recorded_growth_rate(instability: dict, duration_s: float) -> float:
    """The least growth rate [1/s] of the loop that made a recorded self-excited oscillation.

    The line in the oscillating loop's channel rose ``rise``-fold from the record's first segment to its
    largest (:class:`vlab.measure.instability.Oscillation`), within the record's ``duration_s``; a linear loop
    whose fastest pole is ``Re s = sigma`` multiplies a line by at most ``e^{sigma t}``, and saturation or any
    other nonlinearity of a limit cycle only slows that, so ``sigma >= ln(rise) / duration_s``. A line still
    growing at the end adds its own measured rate less three standard errors (the test that called it
    growing).

    Parameters
    ----------
    instability : dict
        :meth:`vlab.measure.instability.InstabilityCheck.as_dict` of the recording (unstable).
    duration_s : float
        Length of the analysed record [s], > 0.

    Returns
    -------
    float
        [1/s], >= 0 (0 when no line of the loop's channel at the recorded frequency is listed).

    Source: the envelope of a linear mode, ``e^{sigma t}``; the describing-function view of a limit cycle
    (Gelb & Vander Velde, 1968, ch. 2): its amplitude grows while the linearised loop is unstable and stops
    where the nonlinearity's gain brings the loop to its boundary.
    """
    f0, loop = instability.get("frequency_hz"), instability.get("loop_point")
    lines = [o for o in instability.get("oscillations", ())
             if o.get("point") == loop and f0 is not None
             and abs(o["frequency_hz"] - f0) <= max(instability.get("resolution_hz", 0.0), 1e-9)]
    if not lines or not duration_s > 0:
        return 0.0
    o = lines[0]
    bound = math.log(max(float(o["rise"]), 1.0)) / duration_s
    if o.get("growing"):
        bound = max(bound, float(o["growth_rate_1_s"]) - 3.0 * float(o["growth_rate_se_1_s"]))
    return max(bound, 0.0)


def rerun_oscillation(v: Validation, recording: Recording, excitation_point: int, loops, *,
                      unstable_loop: bool = False):
    """:func:`find_instability` of a validation's modified rerun (its analysed window), or None without one.

    Parameters
    ----------
    v : Validation or None
        Its ``v_after`` (velocities [m/s] on the recording's time axis, NaN before the rerun starts).
    recording : Recording
        The recording (its force channel and sampling interval).
    excitation_point : int
        Point of the recorded force ``force<ID>``.
    loops : tuple of int
        Feedback points.
    unstable_loop : bool
        The rerun lab's linear loop has an unstable pole (the generalised Nyquist count): any significant
        growth of a line in the noise-free rerun is that pole's (:func:`find_instability`'s ``unstable_loop``).

    Returns
    -------
    InstabilityCheck or None
        None without a rerun or with fewer than 256 samples of it.
    """
    if v is None or not v.v_after:
        return None
    force = np.asarray(recording[f"force{excitation_point}"])
    ran = np.all([np.isfinite(np.asarray(x)) for x in v.v_after.values()], axis=0)
    if ran.sum() < 256:
        return None
    signals = {f"force{excitation_point}": force[ran]}
    signals.update({f"vel{p}": np.asarray(x)[ran] for p, x in v.v_after.items()})
    return find_instability(Recording.from_signals(recording.dt_s, signals), feedback_points=loops,
                            unstable_loop=unstable_loop)


def plant_own_oscillation(v: Validation, recording: Recording, excitation_point: int, loops,
                          modified: LabState, band_top_hz: float) -> float | None:
    """Whether a validation's modified rerun oscillates by itself only because of the rerun plant: the
    frequency of its oscillation [Hz], or None.

    A recording that does not oscillate was made on the structure with the effect; a rerun of the lab with
    the effect that oscillates by itself (:func:`rerun_oscillation`) while the effect's own linear loop
    (``modified``, the diagnosis's model of the same lab: :func:`vlab.diagnose.model.nyquist.loop_stability`)
    has no unstable pole does not reproduce the recorded experiment in the very property it is to witness:
    the rerun plant's own modes -- the MuJoCo plant's above the band keep only their light hinge damping
    (``docs/plants.md``), where the FE model and a real structure damp them more -- are what the effect
    destabilises there. That mechanism is the plant's above the band: an oscillation at or below
    ``band_top_hz`` (where the plant carries the spec's modal damping, as the FE model does) is not
    attributed to it. Call it only for a recording that does not oscillate by itself.

    Parameters
    ----------
    v : Validation
    recording : Recording
    excitation_point : int
    loops : tuple of int
        Feedback points.
    modified : LabState
        The lab with the effect on the FE model (not the plant's linearisation).
    band_top_hz : float
        The highest line of the data [Hz].

    Returns
    -------
    float or None
        The rerun's oscillation frequency [Hz] when the rerun oscillates above ``band_top_hz`` and the linear
        loop is stable (a count the criterion vouches for); None otherwise.
    """
    osc = rerun_oscillation(v, recording, excitation_point, loops)
    if osc is None or not osc.unstable or not osc.frequency_hz > band_top_hz:
        return None
    try:
        st = loop_stability(modified)
    except (ModelError, SpecError):
        return None
    return float(osc.frequency_hz) if st.trusted and st.unstable_poles == 0 else None


def _supported(ranked: list, chi2_0: float, n_obs: int, c_hat: float, min_evidence: float) -> list:
    """The candidates the FRF data support over the nominal lab (overdispersion ``c_hat``; quasi-BIC evidence
    at least ``min_evidence``): single effects first, then pairs, each in BIC order."""
    ok = [h for h in ranked if evidence(h, None, chi2_0=chi2_0, n_obs=n_obs, c_hat=c_hat) >= min_evidence]
    return (sorted([h for h in ok if not isinstance(h, Combination)], key=lambda h: h.bic_)
            + sorted([h for h in ok if isinstance(h, Combination)], key=lambda h: h.bic_))


class _Loops:
    """The candidates' loops, on the MuJoCo plant's linearisation where it can be built (else the FE model):
    their states, their unstable poles and whether the recorded mode is the one that grows
    (:func:`search_cause`)."""

    def __init__(self, problem, nominal: LabState, on_plant: bool) -> None:
        self.problem, self.nominal, self.model, self.on = problem, nominal, None, "the FE model"
        self.band: tuple[float, float] = (0.0, 0.0)
        if on_plant:
            try:
                self.model, self.on = PlantModel(problem), "the MuJoCo plant's linearisation"
            except (ModelError, SpecError):
                self.model = None

    def state(self, h: Hypothesis | None, x=None) -> LabState:
        """The lab with ``h`` at ``x`` (default its fit; ``h`` None: the nominal lab)."""
        x = None if h is None else (h.params_ if x is None else np.atleast_1d(np.asarray(x, dtype=float)))
        if self.model is not None:
            return self.model.state(h, x)
        return self.nominal if h is None else self.problem.state_for(h, x)

    def poles(self, h: Hypothesis | None, x=None, sigma: float = 0.0) -> int | None:
        """Closed-loop poles of ``h`` at ``x`` growing faster than ``e^{sigma t}`` (None: a count the
        criterion cannot vouch for)."""
        try:
            st = loop_stability(self.state(h, x), sigma_1_s=sigma)
        except (ModelError, SpecError):
            return None
        return st.unstable_poles if st.trusted else None

    def on_mode(self, h: Hypothesis, x, sigma: float) -> bool:
        """Whether ``h`` at ``x`` has a loop pole growing faster than ``e^{sigma t}`` on the recorded mode
        (:attr:`band`), and every pole growing that fast lies there (the fastest-growing mode is the one a
        limit cycle settles on)."""
        try:
            near = poles_near(self.state(h, x), self.band, sigma)
        except (ModelError, SpecError):
            return False
        return near > 0 and self.poles(h, x, sigma) == 2 * near


def plant_order(cands: list, model) -> list:
    """The candidates in their order of fit on the plant's linearisation: for a recording the MuJoCo plant made,
    the model it was made with (the FE order carries the FE/plant difference, second order in the referral).

    Parameters
    ----------
    cands : list of Hypothesis
        Fitted (``params_`` set).
    model : PlantModel
        :class:`~vlab.diagnose.fit.plantfit.PlantModel` (``chi2(h, x)``, ``problem.information``).

    Returns
    -------
    list of Hypothesis
        Single effects first, then pairs, each by its quasi-BIC there at its FE fit (a state that cannot be
        built: last).
    """
    key = lambda h: model.problem.information(model.chi2(h, h.params_), h.n_params)[1]  # noqa: E731
    return (sorted((h for h in cands if not isinstance(h, Combination)), key=key)
            + sorted((h for h in cands if isinstance(h, Combination)), key=key))


def search_cause(problem, nominal: LabState, ranked: list, frequency_hz: float, loops, *, chi2_0: float,
                 c_hat: float, plant: str, seed: int, on_plant: bool, growth_1_s: float = 0.0,
                 plant_made: bool = False, recorded: dict | None = None) -> CauseSearch:
    """Find the library effect that makes the loop oscillate at the recording's self-excited frequency.

    Parameters
    ----------
    problem : Problem
        The diagnosis's problem (FRF data of a recording with time histories).
    nominal : LabState
        The nominal lab (closed loop).
    ranked : list of Hypothesis
        The fitted candidates (single effects and pairs, :func:`vlab.diagnose.fit.estimate.rank`).
    frequency_hz : float
        The recording's self-excited frequency [Hz].
    loops : tuple of int
        Feedback points.
    chi2_0 : float
        The nominal lab's chi-square on the fit's footing (evidence over the nominal lab).
    c_hat : float
        Overdispersion of the selection (:func:`vlab.diagnose.fit.rules.select`), >= 1.
    plant : {"mujoco", "linear"}
        Plant of the reruns.
    seed : int
        Seed of the reruns.
    on_plant : bool
        Check the loops on the MuJoCo plant's linearisation (else on the FE model).
    growth_1_s : float
        The least growth rate [1/s] of the recorded oscillation's loop (:func:`recorded_growth_rate`): a
        chain effect stable at its fit is moved to where its loop grows that fast (0: to the boundary).
    plant_made : bool
        The recording names the MuJoCo plant that made it: the candidates are tried in their order on that
        plant's linearisation (:func:`plant_order`), not the FE model's.
    recorded : dict, optional
        The recording's instability check (``InstabilityCheck.as_dict()``): a rerun holding a second
        oscillation the recording would have shown does not reproduce it
        (:func:`~vlab.diagnose.fit.identity.second_oscillation`). None: not checked.

    Returns
    -------
    CauseSearch

    Raises
    ------
    nothing: a candidate whose loop cannot be analysed or whose rerun fails is skipped (said in ``tried``).

    Source: module notes.
    """
    loops_of = _Loops(problem, nominal, on_plant)
    base = loops_of.state(None)
    natural = structure_modes(base)[0]
    on = loops_of.model is not None
    sigma, zq, source = _frequency_uncertainty(problem, base, natural, on_plant=on, same_plant=plant_made and on)
    ident = dict(sigma_rel=sigma, z=zq, recorded=recorded)
    spans = plausible_branches(frequency_hz, natural, sigma, zq) or [branch(frequency_hz, natural)]
    out = CauseSearch(on=loops_of.on, branch_hz=(spans[0][0], spans[-1][1]), growth_1_s=float(growth_1_s),
                      above_band=frequency_hz > problem.ctx.band_hz[1],
                      modes_hz=tuple(float(m) for m in plausible_modes(frequency_hz, natural, sigma, zq)),
                      sigma_source=source)
    loops_of.band = recorded_mode_band(frequency_hz, natural, out.above_band, 0.5 / base.chain.period_s,
                                       sigma_rel=sigma, z=zq)
    poles, state_of = loops_of.poles, loops_of.state

    def on_mode(h: Hypothesis, x) -> bool:
        return loops_of.on_mode(h, x, growth_1_s)

    # a nominal loop the model calls unstable (or cannot count) while its replay is not: no screen
    screen = poles(None) == 0
    cands = _supported(ranked, chi2_0, problem.n_obs, c_hat, problem.policy.evidence)
    if plant_made and loops_of.model is not None:
        cands = plant_order(cands, loops_of.model)
    for h in cands:
        if len(out.tried) >= MAX_RERUNS:
            break
        z = None
        if screen:
            z = poles(h)
            # a chain effect whose fitted loop does not grow on the recorded mode (stable, or unstable on another
            # mode: a fit to a limit cycle's FRFs is no linear response) is moved to the nearest value at which
            # it does
            if h.n_params == 1 and state_of(h).spec is base.spec and not on_mode(h, h.params_):
                x = destabilising_value(h, problem, lambda v: on_mode(h, v))
                g = None if x is None else moved_to(h, problem, x, chi2_0, c_hat)
                if g is not None:
                    out.moved.append((h.label, float(h.params_[0]), x))
                    h, z = g, poles(g)
            # the best-supported candidate is rerun whatever the screen says, and so is a nonlinear one (its
            # linear loop is a describing function at one amplitude: it cannot say where a limit cycle sets in)
            if z == 0 and out.tried and h.effect not in NONLINEAR:
                out.stable.append(h.label)
                continue
        tried, v = _rerun_candidate(problem, nominal, h, frequency_hz, loops, natural=natural, ident=ident,
                                    same_mode=out.above_band, plant=plant, seed=seed, unstable_loop=bool(z))
        out.tried.append(dict(tried, unstable_poles=z))
        if tried["reproduced"]:
            out.chosen, out.validation = h, v
            break
    return out


def _frequency_uncertainty(problem, base: LabState, natural, *, on_plant: bool, same_plant: bool) -> tuple:
    """``(sigma_rel, z, source)`` of the checked structure's natural frequencies ``natural`` [Hz] against the
    recording's structure (:mod:`vlab.diagnose.fit.identity`): none where the recording was made by the plant
    the loops are checked and rerun on (``same_plant``: its structure is the rerun's), else the model-form
    uncertainty (:func:`~vlab.diagnose.model.modelform.model_form_uncertainty`, the plant's discretisation
    ``on_plant``, the FE mesh's on the FE model) and the policy's ``identity_quantile``."""
    if same_plant:
        return None, 0.0, ""
    mf = model_form_uncertainty(base.spec, np.asarray(natural), compared_with="plant" if on_plant else "fe")
    zq = problem.policy.identity_quantile
    return mf.frequency_rel, zq, f"{zq:.3g}-sigma intervals: {mf.describe()}"


def _rerun_candidate(problem, nominal: LabState, h: Hypothesis, frequency_hz: float, loops, *, natural, ident: dict,
                     same_mode: bool, plant: str, seed: int,
                     unstable_loop: bool = False) -> tuple[dict, Validation | None]:
    """Rerun the whole record with ``h`` and check its self-excited lines against the recording's: the entry of
    :attr:`CauseSearch.tried` (without ``unstable_poles``) and the rerun (None when it failed); ``ident``: the
    natural frequencies' ``sigma_rel`` and ``z`` (:func:`~vlab.diagnose.fit.identity.reproduces_oscillation`);
    ``unstable_loop``: ``h``'s linear loop has an unstable pole (:func:`rerun_oscillation`)."""
    data = problem.data
    entry = {"effect": h.effect, "label": h.label, "rerun_frequencies_hz": [], "reproduced": False}
    try:
        v = validate(problem, nominal, problem.fitted_state(h), plant=plant,
                     spec_level=h.spec_level, seed=seed, key=rerun_key(h), whole_record=True)
    except (VlabError, ImportError) as exc:
        return dict(entry, error=str(exc)), None
    check = rerun_oscillation(v, data.recording, data.excitation_point, loops, unstable_loop=unstable_loop)
    kw = dict(natural_hz=natural, same_mode=same_mode, tolerance=problem.policy.oscillation_tolerance,
              sigma_rel=ident["sigma_rel"], z=ident["z"])
    entry["reproduced"] = reproduces_oscillation(frequency_hz, check, **kw)
    if entry["reproduced"] and ident.get("recorded") is not None:
        extra = second_oscillation(check, ident["recorded"], **kw)
        entry["reproduced"], entry["second_oscillation_hz"] = extra is None, extra
    if check is not None and check.unstable:
        entry["rerun_frequencies_hz"] = list(dict.fromkeys(round(o.frequency_hz, 2) for o in check.oscillations))
    return entry, v


def oscillation_cause(fe, design, chain, frequency_hz: float, *, mujoco_plant: bool) -> str:
    """What vlab's sampled-data loop analysis says about a self-excited oscillation at ``frequency_hz``.

    The loop (delay, hold, RC filter; :func:`vlab.diagnose.model.nyquist.loop_stability`) is analysed on
    the FE model and, for a MuJoCo plant built from the structure, on the plant's own linearisation
    (:func:`vlab.diagnose.fit.plantfit.plant_modes`). Where the FE model's loop is stable and the plant's is
    not, the sentence names the plant mode nearest the oscillation and its damping ratio against the FE
    model's: the MuJoCo plant gives the structure's modal damping only to the modes up to 1.25 times the
    highest mode of ``[damping] modal_ratios`` (:mod:`vlab.sim.damping`); higher modes keep the hinge
    damping alone, lighter than the FE model's ``default_ratio``, and a controller whose phase lag (delay,
    hold, filter) turns its collocated velocity feedback into negative damping there destabilises them.

    Parameters
    ----------
    fe : FEModel
        The structure's FE model (its spec builds the MuJoCo plant).
    design : ControllerDesign
        The controller in the loop.
    chain : HardwareChain
        The loop's hardware chain (the design's period).
    frequency_hz : float
        Frequency of the oscillation [Hz].
    mujoco_plant : bool
        Whether the run's plant is the MuJoCo plant built from ``fe.spec`` (also analysed).

    Returns
    -------
    str
        One sentence, or "" where the analysis cannot be made (it never raises).
    """
    from dataclasses import replace

    try:
        from ..fe import modal_analysis
        from ..fe.damping import open_loop_ratios

        state = LabState(fe.spec, fe, replace(chain, noise_m_s=0.0), design)
        n_fe = loop_stability(state).unstable_poles
        text = (f"vlab's sampled-data loop analysis on the FE model finds {n_fe} unstable closed-loop "
                f"pole{'s' if n_fe != 1 else ''}" + (" (the design is unstable on its own model)" if n_fe else
                                                    " (stable: see `vlab design --margins`)"))
        if not mujoco_plant:
            return text
        from .fit.plantfit import plant_modes

        pm = plant_modes(fe.spec, tuple(fe.spec.instrumentation.actuators))
        n_mj = loop_stability(replace(state, point_modes=pm)).unstable_poles
        f_mj = pm.omega / (2 * np.pi)
        k = int(np.argmin(np.abs(f_mj - frequency_hz)))
        f_fe = modal_analysis(fe.m, fe.k).frequencies_hz
        j = int(np.argmin(np.abs(f_fe - f_mj[k])))
        z_fe = float(open_loop_ratios(fe.spec, j + 1)[j])
        text += (f"; on the MuJoCo plant's linearisation {n_mj}: its mode {k + 1} at {f_mj[k]:.1f} Hz has damping "
                 f"ratio {float(pm.zeta[k]):.4f}, the FE model's mode {j + 1} at {f_fe[j]:.1f} Hz {z_fe:.4f}")
        if n_mj > n_fe:
            text += (" -- the plant damps modes above 1.25x the highest [damping] modal_ratios mode with its hinge "
                     "damping alone (docs/plants.md), and the loop's phase lag (delay, hold, filter) turns the "
                     "velocity feedback into negative damping there: list that mode's ratio in [damping] "
                     "modal_ratios if the real structure has it, or lower the gain")
        return text
    except Exception:  # noqa: BLE001 - an explanation must not break a finished run
        return ""
