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
from dataclasses import dataclass

import numpy as np
from scipy import signal

from ..errors import MeasurementError
from ..lab.recording import Recording

#: Response quantity -> unit of the FRF (response per force).
FRF_UNITS = {"displacement": "m/N", "velocity": "(m/s)/N", "acceleration": "(m/s^2)/N"}

_WINDOWS = ("hann", "boxcar")


def _frozen(a, dtype) -> np.ndarray:
    arr = np.array(a, dtype=dtype, copy=True)
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True, eq=False)
class FRF:
    """A frequency response function (response per unit force) on a frequency grid.

    Parameters
    ----------
    freq_hz : array_like, shape (n_freq,)
        Frequencies [Hz], strictly increasing, >= 0.
    h : array_like, shape (n_freq,)
        Complex FRF in SI units (see :attr:`unit`).
    response : {"displacement", "velocity", "acceleration"}
        Response quantity (numerator); the denominator is force [N].
    coherence : array_like, shape (n_freq,), optional
        Ordinary coherence in [0, 1]; ``None`` for an analytical FRF.
    output_name, input_name : str
        Channel names, e.g. ``"vel6"`` and ``"force9"``.
    output_point, input_point : int, optional
        Structure point ids of response and force.
    n_averages : int, optional
        Number of blocks averaged.

    Raises
    ------
    MeasurementError
        Inconsistent shapes, non-increasing or negative frequencies, unknown
        response quantity.
    """

    freq_hz: np.ndarray
    h: np.ndarray
    response: str = "velocity"
    coherence: np.ndarray | None = None
    output_name: str = "output"
    input_name: str = "input"
    output_point: int | None = None
    input_point: int | None = None
    n_averages: int | None = None

    def __post_init__(self) -> None:
        f = _frozen(self.freq_hz, float)
        h = _frozen(self.h, complex)
        name = self.name
        if f.ndim != 1 or h.shape != f.shape:
            raise MeasurementError(f"FRF {name}: freq_hz {f.shape} and h {h.shape} must be equal 1-D shapes")
        if f.size and (np.any(np.diff(f) <= 0) or f[0] < 0 or not np.all(np.isfinite(f))):
            raise MeasurementError(f"FRF {name}: freq_hz must be finite, >= 0 and strictly increasing")
        if self.response not in FRF_UNITS:
            raise MeasurementError(f"FRF {name}: unknown response {self.response!r}; known: {', '.join(FRF_UNITS)}")
        object.__setattr__(self, "freq_hz", f)
        object.__setattr__(self, "h", h)
        if self.coherence is not None:
            c = _frozen(self.coherence, float)
            if c.shape != f.shape:
                raise MeasurementError(f"FRF {name}: coherence shape {c.shape} != freq_hz shape {f.shape}")
            object.__setattr__(self, "coherence", c)

    @property
    def name(self) -> str:
        """``"output/input"``, e.g. ``"vel6/force9"``."""
        return f"{self.output_name}/{self.input_name}"

    @property
    def unit(self) -> str:
        """Unit of :attr:`h`, e.g. ``"(m/s)/N"``."""
        return FRF_UNITS[self.response]

    @property
    def magnitude(self) -> np.ndarray:
        """``|h|``, shape (n_freq,)."""
        return np.abs(self.h)

    @property
    def omega(self) -> np.ndarray:
        """Angular frequency ``2 pi f`` [rad/s], shape (n_freq,)."""
        return 2.0 * np.pi * self.freq_hz

    def band(self, f_low_hz: float, f_high_hz: float) -> FRF:
        """Copy restricted to ``f_low_hz <= f <= f_high_hz``.

        Raises
        ------
        MeasurementError
            If no frequency lies in the band.
        """
        sel = (self.freq_hz >= f_low_hz) & (self.freq_hz <= f_high_hz)
        if not np.any(sel):
            raise MeasurementError(f"FRF {self.name}: no line in [{f_low_hz}, {f_high_hz}] Hz")
        return self._with(self.freq_hz[sel], self.h[sel],
                          None if self.coherence is None else self.coherence[sel], self.response)

    def _with(self, f, h, c, response) -> FRF:
        return FRF(freq_hz=f, h=h, response=response, coherence=c, output_name=self.output_name,
                   input_name=self.input_name, output_point=self.output_point,
                   input_point=self.input_point, n_averages=self.n_averages)

    def to_displacement(self) -> FRF:
        """Displacement FRF (DFRF) from a velocity FRF (VFRF): ``H_d = H_v / (i 2 pi f)``.

        The 0 Hz line, where the division is undefined, is dropped.
        Source: Sec. 5.4.1 ("The VFRFs were then integrated in the frequency domain").

        Raises
        ------
        MeasurementError
            If :attr:`response` is not ``"velocity"``.
        """
        if self.response != "velocity":
            raise MeasurementError(f"FRF {self.name}: to_displacement needs a velocity FRF, not {self.response}")
        keep = self.freq_hz > 0
        f = self.freq_hz[keep]
        c = None if self.coherence is None else self.coherence[keep]
        return self._with(f, self.h[keep] / (2j * np.pi * f), c, "displacement")

    def to_velocity(self) -> FRF:
        """Velocity FRF from a displacement FRF: ``H_v = i 2 pi f H_d``.

        Raises
        ------
        MeasurementError
            If :attr:`response` is not ``"displacement"``.
        """
        if self.response != "displacement":
            raise MeasurementError(f"FRF {self.name}: to_velocity needs a displacement FRF, not {self.response}")
        return self._with(self.freq_hz, self.h * (2j * np.pi * self.freq_hz), self.coherence, "velocity")

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, FRF):
            return NotImplemented
        same_c = (self.coherence is None and other.coherence is None) or (
            self.coherence is not None and other.coherence is not None
            and np.array_equal(self.coherence, other.coherence))
        return (np.array_equal(self.freq_hz, other.freq_hz) and np.array_equal(self.h, other.h)
                and same_c and self.response == other.response
                and (self.output_name, self.input_name, self.output_point, self.input_point,
                     self.n_averages)
                == (other.output_name, other.input_name, other.output_point, other.input_point,
                    other.n_averages))

    __hash__ = None  # type: ignore[assignment]


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
    xa = np.asarray(x, dtype=float)
    ya = np.asarray(y, dtype=float)
    for arr, nm in ((xa, input_name), (ya, output_name)):
        if arr.ndim != 1:
            raise MeasurementError(f"channel {nm}: expected a 1-D time history, got shape {arr.shape}")
        bad = np.flatnonzero(~np.isfinite(arr))
        if bad.size:
            raise MeasurementError(f"channel {nm}: non-finite sample at index {bad[0]}")
    if xa.size != ya.size:
        raise MeasurementError(f"FRF {pair}: channel {input_name} has {xa.size} samples, "
                               f"channel {output_name} has {ya.size}")
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
