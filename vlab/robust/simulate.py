"""Time simulation of chosen robustness samples on the batched MuJoCo lab: what the linear analysis cannot show.

The linearised sampled loop (:mod:`vlab.robust.sampled_loop`) gives damping,
stability and peak levels of the FE model. The laboratory measures a
different thing: H1 FRFs from noisy recordings of the MuJoCo plant (hinge
chain, gravity, geometric stiffness from the simulation itself, residual
modes above the design model's). For chosen samples of each controller this
module builds each perturbed plant from its perturbed spec (one MuJoCo model
per simulation, ``Batch.set_models``), runs them together with their own
delay, channel gains and noise seed (:func:`vlab.lab.batch.run_batch`) and
first asks whether the loop works on that plant, the way ``vlab experiment``
does:

* the run diverged (the plant blew up before the end), or
* :func:`vlab.measure.instability.find_instability` finds a self-excited
  line (a spectral line not caused by the force, far above the noise floor,
  with a steady or growing envelope), or
* :func:`vlab.experiment.checks.self_excited_oscillation` finds most of the
  response above the excitation band.

Such a sample is *unstable on the MuJoCo plant*: its H1 is not a
measurement of the controlled structure and its peak ratios are left out
(NaN). For the others H1 at the response point is compared, line by line
near each mode, with the linear prediction for the same sample (the model
error of the MuJoCo plant against the FE model) and with the nominal
prediction (the analysis/experiment ratio of Table 10 on this plant).

Source: the test of Sec. 5.4.2 (random excitation at point 9, response at
point 6 for the BCC); peak levels as in Table 10; the LQG limit cycle of
Sec. 6.1 ("a limit cycle at approximately 41 Hz").
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..fe.damping import open_loop_ratios
from ..fe import build_fe_model
from ..lab.batch import run_batch
from ..lab.engine import ControllerEngine
from ..lab.excitation import pseudo_random
from ..errors import SimulationError
from ..experiment.checks import self_excited_oscillation
from ..experiment.config import test_definition
from ..lab.loop import HardwareChain
from ..measure.frf import h1
from ..measure.instability import find_instability
from ..sim import MujocoPlant, SimOptions, build_plant
from ..sim.batch_plant import MujocoBatchPlant, layout
from .plant_loop import plant_loop_damping
from .sampled_loop import modal_plant, peak_windows, sampled_loop
from .study import PEAK_HALF_WIDTH, Nominal, StudyConfig, nominal_spec
from .uncertainty import apply_sample, draw_sample

#: Frequency resolution of the check [Hz]: records of 4 s (the full test's 0.05 Hz needs 20 s records).
CHECK_RESOLUTION_HZ = 0.25
#: Records run: one to settle, the rest measured.
CHECK_RECORDS = 3
#: Sensor noise of the check [m/s] (the lab's broadband pick-up, Sec. 5.1).
CHECK_NOISE_M_S = 1e-6


@dataclass(frozen=True)
class PlantVerdict:
    """Whether one time-simulated loop works on its plant.

    Attributes
    ----------
    diverged : bool
        The plant blew up before the end of the run.
    self_excited : bool
        A self-excited line or most of the response above the excitation band (module notes).
    unstable : bool
        ``diverged or self_excited``.
    frequency_hz : float
        The strongest self-excited line [Hz] (NaN when none).
    growth_rate_1_s : float
        Its fitted growth ``sigma`` of ``exp(sigma t)`` over the run's second half [1/s] (NaN when none).
    rise : float
        How much it grew since the run began [-] (NaN when none).
    power_above_band : float
        Share of the response's power (variance) above the excitation band, after settling [-].
    summary : str
        One sentence (:meth:`vlab.measure.instability.InstabilityCheck.summary` or the divergence).
    """

    diverged: bool
    self_excited: bool
    unstable: bool
    frequency_hz: float
    growth_rate_1_s: float
    rise: float
    power_above_band: float
    summary: str


def power_above_band(v: np.ndarray, dt_s: float, band_top_hz: float) -> float:
    """Share of the power of ``v`` (mean removed) above ``band_top_hz`` [-], from its periodogram.

    Parameters
    ----------
    v : ndarray, shape (n,)
        Response [any unit].
    dt_s : float
        Sampling interval [s].
    band_top_hz : float
        Top of the excitation band [Hz].

    Returns
    -------
    float
        In [0, 1]; 0 for a constant signal.
    """
    spec = np.abs(np.fft.rfft(v - np.mean(v))) ** 2
    total = float(spec.sum())
    return float(spec[np.fft.rfftfreq(len(v), dt_s) > band_top_hz].sum() / total) if total > 0 else 0.0


def judge_run(result, *, n_ticks: int, feedback_points, response_point: int, band_hz, settle_s: float
              ) -> PlantVerdict:
    """Whether a loop run is unstable on its plant (divergence, self-excitation; module notes).

    Parameters
    ----------
    result : LoopResult
        The run (:class:`vlab.lab.loop.LoopResult`); shorter than ``n_ticks`` when it diverged.
    n_ticks : int
        Ticks the run was asked for.
    feedback_points : sequence of int
        Collocated loop points.
    response_point : int
        Point whose ``vel<p>`` is tested for power above the band.
    band_hz : (float, float)
        Excitation band [Hz].
    settle_s : float
        Seconds left out of the spectra (start-up transient) [s].

    Returns
    -------
    PlantVerdict

    Raises
    ------
    MeasurementError
        From :func:`vlab.measure.instability.find_instability` (a run shorter than 256 samples after settling).
    """
    rec = result.recording
    nan = math.nan
    if rec.n_samples < n_ticks:
        return PlantVerdict(True, False, True, nan, nan, nan, nan,
                            f"diverged after {rec.n_samples * rec.dt_s:.2f} s of {n_ticks * rec.dt_s:.2f} s")
    skip = int(round(settle_s / rec.dt_s))
    v = np.asarray(rec[f"vel{response_point}"], dtype=float)[skip:]
    share = power_above_band(v, rec.dt_s, band_hz[1])
    check = find_instability(rec, feedback_points=tuple(feedback_points), skip_s=settle_s)
    above = self_excited_oscillation(v, rec.dt_s, band_hz=tuple(band_hz))
    if check.unstable:
        top = max([o for o in check.oscillations if o.point == check.loop_point] or list(check.oscillations),
                  key=lambda o: o.amplitude_m_s)
        return PlantVerdict(False, True, True, top.frequency_hz, top.growth_rate_1_s, top.rise, share,
                            check.summary())
    if above:
        spec = np.abs(np.fft.rfft(v - np.mean(v))) ** 2
        f = np.fft.rfftfreq(len(v), rec.dt_s)
        out = f > band_hz[1]
        return PlantVerdict(False, True, True, float(f[out][np.argmax(spec[out])]), nan, nan, share, above[0])
    return PlantVerdict(False, False, False, nan, nan, nan, share, check.summary())


def build_plants(spec0, specs) -> list:
    """The MuJoCo plants of ``specs``, each built as ``build_plant`` builds it with the physics step of ``spec0``'s.

    Parameters
    ----------
    spec0 : StructureSpec
        The nominal structure (its plant's step is used for every plant).
    specs : sequence of StructureSpec

    Returns
    -------
    list of vlab.sim.Plant

    Raises
    ------
    SimulationError, SpecError
        From :func:`vlab.sim.build_plant`.
    """
    opts = SimOptions(timestep_s=build_plant(spec0).timestep_s)
    return [build_plant(sp, opts) for sp in specs]


def run_cases(cfg: StudyConfig, nominal: Nominal, controller: str, specs, chains, seeds, *, seed: int = 0,
              nthread: int = 0, resolution_hz: float = CHECK_RESOLUTION_HZ, records: int = CHECK_RECORDS,
              plants=None):
    """Run ``controller`` on the MuJoCo plants of ``specs`` with ``chains``, batched by model layout.

    Parameters
    ----------
    cfg : StudyConfig
    nominal : Nominal
    controller : str
    specs : sequence of StructureSpec
        One plant each (built as ``build_plant`` builds it, with the nominal plant's physics step).
    chains : sequence of HardwareChain
        One each (period of the controller's thesis chain).
    seeds : sequence of int
        Sensor-noise seed of each run.
    seed : int
        Seed of the excitation (the test's pseudo-random force, period ``1 / resolution_hz``).
    nthread : int
        Threads of each batch (0: all CPUs).
    resolution_hz : float
        [Hz]; ``records`` periods run.
    records : int
    plants : list of vlab.sim.Plant, optional
        The plants of ``specs`` already built (:func:`build_plants`; default: built here).

    Returns
    -------
    results : list of LoopResult
        Order of ``specs``.
    excitation : ndarray, shape (n_ticks,)
        The force [N].
    verdicts : list of PlantVerdict
        :func:`judge_run` of each, the first record left out as settling.
    batches : int
        ``mujoco.batch`` runs (one per model layout).
    """
    spec0 = nominal_spec(cfg, nominal)
    test = test_definition(spec0)
    acts = nominal.actuators
    design, chain0 = nominal.designs[controller], nominal.chains[controller]
    plants = build_plants(spec0, specs) if plants is None else plants
    record_s = 1.0 / resolution_hz
    dur = records * record_s
    t = np.arange(int(round(dur / chain0.period_s))) * chain0.period_s
    exc = pseudo_random(t, band_hz=test.band_hz, resolution_hz=resolution_hz, rms_n=test.rms_n, seed=seed)
    eng = ControllerEngine(design.f11, design.f12, design.f21, design.f22, period_s=chain0.period_s)
    meas = tuple(dict.fromkeys(acts + (test.response_point,)))
    groups: dict = {}
    for row, plant in enumerate(plants):
        groups.setdefault(layout(plant.model), []).append(row)
    results = [None] * len(plants)
    for rows in groups.values():
        bp = MujocoBatchPlant(MujocoPlant(plants[rows[0]]), len(rows), nthread=nthread,
                              models=[plants[r].model for r in rows])
        out = run_batch(bp, eng, feedback_points=acts, measured_points=meas,
                        excitation_point=acts[nominal.excitation], excitation=exc, duration_s=dur,
                        chain=[chains[r] for r in rows], seeds=[int(seeds[r]) for r in rows])
        for g, r in enumerate(rows):
            results[r] = out.result(g, metadata={"structure": spec0.name, "controller": controller})
    verdicts = [judge_run(r, n_ticks=t.size, feedback_points=acts, response_point=test.response_point,
                          band_hz=test.band_hz, settle_s=record_s) for r in results]
    return results, exc, verdicts, len(groups)


def sample_chain(chain0: HardwareChain, sample, actuators) -> HardwareChain:
    """The controller's thesis chain with a sample's delay and channel gains, and the check's sensor noise.

    Parameters
    ----------
    chain0 : HardwareChain
        The controller's thesis chain (period [s], RC filter [Hz]).
    sample : Sample
        Of :func:`vlab.robust.uncertainty.draw_sample` (delay [periods], gains (n_act,) [-]).
    actuators : sequence of int
        Actuator points, the order of the sample's gains.

    Returns
    -------
    HardwareChain
        With :data:`CHECK_NOISE_M_S` [m/s] of sensor noise.
    """
    return HardwareChain(period_s=chain0.period_s, delay_periods=sample.delay_periods, filter_hz=chain0.filter_hz,
                         noise_m_s=CHECK_NOISE_M_S,
                         actuator_gain={p: float(g) for p, g in zip(actuators, sample.actuator_gain)},
                         sensor_gain={p: float(g) for p, g in zip(actuators, sample.sensor_gain)})


@dataclass(frozen=True)
class SimCheck:
    """Time-simulated samples of one controller on the MuJoCo plant, and its unperturbed plant.

    Attributes
    ----------
    controller : str
    indices : ndarray of int, shape (k,)
        Samples simulated (the worst first, then those drawn at random).
    worst, random : ndarray of bool, shape (k,)
        Chosen as among the worst by the linear measure / drawn at random from all samples (both may hold).
    predicted_unstable : ndarray of bool, shape (k,)
        The sample's sampled-data loop on its perturbed FE model is unstable.
    diverged, unstable_on_plant : ndarray of bool, shape (k,)
        The run blew up / the loop is unstable on the MuJoCo plant (:class:`PlantVerdict`).
    oscillation_hz, growth_rate_1_s, power_above_band : ndarray, shape (k,)
        Self-excited line [Hz] and its growth [1/s] (NaN when none), share of power above the band [-].
    summaries : tuple of str, length k
    peak_sim_over_linear : ndarray, shape (k, n_modes)
        Measured (H1) over the sample's linear prediction, same lines [-]; NaN where unstable on the plant.
    peak_analysis_over_experiment : ndarray, shape (k, n_modes)
        Nominal linear prediction over measured (H1) peak, same lines [-] (Table 10's ratio on this
        plant); NaN where unstable on the plant.
    recordings : tuple of LoopResult or None, length k
        The runs of the worst samples (``None`` for those only drawn at random), order of ``indices``.
    batches : int
        ``mujoco.batch`` runs it took: one per model layout among the plants.
    nominal : PlantVerdict
        The unperturbed plant with the thesis chain.
    nominal_recording : LoopResult
    damping_ratio : ndarray, shape (k, n_modes)
        Closed-loop damping ratio [-] of each compared mode on the sample's MuJoCo plant, from the sampled-data
        loop on its linearisation (:mod:`vlab.robust.plant_loop`); NaN where the run is unstable on the plant
        or a mode is not paired.
    linear_spectral_radius : ndarray, shape (k,)
        ``max |z|`` of that loop [-] (NaN where the plant could not be linearised).
    nominal_damping_ratio : ndarray, shape (n_modes,)
        The same for the unperturbed plant with the thesis chain [-].
    nominal_linear_spectral_radius : float
    """

    controller: str
    indices: np.ndarray
    worst: np.ndarray
    random: np.ndarray
    predicted_unstable: np.ndarray
    diverged: np.ndarray
    unstable_on_plant: np.ndarray
    oscillation_hz: np.ndarray
    growth_rate_1_s: np.ndarray
    power_above_band: np.ndarray
    summaries: tuple
    peak_sim_over_linear: np.ndarray
    peak_analysis_over_experiment: np.ndarray
    recordings: tuple
    batches: int
    nominal: PlantVerdict
    nominal_recording: object
    damping_ratio: np.ndarray | None = None
    linear_spectral_radius: np.ndarray | None = None
    nominal_damping_ratio: np.ndarray | None = None
    nominal_linear_spectral_radius: float = math.nan


def linear_error_db(res: dict, nominal: Nominal, controller: str) -> np.ndarray:
    """Each sample's mean over modes of |20 log10(analysis/experiment)| on the FE loop [dB].

    Parameters
    ----------
    res : dict
        Per-sample arrays of :func:`vlab.robust.study.run_study`.
    nominal : Nominal
    controller : str

    Returns
    -------
    ndarray, shape (n,)
        [dB]; inf for a sample whose FE loop is unstable (or has no peak).
    """
    err = np.abs(20 * np.log10(nominal.peaks[controller][None, :] / res[f"{controller}/peaks"])).mean(axis=1)
    return np.where(res[f"{controller}/spectral_radius"] >= 1.0, np.inf, np.nan_to_num(err, nan=np.inf))


def worst_samples(res: dict, nominal: Nominal, controller: str, k: int) -> np.ndarray:
    """The ``k`` samples furthest from the analysis: unstable ones first, then by mean |dB| peak-ratio error.

    Parameters
    ----------
    res, nominal, controller
        As :func:`linear_error_db`.
    k : int
        How many samples.

    Returns
    -------
    ndarray of int, shape (min(k, n),)
        Sample indices.
    """
    order = np.argsort(-linear_error_db(res, nominal, controller), kind="stable")[:k]
    return res["index"][order]


def choose_samples(res: dict, nominal: Nominal, controller: str, n_worst: int, n_random: int, *, seed: int):
    """Samples to simulate: the ``n_worst`` worst by the linear measure and ``n_random`` drawn at random.

    The random ones are a simple random sample (without replacement) of all
    samples, drawn from ``default_rng([seed, 7])``, the same for every
    controller: the share of them unstable on the MuJoCo plant estimates the
    probability there; the worst ones show the extremes and are not counted.

    Parameters
    ----------
    res : dict
    nominal : Nominal
    controller : str
    n_worst, n_random : int
        >= 0; each capped at the number of samples.
    seed : int

    Returns
    -------
    indices : ndarray of int, shape (k,)
        The worst first, then the random ones not among them.
    worst, random : ndarray of bool, shape (k,)
    """
    all_idx = np.asarray(res["index"], dtype=int)
    w = [int(i) for i in worst_samples(res, nominal, controller, n_worst)]
    rng = np.random.default_rng([int(seed), 7])
    r = sorted(int(i) for i in rng.choice(all_idx, size=min(n_random, all_idx.size), replace=False))
    idx = w + [i for i in r if i not in w]
    return (np.asarray(idx, dtype=int), np.array([i in w for i in idx], dtype=bool),
            np.array([i in r for i in idx], dtype=bool))


def _peak_ratios(cfg, nominal, controller, loop, rec, exc, skip, resolution_hz, nominal_loop):
    """(measured/linear, nominal linear/measured) peak ratios near each mode, shapes (n_modes,) each."""
    test = test_definition(nominal_spec(cfg, nominal))
    frf = h1(exc[skip:], rec[f"vel{test.response_point}"][skip:], dt_s=nominal.chains[controller].period_s,
             resolution_hz=resolution_hz, window="boxcar", f_max_hz=test.band_hz[1]).band(*test.band_hz)
    lin, nom = loop.frf(frf.freq_hz), nominal_loop.frf(frf.freq_hz)
    a = np.full(nominal.n_modes, np.nan)
    b = np.full(nominal.n_modes, np.nan)
    for r, (lo, hi) in enumerate(zip(*peak_windows(nominal.freq_hz[controller], PEAK_HALF_WIDTH))):
        w = (frf.freq_hz >= lo) & (frf.freq_hz <= hi)
        if w.any():
            meas = np.max(np.abs(frf.h[w]))
            a[r], b[r] = meas / np.max(np.abs(lin[w])), np.max(np.abs(nom[w])) / meas
    return a, b


def _linear_loop(spec, nominal: Nominal, controller: str, response_point: int, *, delay_periods, actuator_gain,
                 sensor_gain):
    """The sampled-data loop of ``controller`` on the FE model of ``spec`` with the given chain values."""
    fe = build_fe_model(spec)
    acts, chain0 = nominal.actuators, nominal.chains[controller]
    plant = modal_plant(fe.m, fe.k, open_loop_ratios(fe.spec, fe.n), fe.force_input(acts),
                        fe.force_input((response_point,))[:, 0])
    return sampled_loop(plant, nominal.designs[controller], period_s=chain0.period_s, delay_periods=delay_periods,
                        filter_hz=chain0.filter_hz, actuator_gain=actuator_gain, sensor_gain=sensor_gain,
                        excitation=nominal.excitation)


def simulate_samples(cfg: StudyConfig, nominal: Nominal, controller: str, indices, *, worst=None, random=None,
                     seed: int = 0,
                     nthread: int = 0, resolution_hz: float = CHECK_RESOLUTION_HZ,
                     records: int = CHECK_RECORDS) -> SimCheck:
    """Run samples ``indices`` of ``controller`` and its unperturbed plant on the batched MuJoCo lab.

    The excitation is the test's pseudo-random force (band and RMS of
    Sec. 5.4.2) with period ``1 / resolution_hz`` [Hz]; ``records`` periods
    run, the first settles, H1 and the instability check take the rest
    (module notes).

    Parameters
    ----------
    cfg : StudyConfig
    nominal : Nominal
    controller : str
    indices : sequence of int
        Samples to run (one simulation each).
    worst, random : sequence of bool, optional
        Which of ``indices`` were chosen as the worst / drawn at random (:func:`choose_samples`); default:
        all worst, none random. Only the worst ones keep their recordings.
    seed : int
        Seed of the excitation (sample i's noise: ``seed + 1 + i``; the unperturbed plant's: ``seed``).
    nthread : int
        Threads of the batch (0: all CPUs).
    resolution_hz : float
    records : int

    Returns
    -------
    SimCheck

    Notes
    -----
    Each perturbed plant is built from its spec with the nominal plant's
    physics step and otherwise as ``build_plant`` builds it; its
    discretisation can then differ from the nominal one (the grid's
    shear-flexible top-beam segments get one link or several by their
    ``12 EI / (kGA L^2)``, which the bending stiffness moves). Plants that
    share a layout run as one batch; each layout gets its own.
    """
    spec0, acts = nominal_spec(cfg, nominal), nominal.actuators
    idx = np.asarray(indices, dtype=int)
    wst = np.ones(idx.size, dtype=bool) if worst is None else np.asarray(worst, dtype=bool)
    rnd = np.zeros(idx.size, dtype=bool) if random is None else np.asarray(random, dtype=bool)
    chain0 = nominal.chains[controller]
    samples = [draw_sample(spec0, cfg.uncertainties, seed=cfg.seed, index=int(i), n_act=len(acts),
                           nominal_delay_periods=chain0.delay_periods) for i in idx]
    specs = [apply_sample(spec0, s) for s in samples] + [spec0]
    chains = [sample_chain(chain0, s, acts) for s in samples]
    chains.append(HardwareChain(period_s=chain0.period_s, delay_periods=chain0.delay_periods,
                                filter_hz=chain0.filter_hz, noise_m_s=CHECK_NOISE_M_S))
    seeds = [seed + 1 + int(i) for i in idx] + [seed]
    plants = build_plants(spec0, specs)
    results, exc, verdicts, batches = run_cases(cfg, nominal, controller, specs, chains, seeds, seed=seed,
                                                nthread=nthread, resolution_hz=resolution_hz, records=records,
                                                plants=plants)
    resp = nominal.response_point
    ones = np.ones(len(acts))
    nominal_loop = _linear_loop(spec0, nominal, controller, resp, delay_periods=chain0.delay_periods,
                                actuator_gain=ones, sensor_gain=ones)
    skip = int(round(1.0 / resolution_hz / chain0.period_s))
    k, nm = idx.size, nominal.n_modes
    sim_lin, ana_exp = np.full((k, nm), np.nan), np.full((k, nm), np.nan)
    predicted = np.zeros(k, dtype=bool)
    for row, (s, sp) in enumerate(zip(samples, specs)):
        loop = _linear_loop(sp, nominal, controller, resp, delay_periods=s.delay_periods,
                            actuator_gain=s.actuator_gain, sensor_gain=s.sensor_gain)
        predicted[row] = loop.spectral_radius >= 1.0
        if not verdicts[row].unstable:
            sim_lin[row], ana_exp[row] = _peak_ratios(cfg, nominal, controller, loop, results[row].recording, exc,
                                                      skip, resolution_hz, nominal_loop)
    damp, rho = _plant_damping(nominal, controller, plants, samples + [None], verdicts)
    v = verdicts[:k]
    return SimCheck(controller, idx, wst, rnd, predicted, np.array([x.diverged for x in v], dtype=bool),
                    np.array([x.unstable for x in v], dtype=bool), np.array([x.frequency_hz for x in v]),
                    np.array([x.growth_rate_1_s for x in v]), np.array([x.power_above_band for x in v]),
                    tuple(x.summary for x in v), sim_lin, ana_exp,
                    tuple(r if w else None for r, w in zip(results[:k], wst)), batches, verdicts[k], results[k],
                    damp[:k], rho[:k], damp[k], float(rho[k]))


def _plant_damping(nominal: Nominal, controller: str, plants, samples, verdicts):
    """Closed-loop damping (shape (len(plants), n_modes) [-]) and spectral radius (shape (len(plants),) [-]) of
    ``controller`` on each plant's linearisation (:func:`vlab.robust.plant_loop.plant_loop_damping`) with its
    sample's chain (None: the thesis chain); damping NaN where the run was unstable on the plant."""
    n_act = len(nominal.actuators)
    damp = np.full((len(plants), nominal.n_modes), np.nan)
    rho = np.full(len(plants), np.nan)
    for row, (plant, s, verdict) in enumerate(zip(plants, samples, verdicts)):
        ones = np.ones(n_act)
        try:
            pl = plant_loop_damping(plant, nominal, controller,
                                    delay_periods=nominal.chains[controller].delay_periods if s is None
                                    else s.delay_periods, actuator_gain=ones if s is None else s.actuator_gain,
                                    sensor_gain=ones if s is None else s.sensor_gain)
        except SimulationError:
            continue
        rho[row] = pl.spectral_radius
        if not verdict.unstable:
            damp[row] = pl.damping_ratio
    return damp, rho
