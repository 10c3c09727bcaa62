"""Resonances a model lacks: the measured FRFs' peaks paired with a model's, all channels pooled.

A new resonance (a tuned absorber's, a mode split by a local change) is physics outside the library of
effects, which change masses, stiffnesses, damping and the chain but add no degree of freedom; the decision
asks whether the chosen lab still lacks a measured resonance (:mod:`vlab.diagnose.decision`).
"""

from __future__ import annotations

import numpy as np

from ...errors import MeasurementError
from ...measure.modal import find_peaks

#: A measured peak and a model peak farther apart than this (relative frequency) are not the same resonance.
PEAK_MATCH = 0.10
#: Peaks of one model's channels within this of a stronger one (relative frequency) are that resonance.
SAME_RESONANCE = 0.02


def _resonances(peaks: list[tuple[float, float, int]]) -> list[tuple[float, float, int]]:
    """One entry per resonance from peaks ``(f [Hz], level, point)`` of several channels: peaks within
    :data:`SAME_RESONANCE` of a stronger one are that one's, seen at another channel."""
    out: list[tuple[float, float, int]] = []
    for pk in sorted(peaks, key=lambda x: -x[1]):
        if all(abs(pk[0] / o[0] - 1) > SAME_RESONANCE for o in out):
            out.append(pk)
    return sorted(out)


def stands_out(h: np.ndarray, var: np.ndarray, index: int, limit: float) -> bool:
    """Whether the peak of ``|h|`` (shape (n_f,)) at line ``index`` stands out of the noise: the rise of its
    magnitude above the higher of its two bases (:func:`scipy.signal.peak_prominences`), squared and divided by
    that rise's variance, exceeds ``limit`` [1]. With circular complex noise of variance ``var`` (shape
    (n_f,), ``E|h - h_true|^2``) the magnitude's variance is ``var / 2`` where ``|h|`` is well above the noise
    (Bendat & Piersol, *Random Data*, 4th ed., 2010, Sec. 9.2.2), so the rise's is the sum of its two lines'
    halves. A peak the noise could make (the leakage of an oscillation outside the band scatters an FRF from
    period to period) is no resonance however prominent in decibels."""
    from scipy.signal import peak_prominences

    mag = np.abs(h)
    _prom, left, right = peak_prominences(20 * np.log10(np.maximum(mag, 1e-300)), [index])
    base = int(left[0]) if mag[left[0]] >= mag[right[0]] else int(right[0])
    rise = mag[index] - mag[base]
    return bool(rise**2 > limit * 0.5 * (var[index] + var[base]))


def _peaks(freq_hz: np.ndarray, h: np.ndarray, output_points, prominence_db: float,
           var: np.ndarray | None = None, limit: float | None = None) -> list:
    """``(f [Hz], level [(m/s)/N], point)`` of every channel's peaks of ``h`` (shape (n_f, n_o)) with at least
    ``prominence_db`` prominence and, given the variance ``var`` (shape of ``h``) and a ``limit``, standing out
    of the noise (:func:`stands_out`); a channel without any is skipped."""
    out = []
    for j, p in enumerate(output_points):
        try:
            pks = find_peaks(freq_hz, h[:, j], prominence_db=prominence_db, name=f"vel{p}")
        except MeasurementError:
            continue
        if var is not None and limit is not None:
            pks = [x for x in pks if stands_out(h[:, j], var[:, j], x.index, limit)]
        out += [(float(x.freq_hz), float(np.abs(h[np.argmin(np.abs(freq_hz - x.freq_hz)), j])), int(p)) for x in pks]
    return out


def _misplaced(fm: np.ndarray, fn: np.ndarray, pairs: dict[int, int]) -> list[int]:
    """The measured resonances left unpaired (indices into ``fm``) that a spare model resonance stands for:
    one the model has between the same paired neighbours, at another frequency. The library's effects add no
    degree of freedom, so a measured resonance is one the model lacks only when the measurement has more
    resonances than the model between two resonances both share; fewer or as many, and it is one of the
    model's, misplaced (the parameter that places it is off, or the plants differ there). Paired in order
    of frequency within each such interval."""
    spare = sorted(set(range(fn.size)) - set(pairs.values()))
    out = []
    for i in sorted(set(range(fm.size)) - set(pairs), key=lambda k: fm[k]):
        below = [pairs[k] for k in pairs if fm[k] < fm[i]]
        above = [pairs[k] for k in pairs if fm[k] > fm[i]]
        lo = fn[max(below, key=lambda c: fn[c])] if below else 0.0
        hi = fn[min(above, key=lambda c: fn[c])] if above else np.inf
        inside = [c for c in spare if lo < fn[c] < hi]
        if inside:
            spare.remove(inside[0])
            out.append(i)
    return out


def _assigned(fm: np.ndarray, fn: np.ndarray) -> dict[int, int]:
    """Measured peaks ``fm`` paired one to one with model peaks ``fn`` [Hz] by least relative frequency
    distance (Hungarian assignment), pairs farther apart than :data:`PEAK_MATCH` dropped: index in ``fm`` ->
    index in ``fn``."""
    from scipy.optimize import linear_sum_assignment

    if not (fm.size and fn.size):
        return {}
    cost = np.abs(np.log(fm[:, None] / fn[None, :]))
    gate = np.log1p(PEAK_MATCH)
    # gated: a pair beyond the match costs more than all pairs within it together (n pairs at most, each
    # <= gate), so the assignment first maximises the number of true pairs and never trades a close pair for
    # two distant ones (21.95 Hz with 18.65 and 24.7 with 22.0 cost less in all than 21.95 with 22.0 and 24.7
    # with 18.65)
    rows, cols = linear_sum_assignment(np.where(cost <= gate, cost, gate * (min(fm.size, fn.size) + 1)))
    return {int(r): int(c) for r, c in zip(rows, cols) if cost[r, c] <= gate}


def _lacking(fm: np.ndarray, fn: np.ndarray, *, counted: bool) -> np.ndarray:
    """The measured peaks ``fm`` [Hz] without a partner among ``fn`` [Hz]: not paired (:func:`_assigned`)
    and, with ``counted`` (all of a structure's resonances at hand), not a misplaced one of the model's
    (:func:`_misplaced`)."""
    pairs = _assigned(fm, fn)
    paired = set(pairs) | (set(_misplaced(fm, fn, pairs)) if counted else set())
    return np.array([f for i, f in enumerate(fm) if i not in paired])


def unpaired_peaks(freq_hz: np.ndarray, meas: np.ndarray, model: np.ndarray, output_points, *,
                   prominence_db: float = 6.0, var: np.ndarray | None = None,
                   limit: float | None = None) -> list[dict]:
    """Resonances of the measured FRFs that the model's FRFs on the same lines do not have.

    The measured peaks have at least ``prominence_db`` prominence (:func:`vlab.measure.modal.find_peaks`:
    what a resonance must stand out by to count as one), the model's are its local maxima at any prominence
    (the question is whether the model has that resonance, not whether it stands out as much there; a
    threshold on both sides splits a resonance whose prominence straddles it, 6.03 dB measured and 5.97 dB
    in a rerun). A measured peak is a resonance the model lacks when it has no partner twice:

    1. **on its channel**, where the neighbouring modes' terms move the two peaks alike (close modes and an
       absorber put one resonance at 8.44 Hz at point 9 and near 8.7 Hz elsewhere);
    2. **on the structure**: a resonance is a pole of the whole structure, which every channel shows but one
       near its node (its modal constant there is small, Ewins, *Modal Testing*, 2nd ed., 2000, Sec. 2.6),
       and two models whose shapes differ a little put a local mode's node at different channels (a joint's
       mode at 19.7 Hz at point 7 on a converged BCC plant, at 18.3 Hz at point 6 on the default one): the
       peaks of all channels pooled into resonances (peaks within :data:`SAME_RESONANCE` of a stronger one
       are that one, seen at another channel).

    Partners: one to one by least relative frequency distance (:func:`_assigned`; farther apart than
    :data:`PEAK_MATCH` no pair), and on the structure also a spare model resonance between the same paired
    neighbours (:func:`_misplaced`: misplaced, not missing; on one channel a resonance near its node is not
    seen, so counts there mean nothing: a channel that misses the 9.5 Hz mode would take an absorber's
    12.6 Hz resonance for it). A peak within :data:`PEAK_MATCH` of the first or last line
    may have its partner beyond them and is not judged. Each resonance is reported once, at the channel where
    it is strongest, with its half-power damping ratio there.

    Parameters
    ----------
    freq_hz : ndarray, shape (n_f,)
        The lines [Hz].
    meas, model : ndarray, complex, shape (n_f, n_o)
        Measured and model FRFs [(m/s)/N].
    output_points : sequence of int, length n_o
        The channels' points.
    prominence_db : float
        Smallest prominence [dB] of a measured peak.
    var : ndarray, shape (n_f, n_o), optional
        The variance of ``meas`` [((m/s)/N)^2]; with ``limit``, a measured peak must also stand out of the
        noise (:func:`stands_out`).
    limit : float, optional
        The squared standardised rise [1] a measured peak must exceed (a line limit of the decision policy,
        :meth:`vlab.diagnose.policy.DecisionPolicy.line_limit`).

    Returns
    -------
    list of dict
        ``frequency_hz``, ``damping_ratio`` [-] (NaN where the half-power points are not both in the band),
        ``point`` (the channel), ``level`` (its peak magnitude [(m/s)/N]); sorted by frequency.
    """
    from ...measure.modal import half_power_damping

    pts = list(output_points)
    peaks_m, peaks_n = _peaks(freq_hz, meas, pts, prominence_db, var, limit), _peaks(freq_hz, model, pts, 0.0)
    on_structure = _lacking(np.array([r[0] for r in _resonances(peaks_m)]),
                            np.array([r[0] for r in _resonances(peaks_n)]), counted=True)
    found = []
    for p in pts:
        fm = np.array([f for f, _l, q in peaks_m if q == p])
        for f0 in _lacking(fm, np.array([f for f, _l, q in peaks_n if q == p]), counted=False):
            judged = f0 / (1 + PEAK_MATCH) >= np.min(freq_hz) and f0 * (1 + PEAK_MATCH) <= np.max(freq_hz)
            if judged and np.any(np.abs(on_structure / f0 - 1) <= SAME_RESONANCE):
                found.append(next(pk for pk in peaks_m if pk[2] == p and pk[0] == f0))
    out = []
    for f0, level, p in _resonances(found):
        try:
            zeta = half_power_damping(freq_hz, meas[:, pts.index(p)], f0)
        except MeasurementError:
            zeta = float("nan")
        out.append({"frequency_hz": f0, "damping_ratio": float(zeta), "point": p, "level": level})
    return out
