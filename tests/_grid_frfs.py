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


def grid_frf_data(freq, edit=None, name: str = "grid.uff", rel_noise: float = 0.01) -> tuple[LabState, tuple, FrfData]:
    """Noise-free FRFs at ``freq`` [Hz] of the grid's open-loop test on the linear lab whose spec is ``edit(spec)``
    (the nominal lab itself without ``edit``), with relative noise ``rel_noise`` on every line and file name ``name``.

    Returns the nominal lab, the test's band [Hz] and the data."""
    fe = nominal_fe_model("grid")
    nominal = LabState(fe.spec, fe, HardwareChain(), None)
    truth = nominal if edit is None else nominal.with_spec(edit(fe.spec))
    test = TESTS["grid"]
    exc = fe.spec.instrumentation.excitation
    outs = tuple(test.measured_points)
    h = predict_frf(truth, freq, excitation_point=exc, output_points=outs)
    return nominal, test.band_hz, FrfData(name, "frf", freq, h, (rel_noise * np.abs(h)) ** 2, exc, outs)


def grid_problem(edit, name: str, rel_noise: float = 0.01) -> tuple[Problem, LabState]:
    """The grid's open-loop test (lines 0.2-10 Hz, every 0.05 Hz) on the linear lab whose spec is ``edit(spec)``.

    Returns the diagnosis problem of those FRFs (:func:`grid_frf_data`) against the nominal lab, and the nominal
    lab."""
    nominal, band_hz, data = grid_frf_data(np.arange(4, 201) * 0.05, edit, name, rel_noise)
    return Problem(data, nominal, context_for(nominal, band_hz, data)), nominal
