"""Atomic outputs: every file and folder a command writes appears complete or not at all.

A command first checks its target (:func:`check_output_dir`,
:func:`check_output_file`) before any work starts, then writes into a
temporary sibling (same parent folder, so that :func:`os.replace` is an atomic
rename on one file system) and moves it into place only when complete
(:func:`atomic_dir`, :func:`atomic_file`). With ``overwrite`` an existing
target is renamed away, the new one renamed in, and only then the old one
deleted; an interrupt (Ctrl-C) during those renames is held back until they
are done, so that the target is always either the old one or the new one.

Rules:

- an existing non-empty folder or an existing file is never replaced without
  ``overwrite``; an empty folder may be;
- with ``overwrite`` a folder is replaced only when it is proven vlab's own:
  its manifest (:mod:`vlab.io.manifest`) lists every file in it with its size
  and SHA-256; anything else is refused, naming the foreign files, and only
  the listed files are ever deleted. Every folder written here gets such a
  manifest. Folders without one (written before it existed) are refused;
- a second run writing the same folder at the same time is refused at its
  check (:func:`vlab.io.manifest.acquire_lock`), before any work;
- an interrupt the program could not raise where it landed (Python drops a
  ``KeyboardInterrupt`` raised inside a garbage-collection callback as
  "Exception ignored"; a library may swallow it) is recorded by the caller's
  SIGINT handler (:func:`request_interrupt`) and honoured at the commit: the
  temporary output is discarded and the target left as it was;
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
import warnings
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

from ..errors import OutputError
from .manifest import MANIFEST_NAME, acquire_lock, ownership_problem, release_lock, remove_owned, write_manifest

TMP_PREFIX = ".vlab-tmp-"
OLD_PREFIX = ".vlab-old-"


def _nonempty(path: str | Path | None, option: str) -> Path:
    if path is None or str(path).strip() == "":
        raise OutputError(f"{option}: an empty path is not an output location; give a folder or file name")
    return Path(path)




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
    try:  # os.access trusts the permission bits (root passes on /proc, a read-only mount): try it
        with _interrupts_deferred():  # an interrupt between making and removing the probe would leave it behind
            os.rmdir(tempfile.mkdtemp(prefix=f"{TMP_PREFIX}probe-", dir=parent))
    except OSError as exc:
        raise OutputError(f"{option} {path}: nothing can be written into the folder {parent} "
                          f"({exc.strerror or exc})") from None


def check_output_dir(path: str | Path | None, *, overwrite: bool = False, option: str = "--out",
                     create_parent: bool = False, lock: bool = True) -> Path:
    """Check an output folder before any work starts, and hold its lock.

    Parameters
    ----------
    path : str or Path
        The folder the command will write (created by :func:`atomic_dir`).
    overwrite : bool
        Whether an existing non-empty folder may be replaced (``--overwrite``);
        only a folder proven vlab's by its manifest
        (:func:`vlab.io.manifest.ownership_problem`) is.
    option : str
        The option name used in messages (``"--out"``).
    create_parent : bool
        Accept missing parent folders, which :func:`atomic_dir` creates when
        writing starts (only for a command's default output folder, never
        for a user-given one); the nearest existing ancestor must be writable.
    lock : bool
        Take the folder's lock (:func:`vlab.io.manifest.acquire_lock`), held
        until :func:`atomic_dir` has moved the folder into place or the
        process ends.

    Returns
    -------
    Path
        ``path`` as a Path: the folder, checked (and locked when ``lock``).

    Raises
    ------
    OutputError
        Empty path; the parent folder is missing, not a folder or not
        writable; ``path`` is a symbolic link, a regular file or another
        non-folder; ``path`` is the current folder, one of its parents, the
        home folder or the root; ``path`` is a non-empty folder and
        ``overwrite`` is False, or it is not proven vlab's (no valid
        manifest, or files the manifest does not list: named); another run
        holds the folder's lock.
    """
    p = _nonempty(path, option)
    if p.is_symlink():
        raise OutputError(f"{option} {p}: is a symbolic link (to {os.readlink(p)}); give the folder itself: vlab "
                          "replaces an output folder by renaming and would replace the link")
    if p.exists() and not p.is_dir():
        raise OutputError(f"{option} {p}: is a file, not a folder; give a folder name")
    if p.is_dir():
        full, cwd = _absolute(p), _absolute(Path.cwd())
        if full == cwd or full in cwd.parents or full == _absolute(Path.home()) or full == Path(full.anchor):
            raise OutputError(f"{option} {p}: is the current folder, one of its parents, the home folder or the "
                              "root; give a folder of its own")
        try:
            nonempty = any(p.iterdir())
        except OSError as exc:
            raise OutputError(f"{option} {p}: the folder cannot be read ({exc.strerror})") from None
        if nonempty:
            if not overwrite:
                raise OutputError(f"{option} {p}: the folder exists and is not empty; use --overwrite to replace "
                                  "it or choose another folder")
            why = ownership_problem(p)
            if why is not None:
                raise OutputError(f"{option} {p}: not replaced: {why}")
    _check_parent(p, option, create_parent)
    if lock:
        acquire_lock(p, option)
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
        ``path`` as a Path: the file, checked.

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


_INTERRUPT = {"requested": False}


def request_interrupt() -> None:
    """Record that the user asked to stop (Ctrl-C): no output is committed after this.

    Called by a SIGINT handler besides raising ``KeyboardInterrupt``, for the
    cases where that exception never reaches the program (see the module
    notes). Cleared by :func:`clear_interrupt_request`.
    """
    _INTERRUPT["requested"] = True


def clear_interrupt_request() -> None:
    """Forget an earlier :func:`request_interrupt` (a new command starts)."""
    _INTERRUPT["requested"] = False


def interrupt_requested() -> bool:
    """Whether :func:`request_interrupt` was called since the last :func:`clear_interrupt_request`."""
    return _INTERRUPT["requested"]


def _refuse_if_interrupted() -> None:
    """Raise ``KeyboardInterrupt`` (the temporary output is then discarded) when an interrupt is pending."""
    if _INTERRUPT["requested"]:
        raise KeyboardInterrupt


@contextmanager
def _interrupts_deferred() -> Iterator[None]:
    """Hold SIGINT back (main thread only) while a temporary is made or the renames run.

    The Python-level handler is swapped for one that only records the signal,
    and the recorded signal is handed to the original handler on leaving. A
    thread's signal mask would not do: the kernel delivers a process-directed
    SIGINT to any thread that does not block it (a library's worker thread),
    and Python then runs the handler in the main thread at once.
    """
    if threading.current_thread() is not threading.main_thread() or signal.getsignal(signal.SIGINT) is None:
        yield  # another thread cannot swap handlers; a handler installed outside Python cannot be restored
        return
    held: list[int] = []
    original = signal.signal(signal.SIGINT, lambda signum, frame: held.append(signum))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, original)
        if held:
            if callable(original):
                original(signal.SIGINT, None)
            elif original == signal.SIG_DFL:
                os.kill(os.getpid(), signal.SIGINT)


def _remove(path: Path) -> None:
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
    else:
        try:
            path.unlink()
        except FileNotFoundError:
            pass


def _temp_sibling(target: Path, prefix: str, *, folder: bool, suffix: str = "") -> Path:
    """A new temporary folder or file beside ``target``; OutputError naming ``target`` when it cannot be made."""
    try:
        if folder:
            return Path(tempfile.mkdtemp(prefix=f"{prefix}{target.name}-", dir=target.parent))
        fd, name = tempfile.mkstemp(prefix=f"{prefix}{target.name}-", suffix=suffix, dir=target.parent)
        os.close(fd)
        return Path(name)
    except OSError as exc:
        raise OutputError(f"{target}: cannot write into the folder {target.parent} "
                          f"({exc.strerror or exc})") from None


def _commit_dir(tmp: Path, target: Path, overwrite: bool) -> None:
    """Move ``tmp`` onto ``target``; an existing ``target`` is renamed away, checked again, and only its listed files deleted."""
    check_output_dir(target, overwrite=overwrite)
    old = None
    if target.exists():
        old = _temp_sibling(target, OLD_PREFIX, folder=True)
        os.replace(target, old)  # replaces the empty placeholder folder
        # checked again under the private name (nothing can be added there now): never delete a file not proven vlab's
        why = ownership_problem(old) if any(old.iterdir()) else None
        if why is not None:
            os.replace(old, target)
            raise OutputError(f"{target}: not replaced: {why}")
    os.replace(tmp, target)
    if old is not None:  # still deferred: an interrupt now leaves no .vlab-old- folder behind
        left = remove_owned(old)
        if left:
            warnings.warn(f"{old}: kept, it holds {', '.join(left[:10])} (not written by vlab)", stacklevel=3)


@contextmanager
def atomic_dir(target: str | Path, *, overwrite: bool = False, create_parent: bool = False) -> Iterator[Path]:
    """Write a folder atomically: yield a temporary sibling, move it into place on success with its manifest.

    Parameters
    ----------
    target : str or Path
        The final folder; its parent must exist (:func:`check_output_dir`).
    overwrite : bool
        Replace an existing non-empty folder proven vlab's by its manifest
        (renamed away first; after the new one is in place only the files
        its manifest lists are deleted).
    create_parent : bool
        Create the missing parent folders first (a command's default output
        folder only).

    Yields
    ------
    Path
        The temporary folder to write into (``.vlab-tmp-<name>-XXXX`` beside
        ``target``). On success :data:`vlab.io.manifest.MANIFEST_NAME` listing
        every file written is added before the folder is moved into place. On
        any exception, ``KeyboardInterrupt`` included, it is deleted and
        ``target`` is left untouched. The folder's lock is released either way.

    Raises
    ------
    OutputError
        As :func:`check_output_dir`, checked again when committing (the
        target appeared or changed meanwhile); the temporary folder cannot be
        made; a file written is a link or is named like the manifest.
    """
    try:
        check_output_dir(target, overwrite=overwrite, create_parent=create_parent)
        target = _absolute(Path(target))
        if create_parent:
            try:
                target.parent.mkdir(parents=True, exist_ok=True)
            except OSError as exc:
                raise OutputError(f"{target}: cannot create the folder {target.parent} ({exc.strerror})") from None
        tmp = None
        try:
            with _interrupts_deferred():  # an interrupt lands after tmp is set, so the except below removes it
                tmp = _temp_sibling(target, TMP_PREFIX, folder=True)
            os.chmod(tmp, 0o777 & ~_umask())  # mkdtemp's 0700 -> what mkdir would give
            yield tmp
            write_manifest(tmp)
            with _interrupts_deferred():
                _refuse_if_interrupted()
                _commit_dir(tmp, target, overwrite)
        except BaseException:
            if tmp is not None:
                _remove(tmp)
            raise
    finally:
        release_lock(target)


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
    tmp = None
    try:
        with _interrupts_deferred():  # an interrupt lands after tmp is set, so the except below removes it
            tmp = _temp_sibling(target, TMP_PREFIX, folder=False, suffix=target.suffix)
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp's 0600 -> what open() would give
        yield tmp
        with _interrupts_deferred():
            _refuse_if_interrupted()
            if target.exists() and not overwrite:
                raise OutputError(f"{target}: the file appeared while writing; use --overwrite to replace it")
            os.replace(tmp, target)
    except BaseException:
        if tmp is not None:
            _remove(tmp)
        raise
