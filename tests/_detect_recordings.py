"""Diagnosed linear-plant recordings with a multiple of an effect's detection threshold (the detectability
tests: test_detectability.py, test_detectability_naming.py)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

import vlab
from vlab.diagnose.data.replay import linear_plant
from vlab.diagnose.effects.hypotheses import library
from vlab.diagnose.model.labmodel import LabState
from vlab.diagnose.problem.context import context_for
from vlab.experiment.config import ExperimentConfig, default_chain
from vlab.experiment.runner import measure
from vlab.fe import build_fe_model
from vlab.io.uff import write_recording


def diagnosed(tmp_path, spec, t, factor: float, seed: int, point: int = 6, location: dict | None = None) -> dict:
    """The diagnosis of a linear-plant recording (open loop) with ``factor`` x the threshold ``t`` of its effect
    at ``location`` (default: a mass at ``point``)."""
    fe = build_fe_model(spec)
    chain = default_chain("none", noise_m_s=1e-6)
    nominal = LabState(spec, fe, replace(chain, noise_m_s=0.0), None)
    ctx = context_for(nominal, (0.5, 25.0), None)
    where = {"point": point} if location is None else location
    (h,) = [x for x in library(nominal, ctx, effects=(t.effect,)) if x.location == where]
    state = h.apply(nominal, np.array([t.scaled(factor)]), ctx)
    cfg = ExperimentConfig(structure="bcc", controller="none", plant="linear", chain=chain, seed=seed)
    meta = {"structure": "bcc", "controller": "none", "seed": 0, "plant": "linear FE model"}
    path = tmp_path / f"rec_{factor}_{seed}.uff"
    plant = (linear_plant(state), {"kind": "linear FE model"})  # the state's own damping and dashpots
    write_recording(path, measure(cfg, state.fe, None, metadata=meta, plant=plant).loop.recording)
    return vlab.diagnose(spec, path).as_dict()
