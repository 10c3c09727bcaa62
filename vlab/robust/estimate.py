"""Run time of a robustness study on a structure of one's own, measured before the long part starts.

The dissertation's structures have measured costs (:data:`vlab.robust.scheduler.SECONDS_PER_SAMPLE`,
:data:`~vlab.robust.scheduler.SECONDS_PER_RUN`). For any other structure they are measured here, after
the designs: one sample of the study evaluated in this process (every controller's sampled-data loop on
one perturbed FE model), and two short runs of the time check (:data:`PROBE_S` and twice as many
seconds of the nominal MuJoCo plant in the lab loop with the study's first controller, as
:func:`vlab.robust.simulate.run_cases` runs it): their difference is the cost of :data:`PROBE_S`
simulated seconds, the first run less that is the fixed cost of a run (building the batch, judging the
recording), and a run of ``run_s`` seconds costs ``fixed + run_s / PROBE_S * difference``. The estimate is
as good as the load of the machine stays: a shared machine's other work slows the study as much as it
slowed the probe.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

from .study import Nominal, StudyConfig, nominal_spec, run_chunk

#: Length of the probe run [s]: two records of 0.5 s (the first settles, the check reads the second).
PROBE_S = 1.0


@dataclass(frozen=True)
class Costs:
    """Measured costs of one study.

    Attributes
    ----------
    per_sample_s : float
        One sample, every controller of the study, in one process [s].
    per_run_s : float
        One MuJoCo run of the time check, ``run_s`` seconds long [s].
    """

    per_sample_s: float
    per_run_s: float


def measure_costs(cfg: StudyConfig, nominal: Nominal, *, run_s: float) -> Costs:
    """Time one sample and a short stretch of the nominal MuJoCo plant (module notes).

    Parameters
    ----------
    cfg : StudyConfig
    nominal : Nominal
        From :func:`vlab.robust.study.nominal_analysis`.
    run_s : float
        Length of one time-check run [s].

    Returns
    -------
    Costs

    Raises
    ------
    SimulationError
        The plant cannot be built or run.
    """
    from .simulate import CHECK_NOISE_M_S, build_plants, run_cases

    t0 = time.perf_counter()
    run_chunk(cfg, nominal, [0])
    per_sample = time.perf_counter() - t0
    spec0 = nominal_spec(cfg, nominal)
    c = cfg.controllers[0]
    chain = replace(nominal.chains[c], noise_m_s=CHECK_NOISE_M_S)
    plants = build_plants(spec0, [spec0])
    spent = []
    for length in (PROBE_S, 2 * PROBE_S):
        t0 = time.perf_counter()
        run_cases(cfg, nominal, c, [spec0], [chain], [0], resolution_hz=2.0 / length, records=2, plants=plants)
        spent.append(time.perf_counter() - t0)
    per_s = max(spent[1] - spent[0], 0.0) / PROBE_S
    fixed = max(spent[0] - per_s * PROBE_S, 0.0)
    return Costs(per_sample, fixed + per_s * run_s)
