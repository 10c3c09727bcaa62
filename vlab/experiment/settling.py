"""How long an experiment lets its start-up transient settle (Sec. 5.4.1).

Every excitation repeats once per record of ``1 / resolution_hz`` seconds; the
first records are discarded until the slowest predicted mode's free response,
decaying as ``exp(-zeta omega_n t)``, has fallen to :data:`SETTLE_TOLERANCE`
of its start. :func:`slowest_decay_rate` predicts that rate from the FE model
and the controller; :func:`settle_records` turns it into a number of records.
"""

from __future__ import annotations

import numpy as np

from ..analysis import closed_loop_modes
from ..errors import ModelError
from ..fe import FEModel
from ..fe.damping import structural_damping
from ..spec import input_gains
from .config import test_of

#: Remaining share of the start-up transient (relative to its initial amplitude) allowed when the
#: settling records end; the records measured after it see a transient below this level.
SETTLE_TOLERANCE = 0.01


def settle_records(decay_rate_1_s: float | None, record_s: float, *, tolerance: float = SETTLE_TOLERANCE) -> int:
    """Records to discard so that the start-up transient has decayed to ``tolerance``.

    The free response started with the excitation decays as
    ``exp(-sigma t)`` with ``sigma = zeta * 2 pi f_n`` of the slowest mode;
    ``n = max(1, ceil(ln(1 / tolerance) / (sigma * record_s)))`` records bring
    it below ``tolerance`` of its initial size (which is about the mode's
    steady-state amplitude when the run starts at rest).

    Parameters
    ----------
    decay_rate_1_s : float or None
        Slowest decay rate ``sigma = zeta omega_n`` of the modes in band [1/s];
        None = one record (no damping known).
    record_s : float
        Record length [s].
    tolerance : float
        Transient share left at the end of the settling records [-], in (0, 1).

    Returns
    -------
    int
        Number of settling records, at least 1.

    Raises
    ------
    ModelError
        A non-positive record length or decay rate, or a tolerance outside (0, 1).
    """
    if not record_s > 0:
        raise ModelError(f"record_s must be > 0, got {record_s!r}")
    if not 0 < tolerance < 1:
        raise ModelError(f"tolerance must lie in (0, 1), got {tolerance!r}")
    if decay_rate_1_s is None:
        return 1
    if not (np.isfinite(decay_rate_1_s) and decay_rate_1_s > 0):
        raise ModelError(f"decay_rate_1_s must be a positive finite rate [1/s], got {decay_rate_1_s!r}")
    return max(1, int(np.ceil(np.log(1.0 / tolerance) / (decay_rate_1_s * record_s) - 1e-9)))


def predicted_modes(fe: FEModel, design=None, chain=None) -> tuple[np.ndarray, np.ndarray]:
    """Frequencies and damping ratios of the continuous closed loop's first test modes in the test's band.

    The coils' gains of the structure file's ``[hardware]`` table scale the input matrix ``U`` (Eq. 3.1);
    with ``chain``, its amplifier and actuator gains scale ``U`` too and its sensor gains the outputs
    (its delays and lags are not part of the continuous loop).

    Parameters
    ----------
    fe : FEModel
        The nominal FE model with the spec's open-loop modal damping (its spec selects the test).
    design : ControllerDesign, optional
        The controller (its ``continuous`` form); None = open loop.
    chain : HardwareChain, optional
        The run's chain (:class:`vlab.lab.loop.HardwareChain`); None = ideal gains.

    Returns
    -------
    freq_hz, damping : ndarray, shape (n,)
        Natural frequencies [Hz] and damping ratios [-] (:func:`vlab.analysis.closed_loop_modes`),
        at most the test's ``n_modes``.

    Raises
    ------
    SpecError
        Structure without a test definition.
    """
    test, acts, _ = test_of(fe)
    c = structural_damping(fe)
    u = fe.force_input(acts)
    gi, go = input_gains(fe.spec, acts), np.ones(len(acts))
    if chain is not None:
        gi = gi * chain.amplifier_gain * np.array([chain.actuator_gain.get(p, 1.0) for p in acts])
        go = np.array([chain.sensor_gain.get(p, 1.0) for p in acts])
    fm, zm = closed_loop_modes(fe.m, c, fe.k, u * gi, (u * go).T, None if design is None else design.continuous)
    in_band = (fm >= test.band_hz[0]) & (fm <= test.band_hz[1])
    return fm[in_band][: test.n_modes], zm[in_band][: test.n_modes]


def slowest_decay_rate(fe: FEModel, design=None) -> float | None:
    """Slowest decay rate ``zeta_r omega_r`` [1/s] of the predicted modes in the test's band.

    The modes are those of the continuous closed loop on the FE model with
    the spec's open-loop modal damping (:func:`vlab.analysis.closed_loop_modes`;
    open loop when ``design`` is None), the first ``n_modes`` of the test in
    its band (:func:`~vlab.experiment.config.test_definition`). It sets how many records
    :func:`~vlab.experiment.runner.measure` lets settle (:func:`settle_records`).

    Parameters
    ----------
    fe : FEModel
        The nominal FE model (its spec selects the test).
    design : ControllerDesign, optional
        The controller (its ``continuous`` form); None = open loop.

    Returns
    -------
    float or None
        The smallest positive finite decay rate [1/s]; None when no mode in the band has one.

    Raises
    ------
    SpecError
        Structure without a test definition (:func:`~vlab.experiment.config.test_definition`).
    """
    fm, zm = predicted_modes(fe, design)
    sigma = 2 * np.pi * fm * zm
    sigma = sigma[np.isfinite(sigma) & (sigma > 0)]
    return float(sigma.min()) if sigma.size else None
