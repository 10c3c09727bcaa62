"""Frequency response functions from time histories (Sec. 5.4.1).

The STI-11/23 computed FFTs of response and excitation and divided them to
obtain velocity FRFs (VFRF); displacement FRFs (DFRF) followed by
integration in the frequency domain (Sec. 5.4.1). vlab does the same with
the averaged H1 estimator::

    H1(f)      = G_xy(f) / G_xx(f)
    gamma^2(f) = |G_xy(f)|^2 / (G_xx(f) G_yy(f))
    H_disp(f)  = H_vel(f) / (i 2 pi f)

with ``x`` the force [N], ``y`` the response, and the spectra Welch
averages (:func:`scipy.signal.csd`, :func:`scipy.signal.welch`) over blocks
of ``1 / resolution_hz`` seconds. Time dependence ``exp(+i omega t)``.

Source: Bendat & Piersol, *Random Data*, 4th ed., Sec. 9.1.3 (H1) and
9.2.3 (coherence); Ewins, *Modal Testing*, 2nd ed., Sec. 3.11.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from scipy import signal

from ..errors import MeasurementError
from ..io.frf import FRF, FRF_UNITS
from ..io.recording import Recording

_WINDOWS = ("hann", "boxcar")


def block_length(sample_rate_hz: float, resolution_hz: float) -> int:
    """Samples per analysis block: ``round(sample_rate_hz / resolution_hz)``.

    Raises
    ------
    MeasurementError
        Non-positive inputs or a resolution coarser than ``fs / 2``.
    """
    fs, df = float(sample_rate_hz), float(resolution_hz)
    if not (math.isfinite(fs) and math.isfinite(df)) or fs <= 0 or df <= 0:
        raise MeasurementError(f"sample rate {sample_rate_hz} Hz and resolution {resolution_hz} Hz must be > 0")
    n = int(round(fs / df))
    if n < 2:
        raise MeasurementError(f"resolution {df} Hz is too coarse for sample rate {fs} Hz")
    return n


def required_duration_s(resolution_hz: float, *, n_averages: int = 1, overlap: float = 0.5) -> float:
    """Record length [s] giving ``n_averages`` blocks of ``1 / resolution_hz`` s with ``overlap``.

    ``T = (1 + (n_averages - 1) * (1 - overlap)) / resolution_hz``.

    Raises
    ------
    MeasurementError
        Non-positive resolution, ``n_averages < 1`` or overlap outside [0, 1).
    """
    if not resolution_hz > 0 or n_averages < 1 or not 0 <= overlap < 1:
        raise MeasurementError(
            f"need resolution_hz > 0, n_averages >= 1, 0 <= overlap < 1; got "
            f"{resolution_hz}, {n_averages}, {overlap}")
    return (1 + (n_averages - 1) * (1 - overlap)) / resolution_hz


def _time_histories(x, y, input_name: str, output_name: str) -> tuple[np.ndarray, np.ndarray]:
    """Force and response as float arrays: 1-D, finite, of one length (MeasurementError naming the channel)."""
    xa = np.asarray(x, dtype=float)
    ya = np.asarray(y, dtype=float)
    for arr, nm in ((xa, input_name), (ya, output_name)):
        if arr.ndim != 1:
            raise MeasurementError(f"channel {nm}: expected a 1-D time history, got shape {arr.shape}")
        bad = np.flatnonzero(~np.isfinite(arr))
        if bad.size:
            raise MeasurementError(f"channel {nm}: non-finite sample at index {bad[0]}")
    if xa.size != ya.size:
        raise MeasurementError(f"FRF {output_name}/{input_name}: channel {input_name} has {xa.size} samples, "
                               f"channel {output_name} has {ya.size}")
    return xa, ya


def h1(x, y, *, dt_s: float, resolution_hz: float, overlap: float = 0.5, window: str = "hann",
       response: str = "velocity", f_max_hz: float | None = None,
       input_name: str = "input", output_name: str = "output",
       input_point: int | None = None, output_point: int | None = None) -> FRF:
    """H1 estimate of the FRF from force ``x`` to response ``y`` with coherence.

    ::

        H1 = G_xy / G_xx,   gamma^2 = |G_xy|^2 / (G_xx G_yy)

    Welch averaging over blocks of ``n = round(1 / (resolution_hz dt_s))``
    samples, mean removed per block.

    Parameters
    ----------
    x : array_like, shape (n_samples,)
        Force [N].
    y : array_like, shape (n_samples,)
        Response in SI units ([m/s] for ``response="velocity"``).
    dt_s : float
        Sampling interval [s].
    resolution_hz : float
        Frequency resolution ``df`` [Hz] = 1 / block length.
    overlap : float
        Block overlap fraction in [0, 1); 0.5 is usual with a Hann window.
    window : {"hann", "boxcar"}
        ``"hann"`` for random excitation; ``"boxcar"`` for periodic
        excitation whose period equals the block (leakage-free).
    response : {"velocity", "displacement", "acceleration"}
        Quantity of ``y``.
    f_max_hz : float, optional
        Drop lines above this frequency.
    input_name, output_name : str
        Channel names, used in the result and in error messages.
    input_point, output_point : int, optional
        Point ids carried into the result.

    Returns
    -------
    FRF
        ``freq_hz`` = ``k * df`` from 0 Hz, ``h`` in ``FRF_UNITS[response]``,
        ``coherence``, ``n_averages``.

    Raises
    ------
    MeasurementError
        Records shorter than one block (names the channel), different
        lengths, non-finite samples, zero input power, bad window/overlap.

    Notes
    -----
    H1 is unbiased by noise on the response (Bendat & Piersol, Sec. 9.1.3);
    noise on the force biases it low. The coherence of a single block is 1
    by construction: use several averages.
    """
    pair = f"{output_name}/{input_name}"
    xa, ya = _time_histories(x, y, input_name, output_name)
    if window not in _WINDOWS:
        raise MeasurementError(f"window must be one of {_WINDOWS}, got {window!r}")
    if not 0 <= overlap < 1:
        raise MeasurementError(f"overlap must be in [0, 1), got {overlap}")
    if response not in FRF_UNITS:
        raise MeasurementError(f"unknown response {response!r}; known: {', '.join(FRF_UNITS)}")
    if not dt_s > 0:
        raise MeasurementError(f"dt_s must be > 0, got {dt_s}")
    fs = 1.0 / dt_s
    nper = block_length(fs, resolution_hz)
    if xa.size < nper:
        raise MeasurementError(
            f"channel {output_name} (force {input_name}): record of {xa.size * dt_s:.6g} s "
            f"({xa.size} samples) is shorter than one block of {nper * dt_s:.6g} s needed for "
            f"{resolution_hz} Hz resolution")
    noverlap = int(round(overlap * nper))
    kw = dict(fs=fs, window=window, nperseg=nper, noverlap=noverlap, detrend="constant")
    f, gxx = signal.welch(xa, **kw)
    _, gyy = signal.welch(ya, **kw)
    _, gxy = signal.csd(xa, ya, **kw)
    if not np.any(gxx > 0):
        raise MeasurementError(f"channel {input_name}: zero force power, FRF {pair} undefined")
    with np.errstate(divide="ignore", invalid="ignore"):
        hh = np.where(gxx > 0, gxy / np.where(gxx > 0, gxx, 1.0), np.nan)
        den = gxx * gyy
        coh = np.where(den > 0, np.abs(gxy) ** 2 / np.where(den > 0, den, 1.0), 0.0)
    n_avg = 1 + (xa.size - nper) // (nper - noverlap)
    if f_max_hz is not None:
        keep = f <= f_max_hz
        f, hh, coh = f[keep], hh[keep], coh[keep]
    return FRF(freq_hz=f, h=hh, response=response, coherence=np.clip(coh, 0.0, 1.0),
               output_name=output_name, input_name=input_name, output_point=output_point,
               input_point=input_point, n_averages=int(n_avg))


def measure_frfs(recording: Recording, *, input_channel: str,
                 output_channels: Sequence[str] | None = None, resolution_hz: float,
                 overlap: float = 0.5, window: str = "hann",
                 f_max_hz: float | None = None) -> dict[str, FRF]:
    """H1 FRFs of several response channels of a recording to one force channel.

    Parameters
    ----------
    recording : Recording
        Experiment output.
    input_channel : str
        Name of the force channel, e.g. ``"force4"``.
    output_channels : sequence of str, optional
        Response channels; all non-force channels by default.
    resolution_hz, overlap, window, f_max_hz
        As in :func:`h1`.

    Returns
    -------
    dict of str to FRF
        Keyed by output channel name, in the order requested.

    Raises
    ------
    MeasurementError
        Unknown channel, input not a force, output a force, or any error of :func:`h1`.
    """
    src = recording.channel(input_channel)
    if src.quantity != "force":
        raise MeasurementError(f"channel {input_channel}: input must be a force, not {src.quantity}")
    if output_channels is None:
        output_channels = [c.name for c in recording.channels if c.quantity != "force"]
    out: dict[str, FRF] = {}
    for name in output_channels:
        ch = recording.channel(name)
        if ch.quantity == "force":
            raise MeasurementError(f"channel {name}: a force cannot be an FRF response")
        out[name] = h1(src.samples, ch.samples, dt_s=recording.dt_s, resolution_hz=resolution_hz,
                       overlap=overlap, window=window, response=ch.quantity, f_max_hz=f_max_hz,
                       input_name=src.name, output_name=ch.name, input_point=src.point_id,
                       output_point=ch.point_id)
    return out
