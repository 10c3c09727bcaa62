"""Calibration of the Hanging Grid reconstruction to the dissertation's tables.

The grid's drawing (Fig. 5, Refs. 51-52) is not available, so its geometry is a
reconstruction (``docs/grid-reconstruction.md``, topology "D5a": a +/-45 deg
lattice of pitch ``a``, rows 2-4-3-2-1 with one horizontal bar 10-11, hung
from the top beam at points 15, 17, 18, 20). Its unknown parameters (see
:data:`GRID_PARAMETERS`) -- lattice pitch, top-beam half-span, plate width and
height (which give the plate weight ``W``, the pendulum springs ``W*Y`` and
the plate inertias), top-beam EI, GJ, kGA and mass, joint and coil masses --
are fitted by bounded least squares to

1. Table 3's analytical frequencies (the thesis's own 64-DOF model), and
2. Table 5's Guyan column: the same model condensed (Guyan 1965; Sec. 3.3) to
   the translations at joints 1-9 and 12 and the rotations ``rx`` at the
   bearings 13 and 22 (weight 0.5).

Modes are matched by character, not only by order: Sec. 2.2.2 says modes 7
and 8 are the first bending and the torsion (plates in anti-phase) of the top
beam, so the model's top-beam bending and torsion modes are compared with
Table 3 modes 7 and 8 and its other modes, in frequency order, with modes
1-6 and 9-12; penalties keep top-beam modes out of the other slots and make
mode 1 the pendulum mode (the whole structure swinging about the top-beam
axis).

What the reconstruction reaches (``python -m vlab.grid_fit --check``): 9.2 %
rms against Table 3 analytical, with mode 4 -18 %, mode 10 -16 %, mode 3
+13 %, mode 1 -10 % and modes 7-8 within 2 %; 11 % rms against the Table 5
Guyan column. No parameter is on a bound, four lie within 5 % of one
(half-span, plate width and height, top-beam kGA). A 5 % agreement is out of
reach without the drawing: the remaining error is the unknown geometry, not a
missing stiffness term (the full geometric stiffness of
:mod:`vlab.fe.geometric` is in the model).

Run ``python -m vlab.grid_fit`` to repeat the fit (local, from the values in
``grid.toml``; ``--global`` adds a differential-evolution search); it prints
the parameters (thesis units), which of them are on or near a bound, and the
per-mode tables. The values are written into ``assets/structures/grid.toml``
(by hand), marked "calibrated: Table 3 analytical + Table 5 Guyan (python -m
vlab.grid_fit)". The Guyan condensation is implemented here on purpose
(``T = [I; -K22^-1 K21]``), independent of :mod:`vlab.reduction`.

The package's modules: :mod:`vlab.grid_fit.parameters` (the fitted
parameters and how they set a grid document), :mod:`vlab.grid_fit.modes`
(the character of the grid's modes and their pairing with Table 3) and
:mod:`vlab.grid_fit.fit` (residuals, the fit, its report and ``main``).
"""

from .fit import GridFit, evaluate, fit_grid, main, report, residuals, summarize
from .modes import (N_SEARCH, TOP_BENDING_MODE, TOP_TORSION_MODE, ModeCharacter, guyan_frequencies_hz, match_modes,
                    mode_characters)
from .parameters import (ALUMINIUM_LBF_IN3, CALIBRATED, GRID_PARAMETERS, PLATE_T_IN, PLATE_Y_IN, apply_parameters,
                         current_parameters, plate_properties)

__all__ = [
    "ALUMINIUM_LBF_IN3", "CALIBRATED", "GRID_PARAMETERS", "N_SEARCH", "PLATE_T_IN", "PLATE_Y_IN", "TOP_BENDING_MODE",
    "TOP_TORSION_MODE", "GridFit", "ModeCharacter", "apply_parameters", "current_parameters", "evaluate", "fit_grid",
    "guyan_frequencies_hz", "main", "match_modes", "mode_characters", "plate_properties", "report", "residuals",
    "summarize",
]
