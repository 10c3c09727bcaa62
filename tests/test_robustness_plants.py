"""The robustness study per plant: self-excitation on MuJoCo, Wilson intervals, the scheduler checks, the help."""

from __future__ import annotations

import re
import socket
import threading
import time

import numpy as np
import pytest

from vlab.errors import OptionError
from vlab.robust.plants import binomial_ci, mujoco_statistics, per_plant
from vlab.robust.scheduler import SchedulerError, check_scheduler, parse_samples, parse_scheduler
from vlab.robust.study import StudyConfig, nominal_analysis, run_study, summarize


@pytest.fixture(scope="module")
def lqg_study():
    cfg = StudyConfig(n_samples=3, chunk_size=3, controllers=("lqg",), seed=3)
    nominal = nominal_analysis(cfg)
    _, res = run_study(cfg, nominal=nominal)
    return cfg, nominal, res


def test_self_excited_lqg_sample_is_unstable_on_mujoco_and_left_out(lqg_study):
    """A perturbed LQG sample whose FE loop is stable but whose MuJoCo run self-excites (spillover into a
    residual mode near 50 Hz, above the 25 Hz band) is counted unstable on MuJoCo, its peak ratios are
    NaN, and the MuJoCo statistics use none of them."""
    from vlab.robust.simulate import simulate_samples

    cfg, nominal, res = lqg_study
    assert np.all(res["lqg/spectral_radius"] < 1.0)  # stable on the FE model
    chk = simulate_samples(cfg, nominal, "lqg", [0], worst=[False], random=[True], seed=1)
    assert not chk.predicted_unstable[0] and not chk.diverged[0]
    assert chk.unstable_on_plant[0]
    assert 40.0 < chk.oscillation_hz[0] < 60.0 and chk.power_above_band[0] > 0.9
    assert np.all(np.isnan(chk.peak_sim_over_linear[0])) and np.all(np.isnan(chk.peak_analysis_over_experiment[0]))
    assert chk.nominal.unstable and 40.0 < chk.nominal.frequency_hz < 60.0  # unstable at nominal too
    st = mujoco_statistics(chk, seed=0)
    assert st["probability_unstable"] == 1.0 and st["unstable_random_samples"] == 1
    assert st["peak_ratio_samples"] == 0 and st["peak_ratio_error_db_median"] is None
    assert st["working_loop_at_nominal"] is False
    plants = per_plant(summarize(cfg, nominal, res), [chk], cfg.n_samples, cfg.seed)
    assert plants["fe_sampled_loop"]["lqg"]["probability_unstable"] == 0.0
    assert plants["fe_sampled_loop"]["lqg"]["working_loop_at_nominal"] is True  # on the FE model it works
    assert plants["mujoco_time_simulation"]["lqg"]["probability_unstable"] == 1.0


def test_wilson_interval():
    """Wilson score interval: closed form at 0 events, inside [0, 1], symmetric under k -> n - k."""
    lo, hi = binomial_ci(0, 100)
    z = 1.959963984540054
    assert lo == 0.0 and hi == pytest.approx(z * z / (100 + z * z), rel=1e-9)
    a, b = binomial_ci(3, 20)
    c, d = binomial_ci(17, 20)
    assert 0 < a < 3 / 20 < b < 1 and a == pytest.approx(1 - d) and b == pytest.approx(1 - c)
    assert binomial_ci(0, 0) == [None, None]


def test_scheduler_addresses_and_sample_counts():
    assert parse_scheduler("none") is None and parse_scheduler("local") == "local"
    assert parse_scheduler("tcp://127.0.0.1:8786") == "tcp://127.0.0.1:8786"
    for bad in ("tcp://", "tcp://host", "tcp://host:0", "tcp://host:99999", "tcp://:8786", "udp://x:1"):
        with pytest.raises(OptionError, match=re.escape(repr(bad))):
            parse_scheduler(bad)
    assert parse_samples("1e7") == 10_000_000 and parse_samples("1000") == 1000
    for bad in ("0", "1.5", "x", "-3", "inf"):
        with pytest.raises(OptionError, match="--samples"):
            parse_samples(bad)


class SilentServer:
    """A TCP server on 127.0.0.1 that accepts connections and never answers; it stops by itself after
    ``life_s`` seconds (or on ``close``)."""

    def __init__(self, life_s: float = 30.0):
        self.sock = socket.socket()
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen(8)
        self.sock.settimeout(0.2)
        self.port = self.sock.getsockname()[1]
        self.conns = []
        self.stop = threading.Event()
        self.deadline = time.monotonic() + life_s
        self.thread = threading.Thread(target=self._serve, daemon=True)
        self.thread.start()

    def _serve(self):
        while not self.stop.is_set() and time.monotonic() < self.deadline:
            try:
                self.conns.append(self.sock.accept()[0])
            except OSError:
                pass
        for c in self.conns:
            c.close()
        self.sock.close()

    def close(self):
        self.stop.set()
        self.thread.join(5)


@pytest.mark.slow
def test_silent_scheduler_times_out_before_any_computation(tmp_path, monkeypatch):
    """``--scheduler tcp://...`` to a server that accepts and never answers: exit 1 within 10 s, before the designs."""
    from typer.testing import CliRunner

    import vlab.robust.pipeline as pipeline
    from vlab.cli import app

    def no_designs(cfg):
        raise AssertionError("the designs started before the scheduler answered")

    monkeypatch.setattr(pipeline, "nominal_analysis", no_designs)
    srv = SilentServer()
    try:
        t0 = time.monotonic()
        with pytest.raises(SchedulerError, match="no answer"):
            check_scheduler(f"tcp://127.0.0.1:{srv.port}", timeout_s=1.0)
        assert time.monotonic() - t0 < 3.0
        t0 = time.monotonic()
        res = CliRunner().invoke(app, ["robustness", "bcc", "--samples", "2", "--scheduler",
                                       f"tcp://127.0.0.1:{srv.port}", "--out", str(tmp_path / "o")])
        took = time.monotonic() - t0
    finally:
        srv.close()
    assert res.exit_code == 1, res.output
    assert "no answer from a Dask scheduler" in res.output and took <= 10.0
    assert not (tmp_path / "o").exists()


def test_command_input_errors_and_estimate(tmp_path):
    from typer.testing import CliRunner

    from vlab.cli import app

    res = CliRunner().invoke(app, ["robustness", "bcc", "--scheduler", "tcp://", "--out", str(tmp_path / "a")])
    assert res.exit_code == 2 and "'tcp://'" in res.output
    res = CliRunner().invoke(app, ["robustness", "bcc", "--samples", "1e7", "--out", str(tmp_path / "b")])
    assert res.exit_code == 2 and "--yes" in res.output and re.search(r"about [\d.]+ (h|days)", res.output)
    assert not (tmp_path / "b").exists()


def test_help_states_the_default_spreads():
    """The help gives the default spreads as numbers, the same as the defaults (vlab.robust.uncertainty)."""
    from typer.testing import CliRunner

    from vlab.cli import app
    from vlab.robust.uncertainty import describe

    res = CliRunner().invoke(app, ["robustness", "--help"], terminal_width=200)
    text = " ".join(re.sub(r"[│\s]+", " ", res.output).split())
    assert describe() in text, describe()
    assert "Sec. 5.3" in text and "Sec. 2.1" in text


@pytest.mark.slow
def test_limit_cycle_follows_the_residual_mode():
    """Nominal LQG on the MuJoCo BCC: a limit cycle near 50 Hz that a 5 % stiffer structure moves up and a
    5 % softer one down (the residual mode's frequency), more than the delay's or the filter's changes."""
    from vlab.robust.limit_cycle import limit_cycle_sensitivity

    cfg = StudyConfig(n_samples=1, controllers=("lqg",), seed=0)
    rows = limit_cycle_sensitivity(cfg, nominal_analysis(cfg), "lqg", seed=0)
    assert all(r["unstable"] for r in rows)
    by = {(r["quantity"], r["value"]): r for r in rows}
    assert 45.0 < by[("nominal", None)]["frequency_hz"] < 55.0
    soft, stiff = by[("bending_stiffness_factor", 0.95)]["shift_hz"], by[("bending_stiffness_factor", 1.05)]["shift_hz"]
    assert soft < 0 < stiff
    others = [abs(r["shift_hz"]) for r in rows if r["quantity"] in ("delay_periods", "filter_hz")]
    assert min(abs(soft), stiff) > max(others)


def _group_members(pgid: int) -> list[str]:
    """Command lines of the processes of process group ``pgid`` (Linux /proc)."""
    import os
    from pathlib import Path

    out = []
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                if os.getpgid(int(d.name)) == pgid:
                    out.append((d / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace"))
            except (OSError, ProcessLookupError):
                pass
    return out


@pytest.mark.slow
@pytest.mark.skipif(not __import__("pathlib").Path("/proc/self").exists(), reason="needs Linux /proc")
def test_ctrl_c_on_a_dask_run_prints_one_line(tmp_path):
    """Ctrl-C (SIGINT to the whole foreground group, as a terminal sends it) once the local workers run:
    exit 130 and one line on stderr (no worker tracebacks), no worker left behind."""
    import os
    import signal
    import subprocess
    import sys

    cmd = [sys.executable, "-c", "import signal; signal.signal(signal.SIGINT, signal.default_int_handler); "
           "from vlab.cli import app; app()", "robustness", "bcc", "--samples", "4000", "--workers", "2",
           "--simulate", "0", "--simulate-random", "0", "--quiet", "--out", str(tmp_path / "o")]
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1")
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
                         env=env, preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and sum("spawn_main" in c for c in _group_members(p.pid)) < 2:
            assert p.poll() is None, p.communicate()
            time.sleep(0.2)
        time.sleep(3.0)  # the chunks are running
        os.killpg(p.pid, signal.SIGINT)
        out, err = p.communicate(timeout=60)
    finally:
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGKILL)
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert p.returncode == 130, (out, err)
    assert len(lines) == 1 and lines[0].startswith("interrupted"), err
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline and [c for c in _group_members(p.pid) if "spawn_main" in c]:
        time.sleep(0.2)
    assert not [c for c in _group_members(p.pid) if "spawn_main" in c], _group_members(p.pid)
