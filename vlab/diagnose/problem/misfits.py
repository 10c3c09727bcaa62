"""Misfits of FRFs: the weighted RMS log-magnitude distance between two sets, and the part noise alone leaves.

The diagnosis judges a model's FRFs against the measured ones by the weighted root-mean-square of
``log10 |H_model / H_measured|`` over the used lines [decades]: the selection's "misfit", the
validation's before/after comparison. An exact model does not reach zero: the measured FRFs carry their
noise, whose expected contribution :func:`noise_misfit` gives (first order in the relative noise).
"""

from __future__ import annotations

import numpy as np


def log_misfit(h: np.ndarray, h_ref: np.ndarray, weight: np.ndarray) -> float:
    """Weighted RMS of ``log10|h / h_ref|`` [decades]: the FRF misfit of the diagnosis.

    Parameters
    ----------
    h, h_ref : ndarray, complex, shape (n,)
        Compared FRF values (model or rerun; measured) on the same lines [(m/s)/N].
    weight : ndarray, shape (n,)
        Line weights, ``1 / (sigma_rel^2 + floor^2)`` (:attr:`vlab.diagnose.problem.residuals.Problem.weight_mag`).

    Returns
    -------
    float
        [decades]; NaN for no lines.
    """
    return _weighted_rms(np.log10(np.abs(np.asarray(h) / np.asarray(h_ref))), weight)


def _weighted_rms(e: np.ndarray, weight: np.ndarray) -> float:
    """``sqrt(sum w e^2 / sum w)`` of the per-line distances ``e`` [decades]; NaN for no lines."""
    if np.size(e) == 0:
        return float("nan")
    w = np.asarray(weight, dtype=float)
    return float(np.sqrt(np.sum(w * np.asarray(e) ** 2) / np.sum(w)))


def complex_log_misfit(h: np.ndarray, h_ref: np.ndarray, weight: np.ndarray) -> float:
    """Weighted RMS of ``|log10(h / h_ref)|`` of the complex ratio [decades]: magnitude and phase together.

    ``ln(h / h_ref) = ln|h / h_ref| + j arg(h / h_ref)``: the squared distance is the squared log magnitude
    plus the squared phase [rad], the two parts a fit with phase weighs equally
    (:class:`vlab.diagnose.problem.residuals.Problem`, ``use_phase``). A change that turns the phase more
    than the magnitude (a lag, a delay) shows here and hardly in :func:`log_misfit`. ``h``, ``h_ref`` and
    ``weight`` and the result as in :func:`log_misfit`.
    """
    return _weighted_rms(np.abs(np.log(np.asarray(h, dtype=complex) / np.asarray(h_ref, dtype=complex)))
                         / np.log(10.0), weight)


def noise_misfit(h: np.ndarray, var: np.ndarray, weight: np.ndarray) -> float:
    """Expected :func:`log_misfit` of an exact model against measured FRFs, from their noise alone [decades].

    For a small circular complex relative error of variance
    ``s^2 = var / |h|^2`` the log magnitude takes half of it,
    ``E[(ln|.|)^2] = s^2 / 2`` (circular noise: its real and imaginary parts
    are uncorrelated with equal variance, the usual assumption for averaged
    FRFs, e.g. Pintelon & Schoukens, *System Identification: A Frequency
    Domain Approach*, 2nd ed., 2012); in decades it is divided by ``ln(10)^2``; the lines are
    weighted as in the misfit.

    Parameters
    ----------
    h : ndarray, complex, shape (n,)
        Measured FRF values on the compared lines [(m/s)/N].
    var : ndarray, shape (n,)
        Their variance ``E|h - h_true|^2`` [((m/s)/N)^2].
    weight : ndarray, shape (n,)
        Weights of the misfit.

    Returns
    -------
    float
        [decades]
    """
    s2 = np.asarray(var, dtype=float) / np.maximum(np.abs(h) ** 2, 1e-300)
    w = np.asarray(weight, dtype=float)
    return float(np.sqrt(np.sum(w * s2 / 2.0) / np.sum(w)) / np.log(10.0))


def exact_time_error(h: np.ndarray, rel_var: np.ndarray, force_amplitude: np.ndarray) -> float:
    """Expected relative time-domain error of an exact model against a periodic recording [1].

    In the steady state the velocity at line ``k`` and channel ``j`` is ``F_k h_kj`` and its error
    ``F_k h_kj e_kj`` with ``E|e_kj|^2 = s^2_kj`` (the relative complex variance of the noise and of the model's
    own uncertainty); by Parseval's theorem over whole periods the squared relative time-domain error
    (:func:`vlab.diagnose.data.replay.time_error`) is the response-power-weighted mean of ``s^2``::

        e_t^2 = sum |F_k h_kj|^2 s^2_kj / sum |F_k h_kj|^2

    What the excitation leaves out (the non-excited bins' noise, a transient's residue) is common to any two
    reruns and cancels where two errors are compared in quadrature (:meth:`vlab.diagnose.policy.DecisionPolicy.
    resolved`).

    Parameters
    ----------
    h : ndarray, complex, shape (n,)
        Measured FRF values on the compared lines and channels [(m/s)/N].
    rel_var : ndarray, shape (n,)
        Their relative complex variance ``E|h - h_true|^2 / |h|^2`` [1].
    force_amplitude : ndarray, shape (n,)
        The force amplitude of each value's line [N].

    Returns
    -------
    float
        [1]; NaN where no line carries power.
    """
    power = np.abs(np.asarray(force_amplitude, dtype=float) * np.asarray(h)) ** 2
    total = float(np.sum(power))
    return float(np.sqrt(np.sum(power * np.asarray(rel_var, dtype=float)) / total)) if total > 0 else float("nan")


def exact_model_errors(target: np.ndarray, target_var: np.ndarray, weight: np.ndarray, *,
                       sens: np.ndarray | None = None, sigma: np.ndarray | None = None,
                       force_amplitude: np.ndarray | None = None,
                       periodic: bool = True) -> tuple[float, float]:
    """What an exact model leaves against measured FRFs: its FRF misfit and its time-domain error.

    The noise of the data (:func:`noise_misfit`) and, where a model form is carried, the model's own
    uncertainty (the model form's first-order magnitude variance, added in quadrature to the misfit and to
    the relative variance of the time-domain error, :func:`exact_time_error`). These are the resolutions of
    the quadrature rule by which two errors are compared (:meth:`vlab.diagnose.policy.DecisionPolicy.resolved`).

    Parameters
    ----------
    target : ndarray, complex, shape (n,)
        Measured FRF values on the compared lines and channels [(m/s)/N].
    target_var : ndarray, shape (n,)
        Their variance [((m/s)/N)^2].
    weight : ndarray, shape (n,)
        Weights of the misfit (:attr:`vlab.diagnose.problem.residuals.Problem.weight_mag` on those values).
    sens : ndarray, complex, shape (n, k), optional
        The model form's sensitivities of ``ln H`` on the same values
        (:class:`vlab.diagnose.model.modelform.FrfModelForm`); None: no model form carried.
    sigma : ndarray, shape (k,), optional
        The model form's standard deviations [1].
    force_amplitude : ndarray, shape (n,), optional
        The force amplitude of each value's line [N]; None: no time-domain error (NaN).
    periodic : bool
        Whether the recording was excited periodically (else the time-domain error is NaN: Parseval's
        theorem over whole periods does not apply).

    Returns
    -------
    (misfit, time_error) : (float, float)
        [decades], [1].
    """
    misfit = noise_misfit(target, target_var, weight)
    rel_var = np.asarray(target_var, dtype=float) / np.maximum(np.abs(target) ** 2, 1e-300)
    if sens is not None and sigma is not None and np.size(sigma):
        var_mag = np.sum(sens.real**2 * sigma**2, axis=-1)
        misfit = float(np.hypot(misfit, np.sqrt(np.sum(weight * var_mag) / np.sum(weight)) / np.log(10.0)))
        rel_var = rel_var + np.sum(np.abs(sens) ** 2 * sigma**2, axis=-1)
    if force_amplitude is None or not periodic:
        return misfit, float("nan")
    return misfit, exact_time_error(target, rel_var, force_amplitude)


def exact_phase_misfit(target: np.ndarray, target_var: np.ndarray, weight: np.ndarray, *,
                       sens: np.ndarray | None = None, sigma: np.ndarray | None = None) -> float:
    """Expected :func:`complex_log_misfit` of an exact model against measured FRFs [decades]: magnitude and phase.

    ``E|ln(h / h_true)|^2 = s^2`` for a small circular relative error of variance ``s^2 = var / |h|^2`` (twice
    the log magnitude's share, :func:`noise_misfit`), plus the model form's first-order variance of the complex
    ``ln H``, ``sum_k |d ln H / d theta_k|^2 sigma_k^2`` -- at a resonance mostly phase
    (``d ln H / d ln w_n = j / zeta - 1``), which the log magnitude's share
    (:func:`exact_model_errors`) leaves out.

    Parameters
    ----------
    target, target_var, weight, sens, sigma
        As :func:`exact_model_errors`.

    Returns
    -------
    float
        [decades]
    """
    var = np.asarray(target_var, dtype=float) / np.maximum(np.abs(target) ** 2, 1e-300)
    if sens is not None and sigma is not None and np.size(sigma):
        var = var + np.sum(np.abs(sens) ** 2 * sigma**2, axis=-1)
    w = np.asarray(weight, dtype=float)
    return float(np.sqrt(np.sum(w * var) / np.sum(w)) / np.log(10.0))


def exact_phase_misfit_of(problem, target: np.ndarray, target_var: np.ndarray) -> float:
    """:func:`exact_phase_misfit` of the problem's used lines against ``target`` (shape (n_f, n_o)) and
    ``target_var`` (its variance, same shape) with its weights and model form, as :func:`exact_errors_of`
    [decades]."""
    mask, mf = problem.mask, problem.model_form_frf
    return exact_phase_misfit(target[mask], target_var[mask], problem.weight_mag[mask],
                              sens=None if mf is None else mf.sens[mask], sigma=None if mf is None else mf.sigma)


def exact_errors_of(problem, target: np.ndarray, target_var: np.ndarray) -> tuple[float, float]:
    """:func:`exact_model_errors` of the problem's used lines against ``target`` (shape (n_f, n_o), the FRFs a
    rerun is compared with, and ``target_var`` their variance): with its weights, its model form, its
    data's force amplitudes and excitation. ``problem`` is a :class:`vlab.diagnose.problem.residuals.Problem`
    of FRF data. Returns ``(misfit [decades], time_error [1])``."""
    data, mask, mf = problem.data, problem.mask, problem.model_form_frf
    amp = data.force_amplitude
    return exact_model_errors(
        target[mask], target_var[mask], problem.weight_mag[mask], sens=None if mf is None else mf.sens[mask],
        sigma=None if mf is None else mf.sigma, periodic=data.periodic,
        force_amplitude=None if amp is None else np.broadcast_to(np.asarray(amp)[:, None], mask.shape)[mask])
