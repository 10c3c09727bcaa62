"""Hypotheses in the hardware chain of Fig. 21: delay, lags, channel gains, saturation.

Each builds a modified :class:`~vlab.lab.loop.HardwareChain` (Sec. 5.3),
which the frequency-domain model (:mod:`vlab.diagnose.labmodel`) and the
2 kHz loop of a rerun both use.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from .hypothesis import Hypothesis, _log_trials


class LoopDelay(Hypothesis):
    """``loop_delay``: the computation delay from sample to DAC output.

    Parameter: ``delay_s`` [s] (total; the nominal chain has 1.35 periods,
    Sec. 5.3). Sets ``HardwareChain.delay_periods``.
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
        return replace(state, chain=replace(state.chain, delay_periods=float(x[0]) / state.chain.period_s))

    def _null(self, state, ctx):
        return np.array([state.chain.delay_periods * state.chain.period_s])


class _Lag(Hypothesis):
    param_names = ("corner_hz",)
    log_scale = (True,)
    attr = ""

    @property
    def location(self) -> dict:
        return {"channel": "all"}

    def _space(self, state, ctx):
        hi = ctx.band_hz[1]
        return _log_trials(hi, (1.0, 3.0, 10.0, 30.0, 100.0)), np.array([0.1 * hi]), np.array([1e4 * hi])

    def _apply(self, state, x, ctx):
        return replace(state, chain=replace(state.chain, **{self.attr: float(x[0])}))


class ActuatorLag(_Lag):
    """``actuator_lag``: a first-order lag of the coil force on every channel (coil inductance, amplifier bandwidth).

    Parameter: ``corner_hz`` [Hz] (log10). Sets ``HardwareChain.actuator_lag_hz``
    (one corner for all channels: the chain has no per-channel lag). It also
    acts on the excitation, so it shows open loop too.
    """

    effect = "actuator_lag"
    attr = "actuator_lag_hz"
    order = 8


class SensorLag(_Lag):
    """``sensor_lag``: a first-order lag of the velocity sensors fed back (all channels).

    Parameter: ``corner_hz`` [Hz] (log10). Sets ``HardwareChain.sensor_lag_hz``.
    The recorded channel of a feedback sensor is that sensor's signal, so
    the lag also shows open loop at a measured sensor point; the hypothesis
    is still tried only on closed-loop data.
    """

    effect = "sensor_lag"
    attr = "sensor_lag_hz"
    needs = "closed"
    order = 9


class _Gain(Hypothesis):
    param_names = ("gain",)
    log_scale = (True,)
    attr = ""

    def __init__(self, *, channel: int):
        self.channel = channel

    @property
    def location(self) -> dict:
        return {"channel": self.channel}

    def _space(self, state, ctx):
        return _log_trials(1.0, (0.4, 0.65, 0.85, 1.2, 1.6, 2.5)), np.array([0.02]), np.array([50.0])

    def _apply(self, state, x, ctx):
        gains = dict(getattr(state.chain, self.attr))
        gains[self.channel] = gains.get(self.channel, 1.0) * float(x[0])
        return replace(state, chain=replace(state.chain, **{self.attr: gains}))

    def _null(self, state, ctx):
        return np.array([1.0])


class ActuatorGain(_Gain):
    """``actuator_gain``: force per command of one coil channel (amplifier or coil constant off).

    Parameter: ``gain`` [1] (log10) multiplying ``HardwareChain.actuator_gain[channel]``.
    Open loop it shows only on the excitation channel.
    """

    effect = "actuator_gain"
    attr = "actuator_gain"
    order = 10

    def _applies(self, ctx):
        return ctx.closed_loop or self.channel == ctx.excitation_point


class SensorGain(_Gain):
    """``sensor_gain``: sensitivity of one feedback velocity sensor.

    Parameter: ``gain`` [1] (log10) multiplying ``HardwareChain.sensor_gain[channel]``.
    The recorded channel of the sensor is that sensor's signal, so the gain
    also shows open loop on a recording of that point: it is tried on
    closed-loop data, and on open-loop time histories that recorded the
    sensor's point.
    """

    effect = "sensor_gain"
    attr = "sensor_gain"
    order = 10

    def _applies(self, ctx):
        return ctx.closed_loop or self.channel in ctx.velocity_rms


class Saturation(Hypothesis):
    """``saturation``: the amplifiers limit the coil force.

    Parameter: ``limit_n`` [N] (log10), ``HardwareChain.amplifier_limit_n``
    (one limit for all channels, as the chain has). Fitted with the
    Gaussian-input describing function: channel ``i`` passes
    ``erf(L / (sqrt(2) sigma_i))`` of its command, ``sigma_i`` the RMS of
    excitation plus control on it (:func:`vlab.diagnose.labmodel.with_command_rms`).
    """

    effect = "saturation"
    param_names = ("limit_n",)
    log_scale = (True,)
    needs = "signals"
    order = 13

    @property
    def location(self) -> dict:
        return {"channel": "all"}

    def _ref(self, state, ctx) -> float:
        if not ctx.command_rms:
            from .labmodel import with_command_rms

            st = with_command_rms(replace(state, chain=replace(state.chain, amplifier_limit_n=1e30)), ctx.freq_hz,
                                  ctx.force_amplitude, excitation_point=ctx.excitation_point, iterations=1)
            ctx.command_rms.update(st.rms_force_n)
        return max(ctx.command_rms.values())

    def _space(self, state, ctx):
        r = self._ref(state, ctx)
        return _log_trials(r, (0.5, 1.0, 2.0, 4.0)), np.array([0.02 * r]), np.array([100.0 * r])

    def _apply(self, state, x, ctx):
        from .labmodel import with_command_rms

        st = replace(state, chain=replace(state.chain, amplifier_limit_n=float(x[0])))
        return with_command_rms(st, ctx.freq_hz, ctx.force_amplitude, excitation_point=ctx.excitation_point)
