"""Universal File Format (UFF) input/output with pyuff.

Formats (DESIGN.md, "Data formats"):

* **Recordings** — dataset 58, function type 1 (time response), one record
  per channel: ``rsp_node`` = point id, ``rsp_dir`` = 3 (+Z, out of plane),
  ordinate force [N] (specific data type 13), velocity [m/s] (11),
  displacement [m] (8) or acceleration [m/s^2] (12); abscissa time [s] (17),
  evenly spaced.
* **FRFs** — dataset 58, function type 4, ``ref_node`` = force point,
  ``rsp_node`` = response point, complex ordinate per force (denominator
  type 13), explicit frequency abscissa [Hz]; the coherence follows each FRF
  as a function type 6 record with the same nodes.
* **Mode shapes** — dataset 55, normal modes (analysis type 2, real shapes)
  or complex modes (type 3), 3-DOF nodal data with the shape in Z.

vlab writes datasets 58 in binary form ("58b", doubles) by default, so a
written file reloads bit-identical. Two values the fixed-width UFF header
keeps only to 6 digits are stored exactly in ID lines: ``id4 =
"dt_s=<repr>"`` for time step; and ``id5 = "record i of n"`` lets the
reader detect a file truncated at a record boundary. ID line 1 holds the
channel name (``force4``), or ``output/input`` for an FRF. Dataset 55 is
ASCII ``E13.5``: mode shapes keep 6 significant digits.

A recording's metadata goes to a JSON sidecar next to the UFF file
(``run.uff`` -> ``run.uff.json``), because UFF ID lines hold 80 characters.

Writing never replaces an existing file unless ``overwrite=True``; files are
written to a temporary name and moved into place, so a failed write leaves
no partial file.

Layout: shared file handling and header checks in :mod:`vlab.io.uff_files`,
units in :mod:`vlab.io.uff_units`, mode shapes (dataset 55) in
:mod:`vlab.io.uff55` (re-exported here).

Source: UFF dataset descriptions (SDRC/I-DEAS, https://www.ceas3.uc.edu/sdrluff/);
pyuff (Slavič et al., https://github.com/ladisk/pyuff).
"""

from __future__ import annotations

import json
import math
import os
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import DataFileError, MeasurementError
from .frf import FRF
from .recording import (CLIP_FRACTION, CLIP_RUN, MAX_PLAUSIBLE_RMS, Channel, Recording, channel_name, find_clipping,
                        parse_channel_name)
from .uff_files import (_UNITS, _check_direction, _check_node, _check_target, _check_unit_label, _get_int, _ids,
                        _label, _read_uff, _write_text, _write_uff, sidecar_path)
from .uff_units import check_exponents, check_force_denominator, check_time_axis, frequency_factor

#: UFF specific data type code of each quantity.
SPEC_DATA_TYPE = {"displacement": 8, "velocity": 11, "acceleration": 12, "force": 13}
_CODE_QUANTITY = {8: "displacement", 11: "velocity", 12: "acceleration", 13: "force", 9: "force"}
_UNIT_EXP = {  # (length exponent, force exponent) of each quantity
    "displacement": (1, 0), "velocity": (1, 0), "acceleration": (1, 0), "force": (0, 1)}
_TIME, _FREQ = 17, 18
_FUNC_TIME, _FUNC_FRF, _FUNC_COH = 1, 4, 6
_DT_RE = re.compile(r"^dt_s=(\S+)$")
_NAVG_RE = re.compile(r"^n_averages=(\d+)$")
_NAME_RE = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
_CONV_RE = re.compile(r"^(force|disp|vel|acc)\d+$")
#: Fewest samples a time-response record needs (an FFT of fewer has no line between DC and Nyquist).
MIN_SAMPLES = 4


# --------------------------------------------------------------------------- recordings
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
    _check_target(p, overwrite, side)
    try:
        meta_text = json.dumps(dict(recording.metadata), sort_keys=True, indent=2, allow_nan=False)
    except (TypeError, ValueError) as exc:
        bad = [k for k, v in recording.metadata.items() if not _jsonable(v)]
        raise DataFileError(f"{side}: metadata key(s) {bad} not JSON-serialisable: {exc}") from exc
    n = recording.n_samples
    x = np.arange(n) * recording.dt_s
    dsets = []
    for i, ch in enumerate(recording.channels, start=1):
        le, fe = _UNIT_EXP[ch.quantity]
        d = dict(type=58, binary=int(binary), func_type=_FUNC_TIME, rsp_node=ch.point_id,
                 rsp_dir=ch.direction, ref_node=0, ref_dir=0, x=x, data=np.array(ch.samples),
                 abscissa_spacing=1, abscissa_spec_data_type=_TIME, abscissa_axis_lab="Time",
                 abscissa_axis_units_lab="s",
                 ordinate_spec_data_type=SPEC_DATA_TYPE[ch.quantity], ordinate_len_unit_exp=le,
                 ordinate_force_unit_exp=fe, ordinate_axis_lab=ch.quantity.capitalize(),
                 ordinate_axis_units_lab=ch.unit, orddenom_spec_data_type=0,
                 z_axis_spec_data_type=0)
        d.update(_ids(ch.name, "vlab Recording", i, recording.n_channels,
                      id4=f"dt_s={recording.dt_s!r}"))
        dsets.append(d)
    _write_uff(p, dsets)
    _write_text(side, meta_text + "\n")
    return p


def _jsonable(v: Any) -> bool:
    try:
        json.dumps(v, allow_nan=False)
        return True
    except (TypeError, ValueError):
        return False


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
    p, sets = _read_uff(path)
    recs = [s for s in sets if s.get("type") == 58 and s.get("func_type") == _FUNC_TIME]
    if not recs:
        raise DataFileError(f"{p}: no dataset-58 time-response (function type 1) record")
    metadata = _read_sidecar(p)
    channels = []
    keys: dict[tuple[int, str, int], str] = {}
    dt_ref = None
    ref_name = None
    for i, s in enumerate(recs, start=1):
        name, quantity, node, direction, where = _time_record_identity(p, s, i)
        data = _time_record_samples(p, s, name, where, i)
        dt = _time_step(p, name, s)
        if dt_ref is None:
            dt_ref, ref_name = dt, name
        elif not math.isclose(dt, dt_ref, rel_tol=1e-9):
            raise DataFileError(f"{p}: channel {name} is sampled every {dt!r} s, "
                                f"channel {ref_name} every {dt_ref!r} s")
        if channels and data.size != channels[0].samples.size:
            raise DataFileError(f"{p}: channel {name} has {data.size} samples, channel "
                                f"{channels[0].name} has {channels[0].samples.size}")
        if any(c.name == name for c in channels):
            raise DataFileError(f"{p}: duplicate channel {name} (record {i})")
        key = (node, quantity, direction)
        if key in keys:
            raise DataFileError(f"{p}: {where}: duplicates channel {keys[key]} ({quantity} at node {node}, "
                                f"direction {direction})")
        keys[key] = name
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


def _time_record_identity(p: Path, s: dict, i: int) -> tuple[str, str, int, int, str]:
    """Channel name, quantity, node, direction and message prefix of time record ``i``, its labels checked."""
    where = f"record {i}"
    code = _get_int(p, s, "ordinate_spec_data_type", where)
    node = _check_node(p, s, "rsp_node", where)
    if code not in _CODE_QUANTITY:
        raise DataFileError(f"{p}: record {i} ({_label(s, f'node {node}')!r}): unsupported ordinate "
                            f"specific data type {code} (known: {sorted(_CODE_QUANTITY)})")
    quantity = _CODE_QUANTITY[code]
    fallback = channel_name(quantity, node)
    name = _label(s, fallback)
    if not _NAME_RE.match(name):
        name = fallback
    where = f"record {i}, channel {name}"
    if _CONV_RE.match(name):
        q_name, n_name = parse_channel_name(name)
        if (q_name, n_name) != (quantity, node):
            raise DataFileError(f"{p}: {where}: the name says {q_name} at point {n_name}, the record holds "
                                f"{quantity} (data type {code}) at node {node} (mislabelled channel)")
    direction = _check_direction(p, s, "rsp_dir", where)
    _check_unit_label(p, s, quantity, where)
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
                f"{p}: {where}: RMS {rms:.4g} {_UNITS[quantity]} is implausible for the lab's hardware "
                f"(limit {MAX_PLAUSIBLE_RMS[quantity]:g} {_UNITS[quantity]}, Sec. 5.3): a mis-scaled file "
                "(wrong unit or gain)?")
    if not allow_clipped:
        clip = find_clipping(data)
        if clip is not None:
            run, start, word, value, count = clip
            raise MeasurementError(
                f"{p}: {where}: clipped: {count} samples at its {word} {value:.6g} {_UNITS[quantity]}, "
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
    even = "abscissa_spacing" not in s or _get_int(p, s, "abscissa_spacing", f"channel {name}") == 1
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


def _read_sidecar(p: Path) -> dict:
    side = sidecar_path(p)
    meta: dict = {}
    if side.is_file():
        try:
            meta = json.loads(side.read_text(encoding="utf-8"))
        except (OSError, ValueError) as exc:
            raise DataFileError(f"{side}: unreadable metadata sidecar: {exc}") from exc
        if not isinstance(meta, dict):
            raise DataFileError(f"{side}: metadata sidecar must hold a JSON object")
    return meta


# --------------------------------------------------------------------------- FRFs
def write_frfs(path: str | os.PathLike, frfs: Sequence[FRF] | Mapping[str, FRF], *,
               overwrite: bool = False, binary: bool = True,
               band_hz: tuple[float, float] | None = None) -> Path:
    """Write FRFs as UFF 58 function type 4 records (each followed by its coherence, type 6).

    ID line 4 of every record states the band: ``"excited band <lo>-<hi> Hz"``
    when ``band_hz`` is given, otherwise ``"lines <first>-<last> Hz"``.

    Parameters
    ----------
    path : str or path-like
        Target file.
    frfs : sequence of FRF or mapping of str to FRF
        FRFs with ``output_point`` and ``input_point`` set.
    overwrite : bool
        Replace an existing file.
    binary : bool
        Dataset 58b (exact doubles, default) or ASCII.
    band_hz : (float, float), optional
        The excited band [Hz]; every FRF's lines must lie in it (the lines
        outside an excited band carry no measured information).

    Returns
    -------
    Path

    Raises
    ------
    DataFileError
        Target exists, no FRFs, an FRF without point ids or with non-finite
        values (names it; pyuff would write NaN as 0), an FRF with lines
        outside ``band_hz`` (names it and the line), pyuff failure.
    """
    p = Path(path)
    _check_target(p, overwrite)
    items = list(frfs.values()) if isinstance(frfs, Mapping) else list(frfs)
    if not items:
        raise DataFileError(f"{p}: no FRF to write")
    n_rec = sum(2 if f.coherence is not None else 1 for f in items)
    dsets = []
    i = 0
    for frf in items:
        if frf.output_point is None or frf.input_point is None:
            raise DataFileError(f"{p}: FRF {frf.name} has no output_point/input_point for the UFF nodes")
        if not np.all(np.isfinite(frf.h)) or (frf.coherence is not None
                                              and not np.all(np.isfinite(frf.coherence))):
            # pyuff would silently write NaN as 0
            raise DataFileError(f"{p}: FRF {frf.name}: non-finite values cannot be written "
                                "(restrict it with FRF.band() to the excited lines)")
        fr = np.asarray(frf.freq_hz)
        if band_hz is not None:
            lo, hi = (float(b) for b in band_hz)
            out = np.flatnonzero((fr < lo - 1e-9 * max(1.0, abs(lo))) | (fr > hi + 1e-9 * max(1.0, abs(hi))))
            if out.size:
                raise DataFileError(f"{p}: FRF {frf.name}: line {fr[out[0]]:g} Hz lies outside the excited band "
                                    f"{lo:g}-{hi:g} Hz (restrict it with FRF.band())")
            band_line = f"excited band {lo:g}-{hi:g} Hz"
        else:
            band_line = f"lines {fr[0]:g}-{fr[-1]:g} Hz" if fr.size else "NONE"
        le, fe = _UNIT_EXP[frf.response]
        navg = "NONE" if frf.n_averages is None else f"n_averages={frf.n_averages}"
        base = dict(type=58, binary=int(binary), rsp_node=frf.output_point, rsp_dir=3,
                    ref_node=frf.input_point, ref_dir=3, x=np.array(frf.freq_hz), abscissa_spacing=0,
                    abscissa_spec_data_type=_FREQ, abscissa_axis_lab="Frequency",
                    abscissa_axis_units_lab="Hz", z_axis_spec_data_type=0)
        i += 1
        d = dict(base, func_type=_FUNC_FRF, data=np.array(frf.h, dtype=complex),
                 ordinate_spec_data_type=SPEC_DATA_TYPE[frf.response], ordinate_len_unit_exp=le,
                 ordinate_axis_lab=frf.response.capitalize(),
                 ordinate_axis_units_lab=_UNITS[frf.response],
                 orddenom_spec_data_type=SPEC_DATA_TYPE["force"], orddenom_force_unit_exp=1,
                 orddenom_axis_lab="Force", orddenom_axis_units_lab="N")
        d.update(_ids(frf.name, "vlab FRF", i, n_rec, id3=navg, id4=band_line))
        dsets.append(d)
        if frf.coherence is not None:
            i += 1
            c = dict(base, func_type=_FUNC_COH, data=np.array(frf.coherence, dtype=float),
                     ordinate_spec_data_type=0, ordinate_axis_lab="Coherence",
                     ordinate_axis_units_lab="1", orddenom_spec_data_type=0)
            c.update(_ids(frf.name, "vlab coherence", i, n_rec, id3=navg, id4=band_line))
            dsets.append(c)
    _write_uff(p, dsets)
    return p


def read_frfs(path: str | os.PathLike) -> list[FRF]:
    """Read UFF 58 FRFs (function type 4), attaching coherence records (type 6) with the same nodes.

    Parameters
    ----------
    path : str or path-like
        UFF file.

    Returns
    -------
    list of FRF
        In file order.

    Raises
    ------
    DataFileError
        Missing, malformed or truncated file; no FRF record; unknown
        response type; a denominator that is not force; non-finite values;
        a frequency axis that is negative or not increasing; a coherence
        outside [0, 1]; a node that is not a point id, a direction that is
        not a translation, a unit label or channel name that contradicts the
        record (mislabelled); two FRFs between the same nodes; units that
        are not SI (:mod:`vlab.io.uff_units`: a non-SI units record, a
        denominator per lbf, a frequency axis in units other than Hz, kHz or
        rad/s -- those two are converted to Hz -- unit exponents that
        contradict the data type). The message names the file, the FRF
        record and the value.
    """
    p, sets = _read_uff(path)
    sets = [s for s in sets if s.get("type") == 58]
    frf_sets = [s for s in sets if s.get("func_type") == _FUNC_FRF]
    if not frf_sets:
        raise DataFileError(f"{p}: no dataset-58 FRF (function type 4) record")
    cohs = [s for s in sets if s.get("func_type") == _FUNC_COH]
    for c in cohs:  # the node fields the pairing needs
        for key in ("rsp_node", "ref_node", "rsp_dir", "ref_dir"):
            _get_int(p, c, key, f"coherence record {_label(c, '?')!r}")
    out = []
    seen: dict[tuple[int, int, str], str] = {}
    for i, s in enumerate(frf_sets, start=1):
        where = f"FRF record {i}"
        out_node = _check_node(p, s, "rsp_node", where)
        in_node = _check_node(p, s, "ref_node", where)
        code = _get_int(p, s, "ordinate_spec_data_type", where)
        if code not in (8, 11, 12):
            raise DataFileError(f"{p}: FRF {_label(s, str(out_node))}: unsupported response "
                                f"specific data type {code} (8, 11 or 12 expected)")
        response = _CODE_QUANTITY[code]
        den = int(s.get("orddenom_spec_data_type", 0) or 0)
        if den not in (0, 9, 13):
            raise DataFileError(f"{p}: FRF {_label(s, str(out_node))}: denominator type {den} is not a force")
        default = f"{channel_name(response, out_node)}/{channel_name('force', in_node)}"
        label = _label(s, default)
        if label.count("/") != 1:
            label = default
        out_name, in_name = label.split("/")
        where = f"FRF record {i} ({label})"
        # the output name is the measured channel (an FRF converted to displacement keeps 'vel1'): its
        # point must match; the input must be a force at the reference node
        if _CONV_RE.match(out_name) and parse_channel_name(out_name)[1] != out_node:
            raise DataFileError(f"{p}: {where}: output channel name {out_name!r} contradicts the record's "
                                f"response node {out_node} (mislabelled FRF)")
        if _CONV_RE.match(in_name) and parse_channel_name(in_name) != ("force", in_node):
            raise DataFileError(f"{p}: {where}: input channel name {in_name!r} contradicts the record's "
                                f"force at reference node {in_node} (mislabelled FRF)")
        _check_direction(p, s, "rsp_dir", where)
        _check_direction(p, s, "ref_dir", where)
        _check_unit_label(p, s, response, where)
        check_exponents(p, s, "ordinate", code, where)
        check_force_denominator(p, s, where)
        absc = int(s.get("abscissa_spec_data_type", _FREQ) or 0)
        if absc not in (0, _FREQ):
            raise DataFileError(f"{p}: {where}: abscissa specific data type {absc} is not frequency ({_FREQ})")
        to_hz = frequency_factor(p, s, where)
        f = np.asarray(s.get("x", []))
        h = np.asarray(s.get("data", []))
        if np.iscomplexobj(f):
            raise DataFileError(f"{p}: {where}: complex frequency axis")
        f = f.astype(float)
        if h.size != int(s.get("num_pts", h.size)) or f.size != h.size:
            raise DataFileError(f"{p}: FRF {label}: {h.size} values, header announces {s.get('num_pts')}")
        if h.size == 0:
            raise DataFileError(f"{p}: {where}: no frequency line")
        for what, arr in (("frequency", f), ("value", h)):
            bad = np.flatnonzero(~np.isfinite(arr))
            if bad.size:
                raise DataFileError(f"{p}: FRF {label}: non-finite values ({what} {complex(arr[bad[0]]) if np.iscomplexobj(arr) else float(arr[bad[0]])} at line "
                                    f"{bad[0]}, {bad.size} in all)")
        if f[0] < 0:
            raise DataFileError(f"{p}: {where}: negative frequency {f[0]:g} Hz at line 0")
        steps = np.diff(f)
        if steps.size and np.any(steps <= 0):
            k = int(np.flatnonzero(steps <= 0)[0])
            raise DataFileError(f"{p}: {where}: frequency axis not increasing: line {k + 1} at {f[k + 1]:g} Hz "
                                f"after {f[k]:g} Hz")
        key = (out_node, in_node, response)
        if key in seen:
            raise DataFileError(f"{p}: {where}: a second {response} FRF from node {in_node} to node {out_node} "
                                f"(first: {seen[key]})")
        seen[key] = label
        c = _coherence_for(s, f, sets, cohs)
        f = f * to_hz  # the record's own unit (rad/s, kHz) to Hz, after pairing with its coherence record
        if c is not None:
            bad = np.flatnonzero(~np.isfinite(c))
            if bad.size:
                raise DataFileError(f"{p}: coherence of FRF {label}: non-finite values ({float(c[bad[0]])} at "
                                    f"{f[bad[0]]:g} Hz)")
            bad = np.flatnonzero((c < -1e-9) | (c > 1 + 1e-9))
            if bad.size:
                raise DataFileError(f"{p}: coherence of FRF {label}: {c[bad[0]]:g} at {f[bad[0]]:g} Hz is "
                                    "outside [0, 1]")
        m = _NAVG_RE.match(str(s.get("id3", "")).strip())
        try:
            out.append(FRF(freq_hz=f, h=h.astype(complex), response=response, coherence=c,
                           output_name=out_name, input_name=in_name, output_point=out_node,
                           input_point=in_node, n_averages=int(m.group(1)) if m else None))
        except MeasurementError as exc:
            raise DataFileError(f"{p}: FRF {label}: {exc}") from exc
    return out


def _node_key(s: dict) -> tuple[int, int, int, int]:
    return int(s["rsp_node"]), int(s["rsp_dir"]), int(s["ref_node"]), int(s["ref_dir"])


def _coherence_for(frf_set: dict, f: np.ndarray, sets: list[dict], cohs: list[dict]) -> np.ndarray | None:
    """Coherence record of an FRF: the record right after it (as vlab writes), else the
    only coherence record with the same nodes and frequencies; ``None`` if there is none."""
    def matches(c: dict) -> bool:
        cx = np.asarray(c["x"], dtype=float)
        return (_node_key(c) == _node_key(frf_set) and cx.shape == f.shape
                and np.array_equal(cx, f))
    i = next(k for k, s in enumerate(sets) if s is frf_set)
    if i + 1 < len(sets) and sets[i + 1].get("func_type") == _FUNC_COH and matches(sets[i + 1]):
        return np.real(np.asarray(sets[i + 1]["data"]))
    hits = [c for c in cohs if matches(c)]
    if len(hits) == 1:
        return np.real(np.asarray(hits[0]["data"]))
    return None


from .uff55 import ModeShapes, read_mode_shapes, write_mode_shapes  # noqa: E402  (dataset 55, re-exported)
