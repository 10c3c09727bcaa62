"""Monte Carlo robustness study of the controllers designed on the nominal model (Sec. 7).

Every controller (MFDRF, LQDRF, LQDRF-diag, LQG) is designed once on the
nominal FE model with the thesis settings (:func:`vlab.design.design_controller`)
and realised at its thesis period (LQG 1 ms, DRF 0.5 ms). Each sample
perturbs the structure and the hardware chain (:mod:`vlab.robust.uncertainty`),
rebuilds the FE model, and evaluates every controller on it with the exact
sampled-data loop (:mod:`vlab.robust.sampled_loop`):

* closed-loop damping ratio and frequency of each compared mode;
* stability (``max |z| < 1``) -> probability of instability;
* peak levels of the response FRF near each mode (each model's peak searched
  around its own closed-loop frequency, as a modal test identifies it), and
  the ratio analysis/experiment (nominal prediction over the perturbed
  "laboratory"), as Table 10 lists them;
* an energy performance index ``J`` and its ratio to the nominal one.

These are properties of the linearised loop and need no time simulation.
What does (nonlinear MuJoCo plant, noise, measured H1 FRFs) is checked on the
worst samples with the batched lab (:mod:`vlab.robust.simulate`).

Samples are evaluated in chunks; the chunks are independent and run in this
process or on Dask (``scheduler``), with identical results either way (each
sample draws from its own seeded generator and the arithmetic does not depend
on where it runs).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field

import numpy as np

from ..fe.damping import open_loop_ratios
from ..errors import OptionError
from ..fe import build_fe_model
from ..experiment.config import default_chain, dissertation_structure, test_definition
from ..models import check_fe_model, nominal_fe_model
from ..spec import StructureSpec, load_spec
from .sampled_loop import mode_damping, modal_plant, peak_levels, sampled_loop
from .uncertainty import DEFAULTS, apply_sample, draw_sample

#: The controllers compared (Sec. 7), in the order of the report.
CONTROLLERS = ("mfdrf", "lqdrf", "lqdrf-diag", "lqg")
#: Names of the controllers as the dissertation writes them.
LABELS = {"mfdrf": "MFDRF", "lqdrf": "LQDRF", "lqdrf-diag": "LQDRF-diag", "lqg": "LQG"}
#: Half-width of the window searched for each mode's peak, relative to its nominal closed-loop frequency.
PEAK_HALF_WIDTH = 0.1


@dataclass(frozen=True)
class StudyConfig:
    """Settings of a study.

    Attributes
    ----------
    structure : str
        ``"bcc"``, ``"grid"`` or the path of a structure file (TOML) with a ``[test]`` table and
        ``[instrumentation]``.
    n_samples : int
        Monte Carlo samples (>= 1).
    seed : int
        Seed of the draws (and of the DRF designs' multi-start).
    controllers : tuple of str
        Subset of :data:`CONTROLLERS`.
    uncertainties : tuple of Uncertainty
        Distributions (default :data:`vlab.robust.uncertainty.DEFAULTS`).
    chunk_size : int
        Samples per independent chunk.
    """

    structure: str = "bcc"
    n_samples: int = 1000
    seed: int = 0
    controllers: tuple[str, ...] = CONTROLLERS
    uncertainties: tuple = DEFAULTS
    chunk_size: int = 25

    def __post_init__(self) -> None:
        if not isinstance(self.structure, str) or not self.structure:
            raise OptionError(f"structure {self.structure!r}: give bcc, grid or the path of a structure file")
        if isinstance(self.n_samples, bool) or int(self.n_samples) != self.n_samples or self.n_samples < 1:
            raise OptionError(f"--samples must be a positive integer, got {self.n_samples!r}")
        if isinstance(self.chunk_size, bool) or int(self.chunk_size) != self.chunk_size or self.chunk_size < 1:
            raise OptionError(f"--chunk-size must be a positive integer, got {self.chunk_size!r}")
        bad = [c for c in self.controllers if c not in CONTROLLERS]
        if bad or not self.controllers:
            raise OptionError(f"--controllers {', '.join(bad) or '(none)'}: use some of {', '.join(CONTROLLERS)}")


@dataclass(frozen=True)
class Nominal:
    """What the chunks need: the designs and the nominal analysis (pickled to Dask workers).

    Attributes
    ----------
    designs : dict of str to ControllerDesign
    chains : dict of str to HardwareChain
        Each controller's thesis chain (period, delay 1.35, RC 677 Hz).
    zeta, freq_hz, peaks, energy_j_s : dict of str to ndarray / float
        Nominal sampled-loop damping [-], frequency [Hz], peak levels
        [m/N or (m/s)/N] per mode, energy index [J*s].
    n_modes : int
    actuators : tuple of int
    excitation : int
        Channel index of the excitation.
    response_point : int
    displacement : bool
        Whether the compared FRF is displacement (BCC) or velocity (grid).
    spectral_radius : dict of str to float
        Nominal sampled loop's ``max |z|`` [-] (< 1: a working loop on the nominal FE model).
    spec : StructureSpec or None
        The nominal structure (carried to the workers, so that a structure file need not be readable there).
    """

    designs: dict
    chains: dict
    zeta: dict
    freq_hz: dict
    peaks: dict
    energy_j_s: dict
    n_modes: int
    actuators: tuple
    excitation: int
    response_point: int
    displacement: bool
    spectral_radius: dict = field(default_factory=dict)
    spec: StructureSpec | None = None


def study_spec(cfg: StudyConfig) -> StructureSpec:
    """The nominal structure of the study ``cfg``: a shipped one by name, or a structure file.

    Raises
    ------
    SpecError
        An unknown name, an unreadable or invalid file, or a structure without a modal test (no ``[test]``
        table; :func:`vlab.experiment.config.test_definition` names the fields), without actuators, or with
        a ``[hardware]`` table (not modelled by the study).
    """
    spec = load_spec(cfg.structure)
    test_definition(spec)
    if not spec.instrumentation.actuators:
        from ..errors import SpecError

        raise SpecError(f"{spec._file()}: [instrumentation] actuators is empty; the robustness study needs the "
                        "controllers' actuator/sensor channels")
    if spec.hardware is not None:
        from ..errors import SpecError

        raise SpecError(f"{spec._file()}: [hardware]: the robustness study perturbs the default hardware chain and "
                        "does not model a structure file's own channel gains, delays and lags; remove the table "
                        "for the study (its values can be given as --uncertainty spreads)")
    return spec


def is_dissertation(cfg: StudyConfig) -> bool:
    """Whether the study is on one of the dissertation's structures (its tables and sections are compared).

    Parameters
    ----------
    cfg : StudyConfig
        Its ``structure`` (:func:`vlab.experiment.config.dissertation_structure`).
    """
    return dissertation_structure(cfg.structure)


def _evaluate(fe, design, chain, nominal: Nominal, *, delay_periods, actuator_gain, sensor_gain, centres):
    """Damping, frequency, spectral radius, energy index and peaks of one controller on one FE model."""
    acts = nominal.actuators
    plant = modal_plant(fe.m, fe.k, open_loop_ratios(fe.spec, fe.n), fe.force_input(acts),
                        fe.force_input((nominal.response_point,))[:, 0])
    loop = sampled_loop(plant, design, period_s=chain.period_s, delay_periods=delay_periods,
                        filter_hz=chain.filter_hz, actuator_gain=actuator_gain, sensor_gain=sensor_gain,
                        excitation=nominal.excitation)
    zeta, freq = mode_damping(loop, plant, design, nominal.n_modes, actuator_gain=actuator_gain,
                              sensor_gain=sensor_gain)
    centres = freq if centres is None else centres
    peaks = peak_levels(loop, centres, half_width=PEAK_HALF_WIDTH, displacement=nominal.displacement)
    return zeta, freq, loop.spectral_radius, loop.energy_index(nominal.n_modes), peaks


def nominal_analysis(cfg: StudyConfig) -> Nominal:
    """Design the controllers on the nominal model and analyse their nominal sampled loops.

    Parameters
    ----------
    cfg : StudyConfig
        Its structure, controllers and seed (of the DRF multi-start).

    Returns
    -------
    Nominal

    Raises
    ------
    ModelError, controllers.errors.ControllerError
        From the designs.
    """
    from ..design import design_controller

    spec = study_spec(cfg)
    fe = nominal_fe_model(cfg.structure) if is_dissertation(cfg) else check_fe_model(build_fe_model(spec))
    test = test_definition(spec)
    acts = tuple(fe.spec.instrumentation.actuators)
    exc = acts.index(fe.spec.instrumentation.excitation)
    designs, chains = {}, {}
    base = Nominal({}, {}, {}, {}, {}, {}, test.n_modes, acts, exc, test.response_point,
                   test.response_quantity == "displacement")
    out = {k: {} for k in ("zeta", "freq_hz", "peaks", "energy_j_s", "rho")}
    ones = np.ones(len(acts))
    for c in cfg.controllers:
        chain = default_chain(c)
        d = design_controller(fe, c, seed=cfg.seed, period_s=chain.period_s)
        designs[c], chains[c] = d, chain
        z, f, rho, j, pk = _evaluate(fe, d, chain, base, delay_periods=chain.delay_periods, actuator_gain=ones,
                                     sensor_gain=ones, centres=None)
        out["zeta"][c], out["freq_hz"][c], out["peaks"][c], out["energy_j_s"][c] = z, f, pk, j
        out["rho"][c] = float(rho)
    return Nominal(designs, chains, out["zeta"], out["freq_hz"], out["peaks"], out["energy_j_s"], test.n_modes,
                   acts, exc, test.response_point, test.response_quantity == "displacement", out["rho"], fe.spec)


def run_chunk(cfg: StudyConfig, nominal: Nominal, indices) -> dict:
    """Evaluate samples ``indices`` for every controller; a pure function of its arguments.

    Parameters
    ----------
    cfg : StudyConfig
    nominal : Nominal
        From :func:`nominal_analysis`.
    indices : iterable of int
        Sample numbers.

    Returns
    -------
    dict
        ``"index"`` (n,), and per controller ``c``: ``f"{c}/zeta"`` (n, n_modes) [-],
        ``f"{c}/freq_hz"`` (n, n_modes), ``f"{c}/spectral_radius"`` (n,),
        ``f"{c}/energy_j_s"`` (n,) [J*s], ``f"{c}/peaks"`` (n, n_modes); and
        ``"delay_periods"`` (n,).
    """
    spec0 = nominal_spec(cfg, nominal)
    n_act = len(nominal.actuators)
    idx = np.asarray(list(indices), dtype=int)
    n, nm = idx.size, nominal.n_modes
    out = {"index": idx, "delay_periods": np.empty(n)}
    for c in cfg.controllers:
        out.update({f"{c}/zeta": np.empty((n, nm)), f"{c}/freq_hz": np.empty((n, nm)),
                    f"{c}/spectral_radius": np.empty(n), f"{c}/energy_j_s": np.empty(n),
                    f"{c}/peaks": np.empty((n, nm))})
    for row, i in enumerate(idx):
        s = draw_sample(spec0, cfg.uncertainties, seed=cfg.seed, index=int(i), n_act=n_act,
                        nominal_delay_periods=default_chain("mfdrf").delay_periods)
        fe = build_fe_model(apply_sample(spec0, s))
        out["delay_periods"][row] = s.delay_periods
        for c in cfg.controllers:
            z, f, rho, j, pk = _evaluate(fe, nominal.designs[c], nominal.chains[c], nominal,
                                         delay_periods=s.delay_periods, actuator_gain=s.actuator_gain,
                                         sensor_gain=s.sensor_gain, centres=None)
            out[f"{c}/zeta"][row], out[f"{c}/freq_hz"][row] = z, f
            out[f"{c}/spectral_radius"][row], out[f"{c}/energy_j_s"][row] = rho, j
            out[f"{c}/peaks"][row] = pk
    return out


def nominal_spec(cfg: StudyConfig, nominal: Nominal) -> StructureSpec:
    """The study's nominal structure: the one the nominal analysis carries, else loaded (:func:`study_spec`).

    Parameters
    ----------
    cfg : StudyConfig
    nominal : Nominal
        Of :func:`nominal_analysis` (its ``spec``).

    Raises
    ------
    SpecError
        As :func:`study_spec`, where ``nominal`` carries no spec.
    """
    return nominal.spec if nominal.spec is not None else study_spec(cfg)


def _merge(parts: list[dict]) -> dict:
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}


def default_workers() -> int:
    """Worker processes of the default LocalCluster: one per CPU (``os.cpu_count()``)."""
    return os.cpu_count() or 1


def run_study(cfg: StudyConfig, *, scheduler: str | None = None, nominal: Nominal | None = None,
              n_workers: int | None = None, client=None) -> tuple[Nominal, dict]:
    """Run every chunk of the study; return the nominal analysis and the per-sample arrays (:func:`run_chunk`).

    Parameters
    ----------
    cfg : StudyConfig
    scheduler : str or None
        None: in this process; ``"local"``: a ``dask.distributed.LocalCluster``
        with ``n_workers`` processes (default one per CPU), one thread each;
        ``"tcp://HOST:PORT"``: an existing Dask scheduler (asked for its
        identity first, within :data:`vlab.robust.scheduler.CONNECT_TIMEOUT_S`).
    nominal : Nominal, optional
        Reuse a nominal analysis (default: computed here).
    n_workers : int, optional
        Processes of the local cluster.
    client : distributed.Client, optional
        An open client to run on (then ``scheduler`` is not used).

    Raises
    ------
    OptionError
        A scheduler that is neither None, ``"local"`` nor a ``tcp://HOST:PORT`` address.
    SchedulerError
        A remote scheduler that does not answer in time.
    """
    from .scheduler import check_scheduler, dask_client, parse_scheduler

    scheduler = parse_scheduler(scheduler) if client is None else None
    if scheduler not in (None, "local"):
        check_scheduler(scheduler)
    nominal = nominal if nominal is not None else nominal_analysis(cfg)
    chunks = [range(a, min(a + cfg.chunk_size, cfg.n_samples)) for a in range(0, cfg.n_samples, cfg.chunk_size)]
    if client is not None:
        return nominal, _gather(client, cfg, nominal, chunks)
    if scheduler is None:
        return nominal, _merge([run_chunk(cfg, nominal, ch) for ch in chunks])
    with dask_client(scheduler, n_workers or default_workers()) as cl:
        return nominal, _gather(cl, cfg, nominal, chunks)


def _gather(client, cfg, nominal, chunks) -> dict:
    cfg_f, nom_f = client.scatter(cfg, broadcast=True), client.scatter(nominal, broadcast=True)
    futures = [client.submit(run_chunk, cfg_f, nom_f, list(ch), pure=False) for ch in chunks]
    return _merge(client.gather(futures))


@dataclass(frozen=True)
class Summary:
    """Per-controller statistics of a study (every key of :meth:`as_dict` carries its unit).

    Attributes
    ----------
    per_controller : dict
        Controller -> dict of statistics.
    ranking : dict
        Metric -> controllers from most to least robust.
    thesis_conclusion : dict
        Metric -> ``{"lqg_least_robust": bool, "lqdrf_diag_most_robust": bool,
        "verdict": str}``: ``"holds"`` (LQG strictly the most and LQDRF-diag
        strictly the least vulnerable), ``"partly: ..."``, ``"does not hold"``
        or ``"undecided (all equal)"`` (then the booleans are None); for the
        metrics with bootstrap intervals also whether the first and the last
        place are resolved (their 95 % intervals do not overlap the next one's).
    """

    per_controller: dict = field(default_factory=dict)
    ranking: dict = field(default_factory=dict)
    thesis_conclusion: dict = field(default_factory=dict)


#: Bootstrap resamples of the confidence interval of a median.
N_BOOTSTRAP = 400


def median_ci(x: np.ndarray, seed: int) -> list:
    """95 % percentile-bootstrap interval ``[low, high]`` of the median of ``x``.

    Parameters
    ----------
    x : ndarray, shape (n,)
        Values (any unit; the interval has it).
    seed : int
        Seed of the :data:`N_BOOTSTRAP` resamples.

    Returns
    -------
    list of float or None
        ``[None, None]`` when ``x`` is empty.

    Source: Efron & Tibshirani, *An Introduction to the Bootstrap*, 1993, Sec. 13.3 (percentile interval).
    """
    if x.size == 0:
        return [None, None]
    rng = np.random.default_rng([int(seed), 29])
    med = np.median(x[rng.integers(0, x.size, (N_BOOTSTRAP, x.size))], axis=1)
    lo, hi = np.percentile(med, [2.5, 97.5])
    return [float(lo), float(hi)]


def _q(x: np.ndarray) -> dict:
    x = x[np.isfinite(x)]
    if x.size == 0:
        return {"p5": None, "p25": None, "median": None, "p75": None, "p95": None}
    p = np.percentile(x, [5, 25, 50, 75, 95])
    return {"p5": float(p[0]), "p25": float(p[1]), "median": float(p[2]), "p75": float(p[3]), "p95": float(p[4])}


#: Metrics ranked (lower = more robust) and their description.
METRICS = {
    "probability_unstable": "share of samples with an unstable sampled-data loop",
    "peak_ratio_error_db": "median over samples of the mean over modes of |20 log10(analysis/experiment peak ratio)|",
    "damping_change": "median over samples of the mean over modes of |zeta / zeta_nominal - 1|",
}


def summarize(cfg: StudyConfig, nominal: Nominal, res: dict) -> Summary:
    """Distributions per controller and whether the Sec. 7 ordering holds (LQG worst, LQDRF-diag best).

    Parameters
    ----------
    cfg : StudyConfig
    nominal : Nominal
    res : dict
        Per-sample arrays of :func:`run_study`.

    Returns
    -------
    Summary
        Metrics of :data:`METRICS`, lower = more robust.
    """
    per, score = {}, {m: {} for m in METRICS}
    for c in cfg.controllers:
        stable = res[f"{c}/spectral_radius"] < 1.0
        ratio = nominal.peaks[c][None, :] / res[f"{c}/peaks"]
        db = np.abs(20 * np.log10(ratio))
        dz = np.abs(res[f"{c}/zeta"] / nominal.zeta[c][None, :] - 1.0)
        with np.errstate(invalid="ignore"):  # an unstable nominal loop: inf / inf, left out below as NaN
            e_ratio = res[f"{c}/energy_j_s"] / nominal.energy_j_s[c]
        p_unst = float(1.0 - stable.mean())
        per_sample_db = np.where(stable, db.mean(axis=1), np.nan)
        score["probability_unstable"][c] = p_unst
        score["peak_ratio_error_db"][c] = float(np.nanmedian(per_sample_db)) if stable.any() else math.inf
        per_sample_dz = dz[stable].mean(axis=1)
        score["damping_change"][c] = float(np.median(per_sample_dz)) if stable.any() else math.inf
        per[c] = {
            "samples": int(stable.size),
            "probability_unstable": p_unst,
            "nominal_damping_ratio": nominal.zeta[c].tolist(),
            "nominal_frequency_hz": nominal.freq_hz[c].tolist(),
            "nominal_energy_index_j_s": float(nominal.energy_j_s[c]),
            "damping_ratio_by_mode": [_q(res[f"{c}/zeta"][:, r]) for r in range(nominal.n_modes)],
            "peak_ratio_analysis_over_experiment_by_mode": [_q(ratio[stable, r]) for r in range(nominal.n_modes)],
            "peak_ratio_error_db_median": score["peak_ratio_error_db"][c],
            "peak_ratio_error_db_median_ci95": median_ci(per_sample_db[np.isfinite(per_sample_db)], cfg.seed),
            "damping_change_relative_median": score["damping_change"][c],
            "damping_change_relative_median_ci95": median_ci(per_sample_dz, cfg.seed),
            "energy_index_ratio_to_nominal": _q(e_ratio[stable]),
            "spectral_radius_max": float(np.max(res[f"{c}/spectral_radius"])),
            "nominal_spectral_radius": nominal.spectral_radius.get(c),
        }
    ranking = {m: sorted(cfg.controllers, key=lambda c: (s[c], CONTROLLERS.index(c))) for m, s in score.items()}
    holds = {}
    if "lqg" in cfg.controllers and "lqdrf-diag" in cfg.controllers:
        for m, s in score.items():
            if len(set(s.values())) == 1:
                holds[m] = {"lqg_least_robust": None, "lqdrf_diag_most_robust": None,
                            "verdict": "undecided (all equal)"}
                continue
            worst = all(s["lqg"] > s[c] for c in cfg.controllers if c != "lqg")
            best = all(s["lqdrf-diag"] < s[c] for c in cfg.controllers if c != "lqdrf-diag")
            first, last = LABELS[ranking[m][0]], LABELS[ranking[m][-1]]
            verdict = ("holds" if worst and best else
                       f"partly: LQG is the least robust but {first} (not LQDRF-diag) the most" if worst else
                       f"partly: LQDRF-diag is the most robust but {last} (not LQG) the least" if best else
                       "does not hold")
            holds[m] = {"lqg_least_robust": worst, "lqdrf_diag_most_robust": best, "verdict": verdict}
            ci_key = {"peak_ratio_error_db": "peak_ratio_error_db_median_ci95",
                      "damping_change": "damping_change_relative_median_ci95"}.get(m)
            if ci_key and len(ranking[m]) > 2:
                ci = {c: per[c][ci_key] for c in cfg.controllers}
                if all(v[0] is not None for v in ci.values()):
                    a, b = ranking[m][0], ranking[m][1]
                    y, z = ranking[m][-2], ranking[m][-1]
                    holds[m]["most_robust_resolved_ci95"] = bool(ci[a][1] < ci[b][0])
                    holds[m]["least_robust_resolved_ci95"] = bool(ci[z][0] > ci[y][1])
    return Summary(per, ranking, holds)
