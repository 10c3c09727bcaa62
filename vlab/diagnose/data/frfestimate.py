"""FRFs and their noise from a measured recording or from measured FRF files, checked against the structure.

Two inputs:

- UFF 58 time histories (function type 1) as ``vlab experiment`` writes them:
  one force channel (the excitation, node = point id) and velocity channels;
- UFF 58 FRFs (function type 4), optionally with coherence (type 6).

A recording excited by a periodic signal (the lab's pseudo-random multisine)
is analysed period by period: the first periods are dropped while the
transient decays, each remaining period gives a leakage-free FRF at the
excited lines, and their scatter gives the noise of the mean (the
nonparametric noise estimate for periodic excitation, Pintelon & Schoukens,
*System Identification: A Frequency Domain Approach*, 2nd ed., Sec. 2.5 and
6.4). What is left of the transient is estimated from the lines the
excitation does not reach and removed (:mod:`vlab.measure.transient`): on the
lightly damped BCC it biased the lines below mode 1 by several times their noise. Other excitations use the H1 estimator (:func:`vlab.measure.h1`) with
the variance of Bendat & Piersol, *Random Data*, 4th ed., Eq. (9.90):
``var(H) / |H|^2 = (1 - gamma^2) / (2 n_d gamma^2)``.

Errors name the file and the channel: :class:`vlab.errors.DataFileError` for
an unreadable or inconsistent file (unknown point ids, no force channel),
:class:`vlab.errors.MeasurementError` for data that cannot be analysed (NaN,
clipped or dead channels, too short a record).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.ndimage
import scipy.stats

from ...errors import DataFileError, MeasurementError
from ...fe import FEModel
from ...io.recording import CLIP_RUN, Recording, find_clipping
from ...measure.frf import h1
from ...measure.transient import periodic_spectra
from ...spec import StructureSpec
from .measured import FrfData

#: Sampling rates of the PC-1000 digital controller, 2 to 2000 samples per second (Sec. 5.3):
#: a recording at another rate is not a recording of the lab's loop.
PC1000_RATE_HZ = (2.0, 2000.0)


# ----------------------------------------------------------------------------- checks
def check_channel_samples(path: str, name: str, x: np.ndarray) -> None:
    """Raise MeasurementError for NaN, dead (constant) or clipped samples of one channel.

    Clipping: more than :data:`CLIP_RUN` consecutive samples exactly at the
    channel's maximum or minimum, or more than 2 % of them there
    (:func:`vlab.io.recording.find_clipping`: a saturated amplifier or ADC
    holds its limit; a smooth signal sampled at 2 kHz does not repeat its
    extreme).

    Raises
    ------
    MeasurementError
        Naming ``path`` and ``name``.
    """
    bad = np.flatnonzero(~np.isfinite(x))
    if bad.size:
        raise MeasurementError(f"{path}: channel {name}: non-finite sample at index {bad[0]}")
    if x.size == 0 or np.ptp(x) == 0.0:
        raise MeasurementError(f"{path}: channel {name}: constant signal (dead sensor or disconnected channel)")
    clip = find_clipping(x, CLIP_RUN + 1)
    if clip is not None:
        run, start, word, ext, count = clip
        raise MeasurementError(
            f"{path}: channel {name}: clipped: {count} samples at its {word} {ext:.6g}, {run} consecutive "
            f"from index {start} (saturated amplifier or ADC range)")


#: At most this many samples of two periods of a force may differ for them to be read as one periodic
#: excitation with corrupted samples (rather than a non-periodic excitation).
CORRUPT_AT_MOST = 8


def check_force_repeats(path: str, name: str, xp: np.ndarray, first: int, *, nearly_only: bool = False) -> None:
    """Raise MeasurementError where a periodic excitation's force does not repeat from period to period.

    The force of a periodic excitation (a generated signal, recognised by its
    first two periods repeating exactly) repeats exactly in every period; a
    sample that differs is corrupted, typically a NaN or Inf that the file's
    writer replaced by a number (pyuff writes NaN as 0 and Inf as the largest
    double), which would otherwise be analysed as data. With ``nearly_only``
    (periods that do not repeat: a non-periodic excitation, or a periodic one
    with corrupted samples) only periods that repeat but for at most
    :data:`CORRUPT_AT_MOST` samples are refused.

    Parameters
    ----------
    path : str
        The recording (for messages).
    name : str
        The force channel's name.
    xp : ndarray, shape (m, n_per)
        The analysed periods of the force [N].
    first : int
        Index in the channel of ``xp[0, 0]`` (for messages).
    nearly_only : bool
        Refuse only when at most :data:`CORRUPT_AT_MOST` samples differ.

    Raises
    ------
    MeasurementError
        Naming the channel, the sample index and both values.
    """
    m = xp.shape[0]
    if m < 2:
        return
    ref = np.median(xp, axis=0) if m >= 3 else xp[0]
    tol = 1e-9 * max(float(np.max(np.abs(ref))), 1e-300)
    bad = np.argwhere(np.abs(xp - ref) > tol)
    if bad.size and not (nearly_only and bad.shape[0] > CORRUPT_AT_MOST):
        k, j = (int(v) for v in bad[0])
        n = xp.shape[1]
        what = (f"sample {first + k * n + j} (period {k + 1} of {m}) is {xp[k, j]:.6g} N where the other periods "
                f"hold {ref[j]:.6g} N" if m >= 3 else
                f"samples {first + j} and {first + n + j} (periods 1 and 2) are {xp[0, j]:.6g} N and "
                f"{xp[1, j]:.6g} N")
        raise MeasurementError(
            f"{path}: channel {name}: {what}: a periodic excitation repeats exactly, so a sample was corrupted "
            f"(a NaN or Inf that the file's writer replaced by a number?); {bad.shape[0]} sample(s) differ")


def _check_points(path: str, spec: StructureSpec, fe: FEModel, items: list[tuple[str, int]]) -> None:
    for name, p in items:
        if p not in spec.points:
            raise DataFileError(f"{path}: channel {name}: point id {p} is not a point of the structure "
                                f"{spec.name!r} (points: {sorted(spec.points)})")
        if (p, "w") not in fe.dofs:
            raise DataFileError(f"{path}: channel {name}: point {p} of {spec.name!r} is fixed out of plane "
                                "(a support): nothing to measure there")


# ----------------------------------------------------------------------------- recordings
def _is_periodic(x: np.ndarray, n: int) -> bool:
    if n < 2 or x.size < 2 * n:
        return False
    a, b = x[:n], x[n:2 * n]
    return bool(np.max(np.abs(a - b)) <= 1e-9 * max(np.max(np.abs(a)), 1e-300))


#: Lines in the running median that pools the per-line variance estimates.
POOL_WIDTH = 21


def _pooled_variance(own: np.ndarray, dof: int, width: int = POOL_WIDTH) -> np.ndarray:
    """Running-median pooling of per-line variance estimates with ``dof`` real degrees of freedom, shape
    (n_lines, n_channels): each line takes the median of the ``width`` lines centred on it, or, within half
    a window of the band's edge, of the first or last ``width`` lines (every pool holds ``width`` distinct
    lines; all of them when there are fewer), divided by the median of chi-square(``dof``) / ``dof``."""
    med = scipy.stats.chi2.median(dof) / dof
    n = own.shape[0]
    if n <= width:
        return np.broadcast_to(np.median(own, axis=0), own.shape) / med
    pooled = scipy.ndimage.median_filter(own, size=(width, 1), mode="nearest")
    half = width // 2
    pooled[:half] = np.median(own[:width], axis=0)
    pooled[n - (width - 1 - half):] = np.median(own[n - width:], axis=0)
    return pooled / med


def pooled_dof(dof: int, width: int = POOL_WIDTH) -> float:
    """Effective degrees of freedom of a variance pooled by the running median of ``width`` estimates with
    ``dof`` real degrees of freedom each.

    Each estimate is ``sigma^2 X / dof`` with ``X`` chi-square(``dof``); the sample median of ``n`` draws of a
    density ``f`` with median ``q`` has the asymptotic variance ``1 / (4 n f(q)^2)`` (Kendall & Stuart,
    *The Advanced Theory of Statistics*, vol. 1, Sec. 10.10), so the pooled estimate, divided by ``q``, has
    the relative variance ``1 / (4 n f(q)^2 q^2)``; a chi-square estimate with ``nu`` degrees of freedom has
    ``2 / nu``. Hence ``nu = 8 n f(q)^2 q^2`` for ``X / dof``: ``2 n ln(2)^2`` (20.2 for 21 lines) for
    ``dof`` = 2, approaching ``(2 / pi) n dof`` (the normal's efficiency) as ``dof`` grows.

    Parameters
    ----------
    dof : int
        Real degrees of freedom of each per-line estimate (``2 (m - 1)`` from ``m`` periods), >= 1.
    width : int
        Lines pooled.

    Returns
    -------
    float
        Effective real degrees of freedom of the pooled variance.
    """
    dist = scipy.stats.chi2(dof, scale=1.0 / dof)
    q = dist.median()
    return float(8.0 * width * dist.pdf(q) ** 2 * q**2)


def _check_recording(rec: Recording, spec: StructureSpec, fe: FEModel, path: str) -> tuple:
    """The force channel and the velocity channels of a recording, checked (see :func:`frfs_from_recording`)."""
    rate = 1.0 / rec.dt_s
    if not PC1000_RATE_HZ[0] * (1 - 1e-9) <= rate <= PC1000_RATE_HZ[1] * (1 + 1e-9):
        raise DataFileError(f"{path}: sampled at {rate:.6g} samples/s (dt {rec.dt_s!r} s); the lab's PC-1000 "
                            f"samples at {PC1000_RATE_HZ[0]:g} to {PC1000_RATE_HZ[1]:g} samples/s (Sec. 5.3): "
                            "a mis-sampled recording")
    forces = [c for c in rec.channels if c.quantity == "force"]
    if len(forces) != 1:
        raise DataFileError(f"{path}: expected exactly one force channel (the excitation), found "
                            f"{[c.name for c in forces] or 'none'}")
    fch = forces[0]
    vels = [c for c in rec.channels if c.quantity != "force"]
    if not vels:
        raise DataFileError(f"{path}: no response channel besides {fch.name}")
    for c in vels:
        if c.quantity != "velocity":
            raise DataFileError(f"{path}: channel {c.name}: {c.quantity} channels are not supported; "
                                "record velocities (m/s) as the lab's sensors do")
        if c.direction != 3:
            raise DataFileError(f"{path}: channel {c.name}: direction {c.direction}; only out-of-plane (3) is modelled")
    _check_points(path, spec, fe, [(c.name, c.point_id) for c in rec.channels])
    acts = tuple(spec.instrumentation.actuators)
    if fch.point_id not in acts:
        raise DataFileError(f"{path}: channel {fch.name}: the excitation at point {fch.point_id} is not at an "
                            f"actuator of {spec.name!r} {acts} (the lab excites through a coil)")
    for c in rec.channels:
        check_channel_samples(path, c.name, np.asarray(c.samples))
    dups = [p for p in {c.point_id for c in vels} if sum(c.point_id == p for c in vels) > 1]
    if dups:
        raise DataFileError(f"{path}: several velocity channels at point {dups[0]}")
    return fch, vels


@dataclass(frozen=True)
class _Estimate:
    """FRFs on the analysed lines and their noise, as one estimator gives them (fields of :class:`FrfData`)."""

    freq: np.ndarray
    h: np.ndarray
    var: np.ndarray
    var_dof: float | None
    var_steady: np.ndarray | None
    force_amp: np.ndarray | None
    vrms: dict
    t0: float
    records: tuple | None = None


#: A measured force's lines this far below its strongest line in the band are taken as not excited (its noise
#: floor; 40 dB): a generated force's non-excited lines are exact zeros, found below 1e-6 of the strongest.
MEASURED_LINE_FLOOR = 1e-2


def _periodic_frfs(path: str, fch, vels: list, dt: float, n_per: int, band_hz: tuple, resolution_hz: float,
                   settle_s: float, notes: list, *, measured_force: bool = False) -> _Estimate:
    """Period-by-period FRFs of a periodic excitation, the transient left removed, noise from the scatter.

    ``measured_force``: the force channel is a measurement (noise, quantisation) rather than the generated
    command: its periods are not checked for exact repetition, and lines below :data:`MEASURED_LINE_FLOOR`
    of the strongest are not excited."""
    x = np.asarray(fch.samples)
    lo, hi = band_hz
    n_periods = x.size // n_per
    need = max(1, math.ceil(settle_s / (n_per * dt) - 1e-9))
    skip = need if n_periods - need >= 2 else max(1, min(need, n_periods - 2 if n_periods >= 3 else 1))
    if skip < need:
        notes.append(f"the record holds {n_periods} periods of {n_per * dt:g} s; the transient needs about "
                     f"{settle_s:.0f} s to decay, {skip} period(s) were dropped: lightly damped modes may "
                     "still carry some transient (its period-to-period change counts as noise)")
    m = n_periods - skip
    if m < 1:
        raise MeasurementError(
            f"{path}: channel {fch.name}: record of {x.size * dt:g} s holds {n_periods} period(s) of the "
            f"{resolution_hz:g} Hz excitation; the analysis needs one to settle and one to measure "
            f"({2 * n_per * dt:g} s)")
    if not measured_force:
        check_force_repeats(path, fch.name, x[:n_periods * n_per].reshape(n_periods, n_per), 0)
    seg = slice(skip * n_per, (skip + m) * n_per)
    xp = x[seg].reshape(m, n_per)
    X = np.fft.rfft(xp, axis=1)
    f_all = np.fft.rfftfreq(n_per, dt)
    amp = np.abs(X[-1])
    in_band = (f_all >= lo - 1e-9) & (f_all <= hi + 1e-9)
    floor = MEASURED_LINE_FLOOR * amp[in_band].max(initial=0.0) if measured_force else 1e-6 * amp.max()
    lines = np.flatnonzero((amp > floor) & in_band)
    if lines.size < 3:
        raise MeasurementError(f"{path}: channel {fch.name}: fewer than three excited lines in {band_hz} Hz")
    hp = np.empty((m, lines.size, len(vels)), dtype=complex)
    for j, c in enumerate(vels):
        yp = np.asarray(c.samples)[seg].reshape(m, n_per)
        hp[:, :, j] = np.fft.rfft(yp, axis=1)[:, lines] / X[:, lines]
    h = hp.mean(axis=0)
    if m >= 2:
        own = np.sum(np.abs(hp - h) ** 2, axis=0) / (m - 1) / m
        dof = 2 * (m - 1)
        # the transient left after the dropped periods leaks into every line alike in each period: it is
        # estimated from the non-excited bins of the analysed block and removed (vlab.measure.transient)
        ps = periodic_spectra(np.stack([np.asarray(c.samples)[seg] for c in vels], axis=1), n_per, lines)
        xm = X[:, lines].mean(axis=0)[:, None]
        h = ps.y / xm
        var_steady = np.maximum(_pooled_variance(own, dof), own)
        var = np.maximum(var_steady, ps.noise_var / np.abs(xm) ** 2)
        var_dof = pooled_dof(dof, min(POOL_WIDTH, len(lines)))
        notes.append(f"periodic excitation: {m} period(s) of {n_per * dt:g} s analysed after dropping {skip}; "
                     "the transient left removed by the local polynomial method; noise from the "
                     "period-to-period scatter and the non-excited lines")
    else:
        var = np.zeros_like(h.real)
        var_dof = var_steady = None
        notes.append(f"periodic excitation: one period analysed after dropping {skip}; no noise estimate "
                     "(needs two): the model-error floor alone sets the weights")
    vrms = {c.point_id: float(np.sqrt(np.mean(np.asarray(c.samples)[seg] ** 2))) for c in vels}
    return _Estimate(f_all[lines], h, var, var_dof, var_steady, 2.0 * amp[lines] / n_per, vrms, skip * n_per * dt)


def _h1_frfs(path: str, fch, vels: list, dt: float, n_per: int, band_hz: tuple, resolution_hz: float,
             notes: list) -> _Estimate:
    """H1 FRFs (Hann window, averaged blocks) of a non-periodic excitation, noise from the coherence."""
    x = np.asarray(fch.samples)
    lo, hi = band_hz
    if x.size < 2 * n_per:
        raise MeasurementError(
            f"{path}: channel {fch.name}: record of {x.size * dt:g} s is too short for a {resolution_hz:g} Hz "
            f"resolution with averaging (needs at least {2 * n_per * dt:g} s)")
    hs, cs = [], []
    n_avg = 1
    for c in vels:
        frf = h1(x, np.asarray(c.samples), dt_s=dt, resolution_hz=resolution_hz, window="hann",
                 input_name=fch.name, output_name=c.name)
        hs.append(frf.h)
        cs.append(frf.coherence)
        n_avg = frf.n_averages or 1
        f_all = frf.freq_hz
    sel = (f_all >= lo) & (f_all <= hi) & (f_all > 0)
    h = np.array(hs).T[sel]
    coh = np.clip(np.array(cs).T[sel], 1e-6, 1.0)
    var = np.abs(h) ** 2 * (1 - coh) / (2 * n_avg * coh)
    vrms = {c.point_id: float(np.sqrt(np.mean(np.asarray(c.samples) ** 2))) for c in vels}
    notes.append(f"non-periodic excitation: H1 with Hann window, {n_avg} averages; noise from coherence")
    return _Estimate(f_all[sel], h, var, None, None, None, vrms, 0.0)


def _transient_frfs(path: str, fch, vels: list, dt: float, n_per: int, band_hz: tuple, resolution_hz: float,
                    notes: list) -> _Estimate:
    """H1 FRFs of an impact or burst excitation, one record per event (:func:`vlab.measure.impact.transient_h1`),
    noise from the coherence."""
    from ...measure.impact import transient_h1

    try:
        e = transient_h1(np.asarray(fch.samples), np.stack([np.asarray(c.samples) for c in vels], axis=1), dt_s=dt,
                         resolution_hz=resolution_hz, names=tuple(c.name for c in vels))
    except MeasurementError as exc:
        raise MeasurementError(f"{path}: channel {fch.name}: {exc}") from None
    lo, hi = band_hz
    sel = (e.freq_hz >= lo) & (e.freq_hz <= hi) & (e.freq_hz > 0)
    h, coh = e.h[sel], np.clip(e.coherence[sel], 1e-6, 1.0)
    n_e = len(e.starts)
    var = np.abs(h) ** 2 * (1 - coh) / (2 * n_e * coh)
    vrms = {c.point_id: float(np.sqrt(np.mean(np.asarray(c.samples) ** 2))) for c in vels}
    notes.append(f"transient excitation (impact or burst): H1 over {n_e} records of {n_per * dt:g} s, one per event "
                 f"(force window {e.force_end * dt * 1e3:.3g} ms, responses decayed to {e.decay.max():.2g} of their "
                 "RMS); noise from coherence")
    return _Estimate(e.freq_hz[sel], h, var, None, None, None, vrms, 0.0, (e.starts, e.force_end))


#: FRF estimators of a recording: ``auto`` chooses by the force (:func:`choose_estimator`).
ESTIMATORS = ("auto", "periodic", "h1", "transient")


def choose_estimator(x: np.ndarray, n_per: int, estimator: str, *, periodic: bool, path: str, name: str) -> str:
    """The estimator of a recording's FRFs: the one asked for, or ``auto``'s choice -- ``periodic`` for a force
    that repeats from period to period, ``transient`` for an impact or burst force (quiet most of the time,
    :func:`vlab.measure.impact.is_transient`), else ``h1`` (H1 with a Hann window, random excitation).

    Parameters
    ----------
    x : ndarray, shape (n,)
        The force [N].
    n_per : int
        Samples per period (per record).
    estimator : {"auto", "periodic", "h1", "transient"}
    periodic : bool
        The force repeats from one period to the next (exactly, or within its noise).
    path, name : str
        File and force channel (for messages).

    Returns
    -------
    str
        "periodic", "h1" or "transient".

    Raises
    ------
    DataFileError
        An unknown estimator; "periodic" for a force that does not repeat.
    """
    from ...measure.impact import is_transient

    if estimator not in ESTIMATORS:
        raise DataFileError(f"{path}: FRF estimator {estimator!r}: use one of {', '.join(ESTIMATORS)}")
    if estimator == "periodic" and not periodic:
        raise DataFileError(f"{path}: channel {name}: the force does not repeat from one period to the next: not a "
                            "periodic excitation (use the h1 or transient estimator)")
    if estimator != "auto":
        return estimator
    return "periodic" if periodic else "transient" if is_transient(x) else "h1"


def frfs_from_recording(rec: Recording, spec: StructureSpec, fe: FEModel, *, path: str,
                        resolution_hz: float, band_hz: tuple[float, float], settle_s: float = 0.0,
                        estimator: str = "auto") -> FrfData:
    """FRFs, their noise, force spectrum and velocity RMS from a recording.

    Parameters
    ----------
    rec : Recording
        One force channel (the excitation) and velocity channels.
    spec, fe : StructureSpec, FEModel
        The structure (point ids are checked against it).
    path : str
        File name for messages.
    resolution_hz : float
        Line spacing = 1 / period of the excitation [Hz].
    band_hz : (float, float)
        Band analysed [Hz].
    settle_s : float
        Time for the transient to decay [s]; whole periods covering it are
        dropped (at least one), keeping two periods for the noise estimate
        when the record allows.
    estimator : {"auto", "periodic", "h1", "transient"}
        How the FRFs are estimated (:func:`choose_estimator`).

    Returns
    -------
    FrfData

    Raises
    ------
    DataFileError
        A sampling rate outside the PC-1000's 2-2000 samples/s
        (:data:`PC1000_RATE_HZ`, Sec. 5.3), no or several force channels, a
        channel at an unknown or fixed point, the force not at an actuator,
        channels other than force/velocity.
    MeasurementError
        NaN, dead or clipped channel; a periodic excitation whose force does not
        repeat in the analysed periods (:func:`check_force_repeats`); record shorter than two periods
        (periodic excitation) or one block (other excitation).
    """
    fch, vels = _check_recording(rec, spec, fe, path)
    x = np.asarray(fch.samples)
    dt = rec.dt_s
    n_per = int(round(1.0 / (resolution_hz * dt)))
    notes = []
    outs = tuple(c.point_id for c in vels)
    periodic = _is_periodic(x, n_per)
    how = choose_estimator(x, n_per, estimator, periodic=periodic, path=path, name=fch.name)
    if how == "periodic":
        e = _periodic_frfs(path, fch, vels, dt, n_per, band_hz, resolution_hz, settle_s, notes)
    elif how == "transient":
        e = _transient_frfs(path, fch, vels, dt, n_per, band_hz, resolution_hz, notes)
    else:
        if x.size >= 2 * n_per:
            check_force_repeats(path, fch.name, x[:2 * n_per].reshape(2, n_per), 0, nearly_only=True)
        e = _h1_frfs(path, fch, vels, dt, n_per, band_hz, resolution_hz, notes)
    return FrfData(path, "recording", e.freq, e.h, e.var, fch.point_id, outs, e.force_amp, e.vrms, rec, e.t0, notes,
                   periodic=e.force_amp is not None, var_dof=e.var_dof, var_steady=e.var_steady, records=e.records)


# ----------------------------------------------------------------------------- FRF files
def frfs_from_uff(frfs: list, spec: StructureSpec, fe: FEModel, *, path: str,
                  band_hz: tuple[float, float]) -> FrfData:
    """Stack UFF FRFs (one excitation point, common frequency axis) into :class:`FrfData`.

    Displacement and acceleration FRFs are converted to velocity. The
    variance comes from the coherence and the number of averages when the
    file has them (Bendat & Piersol Eq. 9.90), else it is left to the
    model-error floor.

    Parameters
    ----------
    frfs : list of FRF
        As read by :func:`vlab.io.uff.read_frfs`.
    spec, fe, path
        As :func:`frfs_from_recording`.
    band_hz : (float, float)
        Band kept [Hz].

    Raises
    ------
    DataFileError
        Several excitation points, different frequency axes, unknown or fixed
        points, two FRFs at one output point.
    """
    inputs = {f.input_point for f in frfs}
    if len(inputs) != 1:
        raise DataFileError(f"{path}: FRFs from several excitation points {sorted(inputs)}; give one reference")
    exc = inputs.pop()
    _check_points(path, spec, fe, [(f.name, f.output_point) for f in frfs] + [(frfs[0].input_name, exc)])
    acts = tuple(spec.instrumentation.actuators)
    if exc not in acts:
        raise DataFileError(f"{path}: FRF {frfs[0].name}: the excitation at point {exc} is not at an actuator {acts}")
    f0 = frfs[0].freq_hz
    outs = []
    hs, vs = [], []
    notes = []
    for f in frfs:
        if f.freq_hz.shape != f0.shape or not np.allclose(f.freq_hz, f0, rtol=1e-9, atol=1e-12):
            raise DataFileError(f"{path}: FRF {f.name}: frequency axis differs from FRF {frfs[0].name}")
        if f.output_point in outs:
            raise DataFileError(f"{path}: FRF {f.name}: a second FRF at point {f.output_point}")
        outs.append(f.output_point)
        v = f.to_velocity() if f.response != "velocity" else f
        hs.append(v.h)
        if f.coherence is not None and f.n_averages:
            coh = np.clip(f.coherence, 1e-6, 1.0)
            vs.append(np.abs(v.h) ** 2 * (1 - coh) / (2 * f.n_averages * coh))
        else:
            vs.append(np.zeros(f0.shape))
    if any(not np.any(v) for v in vs):
        notes.append("no coherence/averages in the file: the model-error floor alone sets the weights")
    sel = (f0 >= band_hz[0]) & (f0 <= band_hz[1]) & (f0 > 0)
    h = np.array(hs).T[sel]
    var = np.array(vs).T[sel]
    for j, p in enumerate(outs):
        bad = np.flatnonzero(~np.isfinite(h[:, j]))
        if bad.size:
            raise MeasurementError(f"{path}: FRF at point {p}: non-finite value at {f0[sel][bad[0]]:g} Hz")
    return FrfData(path, "frf", f0[sel], h, var, exc, tuple(outs), None, {}, None, 0.0, notes, periodic=False)
