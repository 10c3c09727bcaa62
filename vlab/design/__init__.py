"""The dissertation's controller designs on vlab's models.

Glue between the lab's models (SI) and the stand-alone design package
:mod:`controllers`: the design model (full FE, exact or Guyan reduction,
corrected Guyan) is converted to the thesis's unit system (inch, lbf,
centisecond; Sec. 3.1) where its weights Q and R mean what they meant in
1990, the design is made there, and the gains and the Eq. (5.1)
realization are converted back to SI for the digital loop (2 kHz; LQG 1 kHz, Sec. 5.3).

Thesis settings (Sec. 6.1, 6.2):

- BCC: zeta_L = 0.03 on n_m = 6 modes; LQR Q = I, R = 0.22 I; Kalman filter
  V1 = 1e-6 I, V2 = 5e-4 I, alpha = 0.2; LQDRF initial conditions in the
  shape of the first 6 modes.
- Grid: zeta_L = 0.03 on n_m = 5 modes; Q = 0.01 I, R = 0.84 I (exact
  reduction) or 1.387 I (corrected Guyan); V1 = 1e-10 I, V2 = 0.5 I,
  alpha = 0.05; n_f = 5.

A structure file's ``[design]`` table gives its weights in SI (``units = "SI"``:
one LQ weight and one noise intensity per kind of state, :mod:`vlab.design.weights`
converts them) or in the thesis units (``units = "thesis"``).

The package's modules: :mod:`vlab.design.settings` (the thesis's settings and
sampling periods), :mod:`vlab.design.weights` (SI weights), :mod:`vlab.design.model`
(the design model and the thesis unit system) and :mod:`vlab.design.controller` (the designs).
"""

from .controller import ControllerDesign, design_controller
from .model import (DesignModel, design_model, performance_index_si, state_labels, state_scaling,
                    to_thesis_units)
from .settings import (CONTROLLERS, DEFAULT_SETTINGS, DESIGN_MODELS, PERIOD_S, THESIS_PERIOD_S, THESIS_SETTINGS,
                       ThesisSettings, design_settings, thesis_period_s)

__all__ = [
    "CONTROLLERS", "DEFAULT_SETTINGS", "DESIGN_MODELS", "PERIOD_S", "THESIS_PERIOD_S", "THESIS_SETTINGS",
    "ControllerDesign", "DesignModel", "ThesisSettings", "design_controller", "design_model", "design_settings",
    "performance_index_si",
    "state_labels", "state_scaling", "thesis_period_s", "to_thesis_units",
]
