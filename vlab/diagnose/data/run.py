"""The run context of one diagnosis: the reruns it has made and those still running in the background.

A diagnosis plays the recorded force back through the 2 kHz loop on several lab states (the nominal lab's
replay, the candidates' validation reruns, the look-alikes' tie-breaks). Each rerun costs a whole
experiment on the plant, so it is made once and kept here under ``(key, plant, seed)``; the nominal
lab's MuJoCo rerun may be started in a background process while the hypotheses are fitted
(:func:`vlab.diagnose.data.rerun_jobs.start_background_rerun`) and is collected here when first asked for.

The context belongs to the process that made it: pickled (to a worker process, with the problem that
refers to it) it arrives empty, without the background processes or the cached recordings.
"""

from __future__ import annotations

from contextlib import contextmanager
from dataclasses import dataclass, field

from threadpoolctl import threadpool_limits


@dataclass
class DiagnosisRun:
    """Reruns of one diagnosis (:mod:`vlab.diagnose.data.rerun_jobs`).

    Attributes
    ----------
    reruns : dict
        ``(key, plant, seed)`` -> :class:`vlab.io.recording.Recording`: the reruns made.
    background : dict
        ``(key, plant, seed)`` -> ``(process, connection)``: reruns still running in a background process.
    note : str
        How the last batch of reruns was made (one ``mujoco.batch``, processes, and why), for the notes.
    """

    reruns: dict = field(default_factory=dict)
    background: dict = field(default_factory=dict)
    note: str = ""

    def __getstate__(self) -> dict:
        """An empty context: the processes and recordings stay with the process that made them."""
        return {"reruns": {}, "background": {}, "note": ""}

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)


@contextmanager
def one_blas_thread():
    """Run the enclosed work with one BLAS thread.

    The diagnosis works on small matrices -- FE models of tens to a few hundred DOFs, receptances of a few
    points -- evaluated thousands of times in its fits; there a second BLAS thread costs more in hand-off
    than it gives, and the diagnosis's background rerun holds the other core. ``benchmarks/blas_threads.py``
    measures the ratio on the grid's FRF prediction.

    Source: threadpoolctl (``threadpool_limits(limits=1, user_api="blas")``).
    """
    with threadpool_limits(limits=1, user_api="blas"):
        yield
