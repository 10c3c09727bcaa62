"""Mismatch diagnosis: locate where a recording and the nominal lab differ, name the physics, model it, validate.

Entry point: :func:`diagnose` (the ``vlab diagnose`` command) returning a
:class:`DiagnosisResult` whose :meth:`~DiagnosisResult.as_dict` is the JSON
output.

Modules
-------
data
    Recordings, UFF FRFs and modal tables, checked, turned into FRFs with noise.
labmodel
    The linear model of the whole lab (structure, chain, controller) in the frequency domain.
specedit
    Public edits of a StructureSpec (added mass, springs, member/joint stiffness, modal damping).
hypotheses
    The library of named physics hypotheses (one class per effect).
problem
    Weighted residuals of a lab state against the data.
fit
    Least-squares fits, 95 % intervals, AIC/BIC ranking, pairs.
locate
    Modes, sensors, band, loop and sensitivity-based localisation.
validate
    Rerun of the experiment with the effect modelled; misfits before and after.
report, figures
    diagnosis.md, diagnosis.json and figures.
pipeline
    :func:`diagnose`.
"""

from .effects.hypotheses import EFFECTS, Hypothesis, library
from .pipeline import DiagnosisResult, diagnose

__all__ = ["EFFECTS", "DiagnosisResult", "Hypothesis", "diagnose", "library"]
