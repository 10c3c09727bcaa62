"""Naming thresholds: the smallest size of an effect that the diagnosis names among its look-alikes.

Detecting a change (:mod:`vlab.diagnose.detectability`) is not naming it. The
diagnosis names an effect when its fit beats every other hypothesis of the
library by the decision policy's ``evidence`` in BIC (rule 3 of :mod:`vlab.diagnose.fit.rules`); one-parameter hypotheses
have the same penalty, so the margin is in chi-square. For the noise-free
data the effect of size ``x`` would give (as the detection thresholds use),
the chi-square a look-alike ``o`` leaves is

    gap_o(x) = min_a |v(x) - a d_o|^2,   a >= 0,

with ``v(x)`` the effect's whitened residual change (the diagnosis's weights:
noise, floor and model form, :meth:`vlab.diagnose.problem.residuals.Problem.residual`)
and ``d_o`` the look-alike's at its own detection threshold, each side of its
null value a direction of its own (first order: the look-alike's change grows
along its direction). The effect is named from the first size, on a ladder of
factors :data:`STEP` above its detection threshold, at which every ``gap_o``
reaches the margin and the :data:`N_REFIT` closest look-alikes, refitted
nonlinearly over their whole range (bounded scalar minimisation), leave it too.

What it does not cover: pairs, two-parameter effects (friction), and the
noise's own share of the gap (the expected chi-square of noise-free data, as
for detection). Where first order misses a look-alike that only a large
nonlinear move reaches (a mode shifted past its neighbour), the refit of the
closest ones catches it only when the first order ranks it among them.

Source: the BIC rule of the diagnosis (Schwarz 1978; Kass & Raftery,
"Bayes factors", JASA 90 (1995) 773-795: a difference of 10 is very strong
evidence); the angle between sensitivity directions as the first-order test
of whether two parameters can be told apart: Brun, Reichert & Kuensch,
"Practical identifiability analysis of large environmental simulation
models", Water Resources Research 37 (2001) 1015-1030.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
import scipy.optimize

from ..errors import VlabError
from .problem.residuals import Problem

#: Ratio between the sizes tried above the detection threshold.
STEP = 1.5
#: Sizes tried at most (STEP**12 = 130 times the detection threshold).
MAX_STEPS = 12
#: Look-alikes refitted nonlinearly at each size that passes the first-order test.
N_REFIT = 3


@dataclass(frozen=True)
class Naming:
    """The naming threshold of one effect at one location, on one side of its null value.

    Attributes
    ----------
    threshold : float or None
        Smallest size [SI] at which the effect is named (a size of the ladder, within a factor
        :data:`STEP`); None when no size up to the bound (or :data:`MAX_STEPS` steps) is.
    look_alike : str or None
        The hypothesis that comes closest at that size (or at the largest size tried).
    gap_chi2 : float or None
        The chi-square that look-alike leaves there [1].
    """

    threshold: float | None
    look_alike: str | None
    gap_chi2: float | None


class LookAlikes:
    """The look-alikes of the library as directions: each one's whitened residual change at its detection
    threshold (module notes).

    Parameters
    ----------
    tester : vlab.diagnose.thresholds.DetectionTest
        The mismatch test of the nominal recording (its problem, nominal lab and context).
    hyps : list of Hypothesis
        One-parameter hypotheses that may be look-alikes.
    thresholds : list of Threshold
        Their detection thresholds; a hypothesis without one (or not detected) is left out.

    Attributes
    ----------
    hyps : list of Hypothesis
        The look-alikes kept, one entry per side of a null value.
    matrix : ndarray, shape (n_look_alikes, n_obs)
        Their whitened residual changes [1].
    """

    def __init__(self, tester, hyps: list, thresholds: list) -> None:
        self.tester = tester
        expected = replace(tester.problem.data, h=tester.problem.predict(tester.nominal))
        self.p0 = Problem(expected, tester.nominal, tester.ctx, floor=tester.problem.floor,
                          model_form_frf=tester.problem.model_form_frf, policy=tester.problem.policy,
                          line_floor=getattr(tester.problem, "line_floor", None))
        self.hyps, self.vectors = [], []
        for t in thresholds:
            h = next((x for x in hyps if x.effect == t.effect and x.location == t.location), None)
            if h is None or t.threshold is None:
                continue
            v = self.change(h, t.threshold)
            if v is not None and np.any(v):
                self.hyps.append(h)
                self.vectors.append(v)
        self.matrix = np.array(self.vectors) if self.vectors else np.zeros((0, self.p0.n_obs))
        self.norm2 = np.sum(self.matrix**2, axis=1)

    def change(self, h, x: float) -> np.ndarray | None:
        """Whitened residual change of hypothesis ``h`` at size ``x`` against the nominal prediction."""
        try:
            return self.p0.residual(h.apply(self.tester.nominal, np.array([x]), self.tester.ctx))
        except (VlabError, ValueError, np.linalg.LinAlgError):
            return None

    def gaps(self, v: np.ndarray, exclude: str) -> np.ndarray:
        """First-order chi-square each look-alike leaves on the change ``v`` (inf for ``exclude``)."""
        if not self.hyps:
            return np.zeros(0)
        proj = np.maximum(self.matrix @ v, 0.0)
        g = float(v @ v) - proj**2 / np.maximum(self.norm2, 1e-300)
        return np.where([h.label == exclude for h in self.hyps], np.inf, g)


def _refit(tester, h_o, data_state) -> float:
    """Chi-square look-alike ``h_o`` leaves on the noise-free data of ``data_state`` after a bounded scalar fit."""
    expected = replace(tester.problem.data, h=tester.problem.predict(data_state))
    p = Problem(expected, tester.nominal, tester.ctx, floor=tester.problem.floor,
                model_form_frf=tester.problem.model_form_frf, policy=tester.problem.policy,
                line_floor=getattr(tester.problem, "line_floor", None))
    _trials, lower, upper = h_o.space(tester.nominal, tester.ctx)
    lo, hi, log = float(lower[0]), float(upper[0]), bool(h_o.log_scale[0]) and lower[0] > 0

    def chi2(u: float) -> float:
        x = math.exp(u) if log else u
        try:
            r = p.residual(h_o.apply(tester.nominal, np.array([x]), tester.ctx))
        except (VlabError, ValueError, np.linalg.LinAlgError):
            return math.inf
        return float(r @ r)

    a, b = (math.log(lo), math.log(hi)) if log else (lo, hi)
    grid = np.linspace(a, b, 9)
    vals = [chi2(u) for u in grid]
    i = int(np.argmin(vals))
    sol = scipy.optimize.minimize_scalar(chi2, bounds=(grid[max(i - 1, 0)], grid[min(i + 1, 8)]), method="bounded",
                                         options={"xatol": 1e-4 * (b - a), "maxiter": 30})
    return float(min(min(vals), sol.fun))


def naming_threshold(directions: LookAlikes, h, detection) -> Naming:
    """The naming threshold of hypothesis ``h`` on the side of its detection threshold ``detection``.

    Parameters
    ----------
    directions : LookAlikes
        The look-alikes (all one-parameter hypotheses of the library with a detection threshold).
    h : Hypothesis
        The effect, one parameter.
    detection : Threshold
        Its detection threshold on one side (:mod:`vlab.diagnose.detectability`).

    Returns
    -------
    Naming
        ``Naming(None, None, None)`` when the effect is not detected; errors of a size that cannot be built
        end the ladder (the effect is then not named), none is raised.
    """
    if detection.threshold is None:
        return Naming(None, None, None)
    tester = directions.tester
    last = (None, None)
    for k in range(MAX_STEPS + 1):
        x = detection.scaled(STEP**k)
        beyond = (detection.bound - x) * (detection.bound - detection.threshold) < 0
        if beyond:
            x = detection.bound
        v = directions.change(h, x)
        if v is None:
            break
        gaps = directions.gaps(v, h.label)
        if gaps.size == 0:
            return Naming(float(x), None, None)
        j = int(np.argmin(gaps))
        last = (directions.hyps[j].label, float(gaps[j]))
        if gaps[j] >= tester.problem.policy.evidence:
            state = h.apply(tester.nominal, np.array([x]), tester.ctx)
            order = np.argsort(gaps)[:N_REFIT]
            refits = [(_refit(tester, directions.hyps[i], state), directions.hyps[i].label) for i in order]
            worst = min(refits)
            last = (worst[1], worst[0])
            if worst[0] >= tester.problem.policy.evidence:
                return Naming(float(x), worst[1], worst[0])
        if beyond:
            break
    return Naming(None, last[0], last[1])
