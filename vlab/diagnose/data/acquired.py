"""Recordings from an acquisition system: any motion quantity and rate, brought to the lab's loop for the diagnosis.

The diagnosis compares velocity FRFs per excitation command, as the lab's
2 kHz loop records them (:func:`vlab.diagnose.model.labmodel.predict_frf`:
the command held by a zero-order hold, velocities sampled at the controller's
instants). A recording made by the lab's own loop is used as it is
(:func:`is_lab_recording`). Any other -- accelerations, displacements or
velocities from an acquisition system at its own rate, sensors mounted in -Z
-- is brought to that form here:

1. **Channels by node and direction.** Each channel's node is the
   structure's point; +Z is the out-of-plane direction the models have, a
   channel in -Z is turned over (times -1), in-plane channels (X, Y) are left
   out (a note says which). One force channel (the excitation), at most one
   motion channel per point.
2. **Resampling to the loop's clock** (:func:`resample`). Every channel is
   resampled to twice the controller rate by a polyphase FIR filter
   (:func:`scipy.signal.resample_poly`; a Kaiser-windowed sinc, beta
   :data:`KAISER_BETA`, :data:`HALF_LENGTH` x max(up, 2 down) taps each
   side, cut off at the lower of the input's and the controller's Nyquist
   frequencies: linear phase, its delay removed, passband error
   :data:`PASSBAND_ERROR` at most in the structure's band,
   :func:`passband_error`). A record of whole excitation
   periods is extended periodically for the filter, other records by a line
   (:func:`scipy.signal.resample_poly`'s ``padtype="line"``). The motion
   channels are kept at the controller's instants ``k T``; the force at the
   middle of each hold, ``(k + 1/2) T``: held by the loop's zero-order hold,
   those values reproduce the measured force with no delay (its magnitude within
   ``1 - sinc(f T)``, 2.6e-4 at 25 Hz for T = 0.5 ms), so the nominal
   plant's replay of the recorded force is driven by the force the
   structure felt.
3. **FRFs, converted to velocity at the FRF level** (:func:`frf_conversion`).
   The FRFs of each motion channel are estimated by the estimators of
   :mod:`vlab.diagnose.data.frfestimate`: period by period when the force
   repeats within :data:`PERIODIC_NOISE` of its RMS from one period to the
   next (a periodic excitation measured with noise), else H1 with a Hann
   window (:func:`frfs_from_acquired`), and then converted: ``H_v = H_a / (j w)`` for accelerations,
   ``H_v = j w H_d`` for displacements, each times ``sinc(f T)``, which with
   the force's half-step ``e^{-j w T / 2}`` makes the hold
   ``(1 - e^{-j w T}) / (j w T)`` of the lab's command-to-velocity FRF.
   At the FRF level the conversion is exact on every analysed line: an
   integration of the time histories would add the drift of sensor offsets
   and of the record's ends, and a derivative would need a filter. The noise
   variance is scaled by ``|conversion|^2``.
4. **Velocity time histories** for what compares signals in time (the
   validation reruns' time-domain error, the start-at-rest test, the
   instability search, the report's figure): the resampled motion
   integrated (or differentiated) in the frequency domain over the whole
   record, lines below half the band's lower edge set to zero
   (:func:`velocity_history`). They do not enter the FRFs.

Sources: Bendat & Piersol, *Random Data*, 4th ed., Wiley 2010, Sec. 6.1 (FRFs
of derivatives: ``H_v = j w H_d``); Crochiere & Rabiner, *Multirate Digital
Signal Processing*, Prentice-Hall 1983, Ch. 2-4 (polyphase resampling);
Franklin, Powell & Workman, *Digital Control of Dynamic Systems*, 3rd ed.,
Sec. 4.3.3 (the zero-order hold's ``(1 - e^{-sT}) / (sT)``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction

import numpy as np
import scipy.signal

from ...errors import DataFileError
from ...fe import FEModel
from ...io.recording import Channel, Recording
from ...spec import StructureSpec
from .frfestimate import (ESTIMATORS, PC1000_RATE_HZ, _check_points, _h1_frfs, _is_periodic, _periodic_frfs,
                          _transient_frfs, check_channel_samples, choose_estimator)
from .measured import FrfData

#: Kaiser window parameter of the resampling filter.
KAISER_BETA = 8.0
#: Taps of the resampling filter on each side of its centre, in multiples of max(up, down).
HALF_LENGTH = 20
#: Stated bound of the resampling filter's relative amplitude error over the structure's band
#: (:func:`passband_error`; 4e-5 measured for 5 kHz -> 4 kHz below 100 Hz).
PASSBAND_ERROR = 1e-4
#: Largest denominator of the ratio of the rates (a rate 5120 Hz to 4000 Hz is 25/32).
MAX_RATIO_DENOMINATOR = 1000
#: A force whose second period differs from its first by less than this fraction of its RMS is a periodic
#: excitation measured with noise (a random excitation differs by about sqrt(2)).
PERIODIC_NOISE = 0.1
#: Directions read as out of plane (UFF codes): +Z as recorded, -Z turned over.
_OUT_OF_PLANE = {3: 1.0, -3: -1.0}


def is_lab_recording(rec: Recording) -> bool:
    """Whether ``rec`` is as the lab's loop records: sampled at a PC-1000 rate (the controller's, 2 to 2000
    samples/s, Sec. 5.3), force and velocities only, all in +Z. Such a recording's force samples are the
    commands held on the controller's clock; any other is an acquisition system's (:func:`frfs_from_acquired`).

    Parameters
    ----------
    rec : Recording

    Returns
    -------
    bool
    """
    rate = 1.0 / rec.dt_s
    in_range = PC1000_RATE_HZ[0] * (1 - 1e-9) <= rate <= PC1000_RATE_HZ[1] * (1 + 1e-9)
    return in_range and all(c.quantity in ("force", "velocity") and c.direction == 3 for c in rec.channels)


def resampling_ratio(rate_in_hz: float, rate_out_hz: float, path: str = "") -> tuple[int, int]:
    """``(up, down)`` with ``rate_in * up / down == rate_out`` (relative 1e-9), the smallest such integers.

    Parameters
    ----------
    rate_in_hz, rate_out_hz : float
        Sampling rates [Hz] of the recording and of the resampled signal.
    path : str
        The file (for messages).

    Returns
    -------
    (int, int)

    Raises
    ------
    DataFileError
        Rates whose ratio is not a fraction with a denominator up to :data:`MAX_RATIO_DENOMINATOR`.
    """
    frac = Fraction(rate_out_hz / rate_in_hz).limit_denominator(MAX_RATIO_DENOMINATOR)
    if not math.isclose(rate_in_hz * frac.numerator / frac.denominator, rate_out_hz, rel_tol=1e-9):
        raise DataFileError(f"{path}: sampled at {rate_in_hz:.9g} samples/s: not a ratio of small integers to "
                            f"{rate_out_hz:.9g} samples/s (denominator up to {MAX_RATIO_DENOMINATOR}), which "
                            "the resampling to the controller's clock needs")
    return frac.numerator, frac.denominator


def resampling_filter(up: int, down: int) -> np.ndarray:
    """The FIR low-pass of :func:`resample` at the rate ``up`` times the input rate, shape (2 L + 1,),
    ``L = HALF_LENGTH max(up, 2 down)``, unit gain at DC (:func:`scipy.signal.firwin`, Kaiser window).

    Parameters ``up``, ``down``: the resampling ratio (:func:`resampling_ratio`).

    Cut off at the lower of the input's Nyquist frequency and half the output's: the output (at twice the
    controller rate) is split into every other sample, the force and the motion at the controller rate,
    which then alias nothing (a held command's images at the controller rate +- f, strong in an
    acceleration, would otherwise fold onto the band's lines)."""
    m = max(up, 2 * down)
    return scipy.signal.firwin(2 * HALF_LENGTH * m + 1, 1.0 / m, window=("kaiser", KAISER_BETA))


def passband_error(up: int, down: int, rate_in_hz: float, freq_hz) -> float:
    """Largest relative amplitude error ``| |H(f)| - 1 |`` of :func:`resampling_filter` at ``freq_hz``.

    Parameters
    ----------
    up, down : int
        The resampling ratio (:func:`resampling_ratio`).
    rate_in_hz : float
        The recording's rate [Hz]; the filter runs at ``up * rate_in_hz``.
    freq_hz : array_like, shape (n_f,)
        Frequencies [Hz].

    Returns
    -------
    float
        The largest error [1] (the filter's phase is linear and removed exactly).
    """
    _, h = scipy.signal.freqz(resampling_filter(up, down), worN=np.asarray(freq_hz, dtype=float), fs=up * rate_in_hz)
    return float(np.max(np.abs(np.abs(h) - 1.0)))


def resample(x: np.ndarray, up: int, down: int, *, periodic: bool) -> np.ndarray:
    """``x`` at ``up / down`` times its rate by :func:`scipy.signal.resample_poly` with :func:`resampling_filter`.

    Parameters
    ----------
    x : ndarray, shape (n,)
    up, down : int
    periodic : bool
        ``x`` holds whole periods of a periodic signal: extended periodically at both ends for the filter
        (exact), else by a line through its end samples.

    Returns
    -------
    ndarray, shape (n * up // down,)
        Output sample ``j`` is at the input time ``j * down / up`` (in input steps).
    """
    h = resampling_filter(up, down)
    n_out = x.size * up // down
    if not periodic:
        return scipy.signal.resample_poly(x, up, down, window=h, padtype="line")[:n_out]
    pad = down * math.ceil(((h.size // 2) // up + 2) / down)
    reps = math.ceil(pad / x.size)
    ext = np.concatenate([np.tile(x, reps)[-pad:], x, np.tile(x, reps)[:pad]])
    y = scipy.signal.resample_poly(ext, up, down, window=h)
    skip = pad * up // down
    return y[skip:skip + n_out]


def velocity_history(quantity: str, y: np.ndarray, dt_s: float, low_hz: float) -> np.ndarray:
    """A velocity time history [m/s] from a motion channel, in the frequency domain over the whole record.

    ``V = A / (j w)`` (acceleration) or ``V = j w D`` (displacement) on every line at or above ``low_hz``;
    the lines below (and DC) are set to zero, so that sensor offsets and the record's ends do not drift.

    Parameters
    ----------
    quantity : {"acceleration", "velocity", "displacement"}
    y : ndarray, shape (n,)
        Samples in SI units.
    dt_s : float
        Sampling interval [s].
    low_hz : float
        Lowest line kept [Hz].

    Returns
    -------
    ndarray, shape (n,)
    """
    if quantity == "velocity":
        return np.asarray(y, dtype=float)
    spec = np.fft.rfft(y)
    w = 2 * np.pi * np.fft.rfftfreq(y.size, dt_s)
    keep = w >= 2 * np.pi * low_hz
    out = np.zeros_like(spec)
    out[keep] = spec[keep] / (1j * w[keep]) if quantity == "acceleration" else spec[keep] * (1j * w[keep])
    return np.fft.irfft(out, y.size)


def frf_conversion(quantity: str, freq_hz: np.ndarray, period_s: float) -> np.ndarray:
    """Factor that turns a motion-per-force FRF of the resampled recording into the lab's velocity per command.

    ``sinc(f T) / (j w)`` for acceleration, ``sinc(f T)`` for velocity, ``j w sinc(f T)`` for displacement
    (``sinc(x) = sin(pi x) / (pi x)``; with the force's half-step the hold ``(1 - e^{-j w T}) / (j w T)``).

    Parameters
    ----------
    quantity : {"acceleration", "velocity", "displacement"}
    freq_hz : ndarray, shape (n_f,)
        Lines [Hz], > 0.
    period_s : float
        Controller period T [s].

    Returns
    -------
    ndarray, complex, shape (n_f,)
    """
    f = np.asarray(freq_hz, dtype=float)
    jw = 2j * np.pi * f
    hold = np.sinc(f * period_s).astype(complex)
    if quantity == "acceleration":
        return hold / jw
    if quantity == "displacement":
        return hold * jw
    return hold


@dataclass(frozen=True)
class LabRate:
    """An acquired recording on the controller's clock (:func:`to_lab_rate`).

    Attributes
    ----------
    recording : Recording
        ``force<p>`` (at the middle of each hold) and ``vel<p>`` (:func:`velocity_history`) at the controller
        period [s].
    motion : tuple of Channel
        The motion channels as measured (their quantity), resampled to the controller's instants, +Z.
    notes : tuple of str
    """

    recording: Recording
    motion: tuple
    notes: tuple


def _select(rec: Recording, spec: StructureSpec, fe: FEModel, path: str) -> tuple:
    """The force channel and the out-of-plane motion channels (turned to +Z), checked; notes."""
    notes = []
    inplane = [c.name for c in rec.channels if c.direction not in _OUT_OF_PLANE]
    if inplane:
        notes.append(f"in-plane channels left out (the models are out of plane): {', '.join(inplane)}")
    chans = [c for c in rec.channels if c.direction in _OUT_OF_PLANE]
    flipped = [c.name for c in chans if c.direction == -3]
    if flipped:
        notes.append(f"channels measured in -Z turned over to +Z: {', '.join(flipped)}")
    forces = [c for c in chans if c.quantity == "force"]
    if len(forces) != 1:
        raise DataFileError(f"{path}: expected exactly one out-of-plane force channel (the excitation), found "
                            f"{[c.name for c in forces] or 'none'}")
    motion = [c for c in chans if c.quantity != "force"]
    if not motion:
        raise DataFileError(f"{path}: no out-of-plane motion channel besides {forces[0].name}")
    _check_points(path, spec, fe, [(c.name, c.point_id) for c in forces + motion])
    acts = tuple(spec.instrumentation.actuators)
    if forces[0].point_id not in acts:
        raise DataFileError(f"{path}: channel {forces[0].name}: the excitation at point {forces[0].point_id} is not "
                            f"at an actuator of {spec.name!r} {acts} (the lab excites through a coil)")
    seen: dict = {}
    for c in motion:
        if c.point_id in seen:
            raise DataFileError(f"{path}: channels {seen[c.point_id]} and {c.name} both measure point {c.point_id} "
                                "out of plane: keep one")
        seen[c.point_id] = c.name
    for c in forces + motion:
        check_channel_samples(path, c.name, np.asarray(c.samples))
    return forces[0], motion, notes


def to_lab_rate(rec: Recording, spec: StructureSpec, fe: FEModel, *, path: str, period_s: float,
                band_hz: tuple[float, float], resolution_hz: float) -> LabRate:
    """An acquisition system's recording on the controller's clock (steps 1, 2 and 4 of the module).

    Parameters
    ----------
    rec : Recording
        Any rate, motion channels of any quantity, any out-of-plane sign; SI.
    spec, fe : StructureSpec, FEModel
        The structure (points checked).
    path : str
        The file (for messages).
    period_s : float
        Controller period T [s].
    band_hz : (float, float)
        The structure's band [Hz].
    resolution_hz : float
        Line spacing of the excitation [Hz] (a record of whole periods is resampled periodically).

    Returns
    -------
    LabRate

    Raises
    ------
    DataFileError
        A rate whose Nyquist frequency is not above the band; rates that are not a ratio of small integers; no
        or several force channels, the force not at an actuator, channels at unknown or fixed points, two motion
        channels at one point.
    MeasurementError
        A dead (constant) or clipped channel.
    """
    force, motion, notes = _select(rec, spec, fe, path)
    rate = 1.0 / rec.dt_s
    if rate <= 2.0 * band_hz[1]:
        raise DataFileError(f"{path}: sampled at {rate:.6g} samples/s: the band up to {band_hz[1]:g} Hz needs more "
                            f"than {2 * band_hz[1]:g} samples/s")
    up, down = resampling_ratio(rate, 2.0 / period_s, path)
    periods = rec.duration_s * resolution_hz
    periodic = abs(periods - round(periods)) * rate / resolution_hz < 0.5 and round(periods) >= 1
    sign = {c.name: _OUT_OF_PLANE[c.direction] for c in [force, *motion]}
    f2 = resample(sign[force.name] * np.asarray(force.samples), up, down, periodic=periodic)
    n = f2.size // 2
    signals = {f"force{force.point_id}": f2[1:2 * n:2]}
    kept = []
    for c in motion:
        y = resample(sign[c.name] * np.asarray(c.samples), up, down, periodic=periodic)[0:2 * n:2]
        kept.append(Channel(name=c.name, point_id=c.point_id, quantity=c.quantity, samples=y, direction=3))
        signals[f"vel{c.point_id}"] = velocity_history(c.quantity, y, period_s, 0.5 * band_hz[0])
    err = passband_error(up, down, rate, np.linspace(0.0, band_hz[1], 64))
    notes.append(f"acquired at {rate:.6g} samples/s, resampled to the controller's {1 / period_s:.6g} samples/s "
                 f"(polyphase FIR {up}/{down}, Kaiser beta {KAISER_BETA:g}, passband error {err:.1e} up to "
                 f"{band_hz[1]:g} Hz, {'periodic' if periodic else 'line'} extension at the ends); the force taken "
                 "at the middle of each hold")
    meta = {**dict(rec.metadata), "acquired_rate_hz": rate, "resampled_up_down": [up, down],
            "resampling_passband_error": err}
    lab = Recording.from_signals(period_s, signals, metadata=meta)
    return LabRate(lab, tuple(kept), tuple(notes))


def periodic_within_noise(x: np.ndarray, n_per: int) -> bool:
    """Whether a measured force repeats from its first period to its second within :data:`PERIODIC_NOISE` of
    its RMS (a periodic excitation measured with noise and quantisation).

    Parameters
    ----------
    x : ndarray, shape (n,)
        The force [N].
    n_per : int
        Samples per period of the excitation.

    Returns
    -------
    bool
        False for a record shorter than two periods or a zero force.
    """
    if n_per < 2 or x.size < 2 * n_per:
        return False
    a, b = x[:n_per], x[n_per:2 * n_per]
    rms = float(np.sqrt(np.mean(x[:2 * n_per] ** 2)))
    return rms > 0 and float(np.sqrt(np.mean((a - b) ** 2))) <= PERIODIC_NOISE * rms


def _estimate(args: tuple, x: np.ndarray, n_per: int, estimator: str, settle_s: float, notes: list):
    """The FRF estimate of :func:`frfs_from_acquired` by the estimator asked for
    (:func:`~vlab.diagnose.data.frfestimate.choose_estimator`; a measured force repeats within its noise)."""
    path, fch = args[0], args[1]
    periodic = _is_periodic(x, n_per) or periodic_within_noise(x, n_per)
    how = choose_estimator(x, n_per, estimator, periodic=periodic, path=path, name=fch.name)
    if how == "periodic":  # a resampled force: lines below 1 % of the strongest are not excited
        return _periodic_frfs(*args, settle_s, notes, measured_force=True)
    if how == "transient":
        return _transient_frfs(*args, notes)
    return _h1_frfs(*args, notes)


def frfs_from_acquired(rec: Recording, spec: StructureSpec, fe: FEModel, *, path: str, period_s: float,
                       resolution_hz: float, band_hz: tuple[float, float], settle_s: float = 0.0,
                       estimator: str = "auto") -> FrfData:
    """Velocity FRFs per excitation command, their noise, and the recording on the controller's clock, from an
    acquisition system's recording (the module's steps 1-4).

    Parameters
    ----------
    rec : Recording
        One force channel (the excitation) and motion channels of any quantity, any rate, in SI.
    spec, fe : StructureSpec, FEModel
        The structure.
    path : str
        The file (for messages).
    period_s : float
        Controller period T [s] of the loop the replay runs.
    resolution_hz : float
        Line spacing = 1 / excitation period [Hz].
    band_hz : (float, float)
        Band analysed [Hz].
    settle_s : float
        Time for the transient to decay [s] (periodic excitation: whole periods covering it are dropped).
    estimator : {"auto", "periodic", "h1", "transient"}
        "auto": period by period when the force repeats from one period to the next, exactly or within
        :data:`PERIODIC_NOISE` of its RMS (a periodic excitation measured with noise:
        :func:`periodic_within_noise`), one record per event for an impact or burst force
        (:func:`vlab.measure.impact.is_transient`), else H1 with a Hann window. "periodic": period by period,
        refused for a force that does not repeat. "h1": H1 always (as the lab's own recordings with a noisy
        force channel are analysed; its noise estimate, from the coherence, is about a hundred times larger).
        "transient": one record per event (:func:`vlab.measure.impact.transient_h1`).

    Returns
    -------
    FrfData
        ``h`` [(m/s)/N] and ``var`` on the analysed lines, ``recording`` the :class:`LabRate` recording
        (``force<p>``, ``vel<p>`` at ``period_s``), notes saying what was converted.

    Raises
    ------
    DataFileError, MeasurementError
        As :func:`to_lab_rate`; a record too short for the resolution; an unknown estimator, or "periodic"
        for a force that does not repeat.
    """
    lr = to_lab_rate(rec, spec, fe, path=path, period_s=period_s, band_hz=band_hz, resolution_hz=resolution_hz)
    lab = lr.recording
    notes = list(lr.notes)
    fch = lab.channel(next(n for n in lab.names if n.startswith("force")))
    x = np.asarray(fch.samples)
    n_per = int(round(1.0 / (resolution_hz * period_s)))
    args = (path, fch, list(lr.motion), period_s, n_per, band_hz, resolution_hz)
    e = _estimate(args, x, n_per, estimator, settle_s, notes)
    conv = np.stack([frf_conversion(c.quantity, e.freq, period_s) for c in lr.motion], axis=1)
    h, var = e.h * conv, e.var * np.abs(conv) ** 2
    var_steady = None if e.var_steady is None else e.var_steady * np.abs(conv) ** 2
    kinds = sorted({c.quantity for c in lr.motion})
    notes.append(f"{', '.join(kinds)} FRFs converted to velocity per command at the FRF level (H_v = H_a / (j w), "
                 "H_v = j w H_d; times sinc(f T) for the command's hold)")
    first = int(round(e.t0 / period_s))
    vrms = {c.point_id: float(np.sqrt(np.mean(np.asarray(lab[f"vel{c.point_id}"])[first:] ** 2))) for c in lr.motion}
    outs = tuple(c.point_id for c in lr.motion)
    return FrfData(path, "recording", e.freq, h, var, fch.point_id, outs, e.force_amp, vrms, lab, e.t0, notes,
                   periodic=e.force_amp is not None, var_dof=e.var_dof, var_steady=var_steady, records=e.records)


__all__ = ["is_lab_recording", "resampling_ratio", "resampling_filter", "passband_error", "resample",
           "velocity_history", "frf_conversion", "LabRate", "to_lab_rate", "periodic_within_noise",
           "frfs_from_acquired", "ESTIMATORS", "KAISER_BETA", "HALF_LENGTH", "PASSBAND_ERROR", "PERIODIC_NOISE"]
