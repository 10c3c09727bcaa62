"""Layer 1 of the diagnosis: the data.

What was recorded (``measured``), its replay through the lab loop on a plant
(``warmstart``, ``replay``) and the reference a recording is referred through
(``reference``). Imports only the lab model (:mod:`vlab.diagnose.model`).
"""
