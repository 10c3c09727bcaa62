"""The result of a diagnosis and its JSON object (the ``--json`` output of ``vlab diagnose``)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ...experiment.results import jsonable
from ...spec import structure_identity
from ..data.measured import FrfData, ModalData
from ..effects.hypotheses import Combination, Hypothesis
from ..fit.locate import FLAG, Location
from ..fit.onstructure import StructureFit, spanning
from ..fit.plantfit import PlantRefit
from ..model.labmodel import LabState
from ..problem.residuals import Problem
from ..validate import Validation


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
    peak_nominal, peak_limit : float
        Largest squared residual of one line and channel of the nominal model and its noise limit
        (:meth:`Problem.peak`, :meth:`Problem.peak_limit`).
    noise_only : dict or None
        When the mismatch was found only by the test without the model-error floor (a baseline given,
        :func:`vlab.diagnose.fit.rules.changed_beyond_noise`): its ``chi2``, ``chi2_limit``, ``peak``,
        ``peak_limit``; else None.
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
    alternatives : list of Hypothesis
        Hypotheses the data cannot tell apart from the selected one.
    separation : dict or None
        The look-alikes by prediction (:mod:`vlab.diagnose.fit.separation`): ``limit_chi2`` [1] and
        ``distance_chi2`` (label -> the chi-square distance [1] of its prediction from the selection's).
    overdispersion : float
        ``max(1, chi2 / (N - k))`` of the selected fit (see :func:`vlab.diagnose.fit.rules.evidence`).
    plant_refit : PlantRefit or None
        The selected effect's mode-moving parameter refitted on the MuJoCo
        plant's linearisation, used by the MuJoCo rerun (:mod:`vlab.diagnose.fit.plantfit`).
    structure_fit : StructureFit or None
        For a recording that names no vlab plant, the selected effect fitted again on the structure's own
        model, the data referred through its linear replay (:mod:`vlab.diagnose.fit.onstructure`): the
        reported value.
    fe_choice : Hypothesis or None
        The FE model's choice where the MuJoCo plant's linearisation replaced it (rule 5), else None.
    rejected : list of dict
        Candidates the validation rerun rejected (they made the FRF misfit or the time-domain error
        worse): ``effect``, ``label``, ``misfit_before``, ``misfit_after`` [decades], ``time_error_before``,
        ``time_error_after`` [1].
    too_small : bool
        The mismatch was found only without the model-error floor and a candidate explained it: a change
        located but too small to name; ``too_small_candidates`` are the hypotheses within 10 of
        the best BIC, whose places are reported.
    reference : str
        What the recording was compared with: the nominal simulation's replay, a measured baseline, or the
        FE model alone.
    instability : dict or None
        For time histories, what :func:`vlab.measure.instability.find_instability` saw in the recording
        (its ``as_dict()``, plus ``in_replay``: whether the nominal plant's replay oscillates too, None when
        there was no replay, ``summary``, ``cause`` where a candidate's rerun reproduced it, and ``unexplained``
        where none did and the FRF choice was judged with the oscillation as its remainder); None for FRFs,
        modal tables and open-loop recordings (without
        feedback the lab's structure cannot oscillate by itself).
    outside_library : bool
        The best effect of the library was rejected (its validation made the fit worse, or it explained
        less than the policy's ``explained_share``: rules 7 and 9 of :mod:`vlab.diagnose.fit.rules`).
    chi2_fit : float or None
        The nominal lab's chi-square on the footing of the fitted hypotheses (with a model form: the linearly
        whitened residual, where ``chi2_nominal`` is its nonlinear profile); None: ``chi2_nominal``.
    within_model_accuracy : bool
        No mismatch, but only because of the model's own uncertainty (floor and model form): the nominal
        model differs from the data beyond the measurement's noise alone.
    mismatch_tests : list of dict
        The mismatch tests the nominal lab failed (:func:`vlab.diagnose.decision.mismatch_tests`: ``test``,
        ``statistic``, ``limit``); empty when there is no mismatch.
    remainder : dict or None
        What the selected effect leaves beyond the mismatch test's limits, confirmed by its validation rerun
        (:func:`vlab.diagnose.decision.remainder_of`); None when nothing is left or nothing is selected.
    threshold : dict or None
        The detection threshold of the selected effect on these data, on the side of its fitted value
        (:func:`vlab.diagnose.detectability.threshold_of`, ``Threshold.as_dict()``); None without a selected
        one-parameter effect.
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
    separation: dict | None = None
    overdispersion: float = 1.0
    plant_refit: PlantRefit | None = None
    structure_fit: StructureFit | None = None
    fe_choice: Hypothesis | None = None
    peak_nominal: float = float("nan")
    peak_limit: float = float("nan")
    noise_only: dict | None = None
    rejected: list = field(default_factory=list)
    too_small: bool = False
    too_small_candidates: list = field(default_factory=list)
    reference: str = "the FE model"
    instability: dict | None = None
    threshold: dict | None = None
    outside_library: bool = False
    within_model_accuracy: bool = False
    chi2_fit: float | None = None
    mismatch_tests: list = field(default_factory=list)
    remainder: dict | None = None

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
        return self.problem.fitted_state(self.selected)

    def _entry(self, h: Hypothesis) -> dict:
        bic0 = self.chi2_nominal if self.chi2_fit is None else self.chi2_fit
        return {"effect": h.effect, "location": h.location, "parameters": h.parameters_dict(),
                "ci95": h.ci95_dict(), "score": float(h.bic_), "aic": float(h.aic_), "chi2": float(h.chi2_),
                "delta_bic": float(bic0 - h.bic_), "misfit_before": self.misfit_nominal,
                "misfit_after": float(h.misfit_)}

    def _selected_entries(self) -> list[dict]:
        """The answer, one entry per part: ``effect``, ``location``, ``parameters``, ``ci95`` and, where the
        answer is fitted on the structure's own model, the value fitted through the MuJoCo plant's replay as
        ``plant_fit`` (a mode-moving parameter refitted on the plant's linearisation: the rerun's value).

        The value belongs to the model that stands for the recording's source. For a recording that names no
        vlab plant and was compared through the MuJoCo plant's replay it is the structure's own model's
        (``structure_fit``, :mod:`vlab.diagnose.fit.onstructure`), with its 95 % interval widened to hold the
        plant's value (the two references' difference is a model-form uncertainty the fit's interval does
        not carry) -- unless the structure's model fails the mismatch test with it where the plant's passes
        (:meth:`structure_value_stands`): then the plant's value, its interval widened to hold the
        structure's, given as ``structure_fit``. Otherwise a parameter refitted on the MuJoCo plant's linearisation is reported at its
        refitted value -- it belongs to the plant that made the recording, the plant the rerun uses -- with
        the FE fit's interval scaled by refitted / FE value (the data's information about the parameter is the
        same; the model that centres it is not), and the FE model's value as ``plant_fit``'s counterpart
        ``fe_fit``."""
        if self.selected is None:
            return []
        h = self.selected
        x, ci = np.asarray(h.params_, dtype=float), np.asarray(h.ci95_, dtype=float).copy()
        fe_fit, plant_fit = {}, None
        r = self.plant_refit
        if r is not None and len(r.params) == len(x):
            for j, (a, b) in enumerate(zip(x, r.params)):
                if a != b and a != 0.0:
                    ci[j] = ci[j] * (b / a)
                    fe_fit[j] = float(a)
            x = np.asarray(r.params, dtype=float)
        sf, structure_value = self.structure_fit, None
        if sf is not None and len(sf.params) == len(x):
            if structure_value_stands(sf, r):
                plant_fit, fe_fit = x, {}
                x, ci = np.asarray(sf.params, dtype=float), spanning(sf.ci95, plant_fit)
            else:  # the plant's value, its interval widened to hold the structure's
                structure_value, ci = np.asarray(sf.params, dtype=float), spanning(ci, sf.params)
        parts = h.parts if isinstance(h, Combination) else (h,)
        out, i = [], 0
        for part in parts:
            names = part.param_names
            idx = range(i, i + part.n_params)
            e = {"effect": part.effect, "location": part.location,
                 "parameters": {n: float(x[j]) for n, j in zip(names, idx)},
                 "ci95": {n: [float(ci[j][0]), float(ci[j][1])] for n, j in zip(names, idx)}}
            if any(j in fe_fit for j in idx):
                e["fe_fit"] = {n: fe_fit[j] for n, j in zip(names, idx) if j in fe_fit}
            if plant_fit is not None:
                e["plant_fit"] = {n: float(plant_fit[j]) for n, j in zip(names, idx)}
            if structure_value is not None:
                e["structure_fit"] = {n: float(structure_value[j]) for n, j in zip(names, idx)}
            out.append(e)
            i += part.n_params
        return out

    def _located(self) -> dict:
        """The JSON's ``located``: the modes, points, members, band, sensors and channels of the location."""
        loc = self.location
        sensors = [p for p, c in loc.channels.items()
                   if c["chi2_per_residual"] > FLAG or (np.isfinite(c["comac"]) and c["comac"] < 0.9)]
        return {"modes": [m.mode for m in loc.modes if m.flagged], "points": loc.points, "members": loc.members,
                "band_hz": loc.band_hz, "extra_resonances": list(loc.extra), "loop": self.loop, "sensors": sensors,
                "mode_errors": [m.as_dict() for m in loc.modes], "channels": loc.channels,
                "sensitivity": loc.sensitivity[:10]}

    def _by_prediction(self, alternatives: list[str]) -> dict | None:
        """The JSON's ``alternatives_by_prediction``: the limit and the distances of those of ``alternatives``
        found by prediction (:attr:`separation`), None when there are none."""
        sep = self.separation or {}
        dist = {k: v for k, v in sep.get("distance_chi2", {}).items() if k in alternatives}
        return {"limit_chi2": sep["limit_chi2"], "distance_chi2": dist} if dist else None

    def structure_value_stands(self) -> bool:
        """Whether the value fitted on the structure's own model is the answer (:func:`structure_value_stands`)."""
        return structure_value_stands(self.structure_fit, self.plant_refit)

    def _value_reference(self) -> str | None:
        """The model the selected parameters belong to, in words (None when nothing is selected)."""
        if self.selected is None:
            return None
        if self.structure_fit is not None and not self.structure_value_stands():
            sf = self.structure_fit
            return (f"the MuJoCo plant's linearisation (the parameter refitted there): the structure's FE model, "
                    f"the data referred through {sf.reference}, leaves chi-square {sf.chi2:.4g} with its own value, "
                    f"beyond its limit {sf.chi2_limit:.4g}, and the interval spans that value")
        if self.structure_fit is not None:
            return f"the structure's FE model, the data referred through {self.structure_fit.reference}"
        if self.plant_refit is not None:
            return "the MuJoCo plant's linearisation (the parameter refitted there)"
        return "the FE model" + ("" if self.reference == "the FE model" else ", the data referred through "
                                 + self.reference)

    def as_dict(self) -> dict:
        """The JSON object: ``mismatch``, ``located``, ``ranked``, ``selected``, ``validated`` and context.

        Units: parameters SI (names carry the unit); ``score`` is the BIC
        (lower is better); misfits of FRF data in decades of
        ``log10|H|`` (weighted RMS), of modal data as relative frequency
        error; time errors relative. Plain JSON types: numbers that are not
        finite become None.
        """
        d = self.data
        located = self._located()
        if self.validation is not None:
            validated = self.validation.as_dict()
            if self.selected is not None:  # the likelihood-ratio limit the reruns' chi-square is judged by
                validated["chi2_change_limit"] = self.problem.policy.lr_limit(self.selected.n_params,
                                                                              self.overdispersion)
            if self.plant_refit is not None:
                validated["parameters"] = {n: float(x) for n, x in zip(self.selected.param_names,
                                                                       self.plant_refit.params)}
                validated["refit"] = self.plant_refit.as_dict()
        else:
            if self.selected is None:
                why = "none (no effect selected)"
            elif isinstance(self.data, FrfData) and self.data.recording is not None:
                why = "linear model (the rerun was not possible: see the notes)"
            else:
                why = "linear model (no time histories to replay)"
            validated = {"plant": why,
                         "misfit_before": self.misfit_nominal,
                         "misfit_after": self.misfit_selected if self.selected is not None else self.misfit_nominal,
                         "time_error_before": None, "time_error_after": None}
        if isinstance(self.data, ModalData):
            fb, _, _ = self.problem.model_modes(self.nominal)
            fa, _, _ = self.problem.model_modes(self.selected_state())
            # a table referred through a reference column is compared as f_cmp = f_meas * f_model / f_ref: the
            # prediction "before" is then the reference itself, "after" the reference with the effect's change
            f_cmp = self.problem.data.freq_hz
            fb, fa = self.data.freq_hz * fb / f_cmp, self.data.freq_hz * fa / f_cmp
            validated["modes"] = [
                {"mode": int(m), "frequency_measured_hz": float(fm), "frequency_before_hz": float(b),
                 "frequency_after_hz": float(a), "error_before": float(b / fm - 1), "error_after": float(a / fm - 1)}
                for m, fm, b, a in zip(self.data.modes, self.data.freq_hz, fb, fa)]
            if self.selected is None and self.ranked:  # what the best fitted candidate would do, though not selected
                top = self.ranked[0]
                fc, _, _ = self.problem.model_modes(self.problem.fitted_state(top))
                fc = self.data.freq_hz * fc / f_cmp
                validated["best_candidate"] = top.label
                for e, c, fm in zip(validated["modes"], fc, self.data.freq_hz):
                    e["frequency_best_candidate_hz"], e["error_best_candidate"] = float(c), float(c / fm - 1)
            if self.problem.data.reference_column is not None:
                validated["modes_compared_with"] = (f"the column {self.problem.data.reference_column!r}, changed by "
                                                    "the effect as vlab's model predicts")
        chosen = None if self.selected is None else self.selected.label
        alternatives = list(dict.fromkeys(h.label for h in self.alternatives if h.label != chosen))
        data = {"source": d.source, "kind": d.kind}
        if isinstance(d, FrfData):
            data.update(n_lines=int(d.freq_hz.size), n_channels=len(d.output_points),
                        excitation_point=d.excitation_point, output_points=list(d.output_points),
                        band_hz=[float(d.freq_hz[0]), float(d.freq_hz[-1])])
        else:
            data.update(n_modes=int(d.freq_hz.size))
        return jsonable({
            "structure": self.structure, "structure_sha256": structure_identity(self.nominal.spec),
            "controller": self.controller, "data": data,
            "mismatch": bool(self.mismatch),
            "statistics": {"chi2_nominal": self.chi2_nominal, "chi2_limit": self.chi2_limit,
                           "chi2_nominal_fit": self.chi2_nominal if self.chi2_fit is None else self.chi2_fit,
                           "peak_nominal": self.peak_nominal, "peak_limit": self.peak_limit,
                           "n_obs": self.problem.n_obs, "floor": self.problem.floor,
                           "noise_only": self.noise_only,
                           "overdispersion": self.overdispersion,
                           "mismatch_tests": list(self.mismatch_tests),
                           "policy": self.problem.policy.as_dict()},
            "located": located,
            "ranked": [self._entry(h) for h in self.ranked],
            "selected": self._selected_entries(),
            "alternatives": alternatives,
            "alternatives_by_prediction": self._by_prediction(alternatives),
            "rejected": list(self.rejected),
            "too_small_to_name": bool(self.too_small),
            "reference": self.reference,
            "value_reference": self._value_reference(),
            "structure_fit": None if self.structure_fit is None else self.structure_fit.as_dict(),
            "uncertainty": self.problem.uncertainty(),
            "instability": self.instability,
            "detection_threshold": self.threshold,
            "outside_library": bool(self.outside_library),
            "within_model_accuracy": bool(self.within_model_accuracy),
            "remainder": self.remainder,
            "validated": validated,
            "notes": list(self.notes),
            "timing_s": dict(self.timing_s),
            "files": {k: str(v) for k, v in self.files.items()},
        })


def structure_value_stands(structure_fit, plant_refit) -> bool:
    """Whether the value fitted on the structure's own model is the answer: it is, unless that model with it
    fails the mismatch test on its own footing (:attr:`vlab.diagnose.fit.onstructure.StructureFit.adequate`)
    while the MuJoCo plant's linearisation with its refitted value passes it on its own -- then the plant's
    value is the estimate (the model the data do not reject) and the structure's widens its interval.

    Parameters
    ----------
    structure_fit : StructureFit or None
    plant_refit : PlantRefit or None
        With ``chi2`` [1] and ``plant_problem`` (its footing, whose ``noise_chi2()`` is the test's limit).

    Returns
    -------
    bool
        True also where either is missing.
    """
    sf, r = structure_fit, plant_refit
    if sf is None or sf.adequate or r is None or getattr(r, "plant_problem", None) is None:
        return True
    return not r.chi2 <= r.plant_problem.noise_chi2()
