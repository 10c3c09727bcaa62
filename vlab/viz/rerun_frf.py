"""FRFs in a rerun recording: magnitude, phase and coherence of every channel on the frequency timeline.

Each FRF ``<name>`` goes to three entities on the ``frequency_mhz`` timeline
(:data:`~vlab.viz.rerun_common.FREQUENCY_TIMELINE`, integer millihertz):

================================  =============================================
``frf/<name>/magnitude``          ``log10 |H(f)|`` (rerun has no log axis; the
                                  dissertation's Figs. 22-31 plot ``|H|`` on one)
``frf/<name>/phase``              ``angle(H(f))`` [deg], in (-180, 180]
``frf/<name>/coherence``          ordinary coherence gamma^2 [-] of an H1
                                  estimate (only for an FRF that carries one)
================================  =============================================

:func:`frf_panels` names the entities of each quantity so that a blueprint shows magnitude, phase and
coherence in views of their own (:func:`frf_views`): their scales differ by orders of magnitude.

Source: rerun-sdk 0.41 Python API (``send_columns``, ``TimeColumn``, ``SeriesLines``,
``blueprint.TimeSeriesView`` with ``contents``); Ewins, *Modal Testing* (2nd ed., 2000), Sec. 3.x: an FRF
is read as magnitude and phase (Bode form) with the coherence of its estimate.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ..errors import MeasurementError
from .rerun_common import FREQUENCY_TIMELINE, FRF_ROOT, PALETTE, check_name, finite_1d, rerun_module

__all__ = ["frf_panels", "frf_views", "log_frfs"]

#: The quantities logged per FRF, with the title of their view.
FRF_QUANTITIES = (("magnitude", "FRF log10|H| vs frequency_mhz (1 Hz = 1000)"),
                  ("phase", "FRF phase [deg] vs frequency_mhz"),
                  ("coherence", "coherence [-] vs frequency_mhz"))


def _frf_arrays(name: str, frf: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """(freq_hz, h, coherence or None) from a ``(freq_hz, h)`` or ``(freq_hz, h, coherence)`` tuple or an
    object with ``freq_hz``, ``h`` and optionally ``coherence``."""
    coh = None
    if hasattr(frf, "freq_hz") and hasattr(frf, "h"):
        f, h, coh = frf.freq_hz, frf.h, getattr(frf, "coherence", None)
    elif isinstance(frf, (tuple, list)) and len(frf) in (2, 3):
        f, h = frf[0], frf[1]
        coh = frf[2] if len(frf) == 3 else None
    else:
        raise MeasurementError(
            f"FRF {name!r}: expected a (freq_hz, h) pair or an object with freq_hz and h, "
            f"got {type(frf).__name__}")
    f = finite_1d(f, f"FRF {name!r} freq_hz")
    h = np.asarray(h)
    if h.ndim != 1 or h.size != f.size:
        raise MeasurementError(f"FRF {name!r}: h has shape {h.shape}, freq_hz has shape {f.shape}")
    if not np.all(np.isfinite(h)):
        raise MeasurementError(f"FRF {name!r}: h has non-finite values")
    if f.size and f[0] < 0.0:
        raise MeasurementError(f"FRF {name!r}: negative frequency {f[0]} Hz")
    if coh is not None:
        coh = np.asarray(coh, dtype=float)
        if coh.shape != f.shape:
            raise MeasurementError(f"FRF {name!r}: coherence has shape {coh.shape}, freq_hz has shape {f.shape}")
    return f, h, coh


def _has_coherence(frf: Any) -> bool:
    if isinstance(frf, (tuple, list)):
        return len(frf) == 3 and frf[2] is not None
    return getattr(frf, "coherence", None) is not None


def frf_panels(frfs: Mapping[str, Any], *, phase: bool = False) -> dict[str, list[str]]:
    """The entity paths :func:`log_frfs` writes for ``frfs``, by quantity.

    Parameters
    ----------
    frfs : mapping of str to FRF
        As :func:`log_frfs`.
    phase : bool
        As :func:`log_frfs`.

    Returns
    -------
    dict of str to list of str
        ``"magnitude"``, and ``"phase"`` (with ``phase``) and ``"coherence"`` (when an FRF carries one)
        -> the entity paths of that quantity, in the order of ``frfs``.
    """
    out: dict[str, list[str]] = {"magnitude": [f"{FRF_ROOT}/{n}/magnitude" for n in frfs]}
    if phase:
        out["phase"] = [f"{FRF_ROOT}/{n}/phase" for n in frfs]
    coh = [f"{FRF_ROOT}/{n}/coherence" for n, v in frfs.items() if _has_coherence(v)]
    if coh:
        out["coherence"] = coh
    return out


def frf_views(panels: Mapping[str, Sequence[str]]) -> list:
    """One rerun time-series view per quantity of :func:`frf_panels`, each showing only its entities.

    Parameters
    ----------
    panels : mapping of str to sequence of str
        Quantity (``"magnitude"``, ``"phase"``, ``"coherence"``) -> entity paths.

    Returns
    -------
    list of rerun.blueprint.TimeSeriesView
        In the order magnitude, phase, coherence.

    Raises
    ------
    MeasurementError
        An unknown quantity.
    """
    import rerun.blueprint as rrb

    titles = dict(FRF_QUANTITIES)
    unknown = set(panels) - set(titles)
    if unknown:
        raise MeasurementError(f"frf_views: unknown quantities {sorted(unknown)}; use {sorted(titles)}")
    return [rrb.TimeSeriesView(origin=FRF_ROOT, contents=[f"+ /{p}" for p in panels[q]], name=titles[q])
            for q, _ in FRF_QUANTITIES if panels.get(q)]


def _send(rec, rr, entity: str, label: str, color, mhz: np.ndarray, values: np.ndarray) -> str:
    rec.log(entity, rr.SeriesLines(names=label, colors=[color]), static=True)
    rec.send_columns(entity, indexes=[rr.TimeColumn(FREQUENCY_TIMELINE, sequence=mhz)],
                     columns=rr.Scalars.columns(scalars=values))
    return entity


def log_frfs(rec, frfs: Mapping[str, Any], *, phase: bool = False) -> list[str]:
    """Log FRFs on the ``frequency_mhz`` timeline: ``log10 |H|``, the phase [deg] and the coherence.

    Parameters
    ----------
    rec : rerun.RecordingStream
        From :func:`vlab.viz.rerun_log.open_recording`.
    frfs : mapping of str to FRF
        Name -> ``(freq_hz, h)``, ``(freq_hz, h, coherence)`` or an object with ``freq_hz``, ``h`` and
        optionally ``coherence`` and ``unit`` (:class:`vlab.io.frf.FRF`): ``freq_hz`` shape (n_freq,) [Hz],
        increasing; ``h`` shape (n_freq,) complex or real (SI units, e.g. (m/s)/N); ``coherence`` shape
        (n_freq,) [-] (NaN is a gap). Names become entity paths ``frf/<name>/...``; use e.g.
        ``"experiment/vel4_force4"`` and ``"analysis/vel4_force4"``. Grids may differ between FRFs.
    phase : bool
        Also log ``frf/<name>/phase``, ``angle(H)`` [deg] (meaningful for complex FRFs).

    Returns
    -------
    list of str
        The entity paths written: ``frf/<name>/magnitude`` per FRF, then its ``phase`` and ``coherence``
        where logged.

    Raises
    ------
    MeasurementError
        Mismatched ``freq_hz``/``h``/``coherence`` shapes, non-finite values, negative
        frequencies, or frequencies not strictly increasing after rounding
        to 1 mHz (names the FRF); invalid names.
    """
    rr = rerun_module()
    paths = []
    for i, (name, frf) in enumerate(frfs.items()):
        check_name(name, "FRF")
        f, h, coh = _frf_arrays(name, frf)
        mhz = np.rint(f * 1000.0).astype(np.int64)
        if np.any(np.diff(mhz) <= 0):
            raise MeasurementError(
                f"FRF {name!r}: frequencies must be strictly increasing and at least 1 mHz apart "
                f"(timeline {FREQUENCY_TIMELINE!r})")
        mag = np.abs(h).astype(float)
        with np.errstate(divide="ignore"):
            logmag = np.where(mag > 0.0, np.log10(np.where(mag > 0.0, mag, 1.0)), np.nan)
        unit = getattr(frf, "unit", None)
        color = PALETTE[i % len(PALETTE)]
        base = f"{FRF_ROOT}/{name}"
        paths.append(_send(rec, rr, f"{base}/magnitude", f"{name} log10|H|" + (f" [{unit}]" if unit else ""),
                           color, mhz, logmag))
        if phase:
            paths.append(_send(rec, rr, f"{base}/phase", f"{name} phase [deg]", color, mhz,
                               np.degrees(np.angle(h.astype(complex)))))
        if coh is not None:
            paths.append(_send(rec, rr, f"{base}/coherence", f"{name} coherence [-]", color, mhz, coh))
    return paths
