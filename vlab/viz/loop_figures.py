"""The feedback loop's figure: Bode and Nyquist plots of the loop gains and the sensitivity's largest singular value.

Four panels: the Bode magnitude [dB] and phase [deg] of each loop-at-a-time gain ``l_i(jw)`` on a
logarithmic frequency axis (0 dB and -180 deg drawn; the gain and phase crossovers marked), the Nyquist
plot of each ``l_i`` around the critical point -1 (with the unit circle; optionally ``det(I + L) - 1``),
and ``sigma_max(S(jw))`` of the sensitivity ``S = (I + L)^-1`` [dB] with its peak ``M_s`` marked. The
phase is unwrapped along frequency, starting in (-180, 180].

Like :mod:`vlab.viz.figures`, the figure is built on :class:`matplotlib.figure.Figure` with the Agg canvas
(no pyplot, no window). :func:`loop_axes` builds it and returns it; its data lines carry ``gid``
``"bode-magnitude:<label>"``, ``"bode-phase:<label>"``, ``"nyquist:<label>"`` and ``"sigma-max-s"``;
:func:`loop_figure` writes it to a file.

Source: Skogestad & Postlethwaite, *Multivariable Feedback Control* (2nd ed., Wiley, 2005), Secs. 2.2
(Bode plots), 2.4.3 (margins on the Bode and Nyquist plots) and 3.3 (singular values of S).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import MeasurementError
from .figures import _freq, _save

__all__ = ["loop_axes", "loop_figure", "unwrapped_phase_deg"]


def unwrapped_phase_deg(gain: Any) -> np.ndarray:
    """Phase of a frequency response [deg], unwrapped along frequency, its first value in (-180, 180].

    Parameters
    ----------
    gain : array_like, complex, shape (n_f,)
        Frequency response.

    Returns
    -------
    ndarray, shape (n_f,)
    """
    return np.degrees(np.unwrap(np.angle(np.asarray(gain, dtype=complex))))


def _gains(freq_hz: np.ndarray, channel_gain: Any, labels: Sequence[str]) -> np.ndarray:
    lg = np.asarray(channel_gain, dtype=complex)
    if lg.ndim != 2 or lg.shape != (freq_hz.size, len(labels)):
        raise MeasurementError(f"channel_gain: expected shape ({freq_hz.size}, {len(labels)}) (one column per "
                               f"label), got {lg.shape}")
    if not np.all(np.isfinite(lg)) or np.any(lg == 0):
        raise MeasurementError("channel_gain: loop gains must be finite and non-zero (log axes)")
    return lg


def loop_axes(freq_hz: Any, channel_gain: Any, labels: Sequence[str], sigma_max_s: Any, *,
              crossovers: Mapping[str, tuple[float, float]] | None = None, det_return_difference: Any = None,
              title: str = "", figsize: tuple[float, float] = (11.0, 7.5), dpi: float = 120.0):
    """Build the loop figure (Bode, Nyquist, ``sigma_max(S)``).

    Parameters
    ----------
    freq_hz : array_like, shape (n_f,)
        Strictly increasing frequencies [Hz], > 0.
    channel_gain : array_like, complex, shape (n_f, n_c)
        Loop-at-a-time gain of each channel [1] (:attr:`vlab.design.loop.LoopAnalysis.channel_gain`).
    labels : sequence of str, length n_c
        Legend label of each channel (e.g. ``"point 5"``).
    sigma_max_s : array_like, shape (n_f,)
        Largest singular value of the sensitivity [1].
    crossovers : mapping of str to (float, float), optional
        Label -> (gain crossover [Hz], phase crossover [Hz]) to mark (NaN: none).
    det_return_difference : array_like, complex, shape (n_f,), optional
        ``det(I + L)``; drawn in the Nyquist panel as ``det(I + L) - 1`` (dashed black, ``gid``
        ``"nyquist:det(I+L)-1"``), whose encirclements of -1 are those of the origin by ``det(I + L)``.
    title : str
        Figure title.
    figsize : (float, float)
        Figure size [in].
    dpi : float
        Resolution [dots per inch].

    Returns
    -------
    matplotlib.figure.Figure
        Axes in ``fig.axes``: magnitude, Nyquist, phase, ``sigma_max(S)``.

    Raises
    ------
    MeasurementError
        Frequencies not increasing or not positive; gains or ``sigma_max_s`` of the wrong shape, not finite
        or zero; a ``crossovers`` label that is not a channel.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    f = _freq(freq_hz, "freq_hz")
    if f[0] <= 0:
        raise MeasurementError("freq_hz: frequencies must be positive (log axis)")
    lg = _gains(f, channel_gain, labels)
    sig = np.asarray(sigma_max_s, dtype=float)
    if sig.shape != f.shape or not np.all(np.isfinite(sig)) or np.any(sig <= 0):
        raise MeasurementError(f"sigma_max_s: expected positive finite values of shape {f.shape}, got {sig.shape}")
    for lb in crossovers or {}:
        if lb not in labels:
            raise MeasurementError(f"crossovers: label {lb!r} is not a channel; channels: {list(labels)}")
    fig = Figure(figsize=figsize, dpi=dpi, layout="constrained")
    FigureCanvasAgg(fig)
    (mag, nyq), (pha, sen) = fig.subplots(2, 2)
    for i, lb in enumerate(labels):
        c = f"C{i % 10}"
        mag.semilogx(f, 20 * np.log10(np.abs(lg[:, i])), color=c, lw=1.2, label=lb, gid=f"bode-magnitude:{lb}")
        pha.semilogx(f, unwrapped_phase_deg(lg[:, i]), color=c, lw=1.2, label=lb, gid=f"bode-phase:{lb}")
        nyq.plot(lg[:, i].real, lg[:, i].imag, color=c, lw=1.0, label=lb, gid=f"nyquist:{lb}")
        fc, fp = (crossovers or {}).get(lb, (np.nan, np.nan))
        if np.isfinite(fc):
            mag.plot([fc], [0.0], marker="o", ms=5, color=c, ls="none")
        if np.isfinite(fp):
            pha.axvline(fp, color=c, ls=":", lw=1.0)
    if det_return_difference is not None:
        dd = np.asarray(det_return_difference, dtype=complex)
        if dd.shape != f.shape or not np.all(np.isfinite(dd)):
            raise MeasurementError(f"det_return_difference: expected finite values of shape {f.shape}, got {dd.shape}")
        nyq.plot(dd.real - 1, dd.imag, color="0.25", ls="--", lw=0.7, label="det(I+L) - 1", gid="nyquist:det(I+L)-1")
        nyq.legend(fontsize="x-small", loc="upper left")
    _decorate(mag, pha, nyq, lg)
    sen.semilogx(f, 20 * np.log10(sig), color="k", lw=1.2, gid="sigma-max-s")
    j = int(np.argmax(sig))
    sen.plot([f[j]], [20 * np.log10(sig[j])], marker="v", color="C3", ls="none",
             label=f"M_s = {sig[j]:.3g} at {f[j]:.3g} Hz")
    sen.set_xlabel("Frequency [Hz]")
    sen.set_ylabel("sigma_max(S) [dB]")
    sen.axhline(0.0, color="0.5", lw=0.8)
    sen.legend(fontsize="small")
    sen.grid(True, which="both", alpha=0.3)
    if title:
        fig.suptitle(title)
    return fig


def _decorate(mag, pha, nyq, lg: np.ndarray) -> None:
    """Reference lines, labels and limits of the Bode and Nyquist panels."""
    mag.axhline(0.0, color="0.5", lw=0.8)
    mag.set_ylabel("|l| [dB]")
    mag.set_xlabel("Frequency [Hz]")
    mag.legend(fontsize="small")
    mag.grid(True, which="both", alpha=0.3)
    ph = np.concatenate([unwrapped_phase_deg(lg[:, i]) for i in range(lg.shape[1])])
    for k in range(int(np.floor((ph.min() + 180.0) / 360.0)), int(np.ceil((ph.max() + 180.0) / 360.0)) + 1):
        pha.axhline(-180.0 + 360.0 * k, color="0.5", lw=0.8, ls="--")
    pha.set_ylabel("arg l [deg]")
    pha.set_xlabel("Frequency [Hz]")
    pha.grid(True, which="both", alpha=0.3)
    t = np.linspace(0, 2 * np.pi, 361)
    nyq.plot(np.cos(t), np.sin(t), color="0.6", lw=0.8, ls="--")
    nyq.plot([-1.0], [0.0], marker="+", color="C3", ms=10, mew=2, ls="none")
    lim = 1.1 * max(1.5, min(float(np.max(np.abs(lg))), 4.0))
    nyq.set_xlim(-lim, lim)
    nyq.set_ylim(-lim, lim)
    nyq.set_aspect("equal")
    nyq.set_xlabel("Re l")
    nyq.set_ylabel("Im l")
    nyq.set_title("Nyquist (positive frequencies)", fontsize="medium")
    nyq.grid(True, alpha=0.3)


def loop_figure(freq_hz: Any, channel_gain: Any, labels: Sequence[str], sigma_max_s: Any, path: str | Path, *,
                crossovers: Mapping[str, tuple[float, float]] | None = None, det_return_difference: Any = None,
                title: str = "", dpi: float = 120.0) -> Path:
    """Write the loop figure (:func:`loop_axes`) to ``path`` (``.png``, ``.svg`` or ``.pdf``) and return ``path``.

    ``freq_hz``, ``channel_gain``, ``labels``, ``sigma_max_s``, ``crossovers``, ``det_return_difference``, ``title``
    and ``dpi`` are those of
    :func:`loop_axes`; parent folders of ``path`` are created. Raises MeasurementError as :func:`loop_axes`,
    DataFileError for another file suffix.
    """
    fig = loop_axes(freq_hz, channel_gain, labels, sigma_max_s, crossovers=crossovers,
                    det_return_difference=det_return_difference, title=title, dpi=dpi)
    return _save(fig, path, dpi)
