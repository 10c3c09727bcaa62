"""The detection threshold of one effect: the smallest size at which the mismatch test fires on its data.

The test of the diagnosis's first rule (:func:`vlab.diagnose.fit.rules.beyond_noise`) is made on the
noise-free FRFs the lab would give with the effect of size ``x``::

    expected chi2(x) = chi2_noise + lambda(x),   lambda(x) = chi2 of the nominal model against the
                                                  noise-free FRFs of the lab with the effect of size x
    detected: expected chi2(x) > chi2 limit      or  the largest noise-free line residual > peak limit

with ``chi2_noise`` what the noise and the model's own small errors contribute, and the limits those of
the diagnosis (:meth:`vlab.diagnose.problem.residuals.Problem.noise_chi2`, ``peak_limit``: the decision
policy's at its false-alarm rate). The threshold is where the expected statistic reaches its limit, found
on a grid of :data:`N_GRID` sizes geometric in the distance from the null value (from :data:`SMALLEST` of
the range to its bound) and refined by bisection: at the threshold a recording is called a mismatch about
half the time; well below it, rarely; well above it, nearly always.

With a model form the test is the diagnosis's own in full: the nominal lab's modes profiled within the
model form (nonlinear), the chi-square and largest line taken after the profile, and the nuisance test
added (its statistic's null mean, the number of profiled parameters, added as ``chi2_noise`` is). That
test is searched from the first-order threshold (linear whitening of the model form) on a ladder of
factors :data:`LADDER`, then bisected. Data referred through a replay carry the referral's second-order
variance as its expected value (:func:`referral_variance`). An effect whose null value lies inside its
range (a gain of 1) gets a threshold on each side.

Source: the diagnosis's own test (rule 1 of :mod:`vlab.diagnose.fit.rules`); the noncentral
chi-square picture of detection, e.g. Kay, *Fundamentals of Statistical Signal Processing*, Vol. II,
Sec. 7.3.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ..errors import VlabError
from .data.measured import FrfData
from .model.labmodel import LabState
from .problem.nuisance import nuisance_test
from .problem.residuals import Problem

#: Sizes tried between an effect's null value and its bound before the bisection.
N_GRID = 24
#: Bisection steps after the grid (the threshold to about 2**-8 of a grid step).
N_BISECT = 8


@dataclass(frozen=True)
class Threshold:
    """The detection threshold of one effect at one location, on one side of its null value.

    Attributes
    ----------
    effect : str
        Library name (``added_mass``, ``loop_delay``, ...).
    location : dict
        Where (``{"point": 6}``, ``{"channel": "all"}``, ...).
    parameter : str
        Parameter name with its SI unit suffix (``mass_kg``).
    null : float or None
        Value at which the effect vanishes [SI] (None: only as a limit, e.g. a rigid joint).
    threshold : float or None
        Smallest departure from ``null`` that the test detects [SI]; None when even the bound of the
        parameter's range is not detected.
    bound : float
        The end of the range searched towards [SI].
    by : str or None
        Which test detects it first: ``"chi2"`` (the total), ``"peak"`` (one line) or, with a model form,
        ``"nuisance"`` (the modes had to move beyond their uncertainty), None if undetected.
    named_at : float or None
        Smallest size [SI] at which the diagnosis names it among its look-alikes (:mod:`vlab.diagnose.naming`);
        None when not computed or not named within the range (see ``look_alike``).
    look_alike : str or None
        The look-alike that comes closest there (or at the largest size tried); None when not computed.
    look_alike_chi2 : float or None
        The chi-square that look-alike leaves [1] (named when >= 10).
    """

    effect: str
    location: dict
    parameter: str
    null: float | None
    threshold: float | None
    bound: float
    by: str | None
    named_at: float | None = None
    look_alike: str | None = None
    look_alike_chi2: float | None = None

    def scaled(self, factor: float) -> float:
        """The parameter value [SI] of ``factor`` times the threshold's effect.

        With a null value, the departure from it is scaled (``null + factor (threshold - null)``); where the
        effect vanishes only in a limit (a rigid joint or support, no lag, no force limit: an infinite
        stiffness, corner or limit), the effect grows as the inverse of the parameter (a compliance, ``f /
        f_c``, a clipped share) and the parameter is divided by ``factor``.

        Raises
        ------
        ValueError
            No threshold (the effect is not detected in its range).
        """
        if self.threshold is None:
            raise ValueError(f"{self.effect} at {self.location}: no threshold to scale")
        if self.null is not None:
            return self.null + factor * (self.threshold - self.null)
        return self.threshold / factor if self.bound < self.threshold else self.threshold * factor

    def as_dict(self) -> dict:
        """JSON-ready dict (the parameter name carries the unit)."""
        return {"effect": self.effect, "location": self.location, "parameter": self.parameter,
                "null": self.null, "threshold": self.threshold, "bound": self.bound, "detected_by": self.by,
                "naming_threshold": self.named_at, "closest_look_alike": self.look_alike,
                "closest_look_alike_chi2": self.look_alike_chi2}


def _path(lo: float, hi: float, log: bool, n: int) -> np.ndarray:
    """``n`` sizes from ``lo`` to ``hi`` (either order), log-spaced when ``log`` and both are positive."""
    if log and lo > 0 and hi > 0:
        return np.geomspace(lo, hi, n)
    return np.linspace(lo, hi, n)


def referral_variance(model_over_base: np.ndarray, h: np.ndarray, h_model: np.ndarray, mf) -> np.ndarray:
    """The relative variance that referring a real recording through the replay plant adds, expected for data ``h``.

    :func:`vlab.diagnose.data.measured.refer_to_model` adds ``(|ln(H_model / H_base)| |ln(H_meas /
    H_base)|)^2`` (model-form error times change, the referral's second-order error). For a real structure
    with the change of ``h`` (data referred to the model: ``h = H_model H_meas / H_base``): ``ln(H_meas /
    H_base) = ln(h / H_model) + e``, ``e`` the structure's own difference from the replay plant, of variance
    ``mf.variance`` (the plant's modes within their model form); its expected square is used.

    Parameters
    ----------
    model_over_base : ndarray, complex, shape (n_f, n_o)
        ``ln(H_model / H_base)``: the model against the replay plant (its own modes, ``FrfModelForm.modes``).
    h, h_model : ndarray, complex, shape (n_f, n_o)
        The data's FRFs (with the effect) and the nominal model's [(m/s)/N].
    mf : FrfModelForm or None
        The model form (None: ``e = 0``).

    Returns
    -------
    ndarray, shape (n_f, n_o)
        Relative variance [1].
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        change = np.abs(np.log(h / h_model)) ** 2 + (0.0 if mf is None else mf.variance)
        out = np.abs(model_over_base) ** 2 * change
    return np.where(np.isfinite(out), out, 0.0)


class DetectionTest:
    """The mismatch test of the nominal recording, applied to the noise-free FRFs of a modified lab.

    With a model form the diagnosis profiles the nominal lab's modes within it (nonlinear,
    :meth:`Problem.nominal_profile`) and also tests how far they had to move (:func:`vlab.diagnose.problem.nuisance.nuisance_test`);
    :meth:`detected` is then that test (``profiled``), and :meth:`detected_first_order` the linear whitening's,
    which is cheap and gives the starting point of the search (:func:`_side`).

    Parameters
    ----------
    problem : Problem
        The mismatch test's problem on the nominal recording (its data, noise, floor and model form).
    nominal : LabState
        The nominal lab.
    ctx : Context
        The nominal lab's scales for the hypotheses.
    chi2_noise : float, optional
        What the noise contributes to the chi-square; default the nominal lab's against the data.
    referral : ndarray, complex, shape (n_f, n_o), optional
        ``ln(H_model / H_base)`` of a referral through a replay plant (:func:`referral_variance`); None: none.
    var0 : ndarray, shape (n_f, n_o), optional
        The recording's own variance under the referral's [((m/s)/N)^2]; default the data's.
    """

    def __init__(self, problem: Problem, nominal: LabState, ctx, chi2_noise: float | None = None,
                 referral: np.ndarray | None = None, var0: np.ndarray | None = None) -> None:
        self.problem, self.nominal, self.ctx = problem, nominal, ctx
        # the replay plant's referral (its second-order term, :func:`referral_variance`) on top of the
        # recording's own variance ``var0``
        self.referral, self.var0 = referral, (problem.data.var if var0 is None else var0)
        self.h_model = None if referral is None else problem.predict(nominal)
        # what the noise (and the model's own small errors) contribute: the nominal lab against the nominal
        # recording, or, on data with an effect, what the fitted effect leaves
        self.chi2_noise = problem.chi2(nominal, test=True) if chi2_noise is None else float(chi2_noise)
        self.limit, self.peak_limit = problem.noise_chi2(), problem.peak_limit()
        mf = problem.model_form_frf
        self.profiled = mf is not None and mf.sigma.size > 0 and isinstance(problem.data, FrfData)
        self.n_profiled = 0
        self._starts: dict = {}  # hypothesis label -> its last profile's optimum (:meth:`detected`)
        if self.profiled:
            from .problem.nuisance import parameters

            pm0 = mf.modes if mf.modes is not None else nominal.point_modes
            self.n_profiled = (len(mf.labels) if pm0 is None
                               else sum(r is not None for _k, r, _j in parameters(mf, pm0)))
            self.nuisance_limit = self.problem.nuisance_limit(self.n_profiled)

    def _expected(self, h, x: float, **kw) -> Problem | None:
        """The problem of the noise-free data of hypothesis ``h`` at size ``x`` (None: cannot be built)."""
        try:
            state = h.apply(self.nominal, np.array([x]), self.ctx)
            expected = replace(self.problem.data, h=self.problem.predict(state))
        except (VlabError, ValueError, np.linalg.LinAlgError):
            return None
        if self.referral is not None:
            expected = replace(expected, var=self.var0 + referral_variance(
                self.referral, expected.h, self.h_model, self.problem.model_form_frf) * np.abs(expected.h) ** 2)
        return Problem(expected, self.nominal, self.ctx, floor=self.problem.floor,
                       model_form_frf=self.problem.model_form_frf, policy=self.problem.policy,
                       line_floor=getattr(self.problem, "line_floor", None), **kw)

    def statistic(self, h, x: float) -> tuple[float, float] | None:
        """Expected chi-square and largest noise-free line residual of hypothesis ``h`` at size ``x`` [SI]
        to first order in the model form (linear whitening; None: the lab cannot be built at that size)."""
        p = self._expected(h, x)
        if p is None:
            return None
        return self.chi2_noise + p.chi2(self.nominal, test=True), p.peak(self.nominal, test=True)

    def detected_first_order(self, h, x: float) -> str | None:
        """``"chi2"``, ``"peak"`` or None for hypothesis ``h`` at size ``x`` [SI], to first order."""
        st = self.statistic(h, x)
        if st is None:
            return None
        return "chi2" if st[0] > self.limit else "peak" if st[1] > self.peak_limit else None

    def forget_start(self, h) -> None:
        """Start the next profile of hypothesis ``h`` from the model as it is (:meth:`detected`)."""
        self._starts.pop(h.label, None)

    def detected(self, h, x: float) -> str | None:
        """``"chi2"``, ``"peak"``, ``"nuisance"`` or None for hypothesis ``h`` at size ``x`` [SI]: the diagnosis's
        own test (rule 1 and, with a model form, the profile and its nuisance tests; the nuisance statistics'
        null means, the number of parameters for their sum and 1 for the largest one's square, added as the
        noise's share is to the chi-square: the noncentral picture of the module notes)."""
        if not self.profiled:
            return self.detected_first_order(h, x)
        # the profile starts where the last one of this hypothesis ended (a nearby size: a few iterations)
        p = self._expected(h, x, profile_nominal=True, profile_start=self._starts.get(h.label))
        if p is None:
            return None
        try:
            chi2, peak, nuis = p.chi2(self.nominal, test=True), p.peak(self.nominal, test=True), nuisance_test(p)
        except (VlabError, ValueError, np.linalg.LinAlgError):
            return None
        self._starts[h.label] = p.nominal_profile()[1]
        if self.chi2_noise + chi2 > self.limit:
            return "chi2"
        if peak > self.peak_limit:
            return "peak"
        if nuis and (self.n_profiled + nuis["nuisance_chi2"] > self.nuisance_limit
                     or 1.0 + nuis["largest_sigmas"] ** 2 > nuis["largest_limit"]):
            return "nuisance"
        return None


#: The search starts this fraction of the way from the null value to the bound (geometric in the distance).
SMALLEST = 1e-7


def _first_detected(detected, h, xs) -> tuple[int, str | None]:
    """Index of the first size of ``xs`` that ``detected(h, x)`` detects (and by which test), or ``(-1, None)``."""
    for i, x in enumerate(xs):
        by = detected(h, float(x))
        if by is not None:
            return i, by
    return -1, None


#: Ratio between the sizes of the profiled test's ladder around the first-order threshold.
LADDER = 1.5
#: Steps of that ladder at most, each way.
LADDER_STEPS = 10
#: Bisection steps of the profiled test between two sizes of its ladder (to about LADDER**(1/32) = 1.3 %: the
#: thresholds ``vlab detectability`` tabulates).
N_BISECT_PROFILED = 5
#: The same for the threshold a diagnosis reports beside a named effect (to about LADDER**(1/8) = 5 %: how far
#: beyond detection the effect lies; each step costs a profile of the nominal lab).
N_BISECT_REPORTED = 3


def _side(test: DetectionTest, h, null: float | None, start: float, end: float, log: bool,
          profiled: bool = True, bisections: int = N_BISECT_PROFILED) -> tuple[float | None, str | None]:
    """Threshold between the null end ``start`` and ``end`` [SI].

    To first order: a grid geometric in the distance from the null value (from :data:`SMALLEST` of the range;
    geometric in the size itself when the null is a limit of a log-scaled parameter), then bisection. With a
    profiled test (a model form): from there a ladder of factors :data:`LADDER` up or down with the
    diagnosis's own test (minutes for the whole library rather than hours), then bisection in the factor.
    """
    if null is None:
        xs = _path(start, end, log, N_GRID)
        to_x = None
    else:
        dist = abs(end - null)
        sign = 1.0 if end >= null else -1.0
        ds = np.geomspace(SMALLEST * dist, dist, N_GRID)
        xs = null + sign * ds

        def to_x(d):
            return null + sign * d
    i, by = _first_detected(test.detected_first_order, h, xs)
    if i < 0:
        thr = None
    elif i == 0:  # detected at the smallest size tried
        thr = float(xs[0])
    else:
        if to_x is None:
            a, b = float(xs[i - 1]), float(xs[i])
            geo = log and a > 0 and b > 0
        else:
            a, b = float(ds[i - 1]), float(ds[i])
            geo = True
        for _ in range(N_BISECT):
            mid = math.sqrt(a * b) if geo else 0.5 * (a + b)
            m_by = test.detected_first_order(h, mid if to_x is None else to_x(mid))
            if m_by is None:
                a = mid
            else:
                b, by = mid, m_by
        thr = b if to_x is None else float(to_x(b))
    if not (profiled and test.profiled):
        return thr, by
    return _profiled_side(test, h, null, start, end, log, thr, bisections)


def _profiled_side(test: DetectionTest, h, null, start: float, end: float, log: bool, first: float | None,
                   bisections: int = N_BISECT_PROFILED):
    """The profiled test's threshold on the side from ``start`` to ``end``, searched from the first-order
    threshold ``first`` (None: at the bound) on a ladder of factors, then bisected in the factor."""
    if first is None:
        first = end
    test.forget_start(h)  # each side's search starts from the model as it is
    if null is not None:
        d1 = abs(first - null)
        sign = 1.0 if end >= null else -1.0

        def at(s: float) -> float:
            return null + sign * d1 * s
    elif log and first > 0 and end > 0:
        up = end > start

        def at(s: float) -> float:
            return first * s if up else first / s
    else:
        def at(s: float) -> float:
            return start + (first - start) * s

    def beyond(x: float) -> bool:  # past the end of the range
        return (x - end) * (end - start) > 0

    def test_at(s: float):
        x = at(s)
        return test.detected(h, end if beyond(x) else x)

    by = test_at(1.0)
    if by is not None:  # detected at the first-order threshold: down the ladder
        hi, lo = 1.0, None
        for k in range(1, LADDER_STEPS + 1):
            s = LADDER**-k
            b = test_at(s)
            if b is None:
                lo = s
                break
            hi, by = s, b
        if lo is None:
            return float(at(hi)), by
    else:
        lo, hi = 1.0, None
        for k in range(1, LADDER_STEPS + 1):
            s = LADDER**k
            prev = at(LADDER ** (k - 1))
            if beyond(prev) or prev == end:  # the end of the range was tried
                break
            by = test_at(s)
            if by is not None:
                hi = s
                break
            lo = s
        if hi is None:
            return None, None
    for _ in range(bisections):
        mid = math.sqrt(lo * hi)
        b = test_at(mid)
        if b is None:
            lo = mid
        else:
            hi, by = mid, b
    x = at(hi)
    return float(end if beyond(x) else x), by


def effect_thresholds(tester: DetectionTest, h, profiled: bool = True,
                      toward: float | None = None, bisections: int = N_BISECT_PROFILED) -> list[Threshold]:
    """The thresholds of the one-parameter hypothesis ``h`` (one per side of its null value); with
    ``profiled=False`` to first order in the model form only (:func:`_side`); with ``toward`` [SI] only on
    the side of that value (both where it is the null value itself).

    Parameters
    ----------
    tester : DetectionTest
        The mismatch test of the nominal recording.
    h : Hypothesis
        A one-parameter hypothesis of the library.
    profiled : bool
        Search with the profiled test where the tester has a model form (else to first order only).
    toward : float, optional
        A size [SI]: only the side of the null value it lies on.
    bisections : int
        Bisection steps of the profiled search (:data:`N_BISECT_PROFILED`, :data:`N_BISECT_REPORTED`).

    Returns
    -------
    list of Threshold
    """
    nominal, ctx = tester.nominal, tester.ctx
    _trials, lower, upper = h.space(nominal, ctx)
    lo, hi, log = float(lower[0]), float(upper[0]), bool(h.log_scale[0])
    null = h.null(nominal, ctx)
    x0 = None if null is None else float(np.asarray(null)[0])
    if x0 is None:  # the effect vanishes only in a limit: start at the end where it is least visible
        st = {v: tester.statistic(h, v) for v in (lo, hi)}
        start = min((lo, hi), key=lambda v: math.inf if st[v] is None else st[v][0])
        sides = [(start, hi if start == lo else lo)]
    elif lo < x0 < hi:
        sides = [(x0, lo), (x0, hi)]
    else:
        sides = [(x0, hi if abs(hi - x0) >= abs(lo - x0) else lo)]
    if toward is not None and x0 is not None:
        sides = [(a, b) for a, b in sides if (toward - x0) * (b - x0) > 0] or sides
    out = []
    for start, end in sides:
        thr, by = _side(tester, h, x0, start, end, log, profiled, bisections)
        out.append(Threshold(h.effect, h.location, h.param_names[0], x0, thr, end, by))
    return out
