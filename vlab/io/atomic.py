"""Atomic outputs: every file and folder a command writes appears complete or not at all.

A command first checks its target (:func:`check_output_dir`,
:func:`check_output_file`) before any work starts, then writes into a
temporary sibling (same parent folder, so that :func:`os.replace` is an atomic
rename on one file system) and moves it into place only when complete
(:func:`atomic_dir`, :func:`atomic_file`). With ``overwrite`` an existing
target is renamed away, the new one renamed in, and only then the old one
deleted; an interrupt (Ctrl-C) during those renames is held back until they
are done, so that the target is always either the old one or the new one.

Rules (issue 26):

- an existing non-empty folder or an existing file is never replaced without
  ``overwrite``; an empty folder may be;
- parent folders are never created: the target's parent must exist (the
  commands' default ``out/...`` folders are the one exception, see
  :func:`check_output_dir` ``create_parent``);
- an empty path is refused, and so is a target whose kind does not match (a
  regular file where a folder is expected and vice versa).
"""

from __future__ import annotations

import os
import shutil
import signal
import tempfile
import threading
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

from ..errors import OutputError

TMP_PREFIX = ".vlab-tmp-"
OLD_PREFIX = ".vlab-old-"


def _nonempty(path: str | Path | None, option: str) -> Path:
    if path is None or str(path).strip() == "":
        raise OutputError(f"{option}: an empty path is not an output location; give a folder or file name")
    return Path(path)


#: Files by which a folder is known as a vlab output folder (experiment, reproduce, diagnose, robustness); only such a
#: folder (or an empty one) is replaced with ``--overwrite``: a folder of the user's own is never deleted.
OUTPUT_MARKERS = ("results.json", "reproduce.json", "diagnosis.json", "robustness.json")


def _absolute(path: Path) -> Path:
    """``path`` made absolute with ``..`` and symlinks resolved (``Path.absolute`` keeps ``..``)."""
    return Path(os.path.realpath(path))


def _check_parent(path: Path, option: str, create_parent: bool) -> None:
    parent = _absolute(path).parent
    if not parent.exists():
        if create_parent:  # created by atomic_dir when writing starts; its nearest existing ancestor must be writable
            while not parent.exists():
                parent = parent.parent
        else:
            raise OutputError(f"{option} {path}: the folder {parent} does not exist (parent folders are not "
                              "created; create it first)")
    if not parent.is_dir():
        raise OutputError(f"{option} {path}: {parent} is not a folder")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise OutputError(f"{option} {path}: the folder {parent} is not writable")


def check_output_dir(path: str | Path | None, *, overwrite: bool = False, option: str = "--out",
                     create_parent: bool = False) -> Path:
    """Check an output folder before any work starts.

    Parameters
    ----------
    path : str or Path
        The folder the command will write (created by :func:`atomic_dir`).
    overwrite : bool
        Whether an existing non-empty folder may be replaced (``--overwrite``).
    option : str
        The option name used in messages (``"--out"``).
    create_parent : bool
        Accept missing parent folders, which :func:`atomic_dir` creates when
        writing starts (only for a command's default output folder, never
        for a user-given one); the nearest existing ancestor must be writable.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    OutputError
        Empty path; the parent folder is missing, not a folder or not
        writable; ``path`` is a regular file (or other non-folder); ``path``
        is the current folder, one of its parents, the home folder or the
        root; ``path`` is a non-empty folder and ``overwrite`` is False, or
        it holds none of :data:`OUTPUT_MARKERS` (not a vlab output folder,
        never deleted).
    """
    p = _nonempty(path, option)
    if p.is_symlink() or (p.exists() and not p.is_dir()):
        raise OutputError(f"{option} {p}: is a file, not a folder; give a folder name")
    if p.is_dir():
        full, cwd = _absolute(p), _absolute(Path.cwd())
        if full == cwd or full in cwd.parents or full == _absolute(Path.home()) or full == Path(full.anchor):
            raise OutputError(f"{option} {p}: is the current folder, one of its parents, the home folder or the "
                              "root; give a folder of its own")
        if any(p.iterdir()):
            if not overwrite:
                raise OutputError(f"{option} {p}: the folder exists and is not empty; use --overwrite to replace "
                                  "it or choose another folder")
            if not any((p / m).is_file() for m in OUTPUT_MARKERS):
                raise OutputError(f"{option} {p}: the folder is not a vlab output folder (it holds none of "
                                  f"{', '.join(OUTPUT_MARKERS)}); --overwrite replaces only those: choose another "
                                  "folder")
    _check_parent(p, option, create_parent)
    return p


def check_output_file(path: str | Path | None, *, overwrite: bool = False, option: str = "--output",
                      suffix: str | None = None) -> Path:
    """Check an output file before any work starts.

    Parameters
    ----------
    path : str or Path
        The file the command will write (with :func:`atomic_file`).
    overwrite : bool
        Whether an existing file may be replaced (``--overwrite``).
    option : str
        The option name used in messages (``"--output"``).
    suffix : str, optional
        Required file suffix (e.g. ``".xml"``).

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    OutputError
        Empty path; wrong suffix; the parent folder is missing or not
        writable; ``path`` is a folder; ``path`` exists and ``overwrite`` is
        False.
    """
    p = _nonempty(path, option)
    if suffix is not None and p.suffix.lower() != suffix:
        raise OutputError(f"{option} {p}: expected a {suffix} file name, got suffix {p.suffix!r}")
    if p.is_dir():
        raise OutputError(f"{option} {p}: is a folder, not a file")
    if p.exists() and not overwrite:
        raise OutputError(f"{option} {p}: the file exists; use --overwrite to replace it")
    _check_parent(p, option, create_parent=False)
    return p


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


@contextmanager
def _interrupts_deferred() -> Iterator[None]:
    """Hold SIGINT back (main thread only) while the renames run."""
    if threading.current_thread() is not threading.main_thread() or not hasattr(signal, "pthread_sigmask"):
        yield
        return
    old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def _remove(path: Path) -> None:
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
    else:
        try:
            path.unlink()
        except FileNotFoundError:
            pass


@contextmanager
def atomic_dir(target: str | Path, *, overwrite: bool = False, create_parent: bool = False) -> Iterator[Path]:
    """Write a folder atomically: yield a temporary sibling, move it into place on success.

    Parameters
    ----------
    target : str or Path
        The final folder; its parent must exist (:func:`check_output_dir`).
    overwrite : bool
        Replace an existing non-empty folder (renamed away first, deleted
        after the new one is in place).
    create_parent : bool
        Create the missing parent folders first (a command's default output
        folder only).

    Yields
    ------
    Path
        The temporary folder to write into (``.vlab-tmp-<name>-XXXX`` beside
        ``target``). On any exception, ``KeyboardInterrupt`` included, it is
        deleted and ``target`` is left untouched.

    Raises
    ------
    OutputError
        As :func:`check_output_dir`, checked again when committing (the
        target appeared meanwhile).
    """
    check_output_dir(target, overwrite=overwrite, create_parent=create_parent)
    target = _absolute(Path(target))
    if create_parent:
        try:
            target.absolute().parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise OutputError(f"{target}: cannot create the folder {target.absolute().parent} ({exc.strerror})") from None
    tmp = Path(tempfile.mkdtemp(prefix=f"{TMP_PREFIX}{target.name}-", dir=target.absolute().parent))
    os.chmod(tmp, 0o777 & ~_umask())  # mkdtemp's 0700 -> what mkdir would give
    try:
        yield tmp
        with _interrupts_deferred():
            check_output_dir(target, overwrite=overwrite)
            old = None
            if target.exists():
                old = Path(tempfile.mkdtemp(prefix=f"{OLD_PREFIX}{target.name}-", dir=target.absolute().parent))
                os.replace(target, old)  # replaces the empty placeholder folder
            os.replace(tmp, target)
            if old is not None:  # still deferred: an interrupt now leaves no .vlab-old- folder behind
                _remove(old)
    except BaseException:
        _remove(tmp)
        raise


@contextmanager
def atomic_file(target: str | Path, *, overwrite: bool = False) -> Iterator[Path]:
    """Write a file atomically: yield a temporary sibling path, rename it onto ``target`` on success.

    Parameters
    ----------
    target : str or Path
        The final file; its parent must exist (:func:`check_output_file`).
    overwrite : bool
        Replace an existing file.

    Yields
    ------
    Path
        The temporary file path (``.vlab-tmp-<name>-XXXX<suffix>`` beside
        ``target``). It is deleted on any exception.

    Raises
    ------
    OutputError
        As :func:`check_output_file`, checked again when committing.
    """
    check_output_file(target, overwrite=overwrite, option="output")
    target = _absolute(Path(target))
    fd, name = tempfile.mkstemp(prefix=f"{TMP_PREFIX}{target.name}-", suffix=target.suffix,
                                dir=target.absolute().parent)
    os.close(fd)
    tmp = Path(name)
    os.chmod(tmp, 0o666 & ~_umask())  # mkstemp's 0600 -> what open() would give
    try:
        yield tmp
        with _interrupts_deferred():
            if target.exists() and not overwrite:
                raise OutputError(f"{target}: the file appeared while writing; use --overwrite to replace it")
            os.replace(tmp, target)
    except BaseException:
        _remove(tmp)
        raise
