"""Recordings of the linear lab loop shared by the diagnosis tests: short, coarse and fast.

A recording is made by running the lab's sampled-data loop (:func:`vlab.diagnose.data.replay.rerun` on the
linear FE plant) on a lab state with the structure's pseudo-random test signal, with sensor noise added.
"""

from __future__ import annotations

import numpy as np

from vlab.diagnose.data.replay import rerun
from vlab.diagnose.model.labmodel import LabState
from vlab.experiment.config import TESTS
from vlab.io.recording import Recording
from vlab.io.uff import write_recording
from vlab.lab.excitation import pseudo_random

RES_HZ = 0.2          # 5 s periods: coarse lines, fast runs
PERIODS = 3


def record_linear(state: LabState, path, *, noise: float = 0.01, seed: int = 1, steady: bool = False) -> str:
    """Run the lab loop on ``state`` with the structure's pseudo-random test signal; add sensor noise.

    ``steady``: start the run in the lab's periodic steady state (a warm start one period in), as a lightly
    damped open loop needs (its transient outlasts the short record)."""
    spec = state.spec
    test = TESTS[spec.name]
    n_per = int(round(1 / RES_HZ / state.chain.period_s))
    n = PERIODS * n_per + (n_per if steady else 0)
    force = pseudo_random(np.arange(n) * state.chain.period_s, band_hz=test.band_hz, resolution_hz=RES_HZ,
                          rms_n=test.rms_n, seed=seed)
    exc = spec.instrumentation.excitation
    meas = tuple(dict.fromkeys(test.measured_points + spec.instrumentation.actuators))
    rec, _ = rerun(state, force, excitation_point=exc, measured_points=meas,
                   **({"start": n_per, "period": n_per} if steady else {}))
    force = force[n - rec.n_samples:]
    rng = np.random.default_rng(seed)
    sig = {f"force{exc}": force}
    for p in meas:
        v = np.asarray(rec[f"vel{p}"])
        sig[f"vel{p}"] = v + noise * np.std(v) * rng.standard_normal(v.size)
    ctrl = "none" if state.design is None else state.design.controller
    out = Recording.from_signals(rec.dt_s, sig, metadata={"structure": spec.name, "controller": ctrl, "seed": 0,
                                                          "resolution_hz": RES_HZ, "plant": "linear FE model"})
    write_recording(path, out, overwrite=True)
    return str(path)
