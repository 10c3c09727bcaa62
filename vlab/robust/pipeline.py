"""A whole robustness study, as ``vlab robustness`` runs it: designs, samples, MuJoCo check, limit cycle.

Order: the scheduler is reached first (a remote one must answer within
:data:`vlab.robust.scheduler.CONNECT_TIMEOUT_S`, before any computation),
then the designs, the samples in chunks, the MuJoCo runs of the chosen
samples of every controller (:func:`vlab.robust.simulate.choose_samples`),
and, for every controller whose *unperturbed* loop is unstable on the
MuJoCo plant, the limit cycle's sensitivity (:mod:`vlab.robust.limit_cycle`).
"""

from __future__ import annotations

import contextlib
import time

from .estimate import measure_costs
from .limit_cycle import CHANGES, fe_loop_mode_near, limit_cycle_sensitivity
from ..units import format_duration
from .scheduler import check_scheduler, confirm_size, dask_client, parse_scheduler
from .simulate import CHECK_RECORDS, CHECK_RESOLUTION_HZ, choose_samples, simulate_samples
from .study import StudyConfig, default_workers, is_dissertation, nominal_analysis, run_study, summarize

#: Default samples per controller run on MuJoCo: the worst by the linear measure, and drawn at random
#: (per structure: a 12 s grid run takes about 6 s on two shared cores, a BCC run about 0.3-0.8 s; a
#: structure of one's own gets :data:`DEFAULT_RANDOM_OWN`, its cost measured before the long part starts).
DEFAULT_WORST = 4
DEFAULT_RANDOM = {"bcc": 100, "grid": 10}
DEFAULT_RANDOM_OWN = 10


def default_random(structure: str) -> int:
    """Samples per controller drawn at random for the MuJoCo check.

    Parameters
    ----------
    structure : str
        A study's structure (name or path).

    Returns
    -------
    int
        :data:`DEFAULT_RANDOM` of the BCC or the grid, else :data:`DEFAULT_RANDOM_OWN`.
    """
    return DEFAULT_RANDOM.get(structure, DEFAULT_RANDOM_OWN)


def mujoco_runs(n_controllers: int, n_samples: int, n_worst: int, n_random: int) -> int:
    """MuJoCo runs of the time check: per controller its chosen samples and the unperturbed plant.

    Parameters
    ----------
    n_controllers, n_samples : int
        Controllers and samples of the study.
    n_worst, n_random : int
        Samples per controller chosen as the worst and drawn at random (together at most ``n_samples``).

    Returns
    -------
    int
        0 when neither is asked for.
    """
    return n_controllers * (min(n_worst + n_random, n_samples) + 1) if (n_worst or n_random) else 0


def run_pipeline(cfg: StudyConfig, *, scheduler: str | None = "local", workers: int | None = None,
                 n_worst: int = DEFAULT_WORST, n_random: int | None = None, limit_cycle: bool = True,
                 progress=None, yes: bool = True, samples_text: str | None = None):
    """Run the study and its checks; return what :func:`vlab.robust.report.write_outputs` takes.

    Parameters
    ----------
    cfg : StudyConfig
    scheduler : str or None
        None or ``"none"`` (this process), ``"local"`` or ``tcp://HOST:PORT`` (:mod:`vlab.robust.scheduler`).
    workers : int, optional
        Processes of the local cluster (default one per CPU).
    n_worst, n_random : int
        Samples per controller run on MuJoCo (>= 0; both 0: no time simulation); ``n_random`` defaults to
        :data:`DEFAULT_RANDOM` of the structure.
    limit_cycle : bool
        Run :func:`vlab.robust.limit_cycle.limit_cycle_sensitivity` for the
        controllers unstable on MuJoCo at nominal.
    progress : callable, optional
        Called with a short text at each stage, the run-time estimate among them.
    yes : bool
        Run a study estimated to take longer than :data:`vlab.robust.scheduler.CONFIRM_ABOVE_S` (a structure
        of one's own is estimated after its designs, :func:`vlab.robust.estimate.measure_costs`; the
        dissertation's before anything runs, by ``vlab robustness``).
    samples_text : str, optional
        ``--samples`` as given, named in the refusal (default: the number).

    Returns
    -------
    nominal : Nominal
    res : dict
        Per-sample arrays (:func:`vlab.robust.study.run_chunk`).
    summary : Summary
    checks : list of SimCheck
    timings : dict
        Seconds: ``designs`` (with the cluster's start), ``study``, ``time_simulation``, ``total``; ``where`` (text).
    extras : dict
        ``time_simulation`` settings, ``limit_cycle_sensitivity`` rows and
        ``fe_loop_mode_near_limit_cycle`` (:func:`vlab.robust.limit_cycle.fe_loop_mode_near`).

    Raises
    ------
    OptionError
        A bad scheduler address; a study estimated too long without ``yes``.
    SchedulerError
        A remote scheduler that does not answer in time.
    """
    n_random = default_random(cfg.structure) if n_random is None else n_random
    scheduler = parse_scheduler(scheduler)
    if scheduler not in (None, "local"):
        check_scheduler(scheduler)
    n_proc = workers or default_workers()
    where = ("this process" if scheduler is None else
             f"a Dask LocalCluster of {n_proc} process{'es' if n_proc != 1 else ''}" if scheduler == "local"
             else f"the Dask scheduler {scheduler}")
    say = progress or (lambda s: None)
    t0 = time.perf_counter()
    with (dask_client(scheduler, n_proc) if scheduler else contextlib.nullcontext()) as client:
        say("designing the controllers")
        nominal = nominal_analysis(cfg)
        _estimate(cfg, nominal, n_proc if scheduler else 1, mujoco_runs(len(cfg.controllers), cfg.n_samples,
                                                                         n_worst, n_random), yes, samples_text, say)
        t1 = time.perf_counter()
        say(f"{cfg.n_samples} perturbed plants on {where}")
        nominal, res = run_study(cfg, nominal=nominal, client=client)
    t2 = time.perf_counter()
    checks, lc = [], {}
    if n_worst or n_random:
        for c in cfg.controllers:
            idx, w, r = choose_samples(res, nominal, c, n_worst, n_random, seed=cfg.seed)
            say(f"time simulation on MuJoCo: {c}, {len(idx)} samples")
            checks.append(simulate_samples(cfg, nominal, c, idx, worst=w, random=r, seed=cfg.seed))
        if limit_cycle:
            say("what moves the limit cycle")
            lc = {ch.controller: limit_cycle_sensitivity(cfg, nominal, ch.controller, seed=cfg.seed)
                  for ch in checks if ch.nominal.unstable}
    fe_modes = {ch.controller: fe_loop_mode_near(cfg, nominal, ch.controller, ch.nominal.frequency_hz)
                for ch in checks if ch.nominal.unstable and ch.nominal.frequency_hz == ch.nominal.frequency_hz}
    t3 = time.perf_counter()
    summary = summarize(cfg, nominal, res)
    timings = {"designs": t1 - t0, "study": t2 - t1, "time_simulation": t3 - t2, "total": t3 - t0, "where": where}
    extras = {"time_simulation": {"worst_per_controller": n_worst, "random_per_controller": n_random,
                                  "random_selection": "simple random sample without replacement of all samples, "
                                                      "numpy default_rng([seed, 7]), the same for every controller",
                                  "resolution_hz": CHECK_RESOLUTION_HZ, "records": CHECK_RECORDS,
                                  "run_s": CHECK_RECORDS / CHECK_RESOLUTION_HZ},
              "limit_cycle_sensitivity": lc, "fe_loop_mode_near_limit_cycle": fe_modes}
    return nominal, res, summary, checks, timings, extras


def _estimate(cfg: StudyConfig, nominal, workers: int, runs: int, yes: bool, samples_text: str | None, say) -> float:
    """The study's run-time estimate said as a stage (a structure of one's own: its costs measured first);
    refused over the limit without ``yes`` (:func:`vlab.robust.scheduler.confirm_size`)."""
    kw = {}
    if not is_dissertation(cfg):
        say("measuring the cost of one sample and of the MuJoCo plant's steps")
        c = measure_costs(cfg, nominal, run_s=CHECK_RECORDS / CHECK_RESOLUTION_HZ)
        kw = {"per_sample_s": c.per_sample_s, "per_run_s": c.per_run_s}
    est = confirm_size(samples_text or str(cfg.n_samples), cfg.structure, cfg.n_samples, len(cfg.controllers),
                       workers, yes, runs, **kw)
    say(f"estimate: about {format_duration(est)} for {cfg.n_samples} samples on {workers} process(es) and "
        f"{runs} MuJoCo runs of {CHECK_RECORDS / CHECK_RESOLUTION_HZ:g} s (and {len(CHANGES)} more for each "
        "controller unstable on MuJoCo at nominal)")
    return est
