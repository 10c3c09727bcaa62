"""Self-excited oscillation and growth in a recording: the loop went unstable.

A stable loop's response is the structure's answer to the excitation plus
sensor noise: at every frequency the response is either coherent with the
force (``gamma^2`` near 1) or small (the noise floor). A loop that has gone
unstable oscillates at its own frequency: a spectral line that is *not*
caused by the force (coherence near 0) and stands far above the channel's incoherent
floor (and is at least ``MIN_LINE_SHARE`` of the channel's RMS), often
growing (no saturation) or holding a constant level (a limit cycle set by
the amplifier limit or another nonlinearity). For every velocity channel::

    G_nn(f) = (1 - gamma^2(f)) G_yy(f)           incoherent (not force-driven) power
    floor   = median over the band of G_nn       the channel's noise floor
    line    : G_nn(f) > LINE_TO_FLOOR * floor  and  gamma^2(f) < MAX_COHERENCE

A line is self-excited when, in addition, it is (a) not periodic with the
excitation -- for a periodic force (the lab's periodic pseudo-random
excitation) the band-passed line differs from one period to the next by at
least ``MIN_PERIOD_CHANGE`` of its norm: a forced response repeats (a sharp
resonance or the nonlinear distortion of the plant: incoherent by the linear
measure, yet periodic), an oscillation the loop makes itself does not -- and
(b) deterministic: its envelope is nearly constant (coefficient of variation
below ``MAX_ENVELOPE_CV``) or grows significantly. A lightly damped mode
driven by sensor noise through the feedback is a narrowband Gaussian process
whose envelope is Rayleigh distributed, with coefficient of variation
``sqrt(4/pi - 1) = 0.52`` over a long record (Bendat & Piersol, Sec. 3.4.3); a sine has 0 (the gate's false-alarm
rate is not bounded over short windows: :data:`MAX_ENVELOPE_CV`) -- and
(c) not decaying: an unstable loop's oscillation grows until a nonlinearity
holds it (a limit cycle) and never dies out by itself, while the free
response of a stable, lightly damped closed-loop mode (the loop's start-up
transient) does; a line whose amplitude falls by ``GROWTH_FACTOR`` or more
over the record's second half, its slope beyond three standard errors, is
such a transient (a grid LQG loop's 14 Hz mode decaying at 0.045-0.049 1/s,
``zeta`` = 0.0005, still 38 dB over the floor a minute after the start).
A line that rises by ``GROWTH_FACTOR`` over the second half is growing (a stable mode building up from
rest rises by less); in the rerun of a loop whose linearisation has an unstable pole
(``unstable_loop``), any significant rise is that pole's growth. A growing line is not periodic with
the force, whatever its change from one period to the next (the period gate does not apply to it).

``LINE_TO_FLOOR`` (1e3, 30 dB): a Welch estimate of a noise spectrum with
``nu = 2 n_avg`` degrees of freedom exceeds its mean by a factor ``x`` with
probability ``exp(-x nu / 2)`` at most (chi-square tail), so with 16 averages a
noise bin reaches even 10x the floor with probability below 1e-30; the margin
above that covers floors that are not flat (a controlled mode's noise-driven
response, leakage at a lightly damped resonance). ``MAX_COHERENCE`` (0.5): the
line is mostly not caused by the force -- at a forced resonance the coherence
stays high even when leakage lowers it, while an oscillation the loop makes
itself is unrelated to the force.

The growth of a line is the slope of its log-amplitude over the record:
the channel band-passed around the line, its RMS in :data:`N_SEGMENTS`
consecutive segments, a least-squares line through ``ln RMS`` against time
(``sigma`` [1/s], ``exp(sigma t)``). The loop that oscillates is the feedback
channel (a collocated sensor/coil point) where the line is strongest.

Source: coherence and the incoherent output spectrum, Bendat & Piersol,
*Random Data*, 4th ed., Secs. 9.2.3 and 7.4 (chi-square distribution of
spectral estimates, Sec. 8.5.4); the dissertation's loop (Sec. 5.3) can go
unstable when the hardware delay and filter turn the rate feedback's phase
(Sec. 6.2 discusses spillover and delay).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import signal

from ..errors import MeasurementError
from ..io.recording import Recording, parse_channel_name

#: A line stands at least this factor above the channel's incoherent floor [-] (30 dB).
LINE_TO_FLOOR = 1e3
#: ... and its coherence with the force is below this [-].
MAX_COHERENCE = 0.5
#: Welch averages aimed at (the block is the largest power of two giving at least this many).
MIN_AVERAGES = 16
#: Coefficient of variation of a Rayleigh envelope (a narrowband Gaussian process), sqrt(4/pi - 1) [-].
ENVELOPE_CV_RAYLEIGH = math.sqrt(4 / math.pi - 1)
#: A line smaller than this share of its channel's RMS (second half) is not counted [-] (-60 dB: below the
#: dynamic range of a 12-bit converter, 72 dB, less a usual headroom; the numerical floor of a noise-free run).
MIN_LINE_SHARE = 1e-3
#: A self-excited line's envelope varies less than this (std/mean) [-]: two thirds of the Rayleigh value. A chosen
#: number without a stated false-alarm rate: over a window holding few of a noise-driven mode's correlation times
#: (``pi zeta f0 T_w``) the Rayleigh envelope's estimated coefficient falls below it often (measured by
#: ``benchmarks/envelope_null.py``: in 2-85 % of records for ``pi zeta f0 T_w`` from 7.5 down to 0.2), so
#: without a periodic force (no period-change gate) a stable, lightly damped mode can pass for a limit cycle.
MAX_ENVELOPE_CV = 2 / 3 * ENVELOPE_CV_RAYLEIGH
#: With a periodic force, a self-excited line changes at least this much (norm ratio) from one period to the next.
#: A chosen margin, not derived from a stated error rate: a steady oscillation at ``f0`` changes by
#: ``2 |sin(pi f0 T)|`` over a period ``T``, so 0.3 leaves undetected the oscillations within 0.048 / T of a
#: harmonic of the excitation (a tenth of all frequencies), while noise alone changes a line 30 dB over its floor
#: by a few hundredths.
MIN_PERIOD_CHANGE = 0.3
#: Segments of the record over which the growth of a line is fitted.
N_SEGMENTS = 8
#: A line still grows when its amplitude rises by at least this factor over the record's second half (slope > 3 se);
#: it decays (a stable mode's transient) when it falls by as much (slope < -3 se). A stable, lightly damped mode that
#: builds up from rest, as a record or a rerun started at rest does, grows as ``1 - exp(-a t)``: from the record's
#: middle to its end by ``1 + exp(-a T / 2) < 2``, so a rise of 2 over the second half is no such build-up; it also
#: guards a measured record's noise-driven lines, whose envelopes wander (see MAX_ENVELOPE_CV). A loop known to have
#: an unstable pole needs no factor (``find_instability(unstable_loop=)``).
GROWTH_FACTOR = 2.0


@dataclass(frozen=True)
class Oscillation:
    """One self-excited line in one velocity channel.

    Attributes
    ----------
    channel : str
        Recording channel, e.g. ``"vel5"``.
    point : int
        Its point id.
    frequency_hz : float
        Line frequency [Hz] (parabolic interpolation of the log spectrum).
    amplitude_m_s : float
        RMS of the line [m/s] (incoherent power summed over the line's bins).
    line_to_floor : float
        Incoherent power at the line over the channel's floor [-].
    coherence : float
        Coherence with the force at the line [-].
    growth_rate_1_s : float
        Fitted ``sigma`` of ``exp(sigma t)`` of the line's amplitude over the
        record's second half [1/s].
    growth_rate_se_1_s : float
        Its standard error [1/s].
    growing : bool
        Still growing at the end: ``sigma`` more than 3 standard errors above
        0 and, in a measured record, a rise of at least :data:`GROWTH_FACTOR`
        over the second half.
    rise : float
        Largest segment RMS over the first segment's [-]: how much the line
        grew since the record began.
    envelope_cv : float
        Coefficient of variation of the line's envelope, growth divided out [-]
        (0 for a sine, 0.52 for a noise-driven mode).
    period_change : float or None
        Change of the line from one excitation period to the next [-] (None:
        the force is not periodic, or no half period clear of the filter's
        end transient).
    """

    channel: str
    point: int
    frequency_hz: float
    amplitude_m_s: float
    line_to_floor: float
    coherence: float
    growth_rate_1_s: float
    growth_rate_se_1_s: float
    growing: bool
    rise: float
    envelope_cv: float
    period_change: float | None

    def as_dict(self) -> dict:
        """JSON-ready dict (keys carry units)."""
        return {"channel": self.channel, "point": self.point, "frequency_hz": self.frequency_hz,
                "amplitude_m_s": self.amplitude_m_s, "line_to_floor": self.line_to_floor,
                "coherence": self.coherence, "growth_rate_1_s": self.growth_rate_1_s,
                "growth_rate_se_1_s": self.growth_rate_se_1_s, "growing": self.growing, "rise": self.rise,
                "envelope_cv": self.envelope_cv, "period_change": self.period_change}


@dataclass(frozen=True)
class InstabilityCheck:
    """What :func:`find_instability` saw in a recording.

    Attributes
    ----------
    unstable : bool
        Some channel holds a self-excited line.
    oscillations : tuple of Oscillation
        Every line found, strongest (largest ``line_to_floor``) first; one per
        channel and frequency.
    loop_point : int or None
        The feedback point where the strongest line is largest (the loop
        that oscillates); None when stable or no feedback channel carries it.
    resolution_hz : float
        Spectral resolution used [Hz].
    n_averages : int
        Welch averages per spectrum.
    """

    unstable: bool
    oscillations: tuple[Oscillation, ...]
    loop_point: int | None
    resolution_hz: float
    n_averages: int

    @property
    def frequency_hz(self) -> float | None:
        """Frequency [Hz] of the strongest line at the loop point (None when stable)."""
        if not self.unstable:
            return None
        at_loop = [o for o in self.oscillations if o.point == self.loop_point]
        return (at_loop or list(self.oscillations))[0].frequency_hz

    def summary(self) -> str:
        """One sentence for a report: frequency, growth, loop; or that none was found."""
        if not self.unstable:
            return "no self-excited oscillation or growth in the recording"
        o = max([x for x in self.oscillations if x.point == self.loop_point] or list(self.oscillations),
                key=lambda x: x.amplitude_m_s)
        if o.growing:
            growth = f"still growing at the end ({o.growth_rate_1_s:.3g} 1/s)"
        elif o.rise >= GROWTH_FACTOR:
            growth = f"grown {o.rise:.3g}-fold since the record began and holding a steady level (a limit cycle)"
        else:
            growth = "at a steady level over the record (a limit cycle)"
        where = (f"strongest in the loop at point {self.loop_point}" if self.loop_point is not None
                 else f"strongest at point {o.point} (not a feedback point)")
        others = sorted({round(x.frequency_hz, 1) for x in self.oscillations} - {round(o.frequency_hz, 1)})
        more = f"; other lines at {', '.join(f'{f:g}' for f in others)} Hz" if others else ""
        return (f"the loop is unstable: a self-excited oscillation at {o.frequency_hz:.2f} Hz "
                f"({o.amplitude_m_s:.3g} m/s RMS at point {o.point}, {10 * math.log10(o.line_to_floor):.0f} dB above "
                f"the noise floor, coherence with the force {o.coherence:.2f}), {growth}, {where}{more}")

    def as_dict(self) -> dict:
        """JSON-ready dict (keys carry units)."""
        return {"unstable": self.unstable, "frequency_hz": self.frequency_hz, "loop_point": self.loop_point,
                "resolution_hz": self.resolution_hz, "n_averages": self.n_averages,
                "oscillations": [o.as_dict() for o in self.oscillations]}


def welch_block(n: int) -> int:
    """The Welch block length of :func:`find_instability` for a record of ``n`` samples.

    Parameters
    ----------
    n : int
        Samples in the record.

    Returns
    -------
    int
        The largest power of two giving at least :data:`MIN_AVERAGES` half-overlapping blocks in ``n`` samples,
        at least 64 and at most ``n`` [samples].
    """
    nper = 2 ** int(math.floor(math.log2(max(2 * n / (MIN_AVERAGES + 1), 64))))
    return max(64, min(nper, n))


def force_period(x: np.ndarray) -> int | None:
    """Samples per period of a force that repeats exactly ``k`` times (k = 2..12) over the record; None otherwise.

    Parameters
    ----------
    x : ndarray, shape (n,)
        Force [N].

    Returns
    -------
    int or None
        The shortest such period [samples].
    """
    n = len(x)
    top = float(np.max(np.abs(x))) if n else 0.0
    if top <= 0:
        return None
    for k in range(12, 1, -1):
        if n % k == 0:
            period = n // k
            if np.max(np.abs(x[period:] - x[:-period])) <= 1e-9 * top:
                return period
    return None


def filter_settling(sos: np.ndarray, *, level: float = MIN_LINE_SHARE) -> int:
    """Samples after which the impulse response of the filter ``sos`` (second-order sections, shape
    (n_sections, 6)) holds less than ``level`` of its amplitude: its energy from there on is below
    ``level**2`` of the whole (the -60 dB of :data:`MIN_LINE_SHARE` by default, the level below which a line
    is not counted). ``sosfiltfilt`` runs the filter both ways, so the samples this close to either end of a
    record carry the filter's response to the record's edge.

    Parameters
    ----------
    sos : ndarray, shape (n_sections, 6)
        A stable filter (:func:`scipy.signal.butter` with ``output="sos"``).
    level : float
        Amplitude ratio [-], in (0, 1).

    Returns
    -------
    int
        Settling time [samples], at least 1.

    Raises
    ------
    ValueError
        ``level`` outside (0, 1).
    """
    if not 0.0 < level < 1.0:
        raise ValueError(f"level must lie in (0, 1), got {level}")
    n = 1024
    while True:  # lengthen the impulse response until its tail is negligible
        imp = np.zeros(n)
        imp[0] = 1.0
        h = signal.sosfilt(sos, imp)
        tail = np.cumsum((h * h)[::-1])[::-1]
        if tail[-max(n // 8, 1)] < level ** 2 * tail[0] or n >= 1 << 24:
            return int(np.flatnonzero(tail >= level ** 2 * tail[0])[-1]) + 1
        n *= 4


def line_statistics(y: np.ndarray, fs: float, f0: float, df: float, period: int | None):
    """Band-pass ``y`` around ``f0`` and measure the line in the record's second half (the statistics by which
    :func:`find_instability` judges a line).

    Parameters
    ----------
    y : ndarray, shape (n,)
        One channel's record [any unit].
    fs : float
        Sampling rate [Hz].
    f0 : float
        The line's frequency [Hz].
    df : float
        Spectral resolution of the line's spectrum [Hz] (the pass band is ``f0 +- max(2 df, 0.02 f0)``).
    period : int or None
        Samples per period of a periodic force (:func:`force_period`); None: no period change measured.

    Returns
    -------
    tuple
        ``(sigma, se, rise, envelope_cv, period_change, late_rms)``: ``sigma`` [1/s]
        and ``se``, the slope of ln RMS over the second half's segments (of
        N_SEGMENTS in all) and its standard error; ``rise``, the largest segment
        RMS over the first one's (how much the line grew since the record
        began); ``envelope_cv``, std/mean of the Hilbert envelope over the second
        half with that slope divided out (a limit cycle holds its level there once it has grown; a tenth cut at
        the end against the filter's edge);
        ``period_change``, the norm of the line's change over one period, ``z(t) - z(t - P)``, over the last
        period's worth of samples clear of the band-pass filter's end transient (:func:`filter_settling`), over the
        norm of ``z(t)`` there (None without a periodic force, or where the record holds no such span of at least
        half a period); ``late_rms``, the line's RMS over the second half [units of ``y``]. A pass band outside
        ``(0, fs/2)`` or a silent segment gives ``(0, inf, 1, inf, None, 0)``.

    Raises
    ------
    nothing of its own (scipy's filter design errors for a malformed rate).
    """
    half = max(2.0 * df, 0.02 * f0)
    lo, hi = max(f0 - half, 0.05 * df), min(f0 + half, 0.49 * fs)
    if not lo < hi:
        return 0.0, math.inf, 1.0, math.inf, None, 0.0
    sos = signal.butter(4, [lo, hi], btype="bandpass", fs=fs, output="sos")
    z = signal.sosfiltfilt(sos, y)
    seg = np.array_split(z, N_SEGMENTS)
    rms = np.array([math.sqrt(float(np.mean(s * s))) for s in seg])
    if np.any(rms <= 0):
        return 0.0, math.inf, 1.0, math.inf, None, 0.0
    lengths = np.array([len(s) for s in seg])
    t = (np.cumsum(lengths) - lengths / 2) / fs
    late = slice(N_SEGMENTS // 2, None)
    coef, cov = np.polyfit(t[late], np.log(rms[late]), 1, cov=True)
    sigma, se = float(coef[0]), float(math.sqrt(max(cov[0, 0], 0.0)))
    env = np.abs(signal.hilbert(z))
    i0, i1 = len(env) // 2, len(env) - len(env) // 10
    env = env[i0:i1] * np.exp(-sigma * np.arange(i0, i1) / fs)
    cv = float(np.std(env) / np.mean(env)) if env.size and np.mean(env) > 0 else math.inf
    change = None
    if period is not None and len(z) >= 3 * period:
        # the zero-phase filter's response to the record's end reaches back over its settling time: a periodic
        # line looks changed there, so the period's change is measured before it
        end = len(z) - filter_settling(sos)
        start = max(end - period, period)
        if end - start >= period // 2:
            now, before = z[start:end], z[start - period:end - period]
            norm = float(np.linalg.norm(now))
            change = float(np.linalg.norm(now - before) / norm) if norm > 0 else None
    late_rms = math.sqrt(float(np.mean(z[len(z) // 2:] ** 2)))
    return sigma, se, float(rms.max() / rms[0]), cv, change, late_rms


def _incoherent_spectrum(x: np.ndarray | None, y: np.ndarray, gxx: np.ndarray | None, kw: dict):
    """Welch lines ``f``, the part of ``G_yy`` incoherent with ``x``, ``(1 - gamma^2) G_yy``, and ``gamma^2``."""
    f, gyy = signal.welch(y, **kw)
    if x is not None:
        _, gxy = signal.csd(x, y, **kw)
        with np.errstate(divide="ignore", invalid="ignore"):
            den = gxx * gyy
            coh = np.clip(np.where(den > 0, np.abs(gxy) ** 2 / np.where(den > 0, den, 1.0), 0.0), 0.0, 1.0)
    else:
        coh = np.zeros_like(gyy)
    return f, (1.0 - coh) * gyy, coh


def _channel_oscillations(name: str, y_full: np.ndarray, skip: int, x: np.ndarray | None, gxx: np.ndarray | None,
                          kw: dict, period: int | None, unstable_loop: bool = False) -> list[Oscillation]:
    """The self-excited lines of one velocity channel (the rule of the module notes; ``unstable_loop`` as
    :func:`find_instability`'s)."""
    fs, df = kw["fs"], kw["fs"] / kw["nperseg"]
    f, gnn, coh = _incoherent_spectrum(None if x is None else x[skip:], y_full[skip:], gxx, kw)
    band = (f > 2 * df) & (f < 0.45 * fs)
    floor = float(np.median(gnn[band]))
    if not floor > 0:
        return []
    cand = band & (gnn > LINE_TO_FLOOR * floor) & (coh < MAX_COHERENCE)
    if not cand.any():
        return []
    # local maxima of G_nn among the candidates, one per line
    idx = [i for i in np.flatnonzero(cand) if gnn[i] >= gnn[max(i - 1, 0)] and gnn[i] >= gnn[min(i + 1, len(f) - 1)]]
    point = parse_channel_name(name)[1]
    found = []
    for i in idx:
        lo, hi = max(i - 1, 0), min(i + 1, len(f) - 1)
        a, b, c = np.log(gnn[[lo, i, hi]])
        den = a - 2 * b + c
        shift = 0.5 * (a - c) / den if den < 0 and lo < i < hi else 0.0
        f0 = float(f[i] + shift * df)
        sl = slice(max(i - 2, 0), min(i + 3, len(f)))
        amp = math.sqrt(float(np.sum(gnn[sl])) * df / 1.5)  # Hann window: noise bandwidth 1.5 bins
        sigma, se, rise, cv, change, late_rms = line_statistics(y_full, fs, f0, df, period)
        if late_rms < MIN_LINE_SHARE * math.sqrt(float(np.mean(y_full[len(y_full) // 2:] ** 2))):
            continue  # below what the lab's converters resolve next to the response
        # a loop with an unstable pole (a noise-free rerun of it) grows by itself at any rate; otherwise a rise of
        # GROWTH_FACTOR tells growth from a stable mode's build-up or a noise-driven envelope's wandering
        growing = sigma > 3 * se and (unstable_loop or math.exp(sigma * len(y_full) / (2 * fs)) >= GROWTH_FACTOR)
        if sigma < -3 * se and math.exp(-sigma * len(y_full) / (2 * fs)) >= GROWTH_FACTOR:
            continue  # it dies out: the free response of a stable mode
        if change is not None and change < MIN_PERIOD_CHANGE and not growing:
            continue  # it repeats with the force: a forced (possibly nonlinear) response (a growing line does not)
        if not (cv < MAX_ENVELOPE_CV or growing):
            continue  # a Rayleigh envelope: a mode driven by noise, stable
        found.append(Oscillation(name, point, f0, amp, float(gnn[i] / floor), float(coh[i]),
                                 sigma, se, bool(growing), rise, cv, change))
    return found


def find_instability(recording: Recording, *, force_channel: str | None = None,
                     feedback_points=(), skip_s: float = 0.0, unstable_loop: bool = False) -> InstabilityCheck:
    """Look for self-excited oscillations (and their growth) in every velocity channel of a recording.

    Parameters
    ----------
    recording : Recording
        Time histories at the controller rate: ``vel<p>`` [m/s] and one
        ``force<p>`` [N] (the excitation).
    force_channel : str, optional
        The excitation channel (default: the only ``force<p>`` channel; none:
        every line counts as incoherent).
    feedback_points : sequence of int
        Collocated sensor/coil points of the loop; the loop that oscillates
        is named among them.
    skip_s : float
        Seconds at the start left out of the spectra (a start-up transient),
        not of the growth fit.
    unstable_loop : bool
        The record is a noise-free simulation of a loop whose linearisation
        has an unstable pole (a candidate's rerun in the search for an
        oscillation's cause): a line whose amplitude grows significantly
        (slope beyond three standard errors over the record's second half)
        is that pole's growth whatever the factor (:data:`GROWTH_FACTOR`),
        and a growing line is not periodic with the force.

    Returns
    -------
    InstabilityCheck

    Raises
    ------
    MeasurementError
        No velocity channel, a named force channel that is missing, non-finite
        samples (naming the channel), or fewer than 256 samples after ``skip_s``.

    Notes
    -----
    The rule and its thresholds are in the module notes (Bendat & Piersol,
    Secs. 7.4, 8.5.4, 9.2.3).
    """
    names = recording.names
    vel = [n for n in names if n.startswith("vel")]
    if not vel:
        raise MeasurementError(f"recording has no velocity channel vel<ID> (channels: {', '.join(names)})")
    if force_channel is None:
        forces = [n for n in names if n.startswith("force")]
        force_channel = forces[0] if len(forces) == 1 else None
    elif force_channel not in names:
        raise MeasurementError(f"force channel {force_channel!r} is not in the recording ({', '.join(names)})")
    fs = recording.sample_rate_hz
    skip = int(round(max(skip_s, 0.0) * fs))
    n = recording.n_samples - skip
    if n < 256:
        raise MeasurementError(f"recording: {n} samples after skipping {skip_s:g} s; at least 256 are needed "
                               f"to look for an oscillation")
    nper = welch_block(n)
    kw = dict(fs=fs, window="hann", nperseg=nper, noverlap=nper // 2, detrend="constant")
    df = fs / nper
    n_avg = 1 + (n - nper) // (nper - nper // 2)
    x = gxx = None
    if force_channel is not None:
        x = np.asarray(recording[force_channel], dtype=float)
        if not np.all(np.isfinite(x)):
            raise MeasurementError(f"channel {force_channel}: non-finite samples")
        _, gxx = signal.welch(x[skip:], **kw)
    period = force_period(x) if x is not None else None
    fb = set(int(p) for p in feedback_points)
    found: list[Oscillation] = []
    for name in vel:
        y_full = np.asarray(recording[name], dtype=float)
        if not np.all(np.isfinite(y_full)):
            raise MeasurementError(f"channel {name}: non-finite samples")
        found += _channel_oscillations(name, y_full, skip, x, gxx, kw, period, unstable_loop)
    found.sort(key=lambda o: -o.line_to_floor)
    loop_point = None
    if found:
        f_top = found[0].frequency_hz
        near = [o for o in found if abs(o.frequency_hz - f_top) <= 2 * df and o.point in fb]
        if near:
            loop_point = max(near, key=lambda o: o.amplitude_m_s).point
    return InstabilityCheck(bool(found), tuple(found), loop_point, float(df), int(n_avg))
