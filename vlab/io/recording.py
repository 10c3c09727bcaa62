"""The output of an experiment: sampled time histories of named channels.

A :class:`Recording` is what the virtual laboratory hands to measurement
(:mod:`vlab.measure`) and diagnosis: uniformly sampled force and motion
channels, each tied to a structure point, plus free-form metadata (structure,
controller, excitation, seed, ...). It mirrors a UFF 58 file of function
type 1 (one record per channel, node = point id, direction 3 = out of plane),
see :mod:`vlab.io.uff`.

Channel names follow ``<prefix><point id>``: ``force4`` (force at point 4),
``vel1`` (velocity at point 1), ``disp6``, ``acc2``. Units are SI and fixed
by the quantity (Sec. 5.4: force voltage and velocity-sensor voltage were
recorded; vlab records them already converted to N and m/s).

Both classes are immutable: sample arrays are copied and made read-only.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import numpy as np

from ..errors import MeasurementError

#: SI unit of each recorded quantity.
QUANTITY_UNITS: Mapping[str, str] = MappingProxyType({
    "force": "N",
    "displacement": "m",
    "velocity": "m/s",
    "acceleration": "m/s^2",
})

#: Channel-name prefix of each quantity (``force4``, ``vel1``, ...).
QUANTITY_PREFIXES: Mapping[str, str] = MappingProxyType({
    "force": "force",
    "displacement": "disp",
    "velocity": "vel",
    "acceleration": "acc",
})

_NAME_RE = re.compile(r"^(force|disp|vel|acc)(\d+)$")

#: Longest run of identical samples at a channel's maximum or minimum that is not
#: taken as clipping (a saturated amplifier or ADC holds its limit; a smooth signal
#: sampled by the PC-1000 at up to 2000 samples/s, Sec. 5.3, does not repeat its
#: extreme exactly four times in a row).
CLIP_RUN = 3

#: Largest plausible RMS of a recorded channel, by quantity, in SI units. Derived
#: from the hardware of Sec. 5.3 and the structures: the coil velocity sensors are
#: linear over about 1/4 in (6.4 mm peak to peak), which at the highest modes of
#: interest (about 20 Hz) is a velocity amplitude of 2 pi 20 Hz x 3.2 mm = 0.4 m/s;
#: 10 m/s RMS is 25 times beyond it. The voice-coil actuators (loudspeaker-type
#: coils driven by controlled-current amplifiers) deliver forces of order 1-10 N;
#: 1000 N RMS is two orders of magnitude beyond. Displacement 0.1 m RMS is
#: 30 times the sensors' and probes' range (1/8 in); acceleration 1e4 m/s^2 RMS is
#: 10 m/s at 160 Hz. A channel beyond these is mis-scaled (wrong unit or gain).
MAX_PLAUSIBLE_RMS: Mapping[str, float] = MappingProxyType({
    "force": 1.0e3,
    "displacement": 0.1,
    "velocity": 10.0,
    "acceleration": 1.0e4,
})


#: Fraction of a channel's samples exactly at its maximum (or minimum) beyond which it is
#: clipped even without a long run: a clipped noise-like signal touches its limit often,
#: in short runs. A continuous-valued signal has a single sample at its extreme; a 12-bit
#: quantised sine holds its extreme code for about 1 % of its samples.
CLIP_FRACTION = 0.02


def find_clipping(x: Any, min_run: int = CLIP_RUN + 1,
                  fraction: float = CLIP_FRACTION) -> tuple[int, int, str, float, int] | None:
    """Where a signal is clipped: a flat top at its maximum or minimum.

    A channel clipped by a saturated amplifier or ADC holds its limit: either
    ``min_run`` or more consecutive samples exactly at the channel's maximum
    (or minimum), or more than ``fraction`` of all samples (and at least
    ``min_run``) exactly at it. A constant signal (``max == min``) is not
    reported here (it is a dead channel, not a clipped one); nor is an extreme
    of exactly zero: a range's limit is not zero, and a one-sided signal that
    rests at zero between events (an impact hammer's pulses, a burst's
    silences, a generated command) is off there, not clipped.

    Parameters
    ----------
    x : array_like, shape (n_samples,)
        Finite samples.
    min_run : int
        Shortest run reported (default :data:`CLIP_RUN` + 1 = 4 samples).
    fraction : float
        Share of samples at one extreme that is clipping whatever the runs
        (default :data:`CLIP_FRACTION` = 2 %).

    Returns
    -------
    (longest_run, run_start_index, "maximum" or "minimum", value, count) or None
        The clipped extreme, its longest run of equal samples and where it
        starts, and how many samples sit at it; None if not clipped.

    Raises
    ------
    MeasurementError
        If ``min_run`` is smaller than 2 or ``fraction`` is not in (0, 1].

    Notes
    -----
    Thresholds: :data:`CLIP_RUN` (3) equal extreme samples in a row are
    accepted, 4 or more are clipping; so are more than :data:`CLIP_FRACTION`
    of the samples at one extreme (Sec. 5.3 for the PC-1000's sampling).
    Quantised data hold their extreme code naturally for a while: both limits
    are raised to twice what a smooth peak of the channel's height and RMS
    rate would show (:func:`quantised_dwell`), so a slow quantised signal is
    not taken for a clipped one.
    """
    if min_run < 2:
        raise MeasurementError(f"find_clipping: min_run must be >= 2, got {min_run}")
    if not 0.0 < fraction <= 1.0:
        raise MeasurementError(f"find_clipping: fraction must be in (0, 1], got {fraction}")
    arr = np.asarray(x, dtype=float).reshape(-1)
    if arr.size < min_run or not np.all(np.isfinite(arr)):
        return None
    hi, lo = float(arr.max()), float(arr.min())
    if hi == lo:
        return None
    q, w = _resolution_and_rate(arr)
    mean = float(arr.mean())
    best = None
    for ext, word in ((hi, "maximum"), (lo, "minimum")):
        if ext == 0.0:
            continue
        at = arr == ext
        count = int(at.sum())
        # samples a smooth (unclipped) peak of this height spends within one quantisation step q of it
        n_q = quantised_dwell(q, abs(ext - mean), w)
        run_limit = max(min_run, int(np.ceil(2.0 * n_q)) + 1)
        # a peak's extra samples at its code (beyond the one any peak has), about once per 2 pi / w samples
        frac_limit = max(fraction, 2.0 * (n_q - 1.0) * w / (2.0 * np.pi))
        if count < run_limit:
            continue
        d = np.diff(np.concatenate(([0], at.astype(np.int8), [0])))
        starts, ends = np.flatnonzero(d == 1), np.flatnonzero(d == -1)
        runs = ends - starts
        k = int(np.argmax(runs))
        if (runs[k] >= run_limit or count > frac_limit * arr.size) and (best is None or count > best[4]):
            best = (int(runs[k]), int(starts[k]), word, ext, count)
    return best


def _resolution_and_rate(arr: np.ndarray) -> tuple[float, float]:
    """Quantisation step (smallest gap between distinct values) and RMS rate [rad/sample] of ``arr``."""
    steps = np.diff(np.unique(arr))
    q = float(steps.min()) if steps.size else 0.0
    dev = arr - arr.mean()
    rms = float(np.sqrt(np.mean(dev ** 2)))
    w = float(np.sqrt(np.mean(np.diff(arr) ** 2)) / rms) if rms > 0 and arr.size > 1 else 0.0
    return q, w


def quantised_dwell(q: float, height: float, w: float) -> float:
    """Samples a smooth, unclipped peak spends within one quantisation step of its extreme.

    Near a peak of height ``A`` above the mean a signal whose RMS rate is
    ``w`` [rad/sample] follows ``x_k ~ A (1 - w^2 k^2 / 2)`` (the curvature of
    its maxima is set by the second spectral moment: Rice, *Mathematical
    analysis of random noise*, 1944-45, Sec. 3.6), so it stays within ``q`` of
    the peak for ``|k| <= sqrt(2 q / A) / w`` samples: ``2 sqrt(2 q / A) / w + 1``
    in all. For continuous-valued data (``q`` at round-off) this is 1; for a
    slow sine of 0.2 full scale sampled at 2 kHz and quantised to 12 bits it
    is about 24, which a clipping test must not take for a flat top.

    Parameters
    ----------
    q : float
        Quantisation step of the data (its smallest gap between distinct values), same unit as ``height``.
    height : float
        Height of the peak above the mean (> 0).
    w : float
        RMS rate of the signal [rad/sample]: ``rms(diff x) / rms(x - mean)``.

    Returns
    -------
    float
        Expected run length [samples], >= 1.

    Raises
    ------
    None.
    """
    if not (q > 0.0 and height > 0.0 and w > 0.0):
        return 1.0
    return 2.0 * float(np.sqrt(2.0 * q / height)) / w + 1.0


_PREFIX_QUANTITY = {p: q for q, p in QUANTITY_PREFIXES.items()}


def channel_name(quantity: str, point_id: int) -> str:
    """Conventional channel name of ``quantity`` at ``point_id``, e.g. ``channel_name("velocity", 1) == "vel1"``.

    Raises
    ------
    MeasurementError
        If ``quantity`` is not one of :data:`QUANTITY_UNITS`.
    """
    if quantity not in QUANTITY_PREFIXES:
        raise MeasurementError(
            f"unknown quantity {quantity!r}; known: {', '.join(QUANTITY_PREFIXES)}")
    return f"{QUANTITY_PREFIXES[quantity]}{int(point_id)}"


def parse_channel_name(name: str) -> tuple[str, int]:
    """Split a conventional channel name into ``(quantity, point_id)``.

    ``"force4" -> ("force", 4)``, ``"vel12" -> ("velocity", 12)``.

    Raises
    ------
    MeasurementError
        If ``name`` does not follow ``<force|disp|vel|acc><point id>``.
    """
    m = _NAME_RE.match(name)
    if m is None:
        raise MeasurementError(
            f"channel name {name!r} does not follow '<force|disp|vel|acc><point id>'; "
            "pass point_ids and quantities explicitly")
    return _PREFIX_QUANTITY[m.group(1)], int(m.group(2))


def _frozen_array(values: Any, *, what: str) -> np.ndarray:
    arr = np.array(values, dtype=float, copy=True)
    if arr.ndim != 1:
        raise MeasurementError(f"{what}: expected a 1-D array of samples, got shape {arr.shape}")
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True, eq=False)
class Channel:
    """One recorded signal.

    Parameters
    ----------
    name : str
        Unique name within the recording (``"force4"``, ``"vel1"``).
    point_id : int
        Structure point (dissertation numbering: docs/getting-started.md, "Units and numbering") where it is measured.
    quantity : {"force", "displacement", "velocity", "acceleration"}
        What is measured; fixes the unit (:data:`QUANTITY_UNITS`).
    samples : array_like, shape (n_samples,)
        Values in SI units ([N], [m], [m/s], [m/s^2]). Copied, read-only.
    direction : int
        UFF direction code; 3 = +Z, out of the structure's plane (default).

    Raises
    ------
    MeasurementError
        Empty name, unknown quantity, samples not 1-D, or non-finite samples.
    """

    name: str
    point_id: int
    quantity: str
    samples: np.ndarray
    direction: int = 3

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise MeasurementError(f"channel name must be a non-empty string, got {self.name!r}")
        if self.quantity not in QUANTITY_UNITS:
            raise MeasurementError(
                f"channel {self.name!r}: unknown quantity {self.quantity!r}; "
                f"known: {', '.join(QUANTITY_UNITS)}")
        if isinstance(self.point_id, bool) or int(self.point_id) != self.point_id:
            raise MeasurementError(f"channel {self.name!r}: point_id must be an integer, "
                                   f"got {self.point_id!r}")
        object.__setattr__(self, "point_id", int(self.point_id))
        object.__setattr__(self, "direction", int(self.direction))
        arr = _frozen_array(self.samples, what=f"channel {self.name!r}")
        bad = np.flatnonzero(~np.isfinite(arr))
        if bad.size:
            raise MeasurementError(
                f"channel {self.name!r}: {bad.size} non-finite sample(s), first at index {bad[0]}")
        object.__setattr__(self, "samples", arr)

    @property
    def unit(self) -> str:
        """SI unit of the samples (``"N"``, ``"m/s"``, ...)."""
        return QUANTITY_UNITS[self.quantity]

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Channel):
            return NotImplemented
        return (self.name == other.name and self.point_id == other.point_id
                and self.quantity == other.quantity and self.direction == other.direction
                and np.array_equal(self.samples, other.samples))

    __hash__ = None  # type: ignore[assignment]


@dataclass(frozen=True, eq=False)
class Recording:
    """Uniformly sampled time histories of several channels (one experiment run).

    Parameters
    ----------
    dt_s : float
        Sampling interval [s] (0.5e-3 for the PC-1000 at 2 kHz, Sec. 5.3).
    channels : sequence of Channel
        At least one; unique names; all with the same number of samples.
    metadata : mapping, optional
        Free-form description of the run (structure, controller, excitation,
        seed, ...). Stored as a read-only mapping; JSON-serialisable values
        are needed to write it next to a UFF file.

    Raises
    ------
    MeasurementError
        Non-positive or non-finite ``dt_s``, no channels, duplicate names or
        channels of different lengths (the message names the channel).

    Notes
    -----
    Sample ``k`` of every channel is taken at ``t_k = k * dt_s``. The record
    length used for frequency resolution is ``duration_s = n_samples * dt_s``
    (resolution ``1 / duration_s`` [Hz] for one block).
    """

    dt_s: float
    channels: tuple[Channel, ...]
    metadata: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        dt = float(self.dt_s)
        if not math.isfinite(dt) or dt <= 0.0:
            raise MeasurementError(f"Recording.dt_s must be a positive finite time step [s], got {self.dt_s!r}")
        object.__setattr__(self, "dt_s", dt)
        chans = tuple(self.channels)
        if not chans:
            raise MeasurementError("Recording needs at least one channel")
        for c in chans:
            if not isinstance(c, Channel):
                raise MeasurementError(f"Recording.channels must hold Channel objects, got {type(c).__name__}")
        names = [c.name for c in chans]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise MeasurementError(f"Recording: duplicate channel name(s) {dup}")
        n0 = chans[0].samples.size
        for c in chans[1:]:
            if c.samples.size != n0:
                raise MeasurementError(
                    f"Recording: channel {c.name!r} has {c.samples.size} samples, "
                    f"channel {chans[0].name!r} has {n0}")
        object.__setattr__(self, "channels", chans)
        object.__setattr__(self, "metadata", MappingProxyType(dict(self.metadata)))

    def __reduce__(self):
        """Pickled (to a worker process) with its metadata as a plain dict; rebuilt read-only."""
        return (Recording, (self.dt_s, self.channels, dict(self.metadata)))

    # -- construction -----------------------------------------------------
    @classmethod
    def from_signals(cls, dt_s: float, signals: Mapping[str, Any], *,
                     metadata: Mapping[str, Any] | None = None,
                     point_ids: Mapping[str, int] | None = None,
                     quantities: Mapping[str, str] | None = None,
                     direction: int = 3) -> Recording:
        """Build a recording from named arrays.

        Parameters
        ----------
        dt_s : float
            Sampling interval [s].
        signals : mapping of str to array_like, each shape (n_samples,)
            Channel name -> samples in SI units. Names like ``force4`` or
            ``vel1`` give quantity and point id; other names need entries in
            ``point_ids`` and ``quantities``.
        metadata : mapping, optional
            Run description.
        point_ids, quantities : mapping, optional
            Override the values parsed from the names.
        direction : int
            UFF direction code of all channels (3 = +Z, out of plane).

        Raises
        ------
        MeasurementError
            Unparseable name without explicit point id/quantity, or any
            error of :class:`Channel` / :class:`Recording`.
        """
        point_ids = dict(point_ids or {})
        quantities = dict(quantities or {})
        chans = []
        for name, values in signals.items():
            if name in point_ids and name in quantities:
                q, p = quantities[name], point_ids[name]
            else:
                q, p = parse_channel_name(name)
                q, p = quantities.get(name, q), point_ids.get(name, p)
            chans.append(Channel(name=name, point_id=p, quantity=q, samples=values,
                                 direction=direction))
        return cls(dt_s=dt_s, channels=tuple(chans), metadata=dict(metadata or {}))

    def with_metadata(self, **items: Any) -> Recording:
        """Copy with ``items`` added to (or replacing keys of) the metadata."""
        return Recording(self.dt_s, self.channels, {**self.metadata, **items})

    def select(self, names: Sequence[str]) -> Recording:
        """Copy holding only the channels ``names`` (in that order).

        Raises
        ------
        MeasurementError
            If a name is not in the recording.
        """
        return Recording(self.dt_s, tuple(self.channel(n) for n in names), self.metadata)

    # -- access -------------------------------------------------------------
    @property
    def names(self) -> tuple[str, ...]:
        """Channel names in recording order."""
        return tuple(c.name for c in self.channels)

    @property
    def n_samples(self) -> int:
        """Number of samples per channel."""
        return int(self.channels[0].samples.size)

    @property
    def n_channels(self) -> int:
        """Number of channels."""
        return len(self.channels)

    @property
    def sample_rate_hz(self) -> float:
        """Sampling rate ``1 / dt_s`` [Hz]."""
        return 1.0 / self.dt_s

    @property
    def duration_s(self) -> float:
        """Record length ``n_samples * dt_s`` [s]."""
        return self.n_samples * self.dt_s

    @property
    def time_s(self) -> np.ndarray:
        """Sample instants ``k * dt_s`` [s], shape (n_samples,)."""
        return np.arange(self.n_samples) * self.dt_s

    def channel(self, name: str) -> Channel:
        """The :class:`Channel` called ``name``.

        Raises
        ------
        MeasurementError
            If there is no such channel (the message lists the channels).
        """
        for c in self.channels:
            if c.name == name:
                return c
        raise MeasurementError(f"no channel {name!r} in recording; channels: {', '.join(self.names)}")

    def find(self, point_id: int, quantity: str) -> Channel:
        """The channel measuring ``quantity`` at ``point_id``.

        Raises
        ------
        MeasurementError
            If none or more than one channel matches.
        """
        hits = [c for c in self.channels if c.point_id == point_id and c.quantity == quantity]
        if len(hits) != 1:
            raise MeasurementError(
                f"{'no' if not hits else len(hits)} {quantity} channel(s) at point {point_id}; "
                f"channels: {', '.join(self.names)}")
        return hits[0]

    def __getitem__(self, name: str) -> np.ndarray:
        """Samples of channel ``name``, shape (n_samples,), read-only."""
        return self.channel(name).samples

    def __contains__(self, name: object) -> bool:
        return name in self.names

    def __iter__(self) -> Iterator[Channel]:
        return iter(self.channels)

    def __len__(self) -> int:
        return len(self.channels)

    def as_array(self, names: Sequence[str] | None = None) -> np.ndarray:
        """Samples stacked as columns, shape (n_samples, n_selected), in ``names`` order."""
        names = self.names if names is None else names
        return np.column_stack([self[n] for n in names])

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Recording):
            return NotImplemented
        return (self.dt_s == other.dt_s and self.channels == other.channels
                and dict(self.metadata) == dict(other.metadata))

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        return (f"Recording(dt_s={self.dt_s!r}, n_samples={self.n_samples}, "
                f"channels={list(self.names)!r})")
