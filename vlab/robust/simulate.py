"""Time simulation of chosen robustness samples on the batched lab: what the linear analysis cannot show.

The linearised sampled loop (:mod:`vlab.robust.sampled_loop`) gives damping,
stability and peak levels of the FE model. The laboratory measures a
different thing: H1 FRFs from noisy recordings of the MuJoCo plant (hinge
chain, gravity, geometric stiffness from the simulation itself). For the
worst samples of each controller this module builds each perturbed plant
from its perturbed spec (one MuJoCo model per simulation,
``Batch.set_models``), runs them together with their own delay, channel gains
and noise seed (:func:`vlab.lab.batch.run_batch`), measures H1 at the
response point and compares it, line by line near each mode, with the
linear prediction for the same sample. A sample predicted unstable should
diverge.

Source: the test of Sec. 5.4.2 (random excitation at point 9, response at
point 6 for the BCC); peak levels as in Table 10.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..calibration import open_loop_ratios
from ..fe import build_fe_model
from ..lab.batch import run_batch
from ..lab.engine import ControllerEngine
from ..lab.excitation import pseudo_random
from ..lab.experiment import TESTS
from ..lab.loop import HardwareChain
from ..measure.frf import h1
from ..models import nominal_fe_model
from ..sim import MujocoPlant, SimOptions, build_plant
from ..sim.batch_plant import MujocoBatchPlant, layout
from .sampled_loop import modal_plant, peak_windows, sampled_loop
from .study import PEAK_HALF_WIDTH, Nominal, StudyConfig
from .uncertainty import apply_sample, draw_sample

#: Frequency resolution of the check [Hz]: records of 4 s (the full test's 0.05 Hz needs 20 s records).
CHECK_RESOLUTION_HZ = 0.25
#: Records run: one to settle, the rest measured.
CHECK_RECORDS = 3
#: Sensor noise of the check [m/s] (the lab's broadband pick-up, Sec. 5.1).
CHECK_NOISE_M_S = 1e-6


@dataclass(frozen=True)
class SimCheck:
    """Time-simulated samples of one controller.

    Attributes
    ----------
    controller : str
    indices : ndarray of int, shape (k,)
        Samples simulated (the worst first).
    predicted_unstable : ndarray of bool, shape (k,)
    diverged : ndarray of bool, shape (k,)
    peak_sim_over_linear : ndarray, shape (k, n_modes)
        Measured (H1) over linearly predicted peak level near each mode, same lines [-]; NaN where diverged.
    recordings : tuple of LoopResult, length k
        Each sample's run (:class:`vlab.lab.loop.LoopResult`, truncated where it diverged), order of ``indices``.
    batches : int
        ``mujoco.batch`` runs it took: one per model layout among the samples.
    """

    controller: str
    indices: np.ndarray
    predicted_unstable: np.ndarray
    diverged: np.ndarray
    peak_sim_over_linear: np.ndarray
    recordings: tuple
    batches: int


def worst_samples(res: dict, nominal: Nominal, controller: str, k: int) -> np.ndarray:
    """The ``k`` samples furthest from the analysis: unstable ones first, then by mean |dB| peak-ratio error.

    Parameters
    ----------
    res : dict
        Per-sample arrays of :func:`vlab.robust.study.run_study`.
    nominal : Nominal
    controller : str
    k : int

    Returns
    -------
    ndarray of int, shape (min(k, n),)
        Sample indices.
    """
    peaks = res[f"{controller}/peaks"]
    err = np.abs(20 * np.log10(nominal.peaks[controller][None, :] / peaks)).mean(axis=1)
    err = np.where(res[f"{controller}/spectral_radius"] >= 1.0, np.inf, np.nan_to_num(err, nan=np.inf))
    order = np.argsort(-err, kind="stable")[:k]
    return res["index"][order]


def simulate_samples(cfg: StudyConfig, nominal: Nominal, controller: str, indices, *, seed: int = 0,
                     nthread: int = 0, resolution_hz: float = CHECK_RESOLUTION_HZ,
                     records: int = CHECK_RECORDS) -> SimCheck:
    """Run samples ``indices`` of ``controller`` on the batched MuJoCo lab and compare with the linear loop.

    The excitation is the test's pseudo-random force (band and RMS of
    Sec. 5.4.2) with period ``1 / resolution_hz`` [Hz]; ``records`` periods
    run, the first settles, H1 is taken over the rest.

    Parameters
    ----------
    cfg : StudyConfig
    nominal : Nominal
    controller : str
    indices : sequence of int
        Samples to run (one simulation each).
    seed : int
        Seed of the excitation (sample i's noise: ``seed + 1 + i``).
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
    ``12 EI / (kGA L^2)``, which the bending stiffness moves). Samples whose
    models share a layout run as one batch; each layout gets its own.
    """
    fe0 = nominal_fe_model(cfg.structure)
    spec0 = fe0.spec
    test = TESTS[cfg.structure]
    acts = nominal.actuators
    design, chain0 = nominal.designs[controller], nominal.chains[controller]
    base = build_plant(spec0)
    opts = SimOptions(timestep_s=base.timestep_s)
    samples = [draw_sample(spec0, cfg.uncertainties, seed=cfg.seed, index=int(i), n_act=len(acts),
                           nominal_delay_periods=chain0.delay_periods) for i in indices]
    specs = [apply_sample(spec0, s) for s in samples]
    plants = [build_plant(sp, opts) for sp in specs]
    chains = [HardwareChain(period_s=chain0.period_s, delay_periods=s.delay_periods, filter_hz=chain0.filter_hz,
                            noise_m_s=CHECK_NOISE_M_S,
                            actuator_gain={p: float(g) for p, g in zip(acts, s.actuator_gain)},
                            sensor_gain={p: float(g) for p, g in zip(acts, s.sensor_gain)}) for s in samples]
    record_s = 1.0 / resolution_hz
    dur = records * record_s
    t = np.arange(int(round(dur / chain0.period_s))) * chain0.period_s
    exc = pseudo_random(t, band_hz=test.band_hz, resolution_hz=resolution_hz, rms_n=test.rms_n, seed=seed)
    eng = ControllerEngine(design.f11, design.f12, design.f21, design.f22, period_s=chain0.period_s)
    resp = test.response_point
    meas = tuple(dict.fromkeys(acts + (resp,)))
    groups: dict = {}
    for row, plant in enumerate(plants):
        groups.setdefault(layout(plant.model), []).append(row)
    results = [None] * len(samples)
    for rows in groups.values():
        bp = MujocoBatchPlant(MujocoPlant(plants[rows[0]]), len(rows), nthread=nthread,
                              models=[plants[r].model for r in rows])
        out = run_batch(bp, eng, feedback_points=acts, measured_points=meas,
                        excitation_point=acts[nominal.excitation], excitation=exc, duration_s=dur,
                        chain=[chains[r] for r in rows], seeds=[seed + 1 + int(indices[r]) for r in rows])
        for g, r in enumerate(rows):
            results[r] = out.result(g, metadata={"structure": cfg.structure, "controller": controller,
                                                 "sample": int(indices[r])})
    skip = int(round(record_s / chain0.period_s))
    ratios = np.full((len(samples), nominal.n_modes), np.nan)
    unstable = np.zeros(len(samples), dtype=bool)
    for row, (s, sp) in enumerate(zip(samples, specs)):
        fe = build_fe_model(sp)
        plant = modal_plant(fe.m, fe.k, open_loop_ratios(fe.spec, fe.n), fe.force_input(acts),
                            fe.force_input((resp,))[:, 0])
        loop = sampled_loop(plant, design, period_s=chain0.period_s, delay_periods=s.delay_periods,
                            filter_hz=chain0.filter_hz, actuator_gain=s.actuator_gain, sensor_gain=s.sensor_gain,
                            excitation=nominal.excitation)
        unstable[row] = loop.spectral_radius >= 1.0
        rec = results[row].recording
        if rec.n_samples < t.size:
            continue
        frf = h1(exc[skip:], rec[f"vel{resp}"][skip:], dt_s=chain0.period_s,
                 resolution_hz=resolution_hz, window="boxcar", f_max_hz=test.band_hz[1]).band(*test.band_hz)
        lin = loop.frf(frf.freq_hz)
        for r, (a, b) in enumerate(zip(*peak_windows(nominal.freq_hz[controller], PEAK_HALF_WIDTH))):
            w = (frf.freq_hz >= a) & (frf.freq_hz <= b)
            if w.any():
                ratios[row, r] = np.max(np.abs(frf.h[w])) / np.max(np.abs(lin[w]))
    diverged = np.array([r.recording.n_samples < t.size for r in results], dtype=bool)
    return SimCheck(controller, np.asarray(indices, dtype=int), unstable, diverged, ratios, tuple(results),
                    len(groups))
