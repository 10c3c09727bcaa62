"""UFF dataset 58 time histories (function type 1): a :class:`~vlab.io.recording.Recording` to and from a file.

One record per channel: ``rsp_node`` = point id, ``rsp_dir`` = 3 (+Z, out
of plane), ordinate force [N] (specific data type 13), velocity [m/s] (11),
displacement [m] (8) or acceleration [m/s^2] (12); abscissa time [s] (17),
evenly spaced; the exact time step in ID line 4 (``dt_s=<repr>``). The
recording's metadata go to a JSON sidecar (``run.uff`` -> ``run.uff.json``).
The format as a whole is described in :mod:`vlab.io.uff`.

Source: UFF dataset descriptions (SDRC/I-DEAS, https://www.ceas3.uc.edu/sdrluff/);
pyuff (Slavič et al., https://github.com/ladisk/pyuff).
"""

from __future__ import annotations

import math
import os
import re
from pathlib import Path

import numpy as np

from ..errors import DataFileError, MeasurementError
from .recording import (CLIP_FRACTION, CLIP_RUN, MAX_PLAUSIBLE_RMS, Channel, Recording, channel_name, find_clipping,
                        parse_channel_name)
from .uff_files import (CODE_QUANTITY, CONVENTIONAL_NAME_RE, SPEC_DATA_TYPE, UNIT_EXPONENTS, UNITS, check_direction,
                        check_node, check_target, check_unit_label, get_int, id_lines, read_sidecar, read_uff,
                        record_label, sidecar_path, sidecar_text, write_text, write_uff)
from .uff_units import check_exponents, check_time_axis

_TIME = 17
_FUNC_TIME = 1
_DT_RE = re.compile(r"^dt_s=(\S+)$")
_NAME_RE = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
#: Fewest samples a time-response record needs (an FFT of fewer has no line between DC and Nyquist).
MIN_SAMPLES = 4


def write_recording(path: str | os.PathLike, recording: Recording, *, overwrite: bool = False,
                    binary: bool = True) -> Path:
    """Write a recording as UFF 58 time histories (one record per channel) plus a JSON sidecar.

    Parameters
    ----------
    path : str or path-like
        Target ``.uff`` file.
    recording : Recording
        Data to write.
    overwrite : bool
        Replace existing files (the UFF and its sidecar).
    binary : bool
        Write dataset 58b (exact doubles, default) or ASCII 58 (12 digits).

    Returns
    -------
    Path
        The written UFF file.

    Raises
    ------
    DataFileError
        Target exists and ``overwrite`` is False; missing directory;
        metadata not JSON-serialisable (names the key); pyuff failure.
    """
    p = Path(path)
    side = sidecar_path(p)
    check_target(p, overwrite, side)
    meta_text = sidecar_text(side, recording.metadata)
    n = recording.n_samples
    x = np.arange(n) * recording.dt_s
    dsets = []
    for i, ch in enumerate(recording.channels, start=1):
        le, fe = UNIT_EXPONENTS[ch.quantity]
        d = dict(type=58, binary=int(binary), func_type=_FUNC_TIME, rsp_node=ch.point_id,
                 rsp_dir=ch.direction, ref_node=0, ref_dir=0, x=x, data=np.array(ch.samples),
                 abscissa_spacing=1, abscissa_spec_data_type=_TIME, abscissa_axis_lab="Time",
                 abscissa_axis_units_lab="s",
                 ordinate_spec_data_type=SPEC_DATA_TYPE[ch.quantity], ordinate_len_unit_exp=le,
                 ordinate_force_unit_exp=fe, ordinate_axis_lab=ch.quantity.capitalize(),
                 ordinate_axis_units_lab=ch.unit, orddenom_spec_data_type=0,
                 z_axis_spec_data_type=0)
        d.update(id_lines(ch.name, "vlab Recording", i, recording.n_channels,
                      id4=f"dt_s={recording.dt_s!r}"))
        dsets.append(d)
    write_uff(p, dsets)
    write_text(side, meta_text)
    return p


def read_recording(path: str | os.PathLike, *, allow_clipped: bool = False,
                   allow_implausible: bool = False) -> Recording:
    """Read UFF 58 time histories (function type 1) into a :class:`Recording`.

    Channel names come from ID line 1 when it is a valid identifier (vlab
    files), else from quantity and node (``vel1``). The time step is the
    exact ``dt_s=`` of ID line 4 when present, else the header's abscissa
    increment. Metadata come from the JSON sidecar if it exists (plus
    ``"source_file"``).

    Every record is checked, and the first problem is reported with the
    file, the record number (1-based, file order), the channel and the
    offending value:

    * non-finite samples (count and first index);
    * clipping: more than :data:`vlab.io.recording.CLIP_RUN` (3) consecutive
      samples exactly at the channel's maximum or minimum, or more than
      :data:`vlab.io.recording.CLIP_FRACTION` (2 %) of its samples there (a
      flat top; :func:`vlab.io.recording.find_clipping`);
    * mis-sampling: fewer than :data:`MIN_SAMPLES` (4) samples, uneven
      abscissa, a non-positive or non-finite step, channels at different
      steps, a step that disagrees with the ``period_s`` of the sidecar
      metadata (the controller period, when the sidecar states it);
    * mislabelling: an abscissa that is not time (specific data type 17),
      an ordinate unit label that contradicts the data type (``in/s`` on a
      velocity: vlab reads SI only), a direction code that is not a
      translation (+-1..3), a node that is not a positive point id, a
      conventional channel name (``vel4``) that contradicts the record's
      quantity or node, two channels of one quantity at one node and
      direction;
    * inconsistency: channels of different lengths, a header sample count
      that differs from the data;
    * implausible magnitudes: an RMS above
      :data:`vlab.io.recording.MAX_PLAUSIBLE_RMS` (velocity 10 m/s,
      force 1000 N, displacement 0.1 m, acceleration 1e4 m/s^2; derived
      from the sensors and coils of Sec. 5.3), which is a mis-scaled file.

    Parameters
    ----------
    path : str or path-like
        UFF file.
    allow_clipped : bool
        Accept channels with a flat top (e.g. to inspect a run whose
        amplifier saturated on purpose).
    allow_implausible : bool
        Accept RMS values beyond :data:`vlab.io.recording.MAX_PLAUSIBLE_RMS`.

    Returns
    -------
    Recording

    Raises
    ------
    DataFileError
        Missing, empty, malformed or truncated file; no time-response
        record; unknown ordinate type; mislabelled, mis-sampled or
        inconsistent records (above); NaN/inf samples; duplicate channels;
        unreadable sidecar; units that are not SI (:mod:`vlab.io.uff_units`:
        a non-SI units record, a time axis not in s, unit exponents that
        contradict the data type). The message names the file, record and channel.
    MeasurementError
        A clipped channel or an implausible RMS (names file, record, channel
        and the value).
    """
    p, sets = read_uff(path)
    recs = [s for s in sets if s.get("type") == 58 and s.get("func_type") == _FUNC_TIME]
    if not recs:
        raise DataFileError(f"{p}: no dataset-58 time-response (function type 1) record")
    metadata = read_sidecar(p)
    channels = []
    keys: dict[tuple[int, str, int], str] = {}
    dt_ref = ref_name = None
    for i, s in enumerate(recs, start=1):
        name, quantity, node, direction, where = _time_record_identity(p, s, i)
        data = _time_record_samples(p, s, name, where, i)
        dt = _time_step(p, name, s)
        if dt_ref is None:
            dt_ref, ref_name = dt, name
        elif not math.isclose(dt, dt_ref, rel_tol=1e-9):
            raise DataFileError(f"{p}: channel {name} is sampled every {dt!r} s, "
                                f"channel {ref_name} every {dt_ref!r} s")
        _check_new_channel(p, channels, keys, i, name, where, data.size, (node, quantity, direction))
        _check_magnitude(p, where, data, quantity, allow_clipped=allow_clipped, allow_implausible=allow_implausible)
        try:
            channels.append(Channel(name=name, point_id=node, quantity=quantity, samples=data,
                                    direction=direction))
        except MeasurementError as exc:
            raise DataFileError(f"{p}: record {i}: {exc}") from exc
    _check_sidecar_period(p, metadata.get("period_s"), dt_ref)
    try:
        return Recording(dt_s=dt_ref, channels=tuple(channels), metadata=metadata)
    except MeasurementError as exc:
        raise DataFileError(f"{p}: {exc}") from exc


def _check_new_channel(p: Path, channels: list, keys: dict, i: int, name: str, where: str, size: int,
                       key: tuple[int, str, int]) -> None:
    """Record ``i`` against the channels read before it: same length, a new name, a new (node, quantity, direction).

    Adds its ``key`` to ``keys``; DataFileError naming both channels otherwise.
    """
    if channels and size != channels[0].samples.size:
        raise DataFileError(f"{p}: channel {name} has {size} samples, channel "
                            f"{channels[0].name} has {channels[0].samples.size}")
    if any(c.name == name for c in channels):
        raise DataFileError(f"{p}: duplicate channel {name} (record {i})")
    if key in keys:
        node, quantity, direction = key
        raise DataFileError(f"{p}: {where}: duplicates channel {keys[key]} ({quantity} at node {node}, "
                            f"direction {direction})")
    keys[key] = name


def _time_record_identity(p: Path, s: dict, i: int) -> tuple[str, str, int, int, str]:
    """Channel name, quantity, node, direction and message prefix of time record ``i``, its labels checked."""
    where = f"record {i}"
    code = get_int(p, s, "ordinate_spec_data_type", where)
    node = check_node(p, s, "rsp_node", where)
    if code not in CODE_QUANTITY:
        raise DataFileError(f"{p}: record {i} ({record_label(s, f'node {node}')!r}): unsupported ordinate "
                            f"specific data type {code} (known: {sorted(CODE_QUANTITY)})")
    quantity = CODE_QUANTITY[code]
    fallback = channel_name(quantity, node)
    name = record_label(s, fallback)
    if not _NAME_RE.match(name):
        name = fallback
    where = f"record {i}, channel {name}"
    if CONVENTIONAL_NAME_RE.match(name):
        q_name, n_name = parse_channel_name(name)
        if (q_name, n_name) != (quantity, node):
            raise DataFileError(f"{p}: {where}: the name says {q_name} at point {n_name}, the record holds "
                                f"{quantity} (data type {code}) at node {node} (mislabelled channel)")
    direction = check_direction(p, s, "rsp_dir", where)
    check_unit_label(p, s, quantity, where)
    check_exponents(p, s, "ordinate", code, where)
    absc = int(s.get("abscissa_spec_data_type", _TIME) or 0)
    if absc not in (0, _TIME):
        raise DataFileError(f"{p}: {where}: abscissa specific data type {absc} is not time ({_TIME})")
    check_time_axis(p, s, where)
    return name, quantity, node, direction, where


def _time_record_samples(p: Path, s: dict, name: str, where: str, i: int) -> np.ndarray:
    """The real, finite samples of time record ``i`` (at least MIN_SAMPLES, as many as its header says)."""
    data = np.asarray(s["data"]) if "data" in s else np.zeros(0)
    if np.iscomplexobj(data):
        raise DataFileError(f"{p}: {where}: complex samples in a time response")
    if data.size != int(s.get("num_pts", data.size)):
        raise DataFileError(f"{p}: {where}: {data.size} samples, header announces "
                            f"{s['num_pts']} (truncated file)")
    bad = np.flatnonzero(~np.isfinite(data))
    if bad.size:
        raise DataFileError(f"{p}: channel {name}: non-finite sample at index {bad[0]} ({float(data[bad[0]])}; "
                            f"{bad.size} in all, record {i})")
    if data.size < MIN_SAMPLES:
        raise DataFileError(f"{p}: {where}: {data.size} sample(s); a record needs at least {MIN_SAMPLES}")
    return data.astype(float)


def _check_magnitude(p: Path, where: str, data: np.ndarray, quantity: str, *, allow_clipped: bool,
                     allow_implausible: bool) -> None:
    """MeasurementError for an implausible RMS or a clipped channel, unless allowed."""
    if not allow_implausible:
        with np.errstate(over="ignore"):
            rms = float(np.sqrt(np.mean(data ** 2)))
        if rms > MAX_PLAUSIBLE_RMS[quantity]:
            raise MeasurementError(
                f"{p}: {where}: RMS {rms:.4g} {UNITS[quantity]} is implausible for the lab's hardware "
                f"(limit {MAX_PLAUSIBLE_RMS[quantity]:g} {UNITS[quantity]}, Sec. 5.3): a mis-scaled file "
                "(wrong unit or gain)?")
    if not allow_clipped:
        clip = find_clipping(data)
        if clip is not None:
            run, start, word, value, count = clip
            raise MeasurementError(
                f"{p}: {where}: clipped: {count} samples at its {word} {value:.6g} {UNITS[quantity]}, "
                f"{run} in a row from index {start} (a flat top: more than {CLIP_RUN} in a row or "
                f"{100 * CLIP_FRACTION:g} % of the samples; saturated amplifier or ADC range)")


def _check_sidecar_period(p: Path, period, dt_ref: float) -> None:
    """DataFileError when the sidecar's controller period ``period_s`` is not a positive number or not the step."""
    if period is None:
        return
    if isinstance(period, bool) or not isinstance(period, (int, float)) or not (
            math.isfinite(period) and period > 0):
        raise DataFileError(f"{sidecar_path(p)}: field 'period_s': expected a positive number of seconds, "
                            f"got {period!r}")
    if not math.isclose(float(period), dt_ref, rel_tol=1e-6):
        raise DataFileError(f"{p}: channels are sampled every {dt_ref!r} s, the sidecar's controller period "
                            f"'period_s' is {period!r} s (mis-sampled recording)")


def _time_step(p: Path, name: str, s: dict) -> float:
    m = _DT_RE.match(str(s.get("id4", "")).strip())
    even = "abscissa_spacing" not in s or get_int(p, s, "abscissa_spacing", f"channel {name}") == 1
    if even:
        inc = float(s.get("abscissa_inc", 0.0))
    else:
        x = np.asarray(s.get("x", []), dtype=float)
        if x.size < 2:
            raise DataFileError(f"{p}: channel {name}: fewer than two samples")
        d = np.diff(x)
        inc = float(d.mean())
        if np.any(np.abs(d - inc) > 1e-6 * abs(inc)):
            raise DataFileError(f"{p}: channel {name}: unevenly spaced time samples")
    if m:
        try:
            exact = float(m.group(1))
        except ValueError:
            raise DataFileError(f"{p}: channel {name}: bad time step in ID line 4: {s['id4']!r}") from None
        if inc > 0 and not math.isclose(exact, inc, rel_tol=1e-5):
            raise DataFileError(f"{p}: channel {name}: ID line time step {exact} s disagrees with "
                                f"the header's {inc} s")
        inc = exact
    if not (math.isfinite(inc) and inc > 0):
        raise DataFileError(f"{p}: channel {name}: sampling interval {inc} s is not positive")
    return inc


