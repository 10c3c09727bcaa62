"""FRFs of a transient excitation -- impact hammer or burst random -- by H1 over one record per event.

An impact test strikes the structure several times, a burst test drives it
with short bursts of random force, each followed by silence while the
response decays. Each event gives one record: it starts a short pre-trigger
before the force first exceeds a trigger level and lasts ``1 / resolution``
seconds. The records are analysed as they are (no window on the response,
the transient being whole within the record); the force is windowed by a
*force window* that keeps the pulse (or burst) and sets the rest of the
record -- where the force channel holds only its noise -- to zero:

``H1 = sum_e conj(F_e) Y_e / sum_e |F_e|^2``,
``gamma^2 = |sum_e conj(F_e) Y_e|^2 / (sum_e |F_e|^2 sum_e |Y_e|^2)``,

the noise of ``H1`` from the coherence as for random excitation,
``var(H) / |H|^2 = (1 - gamma^2) / (2 n_e gamma^2)`` (Bendat & Piersol,
*Random Data*, 4th ed., Wiley 2010, Eq. (9.90)). The estimate is free of
leakage only if each record holds the whole response: the response's RMS
over the last tenth of every record is checked against its RMS over the
record (:data:`DECAY_LIMIT`); a record that ends before the response has
decayed needs a longer record (a finer resolution), not the exponential
window -- that window adds a known damping to every mode
(``sigma = 1 / tau``), which vlab's model would then have to carry.

Sources: Ewins, *Modal Testing: Theory, Practice and Application*, 2nd ed.,
Research Studies Press 2000, Sec. 3.9.3 (impact excitation; force and
exponential windows); Bendat & Piersol, Sec. 9.1 (H1 and its coherence);
Brandt, *Noise and Vibration Analysis*, Wiley 2011, Sec. 13.9 (impact
testing: trigger, pre-trigger, force window) and 13.10 (burst random).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import MeasurementError

#: Trigger level: an event starts where ``|force|`` first exceeds this fraction of its largest value.
TRIGGER_LEVEL = 0.1
#: Pre-trigger: a record starts this fraction of its length before the trigger (the pulse's rise kept).
PRE_TRIGGER = 0.01
#: Largest RMS of the response over the last tenth of a record, relative to its RMS over the whole record:
#: above it the response has not decayed and the record is cut (leakage).
DECAY_LIMIT = 0.05
#: Two excursions above the trigger level this fraction of a record apart are two events.
DOUBLE_HIT_GAP = 0.02
#: A force is transient when it stays below the trigger level for at least this fraction of the record.
QUIET_SHARE = 0.5


@dataclass(frozen=True)
class TransientFrf:
    """H1 FRFs of a transient excitation over one record per event (:func:`transient_h1`).

    Attributes
    ----------
    freq_hz : ndarray, shape (n_f,)
        Lines ``k / (n dt)`` from 0 Hz [Hz].
    h : ndarray, complex, shape (n_f, n_o)
        Response per force.
    coherence : ndarray, shape (n_f, n_o)
        Ordinary coherence over the records.
    starts : tuple of int
        First sample of each record.
    n_record : int
        Samples per record.
    force_end : int
        Samples of each record the force window keeps (from the record's start).
    decay : ndarray, shape (n_o,)
        Each response's largest tail-to-record RMS ratio over the records.
    """

    freq_hz: np.ndarray
    h: np.ndarray
    coherence: np.ndarray
    starts: tuple[int, ...]
    n_record: int
    force_end: int
    decay: np.ndarray


def is_transient(x: np.ndarray) -> bool:
    """Whether the force ``x`` is an impact or burst excitation: below :data:`TRIGGER_LEVEL` of its largest
    value for at least :data:`QUIET_SHARE` of the samples.

    Parameters
    ----------
    x : ndarray, shape (n,)
        Force [N].

    Returns
    -------
    bool
    """
    a = np.abs(np.asarray(x, dtype=float))
    top = float(a.max(initial=0.0))
    return top > 0 and float(np.mean(a < TRIGGER_LEVEL * top)) >= QUIET_SHARE


def event_starts(x: np.ndarray, n_record: int) -> tuple[int, ...]:
    """First samples of the records of the events in ``x``: each a pre-trigger (:data:`PRE_TRIGGER` of a
    record) before the force first exceeds :data:`TRIGGER_LEVEL` of its largest value, the next event
    searched after the record; a record that would run past the end is left out.

    Parameters
    ----------
    x : ndarray, shape (n,)
        Force [N].
    n_record : int
        Samples per record.

    Returns
    -------
    tuple of int
    """
    a = np.abs(np.asarray(x, dtype=float))
    level = TRIGGER_LEVEL * float(a.max(initial=0.0))
    pre = int(round(PRE_TRIGGER * n_record))
    over = np.flatnonzero(a > level)
    starts, k = [], 0
    while True:
        after = over[over >= k]
        if after.size == 0:
            break
        s = max(int(after[0]) - pre, 0)
        if s + n_record > a.size:
            break
        starts.append(s)
        k = s + n_record
    return tuple(starts)


def _single_events(frames: np.ndarray, starts: tuple[int, ...], dt_s: float) -> None:
    """Refuse a record whose force exceeds the trigger level again after a gap of :data:`DOUBLE_HIT_GAP` of the
    record (a double hit, or events closer than a record)."""
    a = np.abs(frames)
    level = TRIGGER_LEVEL * float(a.max())
    for s, row in zip(starts, a):
        over = np.flatnonzero(row > level)
        gaps = np.diff(over)
        if gaps.size and gaps.max() > DOUBLE_HIT_GAP * row.size:
            raise MeasurementError(f"the record starting at {s * dt_s:.6g} s holds two events (a double hit, or "
                                   f"events closer than a record of {row.size * dt_s:g} s): leave them out or "
                                   "record longer gaps")


def _force_end(frames: np.ndarray) -> int:
    """Samples from a record's start that the force window keeps: to where the largest record's force last
    exceeds the trigger level, plus the pre-trigger again (the pulse's tail)."""
    a = np.abs(frames)
    level = TRIGGER_LEVEL * float(a.max())
    last = max(int(np.flatnonzero(row > level)[-1]) for row in a if np.any(row > level))
    return min(frames.shape[1], last + 1 + int(round(PRE_TRIGGER * frames.shape[1])) + 1)


def transient_h1(x, ys, *, dt_s: float, resolution_hz: float, names: tuple[str, ...] = (),
                 records: tuple[tuple[int, ...], int] | None = None) -> TransientFrf:
    """H1 FRFs of a transient excitation, one record per event (module docstring).

    Parameters
    ----------
    x : array_like, shape (n,)
        Force [N].
    ys : array_like, shape (n, n_o)
        Responses (any quantity; the FRF is response per force).
    dt_s : float
        Sampling interval [s].
    resolution_hz : float
        Line spacing [Hz] = 1 / record length.
    names : tuple of str
        Response channel names (for messages).
    records : (starts, force_end), optional
        Analyse these records with this force window (those of an earlier estimate, ``TransientFrf.starts`` and
        ``force_end``: a simulation of the same test analysed as its recording was); default: found here, and
        each response checked to have decayed.

    Returns
    -------
    TransientFrf

    Raises
    ------
    MeasurementError
        A force that is not transient (:func:`is_transient`), fewer than two events with a whole record after
        them (a coherence needs two), a record holding two events (a double hit), a response that has not decayed by the end of its records
        (:data:`DECAY_LIMIT`; names the channel, its tail ratio and the record length).
    """
    xa = np.asarray(x, dtype=float)
    ya = np.asarray(ys, dtype=float).reshape(xa.size, -1)
    n = int(round(1.0 / (resolution_hz * dt_s)))
    if records is not None:
        return _h1_over(xa, ya, n, dt_s, tuple(records[0]), int(records[1]))
    if not is_transient(xa):
        raise MeasurementError(f"the force is not an impact or burst excitation: it is below {TRIGGER_LEVEL:g} of "
                               f"its peak for less than {QUIET_SHARE:.0%} of the record")
    starts = event_starts(xa, n)
    if len(starts) < 2:
        raise MeasurementError(f"{len(starts)} event(s) with a whole record of {n * dt_s:g} s after them "
                               f"({resolution_hz:g} Hz lines): H1 and its coherence need at least two")
    idx = np.asarray(starts)[:, None] + np.arange(n)[None, :]
    _single_events(xa[idx], starts, dt_s)
    end = _force_end(xa[idx])
    out = _h1_over(xa, ya, n, dt_s, starts, end)
    bad = np.flatnonzero(out.decay > DECAY_LIMIT)
    if bad.size:
        j = int(bad[0])
        name = names[j] if j < len(names) else f"response {j}"
        raise MeasurementError(f"channel {name}: the response has not decayed by the end of its {n * dt_s:g}-s "
                               f"records (RMS over the last tenth {out.decay[j]:.3g} of the record's, limit "
                               f"{DECAY_LIMIT:g}): record longer (a finer --resolution), or leave more time "
                               "between the events")
    return out


def _h1_over(xa: np.ndarray, ya: np.ndarray, n: int, dt_s: float, starts: tuple[int, ...],
             end: int) -> TransientFrf:
    """H1 and coherence over the records at ``starts`` (``n`` samples each), the force kept up to ``end``."""
    idx = np.asarray(starts)[:, None] + np.arange(n)[None, :]
    fx = xa[idx].copy()
    fx[:, end:] = 0.0                                             # the force window
    fy = ya[idx]                                                  # (n_e, n, n_o)
    tail = max(n // 10, 1)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.sqrt(np.mean(fy[:, -tail:] ** 2, axis=1) / np.mean(fy ** 2, axis=1))
    decay = np.nan_to_num(ratio, nan=0.0).max(axis=0)
    fxs, fys = np.fft.rfft(fx, axis=1), np.fft.rfft(fy, axis=1)
    gxy = np.sum(np.conj(fxs)[:, :, None] * fys, axis=0)
    gxx = np.sum(np.abs(fxs) ** 2, axis=0)[:, None]
    gyy = np.sum(np.abs(fys) ** 2, axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        h = np.where(gxx > 0, gxy / gxx, 0.0)
        coh = np.where(gxx * gyy > 0, np.abs(gxy) ** 2 / (gxx * gyy), 0.0)
    return TransientFrf(np.fft.rfftfreq(n, dt_s), h, np.clip(coh, 0.0, 1.0), starts, n, end, decay)
