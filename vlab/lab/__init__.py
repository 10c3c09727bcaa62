"""The 2 kHz digital control loop with its hardware chain, its excitation and its plants.

Modules
-------
blocks
    Loop blocks of Fig. 21: :class:`~vlab.lab.blocks.ZeroOrderHold`,
    :class:`~vlab.lab.blocks.SampleDelay` (the PC-1000's 1.35-period delay),
    :class:`~vlab.lab.blocks.RCLowPass` (677 Hz),
    :class:`~vlab.lab.blocks.CurrentAmplifier`, :class:`~vlab.lab.blocks.SensorNoise`.
block
    :class:`~vlab.lab.block.Block`, the base of the blocks: channel count and input checks.
engine
    :class:`~vlab.lab.engine.ControllerEngine`, Eq. (5.1).
excitation
    Pseudo-random, filtered random, sweeps, stepped sine, half-sine pulse.
loop
    :func:`~vlab.lab.loop.run_loop`: the sampled loop of Fig. 21 around one plant.
batch, batch_chain
    The same loop run on many plants at once, one column per run.
linear_plant
    :class:`~vlab.lab.linear_plant.LinearPlant`, the FE model's state space as a plant.

The loop's output, :class:`~vlab.io.recording.Recording` (with :class:`~vlab.io.recording.Channel`),
is defined in :mod:`vlab.io.recording` and re-exported here.
"""

from ..io.recording import Channel, Recording
from .blocks import (PC1000_DELAY_PERIODS, PC1000_PERIOD_S, RC_CORNER_HZ, CurrentAmplifier,
                     RCLowPass, SampleDelay, SensorNoise, ZeroOrderHold)
from .engine import ControllerEngine

__all__ = [
    "PC1000_DELAY_PERIODS", "PC1000_PERIOD_S", "RC_CORNER_HZ",
    "ZeroOrderHold", "SampleDelay", "RCLowPass", "CurrentAmplifier", "SensorNoise",
    "ControllerEngine", "Channel", "Recording",
]
