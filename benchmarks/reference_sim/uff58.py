"""A writer of Universal File Format dataset 58 (function at nodal DOF), ASCII.

Written from the format's definition (SDRC/I-DEAS *Universal File Datasets
Summary*, dataset 58: records 1-12), not from any library: one record per channel,
function type 1 (time response), evenly spaced abscissa, real double-precision
ordinate (4E20.12 per line). This module never imports vlab.
"""

from __future__ import annotations

import datetime as _dt
from dataclasses import dataclass
from pathlib import Path

import numpy as np

QUANTITIES = {
    # name: (specific data type, length exp, force exp, temperature exp, label, unit)
    "acceleration": (12, 1, 0, 0, "Acceleration", "m/s^2"),
    "velocity": (11, 1, 0, 0, "Velocity", "m/s"),
    "displacement": (8, 1, 0, 0, "Displacement", "m"),
    "force": (13, 0, 1, 0, "Force", "N"),
}
"""Ordinate data characteristics (record 9) of the quantities written."""

DIRECTIONS = {"X": 1, "Y": 2, "Z": 3}


class UffError(ValueError):
    """A channel that cannot be written as dataset 58."""


@dataclass(frozen=True)
class Channel:
    """One time history.

    Attributes
    ----------
    name : str
        ID line 1 (at most 80 characters), e.g. ``"9+Z"`` or ``"vel9"``.
    node : int
        Point id (response node).
    direction : str
        ``"X"``, ``"Y"`` or ``"Z"`` (+ direction).
    quantity : str
        A key of :data:`QUANTITIES`.
    dt_s : float
        Sampling interval [s].
    data : ndarray, shape (n,)
        Samples in SI units of ``quantity``.
    description : str
        ID line 2 (e.g. the transducer).
    """

    name: str
    node: int
    direction: str
    quantity: str
    dt_s: float
    data: np.ndarray
    description: str = ""


def _line(text: str) -> str:
    if len(text) > 80:
        raise UffError(f"ID line longer than 80 characters: {text!r}")
    return f"{text:<80}\n"


def format_record(ch: Channel, when: _dt.datetime) -> str:
    """The text of one dataset-58 record, delimiters included.

    Parameters
    ----------
    ch : Channel
    when : datetime.datetime
        Date and time on ID line 3.

    Returns
    -------
    str

    Raises
    ------
    UffError
        Unknown quantity or direction, non-finite samples, dt <= 0.
    """
    if ch.quantity not in QUANTITIES:
        raise UffError(f"channel {ch.name!r}: unknown quantity {ch.quantity!r}")
    if ch.direction not in DIRECTIONS:
        raise UffError(f"channel {ch.name!r}: unknown direction {ch.direction!r}")
    data = np.asarray(ch.data, float)
    if not np.all(np.isfinite(data)) or not ch.dt_s > 0:
        raise UffError(f"channel {ch.name!r}: non-finite samples or dt {ch.dt_s!r}")
    typ, le, fe, te, label, unit = QUANTITIES[ch.quantity]
    out = ["    -1\n", "    58\n", _line(ch.name), _line(ch.description),
           _line(when.strftime("%d-%b-%y %H:%M:%S")), _line(f"sampled at {1.0 / ch.dt_s:.6g} Hz"), _line("NONE")]
    out.append(f"{1:5d}{0:10d}{0:5d}{0:10d} {'NONE':<10}{ch.node:10d}"
               f"{DIRECTIONS[ch.direction]:4d} {'NONE':<10}{0:10d}{0:4d}\n")
    out.append(f"{4:10d}{data.size:10d}{1:10d}{0.0:13.5E}{ch.dt_s:13.5E}{0.0:13.5E}\n")
    out.append(f"{17:10d}{0:5d}{0:5d}{0:5d} {'Time':<20} {'s':<20}\n")
    out.append(f"{typ:10d}{le:5d}{fe:5d}{te:5d} {label:<20} {unit:<20}\n")
    out.append(f"{0:10d}{0:5d}{0:5d}{0:5d} {'NONE':<20} {'NONE':<20}\n")
    out.append(f"{0:10d}{0:5d}{0:5d}{0:5d} {'NONE':<20} {'NONE':<20}\n")
    for i in range(0, data.size, 4):
        out.append("".join(f"{v:20.12E}" for v in data[i:i + 4]) + "\n")
    out.append("    -1\n")
    return "".join(out)


def write_uff58(path: str | Path, channels, when: _dt.datetime | None = None) -> Path:
    """Write time histories as ASCII UFF 58 records, one per channel.

    Parameters
    ----------
    path : str or Path
        Output file (replaced).
    channels : sequence of Channel
    when : datetime.datetime, optional
        Date on ID line 3 (default: 2000-01-01, so files are reproducible).

    Returns
    -------
    Path

    Raises
    ------
    UffError
        As :func:`format_record`, or no channel.
    """
    channels = list(channels)
    if not channels:
        raise UffError("no channel to write")
    when = when or _dt.datetime(2000, 1, 1)
    path = Path(path)
    with open(path, "w", encoding="ascii") as fh:
        for ch in channels:
            fh.write(format_record(ch, when))
    return path
