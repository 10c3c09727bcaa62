"""Every public function and method of vlab.diagnose documents its parameters (the check of test_docstrings)."""

from __future__ import annotations

import importlib

import pytest

from test_docstrings import test_parameters_are_documented as _check

MODULES = ["vlab.diagnose", "vlab.diagnose.data", "vlab.diagnose.labmodel", "vlab.diagnose.specedit",
           "vlab.diagnose.nominal", "vlab.diagnose.result", "vlab.diagnose.selection",
           "vlab.diagnose.context", "vlab.diagnose.hypothesis", "vlab.diagnose.structural", "vlab.diagnose.chain",
           "vlab.diagnose.hypotheses", "vlab.diagnose.problem", "vlab.diagnose.fit", "vlab.diagnose.locate",
           "vlab.diagnose.validate", "vlab.diagnose.report", "vlab.diagnose.figures", "vlab.diagnose.pipeline"]


@pytest.mark.parametrize("modname", MODULES)
def test_diagnose_parameters_are_documented(modname):
    importlib.import_module(modname)
    _check(modname)
