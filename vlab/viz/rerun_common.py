"""What the rerun modules of :mod:`vlab.viz` share: entity paths, timelines, colours and input checks.

The entity paths and timelines of a recording are described in
:mod:`vlab.viz.rerun_log`. rerun itself is imported lazily
(:func:`rerun_module`), so importing :mod:`vlab.viz` stays cheap and has no
side effects.

Source: rerun-sdk 0.41 Python API (entity paths, timelines).
"""

from __future__ import annotations

import math
import re
from typing import Any

import numpy as np

from ..errors import MeasurementError

#: Simulation-time timeline (duration, seconds).
SIM_TIMELINE = "sim_time"
#: Frequency timeline of the FRFs (sequence, integer millihertz).
FREQUENCY_TIMELINE = "frequency_mhz"
#: Parent entity of the time series.
SIGNALS_ROOT = "signals"
#: Animated deformed members (line strips).
STRUCTURE_MEMBERS = "structure/members"
#: Animated structure points.
STRUCTURE_POINTS = "structure/points"
#: Members at rest (static).
STRUCTURE_UNDEFORMED = "structure/undeformed"
#: Parent entity of the FRFs; each FRF goes to ``frf/<name>/magnitude``.
FRF_ROOT = "frf"
#: Run metadata (static JSON text document).
META_ENTITY = "meta/run"

_SEGMENT_RE = re.compile(r"^[A-Za-z0-9_.\-]+$")
#: Colour of the deformed members.
MEMBER_COLOR = (40, 110, 200)
#: Colour of the members at rest.
UNDEFORMED_COLOR = (150, 150, 150)
#: Colour of the structure points.
POINT_COLOR = (220, 80, 30)
#: Tableau-10: the colours of successive FRF curves.
PALETTE = (
    (31, 119, 180), (255, 127, 14), (44, 160, 44), (214, 39, 40), (148, 103, 189),
    (140, 86, 75), (227, 119, 194), (127, 127, 127), (188, 189, 34), (23, 190, 207),
)


def rerun_module():
    """The ``rerun`` module, imported on first use (keeps ``import vlab.viz`` cheap and side-effect free).

    Returns
    -------
    module
        ``rerun`` (rerun-sdk).
    """
    import rerun as rr

    return rr


# ------------------------------------------------------------- validation ---


def check_name(name: str, what: str) -> str:
    """Check an entity-path name: segments of letters, digits, ``_ . -`` joined by '/'.

    Parameters
    ----------
    name : str
        The name (``"vel6"``, ``"experiment/vel4_force4"``).
    what : str
        What it names, for the message (``"signal"``, ``"FRF"``).

    Returns
    -------
    str
        ``name``.

    Raises
    ------
    MeasurementError
        An empty name or one that is not a valid entity path.
    """
    if not isinstance(name, str) or not name:
        raise MeasurementError(f"{what}: name must be a non-empty string, got {name!r}")
    for seg in name.split("/"):
        if not _SEGMENT_RE.match(seg):
            raise MeasurementError(
                f"{what}: name {name!r} is not a valid entity path; use letters, digits, "
                "'_', '.', '-' and '/' between non-empty parts")
    return name


def finite_1d(values: Any, what: str, *, n: int | None = None, dtype: Any = float) -> np.ndarray:
    """``values`` as a finite 1-D array.

    Parameters
    ----------
    values : array_like, shape (n,)
    what : str
        What it is, for the message.
    n : int, optional
        Required length.
    dtype : data-type
        Of the array returned.

    Returns
    -------
    ndarray, shape (n,)

    Raises
    ------
    MeasurementError
        Not 1-D, of another length than ``n``, or non-finite values.
    """
    arr = np.asarray(values, dtype=dtype)
    if arr.ndim != 1:
        raise MeasurementError(f"{what}: expected a 1-D array, got shape {arr.shape}")
    if n is not None and arr.size != n:
        raise MeasurementError(f"{what}: expected shape ({n},), got {arr.shape}")
    bad = np.flatnonzero(~np.isfinite(arr))
    if bad.size:
        raise MeasurementError(f"{what}: {bad.size} non-finite value(s), first at index {bad[0]}")
    return arr


def positive_number(value: float, what: str) -> float:
    """``value`` as a positive finite float.

    Parameters
    ----------
    value : float
    what : str
        What it is, for the message (``"dt_s"``, ``"fps"``).

    Returns
    -------
    float

    Raises
    ------
    MeasurementError
        Zero, negative or not finite.
    """
    v = float(value)
    if not math.isfinite(v) or v <= 0.0:
        raise MeasurementError(f"{what} must be a positive finite number, got {value!r}")
    return v
