"""Figures of a diagnosis: FRF overlays before/after, per-mode errors, time histories.

Each entry of :func:`figures_for` is a callable drawing one PNG at a given
path with :mod:`vlab.viz.figures` (or :func:`vlab.diagnose.report.markdown.time_figure`),
so the report writer controls where and when files appear.
"""

from __future__ import annotations

from functools import partial

import numpy as np

from ...viz.figures import comparison_bar, misfit_overlay
from ..data.measured import FrfData
from ..fit.locate import frf_modes


def _worst_channel(res) -> int:
    ch = res.location.channels
    if not ch:
        return 0
    p = max(ch, key=lambda k: ch[k]["chi2_per_residual"])
    return list(res.data.output_points).index(p)


def figures_for(res, *, log_freq: bool = False) -> dict:
    """Name -> ``draw(path)`` for the report of ``res``, a :class:`~vlab.diagnose.pipeline.DiagnosisResult`.

    For measured FRFs: ``overlay_<point>`` (the worst channel and the driving point: measured, nominal and
    with the selected effect, magnitude [(m/s)/N], phase [deg] where all three are complex, and the
    log-magnitude misfit; :func:`vlab.viz.figures.misfit_overlay`), ``modes`` (frequency errors before and
    after) and ``time`` (the validation's time histories); for modal data ``modes``.

    Parameters
    ----------
    res : DiagnosisResult
        The diagnosis.
    log_freq : bool
        Draw the overlays' frequency on a logarithmic axis (default linear, as the dissertation's Figs. 22-31).

    Returns
    -------
    dict
        Figure name -> callable ``draw(path)`` writing it.
    """
    figs = {}
    data = res.data
    after_state = res.selected_state()
    if isinstance(data, FrfData):
        hb = res.problem.predict(res.nominal)
        ha = res.problem.predict(after_state)
        source = "linear model"
        if res.validation is not None:
            hb, ha = res.validation.h_before, res.validation.h_after
            source = res.validation.plant.split(" (")[0]
        chans = [_worst_channel(res)]
        if data.excitation_point in data.output_points:
            chans.append(list(data.output_points).index(data.excitation_point))
        phase = all(np.iscomplexobj(x) for x in (data.h, hb, ha))
        for j in dict.fromkeys(chans):
            p = data.output_points[j]
            figs[f"overlay_{p}"] = partial(
                misfit_overlay, data.freq_hz, data.h[:, j], hb[:, j], ha[:, j],
                title=f"{res.structure}: velocity at {p} / force at {data.excitation_point} ({source})",
                ylabel="|H| [(m/s)/N]", labels=("measured", "nominal lab", "with the selected effect"),
                phase=phase, log_freq=log_freq)
        modes = res.location.modes
        if modes and res.selected is not None:
            after = {round(m.freq_measured_hz, 9): m for m in frf_modes(res.problem, after_state)}
            before_e, after_e, labels = [], [], []
            for m in modes:
                a = after.get(round(m.freq_measured_hz, 9))
                if a is None or not np.isfinite(m.freq_error) or not np.isfinite(a.freq_error):
                    continue
                labels.append(f"mode {m.mode}")
                before_e.append(-100 * m.freq_error / (1 + m.freq_error))
                after_e.append(-100 * a.freq_error / (1 + a.freq_error))
            if labels:
                figs["modes"] = partial(comparison_bar, labels, before_e, after_e,
                                        title="natural frequency: model / measured - 1",
                                        ylabel="frequency error [%]", names=("nominal", "with the effect"))
        if res.validation is not None and data.recording is not None:
            from .markdown import time_figure

            p = data.output_points[chans[0]]
            rec = data.recording
            figs["time"] = partial(time_figure, rec.time_s, np.asarray(rec[f"vel{p}"]), res.validation.v_before[p],
                                   res.validation.v_after[p], title=f"velocity at point {p}")
    else:
        fb, _, _ = res.problem.model_modes(res.nominal)
        fa, _, _ = res.problem.model_modes(after_state)
        ok = np.isfinite(fb) & np.isfinite(fa)
        labels = [f"mode {m}" for m in data.modes[ok]]
        figs["modes"] = partial(comparison_bar, labels, 100 * (fb[ok] / data.freq_hz[ok] - 1),
                                100 * (fa[ok] / data.freq_hz[ok] - 1),
                                title="natural frequency: model / measured - 1", ylabel="frequency error [%]",
                                names=("nominal", "with the effect"))
    return figs
