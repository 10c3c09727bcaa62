"""An independent reference simulator of the Beam Cross-Cable.

It builds its own FE model from ``assets/structures/bcc.toml`` (numpy and scipy
only, never vlab), runs the 2 kHz digital loop of Sec. 5.3 (delay, zero-order hold,
RC filter, amplifier, noise) in exact state-space discretisation, and writes
recordings the way a laboratory acquisition system would (UFF 58, ASCII), so that
vlab can be tested on data it did not make. See ``docs/validation/reference-sim.md``.
"""
