"""Hypotheses in the hardware chain of Fig. 21: delay, lags, channel gains, saturation.

Each builds a modified :class:`~vlab.lab.loop.HardwareChain` (Sec. 5.3),
which the frequency-domain model (:mod:`vlab.diagnose.model.labmodel`) and the
2 kHz loop of a rerun both use. Each is located on one channel
(``{"channel": <point id>}``: that channel's entry of the chain) or on all
(``{"channel": "all"}``: the global setting).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ...errors import ModelError
from .hypothesis import Hypothesis, _log_trials


class _Channel(Hypothesis):
    """An effect of the controller path on one channel (``channel`` = its actuator/sensor point id) or on
    all channels (``channel="all"``, the default): ``location = {"channel": ...}``.

    A per-channel effect sets the chain's per-channel entry of that point
    (:class:`~vlab.lab.loop.HardwareChain`, ``channel_*`` dicts); "all" sets
    the global setting. Open loop only the excited coil carries force, so
    an actuator-side effect there is one hypothesis ("all", or the
    excitation channel for a gain) and the per-channel variants are tried
    on closed-loop data only.
    """

    in_chain = True

    def __init__(self, *, channel: int | str = "all"):
        if channel != "all" and (isinstance(channel, bool) or not isinstance(channel, (int, np.integer))):
            raise ModelError(f"{type(self).__name__}: channel must be a point id (int) or 'all', got {channel!r}")
        self.channel = channel if channel == "all" else int(channel)

    @property
    def location(self) -> dict:
        return {"channel": self.channel}

    @property
    def per_channel(self) -> bool:
        """True for one channel, False for all."""
        return self.channel != "all"

    def _applies(self, ctx):
        if self.per_channel and not ctx.closed_loop:
            return False
        return super()._applies(ctx)

    def _set(self, state, glob: str, by_channel: str, value):
        """``state`` with the global chain attribute ``glob`` (channel "all") or the entry of this channel in
        the per-channel dict ``by_channel`` set to ``value``."""
        if not self.per_channel:
            return replace(state, chain=replace(state.chain, **{glob: value}))
        entries = dict(getattr(state.chain, by_channel))
        entries[self.channel] = value
        return replace(state, chain=replace(state.chain, **{by_channel: entries}))


class LoopDelay(_Channel):
    """``loop_delay``: the computation delay from sample to DAC output, on one channel or on all.

    Parameter: ``delay_s`` [s] (total; the nominal chain has 1.35 periods,
    Sec. 5.3). Sets ``HardwareChain.delay_periods`` (all channels) or
    ``channel_delay_periods[channel]``: a later DAC output on one coil
    changes the closed-loop damping of the modes that channel controls and
    nothing open loop.
    """

    effect = "loop_delay"
    param_names = ("delay_s",)
    log_scale = (False,)
    needs = "closed"
    order = 7

    def _space(self, state, ctx):
        t = state.chain.period_s
        return (np.array([[t * f] for f in (0.0, 0.6, 2.5, 4.0, 7.0, 12.0)]), np.array([0.0]), np.array([60 * t]))

    def _apply(self, state, x, ctx):
        return self._set(state, "delay_periods", "channel_delay_periods", float(x[0]) / state.chain.period_s)

    def _null(self, state, ctx):
        ch = state.chain
        d = ch.delay_of(self.channel) if self.per_channel else ch.delay_periods
        return np.array([d * ch.period_s])


class _Lag(_Channel):
    param_names = ("corner_hz",)
    log_scale = (True,)
    attr = ""

    def _space(self, state, ctx):
        hi = ctx.band_hz[1]
        return _log_trials(hi, (1.0, 3.0, 10.0, 30.0, 100.0)), np.array([0.1 * hi]), np.array([1e4 * hi])

    def _apply(self, state, x, ctx):
        return self._set(state, self.attr, "channel_" + self.attr, float(x[0]))


class ActuatorLag(_Lag):
    """``actuator_lag``: a first-order lag of the coil force (coil inductance, amplifier bandwidth), one coil or all.

    Parameter: ``corner_hz`` [Hz] (log10). Sets ``HardwareChain.actuator_lag_hz``
    (all channels) or ``channel_actuator_lag_hz[channel]``. It also acts on
    the excitation, so it shows open loop too (there: all channels only).
    """

    effect = "actuator_lag"
    attr = "actuator_lag_hz"
    order = 8


class SensorLag(_Lag):
    """``sensor_lag``: a first-order lag of the velocity sensors fed back, one sensor or all.

    Parameter: ``corner_hz`` [Hz] (log10). Sets ``HardwareChain.sensor_lag_hz``
    or ``channel_sensor_lag_hz[channel]``. The recorded channel of a feedback
    sensor is that sensor's signal, so the lag also shows open loop at a
    measured sensor point; the hypothesis is still tried only on closed-loop
    data.
    """

    effect = "sensor_lag"
    attr = "sensor_lag_hz"
    needs = "closed"
    order = 9


#: Screening trials of a channel gain (factors on its nominal 1): a search grid, not a decision threshold. A
#: gain change of a few per cent moves every peak of its channel by that much, so its chi-square well is
#: about as wide as the change itself: trials 4-7 % apart near 1 keep a small change within one well of a
#: trial, the coarser ones reach large changes. More trials cost one FE evaluation each.
TRIAL_FACTORS_GAIN = (0.4, 0.65, 0.85, 0.93, 0.97, 1.03, 1.07, 1.2, 1.6, 2.5)


class _Gain(_Channel):
    param_names = ("gain",)
    log_scale = (True,)
    attr = ""

    def _space(self, state, ctx):
        return _log_trials(1.0, TRIAL_FACTORS_GAIN), np.array([0.02]), np.array([50.0])

    def _apply(self, state, x, ctx):
        gains = dict(getattr(state.chain, self.attr))
        for p in ((self.channel,) if self.per_channel else state.actuators):
            gains[p] = gains.get(p, 1.0) * float(x[0])
        return replace(state, chain=replace(state.chain, **{self.attr: gains}))

    def _null(self, state, ctx):
        return np.array([1.0])


class ActuatorGain(_Gain):
    """``actuator_gain``: force per command of one coil channel, or of all (amplifier or coil constant off).

    Parameter: ``gain`` [1] (log10) multiplying ``HardwareChain.actuator_gain[channel]``
    (every actuator's for channel "all"). Open loop it shows only on the
    excitation channel (the one hypothesis tried there).
    """

    effect = "actuator_gain"
    attr = "actuator_gain"
    order = 10

    def _applies(self, ctx):
        return ctx.closed_loop or self.channel == ctx.excitation_point


class SensorGain(_Gain):
    """``sensor_gain``: sensitivity of one feedback velocity sensor, or of all.

    Parameter: ``gain`` [1] (log10) multiplying ``HardwareChain.sensor_gain[channel]``
    (every feedback sensor's for channel "all", closed loop only).
    The recorded channel of the sensor is that sensor's signal, so the gain
    also shows open loop on a recording of that point: it is tried on
    closed-loop data, and on open-loop time histories that recorded the
    sensor's point.
    """

    effect = "sensor_gain"
    attr = "sensor_gain"
    order = 10

    def _applies(self, ctx):
        return ctx.closed_loop or (self.per_channel and self.channel in ctx.velocity_rms)


class Saturation(_Channel):
    """``saturation``: the amplifiers limit the coil force, on one channel or on all.

    Parameter: ``limit_n`` [N] (log10), ``HardwareChain.amplifier_limit_n``
    (all channels) or ``channel_limit_n[channel]``. Fitted with the
    Gaussian-input describing function: channel ``i`` passes
    ``erf(L / (sqrt(2) sigma_i))`` of its command, ``sigma_i`` the RMS of
    excitation plus control on it (:func:`vlab.diagnose.model.labmodel.with_command_rms`).
    """

    effect = "saturation"
    param_names = ("limit_n",)
    log_scale = (True,)
    needs = "signals"
    order = 13

    def _ref(self, state, ctx) -> float:
        """RMS command [N] of the channel (of the largest channel for "all") on the unlimited lab."""
        if not ctx.command_rms:
            from ..model.labmodel import with_command_rms

            st = with_command_rms(replace(state, chain=replace(state.chain, amplifier_limit_n=1e30)), ctx.freq_hz,
                                  ctx.force_amplitude, excitation_point=ctx.excitation_point, iterations=1)
            ctx.command_rms.update(st.rms_force_n)
        if self.per_channel and self.channel in ctx.command_rms:
            return ctx.command_rms[self.channel]
        return max(ctx.command_rms.values())

    def _space(self, state, ctx):
        r = self._ref(state, ctx)
        return _log_trials(r, (0.5, 1.0, 2.0, 4.0)), np.array([0.02 * r]), np.array([100.0 * r])

    def _apply(self, state, x, ctx):
        from ..model.labmodel import with_command_rms

        st = self._set(state, "amplifier_limit_n", "channel_limit_n", float(x[0]))
        return with_command_rms(st, ctx.freq_hz, ctx.force_amplitude, excitation_point=ctx.excitation_point)
