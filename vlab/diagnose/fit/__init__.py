"""Layer 4 of the diagnosis: fit, rank and choose.

Least-squares fits and ranking (``estimate``), localisation (``locate``),
the decision rules in the order they apply (``rules``), look-alikes by rerun
(``selection``) and the refits and choices on the MuJoCo plant's
linearisation (``plantfit``, ``plantchoice``, ``plantpair``). Above the
library.
"""
