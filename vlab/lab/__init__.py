"""The experiment: excitation, the 2 kHz digital control loop, and its output.

Modules
-------
blocks
    Loop blocks of Fig. 21: :class:`~vlab.lab.blocks.ZeroOrderHold`,
    :class:`~vlab.lab.blocks.SampleDelay` (the PC-1000's 1.35-period delay),
    :class:`~vlab.lab.blocks.RCLowPass` (677 Hz),
    :class:`~vlab.lab.blocks.CurrentAmplifier`, :class:`~vlab.lab.blocks.SensorNoise`.
engine
    :class:`~vlab.lab.engine.ControllerEngine`, Eq. (5.1).
excitation
    Pseudo-random, filtered random, sweeps, stepped sine, half-sine pulse.
recording
    :class:`~vlab.lab.recording.Recording`, the output of an experiment.
"""

from .blocks import (PC1000_DELAY_PERIODS, PC1000_PERIOD_S, RC_CORNER_HZ, CurrentAmplifier,
                     RCLowPass, SampleDelay, SensorNoise, ZeroOrderHold)
from .engine import ControllerEngine
from .recording import Channel, Recording

__all__ = [
    "PC1000_DELAY_PERIODS", "PC1000_PERIOD_S", "RC_CORNER_HZ",
    "ZeroOrderHold", "SampleDelay", "RCLowPass", "CurrentAmplifier", "SensorNoise",
    "ControllerEngine", "Channel", "Recording",
]
