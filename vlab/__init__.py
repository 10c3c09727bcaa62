"""vlab: a virtual laboratory for active vibration control of flexible structures.

Rebuilds the laboratory of the 1990 dissertation "Experimental and theoretical
investigation of optimal control methods with model reduction" (see
``shared/seed``): FE models of the Beam Cross-Cable and Hanging Grid
structures, reduction and correction, MuJoCo plants, a 2 kHz digital control
loop, modal-test style measurements and mismatch diagnosis.
"""

__version__ = "0.1.0"
