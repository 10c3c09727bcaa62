"""Where the chunks of a robustness study run: the address checked, the scheduler reached in bounded time.

``--scheduler`` takes ``none`` (this process), ``local`` (a
``dask.distributed.LocalCluster``) or ``tcp://HOST:PORT`` (an existing Dask
scheduler). An address is parsed before anything runs (a missing or bad port
is an input error naming the value), and a remote scheduler is asked for its
identity within :data:`CONNECT_TIMEOUT_S` before the designs start: a
``dask.distributed.Client`` given ``timeout=`` still waits without bound on a
server that accepts the connection and never answers, so the first exchange
runs under ``asyncio.wait_for``.

Source: ``distributed.comm.connect`` and the scheduler's ``identity`` handler
(Dask distributed documentation, "Communications" and "Scheduler").
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import math
from urllib.parse import urlsplit

from ..errors import OptionError, VlabError
from ..units import format_duration

#: The most a scheduler may take to answer its identity [s].
CONNECT_TIMEOUT_S = 8.0
#: Seconds one sample takes per worker process, all four controllers, measured on two shared cores
#: (``vlab robustness bcc|grid --samples 1000``: 20 s and 234 s on 2 processes).
SECONDS_PER_SAMPLE = {"bcc": 0.04, "grid": 0.47}
#: Seconds one 12 s MuJoCo run of the time check takes, measured on two shared cores (``vlab robustness
#: bcc|grid``: 365 s for 427 runs, 362 s for 60 runs).
SECONDS_PER_RUN = {"bcc": 0.85, "grid": 6.0}
#: A study estimated to take longer than this [s] needs ``--yes``.
CONFIRM_ABOVE_S = 1800.0


class SchedulerError(VlabError):
    """The Dask scheduler could not be reached or did not answer in time."""


def parse_scheduler(value: str | None) -> str | None:
    """The scheduler setting checked: None (in this process), ``"local"`` or ``"tcp://HOST:PORT"``.

    Parameters
    ----------
    value : str or None
        ``None`` or ``"none"``, ``"local"``, or ``tcp://HOST:PORT`` (port 1-65535).

    Returns
    -------
    str or None

    Raises
    ------
    OptionError
        Anything else, naming the value (a ``tcp://`` address without a host or a port included).
    """
    if value is None or value == "none":
        return None
    if value == "local":
        return value
    if not isinstance(value, str) or not value.startswith("tcp://"):
        raise OptionError(f"--scheduler {value!r}: use local, none or a Dask scheduler address tcp://HOST:PORT")
    parts = urlsplit(value)
    try:
        port = parts.port
    except ValueError:
        port = -1
    if not parts.hostname or port is None or not 1 <= port <= 65535 or parts.path not in ("", "/") \
            or parts.query or parts.fragment:
        raise OptionError(f"--scheduler {value!r}: a Dask scheduler address is tcp://HOST:PORT with a host and a "
                          "port 1-65535, e.g. tcp://127.0.0.1:8786")
    return value


async def _identity(address: str, timeout_s: float) -> dict:
    from distributed.comm import connect

    comm = await connect(address, timeout=timeout_s)
    try:
        await comm.write({"op": "identity", "reply": True})
        return await comm.read()
    finally:
        comm.abort()


def check_scheduler(address: str, timeout_s: float = CONNECT_TIMEOUT_S) -> dict:
    """Ask the Dask scheduler at ``address`` for its identity, within ``timeout_s`` seconds in all.

    Parameters
    ----------
    address : str
        ``tcp://HOST:PORT`` (:func:`parse_scheduler`).
    timeout_s : float
        Bound on the connection and the answer together [s].

    Returns
    -------
    dict
        The scheduler's identity (``type``, ``id``, ``address``, ``workers``, ...).

    Raises
    ------
    SchedulerError
        Refused, unreachable, silent, or an answer that is not a scheduler's.
    """
    try:
        ident = asyncio.run(asyncio.wait_for(_identity(address, timeout_s), timeout_s))
    except (TimeoutError, asyncio.TimeoutError):
        raise SchedulerError(f"--scheduler {address}: no answer from a Dask scheduler within {timeout_s:g} s "
                             "(is it a Dask scheduler, and running?)") from None
    except OSError as exc:
        raise SchedulerError(f"--scheduler {address}: cannot connect ({exc})") from None
    if not isinstance(ident, dict) or ident.get("type") != "Scheduler":
        raise SchedulerError(f"--scheduler {address}: the server answered, but not as a Dask scheduler")
    return ident


def parse_samples(value) -> int:
    """``--samples`` as an integer >= 1: digits, or a float notation of an integer (``1e4``).

    Parameters
    ----------
    value : str or int

    Returns
    -------
    int

    Raises
    ------
    OptionError
        Not a positive whole number, naming the value.
    """
    try:
        x = float(str(value).strip().replace("_", ""))
    except ValueError:
        x = math.nan
    if not math.isfinite(x) or x < 1 or x != int(x):
        raise OptionError(f"--samples must be a positive integer (e.g. 1000 or 1e4), got {value!r}")
    return int(x)


def estimate_seconds(structure: str, n_samples: int, n_controllers: int, workers: int, runs: int = 0, *,
                     per_sample_s: float | None = None, per_run_s: float | None = None) -> float:
    """Rough run time of a study [s]: the samples spread over the workers, plus ``runs`` MuJoCo runs.

    Parameters
    ----------
    structure : str
        ``"bcc"`` or ``"grid"`` (costs :data:`SECONDS_PER_SAMPLE`, :data:`SECONDS_PER_RUN`), or any structure
        with both costs given.
    n_samples, n_controllers, workers : int
        ``workers`` >= 1 processes.
    runs : int
        MuJoCo runs of the time check, all controllers together.
    per_sample_s, per_run_s : float, optional
        Measured costs [s] (:func:`vlab.robust.estimate.measure_costs`): one sample with every controller of
        the study, one run; they replace the tables.

    Returns
    -------
    float
        NaN for a structure without tabled costs and none given.
    """
    if per_sample_s is None:
        if structure not in SECONDS_PER_SAMPLE:
            return math.nan
        per_sample_s = SECONDS_PER_SAMPLE[structure] * n_controllers / 4
    if per_run_s is None:
        per_run_s = SECONDS_PER_RUN.get(structure, math.nan)
    return per_sample_s * n_samples / max(workers, 1) + (per_run_s * runs if runs else 0.0)


def confirm_size(samples_text: str, structure: str, n_samples: int, n_controllers: int, workers: int,
                 yes: bool, runs: int = 0, *, per_sample_s: float | None = None,
                 per_run_s: float | None = None) -> float:
    """Refuse a study estimated (:func:`estimate_seconds`) to run longer than :data:`CONFIRM_ABOVE_S` unless ``yes``.

    Parameters
    ----------
    samples_text : str
        ``--samples`` as given (named in the message).
    structure : str
    n_samples, n_controllers, workers : int
    yes : bool
        ``--yes``.
    runs : int
        MuJoCo runs of the time check (:func:`estimate_seconds`).
    per_sample_s, per_run_s : float, optional
        Measured costs [s], as :func:`estimate_seconds`.

    Returns
    -------
    float
        The estimate [s] (NaN where it cannot be made before the designs: a structure without tabled costs).

    Raises
    ------
    OptionError
        Over the limit without ``yes``: the message gives the estimate.
    """
    est = estimate_seconds(structure, n_samples, max(n_controllers, 1), workers, runs, per_sample_s=per_sample_s,
                           per_run_s=per_run_s)
    if est > CONFIRM_ABOVE_S and not yes:
        raise OptionError(f"--samples {samples_text}: about {format_duration(est)} on {workers} process(es) "
                          f"({n_samples} samples, {runs} MuJoCo runs); pass --yes to run it, or fewer samples "
                          "(or fewer --simulate-random)")
    return est



#: Environment variable of Dask's log level for ``distributed`` (read by each worker process at its start).
_WORKER_LOG_ENV = "DASK_LOGGING__DISTRIBUTED"


@contextlib.contextmanager
def _workers_ignore_sigint():
    """SIGINT ignored in this process while the local workers start, so that they inherit the ignored state;
    their Dask log level set to CRITICAL through the environment they inherit (a task's error reaches the
    client as the task's exception; what a worker logs by itself is its own housekeeping, e.g. the ERROR
    "failed to communicate with scheduler during heartbeat" of a worker whose client was interrupted).

    A terminal's Ctrl-C reaches every process of the foreground group; a worker process that has Python's
    default handler prints its own KeyboardInterrupt traceback. Workers started while SIGINT is ignored keep
    ignoring it across ``exec`` (POSIX), and Python then installs no handler of its own in them; this
    process's handler is restored at once (a Ctrl-C during the start is lost). Only on the main thread.
    """
    import os
    import signal
    import threading

    env = os.environ.get(_WORKER_LOG_ENV)
    os.environ[_WORKER_LOG_ENV] = "critical"  # the workers' own log lines ("event loop unresponsive", heartbeats)
    main = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN) if main else None
    try:
        yield
    finally:
        if main:
            signal.signal(signal.SIGINT, previous)
        if env is None:
            os.environ.pop(_WORKER_LOG_ENV, None)
        else:
            os.environ[_WORKER_LOG_ENV] = env


@contextlib.contextmanager
def dask_client(scheduler: str, n_workers: int):
    """A ``dask.distributed.Client`` on a new LocalCluster (``"local"``) or the scheduler at ``scheduler``.

    Dask's own log lines below CRITICAL are silenced while it runs, and an
    interrupt or a failure closes the cluster with all of them silenced (its
    scheduler reports the client's closed connection as CRITICAL): Ctrl-C
    leaves the command's one line.

    Parameters
    ----------
    scheduler : str
        ``"local"`` or a checked ``tcp://`` address (:func:`check_scheduler`).
    n_workers : int
        Processes of a local cluster (one thread each).

    Yields
    ------
    distributed.Client

    Raises
    ------
    SchedulerError
        The remote scheduler did not take the client within :data:`CONNECT_TIMEOUT_S`.
    """
    from dask.distributed import Client, LocalCluster

    loggers = [logging.getLogger(n) for n in ("distributed", "tornado", "asyncio")]
    levels = [lg.level for lg in loggers]
    for lg in loggers:
        lg.setLevel(logging.CRITICAL)
    try:
        if scheduler == "local":
            with _workers_ignore_sigint():
                cluster = LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True,
                                       dashboard_address=None)
            with cluster, Client(cluster) as client:
                try:
                    yield client
                except BaseException:  # an interrupt or a failure: the shutdown's closed-comm lines are chatter
                    for lg in loggers:
                        lg.setLevel(logging.CRITICAL + 1)
                    raise
        else:
            try:
                client = Client(scheduler, timeout=CONNECT_TIMEOUT_S)
            except (OSError, TimeoutError) as exc:
                raise SchedulerError(f"--scheduler {scheduler}: {exc}") from None
            with client:
                yield client
    finally:
        for lg, lv in zip(loggers, levels):
            lg.setLevel(lv)
