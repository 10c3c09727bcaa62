"""Layer 3 of the diagnosis: the library of physics hypotheses.

The base class (``hypothesis``), one module per effect family
(``structural``, ``beyond_spec``, ``chain``; each imports only the base and
``specedit``) and the registry (``hypotheses``). Above the problem; imports
nothing that fits, validates or reports.
"""
