"""Noise-free FRFs of the linear grid with a structural change, as a diagnosis problem (the diagnosis tests)."""

from __future__ import annotations

import numpy as np

from vlab.diagnose.data.measured import FrfData
from vlab.diagnose.model.labmodel import LabState, predict_frf
from vlab.diagnose.problem.context import context_for
from vlab.diagnose.problem.residuals import Problem
from vlab.experiment.config import TESTS
from vlab.lab.loop import HardwareChain
from vlab.models import nominal_fe_model


def grid_problem(edit, name: str, rel_noise: float = 0.01) -> tuple[Problem, LabState]:
    """The grid's open-loop test (lines 0.2-10 Hz, every 0.05 Hz) on the linear lab whose spec is ``edit(spec)``.

    Returns the diagnosis problem of those FRFs (relative noise ``rel_noise`` on every line, file name
    ``name``) against the nominal lab, and the nominal lab."""
    fe = nominal_fe_model("grid")
    nominal = LabState(fe.spec, fe, HardwareChain(), None)
    truth = nominal.with_spec(edit(fe.spec))
    test = TESTS["grid"]
    freq = np.arange(4, 201) * 0.05
    exc = fe.spec.instrumentation.excitation
    outs = tuple(test.measured_points)
    h = predict_frf(truth, freq, excitation_point=exc, output_points=outs)
    data = FrfData(name, "frf", freq, h, (rel_noise * np.abs(h)) ** 2, exc, outs)
    return Problem(data, nominal, context_for(nominal, test.band_hz, data)), nominal
