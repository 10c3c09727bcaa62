"""MuJoCo plant of a structure, built with MjSpec from the same spec as the FE model.

- :mod:`vlab.sim.builder`: :func:`build_plant` (hinge-chain members, strings as
  tendons, crosspiece arms, voice coils and velocity sensors), timestep check;
- :mod:`vlab.sim.damping`: hinge damping and modal damping tendons;
- :mod:`vlab.sim.linearize`: settle, ``mjd_transitionFD``, modes;
- :mod:`vlab.sim.crosscheck`: FE cross-check (frequencies, MAC), free decay;
- :mod:`vlab.sim.export`: complete plant as MJCF;
- :mod:`vlab.sim.checks`: divergence and energy checks.
"""

from .builder import BuildInfo, Plant, SimOptions, build_mjspec, build_plant, check_timestep
from .crosscheck import CrossCheck, FreeDecay, ModePair, crosscheck, free_decay, mac_matrix, pair_modes
from .linearize import LinearModel, SimModes, linearize, modes, settle

__all__ = [
    "BuildInfo", "CrossCheck", "FreeDecay", "LinearModel", "ModePair", "Plant", "SimModes", "SimOptions",
    "build_mjspec", "build_plant", "check_timestep", "crosscheck", "free_decay", "linearize",
    "mac_matrix", "modes", "pair_modes", "settle",
]
