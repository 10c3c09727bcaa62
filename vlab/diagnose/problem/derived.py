"""A problem derived from another: the same data and model weighted by the noise and the model form alone.

The weights of :func:`vlab.diagnose.fit.rules.changed_beyond_noise`, which asks whether a recording differs from
its reference beyond the noise where the model-error floor would hide it.
"""

from __future__ import annotations

from ..model.labmodel import LabState
from .residuals import Problem


def without_floor(problem: Problem, nominal: LabState | None = None) -> Problem:
    """``problem`` with no model-error floor (``floor = 0``).

    Parameters
    ----------
    problem : Problem
        Its data, context, phase use and modal sigmas are kept.
    nominal : LabState, optional
        The nominal lab of the new problem (default ``problem.base``).

    Returns
    -------
    Problem
        Residuals weighted by the data's own variance and the model-form variance
        (``1 / (sigma_rel^2 + model_var)`` per line of FRF data), without the numerical floor: the
        weights of :func:`vlab.diagnose.fit.rules.changed_beyond_noise`.
    """
    p = Problem(problem.data, problem.base if nominal is None else nominal, problem.ctx, floor=0.0,
                use_phase=problem.use_phase, freq_sigma=problem.freq_sigma, damping_sigma=problem.damping_sigma,
                shape_sigma=problem.shape_sigma, model_form_frf=getattr(problem, "model_form_frf", None),
                profile_nominal=getattr(problem, "profile_nominal", False), policy=problem.policy)
    p.model_form = problem.model_form
    return p
