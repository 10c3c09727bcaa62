"""Output folders are owned by their manifest: nothing vlab did not write is ever deleted, every file written
is listed, and a second concurrent run to the same folder fails at once."""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from vlab.cli import app
from vlab.errors import OutputError
from vlab.io.atomic import atomic_dir, check_output_dir
from vlab.io.manifest import (MANIFEST_NAME, acquire_lock, foreign_entries, read_manifest, release_lock,
                              write_manifest)

ROOT = Path(__file__).resolve().parents[1]


def _tree(folder: Path) -> dict[str, str]:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def _written(out: Path, name: str, text: str) -> Path:
    """``out`` as a vlab command leaves it: the one file ``name`` holding ``text``, and the manifest."""
    with atomic_dir(out) as tmp:
        (tmp / name).write_text(text)
    return out


def _assert_manifest_lists_everything(folder: Path) -> None:
    listed = read_manifest(folder)
    assert listed is not None, f"{folder} has no valid {MANIFEST_NAME}"
    on_disk = {k: v for k, v in _tree(folder).items() if k != MANIFEST_NAME}
    assert set(listed) == set(on_disk), (sorted(listed), sorted(on_disk))
    for rel, digest in on_disk.items():
        assert listed[rel]["sha256"] == digest and listed[rel]["size_bytes"] == (folder / rel).stat().st_size
    assert foreign_entries(folder) == []


# ------------------------------------------------------------------------------- the manifest's property ---
_names = st.text(alphabet="abcdefghijklmnopqrstuvwxyz0123456789_.-", min_size=1, max_size=12).filter(
    lambda s: s not in (".", "..") and s != MANIFEST_NAME)
_trees = st.dictionaries(st.lists(_names, min_size=1, max_size=3).map(tuple), st.binary(max_size=300),
                         min_size=0, max_size=8)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(tree=_trees)
def test_every_file_written_into_an_output_folder_is_in_its_manifest(tree, tmp_path_factory):
    """Whatever a command writes into :func:`atomic_dir`'s folder (any names, sub-folders, sizes), the manifest
    lists exactly those files with their sizes and hashes, and the folder can then be replaced."""
    base = tmp_path_factory.mktemp("prop")
    out = base / "out"
    written = {}
    with atomic_dir(out) as tmp:
        for parts, data in tree.items():
            p = tmp.joinpath(*parts)
            if any(q.is_file() for q in [tmp.joinpath(*parts[:i]) for i in range(1, len(parts))]) or p.is_dir():
                continue  # a name already used as a file (or a folder): not a tree
            p.parent.mkdir(parents=True, exist_ok=True)
            p.write_bytes(data)
            written["/".join(parts)] = data
    _assert_manifest_lists_everything(out)
    assert set(read_manifest(out)) == set(written)
    with atomic_dir(out, overwrite=True) as tmp:
        (tmp / "new.txt").write_text("new")
    assert sorted(p.name for p in out.iterdir()) == ["new.txt", MANIFEST_NAME]


@pytest.mark.slow
def test_an_experiment_lists_every_file_it_wrote(tmp_path):
    """A real command (an experiment on the linear plant): every file in its folder is in the manifest."""
    out = tmp_path / "exp"
    res = CliRunner().invoke(app, ["experiment", "bcc", "--plant", "linear", "--controller", "none",
                                   "--duration", "40", "--out", str(out), "--allow-unstable"])
    assert res.exit_code == 0, res.output
    _assert_manifest_lists_everything(out)
    assert {"results.json", "recording.uff", "recording.uff.json", "frf.uff", "report.md", "frf.png",
            "run.rrd"} <= set(read_manifest(out))
    # the same command again replaces it with --overwrite (the folder is proven vlab's) ...
    res = CliRunner().invoke(app, ["experiment", "bcc", "--plant", "linear", "--controller", "none",
                                   "--duration", "40", "--out", str(out), "--allow-unstable", "--overwrite"])
    assert res.exit_code == 0, res.output
    _assert_manifest_lists_everything(out)
    # ... but not once the user has put a file of their own there: it is named, and nothing changes
    (out / "thesis.tex").write_text("\\chapter{Results}\n")
    before = _tree(out)
    res = CliRunner().invoke(app, ["experiment", "bcc", "--plant", "linear", "--controller", "none",
                                   "--duration", "40", "--out", str(out), "--allow-unstable", "--overwrite"])
    assert res.exit_code == 2 and "thesis.tex" in res.output, res.output
    assert _tree(out) == before


# ------------------------------------------------------------------------------ foreign files survive ---
def test_a_folder_vlab_did_not_write_survives_overwrite(tmp_path):
    """A results.json beside the user's thesis.tex does not make a folder vlab's: --overwrite refuses it."""
    mine = tmp_path / "thesis"
    mine.mkdir()
    (mine / "results.json").write_text("{}")
    (mine / "thesis.tex").write_text("\\documentclass{book}")
    before = _tree(mine)
    with pytest.raises(OutputError, match=MANIFEST_NAME):
        with atomic_dir(mine, overwrite=True) as tmp:
            (tmp / "results.json").write_text("{}")
    assert _tree(mine) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["thesis"]  # no temporary folder left


def test_a_manifest_copied_into_a_users_folder_proves_nothing(tmp_path):
    """A manifest listing files whose hashes differ (a copy, or edited files) does not make them vlab's."""
    out = _written(tmp_path / "out", "report.md", "vlab's")
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "report.md").write_text("the user's")
    (mine / MANIFEST_NAME).write_bytes((out / MANIFEST_NAME).read_bytes())
    with pytest.raises(OutputError, match=r"report\.md \(changed since vlab wrote it\)"):
        check_output_dir(mine, overwrite=True)
    assert (mine / "report.md").read_text() == "the user's"


def test_a_file_added_while_the_run_writes_survives(tmp_path):
    """A foreign file that appears in the old folder after the check, while the new one is written: the old
    folder is checked again after it is renamed away, put back, and the run fails naming the file."""
    out = _written(tmp_path / "out", "results.json", "{}")
    with pytest.raises(OutputError, match="late.txt"):
        with atomic_dir(out, overwrite=True) as tmp:
            (tmp / "results.json").write_text('{"new": 1}')
            (out / "late.txt").write_text("written by the user meanwhile")
    assert (out / "late.txt").read_text() == "written by the user meanwhile"
    assert (out / "results.json").read_text() == "{}"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_a_file_added_between_the_last_check_and_the_rename_survives(tmp_path, monkeypatch):
    """The race after the last check: the old folder is checked again under its private name, after the rename
    away and before anything is deleted; it is put back whole."""
    import vlab.io.atomic as atomic

    out = _written(tmp_path / "out", "results.json", "{}")
    tmp = tmp_path / ".vlab-tmp-out-test"
    tmp.mkdir()
    (tmp / "results.json").write_text('{"new": 1}')
    write_manifest(tmp)
    (out / "late.txt").write_text("written by the user meanwhile")
    monkeypatch.setattr(atomic, "check_output_dir", lambda *a, **k: None)  # the file lands after the check
    with pytest.raises(OutputError, match="late.txt"):
        atomic._commit_dir(tmp, out, True)
    assert (out / "late.txt").read_text() == "written by the user meanwhile"
    assert (out / "results.json").read_text() == "{}"
    assert not any(p.name.startswith(".vlab-old-") for p in tmp_path.iterdir())


def test_links_and_folders_vlab_did_not_write_are_foreign(tmp_path):
    out = _written(tmp_path / "out", "a.txt", "a")
    (out / "link").symlink_to(tmp_path)
    (out / "sub").mkdir()
    assert foreign_entries(out) == ["link (not a regular file)", "sub/ (a folder vlab did not write)"]
    with pytest.raises(OutputError, match="link"):
        check_output_dir(out, overwrite=True)
    assert (out / "link").is_symlink() and (out / "sub").is_dir()


def test_a_symlink_as_out_is_named_a_link(tmp_path):
    (tmp_path / "real").mkdir()
    (tmp_path / "alias").symlink_to("real")
    with pytest.raises(OutputError, match="symbolic link"):
        check_output_dir(tmp_path / "alias")


def test_a_folder_holding_a_file_named_like_the_manifest_is_not_written(tmp_path):
    with pytest.raises(OutputError, match="reserved"):
        with atomic_dir(tmp_path / "out") as tmp:
            (tmp / MANIFEST_NAME).write_text("{}")
    assert not (tmp_path / "out").exists()


def test_write_manifest_refuses_links(tmp_path):
    (tmp_path / "x").symlink_to("/etc/passwd")
    with pytest.raises(OutputError, match="not regular files"):
        write_manifest(tmp_path)


# ------------------------------------------------------------------------------------------ the lock ---
HOLDER = """
import sys, time
from vlab.io.atomic import check_output_dir
check_output_dir(sys.argv[1])
print("locked", flush=True)
time.sleep(60)
"""


def test_a_second_concurrent_run_to_the_same_folder_fails_at_once(tmp_path):
    """Another process holds the new --out (a run in progress): a second run is refused at its check, before any
    work, naming the folder; once the first has ended the folder is free again."""
    out = tmp_path / "new_out"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    holder = subprocess.Popen([sys.executable, "-c", HOLDER, str(out)], stdout=subprocess.PIPE, text=True, env=env)
    try:
        assert holder.stdout.readline().strip() == "locked"
        t0 = time.perf_counter()
        res = CliRunner().invoke(app, ["experiment", "bcc", "--plant", "linear", "--out", str(out)])
        assert res.exit_code == 2, res.output
        assert "another vlab run is writing" in res.output and "new_out" in res.output
        assert time.perf_counter() - t0 < 10
        with pytest.raises(OutputError, match="another vlab run"):
            with atomic_dir(out):
                pass
    finally:
        holder.kill()
        holder.wait()
    assert not out.exists()
    with atomic_dir(out) as tmp:  # the lock died with its process
        (tmp / "a.txt").write_text("a")
    assert (out / "a.txt").exists()


def test_the_lock_is_released_after_writing_and_reentrant_in_one_process(tmp_path):
    out = tmp_path / "o"
    check_output_dir(out)
    check_output_dir(out)  # the same process: no self-conflict
    _written(out, "a", "a")
    code = ("import sys; from vlab.io.atomic import check_output_dir; "
            "check_output_dir(sys.argv[1], overwrite=True); print('ok')")
    res = subprocess.run([sys.executable, "-c", code, str(out)], capture_output=True, text=True,
                         env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert res.stdout.strip() == "ok", res.stderr
    acquire_lock(tmp_path / "p")
    release_lock(tmp_path / "p")
    release_lock(tmp_path / "never_locked")  # a no-op


def test_manifest_json_is_stable(tmp_path):
    with atomic_dir(tmp_path / "o") as tmp:
        (tmp / "b.txt").write_text("bb")
    doc = json.loads((tmp_path / "o" / MANIFEST_NAME).read_text())
    assert doc["format"] == "vlab output folder manifest" and doc["version"] == 1
    assert doc["files"] == {"b.txt": {"size_bytes": 2, "sha256": hashlib.sha256(b"bb").hexdigest()}}


@pytest.mark.parametrize("where", ["probe", "temporary folder", "temporary file"])
def test_an_interrupt_right_after_a_temporary_is_made_leaves_nothing_behind(tmp_path, monkeypatch, where):
    """SIGINT delivered the instant ``mkdtemp``/``mkstemp`` returns (the writability probe, the folder or the
    file being written) raises KeyboardInterrupt and leaves no ``.vlab-tmp-`` entry in the parent folder."""
    import signal
    import tempfile
    from vlab.io.atomic import atomic_file

    real = {"mkdtemp": tempfile.mkdtemp, "mkstemp": tempfile.mkstemp}

    def interrupted(name):
        def made(*args, **kwargs):
            out = real[name](*args, **kwargs)
            if ("probe" in kwargs.get("prefix", "")) == (where == "probe"):
                os.kill(os.getpid(), signal.SIGINT)  # Python raises it at its next check, unless held back
            return out
        return made

    monkeypatch.setattr(tempfile, "mkstemp" if where == "temporary file" else "mkdtemp",
                        interrupted("mkstemp" if where == "temporary file" else "mkdtemp"))
    with pytest.raises(KeyboardInterrupt):
        if where == "probe":
            check_output_dir(tmp_path / "out", lock=False)
        elif where == "temporary folder":
            with atomic_dir(tmp_path / "out"):
                pass
        else:
            with atomic_file(tmp_path / "f.txt"):
                pass
    monkeypatch.undo()
    assert [p.name for p in tmp_path.iterdir()] == []
