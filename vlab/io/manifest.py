"""Ownership of output folders: the manifest of the files vlab wrote, and the lock of a folder being written.

Every output folder vlab writes (through :func:`vlab.io.atomic.atomic_dir`)
carries :data:`MANIFEST_NAME`, a JSON list of every file written into it:
its path relative to the folder, its size in bytes and its SHA-256. Only a
folder whose manifest lists every file in it, each with the recorded size and
hash, is proven vlab's and may be replaced with ``--overwrite``; anything
else there (a file not listed, a listed file changed since, a symbolic link,
a folder holding nothing listed) is the user's and is named in the refusal.

Folders written before the manifest existed have none and are refused: a
file named like one of vlab's outputs (``results.json``) is no proof that
vlab wrote it, so such a folder is never deleted (delete it by hand).

A second run writing the same output folder at the same time fails at once
(:func:`acquire_lock`): an exclusive ``flock`` on a lock file named after the
folder's absolute path, kept in a per-user folder of the system's temporary
folder (nothing is written beside the output folder). The lock is held from
the check before any work until the folder is in place (:func:`release_lock`),
and the operating system releases it when the process ends, however it ends.
"""

from __future__ import annotations

import errno
import hashlib
import json
import os
import stat
import tempfile
from pathlib import Path

from ..errors import OutputError

#: The manifest's file name inside an output folder.
MANIFEST_NAME = "vlab-manifest.json"
#: The manifest's ``format`` field (a folder whose manifest has another is not proven vlab's).
MANIFEST_FORMAT = "vlab output folder manifest"
MANIFEST_VERSION = 1
#: At most this many foreign files are named in a refusal.
NAMED_AT_MOST = 10


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _walk(folder: Path) -> tuple[list[str], list[str], list[str]]:
    """Regular files, other entries (links, devices, ...) and sub-folders of ``folder`` (relative POSIX paths).

    Symbolic links are never followed (a link to a folder is an "other" entry).
    """
    files, others, dirs = [], [], []
    for root, dirnames, filenames in os.walk(folder, followlinks=False):
        rel_root = Path(root).relative_to(folder)
        for name in list(dirnames):
            p = Path(root) / name
            if p.is_symlink():
                others.append((rel_root / name).as_posix())
                dirnames.remove(name)
            else:
                dirs.append((rel_root / name).as_posix())
        for name in filenames:
            mode = os.lstat(Path(root) / name).st_mode
            (files if stat.S_ISREG(mode) else others).append((rel_root / name).as_posix())
    return sorted(files), sorted(others), sorted(dirs)


def write_manifest(folder: str | Path) -> Path:
    """List every file in ``folder`` (recursively) in ``folder / MANIFEST_NAME``.

    Parameters
    ----------
    folder : str or Path
        The output folder just written (the temporary folder of
        :func:`vlab.io.atomic.atomic_dir`, before it is moved into place).

    Returns
    -------
    Path
        The manifest written: JSON ``{"format", "version", "files": {relative
        path: {"size_bytes", "sha256"}}}``.

    Raises
    ------
    OutputError
        ``folder`` holds something vlab does not write (a symbolic link, a
        device, a pipe) or already holds a file named :data:`MANIFEST_NAME`.
    """
    folder = Path(folder)
    files, others, _ = _walk(folder)
    if others:
        raise OutputError(f"{folder}: holds {', '.join(others)}, not regular files; an output folder holds "
                          "only the files its command wrote")
    if MANIFEST_NAME in files:
        raise OutputError(f"{folder / MANIFEST_NAME}: the manifest's name is reserved; a command wrote a file "
                          "of that name")
    entries = {rel: {"size_bytes": (folder / rel).stat().st_size, "sha256": _sha256(folder / rel)} for rel in files}
    path = folder / MANIFEST_NAME
    path.write_text(json.dumps({"format": MANIFEST_FORMAT, "version": MANIFEST_VERSION, "files": entries},
                               indent=1, sort_keys=True) + "\n")
    return path


def read_manifest(folder: str | Path) -> dict[str, dict] | None:
    """The files listed in ``folder``'s manifest, or None when it has no valid manifest.

    Parameters
    ----------
    folder : str or Path
        An existing folder.

    Returns
    -------
    dict or None
        Relative POSIX path -> ``{"size_bytes": int, "sha256": str}``; None
        when :data:`MANIFEST_NAME` is missing, not a regular file, not JSON
        or not of :data:`MANIFEST_FORMAT` (the folder is then not proven
        vlab's). No error is raised.
    """
    path = Path(folder) / MANIFEST_NAME
    try:
        if not stat.S_ISREG(os.lstat(path).st_mode) or path.stat().st_size > 16 * 2**20:
            return None
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(doc, dict) or doc.get("format") != MANIFEST_FORMAT or not isinstance(doc.get("files"), dict):
        return None
    files = doc["files"]
    for rel, entry in files.items():
        if (not isinstance(entry, dict) or not isinstance(entry.get("size_bytes"), int)
                or not isinstance(entry.get("sha256"), str) or Path(rel).is_absolute() or ".." in Path(rel).parts):
            return None
    return files


def foreign_entries(folder: str | Path) -> list[str] | None:
    """What in ``folder`` is not proven written by vlab; None when the folder has no valid manifest.

    Parameters
    ----------
    folder : str or Path
        As :func:`read_manifest`.

    Returns
    -------
    list of str or None
        Relative paths, each with the reason when it is not simply unlisted
        (``"results.json (changed since vlab wrote it)"``); empty when every
        file is listed in the manifest with its size and SHA-256 and nothing
        else is there. None without a valid manifest (:func:`read_manifest`).
    """
    folder = Path(folder)
    listed = read_manifest(folder)
    if listed is None:
        return None
    files, others, dirs = _walk(folder)
    out = [f"{rel} (not a regular file)" for rel in others]
    for rel in files:
        if rel == MANIFEST_NAME:
            continue
        entry = listed.get(rel)
        if entry is None:
            out.append(rel)
        elif (folder / rel).stat().st_size != entry["size_bytes"] or _sha256(folder / rel) != entry["sha256"]:
            out.append(f"{rel} (changed since vlab wrote it)")
    needed = {p.as_posix() for rel in listed for p in Path(rel).parents if p != Path(".")}
    out += [f"{rel}/ (a folder vlab did not write)" for rel in dirs if rel not in needed]
    return sorted(out)


def ownership_problem(folder: str | Path) -> str | None:
    """Why ``folder`` may not be replaced, or None when every entry in it is proven vlab's.

    Parameters
    ----------
    folder : str or Path
        An existing, non-empty folder.

    Returns
    -------
    str or None
        A sentence naming the manifest that is missing or the foreign files
        (at most :data:`NAMED_AT_MOST`, then a count); None when the folder
        may be replaced.
    """
    foreign = foreign_entries(folder)
    if foreign is None:
        return (f"it has no valid {MANIFEST_NAME}, the list of files vlab writes into every output folder "
                "(a folder written by an older vlab has none): it is not proven a vlab output folder and is "
                "never deleted; delete it yourself or choose another folder")
    if not foreign:
        return None
    named = ", ".join(foreign[:NAMED_AT_MOST]) + (f" and {len(foreign) - NAMED_AT_MOST} more"
                                                  if len(foreign) > NAMED_AT_MOST else "")
    return (f"it holds files vlab did not write ({named}); --overwrite replaces only a folder of vlab's own "
            f"files: move them away or choose another folder")


def remove_owned(folder: str | Path) -> list[str]:
    """Delete the files ``folder``'s manifest lists, the manifest, then the emptied folders.

    Nothing that is not listed is deleted: a folder still holding anything is
    left in place.

    Parameters
    ----------
    folder : str or Path
        A folder that :func:`ownership_problem` accepted (renamed to a
        private name first, so that nothing is added meanwhile).

    Returns
    -------
    list of str
        What is left (relative paths); empty when ``folder`` itself is gone.
    """
    folder = Path(folder)
    listed = read_manifest(folder) or {}
    for rel in listed:
        p = folder / rel
        if p.is_file() and not p.is_symlink():
            p.unlink()
    (folder / MANIFEST_NAME).unlink(missing_ok=True)
    _, _, dirs = _walk(folder)
    for rel in sorted(dirs, key=lambda r: r.count("/"), reverse=True):
        try:
            (folder / rel).rmdir()
        except OSError:
            pass
    try:
        folder.rmdir()
    except OSError:
        files, others, dirs = _walk(folder)
        return files + others + dirs
    return []


# ------------------------------------------------------------------------------------------ lock ---

_HELD: dict[str, int] = {}


def _lock_dir() -> Path:
    base = os.environ.get("XDG_RUNTIME_DIR") or tempfile.gettempdir()
    d = Path(base) / f"vlab-locks-{os.getuid() if hasattr(os, 'getuid') else 'user'}"
    d.mkdir(mode=0o700, exist_ok=True)
    return d


def _lock_path(target: Path) -> Path:
    key = os.path.realpath(target)
    return _lock_dir() / f"{hashlib.sha256(key.encode('utf-8', 'surrogateescape')).hexdigest()[:32]}.lock"


def acquire_lock(target: str | Path, option: str = "--out") -> None:
    """Hold the exclusive lock of the output folder ``target`` (kept until :func:`release_lock` or the process ends).

    Held again by the same process, it is a no-op.

    Parameters
    ----------
    target : str or Path
        The output folder (need not exist yet); its absolute path names the lock.
    option : str
        The option named in the message (``"--out"``).

    Raises
    ------
    OutputError
        Another process holds the lock: another vlab run is writing the same
        folder.
    """
    import fcntl

    key = os.path.realpath(target)
    if key in _HELD:
        return
    try:
        path = _lock_path(Path(key))
    except OSError:  # no usable temporary folder: run without a lock rather than refuse
        return
    while True:
        try:
            fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o600)
        except OSError:  # the lock folder is not usable: run without a lock rather than refuse
            return
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            os.close(fd)
            if exc.errno in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
                raise OutputError(f"{option} {target}: another vlab run is writing this folder now; wait for it "
                                  "to end or choose another folder") from None
            return  # locks not supported on this file system
        try:  # the file may have been unlinked by the previous holder between open and flock: retry on the new one
            if os.fstat(fd).st_ino == os.stat(path).st_ino:
                break
        except FileNotFoundError:
            pass
        os.close(fd)
    _HELD[key] = fd


def release_lock(target: str | Path | None = None) -> None:
    """Release the lock of ``target`` held by this process (every held lock when None); a no-op when none is held.

    Parameters
    ----------
    target : str or Path, optional
        The output folder given to :func:`acquire_lock`.
    """
    keys = list(_HELD) if target is None else [os.path.realpath(target)]
    for key in keys:
        fd = _HELD.pop(key, None)
        if fd is None:
            continue
        try:
            _lock_path(Path(key)).unlink(missing_ok=True)
        except OSError:
            pass
        os.close(fd)


__all__ = ["MANIFEST_NAME", "write_manifest", "read_manifest", "foreign_entries", "ownership_problem",
           "remove_owned", "acquire_lock", "release_lock"]
