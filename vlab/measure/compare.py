"""Analysis against experiment, mode by mode, as Tables 10 and 19-21 do.

Both FRFs -- the analytical one and the measured one -- are treated alike:
the modal parameters of each mode are identified from each FRF with the same
curve fit (:func:`vlab.measure.modal_fit.fit_modes`) near the predicted closed-loop
frequency, and the peak levels are read the same way
(:func:`vlab.measure.modal.peak_levels`). The peak level ratio is
analysis / experiment; the average error is ``mean |1 - ratio|`` (Tables 10,
19-21).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from ..errors import MeasurementError
from .modal import average_peak_error, paired_peak_levels, peak_levels
from .modal_fit import fit_each_mode, fit_half_bands


@dataclass(frozen=True)
class ModeComparison:
    """One mode: predicted vs measured frequency [Hz], damping ratio, peak level.

    "Predicted" values are identified from the analytical FRF, "measured" ones
    from the experimental FRF, with the same curve fit; NaN where a mode could
    not be identified.

    Attributes
    ----------
    mode : int
        Mode number, 1-based, in order of the predicted closed-loop frequencies.
    frequency_predicted_hz, frequency_measured_hz : float
        Natural frequency identified in the analytical / measured FRF [Hz].
    damping_predicted, damping_measured : float
        Damping ratio zeta [-] identified in the analytical / measured FRF.
    peak_predicted, peak_measured : float
        Peak level ``|H|`` at the mode in the analytical / measured FRF, in the
        FRF's units ([m/N] for displacement, [(m/s)/N] for velocity FRFs).
    peak_level_ratio : float
        ``peak_predicted / peak_measured``, the dissertation's analytical /
        experimental peak level ratio (Tables 2, 10, 19-21).
    response : str
        ``"displacement"`` or ``"velocity"``: the FRF's quantity, which sets the
        unit of the peak levels (and their keys in :meth:`as_dict`).
    """

    mode: int
    frequency_predicted_hz: float
    frequency_measured_hz: float
    damping_predicted: float
    damping_measured: float
    peak_predicted: float
    peak_measured: float
    peak_level_ratio: float
    response: str = "displacement"

    def as_dict(self) -> dict:
        """JSON-ready dict with the stable keys of results.json, each number's unit in its key.

        The peak levels are ``peak_predicted_m_per_n``/``peak_measured_m_per_n``
        for a displacement FRF and ``..._m_s_per_n`` for a velocity FRF.
        """
        unit = {"displacement": "m_per_n", "velocity": "m_s_per_n"}[self.response]
        out = {}
        for k, v in asdict(self).items():
            if k in ("peak_predicted", "peak_measured"):
                k = f"{k}_{unit}"
            out[k] = float(v) if isinstance(v, (float, np.floating)) else v
        return out


def compare_modes(
    freq_hz: np.ndarray,
    h_analysis: np.ndarray,
    h_experiment: np.ndarray,
    modes_hz: np.ndarray,
    damping_hint: np.ndarray,
    *,
    response: str = "displacement",
) -> list[ModeComparison]:
    """Identify and compare each mode in an analytical and a measured FRF.

    Parameters
    ----------
    freq_hz : ndarray, shape (n_f,)
        Common frequency lines [Hz].
    h_analysis, h_experiment : ndarray, complex, shape (n_f,)
        Analytical and measured FRF on ``freq_hz``, same quantity and units
        ([m/N] or [(m/s)/N]).
    modes_hz : ndarray, shape (n_modes,)
        Predicted closed-loop natural frequencies [Hz].
    damping_hint : ndarray, shape (n_modes,)
        Predicted damping ratios, used to size the fitted bands.
    response : str
        FRF quantity ("displacement" or "velocity").

    Returns
    -------
    list of ModeComparison
        Modes that could be identified in both FRFs; a mode whose peak is not
        found in a FRF gets NaN values.
    """
    df = float(np.median(np.diff(freq_hz)))
    modes_hz = np.asarray(modes_hz, dtype=float)
    halves = fit_half_bands(freq_hz, modes_hz, damping_hint)
    # all modes at once (overlapping bands of close modes fitted together), else one by one
    fits = [fit_each_mode(freq_hz, h, modes_hz, halves, response=response) for h in (h_analysis, h_experiment)]
    out = []
    for i, (fit_a, fit_e, half) in enumerate(zip(*fits, halves)):
        fa, za = (fit_a.freq_hz, fit_a.damping_ratio) if fit_a is not None else (np.nan, np.nan)
        fe, ze = (fit_e.freq_hz, fit_e.damping_ratio) if fit_e is not None else (np.nan, np.nan)
        hb = max(half / 3, 2 * df)
        try:
            if fit_a is not None and fit_e is not None:  # both read by one rule on one window
                pa, pe = paired_peak_levels(freq_hz, h_analysis, h_experiment, fa, fe, half_band_hz=hb)
            else:  # one FRF's mode not identified: the other's level alone, for the record
                pa, pe = (np.nan if np.isnan(fm) else peak_levels(freq_hz, h, [fm], half_band_hz=hb)[0]
                          for h, fm in ((h_analysis, fa), (h_experiment, fe)))
        except MeasurementError:
            pa = pe = np.nan
        out.append(ModeComparison(i + 1, fa, fe, za, ze, pa, pe, pa / pe if pe else np.nan, response))
    return out


def average_error(comparisons: list[ModeComparison]) -> float:
    """Average peak error ``mean |1 - r|`` over the identified modes (Tables 10, 19-21).

    Parameters
    ----------
    comparisons : list of ModeComparison
        Per-mode comparisons (:func:`compare_modes`); modes whose
        ``peak_level_ratio`` r is NaN or infinite are left out.

    Returns
    -------
    float
        The average error [-], NaN when no mode has a finite ratio.
    """
    return finite_average_error([c.peak_level_ratio for c in comparisons])


def finite_average_error(ratios) -> float:
    """``mean |1 - r|`` over the finite peak level ratios (Tables 10, 19-21); NaN if none.

    Parameters
    ----------
    ratios : array_like, shape (n_modes,)
        Peak level ratios [-]; NaN or infinite for modes that were not identified.

    Returns
    -------
    float
        The average error [-] of the identified modes, NaN when none is finite.
    """
    r = np.asarray(ratios, dtype=float)
    r = r[np.isfinite(r)]
    return float(average_peak_error(r)) if r.size else float("nan")
