"""Reruns of the recorded test on several lab states: cached, batched, in processes or in the background.

A diagnosis asks for the rerun of its recorded test on several lab states at once (a candidate and the
nominal lab, the look-alikes of a choice). :func:`reruns` makes each once -- kept in the problem's run
context (:class:`vlab.diagnose.data.run.DiagnosisRun`) under ``(key, plant, seed)`` -- and makes those it
must make the cheapest way: MuJoCo reruns whose plants share one layout as one ``mujoco.batch``
(:mod:`vlab.diagnose.data.batchrerun`), the others in parallel processes, a lone one split over the free
cores (:func:`vlab.diagnose.data.replay.rerun_split`). The nominal lab's MuJoCo rerun can be started in a
background process while the hypotheses are fitted (:func:`start_background_rerun`).

Each single rerun is :func:`vlab.diagnose.data.replay.rerun` (the 2 kHz loop, warm-started where the
excitation is periodic, :mod:`vlab.diagnose.data.warmstart`), without the controller's sensor noise
(:func:`vlab.diagnose.data.replay.expectation`): a rerun is the model's expected response to the recorded
force, compared with a recording whose noise the data's variance already carries.
"""

from __future__ import annotations

import numpy as np

from ...errors import VlabError
from .batchrerun import batch_key, rerun_together, why_apart
from ..model.labmodel import LabState
from .measured import FrfData
from .replay import at_amplitude, expectation, mujoco_plant, recording_of, rerun, rerun_payload, rerun_split
from ..model.nominal import settling_time
from .warmstart import GUARD_DECAY, guard_ticks, recorded_window

#: Run several MuJoCo reruns of :func:`reruns` whose plants share one layout as one ``mujoco.batch``
#: (:mod:`vlab.diagnose.data.batchrerun`) instead of one process each. The same recordings either way
#: (tests/test_diagnose_batchrerun.py); the speed of each way is printed by benchmarks/rerun_batch_speed.py.
BATCH_RERUNS = True

#: Fewest reruns :func:`reruns` makes as one batch by default. Measured side by side
#: (benchmarks/rerun_batch_speed.py, docs/validation/data/rerun_batch_speed.txt: BCC MFDRF, 27.6 s reruns, 2 cores, load
#: average 2.0-3.2, nice -10): processes / batch wall time 0.92 for K = 2, 1.05 for K = 3, 1.14 for K = 4
#: (a second run: 0.90, 1.04, 1.14). The batched loop on one
#: thread costs about 15 us per tick and simulation at N = 2, 11 at N = 4, against the single loop's
#: 13.5, while two processes can use the second core when it is free; so a pair goes to processes.
BATCH_MIN_RERUNS = 3

#: Fewest simulations for which the batch steps on more than one thread: a step of one BCC plant takes
#: about 6 us, and handing a step to a second thread cost 50-100 us per call on the 2-core machine with
#: other jobs running (benchmarks/rerun_batch_speed.py), so a few reruns step on one thread.
BATCH_THREAD_MIN = 16


def _background_job(conn, *args) -> None:
    """Body of a background rerun process: sends ``("ok", (dt_s, signals))`` or ``("error", message)``."""
    try:
        conn.send(("ok", rerun_payload(*args)))
    except VlabError as exc:
        conn.send(("error", str(exc)))
    finally:
        conn.close()


def outlasts_guard(problem, labs) -> bool:
    """Whether a warm-started rerun's start error may outlast its guard: the slowest mode in the band of one
    of ``labs`` decays to :data:`~vlab.diagnose.data.warmstart.GUARD_DECAY` later than the guard before the
    analysed periods ends (:func:`~vlab.diagnose.model.nominal.settling_time`; the guard is capped at
    :data:`~vlab.diagnose.data.warmstart.GUARD_PERIODS` periods). Such reruns run through every analysed
    period, and their FRFs are estimated as the recording's are, the transient left removed
    (:func:`~vlab.diagnose.data.replay.frf_of`); a nearly undamped mode would otherwise carry the start's
    error through the one analysed period a rerun simulates.

    Parameters
    ----------
    problem : Problem
        With :class:`FrfData` from a recording; its ``guard_s`` and band.
    labs : sequence of LabState
        The labs to be rerun.

    Returns
    -------
    bool
        False for data not estimated period by period.
    """
    data: FrfData = problem.data
    if not data.periodic or data.recording is None:
        return False
    dt = data.recording.dt_s
    guard = guard_ticks(data, dt, problem.guard_s) * dt
    return any(settling_time(st, problem.ctx.band_hz, decay=GUARD_DECAY) > guard for st in labs)


def window_for(problem, labs) -> tuple[tuple | None, str]:
    """The window of reruns of ``labs`` and the suffix of their cache keys: through every analysed period,
    ``"@all"``, where :func:`outlasts_guard`; else the default window (None) and no suffix.

    Parameters
    ----------
    problem, labs
        As :func:`outlasts_guard`.

    Returns
    -------
    (tuple or None, str)
        ``(start, period, stop)`` ticks (:func:`reruns`' ``window``) or None, and the suffix.
    """
    data: FrfData = problem.data
    if outlasts_guard(problem, labs):
        return recorded_window(data, data.recording.dt_s, None, guard_s=problem.guard_s), "@all"
    return None, ""


def start_background_rerun(problem, state: LabState, key: str, plant: str, *, seed: int = 0,
                           window: tuple | None = None) -> bool:
    """Start the rerun of ``state`` in a background process, to be picked up by :func:`reruns` under
    ``(key, plant, seed)`` (the nominal lab's MuJoCo rerun, while the hypotheses are fitted).

    The process is a daemon: it ends with the diagnosis, and :func:`stop_background` ends it early.

    Parameters
    ----------
    problem : Problem
        With :class:`FrfData` from a recording (its force is played back).
    state : LabState
        The lab to rerun.
    key : str
        Cache key of the rerun (``"nominal"``; with :func:`window_for`'s suffix for its window).
    plant : {"linear", "mujoco"}
    seed : int
        Seed of the controller's sensor noise (as :func:`reruns`).
    window : (int, int, int or None), optional
        As :func:`reruns` (default: its default).

    Returns
    -------
    bool
        Whether it was started (False where no process can be started; the
        rerun is then made when asked for).
    """
    import multiprocessing

    data: FrfData = problem.data
    if data.recording is None:
        return False
    force = np.asarray(data.recording[f"force{data.excitation_point}"])
    state = expectation(state)
    if window is None:
        window = recorded_window(data, data.recording.dt_s, guard_s=problem.guard_s)
    try:
        recv, send = multiprocessing.Pipe(duplex=False)
        proc = multiprocessing.Process(target=_background_job, daemon=True, args=(
            send, state, force, data.excitation_point, tuple(data.output_points), plant, seed, window))
        proc.start()
        send.close()
    except (OSError, AssertionError, ValueError):  # AssertionError: a daemon process may not start children
        return False
    problem.run.background[(key, plant, seed)] = (proc, recv)
    return True


def _batched(todo: list, force: np.ndarray, data: FrfData, seed: int, window: tuple,
             workers: int) -> tuple[dict, str, str]:
    """The MuJoCo reruns of ``todo`` ((index, LabState) pairs) whose plants share a layout, made as one
    ``mujoco.batch`` per layout (:func:`vlab.diagnose.data.batchrerun.rerun_together`).

    Returns ``({index: Recording or VlabError}, how, why)``: the reruns made, how (for the notes), and why
    the others were left out (a plant alone in its layout, one that cannot be built, or a batch that
    failed): those are for the single path."""
    pts = tuple(data.output_points)
    states, plants, groups = dict(todo), {}, {}
    for i, st in todo:
        try:
            plants[i] = mujoco_plant(st, sensors=pts)
        except VlabError:
            continue  # rerun the single way, which reports the error
        groups.setdefault(batch_key(st, plants[i], pts), []).append(i)
    made: dict = {}
    apart = ""
    for key, idx in groups.items():
        if key is None or len(idx) < 2:
            continue
        nthread = max(1, workers) if len(idx) >= BATCH_THREAD_MIN else 1
        try:
            res = rerun_together([states[i] for i in idx], [plants[i] for i in idx], force,
                                 excitation_point=data.excitation_point, measured_points=pts, seed=seed,
                                 start=window[0], period=window[1], stop=window[2], nthread=nthread)
        except VlabError as exc:
            apart = apart or f"the batch failed: {exc}"
            continue
        made.update(zip(idx, res))
    keys = list(groups)
    if not apart and len(keys) > 1:
        apart = why_apart(keys[0], keys[1])
    elif not apart and len(plants) < len(todo):
        apart = "a plant that cannot be built"
    how = f"{len(made)} MuJoCo reruns as one mujoco.batch" if made else ""
    return made, how, apart


def last_reruns_note(problem) -> str:
    """How the last call of :func:`reruns` on ``problem`` made its reruns, for the diagnosis notes.

    E.g. ``"2 MuJoCo reruns as one mujoco.batch"`` or ``"2 mujoco reruns in 2
    processes (model sizes differ (ngeom 38 vs 37))"``; '' when that call made
    fewer than two (the rest cached) or ``problem`` has seen no call.

    Parameters
    ----------
    problem : Problem
        As given to :func:`reruns`.

    Returns
    -------
    str
    """
    return problem.run.note


def _collect_background(problem, keys: list) -> None:
    """Move the background reruns of ``keys`` into the rerun cache, waiting for them; a failed one is
    dropped, to be rerun in the foreground (where its error is reported)."""
    pending, cache = problem.run.background, problem.run.reruns
    for key in keys:
        if key not in pending:
            continue
        proc, recv = pending.pop(key)
        try:
            status, payload = recv.recv()
            if status == "ok":
                cache[key] = recording_of(payload)
        except (EOFError, OSError):
            pass
        finally:
            recv.close()
            proc.join()


def stop_background(problem) -> None:
    """End the background reruns of ``problem`` that were never asked for."""
    pending, problem.run.background = problem.run.background, {}
    for proc, recv in pending.values():
        proc.terminate()
        proc.join()
        recv.close()


def _in_processes(rest: list, args: tuple, workers: int) -> dict:
    """Reruns of the states ``rest`` (index, LabState) in a pool of processes, ``args`` the rest of
    :func:`~vlab.diagnose.data.replay.rerun_payload`'s arguments: index -> Recording or VlabError; empty
    where no pool can be started here (then they run in this process)."""
    from concurrent.futures import ProcessPoolExecutor
    from concurrent.futures.process import BrokenProcessPool

    out: dict = {}
    try:
        with ProcessPoolExecutor(min(workers, len(rest))) as ex:
            futs = [(i, ex.submit(rerun_payload, st, *args)) for i, st in rest]
            for i, fu in futs:
                try:
                    out[i] = recording_of(fu.result())
                except VlabError as exc:
                    out[i] = exc
    except (OSError, BrokenProcessPool):
        return {}
    return out


def reruns(problem, jobs: list, plant: str, *, seed: int = 0, workers: int = 2, batch: bool | None = None,
           window: tuple | None = None, amplitude: float = 1.0) -> list:
    """Reruns of the recorded test of ``problem`` on several lab states, cached on ``problem``.

    Several MuJoCo reruns (:data:`BATCH_MIN_RERUNS` or more, see ``batch``) whose plants differ only in
    values (the same sizes of everything ``MjData`` holds: stiffness, damping, chain and controller gains;
    not an added mass, a new geom) run as one ``mujoco.batch`` (:mod:`vlab.diagnose.data.batchrerun`), bit
    for bit the reruns made one by one; the others, and every linear rerun, run in parallel processes.
    :func:`last_reruns_note` says which way they went.

    Parameters
    ----------
    problem : Problem
        With :class:`FrfData` from a recording (its force is played back).
    jobs : list of (LabState, str or None)
        States and their cache keys (None: not cached).
    plant : {"linear", "mujoco"}
    seed : int
        Seed of the controller's sensor noise (a key of the cache: the reruns are made without that noise,
        :func:`~vlab.diagnose.data.replay.expectation`).
    workers : int
        Parallel processes when more than one rerun is needed (falls back to one process where a pool cannot
        start); each rerun still running in the background (:func:`start_background_rerun`) holds one of
        them, and one of ``jobs`` is made while it finishes (finished ones are collected first, holding none).
    batch : bool, optional
        True: run MuJoCo reruns that can share a batch as one (two or more);
        False: processes only; None (default): as one batch when
        :data:`BATCH_RERUNS` and at least :data:`BATCH_MIN_RERUNS` are to be made.
    window : (int, int, int or None), optional
        ``(start, period, stop)`` ticks of the reruns (default :func:`~vlab.diagnose.data.warmstart.recorded_window`:
        a warm start before the analysed periods; ``(0, 0, None)``: the whole record from rest). The cache
        keys must name a window other than the default.
    amplitude : float
        The recorded force played back times ``amplitude``, on the states at that level
        (:func:`~vlab.diagnose.data.replay.at_amplitude`); the reruns' signals are at that level. The cache
        keys must name an amplitude other than 1.

    Returns
    -------
    list of Recording or VlabError
        One per job, in order: the rerun, or the error that stopped it
        (a plant that cannot be built, a diverged run).
    """
    data: FrfData = problem.data
    force = np.asarray(data.recording[f"force{data.excitation_point}"]) * amplitude
    # the model's expected response (module notes), at the asked level
    jobs = [(expectation(st if amplitude == 1.0 else at_amplitude(st, amplitude)), k) for st, k in jobs]
    window = recorded_window(data, data.recording.dt_s, guard_s=problem.guard_s) if window is None else window
    pts = tuple(data.output_points)
    cache, pending = problem.run.reruns, problem.run.background
    _collect_background(problem, [k for k, (_proc, recv) in list(pending.items()) if recv.poll()])  # done: frees a core
    waiting = [(k, plant, seed) for _st, k in jobs if k is not None and (k, plant, seed) in pending]
    out: dict = {}
    # the reruns still to make run while the background ones finish (they hold a core each)
    todo = [(i, st) for i, (st, k) in enumerate(jobs)
            if k is None or ((k, plant, seed) not in cache and (k, plant, seed) not in pending)]
    workers = max(1, workers - len(pending))  # a background rerun holds a core
    how, apart, how_rest = "", "", "one after another"
    if batch is None:
        batch = BATCH_RERUNS and len(todo) >= BATCH_MIN_RERUNS
    if batch and plant == "mujoco" and len(todo) > 1:
        out, how, apart = _batched(todo, force, data, seed, window, workers)
    rest = [(i, st) for i, st in todo if i not in out]
    if workers > 1 and len(rest) > 1:
        done = _in_processes(rest, (force, data.excitation_point, pts, plant, seed, window), workers)
        if done:
            out.update(done)
            how_rest = f"in {min(workers, len(rest))} processes"
    first = int(round(data.analysed_from_s / data.recording.dt_s))

    def here(st: LabState, cores: int = 1):
        try:
            if cores > 1 and window[1] and plant == "mujoco" and window[0] < first:
                return rerun_split(st, force, excitation_point=data.excitation_point, measured_points=pts,
                                   plant=plant, seed=seed, start=window[0], first=first, period=window[1],
                                   stop=window[2], workers=cores)
            return rerun(st, force, excitation_point=data.excitation_point, measured_points=pts, plant=plant,
                         seed=seed, start=window[0], period=window[1], stop=window[2])[0]
        except VlabError as exc:
            return exc

    for i, st in todo:  # a lone rerun with the cores free is split over them (rerun_split)
        if i not in out:
            out[i] = here(st, workers if len(todo) == 1 and not waiting else 1)
    if rest and len(todo) > 1:
        how = "; ".join(filter(None, [how, f"{len(rest)} {plant} rerun{'s' if len(rest) > 1 else ''} "
                                      f"{how_rest if len(rest) > 1 else 'alone'}" + (f" ({apart})" if apart else "")]))
    problem.run.note = how
    _collect_background(problem, waiting)
    for i, (st, k) in enumerate(jobs):  # a background rerun that failed is made here, where its error shows
        if k is not None and (k, plant, seed) in waiting and (k, plant, seed) not in cache:
            out[i] = here(st)
    for i, (_st, k) in enumerate(jobs):
        if k is None:
            continue
        if i not in out:
            out[i] = cache[(k, plant, seed)]
        elif not isinstance(out[i], VlabError):
            cache[(k, plant, seed)] = out[i]
    return [out[i] for i in range(len(jobs))]
