"""Convergence study of the MuJoCo plant: the cross-check repeated over discretisations and timesteps.

For each hinge layout, number of links per segment and timestep,
:func:`convergence_study` builds an undamped plant, cross-checks it against
the FE model (:func:`vlab.sim.crosscheck.crosscheck`), and optionally measures
the first mode's free-decay frequency (:func:`vlab.sim.decay.free_decay`) and
the time of one bare ``mj_step`` (README: convergence study).

Sources: MAC, Allemang & Brown (1982); the cross-check's limits are
:data:`vlab.sim.crosscheck.TOL_PCT` and :data:`vlab.sim.crosscheck.MIN_MAC`.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import mujoco

from ..spec import StructureSpec
from .builder import build_plant
from .crosscheck import crosscheck
from .decay import free_decay
from .options import SimOptions
from .timestep import hinge_omega_max

@dataclass(frozen=True)
class StudyRow:
    """One discretisation of :func:`convergence_study`.

    Attributes
    ----------
    segments : int
        Links per member segment (crosspiece arms alike).
    layout : str
        Hinge layout (``"gauss"`` or ``"uniform"``).
    timestep_s : float
        Step used [s] (automatic unless given).
    nv : int
        Degrees of freedom.
    f_max_hz : float
        Highest hinge-spring frequency [Hz].
    errors_pct : tuple of float
        Frequency error of each FE mode [%].
    macs : tuple of float
        MAC of each FE mode.
    decay_hz : float
        First-mode frequency from a free decay [Hz] (nan if not run).
    us_per_step : float
        Wall time of one bare ``mj_step`` [us] (nan if not measured).
    """

    segments: int
    layout: str
    timestep_s: float
    nv: int
    f_max_hz: float
    errors_pct: tuple[float, ...]
    macs: tuple[float, ...]
    decay_hz: float
    us_per_step: float

    @property
    def max_error_pct(self) -> float:
        """Largest ``|error|`` [%]."""
        return max(abs(e) for e in self.errors_pct)

    @property
    def min_mac(self) -> float:
        """Smallest MAC."""
        return min(self.macs)


def convergence_study(spec: StructureSpec, n_modes: int, *, segments=(2, 3, 4), layouts=("gauss",),
                      timesteps=(None,), decay: bool = False, speed_steps: int = 0) -> list[StudyRow]:
    """Cross-check the plant for several segment counts, hinge layouts and timesteps.

    Parameters
    ----------
    spec : StructureSpec
    n_modes : int
        FE modes compared.
    segments : sequence of int
        Links per member segment (and per crosspiece arm), for every member
        (see :class:`~vlab.sim.options.SimOptions`).
    layouts : sequence of str
        Hinge layouts.
    timesteps : sequence of float or None
        Steps [s]; None = automatic.
    decay : bool
        Also measure the first mode's frequency from a free decay.
    speed_steps : int
        Steps timed per row (0: no timing).

    Returns
    -------
    list of StudyRow

    Raises
    ------
    SimulationError
        If a combination cannot be built or is unstable (timestep too large).
    """
    rows = []
    for layout in layouts:
        for n in segments:
            for dt in timesteps:
                opts = SimOptions(segments_per_element=n, crosspiece_segments=n, hinge_layout=layout,
                                  timestep_s=dt, modal_damping=False, stiffness_damping_s=0.0,
                                  check_timestep=dt is None)
                plant = build_plant(spec, opts)
                cc = crosscheck(plant, n_modes)
                omega, _ = hinge_omega_max(plant.model)
                f_decay = math.nan
                if decay:
                    j = cc.pairs[0].sim_mode or 1
                    f_decay = free_decay(plant, j, sim_modes=cc.sim_modes).frequency_hz
                us = math.nan
                if speed_steps:
                    d = mujoco.MjData(plant.model)
                    t0 = time.perf_counter()
                    mujoco.mj_step(plant.model, d, nstep=speed_steps)
                    us = (time.perf_counter() - t0) / speed_steps * 1e6
                rows.append(StudyRow(n, layout, plant.timestep_s, plant.model.nv, omega / (2 * math.pi),
                                     tuple(p.error_pct for p in cc.pairs), tuple(p.mac for p in cc.pairs),
                                     f_decay, us))
    return rows
