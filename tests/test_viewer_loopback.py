"""The rerun viewer that ``vlab experiment --spawn`` starts listens on the loopback address only.

rerun-sdk 0.41's own ``RecordingStream.spawn`` starts ``rerun --port P`` and
the viewer's gRPC server then listens on 0.0.0.0 (``rerun --help``: "--bind
... [default: 0.0.0.0]"). vlab starts the viewer itself with
``--bind 127.0.0.1``.
"""

from __future__ import annotations

import ipaddress
import socket
import subprocess

import pytest

from vlab.viz import rerun_log, viewer


class _FakeViewer:
    """Stands in for ``subprocess.Popen``: records the command line and listens where it says."""

    calls: list[list[str]] = []

    def __init__(self, cmd, **kwargs):
        type(self).calls.append(list(cmd))
        self.kwargs = kwargs
        bind = cmd[cmd.index("--bind") + 1] if "--bind" in cmd else "0.0.0.0"
        port = int(cmd[cmd.index("--port") + 1])
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self.sock.bind((bind, port))
        self.sock.listen()
        self.pid = -1
        self.returncode = None

    def poll(self):
        return None


@pytest.fixture
def fake_viewer(monkeypatch):
    import rerun as rr

    _FakeViewer.calls = []
    sdk_spawns = []
    monkeypatch.setattr(subprocess, "Popen", _FakeViewer)
    # rerun's own spawn (listens on 0.0.0.0) must not be used
    monkeypatch.setattr(rr.RecordingStream, "spawn", lambda self, **kw: sdk_spawns.append(kw))
    monkeypatch.setattr(viewer, "_viewer_executable", lambda: "/opt/fake/rerun", raising=False)
    monkeypatch.setattr(rr.RecordingStream, "disconnect", lambda self: None)
    monkeypatch.setattr(rr.RecordingStream, "flush", lambda self, **kw: None)
    sinks = {}
    monkeypatch.setattr(rr.RecordingStream, "set_sinks",
                        lambda self, *s, **kw: sinks.setdefault("types", [type(x).__name__ for x in s]))
    return _FakeViewer, sdk_spawns, sinks


def test_spawned_viewer_command_binds_loopback(tmp_path, fake_viewer):
    fake, sdk_spawns, sinks = fake_viewer
    rerun_log.log_experiment(tmp_path / "s.rrd", metadata={"a": 1}, spawn=True)
    assert sdk_spawns == []
    assert len(fake.calls) == 1
    cmd = fake.calls[0]
    assert cmd[0] == "/opt/fake/rerun"
    assert cmd[cmd.index("--bind") + 1] == "127.0.0.1"
    assert 1 <= int(cmd[cmd.index("--port") + 1]) <= 65535
    assert sinks["types"] == ["GrpcSink", "FileSink"]


def test_spawn_viewer_url_and_errors(monkeypatch, fake_viewer):
    fake, _, _ = fake_viewer
    proc, url = viewer.spawn_viewer(port=None, timeout_s=5.0)
    port = int(fake.calls[-1][fake.calls[-1].index("--port") + 1])
    assert url == f"rerun+http://127.0.0.1:{port}/proxy"
    assert proc.kwargs["start_new_session"] is True
    proc.sock.close()
    with pytest.raises(ValueError, match="port"):
        viewer.viewer_command(0)
    monkeypatch.setattr(viewer, "_viewer_executable", lambda: None)
    with pytest.raises(RuntimeError, match="not on PATH"):
        viewer.spawn_viewer()


def test_viewer_that_exits_gives_runtime_error(monkeypatch):
    monkeypatch.setattr(viewer, "viewer_command",
                        lambda port, **kw: ["sh", "-c", "echo 'no render context' >&2; exit 3"])
    with pytest.raises(RuntimeError, match="status 3.*no render context"):
        viewer.spawn_viewer(executable="sh", timeout_s=5.0)


def _listening(pid: int) -> list[tuple[str, int]]:
    psutil = pytest.importorskip("psutil")
    try:
        root = psutil.Process(pid)
        procs = [root, *root.children(recursive=True)]
    except psutil.NoSuchProcess:
        return []
    out = []
    for p in procs:
        try:
            out += [(c.laddr.ip, c.laddr.port) for c in p.net_connections(kind="inet")
                    if c.status == psutil.CONN_LISTEN]
        except psutil.NoSuchProcess:
            pass
    return out


def test_real_headless_viewer_listens_on_loopback_only():
    """A real ``rerun --headless`` viewer: every socket it listens on is a loopback address."""
    if viewer._viewer_executable() is None:
        pytest.skip("no rerun viewer executable")
    try:
        proc, url = viewer.spawn_viewer(headless=True, timeout_s=20.0)
    except RuntimeError as exc:
        pytest.skip(f"a headless rerun viewer cannot start here: {exc}")
    try:
        port = int(url.rsplit(":", 1)[1].split("/")[0])
        addrs = _listening(proc.pid)
        if not addrs:
            pytest.skip("the headless viewer exited before its sockets could be read")
        assert (("127.0.0.1", port)) in addrs
        for ip, _ in addrs:
            assert ipaddress.ip_address(ip).is_loopback, f"viewer listens on {ip}: {addrs}"
    finally:
        viewer._kill_group(proc)
