"""MuJoCo plant of a structure, built with MjSpec from the same spec as the FE model.

- :mod:`vlab.sim.builder`: :func:`build_plant` (hinge-chain members, strings as
  tendons, crosspiece arms, pendulum plates, voice coils and velocity sensors);
- :mod:`vlab.sim.options`: :class:`SimOptions`, how a plant is discretised and simulated;
- :mod:`vlab.sim.plant`: :class:`Plant` and :class:`BuildInfo`, what the builder made;
- :mod:`vlab.sim.planner`: the bodies, joints and constraints of a plant, planned from the spec,
  with :mod:`vlab.sim.plan` (the plan's types and mass items), :mod:`vlab.sim.hinges`
  (the hinge chain's discretisation), :mod:`vlab.sim.attachments` (crosspieces, masses,
  strings, supports, springs, coils) and :mod:`vlab.sim.prestress` (the in-plane loads);
- :mod:`vlab.sim.emit`: the plan emitted into an MjSpec (:func:`build_mjspec`);
- :mod:`vlab.sim.timestep`: the hinge chain's highest frequency, the automatic
  step, selective mass scaling and the stability check;
- :mod:`vlab.sim.damping`: hinge damping and the design of the modal damping;
  :mod:`vlab.sim.damping_matrix`: the applied modal damping matrix and its storage;
- :mod:`vlab.sim.linearize`: settle, ``mjd_transitionFD``, modes;
- :mod:`vlab.sim.pairing`: MAC pairing of two sets of modes over a common band;
- :mod:`vlab.sim.crosscheck`: FE cross-check (frequencies, MAC); :mod:`vlab.sim.decay`:
  free decay; :mod:`vlab.sim.convergence`: convergence study;
- :mod:`vlab.sim.runtime`: :class:`MujocoPlant`, the steppable plant of the lab loop, with
  :mod:`vlab.sim.loopio` (the loop's per-tick access) and :mod:`vlab.sim.contract`
  (the naming contract and the checks of an MJCF plant);
- :mod:`vlab.sim.batch_plant`: many plants stepped together;
- :mod:`vlab.sim.checks`: energy and divergence checks;
- :mod:`vlab.sim.modaltest`: the virtual modal test;
- :mod:`vlab.sim.export`: the complete plant as MJCF.
"""

from .builder import build_plant
from .checks import FreeRun, free_run, total_energy
from .contract import check_plant_contract, sensor_rows
from .convergence import convergence_study
from .crosscheck import CrossCheck, ModePair, crosscheck, fe_reference, plant_resolution_spec
from .damping import DampingReport
from .damping_matrix import ModalDamping, load_modal_damping
from .decay import FreeDecay, free_decay
from .emit import build_mjspec
from .export import export_mjcf, load_mjcf
from .hinges import hinge_layout
from .linearize import LinearModel, SimModes, linearize, modes, settle
from .options import SimOptions
from .pairing import BandPairing, UnpairedMode, mac_matrix, pair_band, pair_modes
from .plant import BuildInfo, Plant
from .runtime import MujocoPlant, load_plant_for_experiment
from .timestep import auto_timestep, check_timestep, hinge_omega_max

__all__ = [
    "BandPairing", "BuildInfo", "CrossCheck", "DampingReport", "FreeDecay", "FreeRun", "LinearModel", "ModePair",
    "ModalDamping", "MujocoPlant", "Plant", "SimModes", "SimOptions", "UnpairedMode", "auto_timestep",
    "build_mjspec", "build_plant", "check_plant_contract", "check_timestep", "convergence_study", "crosscheck",
    "export_mjcf", "fe_reference", "free_decay", "free_run", "hinge_layout", "hinge_omega_max", "linearize",
    "load_mjcf", "load_modal_damping", "load_plant_for_experiment", "mac_matrix", "modes", "pair_band",
    "pair_modes", "plant_resolution_spec", "sensor_rows", "settle", "total_energy",
]
