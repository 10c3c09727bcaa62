"""A closed-loop experiment in the virtual laboratory (Chapter 5, Sec. 6.1).

``run_experiment`` designs the controller on the nominal model, builds the
plant (MuJoCo from the same spec, an exported/edited MJCF, or the linear FE
model), runs the digital loop (2 kHz; LQG 1 kHz) with the hardware chain of Sec. 5.3,
excites it the way Sec. 5.4 describes, measures H1 FRFs and compares them
mode by mode with the analysis: the continuous closed-loop FRF the
dissertation computed and the sampled-data FRF with hold, delay and filter.
From the H1 FRFs of all measured points it identifies the mode shapes at those
points and compares them with the FE model's by the MAC (:mod:`vlab.measure.shapes`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Callable

import numpy as np

from ..analysis import (
    closed_loop_frf,
    continuous_controller_frf,
    sampled_data_controller_frf,
    velocity_frf,
)
from ..errors import MeasurementError, ModelError
from ..fe import FEModel
from ..fe.damping import structural_damping
from ..io.frf import FRF
from ..io.recording import Recording
from ..lab.engine import ControllerEngine
from ..lab.excitation import periodic_chirp, pseudo_random, pulse_train
from ..lab.chain_frf import chain_closed_loop_frf, sensor_path
from ..lab.linear_plant import LinearPlant
from ..lab.loop import LoopResult, check_design_period, run_loop
from ..measure.compare import ModeComparison, average_error, compare_modes
from ..measure.frf import h1
from ..measure.shapes import IdentifiedShapes, ShapeComparison, compare_shapes, identify_shapes
from ..spec import StructureTest, input_gains
from .checks import oscillation_above_band, self_excited_oscillation, under_resolved_peaks
from .config import EXCITATIONS, ExperimentConfig, test_definition, test_of, with_hardware
from .settling import SETTLE_TOLERANCE, predicted_modes, settle_records, slowest_decay_rate


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
        oscillation, modes not identified); see :func:`~vlab.experiment.checks.not_meaningful`.
    shapes : IdentifiedShapes or None
        Mode shapes identified from the H1 FRFs of all measured points
        (:func:`vlab.measure.shapes.identify_shapes`; closed-loop shapes when a controller runs); None when
        no mode was found.
    shape_comparison : ShapeComparison or None
        ``shapes`` against the FE model's normal modes in the band at the same points (MAC matrix, modes
        paired by MAC, frequency and damping; :func:`vlab.measure.shapes.compare_shapes`).
    model_shapes : ndarray, shape (n_points, n_model) or None
        The FE model's mass-normalised shapes ``w`` at ``shapes.point_ids`` [1/sqrt(kg)], its modes up to
        the band's upper edge.
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
    shapes: IdentifiedShapes | None = None
    shape_comparison: ShapeComparison | None = None
    model_shapes: np.ndarray | None = None


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
        (:func:`vlab.sim.contract.check_plant_contract`: its ``coil<ID>`` /
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
        return LinearPlant(fe.m, c, fe.k, point_index=pidx, actuator_points=actuators, timestep_s=h,
                           input_gain=input_gains(fe.spec, actuators)), {
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
    discarded (:func:`~vlab.experiment.settling.settle_records`: enough for the slowest mode's start-up
    transient to decay to :data:`~vlab.experiment.settling.SETTLE_TOLERANCE`), the rest are analysed
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
        Structure without a test definition (:func:`~vlab.experiment.config.test_definition`).
    ModelError
        Unknown excitation or plant, a non-positive ``decay_rate_1_s``.
    MeasurementError
        Duration too short for the frequency resolution.
    SimulationError
        The plant diverged (the message says when; the partial recording is kept).
    """
    test, acts, exc_point = test_of(fe)
    cfg = replace(cfg, chain=with_hardware(cfg.chain, fe.spec))
    res_hz = cfg.resolution_hz or test.resolution_hz
    duration, n_settle, warnings = _run_length(cfg, res_hz, decay_rate_1_s)
    plant, info = plant if plant is not None else make_plant(cfg, fe, acts)
    info = {**info, "actuators": acts}
    warnings = list(warnings) + list(info.get("notes", ()))  # e.g. an MJCF's added masses given their weight
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
        metadata=metadata if metadata is not None else _metadata(cfg, fe.spec.name, info.get("kind", "")),
    )
    rec = loop.recording
    skip = int(round(n_settle * (1.0 / res_hz) / rec.dt_s))
    frfs = _velocity_frfs(rec, skip, exc_point, meas, test, res_hz)
    resp = frfs[f"vel{test.response_point}"]
    f, h = resp.freq_hz, resp.h
    if test.response_quantity == "displacement":
        h = h / (2j * np.pi * f)
    return Measurement(replace(cfg, duration_s=duration, resolution_hz=res_hz), loop, frfs, f, h, info, skip,
                       tuple(warnings))


def _run_length(cfg: ExperimentConfig, res_hz: float, decay_rate_1_s: float | None) -> tuple[float, int, list[str]]:
    """Run length [s], settling records and warnings of :func:`measure` (see there); MeasurementError if too short."""
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
    return duration, n_settle, warnings


def _metadata(cfg: ExperimentConfig, structure: str, plant_kind: str) -> dict:
    """The recording's default metadata: structure, controller, excitation, seed, plant and hardware chain."""
    return {
        "structure": structure, "controller": cfg.controller, "reduction": cfg.reduction,
        "excitation": cfg.excitation, "seed": cfg.seed, "plant": plant_kind,
        "chain": {"delay_periods": cfg.chain.delay_periods, "filter_hz": cfg.chain.filter_hz,
                  "amplifier_gain": cfg.chain.amplifier_gain,
                  "amplifier_limit_n": cfg.chain.amplifier_limit_n}}


def _velocity_frfs(rec: Recording, skip: int, exc_point: int, points: tuple[int, ...], test: StructureTest,
                   res_hz: float) -> dict[str, FRF]:
    """H1 velocity FRFs [(m/s)/N] of ``points`` after ``skip`` settling samples, on the test band's lines."""
    x = np.asarray(rec[f"force{exc_point}"])[skip:]
    window = "boxcar"  # every excitation is periodic over one record (_excitation)
    frfs = {}
    for p in points:
        frfs[f"vel{p}"] = h1(x, np.asarray(rec[f"vel{p}"])[skip:], dt_s=rec.dt_s, resolution_hz=res_hz,
                             window=window, f_max_hz=test.band_hz[1], input_name=f"force{exc_point}",
                             output_name=f"vel{p}", input_point=exc_point,
                             output_point=p).band(*test.band_hz)  # only the excited lines
    return frfs


def _predicted_frfs(chain, design, g_fb, g_out, acts, ex, f, response_point, step_s):
    """The continuous and the sampled-data closed-loop FRFs at the response point, shape (n_f,) each.

    The sampled-data one runs through the whole chain (:func:`vlab.lab.chain_frf.chain_closed_loop_frf`:
    gains, per-channel delays, lags, RC filter); at a response point that is a feedback sensor the
    recorded signal is that sensor's (its gain and lag, :func:`vlab.lab.chain_frf.sensor_path`).
    """
    if design is None:
        k_cont = np.zeros((len(f), len(acts), len(acts)), dtype=complex)
        k_core = None
    else:
        k_cont = continuous_controller_frf(f, **design.continuous)
        k_core = sampled_data_controller_frf(f, design.f11, design.f12, design.f21, design.f22, chain.period_s,
                                             delay_periods=0.0, filter_hz=None)
    h_cont = closed_loop_frf(g_fb, g_out, k_cont, ex)[:, 0]
    h_samp = chain_closed_loop_frf(g_fb, g_out, k_core, chain, acts, ex, f, step_s)[:, 0]
    if response_point in acts:
        h_samp = h_samp * sensor_path(chain, acts, f)[:, acts.index(response_point)]
    return h_cont, h_samp


def run_experiment(
    cfg: ExperimentConfig,
    fe: FEModel,
    *,
    design=None,
    progress: Callable[[float], None] | None = None,
    lab_chain=None,
    explain_oscillation: Callable[..., str] | None = None,
) -> ExperimentResult:
    """Run one experiment (:func:`measure`) and compare it with the analysis.

    The analysis uses ``cfg.chain`` with the structure file's ``[hardware]`` settings
    (:func:`~vlab.experiment.config.with_hardware`) and the coils' gains in the input matrix; the run uses
    ``lab_chain`` (default ``cfg.chain``) with the same settings where it sets none of its own.

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
    lab_chain : HardwareChain, optional
        The chain the lab really has where it differs from what the analysis knows (an effect concealed from
        the model, e.g. a sensor gain; its per-channel entries win over the structure file's); same period
        as ``cfg.chain``. None: ``cfg.chain``.
    explain_oscillation : callable, optional
        ``f(fe, design, chain, frequency_hz, mujoco_plant=...) -> str``: a sentence on the cause of a
        self-excited oscillation above the band, appended to its warning (the command line passes
        :func:`vlab.diagnose.instability_cause.oscillation_cause`, the loop analysed on the FE model and the
        plant's linearisation). None: the warning alone.

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
    test, acts, exc_point = test_of(fe)
    if cfg.controller == "lqr":
        raise ModelError("LQR needs every state measured; the laboratory ran it as LQG (use --controller lqg)")
    if design is None and cfg.controller != "none":
        from ..design import design_controller

        design = design_controller(fe, cfg.controller, model=cfg.reduction, seed=cfg.seed,
                                   period_s=cfg.chain.period_s)
    check_design_period(design, cfg.chain)
    cfg = replace(cfg, chain=with_hardware(cfg.chain, fe.spec))
    c = structural_damping(fe)
    u = fe.force_input(acts) * input_gains(fe.spec, acts)  # the coils' gains live in the plant (Eq. 3.1's U)
    fm, zm = predicted_modes(fe, design, cfg.chain)
    run_cfg = cfg if lab_chain is None else replace(cfg, chain=lab_chain)
    check_design_period(design, run_cfg.chain)
    m = measure(run_cfg, fe, design, progress=progress, decay_rate_1_s=slowest_decay_rate(fe, design))
    f = m.freq_hz
    g = velocity_frf(fe.m, c, fe.k, u, fe.force_input(acts + (test.response_point,)).T, f)
    g_fb, g_out = g[:, : len(acts), :], g[:, len(acts):, :]
    ex = acts.index(exc_point)
    h_cont, h_samp = _predicted_frfs(cfg.chain, design, g_fb, g_out, acts, ex, f, test.response_point,
                                     m.plant_info.get("timestep_s") or cfg.chain.period_s / 2)
    if test.response_quantity == "displacement":
        iw = 2j * np.pi * f
        h_cont, h_samp = h_cont / iw, h_samp / iw
    modes = compare_modes(f, h_samp, m.measured, fm, zm, response=test.response_quantity)
    rec = m.loop.recording
    v_resp = np.asarray(rec[f"vel{test.response_point}"])[m.settle_samples:]
    oscillation = self_excited_oscillation(v_resp, rec.dt_s, band_hz=test.band_hz)
    if oscillation and design is not None and explain_oscillation is not None:
        f_osc = oscillation_above_band(v_resp, rec.dt_s, band_hz=test.band_hz)[0]
        cause = explain_oscillation(fe, design, cfg.chain, f_osc,
                                    mujoco_plant=cfg.plant == "mujoco" and cfg.mjcf is None and lab_chain is None)
        if cause:
            oscillation = [oscillation[0] + "; " + cause]
    warnings = list(m.warnings) + under_resolved_peaks(fm, zm, m.config.resolution_hz) + oscillation
    for mc in modes:
        if not np.isfinite(mc.frequency_measured_hz) or not np.isfinite(mc.frequency_predicted_hz):
            warnings.append(f"mode {mc.mode} could not be identified (no resonance peak: overdamped or not "
                            f"observable at point {test.response_point})")
    shapes, comparison, phi = _shapes_of(m, fe, c, fm, zm, exc_point, test.band_hz, warnings)
    return ExperimentResult(
        m.config, m.loop, m.frfs, f, h_cont, h_samp, m.measured, modes, average_error(modes), design,
        m.plant_info, tuple(warnings), shapes, comparison, phi,
    )


def _shapes_of(m: Measurement, fe: FEModel, c: np.ndarray, fm, zm, exc_point: int, band_hz, warnings: list):
    """The shapes identified from the measured points' H1 FRFs (coherence-weighted), compared with the FE
    model's normal modes up to the band's upper edge at the same points (mass-normalised ``w``, damping
    ratios ``phi^T c phi / (2 omega)``): (IdentifiedShapes, ShapeComparison, model shapes) or three None,
    with a warning, when no mode is found."""
    from ..fe import modal_analysis

    points = tuple(int(k[3:]) for k in m.frfs)
    h = np.array([m.frfs[f"vel{p}"].h for p in points])
    coh = np.array([np.nan_to_num(m.frfs[f"vel{p}"].coherence, nan=0.0) for p in points])
    try:
        shapes = identify_shapes(m.freq_hz, h, points, fm, reference_point=exc_point, damping_hint=zm,
                                 response="velocity", weights=coh)
    except MeasurementError as exc:
        warnings.append(f"no mode shape identified ({exc})")
        return None, None, None
    modes = modal_analysis(fe.m, fe.k)
    keep = modes.frequencies_hz <= band_hz[1]
    phi = modes.shapes[:, keep]
    at = np.array([phi[fe.dofs.index(p, "w")] if (p, "w") in fe.dofs else np.zeros(phi.shape[1])
                   for p in points])  # a point without w (a support) does not move
    zeta = np.einsum("ir,ij,jr->r", phi, c, phi) / (4 * np.pi * modes.frequencies_hz[keep])
    return shapes, compare_shapes(shapes, at, modes.frequencies_hz[keep], zeta), at
