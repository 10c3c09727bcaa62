"""Reduction of a structural model to physical master DOFs.

Two reductions of the dissertation (Sec. 3.1), both of which keep physical
DOFs (not modal amplitudes) as the reduced coordinates ``q_R``:

* :class:`GuyanReduction` -- static condensation (Guyan 1965, Ref. 1 of the
  dissertation; Eqs. 3.9-3.16), exact for static loads at the masters.
* :class:`ExactReduction` -- the dissertation's *exact reduction* (Eqs. 3.5-3.8):
  the first ``n_R`` undamped modes seen at ``n_R`` master DOFs. This is SEREP
  (O'Callahan, Avitabile & Riemer, IMAC 1989) with as many modes as masters;
  it reproduces the first ``n_R`` frequencies and the mode shapes at the
  masters exactly.

Both are projections ``q = T q_R`` with a basis ``T`` of shape ``(n, n_R)``
whose master rows are the identity, so that

    m_R = T' m T,   k_R = T' k T,   c_R = T' c T,   U_R = T' U.

A reductor is a small object bound to the full model (pyMOR habit):
``reduce()`` returns an immutable :class:`ReducedModel`, ``reconstruct(q_R)``
maps reduced coordinates back to all ``n`` DOFs; the variants differ only in
the hook ``_basis()``.

Units are whatever the matrices carry; vlab passes SI (kg, N/m, N*s/m, with
rotational DOFs in rad) and frequencies in Hz. The master DOFs are integer
indices into the full DOF list; the optional ``labels`` (one per full DOF,
e.g. ``(point_id, "w")``) are used only to name DOFs in error messages and
are carried into the reduced model.

The package's modules: :mod:`vlab.reduction.checks` (input checks shared
with :mod:`vlab.correction`), :mod:`vlab.reduction.model` (the reduced model),
:mod:`vlab.reduction.reductors` (the two reductions) and
:mod:`vlab.reduction.modal` (modal damping, the dissertation's form).
"""

from .checks import natural_frequencies_hz
from .modal import ExactForm, exact_reduction_form, modal_damping
from .model import ReducedModel
from .reductors import K22_MAX_COND, PHI_R_MAX_COND, ExactReduction, GuyanReduction

__all__ = [
    "PHI_R_MAX_COND",
    "K22_MAX_COND",
    "ReducedModel",
    "GuyanReduction",
    "ExactReduction",
    "ExactForm",
    "exact_reduction_form",
    "modal_damping",
    "natural_frequencies_hz",
]
