"""``diagnose``: compare a recording with the nominal lab, locate the mismatch, explain it, validate.

Pipeline (issue 6):

1. **Predict** the nominal lab for the same excitation and controller: the
   spec's FE model with its open-loop damping, the thesis controller
   (:func:`vlab.design.design_controller`, same seed as the experiment) and
   the nominal hardware chain, in the frequency domain
   (:func:`vlab.diagnose.labmodel.predict_frf`).
2. **Decide** whether there is a mismatch: the weighted chi-square of the
   nominal model against the data must exceed what the measured noise
   explains (:meth:`Problem.noise_chi2`); otherwise the answer is "no
   significant mismatch" and no effect is proposed.
3. **Locate** (:mod:`vlab.diagnose.locate`): modes, sensors, band, loop and,
   by sensitivity-based localisation, points and members.
4. **Explain**: every hypothesis of the library that can show in these data
   is screened at a few sizes; the best are fitted by least squares
   (:mod:`vlab.diagnose.fit`) and ranked by BIC; when the best single effect
   leaves more than noise, pairs of the best effects are fitted too. An
   effect is selected only if it lowers the BIC by 10 or more (strong
   evidence), a pair only if it beats the best single effect by 10.
5. **Validate** (:mod:`vlab.diagnose.validate`): the recorded force is played
   back through the 2 kHz loop on the nominal and on the modified plant;
   FRF and time-domain misfits before and after.
6. **Report** (:mod:`vlab.diagnose.report`).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..analysis import closed_loop_modes
from ..calibration import modal_damping_matrix, open_loop_ratios
from ..errors import DataFileError, ModelError, VlabError
from ..fe import FEModel, build_fe_model
from ..lab.experiment import TESTS
from ..lab.loop import HardwareChain
from ..spec import StructureSpec, load_spec
from .data import FrfData, ModalData, detect_kind, frfs_from_recording, frfs_from_uff, read_modal_csv, read_uff_any
from .fit import STRONG_EVIDENCE, fit_hypothesis, fit_pairs, rank, screen, select
from .hypotheses import Combination, Context, Hypothesis, library
from .labmodel import LabState, natural_frequencies
from .locate import Location, locate
from .problem import Problem
from .validate import Validation, validate

#: Effects that act only in the controller path (seen closed loop only).
CONTROLLER_PATH = ("loop_delay", "sensor_lag", "sensor_gain")
#: Effects whose frequency-domain model is a describing function: look-alikes are separated by a rerun.
NONLINEAR = ("saturation", "friction")
_DESIGNS: dict = {}


@dataclass
class DiagnosisResult:
    """Everything a diagnosis found; :meth:`as_dict` is the ``--json`` object.

    Attributes
    ----------
    structure, controller : str
    data : FrfData or ModalData
    problem : Problem
    nominal : LabState
    mismatch : bool
    chi2_nominal, chi2_limit : float
        Weighted chi-square of the nominal model and the noise limit.
    location : Location
    loop : str or None
        "open", "closed", "both" (None when there is no mismatch).
    ranked : list of Hypothesis
        Fitted hypotheses, best BIC first (empty when there is no mismatch).
    selected : Hypothesis or None
        The chosen effect (a :class:`Combination` for two).
    validation : Validation or None
        Rerun of the experiment (time-history input with a selected effect).
    misfit_nominal, misfit_selected : float
        Misfit of the linear model before and after (FRF: decades; modal:
        relative frequency error).
    notes : list of str
    timing_s : dict
    files : dict
        Name -> path of the report files (when an output folder was given).
    """

    structure: str
    controller: str
    data: FrfData | ModalData
    problem: Problem
    nominal: LabState
    mismatch: bool
    chi2_nominal: float
    chi2_limit: float
    location: Location
    loop: str | None
    ranked: list = field(default_factory=list)
    selected: Hypothesis | None = None
    validation: Validation | None = None
    misfit_nominal: float = float("nan")
    misfit_selected: float = float("nan")
    notes: list = field(default_factory=list)
    timing_s: dict = field(default_factory=dict)
    files: dict = field(default_factory=dict)
    alternatives: list = field(default_factory=list)
    overdispersion: float = 1.0

    @property
    def selected_parts(self) -> list[Hypothesis]:
        """The selected effects, one or two."""
        if self.selected is None:
            return []
        return list(self.selected.parts) if isinstance(self.selected, Combination) else [self.selected]

    def selected_state(self) -> LabState:
        """The lab with the selected effect (the nominal lab if none)."""
        if self.selected is None:
            return self.nominal
        return self.problem.state_for(self.selected, self.selected.params_)

    def _entry(self, h: Hypothesis) -> dict:
        bic0 = self.chi2_nominal
        return {"effect": h.effect, "location": h.location, "parameters": h.parameters_dict(),
                "ci95": h.ci95_dict(), "score": float(h.bic_), "aic": float(h.aic_), "chi2": float(h.chi2_),
                "delta_bic": float(bic0 - h.bic_), "misfit_before": self.misfit_nominal,
                "misfit_after": float(h.misfit_)}

    def _selected_entries(self) -> list[dict]:
        if self.selected is None:
            return []
        h = self.selected
        if not isinstance(h, Combination):
            return [{"effect": h.effect, "location": h.location, "parameters": h.parameters_dict(),
                     "ci95": h.ci95_dict()}]
        out, i = [], 0
        for part in h.parts:
            k = part.n_params
            names = part.param_names
            out.append({"effect": part.effect, "location": part.location,
                        "parameters": {n: float(v) for n, v in zip(names, h.params_[i:i + k])},
                        "ci95": {n: [float(a), float(b)] for n, (a, b) in zip(names, h.ci95_[i:i + k])}})
            i += k
        return out

    def as_dict(self) -> dict:
        """The JSON object: ``mismatch``, ``located``, ``ranked``, ``selected``, ``validated`` and context.

        Units: parameters SI (names carry the unit); ``score`` is the BIC
        (lower is better); misfits of FRF data in decades of
        ``log10|H|`` (weighted RMS), of modal data as relative frequency
        error; time errors relative.
        """
        loc = self.location
        d = self.data
        flagged = [m.mode for m in loc.modes if m.flagged]
        sensors = [p for p, c in loc.channels.items()
                   if c["chi2_per_residual"] > 4.0 or (np.isfinite(c["comac"]) and c["comac"] < 0.9)]
        located = {"modes": flagged, "points": loc.points, "members": loc.members, "band_hz": loc.band_hz,
                   "loop": self.loop, "sensors": sensors, "mode_errors": [m.as_dict() for m in loc.modes],
                   "channels": loc.channels, "sensitivity": loc.sensitivity[:10]}
        if self.validation is not None:
            validated = self.validation.as_dict()
        else:
            validated = {"plant": "linear model (no time histories to replay)" if self.selected is not None
                         else "none (no effect selected)",
                         "misfit_before": self.misfit_nominal,
                         "misfit_after": self.misfit_selected if self.selected is not None else self.misfit_nominal,
                         "time_error_before": None, "time_error_after": None}
        alternatives = [h.label for h in self.alternatives]
        data = {"source": d.source, "kind": d.kind}
        if isinstance(d, FrfData):
            data.update(n_lines=int(d.freq_hz.size), n_channels=len(d.output_points),
                        excitation_point=d.excitation_point, output_points=list(d.output_points),
                        band_hz=[float(d.freq_hz[0]), float(d.freq_hz[-1])])
        else:
            data.update(n_modes=int(d.freq_hz.size))
        return {
            "structure": self.structure, "controller": self.controller, "data": data,
            "mismatch": bool(self.mismatch),
            "statistics": {"chi2_nominal": self.chi2_nominal, "chi2_limit": self.chi2_limit,
                           "n_obs": self.problem.n_obs, "floor": self.problem.floor,
                           "overdispersion": self.overdispersion},
            "located": located,
            "ranked": [self._entry(h) for h in self.ranked],
            "selected": self._selected_entries(),
            "alternatives": alternatives,
            "validated": validated,
            "notes": list(self.notes),
            "timing_s": dict(self.timing_s),
            "files": {k: str(v) for k, v in self.files.items()},
        }


# ----------------------------------------------------------------------------- helpers
def _design(fe: FEModel, controller: str, seed: int):
    if controller == "none":
        return None
    key = (fe.spec.name, id(fe), controller, seed)
    hit = _DESIGNS.get(key)
    if hit is not None and hit[0] is fe:
        return hit[1]
    if controller == "lqr":
        raise ModelError("LQR needs every state measured; the laboratory ran it as LQG (use --controller lqg)")
    from ..design import design_controller

    d = design_controller(fe, controller, seed=seed)
    _DESIGNS[key] = (fe, d)
    return d


def settling_time(state: LabState, band_hz: tuple[float, float], *, decay: float = 0.01) -> float:
    """Time [s] for the slowest in-band mode of the (closed-loop) lab to decay to ``decay``.

    ``ln(1 / decay) / min(zeta_r omega_r)`` over the modes in the band
    (closed loop: :func:`vlab.analysis.closed_loop_modes` with the
    continuous controller).
    """
    fe = state.fe
    c = modal_damping_matrix(fe.m, fe.k, open_loop_ratios(state.spec, fe.n))
    u = fe.force_input(state.actuators)
    cont = state.design.continuous if state.design is not None and state.design.continuous else None
    try:
        fm, zm = closed_loop_modes(fe.m, c, fe.k, u, u.T, cont)
    except (ValueError, np.linalg.LinAlgError, ModelError):
        fm, zm, _ = natural_frequencies(state)
    sel = (fm >= band_hz[0]) & (fm <= band_hz[1]) & (zm > 0)
    if not sel.any():
        return 0.0
    sigma = np.min(2 * np.pi * fm[sel] * zm[sel])
    return float(math.log(1.0 / decay) / sigma)


def context_for(state: LabState, band_hz: tuple[float, float], data) -> Context:
    """Scales of the structure and signals of the data for the hypotheses."""
    fe = state.fe
    w_rows = [i for i, (_n, dof) in enumerate(fe.dofs.labels) if dof == "w"]
    u = np.zeros(fe.n)
    u[w_rows] = 1.0
    total = float(u @ fe.m @ u)
    f, _, phi = natural_frequencies(state)
    om = 2 * np.pi * f
    keep = om > 1e-6
    _, zeta, _ = natural_frequencies(state)
    inband = keep & (f >= band_hz[0]) & (f <= band_hz[1])
    if not inband.any():
        inband = keep
    kp, mp, cp = {}, {}, {}
    for p in state.spec.points:
        if (p, "w") in fe.dofs:
            i = fe.dofs.index(p, "w")
            flex = float(np.sum(phi[i, keep] ** 2 / om[keep] ** 2))
            if flex > 0:
                kp[p] = 1.0 / flex
            ph2 = phi[i, inband] ** 2
            if ph2.max() > 0:
                mp[p] = float(1.0 / ph2.max())
                with np.errstate(divide="ignore"):
                    cp[p] = float(np.min(2 * np.maximum(zeta[inband], 1e-4) * om[inband] / np.maximum(ph2, 1e-300)))
    closed = state.design is not None
    if isinstance(data, FrfData):
        return Context(band_hz, closed, total, float(f[keep][0]), kp, mp, cp, data.freq_hz, data.force_amplitude,
                       dict(data.velocity_rms), data.excitation_point)
    return Context(band_hz, False, total, float(f[keep][0]), kp, mp, cp)


def _data(spec: StructureSpec, fe: FEModel, path: Path, what: str, obj, *, controller: str,
          resolution_hz: float | None, band_hz, settle_of, notes: list):
    """Turn what was read into FrfData or ModalData (see :mod:`vlab.diagnose.data`)."""
    if what == "modal":
        return obj
    if what == "recording":
        meta = dict(obj.metadata)
        if meta.get("structure") not in (None, spec.name):
            raise DataFileError(f"{path}: recorded on structure {meta['structure']!r}, diagnosed as {spec.name!r}")
        if meta.get("controller") not in (None, controller):
            notes.append(f"the recording's metadata says controller {meta['controller']!r}; diagnosed with "
                         f"{controller!r} as asked")
        res = float(resolution_hz or meta.get("resolution_hz") or TESTS[spec.name].resolution_hz)
        return frfs_from_recording(obj, spec, fe, path=str(path), resolution_hz=res, band_hz=band_hz,
                                   settle_s=settle_of())
    return frfs_from_uff(obj, spec, fe, path=str(path), band_hz=band_hz)


def _key(h: Hypothesis) -> str:
    return f"{h.label}:{np.asarray(h.params_).tobytes().hex()}"


def data_has_signals(data) -> bool:
    """True for time-history input (a rerun is possible)."""
    return isinstance(data, FrfData) and data.recording is not None


def tie_break_by_rerun(problem: Problem, nominal: LabState, chosen: Hypothesis, alts: list, plant: str,
                       notes: list, *, max_candidates: int = 3) -> tuple[Hypothesis, list]:
    """Choose among look-alike effects by the time-domain error of a rerun.

    A saturating amplifier and a lower channel gain give nearly the same FRF
    (the saturation's describing function is a gain), and so do Coulomb
    friction and a dashpot at one point; the rerun through the loop
    reproduces the clipping or the friction force itself, so the time
    histories separate them.
    """
    cands = [chosen] + [h for h in alts if h.n_params == chosen.n_params][: max_candidates - 1]
    if len(cands) < 2:
        return chosen, alts
    errs = []
    for h in cands:
        try:
            v = validate(problem, nominal, problem.state_for(h, h.params_), plant="linear", spec_level=False,
                         key=_key(h))
            errs.append(v.time_error_after)
        except (VlabError, ImportError):
            errs.append(float("inf"))
    j = int(np.argmin(errs))
    notes.append("look-alikes compared by rerun (time-domain error): "
                 + ", ".join(f"{h.label}: {e:.3g}" for h, e in zip(cands, errs)))
    best = cands[j]
    return best, [h for h in [chosen] + alts if h is not best]


STRUCTURAL = ("added_mass", "support_stiffness", "joint_flexibility", "member_stiffness")


def located_from_fits(res: "DiagnosisResult", chi2_0: float, *, share: float = 0.9) -> tuple[list, list]:
    """Points and members where the mismatch is, from the fitted local hypotheses (nonlinear best subset).

    The first-order sensitivity ranking (:func:`vlab.diagnose.locate.sensitivity_localisation`)
    chose which local hypotheses were fitted; here each fitted local effect
    counts by the share of the nominal chi-square it removes: the selected
    effect's places, and every local effect removing at least ``share`` of
    what the best local effect removes (places the data cannot tell apart,
    e.g. mirror points). Without a selected local effect, the places the
    sensitivity ranking points at are returned when there is an unexplained
    mismatch.
    """
    parts = res.selected_parts
    local = [h for h in res.ranked if not isinstance(h, Combination)
             and ("point" in h.location or "points" in h.location or "member" in h.location)]
    pts: list = []
    mems: list = []

    def add(h: Hypothesis) -> None:
        loc = h.location
        for p in ([loc["point"]] if "point" in loc else loc.get("points", [])):
            if p not in pts:
                pts.append(p)
        if "member" in loc:
            name = loc["member"] if "segment" not in loc else f"{loc['member']}[{loc['segment'][0]}-{loc['segment'][1]}]"
            if name not in mems:
                mems.append(name)

    for h in parts:
        add(h)
    sel_local = [h for h in parts if "point" in h.location or "points" in h.location or "member" in h.location]
    if sel_local and local:
        gain = max(chi2_0 - h.chi2_ for h in local)
        for h in local:
            if chi2_0 - h.chi2_ >= share * gain and h.effect in {p.effect for p in sel_local}:
                add(h)
    if res.selected is None and res.mismatch:
        return list(res.location.points), list(res.location.members)
    return pts, mems


def prune(hyps: list[Hypothesis], sensitivity: list[dict], *, share: float = 0.25, per_family: int = 6,
          min_explained: float = 0.2) -> list[Hypothesis]:
    """Keep the local structural hypotheses the sensitivity-based localisation points at.

    When the best single local parameter explains at least ``min_explained`` of
    the frequency errors, a local structural hypothesis (added mass, spring at a
    free DOF, joint flexibility, member rigidity) is kept if its sensitivity
    candidate explains at least ``share`` of the best one or is among the
    ``per_family`` best of its effect; its first-order size becomes an extra
    trial value (``estimate_``). Other hypotheses are all kept.
    """
    if not sensitivity or sensitivity[0]["explained"] < min_explained:
        return hyps
    best = sensitivity[0]["explained"]
    by_key = {}
    rank_in_family: dict = {}
    for d in sensitivity:
        key = (d["effect"], tuple(sorted((k, tuple(v) if isinstance(v, list) else v)
                                         for k, v in d["location"].items())))
        rank_in_family[d["effect"]] = rank_in_family.get(d["effect"], 0) + 1
        by_key[key] = (d, rank_in_family[d["effect"]])
    out = []
    for h in hyps:
        if h.effect not in STRUCTURAL:
            out.append(h)
            continue
        key = (h.effect, tuple(sorted((k, tuple(v) if isinstance(v, list) else v) for k, v in h.location.items())))
        hit = by_key.get(key)
        if hit is None:
            out.append(h)  # not a local frequency parameter (e.g. a released support): keep
            continue
        d, r = hit
        if d["explained"] >= share * best or r <= per_family:
            h.estimate_ = d["estimate"]
            out.append(h)
    return out


# ----------------------------------------------------------------------------- entry
def diagnose(structure: str | StructureSpec, recording_path: str | Path, *, controller: str = "none",
             out_dir: str | Path | None = None, plant: str = "auto", resolution_hz: float | None = None,
             seed: int | None = None, effects: tuple[str, ...] | None = None, floor: float = 0.005,
             shortlist: int = 10, pairs: bool = True, validate_run: bool = True, overwrite: bool = True,
             progress=None) -> DiagnosisResult:
    """Diagnose a recording against the nominal laboratory (``vlab diagnose``).

    Parameters
    ----------
    structure : {"bcc", "grid"} or StructureSpec
        The structure (a spec for tests and benchmarks).
    recording_path : str or Path
        UFF 58 time histories (force + velocities, as ``vlab experiment``
        writes them), UFF 58 FRFs, or a CSV modal table (``.csv``).
    controller : {"none", "mfdrf", "lqdrf", "lqdrf-diag", "lqg"}
        The nominal controller that was running.
    out_dir : str or Path, optional
        Folder for ``diagnosis.md``, ``diagnosis.json`` and figures.
    plant : {"auto", "linear", "mujoco"}
        Plant of the validation rerun; ``"auto"`` uses MuJoCo for effects a
        spec can carry and falls back to the linear plant (saying so).
    resolution_hz : float, optional
        Frequency resolution = 1 / excitation period [Hz]; default: the
        recording's metadata, else the structure's test resolution
        (:data:`vlab.lab.experiment.TESTS`).
    seed : int, optional
        Seed of the controller design's multi-start; default the
        recording's metadata seed, else 0.
    effects : tuple of str, optional
        Restrict the library to these effect names.
    floor : float
        Relative model error allowed on FRFs (0.5 %).
    shortlist : int
        Number of screened hypotheses fitted in full (plus the best of each effect).
    pairs : bool
        Consider pairs of effects when no single one explains the data.
    validate_run : bool
        Rerun the experiment for validation (time-history input only).
    overwrite : bool
        Replace existing report files in ``out_dir``.
    progress : callable, optional
        Called with a short string at each stage.

    Returns
    -------
    DiagnosisResult

    Raises
    ------
    DataFileError
        Missing, malformed or truncated file; unknown point ids; a recording
        of another structure; mismatched sample rates or lengths (names the
        file and channel).
    MeasurementError
        NaN, clipped or dead channels; a record too short for the resolution.
    ModelError
        Unknown controller or effect name.
    SpecError
        Unknown structure.
    """
    t_start = time.perf_counter()
    timing: dict = {}
    say = progress or (lambda s: None)
    spec = load_spec(structure) if isinstance(structure, str) else structure
    if spec.name not in TESTS:
        raise ModelError(f"no test definition (band, resolution) for structure {spec.name!r}")
    fe = build_fe_model(spec)
    test = TESTS[spec.name]
    band = test.band_hz
    path = Path(recording_path)
    notes: list = []
    if plant not in ("auto", "linear", "mujoco"):
        raise ModelError(f"unknown plant {plant!r}; use 'auto', 'linear' or 'mujoco'")
    if detect_kind(path) == "modal" and controller != "none":
        notes.append(f"a modal table holds open-loop modes: compared with the open-loop model (controller "
                     f"{controller!r} ignored)")
        controller = "none"
    # seed of the design: from the recording if it says
    design_seed = 0 if seed is None else seed
    chain = HardwareChain()
    state_box: dict = {}

    def nominal_state() -> LabState:
        if "s" not in state_box:
            state_box["s"] = LabState(spec, fe, chain, _design(fe, controller, design_seed))
        return state_box["s"]

    def settle() -> float:
        return settling_time(nominal_state(), band)

    say("reading data")
    if detect_kind(path) == "modal":
        what, obj = "modal", read_modal_csv(path, spec)
    else:
        what, obj = read_uff_any(path)
        if seed is None and what == "recording" and isinstance(obj.metadata.get("seed"), int):
            design_seed = int(obj.metadata["seed"])
    data = _data(spec, fe, path, what, obj, controller=controller, resolution_hz=resolution_hz, band_hz=band,
                 settle_of=settle, notes=notes)
    nominal = nominal_state()
    notes = list(getattr(data, "notes", [])) + notes
    timing["read"] = time.perf_counter() - t_start

    ctx = context_for(nominal, band, data)
    problem = Problem(data, nominal, ctx, floor=floor)
    chi2_0 = problem.chi2(nominal)
    limit = problem.noise_chi2()
    misfit_0 = problem.misfit(nominal)
    say("locating")
    t = time.perf_counter()
    location = locate(problem, nominal)
    timing["locate"] = time.perf_counter() - t
    mismatch = chi2_0 > limit
    res = DiagnosisResult(spec.name, controller, data, problem, nominal, mismatch, chi2_0, limit, location,
                          None, notes=notes, misfit_nominal=misfit_0, misfit_selected=misfit_0)
    if not mismatch:
        res.location.points, res.location.members = [], []
        notes.append("the nominal model agrees with the data within the measured noise: no effect is proposed")
    else:
        say("screening hypotheses")
        t = time.perf_counter()
        hyps = prune(library(nominal, ctx, effects=effects), location.sensitivity)
        scored = []
        for h in hyps:
            try:
                trials, _, _ = h.space(nominal, ctx)
                est = getattr(h, "estimate_", None)
                if est is not None and np.isfinite(est):
                    trials = np.vstack([trials, [[est]], [[est * 0.7]], [[est * 1.4]]])
                scored.append((screen(h, problem, trials)[0][0], h))
            except (VlabError, ValueError, np.linalg.LinAlgError):
                continue
        scored.sort(key=lambda s: s[0])
        keep: list[Hypothesis] = [h for _, h in scored[:shortlist]]
        seen = {h.effect for h in keep}
        for _, h in scored:
            if h.effect not in seen:
                keep.append(h)
                seen.add(h.effect)
        timing["screen"] = time.perf_counter() - t
        say("fitting")
        t = time.perf_counter()
        fitted = []
        for h in keep:
            try:
                fitted.append(fit_hypothesis(h, problem))
            except (VlabError, ValueError, np.linalg.LinAlgError):
                continue
        ranked = rank(fitted)
        timing["fit"] = time.perf_counter() - t
        best = ranked[0] if ranked else None
        if pairs and best is not None and best.chi2_ > limit:
            say("fitting pairs")
            t = time.perf_counter()
            ranked = rank(ranked + fit_pairs(ranked, problem))
            timing["pairs"] = time.perf_counter() - t
        res.ranked = ranked
        chosen, c_hat, alts = select(ranked, chi2_0, problem.n_obs)
        res.overdispersion = c_hat
        if chosen is not None and validate_run and data_has_signals(data) and \
                any(h.effect in NONLINEAR for h in [chosen] + alts):
            say("separating look-alikes by rerun")
            t = time.perf_counter()
            chosen, alts = tie_break_by_rerun(problem, nominal, chosen, alts, plant, notes)
            timing["tie_break"] = time.perf_counter() - t
        res.alternatives = alts
        if chosen is not None:
            res.selected = chosen
            res.misfit_selected = float(chosen.misfit_)
            parts = res.selected_parts
            if not ctx.closed_loop:
                res.loop = "open"
            else:
                res.loop = "closed" if all(p.effect in CONTROLLER_PATH for p in parts) else "both"
        else:
            res.loop = "open" if not ctx.closed_loop else "both"
            notes.append("no hypothesis of the library explains the mismatch (quasi-BIC not lowered by 10)")
    if res.loop is None and mismatch:
        res.loop = "open" if not ctx.closed_loop else "both"
    if mismatch:
        res.location.points, res.location.members = located_from_fits(res, chi2_0)
    # validation
    if res.selected is not None and validate_run and isinstance(data, FrfData) and data.recording is not None:
        say("validating")
        t = time.perf_counter()
        try:
            res.validation = validate(problem, nominal, res.selected_state(), plant=plant,
                                      spec_level=res.selected.spec_level, seed=0, key=_key(res.selected))
        except (VlabError, ImportError) as exc:
            notes.append(f"validation rerun not possible: {exc}")
        timing["validate"] = time.perf_counter() - t
    timing["total"] = time.perf_counter() - t_start
    res.timing_s = timing
    if out_dir is not None:
        from .figures import figures_for
        from .report import write_report

        say("writing the report")
        res.files = write_report(out_dir, res.as_dict(), figures_for(res), overwrite=overwrite)
    return res
