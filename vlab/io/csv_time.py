"""Time histories as CSV: one column per channel, its point, direction, quantity and unit in the header.

The format (any acquisition system's export can be brought to it)::

    # lines starting with '#' are comments (before the header or anywhere below it)
    time [s],9+Z force [N],6+Z acceleration [g],5-Z velocity [mm/s]
    0.0000,0.0123,-0.0012,0.31
    0.0002,0.0131,-0.0010,0.33

* comma-separated, one header line, then one line per sample;
* the first column is the time in seconds, header ``time [s]``, evenly
  spaced (each instant within :data:`TIME_JITTER` of a step of the common
  grid: what printing with limited digits leaves; a rate within the time
  column's round-off of a whole number of samples per second is taken as
  that number);
* every other header is ``<node><sign><axis> <quantity> [<unit>]``: the
  node is the structure's point id, the sign (+ if omitted) and axis X, Y or
  Z the direction (Z = out of the structure's plane), the quantity one of
  ``force``, ``displacement``, ``velocity``, ``acceleration``, and the unit
  one vlab knows for it (:mod:`vlab.io.quantity_units`: ``N``, ``lbf``,
  ``m``, ``mm``, ``m/s``, ``mm/s``, ``in/s``, ``m/s^2``, ``g``, ...); a
  column without a unit is refused;
* samples are converted to SI on reading; one column per quantity, node and
  direction.

Channels are named as :func:`vlab.io.uff_acquired.acquired_channel_name`
names them (``acc6``, ``vel5-Z``). The same checks as for UFF recordings
apply: non-finite samples, clipping and implausible magnitudes
(:func:`vlab.io.uff_time.read_recording`).

Source: RFC 4180 (comma-separated values); units as :mod:`vlab.io.quantity_units`.
"""

from __future__ import annotations

import io
import os
import re
from pathlib import Path

import numpy as np

from ..errors import DataFileError, MeasurementError
from .quantity_units import NO_UNIT, known_labels, normalise_label, unit_factor
from .recording import Channel, Recording
from .uff_acquired import acquired_channel_name
from .uff_time import MIN_SAMPLES, _check_magnitude

#: Largest deviation of a time instant from the evenly spaced grid, as a fraction of the step.
TIME_JITTER = 0.01
#: The time column's header (compared without case and spaces).
TIME_HEADER = "time[s]"
_COLUMN_RE = re.compile(r"^\s*(\d+)\s*([+-]?)\s*([XYZ])\s+(force|displacement|velocity|acceleration)\s*"
                        r"\[([^\]]*)\]\s*$", re.IGNORECASE)
_AXES = {"X": 1, "Y": 2, "Z": 3}


def is_time_csv(path: str | os.PathLike) -> bool:
    """Whether the CSV file at ``path`` holds time histories: its header's first cell is ``time [s]``.

    Parameters
    ----------
    path : str or path-like

    Returns
    -------
    bool
        False for a missing or unreadable file (the reader reports it).
    """
    try:
        with open(path, encoding="utf-8-sig") as fh:
            for line in fh:
                if line.strip() and not line.lstrip().startswith("#"):
                    return "".join(line.split(",")[0].split()).lower() == TIME_HEADER
    except (OSError, UnicodeDecodeError):
        return False
    return False


def direction_code(sign: str, axis: str) -> int:
    """The UFF direction code of ``sign`` (``"+"``, ``"-"`` or ``""`` for +) and ``axis`` (X, Y or Z, any case).

    Returns
    -------
    int
        +-1, +-2, +-3 (3 = +Z, out of the structure's plane).

    Raises
    ------
    KeyError
        An axis other than X, Y, Z.

    Source: UFF dataset 58, record 6 (direction codes).
    """
    return _AXES[axis.upper()] * (-1 if sign == "-" else 1)


def unit_to_si(p: Path, where: str, quantity: str, unit) -> float:
    """The factor that turns ``quantity`` in the unit labelled ``unit`` into SI.

    Parameters
    ----------
    p : Path
        The file (for messages).
    where : str
        Where the label is written, for messages (``"column 3 header '6+Z acceleration [g]'"``).
    quantity : {"force", "displacement", "velocity", "acceleration"}
    unit : str
        The label as written (:mod:`vlab.io.quantity_units`).

    Returns
    -------
    float
        SI value = value x factor.

    Raises
    ------
    DataFileError
        A missing (empty or ``none``) or unknown unit; the message names the file, ``where`` and the labels
        read for ``quantity``.
    """
    if normalise_label(unit) in NO_UNIT:
        raise DataFileError(f"{p}: {where}: no unit; write one of {', '.join(known_labels(quantity))}")
    try:
        return float(unit_factor(quantity, unit))
    except KeyError:
        raise DataFileError(f"{p}: {where}: unit {str(unit).strip()!r} is not a unit of {quantity} vlab reads "
                            f"(known: {', '.join(known_labels(quantity))})") from None


def parse_channel_label(p: Path, where: str, text: str) -> tuple[int, int, str, float, str]:
    """A channel's label ``<node><sign><axis> <quantity> [<unit>]`` (a CSV header cell, an HDF5 dataset's name).

    Parameters
    ----------
    p : Path
        The file (for messages).
    where : str
        What carries the label, for messages (``"column 3 header"``, ``"dataset '/9+Z force [N]': name"``).
    text : str
        The label.

    Returns
    -------
    (node, direction, quantity, factor, unit)
        Point id, UFF direction code (+-1..3), quantity, the factor to SI and
        the unit as written.

    Raises
    ------
    DataFileError
        A label that does not follow the pattern, a node below 1, a missing or
        unknown unit (names the file, ``where`` and the text).
    """
    m = _COLUMN_RE.match(text)
    if m is None:
        raise DataFileError(f"{p}: {where} {text.strip()!r} is not '<node><+|-><X|Y|Z> <quantity> "
                            "[<unit>]' (e.g. '6+Z acceleration [m/s^2]'; quantity: force, displacement, velocity, "
                            "acceleration)")
    node = int(m.group(1))
    if node < 1:
        raise DataFileError(f"{p}: {where} {text.strip()!r}: node {node} is not a point id")
    direction = direction_code(m.group(2), m.group(3))
    quantity, unit = m.group(4).lower(), m.group(5).strip()
    factor = unit_to_si(p, f"{where} {text.strip()!r}", quantity, unit)
    return node, direction, quantity, factor, unit


def parse_column(p: Path, k: int, text: str) -> tuple[int, int, str, float, str]:
    """One CSV channel column's header: :func:`parse_channel_label` of column ``k`` (1-based).

    Parameters
    ----------
    p, k, text : Path, int, str
        The file (for messages), the column number (1-based) and its header cell.

    Returns
    -------
    (node, direction, quantity, factor, unit)
        As :func:`parse_channel_label`.

    Raises
    ------
    DataFileError
        As :func:`parse_channel_label`, naming the file and column.
    """
    return parse_channel_label(p, f"column {k} header", text)


def _split(p: Path) -> tuple[int, list[str], list[str], list[int]]:
    """Header line number, header cells, the data lines and their line numbers (comments and blanks dropped)."""
    if not p.is_file():
        raise DataFileError(f"{p}: no such file")
    try:
        text = p.read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as exc:
        raise DataFileError(f"{p}: unreadable CSV: {exc}") from exc
    head, cells, rows, numbers = None, [], [], []
    for n, line in enumerate(text.splitlines(), start=1):
        s = line.strip()
        if not s or s.startswith("#"):
            continue
        if head is None:
            head, cells = n, [c.strip() for c in s.split(",")]
        else:
            rows.append(s)
            numbers.append(n)
    if head is None:
        raise DataFileError(f"{p}: empty CSV (no header line)")
    if "".join(cells[0].split()).lower() != TIME_HEADER:
        raise DataFileError(f"{p}: line {head}: the first column must be 'time [s]', found {cells[0]!r}")
    if len(cells) < 2:
        raise DataFileError(f"{p}: line {head}: no channel column after the time")
    return head, cells, rows, numbers


def _numbers(p: Path, rows: list[str], numbers: list[int], width: int) -> np.ndarray:
    """The data lines as an array, shape (n_rows, width); DataFileError naming the line and column otherwise."""
    try:
        data = np.loadtxt(io.StringIO("\n".join(rows)), delimiter=",", ndmin=2, dtype=float)
    except ValueError:
        data = None
    if data is None or data.shape[1] != width:
        for n, row in zip(numbers, rows):
            cells = row.split(",")
            if len(cells) != width:
                raise DataFileError(f"{p}: line {n}: {len(cells)} fields, the header has {width}")
            for k, c in enumerate(cells, start=1):
                try:
                    float(c)
                except ValueError:
                    raise DataFileError(f"{p}: line {n}, column {k}: {c.strip()!r} is not a number") from None
        raise DataFileError(f"{p}: unreadable numbers")  # pragma: no cover - loadtxt and float agree
    bad = np.argwhere(~np.isfinite(data))
    if bad.size:
        r, k = (int(v) for v in bad[0])
        raise DataFileError(f"{p}: line {numbers[r]}, column {k + 1}: non-finite value {float(data[r, k])!r} "
                            f"({bad.shape[0]} in all)")
    return data


def even_time_step(p: Path, t: np.ndarray, where: str, at) -> float:
    """The step of evenly spaced time instants [s], checked against the common grid.

    The step is the least-squares slope of the instants against their index; the rate ``1 / step`` is taken
    as the nearest whole number of samples per second where it lies within three standard errors of the
    slope (acquisition systems sample at whole rates; printed instants carry round-off), else as fitted.
    Each instant must lie within :data:`TIME_JITTER` of a step of the grid ``t[0] + k step``.

    Parameters
    ----------
    p : Path
        The file (for messages).
    t : ndarray, shape (n_samples,)
        The instants [s], finite.
    where : str
        What holds them, for messages (``"time column"``, ``"dataset '/time'"``).
    at : callable
        ``at(j) -> str``: where instant ``j`` is written (``"line 12"``, ``"index 11"``).

    Returns
    -------
    float
        The step [s].

    Raises
    ------
    DataFileError
        Fewer than :data:`vlab.io.uff_time.MIN_SAMPLES` instants, a step that is not positive, or an instant
        off the grid (names the file, ``where`` and the first instant off it).

    Source: least-squares line through (k, t_k); standard error of its slope (e.g. Montgomery & Runger,
    *Applied Statistics and Probability for Engineers*, Sec. 11-4).
    """
    n = t.size
    if n < MIN_SAMPLES:
        raise DataFileError(f"{p}: {where}: {n} sample(s); a record needs at least {MIN_SAMPLES}")
    k = np.arange(n, dtype=float)
    slope, start = np.polyfit(k, t, 1)
    if not slope > 0:
        raise DataFileError(f"{p}: {where}: the step {float(slope)!r} s is not positive ({at(0)} to {at(n - 1)})")
    resid = t - (start + slope * k)
    se = float(np.sqrt(np.sum(resid ** 2) / max(n - 2, 1) * 12.0 / (n * (n * n - 1.0))))
    rate, whole = 1.0 / slope, round(1.0 / slope)
    dt = 1.0 / whole if whole > 0 and abs(rate - whole) <= max(3.0 * se * rate ** 2, 1e-9 * rate) else float(slope)
    off = np.abs(t - (t[0] + dt * k)) / dt
    j = int(np.argmax(off))
    if off[j] > TIME_JITTER:
        raise DataFileError(f"{p}: {where}, {at(j)}: time {float(t[j])!r} s is {off[j]:.3g} steps off the evenly "
                            f"spaced grid of step {dt:.6g} s (limit {TIME_JITTER:g}): unevenly sampled")
    return dt


def read_time_csv(path: str | os.PathLike, *, allow_clipped: bool = False,
                  allow_implausible: bool = False) -> Recording:
    """Read CSV time histories (the format of this module) into a :class:`Recording` in SI.

    Parameters
    ----------
    path : str or path-like
        The CSV file.
    allow_clipped, allow_implausible : bool
        As :func:`vlab.io.uff_time.read_recording` (the checks run on the SI values).

    Returns
    -------
    Recording
        One channel per column after the time, samples in SI, ``dt_s`` the
        time column's step [s]; metadata ``source_file``, ``channel_labels``
        (name -> header cell) and ``units_in_file`` (name -> unit as written).

    Raises
    ------
    DataFileError
        Missing, empty or unreadable file; a header not in the format; an
        unknown or missing unit; two columns of one quantity at one node and
        direction; a line with another number of fields or a cell that is not a
        number (names the line and column); non-finite values; fewer than
        :data:`vlab.io.uff_time.MIN_SAMPLES` samples; an uneven time column.
    MeasurementError
        A clipped channel or an implausible RMS, unless allowed.
    """
    p = Path(path)
    _head, cells, rows, numbers = _split(p)
    data = _numbers(p, rows, numbers, len(cells))
    dt = even_time_step(p, data[:, 0], "time column", lambda j: f"line {numbers[j]}")
    channels, labels, units, seen = [], {}, {}, {}
    for k, text in enumerate(cells[1:], start=2):
        node, direction, quantity, factor, unit = parse_column(p, k, text)
        name = acquired_channel_name(quantity, node, direction)
        if name in seen:
            raise DataFileError(f"{p}: columns {seen[name]} and {k} both hold {quantity} at node {node}, "
                                f"direction {direction} ({name})")
        seen[name] = k
        samples = data[:, k - 1] * factor
        _check_magnitude(p, f"column {k}, channel {name}", samples, quantity, allow_clipped=allow_clipped,
                         allow_implausible=allow_implausible)
        channels.append(Channel(name=name, point_id=node, quantity=quantity, samples=samples, direction=direction))
        labels[name], units[name] = text, unit
    try:
        return Recording(dt_s=dt, channels=tuple(channels),
                         metadata={"source_file": str(p), "channel_labels": labels, "units_in_file": units})
    except MeasurementError as exc:  # pragma: no cover - the checks above come first
        raise DataFileError(f"{p}: {exc}") from exc


__all__ = ["read_time_csv", "is_time_csv", "parse_column", "parse_channel_label", "unit_to_si", "direction_code",
           "even_time_step", "TIME_JITTER", "TIME_HEADER"]
