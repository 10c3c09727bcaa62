"""Layer 0 of the diagnosis: the lab itself.

Its linear model in the frequency domain (``labmodel``) and the nominal lab a
recording is compared with (``nominal``). Imports nothing else of
:mod:`vlab.diagnose`.
"""
