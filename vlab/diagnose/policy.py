"""The decision policy of the diagnosis: every threshold it decides by, in one object, derived from one rate.

The user states a false-alarm rate ``alpha``: the probability that a recording of the nominal structure
(within the measurement's noise and the model's stated uncertainty) is reported as a mismatch. Every limit
of the diagnosis follows from it:

* **Is there a mismatch?** Four tests look at the same residuals, weighted by one covariance (noise +
  model-error floor + model form): the total chi-square, the largest single line (a local mismatch), the
  moves of the nominal lab's modes beyond their model-form uncertainty (the profiled nuisance parameters,
  all together) and the largest of those moves (one mode's damping ratio five times the model's moves one
  parameter by eleven standard uncertainties, which adds 135 to a sum of some seventy moves whose limit is
  near 200: the sum alone has little power against one large move, as the total chi-square against one
  line). Each runs at the Šidák rate ``1 - (1 - alpha)^(1/4)``, so that the four together keep ``alpha``;
  the largest of ``n`` lines (or moves) runs at ``1 - (1 - a)^(1/n)`` of its test's rate ``a`` (Šidák,
  J. Am. Stat. Assoc. 62 (1967) 626-633). A self-excited oscillation that the nominal replay does not make is a mismatch too
  (:func:`vlab.diagnose.decision.mismatch_tests`); its detector's false-alarm probability on noise is below
  1e-30 (:mod:`vlab.measure.instability`), so it takes no measurable share of ``alpha``.
* **A noise variance estimated from the data** (``nu`` degrees of freedom, the periods' scatter) makes each
  weighted residual heavier-tailed than a normal one: a squared residual of ``d`` real components over an
  estimated variance follows ``d F(d, nu)`` (Student's argument; Johnson, Kotz & Balakrishnan,
  *Continuous Univariate Distributions* vol. 2, 2nd ed., 1995, Ch. 27). The line limit uses that law. The
  total chi-square sums groups of ``g`` residuals that share one variance estimate (a running pool of
  lines), each group ``g F(g, nu)``; its limit is the quantile of the scaled chi-square with the sum's mean
  and variance (Satterthwaite, Biometrics Bull. 2 (1946) 110-114):
  ``M = n nu / (nu - 2)``, ``V = 2 n nu^2 (g + nu - 2) / ((nu - 2)^2 (nu - 4))``, limit ``= (V / 2M)
  chi2.isf(a, 2 M^2 / V)``. The ``k`` profiled parameters' statistic is bounded the same way by
  ``k F(k, nu)`` (every weight off by one common factor, the worst case). Treating a pool's lines as fully
  sharing their estimate, and the weights' model-form and floor parts as estimated too, errs on the side of
  fewer false alarms; without an estimated variance (``nu`` None) the laws are chi-square.
* **Is an effect better than nothing, a pair better than its better part?** A nested likelihood-ratio test
  (Wilks, Ann. Math. Stat. 9 (1938) 60-62) at the rate ``alpha``: the fall of the chi-square, divided by
  the overdispersion ``c_hat`` of the larger model (Burnham & Anderson, *Model Selection and Multimodel
  Inference*, 2nd ed., 2002, Sec. 6.2), must exceed the ``1 - alpha`` quantile of chi-square with as many
  degrees of freedom as parameters were added; and its quasi-BIC evidence must reach :attr:`evidence`
  ("very strong" on the Kass-Raftery scale of ``2 ln B``, Kass & Raftery, J. Am. Stat. Assoc. 90 (1995)
  773-795), which also orders the candidates.
* **What does a validation resolve?** Misfits of independent parts add in quadrature: a rerun that raises
  the FRF misfit from ``before`` to ``after`` makes the fit worse when ``after^2 - before^2`` exceeds the
  square of the misfit an exact model leaves (the noise and the model form), and what a choice leaves is a
  remainder when ``after^2 - noise^2`` exceeds ``noise^2`` (:meth:`DecisionPolicy.resolved`). The same rule
  on the time-domain error of reruns decides whether a pair with a nonlinear part beats its better part
  alone; on a plant other than the recording's no resolution is known and the simpler model is kept.
* **Is a second effect the explanation of what the first leaves?** The definition by which one effect is
  *the* explanation of a mismatch (it removes the larger part, :attr:`DecisionPolicy.explained_share`, of
  the chi-square) applied to the remainder: a pair replaces its better part only if its second effect
  removes that share of the single effect's chi-square (or brings the data within the noise); a second
  effect that removes less absorbs a part of the remainder, which is reported instead.

Numbers without a statistical principle (yet) are stated as such in their attribute's text.

Source of the heavier tail of an estimated variance: the F distribution of a normal sum of squares over an
independent chi-square one (Johnson, Kotz & Balakrishnan 1995, Ch. 27, its moments Eqs. 27.7-27.8).
"""

from __future__ import annotations

import functools
import math
from dataclasses import asdict, dataclass

import scipy.stats

from ..errors import OptionError

#: Number of mismatch tests that share the false-alarm rate (total chi-square, largest line, the mode moves
#: together, the largest mode move).
MISMATCH_TESTS = 4


@dataclass(frozen=True)
class DecisionPolicy:
    """Every threshold of the diagnosis (see the module text for the principles).

    Attributes
    ----------
    false_alarm_rate : float
        ``alpha`` in (0, 0.5): the probability of reporting a mismatch on data of the nominal structure
        [1]. Default 0.01.
    evidence : float
        Smallest quasi-BIC difference [1] for one candidate to be preferred to another (10: "very
        strong", Kass & Raftery 1995); the candidates within it of the choice are its look-alikes.
    explained_share : float
        Share of the nominal chi-square [1] an effect must remove to be reported as *the* explanation (a
        definition: the larger part of the mismatch), unless it brings the data within the noise; the same
        share of what a single effect leaves for a pair's second effect to replace it.
    oscillation_tolerance : float
        Relative frequency tolerance [1] within which a rerun's self-excited line is the recording's
        (a limit cycle's frequency depends on its amplitude). No statistical principle: a stated
        tolerance; a rerun on the same branch (between the same two natural frequencies) counts too.
    """

    false_alarm_rate: float = 0.01
    evidence: float = 10.0
    explained_share: float = 0.5
    oscillation_tolerance: float = 0.02

    def __post_init__(self) -> None:
        if not (0.0 < self.false_alarm_rate < 0.5) or not math.isfinite(self.false_alarm_rate):
            raise OptionError(f"false-alarm rate {self.false_alarm_rate!r} must lie in (0, 0.5)")

    @property
    def identity_quantile(self) -> float:
        """``z`` [1]: the two-sided standard normal quantile at the false-alarm rate, the half-width (in standard
        uncertainties) of the interval within which a structure's natural frequency lies around its model's
        but with probability ``alpha`` (the identity of an oscillation, :mod:`vlab.diagnose.fit.identity`)."""
        return float(scipy.stats.norm.isf(0.5 * self.false_alarm_rate))

    @property
    def test_rate(self) -> float:
        """Rate of each of the :data:`MISMATCH_TESTS` mismatch tests [1] (Šidák)."""
        return 1.0 - (1.0 - self.false_alarm_rate) ** (1.0 / MISMATCH_TESTS)

    def chi2_limit(self, n: int, nu: float | None = None, shared: int = 1) -> float:
        """Largest total chi-square of ``n`` real residuals under the null [1].

        ``nu`` None: the variances are known, ``chi2.isf(a, n)``. Else each weight's noise variance was
        estimated with ``nu`` (> 4) degrees of freedom, one estimate shared by ``shared`` residuals: the
        Satterthwaite quantile of the sum of ``n / shared`` groups ``g F(g, nu)`` (module text). Raises
        ValueError for ``nu`` <= 4 (the sum's variance is infinite: :meth:`chi2_limit_simulated`)."""
        n = max(int(n), 1)
        if nu is None or not math.isfinite(nu):
            return float(scipy.stats.chi2.isf(self.test_rate, n))
        if nu <= 4:
            raise ValueError(f"chi2_limit needs nu > 4 degrees of freedom of the variance, got {nu!r}")
        g = max(int(shared), 1)
        mean = n * nu / (nu - 2.0)
        var = 2.0 * n * nu**2 * (g + nu - 2.0) / ((nu - 2.0) ** 2 * (nu - 4.0))
        return float(var / (2.0 * mean) * scipy.stats.chi2.isf(self.test_rate, 2.0 * mean**2 / var))

    def chi2_limit_simulated(self, n: int, nu: float, shared: int = 1, *, draws: int = 20000,
                             seed: int = 0) -> float:
        """:meth:`chi2_limit` for any ``nu`` > 0 by simulation [1].

        The ``1 - a`` quantile of the sum of ``round(n / shared)`` groups ``g F(g, nu)`` (``g = n / groups``;
        the law of the module text), for ``nu`` <= 4, where the sum's variance is infinite and the
        Satterthwaite form does not apply (a band of a few lines). Cached.

        Parameters
        ----------
        n : int
            Number of real residuals.
        nu : float
            Degrees of freedom of the estimated noise variance, > 0.
        shared : int
            Residuals sharing one variance estimate.
        draws : int
            Number of simulated sums.
        seed : int
            Seed of the generator: the same limit every run.

        Returns
        -------
        float
            The limit of the total chi-square [1].
        """
        return _sum_of_f_quantile(self.test_rate, max(int(n), 1), float(nu), max(int(shared), 1), draws, seed)

    def line_limit(self, n_lines: int, dof: int, nu: float | None = None) -> float:
        """Largest squared residual of one of ``n_lines`` lines, each with ``dof`` (1 or 2) degrees of
        freedom, under the null [1]; ``nu``: the degrees of freedom of an estimated noise variance (the
        residual then follows ``dof F(dof, nu)``, whose tail is heavier). Šidák over the lines."""
        p = 1.0 - (1.0 - self.test_rate) ** (1.0 / max(int(n_lines), 1))
        if nu:
            return float(dof * scipy.stats.f.isf(p, dof, nu))
        return float(scipy.stats.chi2.isf(p, dof))

    def nuisance_limit(self, k: int, nu: float | None = None) -> float:
        """Largest ``|x|^2`` of ``k`` profiled model-form parameters under the null [1]: chi-square with ``k``
        degrees of freedom (standard normal parameters), ``k F(k, nu)`` when the weights' noise variance was
        estimated with ``nu`` degrees of freedom (module text)."""
        k = max(int(k), 1)
        if nu:
            return float(k * scipy.stats.f.isf(self.test_rate, k, nu))
        return float(scipy.stats.chi2.isf(self.test_rate, k))

    def move_limit(self, k: int, nu: float | None = None) -> float:
        """Largest ``x_j^2`` of one of ``k`` profiled model-form parameters under the null [1]: each standard
        normal, chi-square with 1 degree of freedom (``F(1, nu)`` when the weights' noise variance was estimated
        with ``nu`` degrees of freedom); Šidák over the ``k``."""
        p = 1.0 - (1.0 - self.test_rate) ** (1.0 / max(int(k), 1))
        if nu:
            return float(scipy.stats.f.isf(p, 1, nu))
        return float(scipy.stats.chi2.isf(p, 1))

    def lr_limit(self, k_added: int, c_hat: float = 1.0) -> float:
        """Smallest fall of the chi-square [1] that ``k_added`` more parameters must give to be needed:
        ``c_hat * chi2.isf(alpha, k_added)`` (Wilks; overdispersion ``c_hat`` >= 1)."""
        return float(max(c_hat, 1.0) * scipy.stats.chi2.isf(self.false_alarm_rate, max(int(k_added), 1)))

    def needed(self, chi2_without: float, chi2_with: float, k_added: int, c_hat: float = 1.0) -> bool:
        """Whether ``k_added`` parameters that lower the chi-square from ``chi2_without`` to ``chi2_with``
        are needed (:meth:`lr_limit`, with the overdispersion ``c_hat``)."""
        return bool(chi2_without - chi2_with > self.lr_limit(k_added, c_hat))

    def separable(self, distance_chi2: float, c_hat: float = 1.0) -> bool:
        """Whether two fitted hypotheses whose predictions lie ``distance_chi2`` apart [1] (the chi-square of
        one's prediction taken as the other's data, on the fits' footing) can be told apart by data of this
        noise and model accuracy: the distance exceeds :meth:`lr_limit` of one parameter. If one were true,
        the other's excess chi-square would be at most a noncentral chi-square of one degree of freedom and
        noncentrality ``distance_chi2`` (its fit can move towards the data), which reaches that limit about
        half the time at most when the distance is below it: a test at the false-alarm rate has no better
        than even power (the power argument of a detection threshold; Kay, *Fundamentals of Statistical
        Signal Processing*, Vol. II, Sec. 7.3). ``c_hat``: the overdispersion [1] that scales the limit."""
        return bool(math.isfinite(distance_chi2) and distance_chi2 > self.lr_limit(1, c_hat))

    @staticmethod
    def resolved(before: float, after: float, noise: float | None) -> bool:
        """Whether a validation resolves a fall of the FRF misfit from ``before`` to ``after`` [decades],
        given the misfit ``noise`` an exact model leaves (quadrature: ``before^2 - after^2 > noise^2``).
        Without a finite ``noise``, any fall counts."""
        if not (math.isfinite(before) and math.isfinite(after)):
            return False
        tol = noise**2 if noise is not None and math.isfinite(noise) else 0.0
        return bool(before**2 - after**2 > tol)

    def as_dict(self) -> dict:
        """The policy's numbers for the JSON report (all dimensionless), with the per-test rate."""
        return {**asdict(self), "mismatch_test_rate": self.test_rate}


@functools.lru_cache(maxsize=64)
def _sum_of_f_quantile(rate: float, n: int, nu: float, shared: int, draws: int, seed: int) -> float:
    """The ``1 - rate`` quantile of the sum of ``round(n / shared)`` groups ``g F(g, nu)``, ``g`` = n / groups,
    from ``draws`` seeded sums (:meth:`DecisionPolicy.chi2_limit_simulated`)."""
    import numpy as np

    groups = max(int(round(n / shared)), 1)
    g = n / groups
    rng = np.random.default_rng(seed)
    sums = np.zeros(draws)
    for _ in range(groups):  # one group at a time: memory of one draw per sum
        sums += g * rng.f(g, nu, size=draws)
    return float(np.quantile(sums, 1.0 - rate))


#: The default policy (``vlab diagnose`` without ``--false-alarm-rate``).
DEFAULT_POLICY = DecisionPolicy()
