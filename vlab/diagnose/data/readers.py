"""Reading a diagnosis's measured data: which kind a file holds, and what it becomes.

A ``.csv`` file is a modal table (:mod:`vlab.diagnose.data.modalcsv`) unless its header begins with
``time [s]``: then it holds time histories (:mod:`vlab.io.csv_time`). A ``.h5`` or ``.hdf5`` file holds time
histories in HDF5 (:mod:`vlab.io.hdf5_time`, the channels at the file's root). Any other file is read as UFF, first
as time histories (a recording, dataset 58 function type 1), else as FRFs (function type 4). A UFF
recording with vlab's JSON sidecar is read as vlab writes it (:func:`vlab.io.uff.read_recording`: SI only);
one without, as an acquisition system writes it (:func:`vlab.io.uff_acquired.read_acquired_uff`: units from
its header, channels by node and direction). A recording becomes FRFs on the excited lines with their
noise (:mod:`vlab.diagnose.data.frfestimate`; an acquisition system's recording -- another rate, other
motion quantities -- through :mod:`vlab.diagnose.data.acquired`), FRF files are stacked; a modal table is
used as read.
"""

from __future__ import annotations

from pathlib import Path

from ...errors import DataFileError, VlabError
from ...fe import FEModel
from ...experiment.config import test_definition
from ...spec import StructureSpec
from .acquired import frfs_from_acquired, is_lab_recording
from .frfestimate import frfs_from_recording, frfs_from_uff


def detect_kind(path: str | Path) -> str:
    """``"modal"`` for a .csv modal table at ``path``, else ``"uff"``: time histories (UFF, CSV or HDF5) or
    FRFs, decided on reading (:func:`read_uff_any`).

    Raises
    ------
    DataFileError
        Missing file.
    """
    p = Path(path)
    if not p.is_file():
        raise DataFileError(f"{p}: no such file")
    from ...io.csv_time import is_time_csv

    return "modal" if p.suffix.lower() == ".csv" and not is_time_csv(p) else "uff"


def read_uff_any(path: str | Path) -> tuple[str, object]:
    """Read the file at ``path`` as a recording (UFF function type 1, CSV or HDF5 time histories) or FRFs
    (UFF function type 4).

    A ``.h5``/``.hdf5`` file is read by :func:`vlab.io.hdf5_time.read_time_hdf5` (its root group), a CSV
    whose header begins ``time [s]`` by :func:`vlab.io.csv_time.read_time_csv`, any other file as UFF.

    Returns
    -------
    ("recording", Recording) or ("frf", list of FRF)

    Raises
    ------
    DataFileError
        Malformed, truncated or unsupported file (from :mod:`vlab.io.uff`,
        :mod:`vlab.io.uff_acquired`, :mod:`vlab.io.csv_time`, :mod:`vlab.io.hdf5_time`: h5py missing
        included), or one holding neither kind. Names the file and channel.
    """
    from ...io.csv_time import is_time_csv, read_time_csv
    from ...io.hdf5_time import is_hdf5_path, read_time_hdf5
    from ...io.uff import read_frfs, read_recording, sidecar_path
    from ...io.uff_acquired import read_acquired_uff

    if is_hdf5_path(path):
        return "recording", read_time_hdf5(path)
    if is_time_csv(path):
        return "recording", read_time_csv(path)
    reader = read_recording if sidecar_path(path).is_file() else read_acquired_uff
    try:
        return "recording", reader(path)
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
              resolution_hz: float | None, band_hz, settle_of, period_s: float | None = None,
              estimator: str = "auto"):
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
    period_s : float, optional
        The controller period [s] an acquisition system's recording is brought to
        (:func:`vlab.diagnose.data.acquired.frfs_from_acquired`; default the thesis's 0.5 ms).
    estimator : {"auto", "periodic", "h1", "transient"}
        How a recording's FRFs are estimated (:func:`vlab.diagnose.data.frfestimate.choose_estimator`).

    Raises
    ------
    DataFileError, MeasurementError
        From :mod:`vlab.diagnose.data.frfestimate`; a recording of another structure; an unknown estimator.
    """
    if what == "modal":
        return obj
    if what == "recording":
        from ...design import thesis_period_s

        period_s = period_s or thesis_period_s("none")
        meta = dict(obj.metadata)
        if meta.get("structure") not in (None, spec.name):
            raise DataFileError(f"{path}: recorded on structure {meta['structure']!r}, diagnosed as {spec.name!r}")
        res = float(resolution_hz or meta.get("resolution_hz") or test_definition(spec).resolution_hz)
        if not is_lab_recording(obj):
            return frfs_from_acquired(obj, spec, fe, path=str(path), period_s=period_s, resolution_hz=res,
                                      band_hz=band_hz, settle_s=settle_of(), estimator=estimator)
        return frfs_from_recording(obj, spec, fe, path=str(path), resolution_hz=res, band_hz=band_hz,
                                   settle_s=settle_of(), estimator=estimator)
    return frfs_from_uff(obj, spec, fe, path=str(path), band_hz=band_hz)
