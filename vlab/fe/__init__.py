"""Finite-element library: elements, mesh, gravity statics, assembly, modal analysis."""

from .assembly import FEModel, build_fe_model
from .modal import Modes, modal_analysis

__all__ = ["FEModel", "Modes", "build_fe_model", "modal_analysis"]
