"""Time histories in HDF5: one dataset per channel, its point, direction, quantity and unit in attributes.

The layout (a group of the file, the root by default)::

    /                          attributes: dt_s = 0.0002  (or sample_rate_hz = 5000.0)
    /time                      float (n_samples,) [s]   (optional where dt_s or sample_rate_hz is given)
    /force9                    float (n_samples,)  attributes: node=9, direction="+Z", quantity="force", unit="N"
    /vel5                      float (n_samples,)  attributes: node=5, direction="-Z", quantity="velocity",
                                                               unit="mm/s"
    /6+Z acceleration [g]      float (n_samples,)  no attributes: the name is the CSV column header

* every dataset of the group other than ``time`` is one channel (1-D, real
  numbers), its samples in the unit its ``unit`` attribute names, in the
  group's order (creation order where the file tracks it, else by name);
  sub-groups are not read (a file holding several runs gives each its group,
  read with ``group=``);
* a channel's attributes: ``node`` (an integer >= 1, the structure's point
  id), ``direction`` (``"+Z"``, ``"-Z"``, ``"Z"``, ``"+X"``, ... or the UFF
  code +-1..3; Z = out of the structure's plane), ``quantity`` (``force``,
  ``displacement``, ``velocity``, ``acceleration``) and ``unit`` (a label
  :mod:`vlab.io.quantity_units` knows: ``N``, ``lbf``, ``m``, ``mm/s``,
  ``g``, ...). A dataset with none of them is named by its CSV header
  (``9+Z force [N]``, :func:`vlab.io.csv_time.parse_channel_label`); as an
  HDF5 name cannot hold ``/``, a unit such as ``mm/s`` is given by the
  attributes. A dataset with only some of them is refused, naming the one
  missing;
* the sampling: a ``time`` dataset [s] (evenly spaced, checked as the CSV
  reader's time column, :func:`vlab.io.csv_time.even_time_step`; its
  ``unit`` attribute, if any, must be ``s``), or an attribute ``dt_s`` [s] or
  ``sample_rate_hz`` [Hz] of the group (else of the file's root); where
  several are given they must agree;
* all channels have the time's length; one channel per quantity, node and
  direction.

The attribute names follow the CSV header's fields (node, direction,
quantity, unit), so an export script writes the same four things in either
format. Samples are converted to SI on reading. Channels are named as
:func:`vlab.io.uff_acquired.acquired_channel_name` names them (``acc6``,
``vel5-Z``); the dataset names are kept in the metadata. The same checks as
for CSV and UFF recordings apply: non-finite samples, clipping and
implausible magnitudes (:func:`vlab.io.uff_time.read_recording`); a dead
(constant) channel is refused where the FRFs are estimated
(:mod:`vlab.diagnose.data.frfestimate`).

Reading needs h5py, an optional dependency: ``pip install "vlab[hdf5]"``.

Source: The HDF Group, *HDF5 User's Guide* (groups, datasets, attributes);
h5py (Collette et al., https://docs.h5py.org); units as :mod:`vlab.io.quantity_units`.
"""

from __future__ import annotations

import math
import os
import re
from pathlib import Path

import numpy as np

from ..errors import DataFileError, MeasurementError
from .csv_time import direction_code, even_time_step, parse_channel_label, unit_to_si
from .quantity_units import normalise_label
from .recording import QUANTITY_PREFIXES, Channel, Recording
from .uff_acquired import acquired_channel_name
from .uff_time import MIN_SAMPLES, _check_magnitude

#: File name suffixes read as HDF5 (compared without case).
HDF5_SUFFIXES = (".h5", ".hdf5")
#: The dataset that holds the sample instants [s].
TIME_DATASET = "time"
#: A channel dataset's attributes (all four, or none and a CSV header as its name).
CHANNEL_ATTRS = ("node", "direction", "quantity", "unit")
#: What to install for reading HDF5.
INSTALL_HINT = 'pip install "vlab[hdf5]"'
#: Relative tolerance between two statements of the sampling step (time dataset, dt_s, sample_rate_hz).
STEP_TOLERANCE = 1e-6
_DIRECTION_RE = re.compile(r"^\s*([+-]?)\s*([XYZ])\s*$", re.IGNORECASE)


def is_hdf5_path(path: str | os.PathLike) -> bool:
    """Whether ``path`` (str or path-like) names an HDF5 file by its suffix (:data:`HDF5_SUFFIXES`).

    Returns
    -------
    bool
        ``.h5`` or ``.hdf5`` in any case; the file is not opened (the reader reports a missing or unreadable one).
    """
    return Path(path).suffix.lower() in HDF5_SUFFIXES


def _h5py(p: Path):
    """The h5py module; DataFileError naming the file and the install command without it."""
    try:
        import h5py
    except ImportError:
        raise DataFileError(f"{p}: reading HDF5 time histories needs the h5py package: {INSTALL_HINT}") from None
    return h5py


def _scalar(value):
    """An attribute's single value: a size-1 array's element, a byte string decoded; else as given."""
    if isinstance(value, np.ndarray) and value.size == 1:
        value = value.reshape(-1)[0]
    if isinstance(value, (bytes, np.bytes_)):
        return value.decode("utf-8", errors="replace")
    return value.item() if isinstance(value, np.generic) else value


def _text_attr(p: Path, where: str, attrs, key: str) -> str:
    """Attribute ``key`` as a non-empty string; DataFileError naming the file, ``where`` and ``key``."""
    value = _scalar(attrs[key])
    if not isinstance(value, str) or not value.strip():
        raise DataFileError(f"{p}: {where}: attribute {key!r} = {value!r} is not a non-empty string")
    return value.strip()


def _node_attr(p: Path, where: str, attrs) -> int:
    """Attribute ``node``: an integer >= 1 (a point id)."""
    value = _scalar(attrs["node"])
    if isinstance(value, float) and value.is_integer():
        value = int(value)
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise DataFileError(f"{p}: {where}: attribute 'node' = {value!r} is not a point id (an integer >= 1)")
    return value


def _direction_attr(p: Path, where: str, attrs) -> int:
    """Attribute ``direction``: ``"+Z"``, ``"-X"``, ``"Z"``, ... or the UFF code +-1..3 -> the UFF code."""
    value = _scalar(attrs["direction"])
    if isinstance(value, str):
        m = _DIRECTION_RE.match(value)
        if m is not None:
            return direction_code(m.group(1), m.group(2))
        value = int(value) if re.fullmatch(r"\s*[+-]?\d+\s*", value) else value
    if not isinstance(value, bool) and isinstance(value, int) and value in (-3, -2, -1, 1, 2, 3):
        return value
    raise DataFileError(f"{p}: {where}: attribute 'direction' = {value!r} is not a direction ('+X', '-Y', '+Z', "
                        "... or the UFF code +-1, +-2, +-3; Z = out of the structure's plane)")


def _identity(p: Path, ds) -> tuple[int, int, str, float, str]:
    """A channel dataset's (node, direction, quantity, factor to SI, unit as written), from its attributes or
    its name."""
    where = f"dataset {ds.name!r}"
    given = [k for k in CHANNEL_ATTRS if k in ds.attrs]
    if not given:
        try:
            return parse_channel_label(p, f"{where}: name", ds.name.rsplit("/", 1)[-1])
        except DataFileError as exc:
            raise DataFileError(f"{exc}; or give the dataset the attributes {', '.join(CHANNEL_ATTRS)}") from None
    missing = [k for k in CHANNEL_ATTRS if k not in ds.attrs]
    if missing:
        raise DataFileError(f"{p}: {where}: attribute {missing[0]!r} missing (a channel's attributes are "
                            f"{', '.join(CHANNEL_ATTRS)}; found {', '.join(given)})")
    node = _node_attr(p, where, ds.attrs)
    direction = _direction_attr(p, where, ds.attrs)
    quantity = _text_attr(p, where, ds.attrs, "quantity").lower()
    if quantity not in QUANTITY_PREFIXES:
        raise DataFileError(f"{p}: {where}: attribute 'quantity' = {quantity!r} is not one of "
                            f"{', '.join(QUANTITY_PREFIXES)}")
    unit = _scalar(ds.attrs["unit"])
    unit = unit.strip() if isinstance(unit, str) else unit
    factor = unit_to_si(p, f"{where}: attribute 'unit'", quantity, unit if isinstance(unit, str) else repr(unit))
    return node, direction, quantity, factor, unit


def _samples(p: Path, ds) -> np.ndarray:
    """A dataset's values as float64, shape (n,); DataFileError for another shape, type or a non-finite value."""
    where = f"dataset {ds.name!r}"
    if ds.dtype.kind not in "fiu":
        raise DataFileError(f"{p}: {where}: type {ds.dtype} is not real numbers")
    if len(ds.shape) != 1:
        raise DataFileError(f"{p}: {where}: shape {ds.shape} is not one-dimensional (one channel per dataset)")
    x = np.asarray(ds[()], dtype=float)
    bad = np.flatnonzero(~np.isfinite(x))
    if bad.size:
        raise DataFileError(f"{p}: {where}, index {int(bad[0])}: non-finite value {float(x[bad[0]])!r} "
                            f"({bad.size} in all)")
    return x


def _step_attr(p: Path, g, key: str) -> float | None:
    """Attribute ``key`` (``dt_s`` or ``sample_rate_hz``) of group ``g`` as the step [s]; None where absent."""
    if key not in g.attrs:
        return None
    value = _scalar(g.attrs[key])
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not (math.isfinite(value) and value > 0):
        raise DataFileError(f"{p}: group {g.name!r}: attribute {key!r} = {value!r} is not a positive number")
    return float(value) if key == "dt_s" else 1.0 / float(value)


def _stated_steps(p: Path, g) -> dict[str, float]:
    """The steps [s] the attributes state, by where they are written (the group's, else the root's)."""
    for holder in (g, g.file["/"]):
        steps = {f"group {holder.name!r}: attribute {k!r}": s for k in ("dt_s", "sample_rate_hz")
                 if (s := _step_attr(p, holder, k)) is not None}
        if steps:
            return steps
    return {}


def _time_base(p: Path, g, n: int) -> float:
    """The common step [s] of group ``g``'s channels of ``n`` samples: its ``time`` dataset and/or attributes."""
    steps = _stated_steps(p, g)
    if TIME_DATASET in g and not hasattr(g[TIME_DATASET], "dtype"):
        raise DataFileError(f"{p}: {g[TIME_DATASET].name!r} is a group; '{TIME_DATASET}' is the sample instants [s]")
    if TIME_DATASET in g:
        ds = g[TIME_DATASET]
        if "unit" in ds.attrs and normalise_label(_scalar(ds.attrs["unit"])) not in ("s", "sec", "seconds"):
            raise DataFileError(f"{p}: dataset {ds.name!r}: attribute 'unit' = {_scalar(ds.attrs['unit'])!r}: "
                                "the time must be in seconds ('s')")
        t = _samples(p, ds)
        if t.size != n:
            raise DataFileError(f"{p}: dataset {ds.name!r} has {t.size} instants, the channels {n} samples")
        steps = {f"dataset {ds.name!r}": even_time_step(p, t, f"dataset {ds.name!r}", lambda j: f"index {j}"),
                 **steps}
    if not steps:
        raise DataFileError(f"{p}: group {g.name!r}: no sampling: give a '{TIME_DATASET}' dataset [s] or an "
                            "attribute 'dt_s' [s] or 'sample_rate_hz' [Hz]")
    (first, dt), *others = steps.items()
    for where, other in others:
        if not math.isclose(other, dt, rel_tol=STEP_TOLERANCE):
            raise DataFileError(f"{p}: {first} gives a step of {dt!r} s, {where} {other!r} s")
    if n < MIN_SAMPLES:
        raise DataFileError(f"{p}: group {g.name!r}: {n} sample(s); a record needs at least {MIN_SAMPLES}")
    return dt


def _channel_datasets(p: Path, g) -> list:
    """The datasets of group ``g`` other than the time, in the file's order; DataFileError where there are none."""
    found = [obj for key, obj in g.items() if key != TIME_DATASET and hasattr(obj, "dtype")]
    if not found:
        raise DataFileError(f"{p}: group {g.name!r} holds no channel dataset (one 1-D dataset per channel with "
                            f"the attributes {', '.join(CHANNEL_ATTRS)}, or named '9+Z force [N]')")
    return found


def _read_channels(p: Path, g, *, allow_clipped: bool, allow_implausible: bool):
    """Group ``g``'s channels (in SI) with their dataset names and units as written, and their step [s]."""
    channels, labels, units, seen = [], {}, {}, {}
    datasets = _channel_datasets(p, g)
    for ds in datasets:
        node, direction, quantity, factor, unit = _identity(p, ds)
        name = acquired_channel_name(quantity, node, direction)
        if name in seen:
            raise DataFileError(f"{p}: datasets {seen[name]!r} and {ds.name!r} both hold {quantity} at node {node}, "
                                f"direction {direction} ({name})")
        seen[name] = ds.name
        samples = _samples(p, ds) * factor
        if channels and samples.size != channels[0].samples.size:
            raise DataFileError(f"{p}: dataset {ds.name!r} has {samples.size} samples, dataset "
                                f"{labels[channels[0].name]!r} {channels[0].samples.size}")
        _check_magnitude(p, f"dataset {ds.name!r}, channel {name}", samples, quantity, allow_clipped=allow_clipped,
                         allow_implausible=allow_implausible)
        channels.append(Channel(name=name, point_id=node, quantity=quantity, samples=samples, direction=direction))
        labels[name], units[name] = ds.name, unit
    return channels, labels, units, _time_base(p, g, channels[0].samples.size)


def read_time_hdf5(path: str | os.PathLike, *, group: str = "/", allow_clipped: bool = False,
                   allow_implausible: bool = False) -> Recording:
    """Read HDF5 time histories (the layout of this module) into a :class:`Recording` in SI.

    Parameters
    ----------
    path : str or path-like
        The HDF5 file.
    group : str
        The group holding the channels (default the root, ``"/"``).
    allow_clipped, allow_implausible : bool
        As :func:`vlab.io.uff_time.read_recording` (the checks run on the SI values).

    Returns
    -------
    Recording
        One channel per dataset other than ``time``, samples in SI ([N], [m], [m/s], [m/s^2]), ``dt_s`` the
        step [s]; metadata ``source_file``, ``group``, ``channel_labels`` (name -> dataset path) and
        ``units_in_file`` (name -> unit as written).

    Raises
    ------
    DataFileError
        h5py not installed (names ``pip install "vlab[hdf5]"``); a missing file, one that is not HDF5, or a
        missing group; no channel dataset; a dataset that is not 1-D real numbers; attributes missing or out
        of range (node, direction, quantity); an unknown or missing unit; a dataset name that is not a
        channel header where there are no attributes; two channels of one quantity at one node and
        direction; channels of different lengths; non-finite samples; no sampling stated, or an uneven
        ``time``, or statements of the step that disagree; fewer than
        :data:`vlab.io.uff_time.MIN_SAMPLES` samples. Every message names the file and the dataset or
        group, and the attribute where one is at fault.
    MeasurementError
        A clipped channel or an implausible RMS, unless allowed.
    """
    p = Path(path)
    h5py = _h5py(p)
    if not p.is_file():
        raise DataFileError(f"{p}: no such file")
    try:
        fh = h5py.File(p, "r")
    except OSError as exc:
        raise DataFileError(f"{p}: not a readable HDF5 file: {exc}") from None
    with fh:
        g = fh.get(group)
        if g is None or hasattr(g, "dtype"):
            raise DataFileError(f"{p}: no group {group!r} (groups at the root: "
                                f"{', '.join(k for k, v in fh.items() if not hasattr(v, 'dtype')) or 'none'})")
        group_name = g.name
        channels, labels, units, dt = _read_channels(p, g, allow_clipped=allow_clipped,
                                                     allow_implausible=allow_implausible)
    try:
        return Recording(dt_s=dt, channels=tuple(channels),
                         metadata={"source_file": str(p), "group": group_name, "channel_labels": labels,
                                   "units_in_file": units})
    except MeasurementError as exc:  # pragma: no cover - the checks above come first
        raise DataFileError(f"{p}: {exc}") from exc


__all__ = ["read_time_hdf5", "is_hdf5_path", "HDF5_SUFFIXES", "TIME_DATASET", "CHANNEL_ATTRS", "INSTALL_HINT",
           "STEP_TOLERANCE"]
