"""Virtual experiments for the peak-level-ratio tables (10, 19-21) and the FRF figures (22-31).

Each run is the laboratory procedure of Sec. 5.4.2 in the virtual lab: the
controller runs on the Eq. (5.1) engine at the thesis's sampling period for
it (Sec. 5.3: DRF at 2 kHz, LQG at 1 kHz; :func:`vlab.design.thesis_period_s`)
with the 1.35-period delay,
zero-order hold, 677 Hz RC filter and current amplifier of Sec. 5.3
(:class:`vlab.lab.loop.HardwareChain`), a periodic pseudo-random force is
added to the excitation channel (BCC: point 9, 0.5-25 Hz; grid: joint 4,
0.2-10 Hz), and the H1 FRF to the response point (BCC: displacement at
point 6; grid: velocity at joint 4) is measured over the settled periods
(as many settling periods as the slowest predicted mode needs to decay to
1 %, :func:`vlab.experiment.settling.settle_records`).
The plant is the laboratory structure of :mod:`vlab.reproduce.context`
(``plant="linear"``: stepped exactly; ``plant="mujoco"``: the MuJoCo model of
the nominal spec).

The analysis is the dissertation's: the continuous-time closed loop on the
analysis model (BCC: the full model, Sec. 6.1; grid: the exact reduction
"E.A." or the corrected Guyan model "C.G.", Sec. 6.3). Peak levels are
read from each FRF near its own closed-loop natural frequencies with the
same curve fit (:func:`vlab.measure.compare.compare_modes`) and compared
mode by mode: ratio = analysis / experiment, average error mean |1 - r|
(Tables 10, 19-21).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..analysis import closed_loop_frf, closed_loop_modes, continuous_controller_frf, velocity_frf
from ..design import ControllerDesign, DesignModel
from ..errors import MeasurementError, ModelError
from ..fe import FEModel
from ..experiment.config import ExperimentConfig, test_definition
from ..experiment.runner import make_plant, measure
from ..experiment.settling import slowest_decay_rate
from ..lab.loop import check_design_period
from ..lab.linear_plant import LinearPlant
from ..measure.compare import compare_modes
from .closedloop import actuator_input
from .context import LabStructure, ReproContext

PLANTS = ("linear", "mujoco")


@dataclass(frozen=True)
class RunSpec:
    """One virtual experiment.

    Attributes
    ----------
    structure : str
        ``"bcc"`` or ``"grid"``.
    controller : str
        ``"none"`` (open loop) or a controller of :data:`vlab.design.CONTROLLERS` (not LQR).
    model : str or None
        Design model of the controller (None: the thesis's default).
    resolution_hz : float
        Frequency resolution = 1 / period of the pseudo-random force [Hz].
    periods : int
        Periods measured + 1 (>= 2); before them, as many periods settle and
        are discarded as the slowest predicted mode needs (at least one).
    seed : int
        Seed of the excitation phases.
    """

    structure: str
    controller: str
    model: str | None
    resolution_hz: float
    periods: int = 2
    seed: int = 0

    @property
    def key(self) -> str:
        """A short unique name, e.g. ``"grid/mfdrf@exact"``."""
        return f"{self.structure}/{self.controller}" + (f"@{self.model}" if self.model else "")


@dataclass(frozen=True)
class VirtualRun:
    """The measured FRF of one virtual experiment.

    Attributes
    ----------
    spec : RunSpec
    freq_hz : ndarray, shape (n_f,)
        FRF lines in the test band [Hz].
    h : ndarray, complex, shape (n_f,)
        Measured FRF at the response point in the test's quantity
        (BCC: displacement [m/N]; grid: velocity [(m/s)/N]).
    plant : str
        Description of the plant.
    duration_s : float
        Simulated time [s].
    wall_s : float
        Wall-clock time of the run [s].
    """

    spec: RunSpec
    freq_hz: np.ndarray
    h: np.ndarray
    plant: str
    duration_s: float
    wall_s: float


def _plant(ctx: ReproContext, cfg: ExperimentConfig, fe: FEModel, actuators: tuple[int, ...]):
    if cfg.plant == "linear":
        lab: LabStructure = ctx.lab(cfg.structure)
        pidx = {p: fe.dofs.index(p, "w") for p in fe.spec.points if (p, "w") in fe.dofs}
        return LinearPlant(lab.m, lab.c, lab.k, point_index=pidx, actuator_points=actuators,
                           timestep_s=cfg.chain.period_s / 2), f"linear plant: {lab.description}"
    if cfg.plant == "mujoco":
        if ctx.lab_kind != "nominal":
            raise ModelError("the MuJoCo plant is built from the nominal spec: use lab='nominal' with plant='mujoco'")
        p, info = make_plant(cfg, fe, actuators)
        return p, f"{info.get('kind', 'MuJoCo plant')} ({info.get('source', fe.spec.name)})"
    raise ModelError(f"unknown plant {cfg.plant!r}; use one of {PLANTS}")


def run_virtual_experiment(spec: RunSpec, *, ctx: ReproContext | None = None, plant: str = "linear",
                           lab: str = "as-measured", progress: Callable[[float], None] | None = None) -> VirtualRun:
    """Run one virtual experiment and measure the H1 FRF at the response point.

    Parameters
    ----------
    spec : RunSpec
    ctx : ReproContext, optional
        Shared designs; a new one (with ``lab``) by default.
    plant : {"linear", "mujoco"}
    lab : {"as-measured", "nominal"}
        Laboratory structure when ``ctx`` is not given.
    progress : callable, optional
        Receives the fraction of the run done.

    Returns
    -------
    VirtualRun

    Raises
    ------
    ModelError
        Unknown plant or controller; MuJoCo with the as-measured structure.
    SimulationError
        The closed loop diverged.
    """
    t0 = time.perf_counter()
    ctx = ctx or ReproContext(lab=lab)
    if spec.periods < 2:
        raise ModelError(f"{spec.key}: needs at least 2 periods (one to settle), got {spec.periods}")
    fe = ctx.fe(spec.structure)
    resp = test_definition(spec.structure).response_point
    cfg = ExperimentConfig(structure=spec.structure, controller=spec.controller, excitation="random",
                           periods=spec.periods, seed=spec.seed, plant=plant, resolution_hz=spec.resolution_hz)
    design = None if spec.controller == "none" else ctx.design(spec.structure, spec.controller, spec.model)
    check_design_period(design, cfg.chain)  # both at the thesis period of the controller
    p, desc = _plant(ctx, cfg, fe, tuple(fe.spec.instrumentation.actuators))
    m = measure(cfg, fe, design, plant=(p, {"kind": desc}), measured_points=(resp,), shape_points=(resp,),
                metadata={"run": spec.key}, progress=progress, decay_rate_1_s=slowest_decay_rate(fe, design))
    return VirtualRun(spec, m.freq_hz, m.measured, desc, m.config.duration_s, time.perf_counter() - t0)


def analysis_frf(dm: DesignModel, design: ControllerDesign | None, freq_hz: np.ndarray, structure: str,
                 excitation_point: int) -> np.ndarray:
    """Continuous closed-loop FRF at the test's response point on an analysis model (the thesis's analysis).

    Parameters
    ----------
    dm : DesignModel
        Analysis model (full, exact, corrected-guyan); must contain the response point.
    design : ControllerDesign or None
        Controller (its continuous form); None: open loop.
    freq_hz : ndarray, shape (n_f,)
    structure : str
        Selects the test (response point and quantity).
    excitation_point : int
        Actuator point carrying the excitation.

    Returns
    -------
    ndarray, complex, shape (n_f,)
        Displacement (BCC) or velocity (grid) per force [SI].

    Raises
    ------
    ModelError
        If the response point is not a DOF of ``dm``.
    """
    test = test_definition(structure)
    u = actuator_input(dm)
    try:
        r_row = list(dm.labels).index((test.response_point, "w"))
    except ValueError:
        raise ModelError(f"analysis model {dm.name} has no DOF w at point {test.response_point}") from None
    out = np.zeros((1, dm.m.shape[0]))
    out[0, r_row] = 1.0
    g = velocity_frf(dm.m, dm.c, dm.k, u, np.vstack([u.T, out]), freq_hz)
    n_a = u.shape[1]
    k = (np.zeros((len(freq_hz), n_a, n_a), dtype=complex) if design is None
         else continuous_controller_frf(freq_hz, **design.continuous))
    acts = [lab[0] for lab in (dm.labels[r] for r in dm.actuator_rows)]
    h = closed_loop_frf(g[:, :n_a, :], g[:, n_a:, :], k, acts.index(excitation_point))[:, 0]
    if test.response_quantity == "displacement":
        h = h / (2j * np.pi * np.asarray(freq_hz))
    return h


def predicted_modes(m, c, k, u, design: ControllerDesign | None, structure: str) -> tuple[np.ndarray, np.ndarray]:
    """Closed-loop natural frequencies [Hz] and damping of the first in-band modes of a plant (peak hints).

    Parameters
    ----------
    m, c, k, u
        The plant, as :func:`vlab.reproduce.sampled_modes.sampled_data_modes`.
    design : ControllerDesign or None
        Controller (continuous form); None: open loop.
    structure : str
        Selects the test band and number of modes.

    Returns
    -------
    freq_hz, zeta : ndarray, shape (n_modes,)
    """
    test = test_definition(structure)
    f, z = closed_loop_modes(m, c, k, u, u.T, None if design is None else design.continuous)
    band = (f >= test.band_hz[0]) & (f <= test.band_hz[1])
    return f[band][: test.n_modes], z[band][: test.n_modes]


def peak_levels(freq_hz: np.ndarray, h: np.ndarray, modes_hz: np.ndarray, zeta: np.ndarray,
                structure: str) -> np.ndarray:
    """Peak levels ``|H|`` of the modes of an FRF, identified near its own natural frequencies.

    Uses :func:`vlab.measure.compare.compare_modes` (curve fit, then the
    refined peak) on the FRF alone. A mode that cannot be identified gives NaN.

    Parameters
    ----------
    freq_hz : ndarray, shape (n_f,)
    h : ndarray, complex, shape (n_f,)
    modes_hz : ndarray, shape (n_modes,)
        Expected natural frequencies [Hz].
    zeta : ndarray, shape (n_modes,)
        Expected damping ratios (size the fitted bands).
    structure : str
        Selects the response quantity.

    Returns
    -------
    ndarray, shape (n_modes,)
    """
    test = test_definition(structure)
    try:
        comps = compare_modes(freq_hz, h, h, modes_hz, zeta, response=test.response_quantity)
    except MeasurementError:
        return np.full(len(modes_hz), np.nan)
    return np.array([c.peak_predicted for c in comps], dtype=float)


def measured_peaks(ctx: ReproContext, run: VirtualRun) -> np.ndarray:
    """Peak levels of a run's measured FRF near the laboratory structure's closed-loop modes.

    Parameters
    ----------
    ctx : ReproContext
        Models of the run; its laboratory structure gives the mode hints
        (whichever plant recorded the run).
    run : VirtualRun
        The recorded run and its measured FRF.

    Returns
    -------
    ndarray, shape (n_modes,)
        Peak levels [FRF units]; NaN for a mode not identified.
    """
    s = run.spec
    fe = ctx.fe(s.structure)
    acts = tuple(fe.spec.instrumentation.actuators)
    u = fe.force_input(acts)
    lab = ctx.lab(s.structure)  # with plant="mujoco" the laboratory structure is the nominal model
    design = None if s.controller == "none" else ctx.design(s.structure, s.controller, s.model)
    fm, zm = predicted_modes(lab.m, lab.c, lab.k, u, design, s.structure)
    return peak_levels(run.freq_hz, run.h, fm, zm, s.structure)


def analysis_peaks(ctx: ReproContext, run: VirtualRun, analysis_model: str) -> tuple[np.ndarray, np.ndarray]:
    """Analysis FRF of a run's controller on ``analysis_model`` and its peak levels.

    Parameters
    ----------
    ctx : ReproContext
    run : VirtualRun
    analysis_model : str
        ``"full"``, ``"exact"`` or ``"corrected-guyan"``.

    Returns
    -------
    h : ndarray, complex, shape (n_f,)
        Analysis FRF on the run's lines.
    peaks : ndarray, shape (n_modes,)
    """
    s = run.spec
    fe = ctx.fe(s.structure)
    dm = ctx.design_model(s.structure, analysis_model)
    design = None if s.controller == "none" else ctx.design(s.structure, s.controller, s.model)
    h = analysis_frf(dm, design, run.freq_hz, s.structure, fe.spec.instrumentation.excitation)
    fm, zm = predicted_modes(dm.m, dm.c, dm.k, actuator_input(dm), design, s.structure)
    return h, peak_levels(run.freq_hz, h, fm, zm, s.structure)


@dataclass(frozen=True)
class RunComparison:
    """A run's measured FRF and peaks with the analysis on one or more models.

    Attributes
    ----------
    run : VirtualRun
    measured_peaks : ndarray, shape (n_modes,)
    analysis : dict
        Analysis model name -> (FRF ndarray complex (n_f,), peaks ndarray (n_modes,)).
    """

    run: VirtualRun
    measured_peaks: np.ndarray
    analysis: dict

    def ratios(self, model: str) -> np.ndarray:
        """Analysis/experiment peak level ratios on ``model``, shape (n_modes,) (NaN where unidentified)."""
        a = self.analysis[model][1]
        n = min(len(a), len(self.measured_peaks))
        with np.errstate(invalid="ignore", divide="ignore"):
            return a[:n] / self.measured_peaks[:n]


def compare_run(ctx: ReproContext, run: VirtualRun, models: tuple[str, ...]) -> RunComparison:
    """Peak levels of a run and of its analysis on each of ``models`` (see the module docstring).

    Parameters
    ----------
    ctx : ReproContext
        Models and designs of the run.
    run : VirtualRun
        The recorded run.
    models : tuple of str
        Analysis models.

    Returns
    -------
    RunComparison
    """
    return RunComparison(run, measured_peaks(ctx, run), {m: analysis_peaks(ctx, run, m) for m in models})
