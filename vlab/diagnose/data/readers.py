"""Reading a diagnosis's measured data: which kind a file holds, and what it becomes.

A ``.csv`` file is a modal table (:mod:`vlab.diagnose.data.modalcsv`); any other file is read as UFF,
first as time histories (a recording, dataset 58 function type 1), else as FRFs (function type 4).
A recording becomes FRFs on the excited lines with their noise, FRF files are stacked
(:mod:`vlab.diagnose.data.frfestimate`); a modal table is used as read.
"""

from __future__ import annotations

from pathlib import Path

from ...errors import DataFileError, VlabError
from ...fe import FEModel
from ...experiment.config import test_definition
from ...spec import StructureSpec
from .frfestimate import frfs_from_recording, frfs_from_uff


def detect_kind(path: str | Path) -> str:
    """``"modal"`` for a .csv file at ``path``, else ``"uff"`` (decided on reading).

    Raises
    ------
    DataFileError
        Missing file.
    """
    p = Path(path)
    if not p.is_file():
        raise DataFileError(f"{p}: no such file")
    return "modal" if p.suffix.lower() == ".csv" else "uff"


def read_uff_any(path: str | Path) -> tuple[str, object]:
    """Read the UFF file at ``path`` as a recording (function type 1) or FRFs (type 4).

    Returns
    -------
    ("recording", Recording) or ("frf", list of FRF)

    Raises
    ------
    DataFileError
        Malformed, truncated or unsupported file (from :mod:`vlab.io.uff`),
        or one holding neither kind. Names the file and channel.
    """
    from ...io.uff import read_frfs, read_recording

    try:
        return "recording", read_recording(path)
    except DataFileError as exc:
        if "no dataset-58 time-response" not in str(exc):
            raise
    try:
        return "frf", read_frfs(path)
    except DataFileError as exc:
        if "no dataset-58 FRF" in str(exc):
            raise DataFileError(f"{path}: neither time histories (UFF 58, function type 1) nor FRFs "
                                "(function type 4)") from None
        raise
    except VlabError:
        raise


def read_data(spec: StructureSpec, fe: FEModel, path: Path, what: str, obj, *,
              resolution_hz: float | None, band_hz, settle_of):
    """Turn what was read into FrfData or ModalData (see :mod:`vlab.diagnose.data.measured`).

    Parameters
    ----------
    spec, fe : StructureSpec, FEModel
        The nominal structure.
    path : Path
        The file (for messages).
    what : {"modal", "recording", "frf"}
        Kind of ``obj``.
    obj : ModalData, Recording or list of FRF
        What was read.
    resolution_hz : float or None
        Resolution asked for [Hz]; else the metadata's, else the structure's test resolution.
    band_hz : (float, float)
        Band analysed [Hz].
    settle_of : callable
        Returns the settling time [s] of the nominal lab (called for recordings only).

    Raises
    ------
    DataFileError, MeasurementError
        From :mod:`vlab.diagnose.data.frfestimate`; a recording of another structure.
    """
    if what == "modal":
        return obj
    if what == "recording":
        meta = dict(obj.metadata)
        if meta.get("structure") not in (None, spec.name):
            raise DataFileError(f"{path}: recorded on structure {meta['structure']!r}, diagnosed as {spec.name!r}")
        res = float(resolution_hz or meta.get("resolution_hz") or test_definition(spec).resolution_hz)
        return frfs_from_recording(obj, spec, fe, path=str(path), resolution_hz=res, band_hz=band_hz,
                                   settle_s=settle_of())
    return frfs_from_uff(obj, spec, fe, path=str(path), band_hz=band_hz)
