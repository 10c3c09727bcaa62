"""Mismatch diagnosis: locate where a recording and the nominal lab differ, name the physics, model it, validate.

Entry point: :func:`diagnose` (the ``vlab diagnose`` command) returning a
:class:`DiagnosisResult` whose :meth:`~DiagnosisResult.as_dict` is the JSON
output.

The subpackages follow the data flow, one way: a module imports modules of
its own layer and of the layers listed before it below, never of one after
it, and there are no import cycles (``tests/test_diagnose_layers.py``).
Where this differs from the plain picture data -> problem -> library -> fit
-> validate -> report, and why:

- ``model`` comes first: the lab model is used by every layer and uses none
  (the data are read without it).
- The replay of a recording (``data.replay``, with ``data.warmstart``) is
  in the data layer: the reference a recording is compared with is the
  nominal plant's replay of it (``data.reference``), and the same replays
  give the look-alike reruns of the fit layer and the validation reruns.
- The library of hypotheses is ``effects``, not ``library``: :func:`library`
  is a public name of this package, which a subpackage of that name would
  shadow.
- A module whose name would repeat its package's was renamed: ``data`` ->
  ``data.measured``, ``problem`` -> ``problem.residuals``, ``fit`` ->
  ``fit.estimate``, ``report`` -> ``report.markdown``.
- Every decision rule is in ``fit.rules``, those applied after the
  validation (``worsens``, ``explains``) too: they take the validation and
  the result as arguments, so the fit layer imports neither.

Modules
-------
model
    ``labmodel``: the linear model of the whole lab (structure, chain, controller) in the frequency
    domain; ``nominal``: the nominal lab (its mesh, the controller design, the settling time).
data
    ``measured``: the measured FRFs and modal tables, and their referral to the model; ``frfestimate``:
    recordings and UFF FRFs checked and turned into FRFs with noise; ``modalcsv``: modal tables;
    ``readers``: which kind a file holds;
    ``warmstart``, ``replay``: the recorded force played back through the lab loop on a plant;
    ``reference``: the recording's settings and the replay it is referred through.
problem
    ``context``: scales and signals the hypotheses need; ``residuals``: weighted residuals of a lab
    state against the data, the noise limits and the model-error floor.
effects
    The library of named physics hypotheses: ``hypothesis`` (the base class and the pair), one module
    per family (``structural``, ``beyond_spec``, ``chain``), ``specedit`` (public edits of a
    StructureSpec) and the registry ``hypotheses``.
fit
    ``estimate``: least-squares fits, 95 % intervals, BIC ranking, pairs; ``locate``: modes, sensors,
    band, loop and sensitivity-based localisation; ``rules``: the decision rules, in the order they
    apply; ``selection``: look-alikes separated by rerun, located places; ``plantfit``,
    ``plantchoice``, ``plantpair``: refits and choices on the MuJoCo plant's linearisation.
validate
    Rerun of the experiment with the effect modelled; misfits before and after.
report
    ``result``: the result and its JSON object; ``markdown``: diagnosis.md, diagnosis.json and the
    readable formatting; ``figures``.
pipeline
    :func:`diagnose`.
thresholds, naming, detectability
    Beside the pipeline (``vlab detectability``): the smallest size of each effect the diagnosis detects
    (``thresholds``: the test and its search; ``detectability``: the whole library) and names among its
    look-alikes (``naming``) in the lab's nominal test.
"""

from .effects.hypotheses import EFFECTS, Hypothesis, library
from .pipeline import DiagnosisResult, diagnose

__all__ = ["EFFECTS", "DiagnosisResult", "Hypothesis", "diagnose", "library"]
