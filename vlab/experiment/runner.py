"""A closed-loop experiment in the virtual laboratory (Chapter 5, Sec. 6.1).

``run_experiment`` designs the controller on the nominal model, builds the
plant (MuJoCo from the same spec, an exported/edited MJCF, or the linear FE
model), runs the digital loop (2 kHz; LQG 1 kHz) with the hardware chain of Sec. 5.3,
excites it the way Sec. 5.4 describes, measures H1 FRFs and compares them
mode by mode with the analysis: the continuous closed-loop FRF the
dissertation computed and the sampled-data FRF with hold, delay and filter.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import Callable

import numpy as np

from ..analysis import (
    closed_loop_frf,
    closed_loop_modes,
    continuous_controller_frf,
    sampled_data_controller_frf,
    velocity_frf,
)
from ..fe.damping import structural_damping
from ..errors import MeasurementError, ModelError
from ..errors import SpecError
from ..fe import FEModel
from ..io.frf import FRF
from ..lab.engine import ControllerEngine
from ..lab.excitation import periodic_chirp, pseudo_random, pulse_train
from ..lab.linear_plant import LinearPlant
from ..lab.loop import HardwareChain, LoopResult, check_design_period, run_loop
from ..measure.compare import ModeComparison, average_error, compare_modes
from ..measure.frf import h1
from ..spec import StructureSpec, StructureTest, load_spec

EXCITATIONS = ("random", "sweep", "impulse")


TESTS = {
    # BCC: 0-25 Hz random at point 9, displacement at point 6 (Sec. 5.4.2, Table 10)
    "bcc": StructureTest((0.5, 25.0), 0.05, 0.5, 6, 6, (5, 6, 7, 9), "displacement"),
    # grid: 0-10 Hz random at joint 4, velocity at joints 1-5, 8 (Sec. 5.4.2, Tables 19-21)
    "grid": StructureTest((0.2, 10.0), 0.02, 0.2, 4, 4, (1, 2, 3, 4, 5, 8), "velocity"),
}


def test_definition(spec: StructureSpec | str) -> StructureTest:
    """The modal test of a structure (Sec. 5.4): its own ``[test]`` table, else the shipped one.

    A structure file's ``[test]`` table (band, resolution, force level,
    points, response quantity; read by :func:`vlab.spec.load_spec`) wins;
    without one, a structure named like a shipped one (``"bcc"``, ``"grid"``)
    gets its entry of :data:`TESTS` (Sec. 5.4.2, Tables 10 and 19-21).

    Parameters
    ----------
    spec : StructureSpec or str
        The structure, or a name or TOML path for :func:`vlab.spec.load_spec`.

    Returns
    -------
    StructureTest

    Raises
    ------
    SpecError
        The structure has no ``[test]`` table and no shipped test (the
        message names its file and the fields to add); as :func:`load_spec`
        for a name or path.
    """
    if isinstance(spec, (str, Path)):
        spec = load_spec(spec)
    if spec.test is not None:
        return spec.test
    if spec.name in TESTS:
        return TESTS[spec.name]
    raise SpecError(f"{spec._file()}: structure {spec.name!r} has no [test] table (band_hz, resolution_hz, rms_n, "
                    f"n_modes, response_point, measured_points, response_quantity) and no shipped test "
                    f"(shipped: {', '.join(TESTS)}); add one (`vlab init beam PATH` writes an example)")


test_definition.__test__ = False  # not a pytest test, although its name starts with "test_"



@dataclass(frozen=True)
class ExperimentConfig:
    """Settings of one experiment (the options of ``vlab experiment``).

    Attributes
    ----------
    structure : str
        Structure name (``"bcc"``, ``"grid"`` or the ``name`` of a structure file); the
        test itself comes from the FE model's spec (:func:`test_definition`).
    controller : str
        ``"none"`` (open loop), ``"lqg"``, ``"mfdrf"``, ``"lqdrf"`` or
        ``"lqdrf-diag"`` (:data:`vlab.design.CONTROLLERS`; ``"lqr"`` is refused:
        it needs the full state).
    reduction : str or None
        Design model (``"full"``, ``"exact"``, ``"guyan"``,
        ``"corrected-guyan"``); None = the thesis's choice
        (:func:`vlab.design.design_controller`).
    excitation : str
        One of :data:`EXCITATIONS`: ``"random"`` (periodic pseudo-random),
        ``"sweep"`` (a linear sweep across the band once per record) or
        ``"impulse"`` (one half-sine pulse per record), in the structure's band
        (Sec. 5.4); all three periodic over a record.
    duration_s : float or None
        Run length [s]; None = ``periods`` records of ``1 / resolution_hz``.
    periods : int
        Number of records of length ``1 / resolution_hz`` [s] run when
        ``duration_s`` is None: ``periods - 1`` records are measured after the
        settling records (one, or more for lightly damped modes; see
        :func:`settle_records`).
    chain : HardwareChain or None
        Hardware between controller and coils (Sec. 5.3). None (default) =
        the thesis chain at the thesis's sampling period for ``controller``
        (:func:`vlab.design.thesis_period_s`: LQG 1 ms, the others 0.5 ms);
        after construction it is always a :class:`HardwareChain`.
    seed : int
        Seed of the excitation, the sensor noise and the DRF optimisers' multi-start.
    plant : str
        ``"mujoco"`` (MuJoCo plant) or ``"linear"`` (the FE model stepped exactly).
    mjcf : Path or None
        An exported and possibly edited MJCF file to run instead of the plant
        built from the spec (``"mujoco"`` only).
    resolution_hz : float or None
        FRF frequency resolution [Hz]; None = the structure's
        :attr:`StructureTest.resolution_hz`.
    """

    structure: str = "bcc"
    controller: str = "mfdrf"
    reduction: str | None = None
    excitation: str = "random"
    duration_s: float | None = None
    periods: int = 3
    chain: HardwareChain | None = None
    seed: int = 0
    plant: str = "mujoco"
    mjcf: Path | None = None
    resolution_hz: float | None = None

    def __post_init__(self) -> None:
        if self.chain is None:
            object.__setattr__(self, "chain", default_chain(self.controller))


def default_chain(controller: str, **settings) -> HardwareChain:
    """The Sec. 5.3 hardware chain at the thesis's sampling period for ``controller``.

    Parameters
    ----------
    controller : str
        ``"none"`` or one of :data:`vlab.design.CONTROLLERS`; selects the
        period (:func:`vlab.design.thesis_period_s`: LQG 1 ms, others 0.5 ms).
    **settings
        Other :class:`HardwareChain` fields (``delay_periods``, ``noise_m_s``,
        ...); ``period_s`` here overrides the thesis period.

    Returns
    -------
    HardwareChain

    Raises
    ------
    ModelError
        Unknown controller.
    """
    from ..design import thesis_period_s

    settings.setdefault("period_s", thesis_period_s(controller))
    return HardwareChain(**settings)


def period_source(controller: str, period_s: float) -> str:
    """Where a run's sampling period comes from, for reports: the thesis's value or a user setting.

    Parameters
    ----------
    controller : str
        ``"none"`` or one of :data:`vlab.design.CONTROLLERS`.
    period_s : float
        The period used [s].

    Returns
    -------
    str
        E.g. ``"thesis value for lqg (Sec. 5.3)"`` or ``"set by the user (thesis value for lqg: 1 ms)"``.

    Raises
    ------
    ModelError
        Unknown controller.
    """
    from ..design import thesis_period_s

    ref = thesis_period_s(controller)
    if abs(period_s - ref) <= 1e-12 * ref:
        return f"thesis value for {controller} (Sec. 5.3)"
    return f"set by the user (thesis value for {controller}: {ref * 1e3:g} ms)"


@dataclass(frozen=True)
class ExperimentResult:
    """Everything an experiment produced (see :func:`vlab.experiment.results.write_outputs`).

    Attributes
    ----------
    config, loop, frfs, freq_hz, measured, plant_info
        As in :class:`Measurement` (``freq_hz``: the comparison band).
    analysis_continuous : ndarray, complex, shape (n_f,)
        Closed-loop FRF at the response point with the continuous controller,
        as the dissertation computed it (Sec. 6.1), in the units of
        ``response_quantity`` ([m/N] or [(m/s)/N]).
    analysis_sampled : ndarray, complex, shape (n_f,)
        The same with the sampled-data controller (hold, delay, RC filter).
    modes : list of ModeComparison
        Mode-by-mode comparison of ``analysis_sampled`` with ``measured``
        (Tables 10, 19-21).
    avg_peak_error : float
        Average peak level error ``mean |1 - ratio|`` over the identified modes.
    design : ControllerDesign or None
        The controller run (None for open loop).
    warnings : tuple of str
        Warnings of the run (a run too short to settle the slowest mode, self-excited
        oscillation, modes not identified); see :func:`not_meaningful`.
    """

    config: ExperimentConfig
    loop: LoopResult
    frfs: dict[str, FRF]
    freq_hz: np.ndarray
    analysis_continuous: np.ndarray
    analysis_sampled: np.ndarray
    measured: np.ndarray
    modes: list[ModeComparison]
    avg_peak_error: float
    design: object | None
    plant_info: dict
    warnings: tuple[str, ...] = ()


#: Remaining share of the start-up transient (relative to its initial amplitude) allowed when the
#: settling records end; the records measured after it see a transient below this level.
SETTLE_TOLERANCE = 0.01


def _excitation(cfg: ExperimentConfig, test: StructureTest, resolution_hz: float, duration_s: float) -> Callable:
    """The excitation force of ``cfg.excitation`` as a function of time, periodic over one record.

    All three repeat every record of ``1 / resolution_hz`` seconds (Sec. 5.4.1): a
    periodic pseudo-random multisine, a linear sweep across the band once per
    record (:func:`~vlab.lab.excitation.periodic_chirp`), or one half-sine
    impact per record (:func:`~vlab.lab.excitation.pulse_train`, length
    ``1.5 / (1.2 f_high)`` so that its first spectral zero lies at 1.2 times the
    band's upper edge). Once settled, every record is a period of the steady
    state and H1 with a rectangular window is leakage-free.
    """
    lo, hi = test.band_hz
    record_s = 1.0 / resolution_hz
    if cfg.excitation == "random":
        return lambda t: pseudo_random(t, band_hz=(lo, hi), resolution_hz=resolution_hz, rms_n=test.rms_n,
                                       seed=cfg.seed)
    if cfg.excitation == "sweep":
        return lambda t: periodic_chirp(t, band_hz=(lo, hi), period_s=record_s, amplitude_n=test.rms_n * np.sqrt(2))
    if cfg.excitation == "impulse":
        return lambda t: pulse_train(t, peak_n=20 * test.rms_n, duration_s=1.5 / (1.2 * hi), period_s=record_s)
    raise ModelError(f"unknown excitation {cfg.excitation!r}; use one of {EXCITATIONS}")


def settle_records(decay_rate_1_s: float | None, record_s: float, *, tolerance: float = SETTLE_TOLERANCE) -> int:
    """Records to discard so that the start-up transient has decayed to ``tolerance``.

    The free response started with the excitation decays as
    ``exp(-sigma t)`` with ``sigma = zeta * 2 pi f_n`` of the slowest mode;
    ``n = max(1, ceil(ln(1 / tolerance) / (sigma * record_s)))`` records bring
    it below ``tolerance`` of its initial size (which is about the mode's
    steady-state amplitude when the run starts at rest).

    Parameters
    ----------
    decay_rate_1_s : float or None
        Slowest decay rate ``sigma = zeta omega_n`` of the modes in band [1/s];
        None = one record (no damping known).
    record_s : float
        Record length [s].
    tolerance : float
        Transient share left at the end of the settling records [-], in (0, 1).

    Returns
    -------
    int
        Number of settling records, at least 1.

    Raises
    ------
    ModelError
        A non-positive record length or decay rate, or a tolerance outside (0, 1).
    """
    if not record_s > 0:
        raise ModelError(f"record_s must be > 0, got {record_s!r}")
    if not 0 < tolerance < 1:
        raise ModelError(f"tolerance must lie in (0, 1), got {tolerance!r}")
    if decay_rate_1_s is None:
        return 1
    if not (np.isfinite(decay_rate_1_s) and decay_rate_1_s > 0):
        raise ModelError(f"decay_rate_1_s must be a positive finite rate [1/s], got {decay_rate_1_s!r}")
    return max(1, int(np.ceil(np.log(1.0 / tolerance) / (decay_rate_1_s * record_s) - 1e-9)))


def make_plant(cfg: ExperimentConfig, fe: FEModel, actuators: tuple[int, ...], timestep_s: float | None = None):
    """The plant of an experiment: ``"mujoco"`` (from the spec or ``cfg.mjcf``) or ``"linear"`` (FE).

    Parameters
    ----------
    cfg : ExperimentConfig
        ``cfg.plant`` selects the kind, ``cfg.mjcf`` an exported MJCF file,
        ``cfg.chain.period_s`` the default linear-plant step.
    fe : FEModel
        The FE model: its spec builds the MuJoCo plant; its ``m`` [kg] and
        ``k`` [N/m], shape (n, n), with the spec's open-loop modal damping
        (Sec. 2.1.2) form the linear plant.
    actuators : tuple of int
        Coil point ids driven by the loop, in channel order.
    timestep_s : float, optional
        Physics step of the linear plant [s]; default half the controller
        period. Ignored for the MuJoCo plant (its step comes from the built
        model or the MJCF file).

    Returns
    -------
    (plant, info) : plant with the loop's Plant protocol, and a dict describing it.

    Raises
    ------
    ModelError
        Unknown plant kind; an MJCF file with the linear plant (``--mjcf``
        with ``--plant linear``: the linear plant is the FE model, it cannot
        run an MJCF); an MJCF that breaks the naming contract
        (:func:`vlab.sim.runtime.check_plant_contract`: its ``coil<ID>`` /
        ``vel<ID>`` at the spec's instrumentation and the test's measured
        points). DataFileError / SimulationError from the MuJoCo side.
    """
    if cfg.mjcf is not None and cfg.plant != "mujoco":
        raise ModelError(f"--mjcf {cfg.mjcf} needs the MuJoCo plant (--plant mujoco); --plant {cfg.plant} "
                         "would ignore it: drop one of the two options")
    if cfg.plant == "linear":
        c = structural_damping(fe)
        pidx = {p: fe.dofs.index(p, "w") for p in fe.spec.points if (p, "w") in fe.dofs}
        h = timestep_s or cfg.chain.period_s / 2
        return LinearPlant(fe.m, c, fe.k, point_index=pidx, actuator_points=actuators, timestep_s=h), {
            "kind": "linear FE model", "timestep_s": h}
    if cfg.plant == "mujoco":
        from ..sim import load_plant_for_experiment

        return load_plant_for_experiment(fe.spec, mjcf=cfg.mjcf, actuators=actuators,
                                         sensors=test_definition(fe.spec).measured_points)
    raise ModelError(f"unknown plant {cfg.plant!r}; use 'mujoco' or 'linear'")


@dataclass(frozen=True)
class Measurement:
    """What one run of the test measured (:func:`measure`).

    Attributes
    ----------
    config : ExperimentConfig
        The settings, with ``duration_s`` and ``resolution_hz`` filled in.
    loop : LoopResult
        The run: recording at the controller rate, commands and displacements.
    frfs : dict[str, FRF]
        H1 velocity FRFs [(m/s)/N] from the excitation force, keyed ``"vel<point>"`` for every measured
        point, on the excited lines only (the test band, edges included).
    freq_hz : ndarray, shape (n_f,)
        Frequency lines of the test band [Hz].
    measured : ndarray, complex, shape (n_f,)
        FRF at the response point on those lines, in the test's ``response_quantity``
        ([m/N] for ``"displacement"``, [(m/s)/N] for ``"velocity"``).
    plant_info : dict
        Description of the plant (``"kind"``, ``"timestep_s"``, ``"actuators"``,
        and for MuJoCo ``"source"``, ``"nv"``, ...; see :func:`make_plant`).
    settle_samples : int
        Samples of the recording discarded as settling before the FRFs were measured.
    warnings : tuple of str
        Warnings of the measurement (a settling time too short for the slowest mode).
    """

    config: ExperimentConfig
    loop: LoopResult
    frfs: dict[str, FRF]
    freq_hz: np.ndarray
    measured: np.ndarray
    plant_info: dict
    settle_samples: int
    warnings: tuple[str, ...] = ()


def _test_of(fe: FEModel) -> tuple[StructureTest, tuple[int, ...], int]:
    """The structure's test, its actuator points (channel order) and its excitation point; SpecError if none."""
    return test_definition(fe.spec), tuple(fe.spec.instrumentation.actuators), fe.spec.instrumentation.excitation


def _predicted_modes(fe: FEModel, design=None) -> tuple[np.ndarray, np.ndarray]:
    """Frequencies [Hz] and damping ratios, each (n,), of the continuous closed loop's first test modes in band."""
    test, acts, _ = _test_of(fe)
    c = structural_damping(fe)
    u = fe.force_input(acts)
    fm, zm = closed_loop_modes(fe.m, c, fe.k, u, u.T, None if design is None else design.continuous)
    in_band = (fm >= test.band_hz[0]) & (fm <= test.band_hz[1])
    return fm[in_band][: test.n_modes], zm[in_band][: test.n_modes]


def slowest_decay_rate(fe: FEModel, design=None) -> float | None:
    """Slowest decay rate ``zeta_r omega_r`` [1/s] of the predicted modes in the test's band.

    The modes are those of the continuous closed loop on the FE model with
    the spec's open-loop modal damping (:func:`vlab.analysis.closed_loop_modes`;
    open loop when ``design`` is None), the first ``n_modes`` of the test in
    its band (:func:`test_definition`). It sets how many records :func:`measure` lets
    settle (:func:`settle_records`).

    Parameters
    ----------
    fe : FEModel
        The nominal FE model (its spec selects the test).
    design : ControllerDesign, optional
        The controller (its ``continuous`` form); None = open loop.

    Returns
    -------
    float or None
        The smallest positive finite decay rate [1/s]; None when no mode in the band has one.

    Raises
    ------
    SpecError
        Structure without a test definition (:func:`test_definition`).
    """
    fm, zm = _predicted_modes(fe, design)
    sigma = 2 * np.pi * fm * zm
    sigma = sigma[np.isfinite(sigma) & (sigma > 0)]
    return float(sigma.min()) if sigma.size else None


def measure(
    cfg: ExperimentConfig,
    fe: FEModel,
    design=None,
    *,
    plant=None,
    measured_points: tuple[int, ...] | None = None,
    shape_points: tuple[int, ...] | None = None,
    metadata: dict | None = None,
    progress: Callable[[float], None] | None = None,
    decay_rate_1_s: float | None = None,
) -> Measurement:
    """Run the test of Sec. 5.4.2 once and measure its H1 FRFs (no analysis).

    The controller runs on the Eq. (5.1) engine in the digital loop (period ``cfg.chain.period_s``) with
    ``cfg.chain`` (Sec. 5.3); the excitation of ``cfg.excitation`` is added at
    the structure's excitation channel. Every excitation repeats once per
    record of ``1 / resolution_hz`` seconds; the first records settle and are
    discarded (:func:`settle_records`: enough for the slowest mode's start-up
    transient to decay to :data:`SETTLE_TOLERANCE`), the rest are analysed
    with H1 and a rectangular window over blocks of one record.

    Parameters
    ----------
    cfg : ExperimentConfig
        Settings of the experiment (``cfg.controller`` is not read: ``design`` is run).
    fe : FEModel
        The nominal FE model: its spec gives the test, channels and points.
    design : ControllerDesign, optional
        The controller run (its Eq. (5.1) matrices ``f11``-``f22``); None runs open loop.
    plant : (plant, info), optional
        A plant with the loop's Plant protocol and a dict describing it; by
        default :func:`make_plant` builds ``cfg.plant``.
    measured_points : tuple of int, optional
        Points whose velocity is recorded and H1 is measured; default the
        test's :attr:`StructureTest.measured_points` and the actuators.
    shape_points : tuple of int, optional
        Points whose displacement is recorded for the deflection shape; default
        every point with an out-of-plane DOF (the supports stay at rest).
    metadata : dict, optional
        Stored with the recording; default structure, controller, excitation, seed and plant.
    progress : callable, optional
        Receives the fraction of the run done.
    decay_rate_1_s : float, optional
        Slowest expected decay rate ``zeta omega_n`` of the modes in band [1/s]
        (e.g. from :func:`vlab.analysis.closed_loop_modes`); sets the number of
        settling records. None = one record. With ``cfg.duration_s`` None the run
        lasts the settling records plus ``cfg.periods - 1`` measured records;
        a given duration too short to settle is run anyway with a warning
        naming the transient left.

    Returns
    -------
    Measurement

    Raises
    ------
    SpecError
        Structure without a test definition (:func:`test_definition`).
    ModelError
        Unknown excitation or plant, a non-positive ``decay_rate_1_s``.
    MeasurementError
        Duration too short for the frequency resolution.
    SimulationError
        The plant diverged (the message says when; the partial recording is kept).
    """
    test, acts, exc_point = _test_of(fe)
    res_hz = cfg.resolution_hz or test.resolution_hz
    record_s = 1.0 / res_hz
    n_settle = settle_records(decay_rate_1_s, record_s)
    duration = cfg.duration_s if cfg.duration_s is not None else (n_settle + cfg.periods - 1) * record_s
    if duration < 2 * record_s - 1e-9:
        raise MeasurementError(
            f"duration {duration:g} s is too short for a {res_hz:g} Hz resolution: it needs one record of "
            f"{record_s:g} s to settle and at least one to measure ({2 * record_s:g} s); "
            "raise --duration or coarsen the resolution"
        )
    warnings = []
    n_records = int(np.floor(duration / record_s + 1e-9))
    if n_settle > n_records - 1:
        left = float(np.exp(-decay_rate_1_s * (n_records - 1) * record_s))
        warnings.append(
            f"the run of {duration:g} s settles only {(n_records - 1) * record_s:g} s before the last record; the "
            f"slowest mode decays at {decay_rate_1_s:.4g} 1/s, so {100 * left:.0f} % of its start-up transient is "
            f"left when the measured record starts: its FRF and peak level may be off by up to about that; a run "
            f"of at least {(n_settle + 1) * record_s:g} s settles to {100 * SETTLE_TOLERANCE:g} %")
        n_settle = n_records - 1
    plant, info = plant if plant is not None else make_plant(cfg, fe, acts)
    info = {**info, "actuators": acts}
    engine = None
    if design is not None:
        engine = ControllerEngine(design.f11, design.f12, design.f21, design.f22, period_s=cfg.chain.period_s)
    meas = tuple(dict.fromkeys((measured_points or test.measured_points) + acts))
    if shape_points is None:
        shape_points = tuple(p for p in fe.spec.points if (p, "w") in fe.dofs)  # supports stay at rest
    loop = run_loop(
        plant, engine, feedback_points=acts, measured_points=meas, excitation_point=exc_point,
        excitation=_excitation(cfg, test, res_hz, duration), duration_s=duration, chain=cfg.chain,
        seed=cfg.seed, progress=progress, shape_points=shape_points,
        metadata=metadata if metadata is not None else {
            "structure": fe.spec.name, "controller": cfg.controller, "reduction": cfg.reduction,
            "excitation": cfg.excitation, "seed": cfg.seed, "plant": info.get("kind", ""),
            "chain": {"delay_periods": cfg.chain.delay_periods, "filter_hz": cfg.chain.filter_hz,
                      "amplifier_gain": cfg.chain.amplifier_gain,
                      "amplifier_limit_n": cfg.chain.amplifier_limit_n}},
    )
    rec = loop.recording
    skip = int(round(n_settle * record_s / rec.dt_s))
    x = np.asarray(rec[f"force{exc_point}"])[skip:]
    window = "boxcar"  # every excitation is periodic over one record (_excitation)
    frfs = {}
    for p in meas:
        frfs[f"vel{p}"] = h1(x, np.asarray(rec[f"vel{p}"])[skip:], dt_s=rec.dt_s, resolution_hz=res_hz,
                             window=window, f_max_hz=test.band_hz[1], input_name=f"force{exc_point}",
                             output_name=f"vel{p}", input_point=exc_point,
                             output_point=p).band(*test.band_hz)  # only the excited lines
    resp = frfs[f"vel{test.response_point}"]
    f, h = resp.freq_hz, resp.h
    if test.response_quantity == "displacement":
        h = h / (2j * np.pi * f)
    return Measurement(replace(cfg, duration_s=duration, resolution_hz=res_hz), loop, frfs, f, h, info, skip,
                       tuple(warnings))


def run_experiment(
    cfg: ExperimentConfig,
    fe: FEModel,
    *,
    design=None,
    progress: Callable[[float], None] | None = None,
) -> ExperimentResult:
    """Run one experiment (:func:`measure`) and compare it with the analysis.

    Parameters
    ----------
    cfg : ExperimentConfig
        Settings of the experiment.
    fe : FEModel
        The nominal FE model (analysis and controller design).
    design : ControllerDesign, optional
        A design to use; by default designed here with the thesis settings
        (:func:`vlab.design.design_controller`); None with ``cfg.controller ==
        "none"`` runs open loop.
    progress : callable, optional
        Receives the fraction of the run done.

    Returns
    -------
    ExperimentResult

    Raises
    ------
    ModelError
        Unknown controller, LQR requested (needs the full state), a given
        ``design`` realised at another period than ``cfg.chain.period_s``;
        and as :func:`measure`.
    MeasurementError, SimulationError
        As :func:`measure`.
    """
    test, acts, exc_point = _test_of(fe)
    if cfg.controller == "lqr":
        raise ModelError("LQR needs every state measured; the laboratory ran it as LQG (use --controller lqg)")
    if design is None and cfg.controller != "none":
        from ..design import design_controller

        design = design_controller(fe, cfg.controller, model=cfg.reduction, seed=cfg.seed,
                                   period_s=cfg.chain.period_s)
    check_design_period(design, cfg.chain)
    c = structural_damping(fe)
    u = fe.force_input(acts)
    fm, zm = _predicted_modes(fe, design)
    m = measure(cfg, fe, design, progress=progress, decay_rate_1_s=slowest_decay_rate(fe, design))
    f = m.freq_hz
    g = velocity_frf(fe.m, c, fe.k, u, fe.force_input(acts + (test.response_point,)).T, f)
    g_fb, g_out = g[:, : len(acts), :], g[:, len(acts):, :]
    ex = acts.index(exc_point)
    chain = cfg.chain
    if design is None:
        k_cont = np.zeros((len(f), len(acts), len(acts)), dtype=complex)
        k_samp = k_cont
    else:
        k_cont = continuous_controller_frf(f, **design.continuous)
        k_samp = sampled_data_controller_frf(
            f, design.f11, design.f12, design.f21, design.f22, chain.period_s,
            delay_periods=chain.delay_periods, filter_hz=chain.filter_hz)
    h_cont = closed_loop_frf(g_fb, g_out, k_cont, ex)[:, 0]
    h_samp = closed_loop_frf(g_fb, g_out, k_samp, ex)[:, 0]
    if test.response_quantity == "displacement":
        iw = 2j * np.pi * f
        h_cont, h_samp = h_cont / iw, h_samp / iw
    modes = compare_modes(f, h_samp, m.measured, fm, zm, response=test.response_quantity)
    rec = m.loop.recording
    warnings = list(m.warnings) + under_resolved_peaks(fm, zm, m.config.resolution_hz) + self_excited_oscillation(np.asarray(rec[f"vel{test.response_point}"])[m.settle_samples:],
                                        rec.dt_s, band_hz=test.band_hz)
    for mc in modes:
        if not np.isfinite(mc.frequency_measured_hz) or not np.isfinite(mc.frequency_predicted_hz):
            warnings.append(f"mode {mc.mode} could not be identified (no resonance peak: overdamped or not "
                            f"observable at point {test.response_point})")
    return ExperimentResult(
        m.config, m.loop, m.frfs, f, h_cont, h_samp, m.measured, modes, average_error(modes), design,
        m.plant_info, tuple(warnings),
    )


def under_resolved_peaks(freq_hz, damping, resolution_hz: float, *, lines_per_bandwidth: float = 2.0) -> list[str]:
    """Warn about modes whose half-power bandwidth ``2 zeta f`` spans fewer than ``lines_per_bandwidth`` lines.

    Peak levels are read on the FRF lines (:func:`vlab.measure.modal.peak_levels`,
    Sec. 5.4.1). A peak narrower than the line spacing ``df`` may fall
    between lines: a line ``df / 2`` from the natural frequency shows only
    ``1 / sqrt(1 + (df / (2 zeta f))^2)`` of the peak (single mode near
    resonance). Analysis and experiment are read on the same lines, so their
    ratio is right when both peaks sit at the same frequency; a plant whose
    mode is shifted by a fraction of a line changes the measured level by up
    to that factor (the dissertation's explanation of its open-loop ratios,
    Sec. 6.1, Table 2).

    Parameters
    ----------
    freq_hz : array_like, shape (n_modes,)
        Predicted natural frequencies [Hz].
    damping : array_like, shape (n_modes,)
        Predicted damping ratios zeta [-].
    resolution_hz : float
        FRF line spacing ``df`` [Hz].
    lines_per_bandwidth : float
        Lines a half-power bandwidth should span to be resolved.

    Returns
    -------
    list of str
        Empty, or one message listing every under-resolved mode with its
        frequency, zeta, bandwidth and the worst-case level read on a line.

    Raises
    ------
    ModelError
        Shapes differ or a non-positive resolution.
    """
    f = np.asarray(freq_hz, dtype=float)
    z = np.asarray(damping, dtype=float)
    if f.shape != z.shape or f.ndim != 1:
        raise ModelError(f"freq_hz {f.shape} and damping {z.shape} must be equal 1-D shapes")
    if not resolution_hz > 0:
        raise ModelError(f"resolution_hz must be > 0, got {resolution_hz!r}")
    bw = 2 * z * f
    bad = [i for i in range(f.size) if np.isfinite(bw[i]) and 0 < bw[i] < lines_per_bandwidth * resolution_hz]
    if not bad:
        return []
    parts = []
    for i in bad:
        worst = 1.0 / np.sqrt(1.0 + (resolution_hz / bw[i]) ** 2)
        parts.append(f"mode {i + 1} ({f[i]:.2f} Hz, zeta {z[i]:.4f}, bandwidth {bw[i]:.3f} Hz: a line may read "
                     f"{100 * worst:.0f} % of the peak)")
    return [f"peaks narrower than {lines_per_bandwidth:g} lines of {resolution_hz:g} Hz: " + "; ".join(parts)
            + ". Analysis and experiment are read on the same lines; where the plant's mode is shifted by a fraction "
              "of a line the peak level ratio of that mode is biased by up to that factor: use a finer resolution"]


#: Phrase that marks a warning saying the run's FRF comparison cannot be used (see :func:`not_meaningful`).
NOT_MEANINGFUL = "the FRF comparison is not meaningful"


def not_meaningful(warnings) -> list[str]:
    """The warnings that say the run's FRF comparison is not meaningful.

    ``vlab experiment`` exits with status 1 when there is one, unless
    ``--allow-unstable``.

    Parameters
    ----------
    warnings : sequence of str
        Warnings of a run (:attr:`ExperimentResult.warnings`).

    Returns
    -------
    list of str
        Those containing :data:`NOT_MEANINGFUL` (a self-excited oscillation or limit cycle).
    """
    return [w for w in warnings if NOT_MEANINGFUL in w]


def self_excited_oscillation(v: np.ndarray, dt_s: float, *, band_hz: tuple[float, float]) -> list[str]:
    """Warn when most of the response lies outside the excitation band.

    A closed loop that destabilises a residual mode (spillover, Sec. 6.2.1) or
    runs into a limit cycle (Sec. 6.1: "a limit cycle at approximately 41 Hz")
    responds mostly at a frequency the excitation does not contain.

    Parameters
    ----------
    v : ndarray, shape (n,)
        Response velocity [m/s].
    dt_s : float
        Sampling interval [s].
    band_hz : (float, float)
        Excitation band [Hz].

    Returns
    -------
    list of str
        Empty, or one message naming the dominant frequency and its share of the RMS.
    """
    spec = np.abs(np.fft.rfft(v - np.mean(v))) ** 2
    f = np.fft.rfftfreq(len(v), dt_s)
    out = f > 1.2 * band_hz[1]
    total = spec.sum()
    if total <= 0 or spec[out].sum() < 0.5 * total:
        return []
    f_dom = f[out][np.argmax(spec[out])]
    share = np.sqrt(spec[out].sum() / total)
    return [
        f"self-excited oscillation at {f_dom:.1f} Hz ({100 * share:.0f} % of the response RMS lies above the "
        f"excitation band): the controller destabilises a mode outside its design model (spillover) or the "
        f"loop runs in a limit cycle; {NOT_MEANINGFUL}"
    ]
