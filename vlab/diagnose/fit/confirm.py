"""Whether a validation rerun confirms a choice: rules 7, 8 and 10 of :mod:`vlab.diagnose.fit.rules`.

A choice made on the linear model is rerun on a plant (:mod:`vlab.diagnose.validate`) and judged there on
the footing of the fit that made it: the reruns' chi-square with the diagnosis's covariance (noise, floor and
the model form's correlated part whitened, ``Validation.chi2_before`` / ``chi2_after``). The choice at size
zero is the nominal lab, so the two reruns are a nested pair and the likelihood-ratio test judges a change
of their chi-square in either direction at the policy's false-alarm rate
(:meth:`vlab.diagnose.policy.DecisionPolicy.needed` with the choice's parameter count and overdispersion):

- **worse** (rule 7, :func:`worsens`): the rerun's chi-square rises by more than the limit;
- **better** (rule 8, :func:`improves_on_nominal`): it falls by more than the limit, as the fit's own did.

The RMS misfits and the time-domain error a rerun also reports carry the model's own uncertainty only as a
mean floor (:func:`vlab.diagnose.problem.misfits.exact_model_errors`); where the floor is concentrated in
one lightly damped mode's frequency, an exact model's squared error is about that floor times a chi-square
with one degree of freedom, beyond its mean with probability 0.32. They decide only where the chi-square
is not available (validations made without it), and the time-domain error also where the chi-square
resolves no improvement: what the FRFs do not show (a transient, a nonlinear rerun's waveform). A
recording that oscillates by itself is judged on its FRF misfit alone: its limit cycle is neither in the
linear covariance nor matched sample by sample.

The remainder (rule 10, :func:`remainder_resolved`) is what a selected choice leaves beyond what an exact
model leaves (the misfit's side of :func:`vlab.diagnose.decision.remainder_of`, which also applies the line
test).

Sources: the likelihood-ratio test (Wilks, Ann. Math. Stat. 9 (1938) 60-62) with overdispersion (Burnham &
Anderson, *Model Selection and Multimodel Inference*, 2nd ed., 2002, Sec. 6.2); misfits of independent parts
adding in quadrature (GUM, JCGM 100:2008, Sec. 5.1).
"""

from __future__ import annotations

import math

import numpy as np

from ..effects.hypotheses import Hypothesis
from ..policy import DEFAULT_POLICY, DecisionPolicy


def chi2_of(v) -> tuple[float, float] | None:
    """The validation's chi-square before and after (``Validation.chi2_before`` / ``chi2_after``), or None
    where it does not carry finite ones."""
    b, a = getattr(v, "chi2_before", np.nan), getattr(v, "chi2_after", np.nan)
    return (float(b), float(a)) if np.isfinite(b) and np.isfinite(a) else None


def worsens(v, *, self_excited: bool = False, k: int = 1, c_hat: float = 1.0,
            policy: DecisionPolicy = DEFAULT_POLICY) -> bool:
    """Whether a validation rerun makes the fit worse (such an effect is never selected): rule 7.

    With the reruns' chi-square (module notes): worse when it rises by more than the likelihood-ratio limit
    of the choice's ``k`` parameters (overdispersion ``c_hat``); better when it falls by more. Without it,
    the FRF misfit must rise beyond the misfit an exact model leaves, in quadrature
    (``after^2 - before^2 > noise^2``, :meth:`~vlab.diagnose.policy.DecisionPolicy.resolved`). The
    time-domain error rises beyond the error an exact model leaves (``noise_time_error``, the same rule;
    any rise where it is NaN) rejects only where the FRFs do not resolve an improvement. NaN errors (no
    overlap) count as neither.

    A recording that oscillates by itself (``self_excited``, the oscillation reproduced by the rerun) is
    judged on its FRF misfit alone.

    Parameters
    ----------
    v : Validation
    self_excited : bool
        The recording and the rerun both oscillate by themselves (rule 11 met).
    k : int
        The choice's parameter count.
    c_hat : float
        The overdispersion of its fit (>= 1).
    policy : DecisionPolicy

    Returns
    -------
    bool
    """
    chi2s = None if self_excited else chi2_of(v)
    if chi2s is not None:
        frf_worse = policy.needed(chi2s[1], chi2s[0], k, c_hat)
        frf_better = policy.needed(chi2s[0], chi2s[1], k, c_hat)
    else:
        frf_worse = DecisionPolicy.resolved(v.misfit_after, v.misfit_before, v.noise_misfit)
        frf_better = DecisionPolicy.resolved(v.misfit_before, v.misfit_after, v.noise_misfit)
    if self_excited:
        return frf_worse
    time_worse = DecisionPolicy.resolved(v.time_error_after, v.time_error_before, v.noise_time_error)
    return frf_worse or (time_worse and not frf_better)


def improves_on_nominal(chosen: Hypothesis, chi2_nominal: float, c_hat: float, validation,
                        policy: DecisionPolicy = DEFAULT_POLICY, *, self_excited: bool = False) -> tuple[bool, str]:
    """Rule 8: whether a choice fits better than the nominal lab on the footing of the mismatch test.

    Parameters
    ----------
    chosen : Hypothesis
        Fitted (``chi2_``, ``n_params``).
    chi2_nominal : float
        The nominal lab's chi-square on the footing of the choice's fit [1] (the same weights, the model
        form whitened): the choice at size zero is the nominal lab, so the two are nested and Wilks's
        likelihood-ratio test applies. (The nominal's *profiled* chi-square is not that footing: its modes
        move freely within their model form, beyond their limit where the model-form test failed, while the
        choice's do not.)
    c_hat : float
        Overdispersion of the choice's fit (>= 1).
    validation : Validation or None
        Its validation rerun (None: none was made). With the reruns' chi-square (module notes) it must fall
        by the same likelihood-ratio limit as the fit's; without it, the FRF misfit must fall -- with the
        phase where the fit used it (``phase_misfit_*``), the footing of the choice's own chi-square.
    policy : DecisionPolicy
    self_excited : bool
        The recording oscillates by itself and the choice's rerun reproduces it: its FRFs hold a limit
        cycle, and neither the linear fit nor the FRF misfit judges it.

    Returns
    -------
    (bool, str)
        Whether it does, and the reason when it does not ("" when it does).
    """
    if self_excited:
        return True, ""
    limit = policy.lr_limit(chosen.n_params, c_hat)
    if not policy.needed(chi2_nominal, chosen.chi2_, chosen.n_params, c_hat):
        return False, (f"its chi-square {chosen.chi2_:.4g} is not below the nominal lab's {chi2_nominal:.4g} by the "
                       f"likelihood-ratio limit {limit:.4g}")
    v = validation
    if v is None:
        return True, ""
    chi2s = chi2_of(v)
    if chi2s is not None:
        if policy.needed(chi2s[0], chi2s[1], chosen.n_params, c_hat):
            return True, ""
        return False, (f"its validation rerun does not lower the chi-square by the likelihood-ratio limit "
                       f"({chi2s[0]:.4g} -> {chi2s[1]:.4g}, limit {limit:.4g})")
    # on the fit's footing: with the phase where the fit used it (a lag turns the phase, hardly the magnitude)
    pb, pa = getattr(v, "phase_misfit_before", np.nan), getattr(v, "phase_misfit_after", np.nan)
    with_phase = bool(np.isfinite(pb) and np.isfinite(pa))
    before, after = (pb, pa) if with_phase else (v.misfit_before, v.misfit_after)
    if not after < before:
        return False, (f"its validation rerun does not lower the FRF misfit{' with phase' if with_phase else ''} "
                       f"({before:.3g} -> {after:.3g} decades)")
    return True, ""


def remainder_resolved(misfit_after: float, noise_misfit: float | None) -> bool:
    """Whether the misfit an explanation leaves is resolved from the misfit an exact model leaves.

    Misfits of independent parts add in quadrature: the remainder's own misfit is
    ``sqrt(after^2 - noise^2)``, resolved when it exceeds ``noise`` itself
    (:meth:`vlab.diagnose.policy.DecisionPolicy.resolved` of ``after`` against ``noise``), i.e. when
    ``after > sqrt(2) noise``.

    Parameters
    ----------
    misfit_after : float
        FRF misfit [decades] of the lab with the chosen effect (validation rerun or linear model).
    noise_misfit : float or None
        The misfit an exact model leaves (same unit): the measured noise, and the model form where it is
        carried. None or not finite: unknown, and nothing is resolved.

    Returns
    -------
    bool
    """
    if noise_misfit is None or not math.isfinite(noise_misfit) or not math.isfinite(misfit_after):
        return False
    return DecisionPolicy.resolved(misfit_after, noise_misfit, noise_misfit)
