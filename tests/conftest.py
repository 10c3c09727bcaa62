"""Settings shared by the whole test suite."""

from __future__ import annotations

import os


def pytest_configure(config) -> None:
    """Remove ``COLUMNS`` and ``LINES`` from the environment: pytest-xdist's workers set them (80 x 24), and the
    command line's tables follow ``COLUMNS`` when piped, so the tests would see a narrower table than a user's
    pipe gets (tests that need a width set it themselves).

    In a pytest-xdist worker, BLAS gets the worker's share of the cores (one thread each with ``-n auto``):
    OpenBLAS starts one thread per core in every process, so two workers on two cores ran four BLAS threads
    that wait on each other's cores for the small matrices vlab works on (what the diagnosis already does
    for its own fits: :func:`vlab.diagnose.data.run.one_blas_thread`). The limit is set in this process with
    threadpoolctl and in the environment, so that the processes a test starts (the command line, a dask
    cluster) run with the same number of threads as the in-process code they are compared with."""
    for name in ("COLUMNS", "LINES"):
        os.environ.pop(name, None)
    _run_named_tests(config)
    _sigint_as_in_a_terminal()
    workers = os.environ.get("PYTEST_XDIST_WORKER_COUNT")
    if workers is not None:
        threads = str(max(1, (os.cpu_count() or 1) // int(workers)))
        for name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
            os.environ.setdefault(name, threads)
        from threadpoolctl import threadpool_limits

        threadpool_limits(limits=int(os.environ["OPENBLAS_NUM_THREADS"]), user_api="blas")


def _sigint_as_in_a_terminal() -> None:
    """Ctrl-C raises KeyboardInterrupt, as in a terminal, also when the suite was started in the background:
    a shell without job control starts a background command with SIGINT ignored, Python then keeps it
    ignored, and the tests of what an interrupt leaves behind would see no interrupt at all."""
    import signal
    import threading

    if threading.current_thread() is threading.main_thread() and signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)


#: The marker expression of pyproject's ``addopts``: the default run leaves out the end-to-end checks.
DEFAULT_MARKEXPR = "not slow and not long"


def _run_named_tests(config) -> None:
    """A test named on the command line by its node id (``pytest tests/x.py::test_y``) runs whatever its
    marker: the default ``-m 'not slow and not long'`` of ``addopts`` would deselect a ``slow`` one without a
    word. Only where every argument names a test and ``-m`` is the default's."""
    args = [str(a) for a in config.args]
    if args and all("::" in a for a in args) and config.option.markexpr == DEFAULT_MARKEXPR:
        config.option.markexpr = ""
