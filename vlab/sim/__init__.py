"""MuJoCo plant of a structure, built with MjSpec from the same spec as the FE model.

- :mod:`vlab.sim.builder`: :func:`build_plant` (hinge-chain members, strings as
  tendons, crosspiece arms, pendulum plates, voice coils and velocity sensors);
- :mod:`vlab.sim.timestep`: the hinge chain's highest frequency, the automatic
  step, selective mass scaling and the stability check;
- :mod:`vlab.sim.damping`: hinge damping and modal damping tendons;
- :mod:`vlab.sim.linearize`: settle, ``mjd_transitionFD``, modes;
- :mod:`vlab.sim.crosscheck`: FE cross-check (frequencies, MAC), free decay,
  convergence study;
- :mod:`vlab.sim.planner`: the bodies, joints and constraints of a plant, planned from the spec;
- :mod:`vlab.sim.runtime`: :class:`MujocoPlant`, the steppable plant of the lab loop;
- :mod:`vlab.sim.checks`: energy and divergence checks;
- :mod:`vlab.sim.export`: the complete plant as MJCF.
"""

from .builder import BuildInfo, Plant, SimOptions, build_mjspec, build_plant
from .checks import FreeRun, free_run, total_energy
from .crosscheck import (
    BandPairing,
    CrossCheck,
    FreeDecay,
    ModePair,
    UnpairedMode,
    convergence_study,
    crosscheck,
    fe_reference,
    free_decay,
    mac_matrix,
    pair_band,
    pair_modes,
    plant_resolution_spec,
)
from .damping import DampingReport, ModalDamping, load_modal_damping
from .export import export_mjcf, load_mjcf
from .linearize import LinearModel, SimModes, linearize, modes, settle
from .planner import hinge_layout
from .runtime import MujocoPlant, check_plant_contract, load_plant_for_experiment, sensor_rows
from .timestep import auto_timestep, check_timestep, hinge_omega_max

__all__ = [
    "BandPairing", "BuildInfo", "CrossCheck", "DampingReport", "FreeDecay", "FreeRun", "LinearModel", "ModePair",
    "ModalDamping", "MujocoPlant", "Plant", "SimModes", "SimOptions", "UnpairedMode", "auto_timestep",
    "build_mjspec", "build_plant", "check_plant_contract", "check_timestep", "convergence_study", "crosscheck",
    "export_mjcf", "fe_reference", "free_decay", "free_run", "hinge_layout", "hinge_omega_max", "linearize",
    "load_mjcf", "load_modal_damping", "load_plant_for_experiment", "mac_matrix", "modes", "pair_band",
    "pair_modes", "plant_resolution_spec", "sensor_rows", "settle", "total_energy",
]
