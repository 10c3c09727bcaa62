"""UFF dataset 58 FRFs (function type 4) with their coherence (type 6): :class:`~vlab.io.frf.FRF` to and from a file.

``ref_node`` = force point, ``rsp_node`` = response point, complex ordinate
per force (denominator type 13), explicit frequency abscissa [Hz] (18); the
coherence follows each FRF as a function type 6 record with the same nodes.
ID line 3 holds ``n_averages=<n>``, ID line 4 the band. The format as a whole
is described in :mod:`vlab.io.uff`.

Source: UFF dataset descriptions (SDRC/I-DEAS, https://www.ceas3.uc.edu/sdrluff/);
pyuff (Slavič et al., https://github.com/ladisk/pyuff).
"""

from __future__ import annotations

import os
import re
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from ..errors import DataFileError, MeasurementError
from .frf import FRF
from .recording import channel_name, parse_channel_name
from .uff_files import (CODE_QUANTITY, CONVENTIONAL_NAME_RE, SPEC_DATA_TYPE, UNIT_EXPONENTS, UNITS, check_direction,
                        check_node, check_target, check_unit_label, get_int, id_lines, read_uff, record_label,
                        sidecar_path, sidecar_text, write_text, write_uff)
from .uff_units import check_exponents, check_force_denominator, frequency_factor

_FREQ = 18
_FUNC_FRF, _FUNC_COH = 4, 6
_NAVG_RE = re.compile(r"^n_averages=(\d+)$")


def write_frfs(path: str | os.PathLike, frfs: Sequence[FRF] | Mapping[str, FRF], *,
               overwrite: bool = False, binary: bool = True,
               band_hz: tuple[float, float] | None = None, metadata: Mapping | None = None) -> Path:
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
    metadata : mapping, optional
        The test's setup (structure, controller, seed, chain, ... as a recording's), written to the JSON
        sidecar ``<path>.json`` that a diagnosis reads as it reads a recording's.

    Returns
    -------
    Path
        ``path``, the UFF 58 file written.

    Raises
    ------
    DataFileError
        Target exists, no FRFs, an FRF without point ids or with non-finite
        values (names it; pyuff would write NaN as 0), an FRF with lines
        outside ``band_hz`` (names it and the line), pyuff failure.
    """
    p = Path(path)
    side = sidecar_path(p)
    check_target(p, overwrite, *([side] if metadata is not None else []))
    meta_text = None if metadata is None else sidecar_text(side, metadata)
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
        le, fe = UNIT_EXPONENTS[frf.response]
        navg = "NONE" if frf.n_averages is None else f"n_averages={frf.n_averages}"
        base = dict(type=58, binary=int(binary), rsp_node=frf.output_point, rsp_dir=3,
                    ref_node=frf.input_point, ref_dir=3, x=np.array(frf.freq_hz), abscissa_spacing=0,
                    abscissa_spec_data_type=_FREQ, abscissa_axis_lab="Frequency",
                    abscissa_axis_units_lab="Hz", z_axis_spec_data_type=0)
        i += 1
        d = dict(base, func_type=_FUNC_FRF, data=np.array(frf.h, dtype=complex),
                 ordinate_spec_data_type=SPEC_DATA_TYPE[frf.response], ordinate_len_unit_exp=le,
                 ordinate_axis_lab=frf.response.capitalize(),
                 ordinate_axis_units_lab=UNITS[frf.response],
                 orddenom_spec_data_type=SPEC_DATA_TYPE["force"], orddenom_force_unit_exp=1,
                 orddenom_axis_lab="Force", orddenom_axis_units_lab="N")
        d.update(id_lines(frf.name, "vlab FRF", i, n_rec, id3=navg, id4=band_line))
        dsets.append(d)
        if frf.coherence is not None:
            i += 1
            c = dict(base, func_type=_FUNC_COH, data=np.array(frf.coherence, dtype=float),
                     ordinate_spec_data_type=0, ordinate_axis_lab="Coherence",
                     ordinate_axis_units_lab="1", orddenom_spec_data_type=0)
            c.update(id_lines(frf.name, "vlab coherence", i, n_rec, id3=navg, id4=band_line))
            dsets.append(c)
    write_uff(p, dsets)
    if meta_text is not None:
        write_text(side, meta_text)
    return p


def read_frfs(path: str | os.PathLike) -> list[FRF]:
    """Read UFF 58 FRFs (function type 4), attaching coherence records (type 6) with the same nodes.

    Parameters
    ----------
    path : str or path-like
        UFF file of FRF records (dataset 58, function type 4; coherence type 6).

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
    p, sets = read_uff(path)
    sets = [s for s in sets if s.get("type") == 58]
    frf_sets = [s for s in sets if s.get("func_type") == _FUNC_FRF]
    if not frf_sets:
        raise DataFileError(f"{p}: no dataset-58 FRF (function type 4) record")
    cohs = [s for s in sets if s.get("func_type") == _FUNC_COH]
    for c in cohs:  # the node fields the pairing needs
        for key in ("rsp_node", "ref_node", "rsp_dir", "ref_dir"):
            get_int(p, c, key, f"coherence record {record_label(c, '?')!r}")
    out = []
    seen: dict[tuple[int, int, str], str] = {}
    for i, s in enumerate(frf_sets, start=1):
        out_node, in_node, response, label, out_name, in_name, where = _frf_identity(p, s, i)
        f, h, to_hz = _frf_values(p, s, where, label)
        key = (out_node, in_node, response)
        if key in seen:
            raise DataFileError(f"{p}: {where}: a second {response} FRF from node {in_node} to node {out_node} "
                                f"(first: {seen[key]})")
        seen[key] = label
        c = _coherence_for(s, f, sets, cohs)
        f = f * to_hz  # the record's own unit (rad/s, kHz) to Hz, after pairing with its coherence record
        _check_coherence(p, label, c, f)
        m = _NAVG_RE.match(str(s.get("id3", "")).strip())
        try:
            out.append(FRF(freq_hz=f, h=h.astype(complex), response=response, coherence=c,
                           output_name=out_name, input_name=in_name, output_point=out_node,
                           input_point=in_node, n_averages=int(m.group(1)) if m else None))
        except MeasurementError as exc:
            raise DataFileError(f"{p}: FRF {label}: {exc}") from exc
    return out


def _frf_identity(p: Path, s: dict, i: int):
    """Nodes, response quantity, label, channel names and message prefix of FRF record ``i``, its labels checked."""
    where = f"FRF record {i}"
    out_node = check_node(p, s, "rsp_node", where)
    in_node = check_node(p, s, "ref_node", where)
    code = get_int(p, s, "ordinate_spec_data_type", where)
    if code not in (8, 11, 12):
        raise DataFileError(f"{p}: FRF {record_label(s, str(out_node))}: unsupported response "
                            f"specific data type {code} (8, 11 or 12 expected)")
    response = CODE_QUANTITY[code]
    den = int(s.get("orddenom_spec_data_type", 0) or 0)
    if den not in (0, 9, 13):
        raise DataFileError(f"{p}: FRF {record_label(s, str(out_node))}: denominator type {den} is not a force")
    default = f"{channel_name(response, out_node)}/{channel_name('force', in_node)}"
    label = record_label(s, default)
    if label.count("/") != 1:
        label = default
    out_name, in_name = label.split("/")
    where = f"FRF record {i} ({label})"
    # the output name is the measured channel (an FRF converted to displacement keeps 'vel1'): its
    # point must match; the input must be a force at the reference node
    if CONVENTIONAL_NAME_RE.match(out_name) and parse_channel_name(out_name)[1] != out_node:
        raise DataFileError(f"{p}: {where}: output channel name {out_name!r} contradicts the record's "
                            f"response node {out_node} (mislabelled FRF)")
    if CONVENTIONAL_NAME_RE.match(in_name) and parse_channel_name(in_name) != ("force", in_node):
        raise DataFileError(f"{p}: {where}: input channel name {in_name!r} contradicts the record's "
                            f"force at reference node {in_node} (mislabelled FRF)")
    check_direction(p, s, "rsp_dir", where)
    check_direction(p, s, "ref_dir", where)
    check_unit_label(p, s, response, where)
    check_exponents(p, s, "ordinate", code, where)
    check_force_denominator(p, s, where)
    absc = int(s.get("abscissa_spec_data_type", _FREQ) or 0)
    if absc not in (0, _FREQ):
        raise DataFileError(f"{p}: {where}: abscissa specific data type {absc} is not frequency ({_FREQ})")
    return out_node, in_node, response, label, out_name, in_name, where


def _frf_values(p: Path, s: dict, where: str, label: str) -> tuple[np.ndarray, np.ndarray, float]:
    """Frequency lines (the record's unit), values and the factor to Hz of an FRF record, checked."""
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
            value = complex(arr[bad[0]]) if np.iscomplexobj(arr) else float(arr[bad[0]])
            raise DataFileError(f"{p}: FRF {label}: non-finite values ({what} {value} at line "
                                f"{bad[0]}, {bad.size} in all)")
    if f[0] < 0:
        raise DataFileError(f"{p}: {where}: negative frequency {f[0]:g} Hz at line 0")
    steps = np.diff(f)
    if steps.size and np.any(steps <= 0):
        k = int(np.flatnonzero(steps <= 0)[0])
        raise DataFileError(f"{p}: {where}: frequency axis not increasing: line {k + 1} at {f[k + 1]:g} Hz "
                            f"after {f[k]:g} Hz")
    return f, h, to_hz


def _check_coherence(p: Path, label: str, c: np.ndarray | None, f: np.ndarray) -> None:
    """DataFileError for a coherence that is not finite or outside [0, 1]."""
    if c is None:
        return
    bad = np.flatnonzero(~np.isfinite(c))
    if bad.size:
        raise DataFileError(f"{p}: coherence of FRF {label}: non-finite values ({float(c[bad[0]])} at "
                            f"{f[bad[0]]:g} Hz)")
    bad = np.flatnonzero((c < -1e-9) | (c > 1 + 1e-9))
    if bad.size:
        raise DataFileError(f"{p}: coherence of FRF {label}: {c[bad[0]]:g} at {f[bad[0]]:g} Hz is "
                            "outside [0, 1]")


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
