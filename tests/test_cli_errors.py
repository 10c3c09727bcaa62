"""The CLI's single error path, its atomic outputs and the --spawn fallback."""

from __future__ import annotations

import hashlib
import os
import signal
from pathlib import Path

import pytest
from typer.testing import CliRunner

from vlab.cli import app
from vlab.errors import MeasurementError, OutputError, SimulationError, SpecError
from vlab.io.atomic import atomic_dir, atomic_file
from vlab.io.manifest import write_manifest

runner = CliRunner()


def _flat(text: str) -> str:
    return " ".join(text.split())


# ------------------------------------------------------------------ error path ---


@pytest.mark.parametrize("message", [
    "field 'structure.gravity': expected [list], got [0.0]",
    "noise.sigma_m_s must be finite, got [inf]",
    "value [bold]x[/bold] and [link=file:///etc]y[/link]",
])
def test_values_in_brackets_are_printed_verbatim(monkeypatch, message):
    """Rich markup must not eat values: the message appears character for character."""
    import vlab.models

    def boom(*a, **k):
        raise SpecError(message)

    monkeypatch.setattr(vlab.models, "nominal_fe_model", boom)
    res = runner.invoke(app, ["modes", "bcc"])
    assert res.exit_code == 2
    assert message in _flat(res.output), res.output
    assert "Traceback" not in res.output


@pytest.mark.parametrize("exc, code", [
    (SpecError("bad spec"), 2),
    (SimulationError("diverged at 1.2 s"), 1),
    (MeasurementError("too short"), 1),
    (OSError(28, "No space left on device", "out/x.uff"), 1),
    (MemoryError("Unable to allocate 149. GiB"), 1),
    (RuntimeError("something unexpected"), 1),
])
def test_exit_status_by_exception_class(monkeypatch, exc, code):
    import vlab.models

    def boom(*a, **k):
        raise exc

    monkeypatch.setattr(vlab.models, "nominal_fe_model", boom)
    res = runner.invoke(app, ["modes", "bcc"])
    assert res.exit_code == code, res.output
    assert "Traceback" not in res.output and len(res.output.strip().splitlines()) == 1, res.output
    assert res.output.startswith("error:")


def test_measurement_error_of_diagnose_is_bad_input(monkeypatch, tmp_path):
    import vlab.diagnose

    rec = tmp_path / "rec.uff"
    rec.write_text("x")

    def boom(*a, **k):
        raise MeasurementError(f"{rec}: channel vel6 has 100 NaN samples")

    monkeypatch.setattr(vlab.diagnose, "diagnose", boom)
    res = runner.invoke(app, ["diagnose", "--structure", "bcc", "--recording", str(rec), "--out",
                              str(tmp_path / "d"), "--json"])
    assert res.exit_code == 2 and "100 NaN samples" in _flat(res.output)
    assert not (tmp_path / "d").exists() and [p.name for p in tmp_path.iterdir()] == ["rec.uff"]


def test_debug_shows_the_traceback(monkeypatch):
    import vlab.models

    def boom(*a, **k):
        raise RuntimeError("something unexpected")

    monkeypatch.setattr(vlab.models, "nominal_fe_model", boom)
    res = runner.invoke(app, ["--debug", "modes", "bcc"])
    assert isinstance(res.exception, RuntimeError)  # propagates: the traceback is shown


def test_help_documents_the_exit_status():
    res = runner.invoke(app, ["--help"])
    assert res.exit_code == 0 and "Exit status" in res.output and "130 interrupted" in _flat(res.output)


# ------------------------------------------------------------------ atomic outputs ---


def _tree(folder: Path) -> dict[str, str]:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def _old_output(out: Path) -> Path:
    """``out`` made a previous vlab output folder (files and manifest): the only kind --overwrite replaces."""
    out.mkdir()
    (out / "old.txt").write_text("old")
    (out / "results.json").write_text("{}")
    write_manifest(out)
    return out


def test_atomic_dir_failure_leaves_the_old_folder(tmp_path):
    out = _old_output(tmp_path / "out")
    before = _tree(out)
    with pytest.raises(KeyboardInterrupt):
        with atomic_dir(out, overwrite=True) as tmp:
            (tmp / "new.txt").write_text("half")
            raise KeyboardInterrupt
    assert _tree(out) == before and sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_a_dropped_interrupt_is_honoured_at_the_commit(tmp_path):
    """A Ctrl-C recorded but never raised where it landed (Python drops a KeyboardInterrupt raised in a
    garbage-collection callback): the folder and the file are not committed, the old ones stay."""
    from vlab.io.atomic import clear_interrupt_request, request_interrupt

    out = _old_output(tmp_path / "out")
    before = _tree(out)
    try:
        with pytest.raises(KeyboardInterrupt):
            with atomic_dir(out, overwrite=True) as tmp:
                (tmp / "new.txt").write_text("complete")
                request_interrupt()
        with pytest.raises(KeyboardInterrupt):
            with atomic_file(tmp_path / "x.txt") as tmp:
                tmp.write_text("complete")
    finally:
        clear_interrupt_request()
    assert _tree(out) == before and sorted(p.name for p in tmp_path.iterdir()) == ["out"]
    with atomic_file(tmp_path / "x.txt") as tmp:  # cleared: written again
        tmp.write_text("complete")
    assert (tmp_path / "x.txt").read_text() == "complete"


class _DropsAnInterrupt:
    """Sends SIGINT from a finaliser: the handler's KeyboardInterrupt is raised inside ``__del__``, where
    Python can only print "Exception ignored" and go on (what a garbage-collection callback does)."""

    def __del__(self):
        os.kill(os.getpid(), signal.SIGINT)
        sum(range(1000))  # the handler runs here, inside the finaliser


@pytest.mark.skipif(not hasattr(signal, "pthread_sigmask"), reason="POSIX signals")
def test_a_command_whose_interrupt_was_dropped_ends_as_interrupted(tmp_path, monkeypatch):
    import vlab.sim

    real = vlab.sim.build_plant

    def dropped(spec):
        _DropsAnInterrupt()
        return real(spec)

    monkeypatch.setattr(vlab.sim, "build_plant", dropped)
    path = tmp_path / "bcc.xml"
    res = runner.invoke(app, ["export-mjcf", "bcc", "-o", str(path)])
    assert res.exit_code == 130 and res.output == "interrupted: nothing written\n", res.output
    assert list(tmp_path.iterdir()) == []
    from vlab.io.atomic import atomic_file, interrupt_requested

    assert not interrupt_requested()  # the command's record does not outlive it: in-process writes go on
    with atomic_file(tmp_path / "after.txt") as tmp:
        tmp.write_text("written")
    (tmp_path / "after.txt").unlink()
    monkeypatch.setattr(vlab.sim, "build_plant", real)
    res = runner.invoke(app, ["export-mjcf", "bcc", "-o", str(path)])  # the next command starts clean
    assert res.exit_code == 0 and path.exists(), res.output


def test_atomic_dir_overwrite_replaces_whole_and_refuses_without(tmp_path):
    out = _old_output(tmp_path / "out")
    with pytest.raises(OutputError, match="--overwrite"):
        with atomic_dir(out) as tmp:
            pass
    with atomic_dir(out, overwrite=True) as tmp:
        (tmp / "new.txt").write_text("new")
    assert sorted(p.name for p in out.iterdir()) == ["new.txt", "vlab-manifest.json"]
    mask = os.umask(0)
    os.umask(mask)
    fresh = tmp_path / "fresh"
    fresh.mkdir()  # the permissions a plain mkdir gives
    assert out.stat().st_mode & 0o777 == fresh.stat().st_mode & 0o777 == 0o777 & ~mask
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fresh", "out"]


def test_atomic_file_and_missing_parent(tmp_path):
    target = tmp_path / "x.xml"
    target.write_text("old")
    with pytest.raises(OutputError, match="exists"):
        with atomic_file(target) as tmp:
            pass
    with atomic_file(target, overwrite=True) as tmp:
        tmp.write_text("new")
    assert target.read_text() == "new"
    mask = os.umask(0)
    os.umask(mask)
    assert target.stat().st_mode & 0o777 == 0o666 & ~mask
    with pytest.raises(OutputError, match="does not exist"):
        with atomic_file(tmp_path / "nope" / "x.xml") as tmp:
            pass
    assert not (tmp_path / "nope").exists()


def test_export_mjcf_overwrite(tmp_path):
    path = tmp_path / "bcc.xml"
    path.write_text("mine")
    res = runner.invoke(app, ["export-mjcf", "bcc", "-o", str(path)])
    assert res.exit_code == 2 and path.read_text() == "mine"
    res = runner.invoke(app, ["export-mjcf", "bcc", "-o", str(path), "--overwrite"])
    assert res.exit_code == 0, res.output
    assert "<mujoco" in path.read_text() and sorted(p.name for p in tmp_path.iterdir()) == ["bcc.xml"]


# ------------------------------------------------------------------ --spawn ---


@pytest.fixture(scope="module")
def short_run():
    from vlab.experiment.config import ExperimentConfig
    from vlab.experiment.runner import run_experiment
    from vlab.models import nominal_fe_model

    cfg = ExperimentConfig(structure="bcc", controller="none", plant="linear", resolution_hz=0.25, duration_s=8.0)
    return run_experiment(cfg, nominal_fe_model("bcc"))


@pytest.mark.slow
def test_spawn_failure_keeps_the_outputs(short_run, tmp_path, monkeypatch):
    """A viewer that cannot be reached after the run: every output is still written, with a warning."""

    import vlab.experiment.runner as ex

    monkeypatch.setenv("DISPLAY", ":99")
    monkeypatch.setattr(ex, "run_experiment", lambda cfg, fe, **kw: short_run)

    def no_viewer(**kw):
        raise RuntimeError("the rerun viewer exited with status 1 before accepting connections on 127.0.0.1:9876")

    # the viewer is started by vlab's own spawn_viewer (never rerun's RecordingStream.spawn); whether a real
    # viewer starts without a display depends on the machine, so the failure is made here, where it would occur
    import vlab.viz.rerun_log as rlog
    import vlab.viz.viewer as rl

    monkeypatch.setattr(rlog, "spawn_viewer", no_viewer)
    monkeypatch.setattr(rl, "viewer_unavailable_reason", lambda: None)
    out = tmp_path / "o"
    res = runner.invoke(app, ["experiment", "bcc", "--controller", "none", "--plant", "linear", "--spawn",
                              "--duration", "40", "--out", str(out), "--allow-unstable"])
    assert res.exit_code == 0, res.output
    assert "rerun viewer could not be started" in _flat(res.output)
    assert {"recording.uff", "frf.uff", "results.json", "report.md", "frf.png", "run.rrd"} <= {
        p.name for p in out.iterdir()}
    assert (out / "run.rrd").stat().st_size > 0


def test_overwrite_never_deletes_a_folder_vlab_did_not_write_nor_a_parent_of_the_current_one(tmp_path, monkeypatch):
    """--overwrite replaced any folder, a parent of the current one included (review: a run with --out set to
    the parent deleted the user's files there and the current folder itself)."""
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "precious.txt").write_text("keep")
    with pytest.raises(OutputError, match="not proven a vlab output folder"):
        with atomic_dir(mine, overwrite=True):
            pass
    assert (mine / "precious.txt").read_text() == "keep"
    here = tmp_path / "a" / "b"
    here.mkdir(parents=True)
    (tmp_path / "a" / "results.json").write_text("{}")
    monkeypatch.chdir(here)
    for target in (tmp_path / "a", Path("..")):
        with pytest.raises(OutputError, match="parents"):
            with atomic_dir(target, overwrite=True):
                pass
    assert here.is_dir() and (tmp_path / "a" / "results.json").exists()


@pytest.mark.slow
def test_an_experiment_whose_loop_is_predicted_unstable_exits_1_unless_allowed(tmp_path):
    """A delay of 1e5 sampling periods (50 s, longer than a 20 s record) makes the analysis predict negative damping: the
    premise of the comparison fails, so the run says why and exits 1; --allow-unstable exits 0 (outputs kept)."""
    out = tmp_path / "out"
    args = ["experiment", "bcc", "--plant", "linear", "--delay-periods", "1e5", "--out", str(out)]
    res = runner.invoke(app, args)
    flat = _flat(res.output)
    assert res.exit_code == 1, res.output
    assert "predicted unstable" in flat and "delay 100000 samples" in flat and "at least one record" in flat
    import json

    warnings = json.loads((out / "results.json").read_text())["warnings"]
    assert any("predicted unstable" in w for w in warnings) and any("at least one record" in w for w in warnings)
    res = runner.invoke(app, [*args, "--overwrite", "--allow-unstable"])
    assert res.exit_code == 0, res.output
    assert "predicted unstable" in _flat(res.output)


def test_allow_outside_inputs_is_explicit_and_does_not_outlive_the_command(tmp_path, monkeypatch):
    """A [reference] outside the structure's folder is refused; `vlab --allow-outside-inputs` reads it (here a
    table beside, in a sibling folder); the allowance ends with the command."""
    import shutil

    from vlab.io.confine import ALLOW_ENV
    from vlab.spec import DATA_DIR, STRUCTURES_DIR

    monkeypatch.delenv(ALLOW_ENV, raising=False)
    (tmp_path / "tables").mkdir()
    (tmp_path / "model").mkdir()
    shutil.copy(DATA_DIR / "table1_bcc_frequencies.csv", tmp_path / "tables" / "f.csv")
    text = (STRUCTURES_DIR / "bcc.toml").read_text().replace('frequencies = "table1_bcc_frequencies.csv"',
                                                             'frequencies = "../tables/f.csv"')
    toml = tmp_path / "model" / "mine.toml"
    toml.write_text(text)
    res = runner.invoke(app, ["modes", str(toml), "--n", "2"])
    assert res.exit_code == 2 and "reaches outside" in _flat(res.output) and "--allow-outside-inputs" in res.output
    res = runner.invoke(app, ["--allow-outside-inputs", "modes", str(toml), "--n", "2"])
    assert res.exit_code == 0, res.output
    assert ALLOW_ENV not in os.environ
    res = runner.invoke(app, ["modes", str(toml), "--n", "2"])
    assert res.exit_code == 2
