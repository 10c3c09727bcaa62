"""Which mode a self-excited oscillation belongs to, and whether a rerun's oscillation is the recording's.

A self-excited oscillation of a lightly damped structure under velocity feedback is a mode driven unstable by
the loop's phase: the root-locus branch that crosses the imaginary axis departs from that mode's open-loop
pole, and for collocated feedback each branch runs between neighbouring open-loop poles and zeros, which
interlace (Preumont, *Vibration Control of Active Structures*, 3rd ed., 2011, Sec. 7.2). Two identities
follow: the **branch** (the two natural frequencies that bracket the oscillation, :func:`branch`) and the
**nearest mode** (:func:`nearest_mode`). A limit cycle's frequency depends on its amplitude and on the
structure's high modes, which no model-form uncertainty of the band covers (the same 8.2 ms delay on one
channel of the BCC oscillated at 43.0 Hz on the converged MuJoCo plant and at 48.2 Hz on the default one,
both between its modes at 36.9 and 50.1 Hz), so the frequency alone does not identify it. Above the measured
band the diagnosis compares the nearest mode, in the band the branch
(:func:`vlab.diagnose.instability_cause.search_cause`).

The recording's structure is not the model. Each natural frequency of the model lies within its model-form
uncertainty ``sigma`` of the structure's (relative, :func:`vlab.diagnose.model.modelform.model_form_uncertainty`:
the calibration residual and the discretisation; above the band the MuJoCo plant's measured discretisation,
which grows from a few tenths of a percent to several percent, ``benchmarks/plant_model_form.py``). So the
recording's identity is a set: every branch (:func:`plausible_branches`) or nearest mode
(:func:`plausible_modes`) it has on some structure whose natural frequencies lie within ``z sigma`` of the
model's, ``z`` the two-sided standard normal quantile at the policy's false-alarm rate
(:attr:`vlab.diagnose.policy.DecisionPolicy.identity_quantile`): a natural frequency lies outside its interval
with probability ``alpha``. A rerun runs on the model itself, so its own identity is exact, and it reproduces
the recording's oscillation when its identity is in the recording's set
(:func:`reproduces_oscillation`).
"""

from __future__ import annotations

import math

import numpy as np

from ...measure.instability import LINE_TO_FLOOR
from ..policy import DEFAULT_POLICY


def branch(frequency_hz: float, natural_hz) -> tuple[float, float]:
    """The two natural frequencies [Hz] of ``natural_hz`` that bracket ``frequency_hz`` (0 or inf past the ends;
    non-finite and non-positive values ignored).

    For collocated feedback each closed-loop root-locus branch runs between neighbouring open-loop poles and
    zeros, which interlace, so the interval between two natural frequencies names the branch (Preumont,
    *Vibration Control of Active Structures*, 3rd ed., 2011, Sec. 7.2)."""
    f = np.asarray(natural_hz, dtype=float).ravel()
    f = np.sort(f[np.isfinite(f) & (f > 0)])
    below, above = f[f <= frequency_hz], f[f > frequency_hz]
    return (float(below[-1]) if below.size else 0.0, float(above[0]) if above.size else math.inf)


def nearest_mode(frequency_hz: float, natural_hz) -> float:
    """The natural frequency [Hz] of ``natural_hz`` nearest ``frequency_hz`` (relative distance; nan if none).

    A self-excited oscillation of a lightly damped structure under velocity feedback is a mode driven
    unstable by the loop's phase: the root-locus branch that crosses the imaginary axis departs from that
    mode's open-loop pole, and the limit cycle lies close to it (Preumont, *Vibration Control of Active
    Structures*, 3rd ed., 2011, Sec. 7.2), so the nearest mode names which one oscillates.

    Parameters
    ----------
    frequency_hz : float
        The oscillation's frequency [Hz], > 0.
    natural_hz : array_like, shape (n,)
        Natural frequencies [Hz]; non-finite and non-positive values are ignored.

    Returns
    -------
    float
        The nearest by relative distance (``|ln(f / frequency_hz)|``) [Hz]; nan when none is left.
    """
    f = np.asarray(natural_hz, dtype=float)
    f = f[np.isfinite(f) & (f > 0)]
    if not f.size:
        return math.nan
    return float(f[np.argmin(np.abs(np.log(f / frequency_hz)))])


def _modes_and_widths(natural_hz, sigma_rel, z: float) -> tuple[np.ndarray, np.ndarray]:
    """The positive finite natural frequencies [Hz], sorted, and the half-widths ``z sigma`` [1] of their
    log-frequency intervals (0 without ``sigma_rel``); raises ValueError when ``sigma_rel`` does not match."""
    f = np.asarray(natural_hz, dtype=float).ravel()
    s = np.zeros_like(f) if sigma_rel is None else np.asarray(sigma_rel, dtype=float).ravel()
    if s.shape != f.shape:
        raise ValueError(f"sigma_rel has {s.size} values for {f.size} natural frequencies")
    keep = np.isfinite(f) & (f > 0)
    f, s = f[keep], np.where(np.isfinite(s[keep]), np.abs(s[keep]), np.inf)
    order = np.argsort(f)
    return f[order], max(float(z), 0.0) * s[order]


def plausible_modes(frequency_hz: float, natural_hz, sigma_rel=None, z: float = 0.0) -> np.ndarray:
    """The natural frequencies [Hz] of ``natural_hz`` that may be nearest to ``frequency_hz`` on a structure
    whose natural frequencies each lie within ``z sigma_rel`` (relative, in log frequency) of the model's.

    Mode ``m`` qualifies when its least possible distance ``max(|ln(f / f_m)| - w_m, 0)`` is at most the
    greatest possible distance ``|ln(f / f_j)| + w_j`` of every other mode (``w = z sigma_rel``): the modes move
    independently, so ``m`` placed at its nearest and the others at their farthest is a possible structure.

    Parameters
    ----------
    frequency_hz : float
        The oscillation's frequency [Hz], > 0.
    natural_hz : array_like, shape (n,)
        The model's natural frequencies [Hz]; non-finite and non-positive values are ignored.
    sigma_rel : array_like, shape (n,), optional
        Relative standard uncertainty of each natural frequency [1] (module notes); None: 0 (the model's
        frequencies exact, and the set is :func:`nearest_mode` alone, ties aside).
    z : float
        Half-width of each interval in standard uncertainties [1] (the policy's ``identity_quantile``).

    Returns
    -------
    ndarray, shape (k,)
        The plausible nearest natural frequencies [Hz], ascending; empty when none is left.

    Raises
    ------
    ValueError
        ``sigma_rel`` of another length than ``natural_hz``.
    """
    f, w = _modes_and_widths(natural_hz, sigma_rel, z)
    if not f.size:
        return f
    d = np.abs(np.log(f / frequency_hz))
    least, most = np.maximum(d - w, 0.0), d + w
    keep = [m for m in range(f.size) if f.size == 1 or least[m] <= np.delete(most, m).min()]
    return f[keep]


def plausible_branches(frequency_hz: float, natural_hz, sigma_rel=None, z: float = 0.0) -> list[tuple[float, float]]:
    """The branches (:func:`branch`, named by the model's natural frequencies [Hz]) on which ``frequency_hz``
    may lie on a structure whose natural frequencies each lie within ``z sigma_rel`` of the model's: the branch
    between ``f_k`` and ``f_k+1`` when ``f_k exp(-w_k) < frequency_hz < f_k+1 exp(w_k+1)``.

    Parameters
    ----------
    frequency_hz, natural_hz, sigma_rel, z
        As :func:`plausible_modes` (without ``sigma_rel`` the set is :func:`branch` alone).

    Returns
    -------
    list of (float, float)
        Each branch's lower and upper natural frequency [Hz] (0 and inf past the ends), ascending.

    Raises
    ------
    ValueError
        ``sigma_rel`` of another length than ``natural_hz``.
    """
    f, w = _modes_and_widths(natural_hz, sigma_rel, z)
    lo = np.concatenate(([0.0], f * np.exp(-w)))
    hi = np.concatenate((f * np.exp(w), [math.inf]))
    ends = np.concatenate(([0.0], f, [math.inf]))
    return [(float(ends[k]), float(ends[k + 1])) for k in range(f.size + 1)
            if lo[k] <= frequency_hz < hi[k]]


def _same_oscillation(f_recorded: float, f_rerun: float, resolution_hz: float, natural_hz, *, tolerance: float,
                      same_mode: bool, sigma_rel, z: float) -> bool:
    """Whether a rerun's line at ``f_rerun`` [Hz] is the recording's at ``f_recorded`` [Hz]: within the relative
    ``tolerance`` (or two spectral lines of ``resolution_hz``), else by identity (module notes)."""
    if abs(f_rerun - f_recorded) <= max(tolerance * f_recorded, 2 * resolution_hz):
        return True
    if natural_hz is None or not np.size(natural_hz):
        return False
    if same_mode:
        return bool(np.isin(nearest_mode(f_rerun, natural_hz), plausible_modes(f_recorded, natural_hz, sigma_rel, z)))
    return branch(f_rerun, natural_hz) in plausible_branches(f_recorded, natural_hz, sigma_rel, z)


def second_oscillation(rerun_check, recorded: dict, natural_hz=None, *,
                       tolerance: float = DEFAULT_POLICY.oscillation_tolerance, same_mode: bool = False,
                       sigma_rel=None, z: float = 0.0) -> float | None:
    """A self-excited line of a rerun that is an oscillation of its own, which the recording would have shown
    and does not: its frequency [Hz], or None.

    A limit cycle is one periodic orbit, whose spectrum is its fundamental and the fundamental's harmonics. A
    rerun line that is neither the rerun's oscillation nor one of its harmonics (``k f0`` within ``2 k``
    spectral lines), nor at a recorded line's frequency (the relative ``tolerance`` or two lines), nor of the
    identity of another recorded oscillation (:func:`reproduces_oscillation`'s criterion against each recorded
    line that is not the recorded oscillation or its harmonic: the recorded oscillation's own identity is the
    rerun's oscillation's, and a rerun oscillating on two of its plausible modes holds two oscillations) is a
    second oscillation. The recording would have shown it where, scaled to the recorded oscillation at the
    same point, it stands :data:`vlab.measure.instability.LINE_TO_FLOOR` above that channel's floor:
    ``(a / a0)^2 l0 >= LINE_TO_FLOOR``, ``a / a0`` the line's amplitude over the rerun's oscillation at that
    point (its largest anywhere, where it has none there), ``l0`` the recorded oscillation's line-to-floor
    ratio there (the detector's own threshold; a point the recorded oscillation does not reach does not judge).

    Parameters
    ----------
    rerun_check : InstabilityCheck
        :func:`vlab.measure.instability.find_instability` of the rerun (unstable).
    recorded : dict
        The recording's :meth:`~vlab.measure.instability.InstabilityCheck.as_dict`: ``frequency_hz`` [Hz],
        ``resolution_hz`` [Hz], ``oscillations`` (``point``, ``frequency_hz`` [Hz], ``line_to_floor`` [1]).
    natural_hz, tolerance, same_mode, sigma_rel, z
        As :func:`reproduces_oscillation`.

    Returns
    -------
    float or None
        The strongest such line's frequency [Hz] (lines in ``rerun_check``'s order, strongest first).

    Raises
    ------
    KeyError
        ``recorded`` without those keys.
    """
    f0, res = rerun_check.frequency_hz, rerun_check.resolution_hz
    lines = list(recorded["oscillations"])
    f_rec, res_rec = float(recorded["frequency_hz"]), float(recorded["resolution_hz"])
    own = {o.point: o.amplitude_m_s for o in rerun_check.oscillations if _harmonic(o.frequency_hz, f0, res) == 1}
    floor_of = {int(y["point"]): float(y["line_to_floor"]) for y in lines
                if _harmonic(float(y["frequency_hz"]), f_rec, res_rec) == 1}
    # other recorded oscillations (not the recorded one, nor its harmonics): matched by identity as well
    others = [float(y["frequency_hz"]) for y in lines if not _harmonic(float(y["frequency_hz"]), f_rec, res_rec)]
    kw = dict(tolerance=tolerance, same_mode=same_mode, sigma_rel=sigma_rel, z=z)
    for o in rerun_check.oscillations:
        f = o.frequency_hz
        if _harmonic(f, f0, res) or any(abs(f - float(y["frequency_hz"])) <= max(tolerance * f, 2 * res)
                                        for y in lines):
            continue
        if any(_same_oscillation(g, f, res, natural_hz, **kw) for g in others):
            continue
        a0 = own.get(o.point) or max(own.values(), default=0.0)  # the rerun's oscillation at that point, else its largest
        l0 = floor_of.get(o.point)
        if a0 and l0 and (o.amplitude_m_s / a0) ** 2 * l0 >= LINE_TO_FLOOR:
            return float(f)
    return None


def _harmonic(f: float, f0: float, resolution_hz: float) -> int:
    """``k`` when ``f`` [Hz] is the ``k``-th harmonic of ``f0`` [Hz] (within ``2 k`` spectral lines of
    ``resolution_hz``), else 0."""
    k = max(round(f / f0), 1)
    return k if abs(f - k * f0) <= 2 * k * resolution_hz else 0


def reproduces_oscillation(frequency_hz: float, rerun_check, natural_hz=None, *,
                           tolerance: float = DEFAULT_POLICY.oscillation_tolerance,
                           same_mode: bool = False, sigma_rel=None, z: float = 0.0,
                           recorded: dict | None = None) -> bool:
    """Whether a rerun oscillates by itself as the recording did (rule 11 of :mod:`vlab.diagnose.fit.rules`).

    Parameters
    ----------
    frequency_hz : float
        The recording's self-excited frequency [Hz].
    rerun_check : InstabilityCheck or None
        :func:`vlab.measure.instability.find_instability` of the candidate's
        validation rerun (None: no rerun, which does not reproduce it). Its oscillation is compared: its
        strongest line at its loop point (``rerun_check.frequency_hz``), the definition of the recording's
        ``frequency_hz``. Its weaker lines count only as a second oscillation the recording lacks
        (``recorded``): a rerun that diverges holds self-excited lines all over the spectrum (one such rerun
        held 70, from 11.6 to 261 Hz), and one of them would match any recorded oscillation.
    natural_hz : array_like, shape (n,), optional
        Natural frequencies [Hz] of the rerun's structure: a rerun whose branch (:func:`branch`) is one the
        recording's oscillation may lie on (:func:`plausible_branches`) counts too.
    same_mode : bool
        Compare the mode that oscillates instead of the branch: a rerun counts when its nearest natural
        frequency (:func:`nearest_mode`) may be the recording's (:func:`plausible_modes`). For an
        oscillation above the measured band, where a mode's frequency may move past its neighbour's
        midpoint (the branch would change) while it stays the nearest mode of its own limit cycle.
    sigma_rel : array_like, shape (n,), optional
        Relative model-form uncertainty of each of ``natural_hz`` [1] (module notes); None: the model's
        natural frequencies taken as the structure's.
    z : float
        Half-width of the natural frequencies' intervals in standard uncertainties [1]
        (:attr:`vlab.diagnose.policy.DecisionPolicy.identity_quantile`).
    recorded : dict, optional
        The recording's instability check (:func:`second_oscillation`): a rerun holding a second
        oscillation that the recording would have shown does not reproduce it. None: not checked.

    Returns
    -------
    bool
        True when the rerun's oscillation lies within the relative ``tolerance`` (the policy's
        ``oscillation_tolerance``) of ``frequency_hz`` (or two of its spectral lines, whichever is
        wider), or its identity (branch, or nearest mode with ``same_mode``) is one the recording's may have,
        and it holds no second oscillation the recording lacks.

    Raises
    ------
    ValueError
        ``sigma_rel`` of another length than ``natural_hz``.
    """
    if rerun_check is None or not rerun_check.unstable:
        return False
    kw = dict(tolerance=tolerance, same_mode=same_mode, sigma_rel=sigma_rel, z=z)
    if not _same_oscillation(frequency_hz, rerun_check.frequency_hz, rerun_check.resolution_hz, natural_hz, **kw):
        return False
    return recorded is None or second_oscillation(rerun_check, recorded, natural_hz, **kw) is None
