"""Checks of a finished run: peaks too narrow for the lines, self-excited oscillations (Sec. 6.1, 6.2.1).

Each check returns warning messages; a warning containing
:data:`NOT_MEANINGFUL` marks a run whose FRF comparison cannot be used
(:func:`not_meaningful`), and ``vlab experiment`` then exits with status 1.
"""

from __future__ import annotations

import numpy as np

from ..errors import ModelError


def under_resolved_peaks(freq_hz, damping, resolution_hz: float, *, lines_per_bandwidth: float = 2.0) -> list[str]:
    """Warn about modes whose half-power bandwidth ``2 zeta f`` spans fewer than ``lines_per_bandwidth`` lines.

    Peak levels are read on the FRF lines (:func:`vlab.measure.modal.peak_levels`,
    Sec. 5.4.1). A peak narrower than the line spacing ``df`` may fall
    between lines: a line ``df / 2`` from the natural frequency shows only
    ``1 / sqrt(1 + (df / (2 zeta f))^2)`` of the peak (single mode near
    resonance). Analysis and experiment are read on the same lines, so their
    ratio is right when both peaks sit at the same frequency; a plant whose
    mode is shifted by a fraction of a line changes the measured level by up
    to that factor (the dissertation's explanation of its open-loop ratios,
    Sec. 6.1, Table 2).

    Parameters
    ----------
    freq_hz : array_like, shape (n_modes,)
        Predicted natural frequencies [Hz].
    damping : array_like, shape (n_modes,)
        Predicted damping ratios zeta [-].
    resolution_hz : float
        FRF line spacing ``df`` [Hz].
    lines_per_bandwidth : float
        Lines a half-power bandwidth should span to be resolved.

    Returns
    -------
    list of str
        Empty, or one message listing every under-resolved mode with its
        frequency, zeta, bandwidth and the worst-case level read on a line.

    Raises
    ------
    ModelError
        Shapes differ or a non-positive resolution.
    """
    f = np.asarray(freq_hz, dtype=float)
    z = np.asarray(damping, dtype=float)
    if f.shape != z.shape or f.ndim != 1:
        raise ModelError(f"freq_hz {f.shape} and damping {z.shape} must be equal 1-D shapes")
    if not resolution_hz > 0:
        raise ModelError(f"resolution_hz must be > 0, got {resolution_hz!r}")
    bw = 2 * z * f
    bad = [i for i in range(f.size) if np.isfinite(bw[i]) and 0 < bw[i] < lines_per_bandwidth * resolution_hz]
    if not bad:
        return []
    parts = []
    for i in bad:
        worst = 1.0 / np.sqrt(1.0 + (resolution_hz / bw[i]) ** 2)
        parts.append(f"mode {i + 1} ({f[i]:.2f} Hz, zeta {z[i]:.4f}, bandwidth {bw[i]:.3f} Hz: a line may read "
                     f"{100 * worst:.0f} % of the peak)")
    return [f"peaks narrower than {lines_per_bandwidth:g} lines of {resolution_hz:g} Hz: " + "; ".join(parts)
            + ". Analysis and experiment are read on the same lines; where the plant's mode is shifted by a fraction "
              "of a line the peak level ratio of that mode is biased by up to that factor: use a finer resolution"]


#: Phrase that marks a warning saying the run's FRF comparison cannot be used (see :func:`not_meaningful`).
NOT_MEANINGFUL = "the FRF comparison is not meaningful"


def not_meaningful(warnings) -> list[str]:
    """The warnings that say the run's FRF comparison is not meaningful.

    ``vlab experiment`` exits with status 1 when there is one, unless
    ``--allow-unstable``.

    Parameters
    ----------
    warnings : sequence of str
        Warnings of a run (:attr:`vlab.experiment.runner.ExperimentResult.warnings`).

    Returns
    -------
    list of str
        Those containing :data:`NOT_MEANINGFUL` (a self-excited oscillation or limit cycle).
    """
    return [w for w in warnings if NOT_MEANINGFUL in w]


def oscillation_above_band(v: np.ndarray, dt_s: float, *, band_hz: tuple[float, float]):
    """The dominant frequency above ``1.2 band_hz[1]`` and its share of the RMS, or None below half the power.

    ``v`` (shape (n,), [m/s]) sampled every ``dt_s`` [s], ``band_hz`` the excitation band [Hz], as in
    :func:`self_excited_oscillation`. Returns ``(frequency [Hz], RMS share [-])`` or None.
    """
    spec = np.abs(np.fft.rfft(v - np.mean(v))) ** 2
    f = np.fft.rfftfreq(len(v), dt_s)
    out = f > 1.2 * band_hz[1]
    total = spec.sum()
    if total <= 0 or spec[out].sum() < 0.5 * total:
        return None
    return float(f[out][np.argmax(spec[out])]), float(np.sqrt(spec[out].sum() / total))


def self_excited_oscillation(v: np.ndarray, dt_s: float, *, band_hz: tuple[float, float]) -> list[str]:
    """Warn when most of the response lies outside the excitation band.

    A closed loop that destabilises a residual mode (spillover, Sec. 6.2.1) or
    runs into a limit cycle (Sec. 6.1: "a limit cycle at approximately 41 Hz")
    responds mostly at a frequency the excitation does not contain.

    Parameters
    ----------
    v : ndarray, shape (n,)
        Response velocity [m/s].
    dt_s : float
        Sampling interval [s].
    band_hz : (float, float)
        Excitation band [Hz].

    Returns
    -------
    list of str
        Empty, or one message naming the dominant frequency and its share of the RMS.
    """
    found = oscillation_above_band(v, dt_s, band_hz=band_hz)
    if found is None:
        return []
    f_dom, share = found
    return [
        f"self-excited oscillation at {f_dom:.1f} Hz ({100 * share:.0f} % of the response RMS lies above the "
        f"excitation band): the controller destabilises a mode outside its design model (spillover), a mode the "
        f"plant damps less than the model, or the loop runs in a limit cycle; {NOT_MEANINGFUL}"
    ]
