"""Resonances a model lacks, all channels pooled (vlab.diagnose.fit.resonances), on closed-form modal FRFs."""

from __future__ import annotations

import numpy as np

from vlab.diagnose.fit.resonances import unpaired_peaks


def _frf(f_hz, modes):
    """Velocity FRF of uncoupled modes ``(f_r [Hz], zeta_r, residue)`` (closed form), shape (n_f,)."""
    w = 2 * np.pi * np.asarray(f_hz)
    return sum(a * 1j * w / ((2 * np.pi * fr) ** 2 - w**2 + 2j * z * (2 * np.pi * fr) * w) for fr, z, a in modes)


F = np.arange(0.5, 30.0, 0.01)
COMMON = [(2.0, 0.01, 1.0), (9.5, 0.01, 1.0), (14.0, 0.01, 1.0), (25.0, 0.01, 1.0)]


def test_a_local_mode_the_model_shows_at_another_channel_is_the_models():
    """Measured: a local mode at 19.7 Hz seen at channel 7 only; the model has it at 18.3 Hz (7 % lower), seen
    at channel 6 only (its node moved): the model has that resonance."""
    meas = np.stack([_frf(F, COMMON), _frf(F, COMMON + [(19.7, 0.005, 0.5)])], axis=1)
    model = np.stack([_frf(F, COMMON + [(18.3, 0.005, 0.5)]), _frf(F, COMMON)], axis=1)
    assert unpaired_peaks(F, meas, model, [6, 7]) == []
    # a model without it anywhere lacks it
    bare = np.stack([_frf(F, COMMON), _frf(F, COMMON)], axis=1)
    assert [round(r["frequency_hz"], 1) for r in unpaired_peaks(F, meas, bare, [6, 7])] == [19.7]


def test_a_misplaced_resonance_is_the_models_a_new_one_is_not():
    """Between the shared 14 and 25 Hz modes the measurement has a resonance at 16.2 Hz and the model one at
    18.5 Hz (12 %, beyond the match): the same degree of freedom, misplaced. A second measured one there
    (21.5 Hz) has no spare partner: a resonance the model lacks."""
    meas = _frf(F, COMMON + [(16.2, 0.005, 0.5)])[:, None]
    model = _frf(F, COMMON + [(18.5, 0.005, 0.5)])[:, None]
    assert unpaired_peaks(F, meas, model, [5]) == []
    two = _frf(F, COMMON + [(16.2, 0.005, 0.5), (21.5, 0.005, 0.4)])[:, None]
    assert [round(r["frequency_hz"], 1) for r in unpaired_peaks(F, two, model, [5])] == [21.5]


def test_a_channel_at_a_node_does_not_count_resonances():
    """Channel 5 sits at the node of the 9.5 Hz mode and shows an absorber's 12.6 Hz resonance; channel 9 shows
    both. On channel 5 alone the model's 9.5 Hz would look like a spare partner for 12.6 Hz; on the structure
    the measured 9.5 Hz takes it, and 12.6 Hz is a resonance the model lacks."""
    at_node = [m for m in COMMON if m[0] != 9.5]
    meas = np.stack([_frf(F, at_node + [(12.6, 0.02, 0.5)]), _frf(F, COMMON + [(12.6, 0.02, 0.5)])], axis=1)
    model = np.stack([_frf(F, COMMON), _frf(F, COMMON)], axis=1)
    (extra,) = unpaired_peaks(F, meas, model, [5, 9])
    assert abs(extra["frequency_hz"] / 12.6 - 1) < 0.01
