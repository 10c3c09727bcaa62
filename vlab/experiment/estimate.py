"""Memory and time of an experiment run, estimated before it starts, and the memory available for it.

The command line refuses a run whose estimate does not fit in the available memory and prints the estimate
before the run; :func:`estimate_experiment` is the model, :func:`available_memory_bytes` what it is
compared with.
"""

from __future__ import annotations

import math
import os

#: Rough controller ticks per second of the experiment loop (measured on the development machine,
#: 2 shared cores, open loop, 40 s BCC / 100 s grid runs): linear plant ~4800, MuJoCo BCC ~3600;
#: the MuJoCo grid (more bodies) is taken slower. Keys: (plant kind, structure name); any other
#: structure is taken at 1500 ticks/s. Only for the time estimate shown before a run.
LOOP_TICKS_PER_S = {("linear", "bcc"): 4800.0, ("linear", "grid"): 4800.0,
                    ("mujoco", "bcc"): 3600.0, ("mujoco", "grid"): 1500.0}
#: Ticks per second taken for a (plant, structure) pair not in :data:`LOOP_TICKS_PER_S`.
DEFAULT_TICKS_PER_S = 1500.0
#: Memory bandwidth assumed for the delay line's per-tick shift [bytes/s] (time estimate only).
SHIFT_BYTES_PER_S = 2e9


def estimate_experiment(fe, *, plant: str, period_s: float, duration_s: float | None,
                        delay_periods: float) -> dict[str, float]:
    """Memory and time an experiment run would need, estimated before it starts.

    The model counts 8-byte floats. Memory: the loop's per-tick signals (velocities of the measured
    points and the actuator points, displacements of the shape points -- the points with a ``w`` degree
    of freedom --, commands of the actuators), x3 for the copies the recording, the H1 estimate and the
    rerun log make, plus 4 values per tick for the excitation and the time; and the computation-delay
    line: the DAC buffer of :class:`vlab.lab.batch_chain.ChainRun`, ``floor(D) + 2`` samples per
    actuator (:attr:`vlab.lab.batch_chain.BatchChain.history`), x3 (buffer, shift copy, state).
    Time: ticks / :data:`LOOP_TICKS_PER_S` (measured loop rates, see there) plus the delay line's
    per-tick shift at :data:`SHIFT_BYTES_PER_S`. Design, outputs and figures are not included.

    Parameters
    ----------
    fe : FEModel
        The nominal FE model (its spec selects the test of Sec. 5.4; its ``spec.name`` and ``plant``
        select the loop rate).
    plant : {"linear", "mujoco"}
        Plant kind.
    period_s : float
        Controller sampling period [s], > 0.
    duration_s : float or None
        Run length [s]; None = the default (settling records of the slowest open-loop mode,
        :func:`vlab.experiment.settling.settle_records`, plus the measured records); with a controller
        the loop settles sooner, so the default is an upper bound.
    delay_periods : float
        Computation delay [sampling periods], >= 0.

    Returns
    -------
    dict of str to float
        ``duration_s`` [s] (the run length used), ``n_ticks`` [1] (controller ticks,
        ``floor(duration_s / period_s)``), ``memory_bytes`` [bytes], ``time_s`` [s] (the loop only).

    Raises
    ------
    SpecError
        Structure without a test definition (:func:`vlab.experiment.config.test_definition`).
    """
    from .config import ExperimentConfig, test_definition
    from .settling import settle_records, slowest_decay_rate

    test = test_definition(fe.spec)
    record_s = 1.0 / test.resolution_hz
    if duration_s is None:
        n_settle = settle_records(slowest_decay_rate(fe, None), record_s)
        duration_s = (n_settle + ExperimentConfig.periods - 1) * record_s
    n_ticks = math.floor(duration_s / period_s + 1e-9)
    acts = tuple(fe.spec.instrumentation.actuators)
    n_meas = len(dict.fromkeys(tuple(test.measured_points) + acts))
    n_shape = sum(1 for p in fe.spec.points if (p, "w") in fe.dofs)
    per_tick = 8.0 * (3 * (n_meas + n_shape + len(acts)) + 4)
    delay_bytes = 8.0 * (math.floor(delay_periods) + 2) * len(acts)
    rate = LOOP_TICKS_PER_S.get((plant, fe.spec.name), DEFAULT_TICKS_PER_S)
    return {"duration_s": float(duration_s), "n_ticks": float(n_ticks),
            "memory_bytes": n_ticks * per_tick + 3 * delay_bytes,
            "time_s": n_ticks / rate + n_ticks * delay_bytes / SHIFT_BYTES_PER_S}


def available_memory_bytes() -> int | None:
    """Memory available to a new run [bytes]: ``MemAvailable`` of ``/proc/meminfo``, else ``os.sysconf``.

    Returns
    -------
    int or None
        Bytes, or None where the system does not say.
    """
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return int(os.sysconf("SC_AVPHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return None
