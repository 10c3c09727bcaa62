"""Input files confined to their folder: a file named inside another input stays beside it.

A structure file's ``[reference]`` tables and an MJCF model's ``<include>``
files and assets are resolved inside the naming file's own folder (and, for
a structure file, the packaged data folder); a name that reaches outside
(an absolute path, ``..``, a symbolic link pointing away) is refused with a
message naming it, and so is anything but a regular file (``/dev/zero``, a
pipe) or a file over a size limit. The user allows names outside explicitly:
``vlab --allow-outside-inputs ...``, which sets the environment variable
:data:`ALLOW_ENV` to ``1`` (read by :func:`outside_allowed`). A text input is
read by :func:`read_utf8`, which names the line of a byte that is not UTF-8.
"""

from __future__ import annotations

import os
import stat
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Sequence

from ..errors import DataFileError

#: Environment variable that, set to ``1``, allows input files named outside their folder.
ALLOW_ENV = "VLAB_ALLOW_OUTSIDE_INPUTS"
#: Largest file an input may name (a data table, an MJCF include or asset) [bytes].
MAX_NAMED_BYTES = 64 * 2**20
#: Most MJCF files one model may include (nested includes counted).
MAX_INCLUDES = 200
#: MJCF ``<compiler>`` attributes naming a folder that asset file names are relative to.
MJCF_DIR_ATTRS = ("assetdir", "meshdir", "texturedir")


def outside_allowed(allow: bool | None = None) -> bool:
    """Whether input files named outside their folder are allowed.

    Parameters
    ----------
    allow : bool, optional
        An explicit choice; None reads :data:`ALLOW_ENV` (``"1"`` allows).

    Returns
    -------
    bool
    """
    if allow is not None:
        return bool(allow)
    return os.environ.get(ALLOW_ENV, "") == "1"


def read_utf8(path: Path, error: type[Exception], *, encoding: str = "utf-8", hint: str = "") -> str:
    """The text of an input file, decoded as UTF-8.

    Parameters
    ----------
    path : Path
        The file (its existence is the caller's to check, with its own message).
    error : type of Exception
        Raised, naming the file, where it cannot be read or is not UTF-8.
    encoding : {"utf-8", "utf-8-sig"}
        ``"utf-8-sig"`` also accepts (and drops) a byte-order mark.
    hint : str
        Appended to the message of a file that is not UTF-8 (e.g. ``"; TOML files must be UTF-8"``).

    Returns
    -------
    str

    Raises
    ------
    error
        ``"<path>: cannot be read: <reason>"``, or ``"<path>: line <n>: not UTF-8 text (byte <b> at offset
        <k>)<hint>"`` naming the first byte that does not decode.
    """
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise error(f"{path}: cannot be read: {exc.strerror or exc}") from None
    try:
        return raw.decode(encoding)
    except UnicodeDecodeError as exc:
        line = raw[:exc.start].count(b"\n") + 1
        raise error(f"{path}: line {line}: not UTF-8 text (byte {raw[exc.start:exc.start + 1]!r} at offset "
                    f"{exc.start}){hint}") from None


def _inside(path: Path, folder: Path) -> bool:
    return path == folder or folder in path.parents


def confined_file(name: str, folders: Sequence[Path], *, where: str, allow: bool | None = None,
                  max_bytes: int = MAX_NAMED_BYTES, error: type[Exception] = DataFileError) -> Path:
    """The regular file ``name`` names, resolved inside one of ``folders``.

    Parameters
    ----------
    name : str
        The file name as written in the naming file (relative, or absolute).
    folders : sequence of Path
        The folders it may be in, tried in order (a relative ``name`` is
        taken relative to each).
    where : str
        The naming file and field, for messages (``"bcc.toml: field
        'reference.frequencies'"``).
    allow : bool, optional
        Allow a file outside ``folders`` (None: :func:`outside_allowed`).
    max_bytes : int
        Largest size accepted [bytes].
    error : type
        The exception class raised (the naming file's own error class).

    Returns
    -------
    Path
        The file's real path (symbolic links resolved).

    Raises
    ------
    error
        ``name`` is empty; it reaches outside every folder of ``folders``
        (unless allowed; names it and the folders); it is missing, not a
        regular file or larger than ``max_bytes``.
    """
    if not isinstance(name, str) or not name.strip():
        raise error(f"{where}: expected a file name, got {name!r}")
    found_outside = None
    for folder in folders:
        real_folder = Path(os.path.realpath(folder))
        candidate = Path(os.path.realpath(Path(folder) / name))
        if not os.path.lexists(Path(folder) / name):
            continue
        if _inside(candidate, real_folder):
            return _checked(candidate, name, where, max_bytes, error)
        found_outside = found_outside or candidate
    if found_outside is not None:
        if outside_allowed(allow):
            return _checked(found_outside, name, where, max_bytes, error)
        raise error(f"{where}: {name!r} reaches outside {' and '.join(os.path.realpath(f) for f in folders)} (it is "
                    f"{found_outside}); input files are read only from there; `vlab --allow-outside-inputs ...` "
                    f"allows it")
    raise error(f"{where}: file {name!r} not found in {' nor '.join(str(f) for f in folders)}")


def _checked(path: Path, name: str, where: str, max_bytes: int, error: type[Exception]) -> Path:
    try:
        st = os.stat(path)
    except OSError as exc:
        raise error(f"{where}: {name!r} ({path}) cannot be read: {exc.strerror or exc}") from None
    if not stat.S_ISREG(st.st_mode):
        raise error(f"{where}: {name!r} ({path}) is not a regular file")
    if st.st_size > max_bytes:
        raise error(f"{where}: {name!r} ({path}) is {st.st_size} bytes, more than the {max_bytes} bytes "
                    "accepted for a named input file")
    return path


def _parse_xml(path: Path, where: str) -> ET.Element:
    try:
        return ET.parse(path).getroot()
    except ET.ParseError as exc:
        raise DataFileError(f"{where}: not a loadable MJCF model: not well-formed XML ({exc})") from None
    except OSError as exc:
        raise DataFileError(f"{where}: cannot be read: {exc.strerror or exc}") from None


def check_mjcf_files(path: str | Path, *, allow: bool | None = None) -> list[Path]:
    """Check every file an MJCF model names before MuJoCo reads it: includes (recursively) and assets.

    Relative names are taken from the model file's folder (MuJoCo's rule for
    ``<include file>``; asset names also under ``<compiler>``'s
    ``assetdir``/``meshdir``/``texturedir``); every name must stay inside
    that folder (:func:`confined_file`), be a regular file and at most
    :data:`MAX_NAMED_BYTES`.

    Parameters
    ----------
    path : str or Path
        The MJCF file given by the user.
    allow : bool, optional
        Allow files outside the model's folder (None: :func:`outside_allowed`).

    Returns
    -------
    list of Path
        The real paths of the files named (includes and assets), in document order.

    Raises
    ------
    DataFileError
        The model or an included file is not well-formed XML, an attribute
        names a file outside the folder (names the file, element and
        attribute), a named file is missing, not a regular file or too
        large, or more than :data:`MAX_INCLUDES` files are included.
    """
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    named: list[Path] = []
    pending = [(path, _parse_xml(path, str(path)))]
    seen = {os.path.realpath(path)}
    while pending:
        src, root = pending.pop(0)
        dirs = {a: "" for a in MJCF_DIR_ATTRS}
        for comp in root.iter("compiler"):
            dirs.update({a: comp.get(a) for a in MJCF_DIR_ATTRS if comp.get(a) is not None})
        for elem in root.iter():
            for attr, value in elem.attrib.items():
                if not attr.startswith("file") or elem.tag == "compiler":
                    continue
                sub = ("" if elem.tag == "include" else
                       dirs["texturedir"] or dirs["assetdir"] if elem.tag == "texture" else
                       dirs["meshdir"] or dirs["assetdir"])
                where = f"{path}: <{elem.tag} {attr}=\"{value}\">" + (f" (in {src})" if src != path else "")
                real = confined_file(os.path.join(sub, value) if sub else value, [folder], where=where,
                                     allow=allow)
                named.append(real)
                if elem.tag == "include" and str(real) not in seen:
                    seen.add(str(real))
                    if len(seen) > MAX_INCLUDES:
                        raise DataFileError(f"{path}: includes more than {MAX_INCLUDES} files")
                    pending.append((real, _parse_xml(real, where)))
    return named


__all__ = ["ALLOW_ENV", "MAX_NAMED_BYTES", "outside_allowed", "confined_file", "check_mjcf_files"]
