"""Layer 6 of the diagnosis: the report.

The result and its JSON object (``result``), diagnosis.md and the readable
formatting (``markdown``), the figures (``figures``). Above the validation
(layer 5, :mod:`vlab.diagnose.validate`); only the pipeline is above it.
"""
