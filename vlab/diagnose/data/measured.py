"""Measured data for a diagnosis: recordings, FRFs or modal tables, checked and turned into FRFs.

Three inputs:

- UFF 58 time histories (function type 1) as ``vlab experiment`` writes them:
  one force channel (the excitation, node = point id) and velocity channels;
- UFF 58 FRFs (function type 4), optionally with coherence (type 6);
- a CSV modal table: ``mode``, ``frequency_hz``, ``damping_ratio`` and
  optional shape columns ``shape_<point>`` (aliases: the dissertation's
  ``experimental_hz`` and ``damping_experimental`` of Table 3; ``#`` lines
  are comments).

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
an unreadable or inconsistent file (unknown point ids, no force channel,
malformed CSV), :class:`vlab.errors.MeasurementError` for data that cannot be
analysed (NaN, clipped or dead channels, too short a record).
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import scipy.ndimage
import scipy.stats

from ...errors import DataFileError, MeasurementError, VlabError
from ...fe import FEModel
from ...lab.experiment import test_definition
from ...lab.recording import CLIP_RUN, Recording, find_clipping
from ...measure.frf import h1
from ...measure.transient import periodic_spectra
from ...spec import StructureSpec
from ..model.modelform import printed_resolution

#: Sampling rates of the PC-1000 digital controller, 2 to 2000 samples per second (Sec. 5.3):
#: a recording at another rate is not a recording of the lab's loop.
PC1000_RATE_HZ = (2.0, 2000.0)
#: Lines whose relative noise exceeds this (SNR below ~2) are not used.
MAX_RELATIVE_NOISE = 0.5


@dataclass(frozen=True)
class FrfData:
    """Measured FRFs from one excitation point to several velocity outputs.

    Attributes
    ----------
    source : str
        File the data came from.
    kind : {"recording", "frf"}
    freq_hz : ndarray, shape (n_f,)
        Lines [Hz].
    h : ndarray, complex, shape (n_f, n_o)
        Velocity per force [(m/s)/N].
    var : ndarray, shape (n_f, n_o)
        Variance of ``h`` (complex: ``E|h - h_true|^2``) [((m/s)/N)^2].
    excitation_point : int
    output_points : tuple of int, length n_o
    force_amplitude : ndarray, shape (n_f,) or None
        One-sided amplitude of the excitation at each line [N] (recordings).
    velocity_rms : dict
        Output point -> RMS velocity [m/s] over the analysed periods (recordings).
    recording : Recording or None
        The time histories (recordings).
    analysed_from_s : float
        Start of the analysed part of the recording [s] (transient dropped).
    notes : list of str
        What was assumed on the way (resolution, settling, noise estimate).
    periodic : bool
        Estimated period by period (periodic excitation) rather than by H1 with a Hann window.
    h_recorded : ndarray, complex, shape (n_f, n_o) or None
        The FRFs as recorded when ``h`` has been referred to the model through a
        baseline recording (:func:`refer_to_model`); None otherwise.
    var_recorded : ndarray, shape (n_f, n_o) or None
        The variance of ``h_recorded`` (the recording's own noise) [((m/s)/N)^2].
    var_baseline : ndarray, shape (n_f, n_o) or None
        The variance of the baseline's FRFs (its own noise) when ``h`` has been
        referred through a baseline [((m/s)/N)^2]; None otherwise.
    var_dof : float or None
        Effective real degrees of freedom of ``var`` when it is estimated from
        the data (period-to-period scatter, pooled over neighbouring lines:
        :func:`pooled_dof`); None when it is taken as known.
    var_steady : ndarray, shape (n_f, n_o) or None
        A periodic recording's variance without the uncertainty of the transient's removal
        (:mod:`vlab.measure.transient`), which ``var`` includes [((m/s)/N)^2]: what is left when the
        reference carries the same transient (``same_transient``); None otherwise.
    same_transient : bool
        This FrfData is a reference replayed from rest through the recording's own periods: it carries the
        recording's transient, which then cancels in :func:`refer_to_model`.
    """

    source: str
    kind: str
    freq_hz: np.ndarray
    h: np.ndarray
    var: np.ndarray
    excitation_point: int
    output_points: tuple[int, ...]
    force_amplitude: np.ndarray | None = None
    velocity_rms: dict = field(default_factory=dict)
    recording: Recording | None = None
    analysed_from_s: float = 0.0
    notes: list = field(default_factory=list)
    periodic: bool = True
    h_recorded: np.ndarray | None = None
    var_recorded: np.ndarray | None = None
    var_baseline: np.ndarray | None = None
    var_dof: float | None = None
    var_steady: np.ndarray | None = None
    same_transient: bool = False

    @property
    def sigma_rel(self) -> np.ndarray:
        """Relative standard deviation ``sqrt(var) / |h|``, shape (n_f, n_o)."""
        return np.sqrt(self.var) / np.maximum(np.abs(self.h), 1e-300)


@dataclass(frozen=True)
class ModalData:
    """A measured modal table.

    Attributes
    ----------
    source : str
    modes : ndarray of int, shape (n_m,)
        Mode numbers as given.
    freq_hz : ndarray, shape (n_m,)
        Natural frequencies [Hz].
    damping : ndarray, shape (n_m,)
        Damping ratios (NaN where not given).
    shapes : ndarray, shape (n_p, n_m) or None
        Mode shapes at ``shape_points``.
    shape_points : tuple of int
    notes : list of str
    kind : str
        Always ``"modal"``.
    freq_sigma_hz : ndarray, shape (n_m,) or None
        Standard uncertainty of each frequency [Hz] (column ``frequency_sigma_hz``; NaN where blank).
    damping_sigma : ndarray, shape (n_m,) or None
        Standard uncertainty of each damping ratio [-] (column ``damping_sigma``; NaN where blank).
    freq_resolution_hz : ndarray, shape (n_m,) or None
        The resolution each frequency is printed to [Hz] (one unit in its last digit,
        :func:`vlab.diagnose.model.modelform.printed_resolution`).
    damping_resolution : ndarray, shape (n_m,) or None
        The resolution each damping ratio is printed to [-] (NaN where not given).
    reference_hz : ndarray, shape (n_m,) or None
        A reference model's frequency of each mode [Hz] (the column named by
        ``reference_column`` of :func:`read_modal_csv`, e.g. a published
        analysis): the data are then compared with it, vlab's model predicting
        only what a change does (:meth:`vlab.diagnose.problem.residuals.Problem`).
    reference_resolution_hz : ndarray, shape (n_m,) or None
        The resolution the reference frequencies are printed to [Hz].
    reference_column : str or None
        The column ``reference_hz`` came from (kept when the table has been referred, and
        ``reference_hz`` set to None).
    """

    source: str
    modes: np.ndarray
    freq_hz: np.ndarray
    damping: np.ndarray
    shapes: np.ndarray | None = None
    shape_points: tuple[int, ...] = ()
    notes: list = field(default_factory=list)
    kind: str = "modal"
    freq_sigma_hz: np.ndarray | None = None
    damping_sigma: np.ndarray | None = None
    freq_resolution_hz: np.ndarray | None = None
    damping_resolution: np.ndarray | None = None
    reference_hz: np.ndarray | None = None
    reference_resolution_hz: np.ndarray | None = None
    reference_column: str | None = None


# ----------------------------------------------------------------------------- checks
def check_channel_samples(path: str, name: str, x: np.ndarray) -> None:
    """Raise MeasurementError for NaN, dead (constant) or clipped samples of one channel.

    Clipping: more than :data:`CLIP_RUN` consecutive samples exactly at the
    channel's maximum or minimum, or more than 2 % of them there
    (:func:`vlab.lab.recording.find_clipping`: a saturated amplifier or ADC
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
    """Running-median pooling of per-line variance estimates with ``dof`` real degrees of freedom."""
    med = scipy.stats.chi2.median(dof) / dof
    pooled = scipy.ndimage.median_filter(own, size=(width, 1), mode="nearest") / med
    return pooled


def pooled_dof(dof: int, width: int = POOL_WIDTH) -> float:
    """Effective degrees of freedom of a variance pooled by the running median of ``width`` estimates with
    ``dof`` real degrees of freedom each: ``(2 / pi) width dof``, the large-sample efficiency of the median
    against the mean (Kendall & Stuart, *The Advanced Theory of Statistics*, vol. 1, Sec. 10.10).

    Parameters
    ----------
    dof : int
        Real degrees of freedom of each per-line estimate (``2 (m - 1)`` from ``m`` periods).
    width : int
        Lines pooled.

    Returns
    -------
    float
        Effective real degrees of freedom of the pooled variance (27 for ``dof`` = 2, ``width`` = 21).
    """
    return 2.0 / math.pi * width * dof


def frfs_from_recording(rec: Recording, spec: StructureSpec, fe: FEModel, *, path: str,
                        resolution_hz: float, band_hz: tuple[float, float], settle_s: float = 0.0) -> FrfData:
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
    x = np.asarray(fch.samples)
    dt = rec.dt_s
    n_per = int(round(1.0 / (resolution_hz * dt)))
    notes = []
    lo, hi = band_hz
    outs = tuple(c.point_id for c in vels)
    if not _is_periodic(x, n_per) and x.size >= 2 * n_per:
        check_force_repeats(path, fch.name, x[:2 * n_per].reshape(2, n_per), 0, nearly_only=True)
    if _is_periodic(x, n_per):
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
        check_force_repeats(path, fch.name, x[:n_periods * n_per].reshape(n_periods, n_per), 0)
        seg = slice(skip * n_per, (skip + m) * n_per)
        xp = x[seg].reshape(m, n_per)
        X = np.fft.rfft(xp, axis=1)
        f_all = np.fft.rfftfreq(n_per, dt)
        amp = np.abs(X[-1])
        lines = np.flatnonzero((amp > 1e-6 * amp.max()) & (f_all >= lo - 1e-9) & (f_all <= hi + 1e-9))
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
            var_dof = pooled_dof(dof)
            notes.append(f"periodic excitation: {m} period(s) of {n_per * dt:g} s analysed after dropping {skip}; "
                         "the transient left removed by the local polynomial method; noise from the "
                         "period-to-period scatter and the non-excited lines")
        else:
            var = np.zeros_like(h.real)
            var_dof = var_steady = None
            notes.append(f"periodic excitation: one period analysed after dropping {skip}; no noise estimate "
                         "(needs two): the model-error floor alone sets the weights")
        freq = f_all[lines]
        force_amp = 2.0 * amp[lines] / n_per
        vrms = {c.point_id: float(np.sqrt(np.mean(np.asarray(c.samples)[seg] ** 2))) for c in vels}
        t0 = skip * n_per * dt
    else:
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
        freq = f_all[sel]
        h = np.array(hs).T[sel]
        coh = np.clip(np.array(cs).T[sel], 1e-6, 1.0)
        var = np.abs(h) ** 2 * (1 - coh) / (2 * n_avg * coh)
        var_dof = var_steady = None
        force_amp = None
        vrms = {c.point_id: float(np.sqrt(np.mean(np.asarray(c.samples) ** 2))) for c in vels}
        notes.append(f"non-periodic excitation: H1 with Hann window, {n_avg} averages; noise from coherence")
        t0 = 0.0
    return FrfData(path, "recording", freq, h, var, fch.point_id, outs, force_amp, vrms, rec, t0, notes,
                   periodic=force_amp is not None, var_dof=var_dof, var_steady=var_steady)


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
    spec : StructureSpec
    fe : FEModel
        The structure (point ids are checked against it).
    path : str
        File name for messages.
    band_hz : (float, float)
        Band kept [Hz].

    Returns
    -------
    FrfData

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


# ----------------------------------------------------------------------------- modal CSV
_FREQ = ("frequency_hz", "experimental_hz", "freq_hz", "frequency")
_DAMP = ("damping_ratio", "damping_experimental", "zeta", "damping")
#: Highest natural frequency a measured modal table may hold [Hz]: the Nyquist
#: frequency of the PC-1000 at its fastest rate, 2000 samples/s (Sec. 5.3).
MAX_MODAL_FREQUENCY_HZ = 1000.0


def read_modal_csv(path: str | Path, spec: StructureSpec, *, reference_column: str | None = None) -> ModalData:
    """Read a modal table (CSV) and check it against the structure.

    Columns: ``mode`` (positive integers), a frequency column
    (``frequency_hz`` or ``experimental_hz``) [Hz], optional damping
    (``damping_ratio`` or ``damping_experimental``), optional shape columns
    ``shape_<point id>`` (or ``phi_<point id>``), optional standard
    uncertainties ``frequency_sigma_hz`` [Hz] and ``damping_sigma`` [-]
    (non-negative; blank = not given). Lines starting with ``#`` are
    comments; other columns are ignored (and listed in the notes). The file
    may start with a UTF-8 byte-order mark.

    Parameters
    ----------
    path : str or Path
        The CSV file.
    spec : StructureSpec
        The structure (shape point ids are checked against it).
    reference_column : str, optional
        A column of reference-model frequencies [Hz] (e.g. ``analytical_hz``, the
        published analysis the measurement was compared with): read into
        ``reference_hz``; every row must have a positive value.

    Returns
    -------
    ModalData
        Sorted by frequency.

    Raises
    ------
    DataFileError
        Missing file or column, a file that is not UTF-8, a repeated or empty
        column name, a row with the wrong number of fields, a non-numeric or
        non-finite value, a non-positive frequency or one above
        :data:`MAX_MODAL_FREQUENCY_HZ` (1000 Hz), a damping ratio outside
        [0, 1), a negative uncertainty, repeated mode numbers or
        frequencies, a shape column for a point the structure does not have,
        a shape that is zero at every point. The message names the file,
        line and column and the value.
    """
    p = Path(path)
    if not p.is_file():
        raise DataFileError(f"{p}: no such file")
    try:
        raw = p.read_bytes()
    except OSError as exc:
        raise DataFileError(f"{p}: unreadable: {exc}") from None
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = raw[:exc.start].count(b"\n") + 1
        raise DataFileError(f"{p}: line {line}: not UTF-8 text (byte {raw[exc.start:exc.start + 1]!r} at offset "
                            f"{exc.start})") from None
    if "\x00" in text:
        raise DataFileError(f"{p}: line {text[:text.index(chr(0))].count(chr(10)) + 1}: NUL byte (a binary file?)")
    lines = [(i + 1, ln) for i, ln in enumerate(text.splitlines()) if ln.strip() and not ln.lstrip().startswith("#")]
    if len(lines) < 2:
        raise DataFileError(f"{p}: no data rows (a header line and at least one mode are needed)")
    try:
        rows = list(csv.reader([ln for _, ln in lines]))
    except csv.Error as exc:
        raise DataFileError(f"{p}: malformed CSV: {exc}") from None
    header = [h.strip() for h in rows[0]]
    hline = lines[0][0]
    for i, h in enumerate(header):
        if not h:
            raise DataFileError(f"{p}: line {hline}: column {i + 1} has no name (header: {header})")
        if header.index(h) != i:
            raise DataFileError(f"{p}: line {hline}: column {h!r} appears twice (columns {header.index(h) + 1} "
                                f"and {i + 1})")
    col = {h: i for i, h in enumerate(header)}
    if "mode" not in col:
        raise DataFileError(f"{p}: no 'mode' column (columns: {header})")
    fcol = next((c for c in _FREQ if c in col), None)
    if fcol is None:
        raise DataFileError(f"{p}: no frequency column (one of {_FREQ}); columns: {header}")
    dcol = next((c for c in _DAMP if c in col), None)
    shape_cols = {}
    for h in header:
        for pre in ("shape_", "phi_"):
            if h.startswith(pre):
                tail = h[len(pre):]
                if not tail.isdigit():
                    raise DataFileError(f"{p}: column {h!r}: expected {pre}<point id>")
                pid = int(tail)
                if pid not in spec.points:
                    raise DataFileError(f"{p}: column {h!r}: point id {pid} is not a point of {spec.name!r} "
                                        f"(points: {sorted(spec.points)})")
                shape_cols[pid] = col[h]
    sigma_cols = {c: col[c] for c in ("frequency_sigma_hz", "damping_sigma") if c in col}
    if "damping_sigma" in sigma_cols and dcol is None:
        raise DataFileError(f"{p}: column 'damping_sigma' without a damping column (one of {_DAMP})")
    if reference_column is not None and reference_column not in col:
        raise DataFileError(f"{p}: no column {reference_column!r} for the reference frequencies (columns: {header})")
    if reference_column is not None and reference_column in (fcol, "mode", dcol):
        raise DataFileError(f"{p}: the reference column {reference_column!r} is the table's own {reference_column} "
                            "column: name the reference model's frequencies")
    used = {"mode", fcol, dcol, reference_column} | {header[i] for i in shape_cols.values()} | set(sigma_cols)
    ignored = [h for h in header if h not in used]
    modes, freq, damp, shapes, sigmas, res, refs = [], [], [], [], [], [], []
    for (lineno, _), row in zip(lines[1:], rows[1:]):
        if len(row) != len(header):
            raise DataFileError(f"{p}: line {lineno}: {len(row)} fields, the header has {len(header)}")

        def num(name: str, idx: int, *, allow_empty: bool = False) -> float:
            s = row[idx].strip()
            if allow_empty and s == "":
                return float("nan")
            try:
                v = float(s)
            except ValueError:
                raise DataFileError(f"{p}: line {lineno}, column {name!r}: not a number: {s!r}") from None
            if not math.isfinite(v):
                raise DataFileError(f"{p}: line {lineno}, column {name!r}: not finite: {s!r}")
            return v

        mv = num("mode", col["mode"])
        if mv != int(mv) or mv < 1:
            raise DataFileError(f"{p}: line {lineno}, column 'mode': expected a positive integer, got {row[col['mode']]!r}")
        fv = num(fcol, col[fcol])
        if fv <= 0:
            raise DataFileError(f"{p}: line {lineno}, column {fcol!r}: frequency must be > 0 Hz, got {fv}")
        if fv > MAX_MODAL_FREQUENCY_HZ:
            raise DataFileError(f"{p}: line {lineno}, column {fcol!r}: {fv:g} Hz is above the "
                                f"{MAX_MODAL_FREQUENCY_HZ:g} Hz Nyquist frequency of the PC-1000 at 2000 samples/s "
                                "(Sec. 5.3): not a measured mode (a unit slip?)")
        dv = num(dcol, col[dcol], allow_empty=True) if dcol else float("nan")
        if math.isfinite(dv) and not 0.0 <= dv < 1.0:
            raise DataFileError(f"{p}: line {lineno}, column {dcol!r}: damping ratio must be in [0, 1), got {dv}")
        sig = []
        for c, idx in sigma_cols.items():
            sv = num(c, idx, allow_empty=True)
            if math.isfinite(sv) and sv < 0:
                raise DataFileError(f"{p}: line {lineno}, column {c!r}: an uncertainty must be >= 0, got {sv}")
            sig.append(sv)
        sigmas.append(sig)
        if reference_column is not None:
            rv = num(reference_column, col[reference_column])
            if rv <= 0:
                raise DataFileError(f"{p}: line {lineno}, column {reference_column!r}: a reference frequency must be "
                                    f"> 0 Hz, got {rv}")
            refs.append((rv, printed_resolution(row[col[reference_column]])))
        res.append((printed_resolution(row[col[fcol]]),
                    printed_resolution(row[col[dcol]]) if dcol and math.isfinite(dv) else float("nan")))
        modes.append(int(mv))
        freq.append(fv)
        damp.append(dv)
        shapes.append([num(header[i], i) for i in shape_cols.values()])
    if len(set(modes)) != len(modes):
        raise DataFileError(f"{p}: column 'mode': repeated mode numbers {sorted(m for m in set(modes) if modes.count(m) > 1)}")
    dupf = sorted({f for f in freq if freq.count(f) > 1})
    if dupf:
        raise DataFileError(f"{p}: column {fcol!r}: repeated frequency {dupf[0]:g} Hz (a duplicated row?)")
    order = np.argsort(freq)
    sig_arr = np.array(sigmas, dtype=float).reshape(len(modes), len(sigma_cols))[order]
    sig_of = {c: sig_arr[:, j] for j, c in enumerate(sigma_cols)}
    notes = []
    if ignored:
        notes.append(f"columns not used: {ignored}")
    sh = np.array(shapes, dtype=float).T[:, order] if shape_cols else None
    if sh is not None and np.any(np.all(sh == 0, axis=0)):
        raise DataFileError(f"{p}: a mode shape is zero at every point")
    return ModalData(str(p), np.array(modes)[order], np.array(freq)[order], np.array(damp)[order], sh,
                     tuple(shape_cols), notes, freq_sigma_hz=sig_of.get("frequency_sigma_hz"),
                     damping_sigma=sig_of.get("damping_sigma"),
                     freq_resolution_hz=np.array([r[0] for r in res])[order],
                     damping_resolution=np.array([r[1] for r in res])[order],
                     reference_hz=np.array([r[0] for r in refs])[order] if refs else None,
                     reference_resolution_hz=np.array([r[1] for r in refs])[order] if refs else None,
                     reference_column=reference_column)


# ----------------------------------------------------------------------------- dispatch
def detect_kind(path: str | Path) -> str:
    """``"modal"`` for a .csv file at ``path``, else ``"uff"`` (decided on reading).

    Raises
    ------
    DataFileError
        Missing file.
    """
    p = Path(path)
    if not p.is_file():
        raise DataFileError(f"{p}: no such file")
    return "modal" if p.suffix.lower() == ".csv" else "uff"


def read_uff_any(path: str | Path) -> tuple[str, object]:
    """Read the UFF file at ``path`` as a recording (function type 1) or FRFs (type 4).

    Returns
    -------
    ("recording", Recording) or ("frf", list of FRF)

    Raises
    ------
    DataFileError
        Malformed, truncated or unsupported file (from :mod:`vlab.io.uff`),
        or one holding neither kind. Names the file and channel.
    """
    from ...io.uff import read_frfs, read_recording

    try:
        return "recording", read_recording(path)
    except DataFileError as exc:
        if "no dataset-58 time-response" not in str(exc):
            raise
    try:
        return "frf", read_frfs(path)
    except DataFileError as exc:
        if "no dataset-58 FRF" in str(exc):
            raise DataFileError(f"{path}: neither time histories (UFF 58, function type 1) nor FRFs "
                                "(function type 4)") from None
        raise
    except VlabError:
        raise


def read_data(spec: StructureSpec, fe: FEModel, path: Path, what: str, obj, *,
              resolution_hz: float | None, band_hz, settle_of):
    """Turn what was read into FrfData or ModalData (see :mod:`vlab.diagnose.data.measured`).

    Parameters
    ----------
    spec, fe : StructureSpec, FEModel
        The nominal structure.
    path : Path
        The file (for messages).
    what : {"modal", "recording", "frf"}
        Kind of ``obj``.
    obj : ModalData, Recording or list of FRF
        What was read.
    resolution_hz : float or None
        Resolution asked for [Hz]; else the metadata's, else the structure's test resolution.
    band_hz : (float, float)
        Band analysed [Hz].
    settle_of : callable
        Returns the settling time [s] of the nominal lab (called for recordings only).

    Raises
    ------
    DataFileError, MeasurementError
        From :mod:`vlab.diagnose.data.measured`; a recording of another structure.
    """
    if what == "modal":
        return obj
    if what == "recording":
        meta = dict(obj.metadata)
        if meta.get("structure") not in (None, spec.name):
            raise DataFileError(f"{path}: recorded on structure {meta['structure']!r}, diagnosed as {spec.name!r}")
        res = float(resolution_hz or meta.get("resolution_hz") or test_definition(spec).resolution_hz)
        return frfs_from_recording(obj, spec, fe, path=str(path), resolution_hz=res, band_hz=band_hz,
                                   settle_s=settle_of())
    return frfs_from_uff(obj, spec, fe, path=str(path), band_hz=band_hz)


def refer_to_model(data: FrfData, baseline: FrfData, h_model: np.ndarray) -> FrfData:
    """Refer measured FRFs to the model through a baseline recording of the unmodified structure.

    ``H_ref = H_meas * H_model / H_baseline`` line by line: the ratio of the
    recording to the baseline (the change since the baseline) is kept and the
    model-form error shared by both (the model's offsets against this plant,
    present before any change) is removed to first order -- the reference-state
    idea of vibration-based damage detection (Doebling et al., *Damage
    identification and health monitoring of structural and mechanical systems
    from changes in their vibration characteristics*, LA-13070-MS, 1996, Sec. 3).
    Variances add in relative terms (the recording's without the uncertainty of its transient's removal
    when the baseline carries the same transient, ``baseline.same_transient``), and the referral's
    second-order error,
    ``|ln(H_model / H_baseline)| * |ln(H_meas / H_baseline)|`` (model-form
    error times change), is added as a systematic relative variance.

    Parameters
    ----------
    data, baseline : FrfData
        The recording under diagnosis and the baseline of the same test (same
        lines, excitation point and outputs).
    h_model : ndarray, complex, shape (n_f, n_o)
        The nominal model's FRFs on the data's lines [(m/s)/N].

    Returns
    -------
    FrfData
        ``h`` referred to the model, ``var`` propagated, ``h_recorded`` and
        ``var_recorded`` the recorded FRFs and their noise, ``var_baseline``
        the baseline's noise; a note says so.

    Raises
    ------
    DataFileError
        The baseline has other lines, another excitation point or other outputs
        (names the baseline file).
    """
    if (baseline.excitation_point != data.excitation_point
            or tuple(baseline.output_points) != tuple(data.output_points)):
        raise DataFileError(
            f"{baseline.source}: baseline excites point {baseline.excitation_point} and measures "
            f"{list(baseline.output_points)}; the recording {data.source} excites {data.excitation_point} and "
            f"measures {list(data.output_points)}: a baseline must be the same test")
    if baseline.freq_hz.shape != data.freq_hz.shape or not np.allclose(baseline.freq_hz, data.freq_hz,
                                                                       rtol=1e-9, atol=1e-9):
        raise DataFileError(
            f"{baseline.source}: baseline lines ({baseline.freq_hz.size} from {baseline.freq_hz[0]:g} Hz, "
            f"step {np.median(np.diff(baseline.freq_hz)):g} Hz) differ from the recording's "
            f"({data.freq_hz.size} from {data.freq_hz[0]:g} Hz): use the same excitation and resolution")
    own_var = data.var_steady if baseline.same_transient and data.var_steady is not None else data.var
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(np.abs(baseline.h) > 0, h_model / baseline.h, 0.0)
        # the referral is exact to first order; its second-order error is the product of the
        # model-form error and the change (ln of each ratio), kept as a systematic variance
        cross = np.abs(np.log(ratio)) * np.abs(np.log(data.h / baseline.h))
        rel_var = own_var / np.maximum(np.abs(data.h) ** 2, 1e-300) + \
            baseline.var / np.maximum(np.abs(baseline.h) ** 2, 1e-300) + np.where(np.isfinite(cross), cross, 0.0) ** 2
    h = data.h * ratio
    note = (f"referred to the model through the baseline {baseline.source}: H = H_recorded * H_model / "
            "H_baseline (the model-form error present in the baseline is removed to first order)")
    return replace(data, h=h, var=rel_var * np.abs(h) ** 2, h_recorded=data.h, var_recorded=own_var,
                   var_baseline=baseline.var, var_steady=None, notes=list(data.notes) + [note])
