"""A live rerun viewer that listens on the loopback address only.

rerun's own :func:`rerun.spawn` (rerun-sdk 0.41) starts a viewer whose gRPC
server listens on every network interface; :func:`spawn_viewer` starts it
with ``--bind 127.0.0.1`` (:func:`viewer_command`) and waits until it
accepts connections. :func:`viewer_unavailable_reason` says before a run
why no viewer can be started here.

Source: rerun-sdk 0.41 (``rerun --help``: ``--bind``, ``--port``,
``--memory-limit``, ``--headless``).
"""

from __future__ import annotations

#: The only address a viewer started by vlab listens on (loopback, IPv4).
VIEWER_BIND_ADDRESS = "127.0.0.1"


def _viewer_executable() -> str | None:
    """The ``rerun`` viewer executable: on ``PATH`` or beside the Python interpreter."""
    import os
    import shutil
    import sys

    return shutil.which("rerun") or shutil.which("rerun", path=os.path.dirname(sys.executable))


def viewer_command(port: int, *, executable: str = "rerun", headless: bool = False,
                   memory_limit: str = "75%") -> list[str]:
    """The command line that starts a rerun viewer listening on the loopback address only.

    rerun's own :func:`rerun.spawn` (rerun-sdk 0.41) starts ``rerun --port P``
    without ``--bind``, and the viewer's gRPC server then listens on
    ``0.0.0.0`` (``rerun --help``: "--bind: What bind address IP to use
    [default: 0.0.0.0]"), i.e. on every network interface: anyone on the
    network could stream data into it. This command adds
    ``--bind 127.0.0.1``.

    Parameters
    ----------
    port : int
        TCP port of the viewer's gRPC server, 1-65535.
    executable : str
        The ``rerun`` executable.
    headless : bool
        Add ``--headless`` (no window; the gRPC server still runs).
    memory_limit : str
        The viewer's ``--memory-limit`` (rerun's default for spawned viewers).

    Returns
    -------
    list of str
        ``[executable, "--bind", "127.0.0.1", "--port", str(port), ...]``.

    Raises
    ------
    ValueError
        ``port`` is not an integer in 1-65535.
    """
    if isinstance(port, bool) or not isinstance(port, int) or not 1 <= port <= 65535:
        raise ValueError(f"viewer port must be an integer in 1-65535, got {port!r}")
    cmd = [executable, "--bind", VIEWER_BIND_ADDRESS, "--port", str(port),
           f"--memory-limit={memory_limit}", "--expect-data-soon"]
    if headless:
        cmd.append("--headless")
    return cmd


def _free_loopback_port() -> int:
    import socket

    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind((VIEWER_BIND_ADDRESS, 0))
        return int(s.getsockname()[1])


def _kill_group(proc) -> None:
    """Kill a process started with ``start_new_session=True`` and its children (the ``rerun``
    launcher script runs the viewer binary as a child)."""
    import os
    import signal

    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError, AttributeError):
        proc.kill()
    proc.wait()


def spawn_viewer(*, port: int | None = None, timeout_s: float = 20.0, headless: bool = False,
                 executable: str | None = None):
    """Start a rerun viewer whose gRPC server listens on 127.0.0.1 only, and wait until it accepts connections.

    Replaces :meth:`rerun.RecordingStream.spawn`, whose viewer listens on
    all interfaces (see :func:`viewer_command`). The viewer runs in its own
    session (detached, like rerun's ``detach_process=True``), so it stays
    open after the run; its stderr goes to a temporary file that is quoted
    if it fails to start.

    Parameters
    ----------
    port : int, optional
        TCP port; a free loopback port if None.
    timeout_s : float
        How long to wait [s] for the viewer to accept a TCP connection on
        ``127.0.0.1:port``.
    headless : bool
        Start it without a window (``--headless``).
    executable : str, optional
        The ``rerun`` executable; looked up on ``PATH`` and beside the
        Python interpreter if None.

    Returns
    -------
    process : subprocess.Popen
        The viewer process.
    url : str
        Its gRPC proxy URL, ``rerun+http://127.0.0.1:<port>/proxy``, for
        :class:`rerun.GrpcSink`.

    Raises
    ------
    RuntimeError
        No ``rerun`` executable; the viewer exited before accepting
        connections (the message quotes the end of its stderr); or it did
        not accept a connection within ``timeout_s`` (it is then killed, with
        its process group).
    """
    import os
    import socket
    import subprocess
    import tempfile
    import time

    exe = executable or _viewer_executable()
    if exe is None:
        raise RuntimeError("the rerun viewer executable is not on PATH")
    port = _free_loopback_port() if port is None else port
    cmd = viewer_command(port, executable=exe, headless=headless)
    env = dict(os.environ, RERUN_APP_ONLY="true")  # as rerun's spawn: no analytics prompt
    with tempfile.TemporaryFile() as log:
        proc = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=log,
                                env=env, start_new_session=True)
        deadline = time.monotonic() + float(timeout_s)
        while True:
            try:
                with socket.create_connection((VIEWER_BIND_ADDRESS, port), timeout=0.5):
                    break
            except OSError:
                pass
            if proc.poll() is not None:
                log.seek(0)
                tail = log.read().decode("utf-8", "replace").strip().splitlines()[-3:]
                raise RuntimeError(f"the rerun viewer exited with status {proc.returncode} before "
                                   f"accepting connections on {VIEWER_BIND_ADDRESS}:{port}: "
                                   + " | ".join(tail))
            if time.monotonic() > deadline:
                _kill_group(proc)
                raise RuntimeError(f"the rerun viewer did not accept connections on "
                                   f"{VIEWER_BIND_ADDRESS}:{port} within {timeout_s} s")
            time.sleep(0.05)
    return proc, f"rerun+http://{VIEWER_BIND_ADDRESS}:{port}/proxy"


def viewer_unavailable_reason() -> str | None:
    """Why a live rerun viewer (``spawn=True``) cannot be started here, or None if it can be tried.

    Checked before a run starts (``vlab experiment --spawn``), so that a run
    is not done only to fail when the viewer is spawned: on Linux and other
    X11/Wayland systems a display (``DISPLAY`` or ``WAYLAND_DISPLAY``) is
    needed, and on every system the ``rerun`` viewer executable (on ``PATH``
    or beside the Python interpreter).

    Returns
    -------
    str or None
        A one-line reason, or None.
    """
    import os
    import sys

    if sys.platform.startswith(("linux", "freebsd", "openbsd", "netbsd")) and not (
            os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        return "no display: neither DISPLAY nor WAYLAND_DISPLAY is set"
    if _viewer_executable() is None:
        return "the rerun viewer executable is not on PATH"
    return None
