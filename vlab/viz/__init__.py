"""Visualisation: rerun recordings (``.rrd``) and matplotlib figures.

Modules
-------
rerun_log
    :func:`~vlab.viz.rerun_log.log_experiment` writes signals
    (``signals/<channel>`` on ``sim_time``), the animated deformed structure
    (``structure/members``, ``structure/points``) and FRFs
    (``frf/<name>/magnitude`` on ``frequency_mhz``) to a ``.rrd`` file;
    :func:`~vlab.viz.rerun_log.rrd_entity_paths` reads one back.
rerun_frf
    FRFs in a recording: ``frf/<name>/magnitude``, ``phase`` and ``coherence`` on ``frequency_mhz``, one
    view per quantity.
rerun_structure
    The structure at rest and its animated deformed shape in a recording.
viewer
    A live rerun viewer listening on the loopback address only.
rerun_common
    Entity paths, timelines, colours and input checks the rerun modules share.
figures
    :func:`~vlab.viz.figures.frf_figure` (log-magnitude FRFs as in Figs.
    22-31), :func:`~vlab.viz.figures.misfit_overlay` and
    :func:`~vlab.viz.figures.comparison_bar` (before/after a fit).
mode_figures
    Mode shapes drawn on the structure; identified shapes beside a model's
    (:func:`~vlab.viz.mode_figures.shape_comparison_figure`).

Importing this package imports neither rerun nor matplotlib; both are
loaded when a function first needs them.
"""

from .figures import comparison_bar, frf_figure, misfit_overlay
from .rerun_common import FREQUENCY_TIMELINE, SIM_TIMELINE
from .rerun_log import (close_recording, log_experiment, log_frfs, log_recording, log_signals, open_recording,
                        rrd_entity_paths, rrd_row_counts)
from .rerun_structure import log_deformed_shapes, log_structure, structure_geometry

__all__ = [
    "FREQUENCY_TIMELINE", "SIM_TIMELINE",
    "close_recording", "comparison_bar", "frf_figure", "log_deformed_shapes", "log_experiment",
    "log_frfs", "log_recording", "log_signals", "log_structure", "misfit_overlay", "open_recording",
    "rrd_entity_paths", "rrd_row_counts", "structure_geometry",
]
