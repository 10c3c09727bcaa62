"""UFF 58 time histories written by an acquisition system: any motion quantity, unit, rate and channel label.

vlab's own recordings (:mod:`vlab.io.uff_time`) are SI, named ``vel4`` and
come with a JSON sidecar. A file from a data-acquisition system differs:
accelerometers or vibrometers, 5 or 10 kHz, labels such as ``9+Z`` or
``Point 6 Z``, units from its own unit system, no sidecar. This reader takes
each dataset-58 record of function type 1 (time response) as one channel:

* **what**: the ordinate's specific data type (8 displacement, 11 velocity,
  12 acceleration, 9 or 13 force);
* **where**: the response node (the structure's point id) and direction
  (+-1..3; 3 = +Z, out of the structure's plane), never the ID line (kept in
  the metadata as the channel's label);
* **units**, from the header's data characteristics (record 9: the length
  and force unit exponents and the axis units label) and the file's units
  record (dataset 164): a label vlab knows (:mod:`vlab.io.quantity_units`:
  ``g``, ``mm/s``, ``in/s^2``, ``lbf``, ...) converts the record on its own;
  an empty label (or ``NONE``) means the unit system's unit, converted by the
  units record's factors (SI = value / (length ** a * force ** b) for
  exponents a, b; SI without a units record). A labelled unit in a file whose
  units record is not SI must be that system's unit (``in/s^2`` in an inch
  file): a label that contradicts the units record is refused;
* **when**: an evenly spaced time abscissa in seconds (specific data type
  17), one step for all channels, any rate.

The channel of ``quantity`` at ``node`` in +Z is named as vlab names it
(``acc6``, ``force9``); another direction adds it (``acc6-Z``, ``acc6+X``).
The diagnosis maps channels to the structure's points by node and direction
(:mod:`vlab.diagnose.data.acquired`).

Source: UFF datasets 58 and 164 (SDRC/I-DEAS, *Universal File Datasets
Summary*, https://www.ceas3.uc.edu/sdrluff/); pyuff (Slavič et al.,
https://github.com/ladisk/pyuff).
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from ..errors import DataFileError, MeasurementError
from .quantity_units import NO_UNIT, known_labels, normalise_label, unit_factor
from .recording import QUANTITY_PREFIXES, Channel, Recording
from .uff_files import CODE_QUANTITY, UNIT_EXPONENTS, check_direction, check_node, get_int, read_uff, record_label
from .uff_time import _check_magnitude, _check_new_channel, _time_record_samples, _time_step
from .uff_units import SI_TOLERANCE, check_exponents, check_time_axis, exponents, units_system

_TIME = 17
_FUNC_TIME = 1
#: Relative tolerance between a unit label's factor and the units record's (both state the same unit).
LABEL_TOLERANCE = 1e-4


def acquired_channel_name(quantity: str, node: int, direction: int) -> str:
    """The channel name of ``quantity`` at ``node`` in ``direction``: ``acc6`` in +Z, else ``acc6-Z``, ``acc6+X``.

    Parameters
    ----------
    quantity : {"force", "displacement", "velocity", "acceleration"}
    node : int
        Point id.
    direction : int
        UFF direction code, +-1..3.

    Returns
    -------
    str

    Raises
    ------
    KeyError
        Unknown quantity.
    """
    name = f"{QUANTITY_PREFIXES[quantity]}{int(node)}"
    if direction == 3:
        return name
    return f"{name}{'+' if direction > 0 else '-'}{'XYZ'[abs(direction) - 1]}"


def ordinate_factor(p: Path, s: dict, quantity: str, system, where: str) -> tuple[float, str]:
    """The factor that turns a time record's ordinate into SI, and the unit it was in.

    Parameters
    ----------
    p : Path
        The file (for messages).
    s : dict
        The dataset-58 record as pyuff reads it.
    quantity : str
        Its quantity (from the specific data type).
    system : (float, float, str) or None
        The units record's length and force factors and description
        (:func:`vlab.io.uff_units.units_system`); None: SI.
    where : str
        The record, for messages.

    Returns
    -------
    (float, str)
        SI value = file value x factor; the unit in words (the label, or the
        unit system's description).

    Raises
    ------
    DataFileError
        A unit label that is not a unit of the quantity (names the label and the
        labels read), or one that contradicts a non-SI units record.
    """
    le, fe = exponents(p, s, "ordinate", where)
    if (le, fe) == (0, 0):
        le, fe = UNIT_EXPONENTS[quantity]
    sys_factor = 1.0 if system is None else 1.0 / (system[0] ** le * system[1] ** fe)
    raw = s.get("ordinate_axis_units_lab", "")
    label = normalise_label(raw)
    if label in NO_UNIT:
        return sys_factor, ("SI" if system is None else f"the units record's {system[2]!r}")
    try:
        factor = unit_factor(quantity, raw)
    except KeyError:
        raise DataFileError(f"{p}: {where}: ordinate unit label {str(raw).strip()!r} is not a unit of {quantity} "
                            f"vlab reads (known: {', '.join(known_labels(quantity))})") from None
    si_system = system is None or math.isclose(sys_factor, 1.0, rel_tol=SI_TOLERANCE)
    if not si_system and not math.isclose(factor, sys_factor, rel_tol=LABEL_TOLERANCE):
        raise DataFileError(f"{p}: {where}: ordinate unit label {str(raw).strip()!r} (x {factor:.6g} to SI) "
                            f"contradicts the units record {system[2]!r} (x {sys_factor:.6g} to SI for exponents "
                            f"{le}, {fe})")
    return factor, str(raw).strip()


def _record(p: Path, s: dict, i: int, system, *, allow_clipped: bool, allow_implausible: bool):
    """One time record as (name, node, quantity, direction, samples in SI, step [s], label, unit)."""
    where = f"record {i}"
    code = get_int(p, s, "ordinate_spec_data_type", where)
    node = check_node(p, s, "rsp_node", where)
    label = record_label(s, "")
    if code not in CODE_QUANTITY:
        raise DataFileError(f"{p}: {where} ({label or f'node {node}'!r}): unsupported ordinate specific data type "
                            f"{code} (known: {sorted(CODE_QUANTITY)})")
    quantity = CODE_QUANTITY[code]
    direction = check_direction(p, s, "rsp_dir", where)
    name = acquired_channel_name(quantity, node, direction)
    where = f"record {i}, channel {name}" + (f" ({label!r})" if label else "")
    check_exponents(p, s, "ordinate", code, where)
    absc = int(s.get("abscissa_spec_data_type", _TIME) or 0)
    if absc not in (0, _TIME):
        raise DataFileError(f"{p}: {where}: abscissa specific data type {absc} is not time ({_TIME})")
    check_time_axis(p, s, where)
    factor, unit = ordinate_factor(p, s, quantity, system, where)
    data = _time_record_samples(p, s, name, where, i) * factor
    _check_magnitude(p, where, data, quantity, allow_clipped=allow_clipped, allow_implausible=allow_implausible)
    return name, node, quantity, direction, data, _time_step(p, name, s), label, unit


def read_acquired_uff(path: str | os.PathLike, *, allow_clipped: bool = False,
                      allow_implausible: bool = False) -> Recording:
    """Read an acquisition system's UFF 58 time histories (function type 1) into a :class:`Recording` in SI.

    Parameters
    ----------
    path : str or path-like
        UFF file (ASCII 58 or binary 58b).
    allow_clipped, allow_implausible : bool
        As :func:`vlab.io.uff_time.read_recording` (the checks run on the SI values).

    Returns
    -------
    Recording
        One channel per record, samples in SI ([N], [m], [m/s], [m/s^2]),
        ``dt_s`` the common step [s]; metadata ``source_file``,
        ``channel_labels`` (name -> ID line 1) and ``units_in_file``
        (name -> the unit the record was in).

    Raises
    ------
    DataFileError
        Missing, empty, malformed or truncated file; no time record; an
        unknown ordinate type, unit label or direction; a label that
        contradicts the units record; a time axis not in s; uneven sampling or
        channels at different steps; duplicate channels (one quantity at one
        node and direction); channels of different lengths; non-finite
        samples. The message names the file, the record and the channel.
    MeasurementError
        A clipped channel or an implausible RMS (in SI), unless allowed.
    """
    p, sets = read_uff(path, si_only=False)
    recs = [s for s in sets if s.get("type") == 58 and s.get("func_type") == _FUNC_TIME]
    if not recs:
        raise DataFileError(f"{p}: no dataset-58 time-response (function type 1) record")
    system = units_system(p, sets)
    channels: list[Channel] = []
    keys: dict = {}
    labels, units = {}, {}
    dt_ref = ref_name = None
    for i, s in enumerate(recs, start=1):
        name, node, quantity, direction, data, dt, label, unit = _record(
            p, s, i, system, allow_clipped=allow_clipped, allow_implausible=allow_implausible)
        if dt_ref is None:
            dt_ref, ref_name = dt, name
        elif not math.isclose(dt, dt_ref, rel_tol=1e-9):
            raise DataFileError(f"{p}: channel {name} is sampled every {dt!r} s, channel {ref_name} every "
                                f"{dt_ref!r} s")
        _check_new_channel(p, channels, keys, i, name, f"record {i}, channel {name}", data.size,
                           (node, quantity, direction))
        channels.append(Channel(name=name, point_id=node, quantity=quantity, samples=np.asarray(data),
                                direction=direction))
        labels[name], units[name] = label, unit
    try:
        return Recording(dt_s=dt_ref, channels=tuple(channels),
                         metadata={"source_file": str(p), "channel_labels": labels, "units_in_file": units})
    except MeasurementError as exc:
        raise DataFileError(f"{p}: {exc}") from exc


__all__ = ["read_acquired_uff", "acquired_channel_name", "ordinate_factor", "LABEL_TOLERANCE"]
