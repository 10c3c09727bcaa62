"""The base class of the physics hypotheses and the combination of two.

Estimator habits after scikit-learn (Buitinck et al., 2013): a keyword-only constructor
that fixes *where* the effect is, :func:`vlab.diagnose.fit.estimate.fit_hypothesis` that
estimates *how large* it is (the fit lives there, after the hypotheses, so
that the data flow runs one way), fitted values ending in ``_`` and
:meth:`Hypothesis.score` returning one comparable number (the BIC, lower is
better). Subclasses implement ``_space``, ``_apply`` and optionally
``_null`` and ``_applies`` (:mod:`vlab.diagnose.effects.structural`,
:mod:`vlab.diagnose.effects.beyond_spec`, :mod:`vlab.diagnose.effects.chain`).
"""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np

from ...errors import ModelError
from ..model.labmodel import LabState
from ..problem.context import Context


class Hypothesis:
    """Base class: one physics effect at one location.

    Subclasses set the class attributes (``effect`` to ``moves_modes``) and
    implement :meth:`space` and :meth:`apply`; the fitted attributes (ending
    in ``_``) are set by :func:`vlab.diagnose.fit.estimate.fit_hypothesis`.

    Attributes
    ----------
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
    moves_modes : bool
        True when the effect shifts natural frequencies (mass, stiffness): its
        one parameter is scanned densely before the local fit
        (:func:`vlab.diagnose.fit.estimate.trials_for`).
    in_chain : bool
        True when the effect acts in the hardware chain (delay, lag, gain, amplifier limit), leaving the
        structure as it is.
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
    coarse_ : ndarray, shape (k,)
        Set by :func:`vlab.diagnose.fit.estimate.screen`: the screened value with the
        least smoothed error; ``coarse_error_`` that error.
    """

    effect: ClassVar[str] = ""
    param_names: ClassVar[tuple[str, ...]] = ()
    log_scale: ClassVar[tuple[bool, ...]] = ()
    needs: ClassVar[str] = "any"
    spec_level: ClassVar[bool] = True
    moves_modes: ClassVar[bool] = False
    in_chain: ClassVar[bool] = False
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

    # -- to implement in subclasses: _space, _apply, _null (optional), _applies (optional)
    def space(self, state: LabState, ctx: Context) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Trial values and bounds of the parameters [SI].

        Parameters
        ----------
        state : LabState
            The nominal lab (scales are taken from it).
        ctx : Context
            Scales and signals of the data.

        Returns
        -------
        trials : ndarray, shape (n_trials, k)
        lower, upper : ndarray, shape (k,)
        """
        return self._space(state, ctx)

    def apply(self, state: LabState, x: np.ndarray, ctx: Context) -> LabState:
        """The lab with the effect of size ``x``.

        Parameters
        ----------
        state : LabState
            The lab to modify (not changed).
        x : ndarray, shape (k,)
            Parameter values [SI].
        ctx : Context
            Scales and signals of the data.

        Returns
        -------
        LabState

        Raises
        ------
        ModelError, SpecError
            If the modified lab cannot be built.
        """
        return self._apply(state, np.asarray(x, dtype=float), ctx)

    def null(self, state: LabState, ctx: Context) -> np.ndarray | None:
        """Parameter values [SI] at which the effect vanishes (None if only as a limit, e.g. a rigid support).

        Parameters
        ----------
        state : LabState
            The nominal lab.
        ctx : Context
            Scales and signals of the data.
        """
        return self._null(state, ctx)

    def applies_to(self, ctx: Context) -> bool:
        """Whether the effect can show in data of this kind (open/closed loop, time histories).

        Parameters
        ----------
        ctx : Context
            Scales and signals of the data.
        """
        return self._applies(ctx)

    def _space(self, state, ctx):
        raise NotImplementedError

    def _apply(self, state, x, ctx):
        raise NotImplementedError

    def _null(self, state, ctx):
        return None

    def _applies(self, ctx) -> bool:
        if self.needs == "closed":
            return ctx.closed_loop
        if self.needs == "signals":
            return ctx.has_signals
        return True

    # -- estimator interface
    def score(self, problem=None) -> float:
        """The Bayesian information criterion of the fit (lower is better).

        Parameters
        ----------
        problem : vlab.diagnose.problem.residuals.Problem, optional
            Score the fitted parameters on this problem instead of the one fitted.

        Raises
        ------
        ModelError
            If the hypothesis has not been fitted.
        """
        if not hasattr(self, "bic_"):
            raise ModelError(f"{self.label}: fit it (vlab.diagnose.fit.estimate.fit_hypothesis) before score()")
        if problem is None:
            return float(self.bic_)
        chi2 = problem.chi2(problem.fitted_state(self))
        return float(chi2 + self.n_params * math.log(problem.n_obs))

    def parameters_dict(self) -> dict:
        """Fitted parameters ``{name: value}`` [SI]."""
        return {n: float(v) for n, v in zip(self.param_names, self.params_)}

    def ci95_dict(self) -> dict:
        """Confidence intervals ``{name: [low, high]}`` [SI]."""
        return {n: [float(a), float(b)] for n, (a, b) in zip(self.param_names, self.ci95_)}


def _log_trials(ref: float, factors) -> np.ndarray:
    return np.array([[ref * f] for f in factors])


class _AtPoint(Hypothesis):
    """A hypothesis at one point (``point=``)."""

    def __init__(self, *, point: int):
        self.point = point

    @property
    def location(self) -> dict:
        return {"point": self.point}


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

    def split(self, x: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """The values of the first and the second part in a parameter vector of the pair.

        Parameters
        ----------
        x : ndarray, shape (n_params,), optional
            Parameters [SI], the first part's then the second's (default: the fitted ``params_``).

        Returns
        -------
        first : ndarray, shape (k1,)
        second : ndarray, shape (k2,)
            Copies [SI].

        Raises
        ------
        AttributeError
            ``x`` not given and the pair not fitted.
        """
        x = np.asarray(self.params_ if x is None else x, dtype=float)
        k = self.parts[0].n_params
        return x[:k].copy(), x[k:].copy()

    def _space(self, state, ctx):
        t1, l1, u1 = self.parts[0].space(state, ctx)
        t2, l2, u2 = self.parts[1].space(state, ctx)
        trials = np.array([np.concatenate([a, b]) for a in t1 for b in t2])
        return trials, np.concatenate([l1, l2]), np.concatenate([u1, u2])

    def _apply(self, state, x, ctx):
        a, b = self.split(x)
        (h1, x1), (h2, x2) = sorted(((self.parts[0], a), (self.parts[1], b)), key=lambda t: t[0].stage)
        return h2.apply(h1.apply(state, x1, ctx), x2, ctx)

    def _null(self, state, ctx):
        n1, n2 = self.parts[0].null(state, ctx), self.parts[1].null(state, ctx)
        return None if n1 is None or n2 is None else np.concatenate([n1, n2])
