"""The ``[hardware]`` table of a structure file: per-channel settings of the coils and the sensors.

A structure file may state how its actuator and sensor channels differ from the ideal chain of Fig. 21
(Sec. 5.3): a coil whose force per command is off, a sensor whose sensitivity is off, a later DAC output,
a first-order lag. Each setting is an array of tables under ``hardware``, every entry with its source;
``channel`` is the actuator point id of the channel (its collocated sensor for the sensor settings) or
``"all"`` (every channel):

``[[hardware.actuator_gain]]``
    ``channel``, ``gain`` (force per command [1], > 0), ``source``. Lives in the plant: the FE model's
    input matrix ``U`` of Eq. (3.1) (:meth:`Hardware.input_gains`) and the MuJoCo coil's ``gainprm``.
``[[hardware.sensor_gain]]``
    ``channel``, ``gain`` (sensitivity [1], > 0), ``source``. Lives in the hardware chain
    (:attr:`vlab.lab.loop.HardwareChain.sensor_gain`).
``[[hardware.loop_delay]]``
    ``channel``, ``delay = { value, unit = "s", source }``: the delay from sample to DAC output of that
    channel [s] (>= 0), in the chain as ``channel_delay_periods`` (delay / sampling period).
``[[hardware.actuator_lag]]`` and ``[[hardware.sensor_lag]]``
    ``channel``, ``corner = { value, unit = "Hz", source }``: a first-order lag of the coil force or of
    the sensor signal, corner [Hz] (> 0), in the chain as ``channel_actuator_lag_hz`` /
    ``channel_sensor_lag_hz``.

Several entries of one setting combine as the diagnosis applies its effects (:mod:`vlab.diagnose.effects.
chain`): gains multiply (a gain found on an updated file multiplies the file's own), a delay or a corner
replaces the one before it for its channel. The names are those of the diagnosis's effects.

Errors: :class:`vlab.errors.SpecError` naming the file and the field (``hardware.sensor_gain[0].gain``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np


#: The settings of the ``[hardware]`` table (arrays of tables), in the order they are read.
HARDWARE_TABLES = ("actuator_gain", "sensor_gain", "loop_delay", "actuator_lag", "sensor_lag")
#: Largest plausible gain of a channel [1]: beyond it, a unit or exponent slip (the diagnosis fits 0.02 .. 50).
MAX_GAIN = 100.0
#: Longest plausible delay from sample to DAC output [s] (a thousand 1 ms periods).
MAX_DELAY_S = 1.0


@dataclass(frozen=True)
class Hardware:
    """The per-channel settings of a structure file's ``[hardware]`` table, resolved per channel.

    Attributes
    ----------
    actuator_gain : dict[int, float]
        Actuator point id -> force per command [1] (missing: 1), the product of its entries.
    sensor_gain : dict[int, float]
        Sensor (= actuator) point id -> sensitivity [1] (missing: 1).
    delay_s : dict[int, float]
        Actuator point id -> delay from sample to DAC output [s] (missing: the chain's).
    actuator_lag_hz, sensor_lag_hz : dict[int, float]
        Point id -> corner frequency [Hz] of a first-order lag (missing: none).
    sources : tuple of str
        ``"<setting> <channel>: <source>"`` of every entry, in file order.
    """

    actuator_gain: dict[int, float] = field(default_factory=dict)
    sensor_gain: dict[int, float] = field(default_factory=dict)
    delay_s: dict[int, float] = field(default_factory=dict)
    actuator_lag_hz: dict[int, float] = field(default_factory=dict)
    sensor_lag_hz: dict[int, float] = field(default_factory=dict)
    sources: tuple[str, ...] = ()

    def input_gains(self, points) -> np.ndarray:
        """The actuator gains of ``points`` (1 where none is set), shape (len(points),) [1].

        Multiplying column j of the FE model's input matrix ``U`` (Eq. 3.1) by entry j puts the coils'
        gains into the plant, as ``gainprm`` does in the MuJoCo plant.

        Parameters
        ----------
        points : sequence of int
            Actuator point ids, in column order.

        Returns
        -------
        ndarray, shape (n_points,)
        """
        return np.array([self.actuator_gain.get(int(p), 1.0) for p in points], dtype=float)

    def output_gains(self, points) -> np.ndarray:
        """The sensor gains of ``points`` (1 where none is set), shape (len(points),) [1].

        Parameters
        ----------
        points : sequence of int
            Sensor point ids.

        Returns
        -------
        ndarray, shape (n_points,)
        """
        return np.array([self.sensor_gain.get(int(p), 1.0) for p in points], dtype=float)

    @property
    def chain_settings(self) -> bool:
        """True when the table sets anything of the hardware chain (sensor gains, delays, lags)."""
        return bool(self.sensor_gain or self.delay_s or self.actuator_lag_hz or self.sensor_lag_hz)


#: Setting of the table -> the :class:`Hardware` attribute it fills.
SETTING_ATTRIBUTES = {"actuator_gain": "actuator_gain", "sensor_gain": "sensor_gain", "loop_delay": "delay_s",
                      "actuator_lag": "actuator_lag_hz", "sensor_lag": "sensor_lag_hz"}


def combine(values: dict[int, float], setting: str, points, value: float) -> None:
    """Apply one entry of ``setting`` to the per-channel ``values`` (in place): a gain multiplies the
    channel's gain (missing: 1), a delay or a corner replaces it.

    Parameters
    ----------
    values : dict[int, float]
        Point id -> value of that setting so far.
    setting : str
        One of :data:`HARDWARE_TABLES`.
    points : sequence of int
        The entry's channels.
    value : float
        Its value (gain [1], delay [s] or corner [Hz]).
    """
    for p in points:
        values[p] = values.get(p, 1.0) * value if setting.endswith("gain") else value


def with_entries(hw: "Hardware | None", actuators, entries) -> "Hardware":
    """``hw`` with more entries applied as the table applies them (:func:`combine`).

    Parameters
    ----------
    hw : Hardware or None
        The settings so far (None: none).
    actuators : sequence of int
        The channels (``"all"`` means every one).
    entries : iterable of (str, int or "all", float)
        ``(setting, channel, value)``, setting one of :data:`HARDWARE_TABLES`.

    Returns
    -------
    Hardware
        A new object (sources unchanged).
    """
    hw = hw or Hardware()
    attrs = {a: dict(getattr(hw, a)) for a in SETTING_ATTRIBUTES.values()}
    for setting, ch, value in entries:
        combine(attrs[SETTING_ATTRIBUTES[setting]], setting, tuple(actuators) if ch == "all" else (int(ch),),
                float(value))
    return Hardware(**attrs, sources=hw.sources)


def input_gains(spec, points) -> np.ndarray:
    """The actuator gains of a structure's ``[hardware]`` table at ``points`` (ones without a table).

    Parameters
    ----------
    spec : StructureSpec
    points : sequence of int
        Actuator point ids, in column order of the input matrix ``U`` (Eq. 3.1).

    Returns
    -------
    ndarray, shape (n_points,) [1]
    """
    hw = getattr(spec, "hardware", None)
    return np.ones(len(tuple(points))) if hw is None else hw.input_gains(points)


def output_gains(spec, points) -> np.ndarray:
    """The sensor gains of a structure's ``[hardware]`` table at ``points`` (ones without a table).

    Parameters
    ----------
    spec : StructureSpec
    points : sequence of int
        Sensor point ids, in row order of the velocity output matrix.

    Returns
    -------
    ndarray, shape (n_points,) [1]
    """
    hw = getattr(spec, "hardware", None)
    return np.ones(len(tuple(points))) if hw is None else hw.output_gains(points)


def _channels(r, channels: tuple[int, ...]) -> tuple:
    """The channels of one entry: its ``channel`` (an actuator point) or every channel for ``"all"``."""
    ch = r.raw("channel", types=(int, str))
    if ch == "all":
        return channels
    if isinstance(ch, bool) or not isinstance(ch, int) or ch not in channels:
        r.fail("channel", f"{ch!r} is not a channel: give an actuator point id of [instrumentation] "
                          f"{list(channels)} or \"all\"")
    return (ch,)


def _gain(r) -> float:
    g = r.raw("gain", types=(int, float))
    if isinstance(g, bool) or not math.isfinite(g) or not 0.0 < g <= MAX_GAIN:
        r.fail("gain", f"a channel gain must be a number in (0, {MAX_GAIN:g}], got {g!r}")
    return float(g)


def read_hardware(hr, instrumentation) -> Hardware | None:
    """The ``[hardware]`` table (the module's docstring lists its settings).

    Parameters
    ----------
    hr : TableReader or None
        Reader of the table; None when the file has none.
    instrumentation : Instrumentation or None
        The structure's actuator points (the channels).

    Returns
    -------
    Hardware or None

    Raises
    ------
    SpecError
        No ``[instrumentation]`` table; an entry that is not an array of tables; an unknown field or
        setting; a channel that is no actuator point; a gain <= 0 or above :data:`MAX_GAIN`; a negative
        delay or one above :data:`MAX_DELAY_S`; a corner <= 0; a missing source. The message names the
        file and the field.
    """
    if hr is None:
        return None
    if instrumentation is None:
        hr.fail("", "needs an [instrumentation] table (its actuators are the channels)")
    chans = tuple(instrumentation.actuators)
    out: dict[str, dict] = {a: {} for a in SETTING_ATTRIBUTES.values()}
    sources = []
    for name in HARDWARE_TABLES:
        for _, r in hr.entries(name, []):
            points = _channels(r, chans)
            if name.endswith("gain"):
                value, src = _gain(r), r.str("source")
                if not src.strip():
                    r.fail("source", "empty: every value needs its source")
            elif name == "loop_delay":
                q = r.quantity("delay", "time", positive=False)
                if q.si > MAX_DELAY_S:
                    r.fail("delay", f"{q.si:g} s is longer than {MAX_DELAY_S:g} s: a unit or exponent slip?")
                value, src = q.si, q.source
            else:
                q = r.quantity("corner", "frequency")
                value, src = q.si, q.source
            combine(out[SETTING_ATTRIBUTES[name]], name, points, value)
            sources.append(f"{name} {r.table['channel']}: {src}")
    hr.done()
    return Hardware(**out, sources=tuple(sources))

