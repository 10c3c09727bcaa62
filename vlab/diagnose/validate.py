"""Validation: rerun the experiment with the selected effect modelled and compare misfits.

The recorded excitation force is played back through the lab loop on the
nominal and on the modified lab (:mod:`vlab.diagnose.data.replay`: on the
MuJoCo plant built from the modified spec when the effect can be expressed
in a spec and MuJoCo is available, else on the exact linear plant; with
periodic excitation from the lab's periodic steady state one period before
the analysed ones, :mod:`vlab.diagnose.data.warmstart`).

Misfits (before = nominal, after = with the effect):

- FRF: weighted RMS of ``log10|H_rerun / H_recorded|`` over the lines of the
  diagnosis [decades] (:meth:`vlab.diagnose.problem.residuals.Problem.misfit` weights);
  with a measured baseline, or a replay on another plant than the reruns'
  (a MuJoCo replay checked on the linear plant), the reruns are referred
  through it as the data are
  (``H_rerun * H_baseline / H_rerun,nominal``: the nominal rerun becomes the
  baseline), so that the rerun plant's own difference from the structure,
  present in the baseline too, cancels;
- time domain: ``||v_rerun - v_recorded|| / ||v_recorded||`` over all
  velocity channels after the dropped transient [1].

The FRF misfit a perfect model would still show, from the measured noise
alone, is reported with them (``noise_misfit``): a small effect's misfit
cannot fall further than that, whatever the model.

Two properties of a rerun plant that are not the effect's are kept out of
the judgement:

- **its start**: a warm start's error decays in the guard period only if the
  lab's slowest mode does; where it may not (:func:`vlab.diagnose.data.rerun_jobs.outlasts_guard`, a nearly
  undamped mode), both reruns run through every analysed period and their
  FRFs are estimated as the recording's are, the transient left removed;
- **its level dependence**: a MuJoCo plant's response is not exactly linear
  (finite rotations of its hinge chain, a tensioned cable's stretch), and an
  effect that sharpens a resonance raises the level there. Both MuJoCo reruns
  are repeated at :data:`~vlab.diagnose.data.replay.LOW_LEVEL` x the recorded force with the lab's own
  nonlinear elements scaled with it
  (:func:`vlab.diagnose.data.replay.at_amplitude`); the chi-square below is
  that of the low-level reruns, the best linear approximations, with both
  reruns' distortions as a variance about them
  (:func:`vlab.diagnose.data.replay.distortion_variance`), since whether the structure shares the
  plant's level dependence is not known; where the data were referred through the nominal replay on the
  same plant with its distortion in their variance
  (:func:`vlab.diagnose.data.reference.with_replay_distortion`), the nominal rerun's is not counted twice.

The decision weighs the reruns on the footing of the fit that chose the
effect: their chi-square with the diagnosis's own covariance (noise, floor
and the model form's correlated part whitened,
:meth:`vlab.diagnose.problem.residuals.Problem.frf_chi2`), the reruns
referred into the data's frame (``H_rerun * H_data / H_target``: the factor
that took the compared FRFs to the data, applied to the reruns). The RMS
misfits above carry the model form only as a mean floor; a rerun plant whose
lightly damped mode lies a standard uncertainty off moves both misfits by
more than that mean where the effect sharpens the mode, while the whitened
chi-square discounts the directions the model form spans -- so the mismatch
test, the selection and the validation judge on one covariance.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..errors import ModelError, VlabError
from ..io.recording import Recording
from .data.measured import FrfData
from .data.replay import LOW_LEVEL, distortion_variance, frf_of, time_error
from .data.rerun_jobs import last_reruns_note, reruns, window_for
from .model.labmodel import LabState
from .problem.misfits import complex_log_misfit, exact_errors_of, exact_phase_misfit_of, log_misfit




@dataclass(frozen=True)
class Validation:
    """Result of a validation rerun.

    Attributes
    ----------
    plant : str
        Plant used (and why, if not the one asked for).
    misfit_before, misfit_after : float
        FRF misfit [decades] of the nominal and of the modified lab.
    time_error_before, time_error_after : float
        Relative time-domain error [1].
    noise_misfit : float
        The misfit an exact model leaves [decades]: from the measured noise of the compared FRFs and, where
        the diagnosis carries the model's own uncertainty (``problem.model_form_frf``), from that
        uncertainty's log-magnitude variance (first order), added in quadrature
        (:func:`vlab.diagnose.problem.misfits.noise_misfit` for the noise).
    h_before, h_after : ndarray, complex, shape (n_f, n_o)
        FRFs of the reruns on the data's lines (with a measured baseline: referred through it, the nominal
        one then being the baseline's).
    v_before, v_after : dict
        Point -> rerun velocity [m/s] on the recording's time axis, shape (n_samples,)
        (NaN before a warm-started rerun begins).
    phase_misfit_before, phase_misfit_after : float
        The same FRFs' misfit with their phase (:func:`vlab.diagnose.problem.misfits.complex_log_misfit`)
        [decades]: the footing of a fit that uses the phase (NaN where it did not).
    noise_time_error : float
        The time-domain error an exact model leaves [1], from the same noise and model form as
        ``noise_misfit`` (:func:`vlab.diagnose.problem.misfits.exact_time_error`); NaN without the
        excitation's line amplitudes.
    target : ndarray, complex, shape (n_f, n_o), or None
        The FRFs ``h_before`` and ``h_after`` were compared with: the recording (on the plant it was
        recorded or replayed on, or with a measured baseline), else the data referred to the model.
    chi2_before, chi2_after : float
        The reruns' chi-square on the fit's footing [1] (module notes); NaN where not computed.
    target_var : ndarray, shape (n_f, n_o), or None
        The variance of ``target`` [((m/s)/N)^2].
    noise_phase_misfit : float
        What an exact model leaves on ``phase_misfit_*``'s footing, magnitude and phase [decades]
        (:func:`vlab.diagnose.problem.misfits.exact_phase_misfit`; NaN where the fit does not use the phase).
    peak_after : float
        The modified rerun's largest squared residual of one line [1] with the covariance of ``chi2_after``,
        in the tests' relative-error form (:meth:`~vlab.diagnose.problem.residuals.Problem.peak_of`), for the
        mismatch test's line limit; NaN where not computed.
    """

    plant: str
    misfit_before: float
    misfit_after: float
    time_error_before: float
    time_error_after: float
    noise_misfit: float
    h_before: np.ndarray
    h_after: np.ndarray
    v_before: dict
    v_after: dict
    phase_misfit_before: float = float("nan")
    phase_misfit_after: float = float("nan")
    noise_time_error: float = float("nan")
    target: np.ndarray | None = None
    chi2_before: float = float("nan")
    chi2_after: float = float("nan")
    target_var: np.ndarray | None = None
    noise_phase_misfit: float = float("nan")
    peak_after: float = float("nan")

    def as_dict(self) -> dict:
        """Summary for diagnosis.json (its NaN values become null there, :func:`vlab.experiment.results.jsonable`)."""
        return {"plant": self.plant, "misfit_before": self.misfit_before, "misfit_after": self.misfit_after,
                "time_error_before": self.time_error_before, "time_error_after": self.time_error_after,
                "noise_misfit": self.noise_misfit, "noise_time_error": self.noise_time_error,
                "chi2_before": self.chi2_before, "chi2_after": self.chi2_after, "peak_after": self.peak_after,
                **({"phase_misfit_before": self.phase_misfit_before, "phase_misfit_after": self.phase_misfit_after,
                    "noise_phase_misfit": self.noise_phase_misfit}
                   if np.isfinite(self.phase_misfit_before) else {})}


def validate(problem, nominal: LabState, modified: LabState, *, plant: str = "auto", spec_level: bool = True,
             seed: int = 0, key: str | None = None, workers: int = 2, whole_record: bool = False) -> Validation:
    """Rerun the recorded experiment on the nominal and the modified lab and compare with the recording.

    Parameters
    ----------
    problem : Problem
        With :class:`FrfData` from a recording.
    nominal, modified : LabState
    plant : {"auto", "linear", "mujoco"}
        ``"auto"``: MuJoCo when the effect is spec-level and MuJoCo builds the
        plant, else linear (the reason is put into ``Validation.plant``).
    spec_level : bool
        Whether the effect can be carried by the MuJoCo plant.
    seed : int
    key : str, optional
        Name under which the rerun of ``modified`` is cached on ``problem``
        (the nominal rerun is always cached).
    workers : int
        Run the two reruns in parallel processes when > 1 and both are needed.
    whole_record : bool
        Rerun the whole record from rest, as it was recorded (default: from a warm start before the analysed
        periods, :mod:`vlab.diagnose.data.warmstart`): what grows over the record -- a self-excited
        oscillation -- grows in the rerun over the same time from the same start.

    Returns
    -------
    Validation

    Raises
    ------
    ModelError
        Data without time histories, or a recording not sampled at the controller period.
    SimulationError
        A rerun diverged.
    """
    data: FrfData = problem.data
    if data.recording is None:
        raise ModelError("validation by rerun needs time histories")
    rec = data.recording
    if abs(rec.dt_s - nominal.chain.period_s) > 1e-9 * nominal.chain.period_s:
        raise ModelError(f"{data.source}: sampled every {rec.dt_s:g} s, the controller period is "
                         f"{nominal.chain.period_s:g} s: the recorded force cannot be played back")
    pts = tuple(data.output_points)
    kind = plant
    note = ""
    if plant == "auto":
        kind = "mujoco" if spec_level else "linear"
        if not spec_level:
            note = " (the effect is not expressible in a spec: linear plant)"

    base, base_key = nominal, "nominal"
    if nominal.mjcf is not None and modified.mjcf is None and kind != "linear":
        # an effect that edits the spec cannot be carried by the nominal MJCF file: both reruns on the plant
        # built from the spec, so that before and after are the same plant but for the effect
        base, base_key = replace(nominal, mjcf=None), "nominal@spec"
        note = (f" built from the spec (the effect cannot be applied to {nominal.mjcf}: the nominal rerun is "
                "made there too)")

    window = None
    if whole_record:
        window = (0, 0, None)
        base_key, key = f"{base_key}@whole", (None if key is None else f"{key}@whole")
    else:
        window, suffix = window_for(problem, (base, modified))
        base_key, key = f"{base_key}{suffix}", (None if key is None else f"{key}{suffix}")

    def both(k: str) -> list[Recording]:
        runs = reruns(problem, [(base, base_key), (modified, key)], k, seed=seed, workers=workers, window=window)
        for r in runs:
            if isinstance(r, VlabError):
                raise r
        return runs

    try:
        runs = both(kind)
    except (VlabError, ImportError) as exc:
        if plant != "auto" or kind == "linear":
            raise
        note = f" (MuJoCo plant failed: {exc}; fell back to the linear plant)"
        kind = "linear"
        runs = both(kind)
    how = last_reruns_note(problem)  # both reruns made here: one mujoco.batch, or processes (and why)
    desc = ("linear FE plant" if kind == "linear" else "MuJoCo plant" if base.mjcf is None
            else f"MuJoCo plant of {base.mjcf}") + note + (f" ({how})" if how and kind == "mujoco" else "")
    low = None
    if kind == "mujoco" and not whole_record:
        low = reruns(problem, [(base, f"{base_key}@level"), (modified, None if key is None else f"{key}@level")],
                     kind, seed=seed, workers=workers, window=window, amplitude=LOW_LEVEL)
        failed = next((r for r in low if isinstance(r, VlabError)), None)
        if failed is not None:  # judged as before, on the reruns at the recorded level, and said so
            low = None
            desc += f"; its reruns at {LOW_LEVEL:g} x the level failed ({failed}): judged at the recorded level"
    return _compared(problem, desc, kind, runs, pts, low)


def reruns_distortion(full: tuple, low: tuple, in_data: np.ndarray | None) -> np.ndarray:
    """The reruns' level dependence to add to the data's variance: :func:`distortion_variance` of the nominal
    and modified reruns (``full`` at the recorded level, ``low`` at :data:`LOW_LEVEL` x it, each shape
    (n_f, n_o), complex [(m/s)/N]) less ``in_data``, the relative variance [1] the data already carry
    (:attr:`FrfData.var_distortion`: the nominal replay's own, where the reruns are made on the plant the data
    were referred through -- the nominal rerun is that replay), never below zero. Returns shape (n_f, n_o) [1].
    """
    extra = distortion_variance(full, low)
    return extra if in_data is None else np.maximum(extra - in_data, 0.0)


def _compared(problem, desc: str, kind: str, runs: list, pts: tuple, low: list | None = None) -> Validation:
    """The two reruns (nominal, modified) compared with the recording (:func:`validate`'s last step); with
    their reruns at a low level ``low``, their chi-square is that of the low-level reruns with the
    distortion as a variance (:func:`~vlab.diagnose.data.replay.distortion_variance`)."""
    data: FrfData = problem.data
    hb, ha = frf_of(runs[0], data), frf_of(runs[1], data)
    lb, la = (hb, ha) if low is None else (frf_of(low[0], data), frf_of(low[1], data))
    extra = None if low is None else reruns_distortion((hb, ha), (lb, la), data.var_distortion
                                                       if kind == problem.replay_plant else None)
    if extra is not None:
        desc += (f"; judged by its reruns at {LOW_LEVEL:g} x the level, the plant's own level dependence (a "
                 f"relative change of the FRFs up to {np.sqrt(np.max(extra[problem.mask])):.2g}, median "
                 f"{np.sqrt(np.median(extra[problem.mask])):.2g}) counted as its uncertainty")
    mask = problem.mask
    w = problem.weight_mag[mask]
    through_base = (problem.replay_plant != kind and data.h_baseline is not None and data.h_recorded is not None)
    if through_base:
        # referred through the baseline as the data are (a measured one, or the replay on another plant than
        # the reruns'): the reruns' change from the nominal rerun, applied to the baseline (H_b = H_baseline,
        # H_a = H_rerun,modified H_baseline / H_rerun,nominal), is compared with the recording, so the rerun
        # plant's own difference from the structure cancels as in the diagnosis
        with np.errstate(divide="ignore", invalid="ignore"):
            scale = np.where(np.abs(hb) > 0, data.h_baseline / hb, 0.0)
            scale_low = np.where(np.abs(lb) > 0, data.h_baseline / lb, 0.0)
            gain = np.where(np.abs(data.h_baseline) > 0, np.abs(data.h_recorded / data.h_baseline) ** 2, 0.0)
        hb, ha, lb, la = hb * scale, ha * scale, lb * scale_low, la * scale_low
        target, target_var = data.h_recorded, data.var_recorded + data.var_baseline * gain
    else:
        # a rerun on the plant the recording was made on -- the MuJoCo plant, or the plant the recorded force
        # was replayed on as the reference -- is compared with what was recorded; a linear rerun with the data
        # referred to the model
        recorded = data.h_recorded is not None and (kind == "mujoco" or kind == problem.replay_plant)
        target = data.h_recorded if recorded else data.h
        target_var = data.var_recorded if (recorded and data.var_recorded is not None) else data.var

    floor_misfit, time_noise = exact_errors_of(problem, target, target_var)
    rb, ra = residual_in_data_frame(problem, lb, target, extra), residual_in_data_frame(problem, la, target, extra)
    peak_after = problem.peak_of(residual_in_data_frame(problem, la, target, extra, test=True))
    rec = data.recording
    phases = ((complex_log_misfit(hb[mask], target[mask], w), complex_log_misfit(ha[mask], target[mask], w))
              if problem.use_phase else (float("nan"), float("nan")))
    return Validation(desc, log_misfit(hb[mask], target[mask], w), log_misfit(ha[mask], target[mask], w),
                      time_error(runs[0], data), time_error(runs[1], data), floor_misfit, hb, ha,
                      {p: _on_recording_axis(runs[0], p, rec) for p in pts},
                      {p: _on_recording_axis(runs[1], p, rec) for p in pts}, *phases, time_noise, target,
                      float(rb @ rb), float(ra @ ra), target_var,
                      exact_phase_misfit_of(problem, target, target_var) if problem.use_phase else float("nan"),
                      peak_after)


def chi2_in_data_frame(problem, h: np.ndarray, target: np.ndarray, extra_var: np.ndarray | None = None) -> float:
    """Chi-square [1] of a rerun's FRFs ``h`` compared with ``target`` on the footing of the fit: ``|r|^2`` of
    :func:`residual_in_data_frame` of ``problem``, ``h``, ``target`` and ``extra_var`` (raises as it does)."""
    r = residual_in_data_frame(problem, h, target, extra_var)
    return float(r @ r)


def residual_in_data_frame(problem, h: np.ndarray, target: np.ndarray, extra_var: np.ndarray | None = None,
                           *, test: bool = False) -> np.ndarray:
    """Weighted residuals of a rerun's FRFs ``h`` compared with ``target`` on the footing of the fit (module
    notes): ``h`` referred into the data's frame, ``h * H_data / target`` (the factor that took ``target`` to
    the data ``problem.data.h``; 1 where it is not finite), through
    :meth:`~vlab.diagnose.problem.residuals.Problem.frf_residual` (``test``: in the tests' relative-error
    form, whose largest line :meth:`~vlab.diagnose.problem.residuals.Problem.peak_limit` judges).

    Parameters
    ----------
    problem : Problem
        Of FRF data.
    h, target : ndarray, complex, shape (n_f, n_o)
        [(m/s)/N].
    extra_var : ndarray, shape (n_f, n_o), optional
        Relative variance [1] added to each line's noise (:func:`~vlab.diagnose.data.replay.distortion_variance`).
    test : bool
        The tests' relative error instead of the fits' log ratio.

    Returns
    -------
    ndarray, shape (n_obs,)
        [1]; its square sum is the chi-square, its largest line :meth:`Problem.peak_of`.

    Raises
    ------
    ValueError
        ``h`` of another shape than the data's.
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        frame = problem.data.h / target
    return problem.frf_residual(h * np.where(np.isfinite(frame), frame, 1.0), extra_var, test=test)


def _on_recording_axis(run: Recording, p: int, rec: Recording) -> np.ndarray:
    """Velocity ``vel<p>`` of a rerun on the recording's time axis, shape (rec.n_samples,): NaN before a
    warm-started rerun begins (its metadata ``start_s``)."""
    out = np.full(rec.n_samples, np.nan)
    k0 = int(round(float(run.metadata.get("start_s", 0.0)) / rec.dt_s))
    v = np.asarray(run[f"vel{p}"])[: max(rec.n_samples - k0, 0)]
    out[k0:k0 + v.size] = v
    return out
