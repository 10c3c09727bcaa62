"""The lab's sampled-data loop in the frequency domain: loop gain, sensitivity and stability margins.

The loop of the laboratory (Fig. 21, Sec. 5.3) is the structure ``G(jw)`` -- the velocity FRF from the
coil forces to the collocated velocity sensors, from the full FE model with the structure's damping
(:func:`vlab.fe.damping.structural_damping`) -- closed by the digital controller seen as its equivalent
continuous ``K(jw)`` with the computation delay (1.35 periods), the zero-order hold and the 677 Hz RC filter
(:func:`vlab.analysis.sampled_data_controller_frf`). With ``u = -K y`` and ``y = G u`` the loop broken at
the actuators has the loop gain ``L = K G`` (negative feedback), the return difference ``I + L`` and the
(input) sensitivity ``S = (I + L)^-1``; ``M_s = max_w sigma_max(S)`` is its peak (Skogestad &
Postlethwaite, *Multivariable Feedback Control*, 2nd ed., Wiley 2005, Secs. 2.4.3, 3.3 and 9.2).

Margins are loop-at-a-time (Skogestad & Postlethwaite 2005, Sec. 9.2.2 -- "breaking one loop at a time"):
channel ``i`` is opened with the others closed, its loop gain is
``l_i = L_ii - L_ir (I + L_rr)^-1 L_ri`` (``r`` the other channels), equal to ``1 / [(I + L)^-1]_ii - 1``.
Its gain margin [dB] is ``-20 log10 |l_i|`` where ``l_i`` crosses the negative real axis (phase -180 deg)
and its phase margin [deg] is ``180 - |arg l_i|`` where ``|l_i|`` crosses 1: the smallest phase change,
lag or lead, that puts ``l_i`` on -1. Where ``l_i`` crosses more than once, the smallest margin is kept (of
the gain margins the one nearest to 0 dB, the choice of python-control's ``stability_margins``, which gives
the same numbers on an FRF data object; its signed phase margin is +/- this one). The crossings are found
by this module's own search on the frequency grid (linear interpolation between grid points: ``log |l|``
against ``log f`` for ``|l| = 1``, the complex ``l`` against ``f`` for ``Im l = 0``), so the grid of
:func:`loop_frequencies` resolves every lightly damped mode.

Closed-loop stability is read off the Nyquist plot of ``det(I + L)`` (the generalised Nyquist theorem,
Skogestad & Postlethwaite 2005, Sec. 4.9.2): the loop is stable when ``det(I + L)`` encircles the origin
anti-clockwise as often as ``L`` has unstable poles (the controller's; the damped structure has none).

The margins are those of the loop on the FE model with the equivalent continuous controller, below the
Nyquist frequency (aliasing neglected, as in :func:`vlab.analysis.sampled_data_controller_frf`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..analysis import PC1000_DELAY_PERIODS, RC_CORNER_HZ, sampled_data_controller_frf, velocity_frf
from ..errors import ModelError
from ..fe import FEModel, modal_analysis
from ..fe.damping import open_loop_ratios, structural_damping
from ..spec import input_gains, output_gains

__all__ = ["ChannelMargins", "LoopAnalysis", "analyse_loop", "channel_margins", "loop_at_a_time", "loop_summary",
           "loop_frequencies", "nyquist_encirclements", "sensitivity_sigma_max"]


@dataclass(frozen=True)
class ChannelMargins:
    """Loop-at-a-time stability margins of one channel (the others closed).

    Attributes
    ----------
    point : int
        Actuator/sensor point id of the channel.
    gain_margin_db : float
        ``-20 log10 |l|`` at the phase crossover kept [dB]; ``inf`` when ``l`` never crosses the negative
        real axis on the grid (negative: the loop gain must fall to reach stability margin 0, i.e. the
        crossing lies outside -1).
    phase_crossover_hz : float
        Frequency of that crossing [Hz]; NaN without one.
    phase_margin_deg : float
        ``180 - |arg l|`` at the gain crossover kept [deg], in [0, 180]; ``inf`` when ``|l|`` never crosses 1.
    crossover_hz : float
        Gain crossover frequency of the phase margin [Hz]; NaN without one.
    """

    point: int
    gain_margin_db: float
    phase_crossover_hz: float
    phase_margin_deg: float
    crossover_hz: float


@dataclass(frozen=True)
class LoopAnalysis:
    """The sampled-data loop of one design on the FE model.

    Attributes
    ----------
    freq_hz : ndarray, shape (n_f,)
        Frequency grid [Hz] (:func:`loop_frequencies`).
    points : tuple of int, length n_c
        Actuator = sensor point of each channel.
    plant : ndarray, complex, shape (n_f, n_c, n_c)
        ``G(jw)`` [(m/s)/N], velocity at the sensors per coil force.
    controller : ndarray, complex, shape (n_f, n_c, n_c)
        ``K(jw)`` [N/(m/s)], ``u = -K y``, with delay, hold and RC filter.
    loop_gain : ndarray, complex, shape (n_f, n_c, n_c)
        ``L = K G`` [1].
    channel_gain : ndarray, complex, shape (n_f, n_c)
        Loop-at-a-time gains ``l_i`` [1] (:func:`loop_at_a_time`).
    return_difference_det : ndarray, complex, shape (n_f,)
        ``det(I + L)`` [1] (its Nyquist plot).
    sigma_max_s : ndarray, shape (n_f,)
        Largest singular value of ``S = (I + L)^-1`` [1].
    peak_sensitivity : float
        ``M_s = max sigma_max(S)`` on the grid [1].
    peak_sensitivity_hz : float
        Its frequency [Hz].
    margins : tuple of ChannelMargins, length n_c
    period_s, delay_periods : float
        Sampling period [s] and computation delay [periods] of the controller.
    filter_hz : float or None
        RC corner [Hz] (None: no filter).
    encirclements : int
        Counter-clockwise encirclements of the origin by ``det(I + L)`` over the band, both signs of frequency
        (:func:`nyquist_encirclements`).
    open_loop_unstable_poles : int
        Unstable poles of ``L``: the controller's (eigenvalues of ``F22`` outside the unit circle); the damped
        structure has none.
    closed_loop_unstable_poles : int
        ``open_loop_unstable_poles - encirclements`` (the generalised Nyquist criterion): 0 for a stable loop.
    """

    freq_hz: np.ndarray
    points: tuple[int, ...]
    plant: np.ndarray
    controller: np.ndarray
    loop_gain: np.ndarray
    channel_gain: np.ndarray
    return_difference_det: np.ndarray
    sigma_max_s: np.ndarray
    peak_sensitivity: float
    peak_sensitivity_hz: float
    margins: tuple[ChannelMargins, ...]
    period_s: float
    delay_periods: float
    filter_hz: float | None
    encirclements: int
    open_loop_unstable_poles: int
    closed_loop_unstable_poles: int


def nyquist_encirclements(return_difference_det: np.ndarray) -> int:
    """Counter-clockwise encirclements of the origin by ``det(I + L(jw))`` for ``w`` from -w_max to w_max.

    Parameters
    ----------
    return_difference_det : ndarray, complex, shape (n_f,)
        ``det(I + L)`` on an increasing positive frequency grid, fine enough that its phase changes by less
        than pi between neighbours, from near zero frequency (where ``L`` of velocity feedback vanishes) to the
        end of the band (where ``L`` is small): the curve closes near 1.

    Returns
    -------
    int
        ``round(2 * (change of arg over the grid) / (2 pi))`` (the negative frequencies mirror the positive ones).

    Raises
    ------
    ModelError
        Non-finite values, or a zero on the grid (the loop is on the stability boundary).

    Source: Skogestad & Postlethwaite (2005), Sec. 4.9.2 (generalised Nyquist theorem).
    """
    d = np.asarray(return_difference_det, dtype=complex)
    if not np.all(np.isfinite(d)) or np.any(d == 0):
        raise ModelError("det(I + L) must be finite and non-zero on the grid")
    turns = (np.unwrap(np.angle(d))[-1] - np.angle(d[0])) / (2 * np.pi)
    return int(np.round(2 * turns))


def loop_frequencies(fe: FEModel, period_s: float, *, f_min_hz: float = 0.05, n_log: int = 3000,
                     n_peak: int = 41, fraction_of_nyquist: float = 0.98) -> np.ndarray:
    """Frequency grid for the loop: log-spaced up to near the Nyquist frequency, dense at every mode.

    Parameters
    ----------
    fe : FEModel
        The structure (its natural frequencies and modal damping ratios, :func:`open_loop_ratios`).
    period_s : float
        Sampling period T [s]; the grid ends at ``fraction_of_nyquist / (2 T)``.
    f_min_hz : float
        Lowest frequency [Hz].
    n_log : int
        Number of log-spaced points.
    n_peak : int
        Points over ``f_r (1 +/- 8 zeta_r)`` around each mode ``r`` below the end (half-power bandwidth
        ``2 zeta_r f_r``).
    fraction_of_nyquist : float
        End of the grid as a fraction of the Nyquist frequency, in (0, 1).

    Returns
    -------
    ndarray, shape (n_f,)
        Strictly increasing frequencies [Hz].

    Raises
    ------
    ModelError
        Non-positive period, or ``f_min_hz`` not below the end of the grid.
    """
    if not period_s > 0:
        raise ModelError(f"period_s must be positive, got {period_s!r}")
    f_max = fraction_of_nyquist / (2.0 * period_s)
    if not 0 < f_min_hz < f_max:
        raise ModelError(f"f_min_hz must be in (0, {f_max:g}) Hz, got {f_min_hz!r}")
    fr = modal_analysis(fe.m, fe.k, fe.n).frequencies_hz
    zeta = np.maximum(open_loop_ratios(fe.spec, fe.n), 1e-4)
    parts = [np.geomspace(f_min_hz, f_max, n_log)]
    for f, z in zip(fr, zeta):
        if f_min_hz < f < f_max:
            parts.append(f * (1 + z * np.linspace(-8.0, 8.0, n_peak)))
    f = np.unique(np.concatenate(parts))
    return f[(f >= f_min_hz) & (f <= f_max)]


def loop_at_a_time(loop_gain: np.ndarray) -> np.ndarray:
    """Loop gain of each channel with the other channels closed.

    Parameters
    ----------
    loop_gain : ndarray, complex, shape (n_f, n_c, n_c)
        ``L(jw)``, negative feedback.

    Returns
    -------
    ndarray, complex, shape (n_f, n_c)
        ``l_i = L_ii - L_ir (I + L_rr)^-1 L_ri`` (the Schur complement; ``L_ii`` for one channel).

    Raises
    ------
    ModelError
        ``loop_gain`` not of shape (n_f, n, n).

    Source: Skogestad & Postlethwaite (2005), Sec. 9.2.2 (loop-at-a-time margins).
    """
    lg = np.asarray(loop_gain, dtype=complex)
    if lg.ndim != 3 or lg.shape[1] != lg.shape[2]:
        raise ModelError(f"loop_gain must be (n_f, n, n), got {lg.shape}")
    n = lg.shape[1]
    out = np.empty(lg.shape[:2], dtype=complex)
    for i in range(n):
        r = [j for j in range(n) if j != i]
        out[:, i] = lg[:, i, i]
        if r:
            lrr = np.eye(n - 1) + lg[:, r][:, :, r]
            out[:, i] -= np.einsum("fj,fj->f", lg[:, i, r], np.linalg.solve(lrr, lg[:, r, i][:, :, None])[:, :, 0])
    return out


def sensitivity_sigma_max(loop_gain: np.ndarray) -> np.ndarray:
    """Largest singular value of the sensitivity ``S = (I + L)^-1`` at each frequency.

    Parameters
    ----------
    loop_gain : ndarray, complex, shape (n_f, n_c, n_c)
        ``L(jw)``.

    Returns
    -------
    ndarray, shape (n_f,)
        ``sigma_max(S) = 1 / sigma_min(I + L)`` [1].

    Source: Skogestad & Postlethwaite (2005), Sec. 3.3.
    """
    lg = np.asarray(loop_gain, dtype=complex)
    rd = np.eye(lg.shape[1]) + lg
    return 1.0 / np.linalg.svd(rd, compute_uv=False)[:, -1]


def _gain_crossings(f: np.ndarray, l: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Frequencies [Hz] where ``|l|`` crosses 1 and ``l`` there (linear in log |l| vs log f; l linear in f)."""
    lm = np.log(np.abs(l))
    i = np.nonzero(np.sign(lm[:-1]) * np.sign(lm[1:]) < 0)[0]
    t = lm[i] / (lm[i] - lm[i + 1])
    fc = np.exp(np.log(f[i]) + t * (np.log(f[i + 1]) - np.log(f[i])))
    s = (fc - f[i]) / (f[i + 1] - f[i])
    return fc, l[i] + s * (l[i + 1] - l[i])


def _phase_crossings(f: np.ndarray, l: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Frequencies [Hz] where ``l`` crosses the negative real axis and ``Re l`` there (l linear in f)."""
    im = l.imag
    i = np.nonzero(np.sign(im[:-1]) * np.sign(im[1:]) < 0)[0]
    t = im[i] / (im[i] - im[i + 1])
    re = l.real[i] + t * (l.real[i + 1] - l.real[i])
    keep = re < 0
    return (f[i] + t * (f[i + 1] - f[i]))[keep], re[keep]


def channel_margins(freq_hz: np.ndarray, gain: np.ndarray, point: int = 0) -> ChannelMargins:
    """Gain and phase margin of one loop gain on a frequency grid (own crossing search).

    Parameters
    ----------
    freq_hz : ndarray, shape (n_f,)
        Strictly increasing frequencies [Hz].
    gain : ndarray, complex, shape (n_f,)
        Loop gain ``l(jw)`` [1], negative feedback.
    point : int
        Point id recorded in the result.

    Returns
    -------
    ChannelMargins
        Of the phase crossovers the one with the smallest ``|gain margin [dB]|``; of the gain crossovers
        the one with the smallest phase margin.

    Raises
    ------
    ModelError
        Shapes that differ, frequencies not increasing, non-finite or zero gains.

    Source: Skogestad & Postlethwaite (2005), Sec. 2.4.3 (``GM = 1 / |L(j w_180)|``, ``PM = angle L(j w_c) + 180 deg``).
    """
    f = np.asarray(freq_hz, dtype=float)
    l = np.asarray(gain, dtype=complex)
    if f.ndim != 1 or l.shape != f.shape or f.size < 2 or np.any(np.diff(f) <= 0):
        raise ModelError(f"channel_margins: increasing freq_hz and gain of one shape (n_f,); got {f.shape}, {l.shape}")
    if not np.all(np.isfinite(l)) or np.any(l == 0):
        raise ModelError("channel_margins: the loop gain must be finite and non-zero")
    fp, re = _phase_crossings(f, l)
    gm, fpc = np.inf, np.nan
    if fp.size:
        gms = -20.0 * np.log10(np.abs(re))
        k = int(np.argmin(np.abs(gms)))
        gm, fpc = float(gms[k]), float(fp[k])
    fc, lc = _gain_crossings(f, l)
    pm, fgc = np.inf, np.nan
    if fc.size:
        pms = 180.0 - np.abs(np.degrees(np.angle(lc)))
        k = int(np.argmin(pms))
        pm, fgc = float(pms[k]), float(fc[k])
    return ChannelMargins(int(point), gm, fpc, pm, fgc)


def analyse_loop(fe: FEModel, design, *, freq_hz: np.ndarray | None = None,
                 delay_periods: float = PC1000_DELAY_PERIODS, filter_hz: float | None = RC_CORNER_HZ) -> LoopAnalysis:
    """Loop gain, sensitivity and loop-at-a-time margins of a design in the lab's sampled-data loop.

    Parameters
    ----------
    fe : FEModel
        The full FE model of the structure (the plant; its spec's actuators are the channels and its
        damping the structure's, :func:`vlab.fe.damping.structural_damping`).
    design : ControllerDesign
        The controller (:func:`vlab.design.design_controller`; its Eq. (5.1) realization ``f11``-``f22`` at
        ``design.period_s``, one sensor per actuator).
    freq_hz : ndarray, shape (n_f,), optional
        Frequencies [Hz] below the Nyquist frequency; default :func:`loop_frequencies`.
    delay_periods : float
        Computation delay [sampling periods] (Sec. 5.3: 1.35).
    filter_hz : float or None
        RC filter corner [Hz] (Sec. 5.3: 677 Hz); None: no filter.

    Returns
    -------
    LoopAnalysis

    Raises
    ------
    ModelError
        An LQR design (full-state feedback, no sensor loop), a design whose channels are not the spec's
        actuators, frequencies not increasing or at/above the Nyquist frequency.

    Source: Fig. 21 and Sec. 5.3 (the loop and its chain), Eq. (5.1); Skogestad & Postlethwaite (2005),
    Secs. 2.4.3, 3.3, 9.2.
    """
    acts = tuple(fe.spec.instrumentation.actuators)
    if design.controller == "lqr":
        raise ModelError("LQR feeds back every state, not the sensors: it has no loop through the lab's chain "
                         "(analyse lqg, mfdrf, lqdrf or lqdrf-diag)")
    if design.f11.shape != (len(acts), len(acts)):
        raise ModelError(f"{fe.spec.name}: design {design.controller} maps {design.f11.shape[1]} sensors to "
                         f"{design.f11.shape[0]} actuators; the structure has {len(acts)} collocated pairs {acts}")
    period = float(design.period_s)
    f = loop_frequencies(fe, period) if freq_hz is None else np.asarray(freq_hz, dtype=float)
    if f.ndim != 1 or f.size < 2 or np.any(np.diff(f) <= 0) or f[0] <= 0 or f[-1] >= 0.5 / period:
        raise ModelError(f"freq_hz must increase within (0, {0.5 / period:g}) Hz (the Nyquist frequency)")
    u = fe.force_input(acts)
    # the coils' and sensors' gains of the structure file's [hardware] table, if any
    g = velocity_frf(fe.m, structural_damping(fe), fe.k, u * input_gains(fe.spec, acts),
                     (u * output_gains(fe.spec, acts)).T, f)
    k = sampled_data_controller_frf(f, design.f11, design.f12, design.f21, design.f22, period,
                                    delay_periods=delay_periods, filter_hz=filter_hz)
    lg = k @ g
    li = loop_at_a_time(lg)
    sig = sensitivity_sigma_max(lg)
    j = int(np.argmax(sig))
    det = np.linalg.det(np.eye(len(acts)) + lg)
    margins = tuple(channel_margins(f, li[:, i], p) for i, p in enumerate(acts))
    n_enc = nyquist_encirclements(det)
    p_ol = int(np.sum(np.abs(np.linalg.eigvals(design.f22)) > 1.0)) if design.f22.size else 0
    return LoopAnalysis(f, acts, g, k, lg, li, det, sig, float(sig[j]), float(f[j]), margins, period,
                        float(delay_periods), filter_hz, n_enc, p_ol, p_ol - n_enc)


def _finite_or_none(x: float) -> float | None:
    return float(x) if np.isfinite(x) else None


def loop_summary(analysis: LoopAnalysis) -> dict:
    """The margins and the peak sensitivity as a JSON-ready dict (keys with units; no margin: None).

    Parameters
    ----------
    analysis : LoopAnalysis
        From :func:`analyse_loop`.

    Returns
    -------
    dict
        ``peak_sensitivity``, ``peak_sensitivity_hz``, the chain (``period_s``, ``delay_periods``,
        ``filter_hz``), ``nyquist`` (the generalised Nyquist criterion on ``det(I + L)``: encirclements,
        open- and closed-loop unstable poles, ``stable``), ``margin_method``, ``freq_range_hz`` (the grid)
        and ``channels``: one dict per channel with ``point``, ``gain_margin_db``, ``phase_crossover_hz``,
        ``phase_margin_deg`` and ``crossover_hz`` (None where the loop gain has no such crossing on the grid).
    """
    a = analysis
    return {
        "peak_sensitivity": a.peak_sensitivity,
        "peak_sensitivity_hz": a.peak_sensitivity_hz,
        "period_s": a.period_s,
        "delay_periods": a.delay_periods,
        "filter_hz": a.filter_hz,
        "freq_range_hz": [float(a.freq_hz[0]), float(a.freq_hz[-1])],
        "nyquist": {"encirclements_ccw": a.encirclements, "open_loop_unstable_poles": a.open_loop_unstable_poles,
                    "closed_loop_unstable_poles": a.closed_loop_unstable_poles,
                    "stable": a.closed_loop_unstable_poles == 0},
        "margin_method": "loop-at-a-time (each channel opened, the others closed), own crossing search",
        "channels": [{"point": m.point, "gain_margin_db": _finite_or_none(m.gain_margin_db),
                      "phase_crossover_hz": _finite_or_none(m.phase_crossover_hz),
                      "phase_margin_deg": _finite_or_none(m.phase_margin_deg),
                      "crossover_hz": _finite_or_none(m.crossover_hz)} for m in a.margins],
    }
