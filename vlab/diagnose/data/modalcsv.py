"""Reading a measured modal table (CSV) for a diagnosis, checked against the structure.

A modal table lists, per mode, its natural frequency [Hz], optionally its damping ratio, mode-shape
values at points of the structure and standard uncertainties of the frequency and the damping. Each
value's printed resolution (one unit in its last digit, :func:`vlab.diagnose.model.modelform.printed_resolution`)
is kept: a table printed to a few digits is known no better than that. A column of a reference model's
frequencies (e.g. a published analysis) may be read with it, the data then compared with that reference.
Every error names the file, the line, the column and the value (:class:`vlab.errors.DataFileError`).
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...errors import DataFileError
from ...io.confine import read_utf8
from ...spec import StructureSpec
from ..model.modelform import printed_resolution
from .measured import ModalData

_FREQ = ("frequency_hz", "experimental_hz", "freq_hz", "frequency")
_DAMP = ("damping_ratio", "damping_experimental", "zeta", "damping")
#: Highest natural frequency a measured modal table may hold [Hz]: the Nyquist
#: frequency of the PC-1000 at its fastest rate, 2000 samples/s (Sec. 5.3).
MAX_MODAL_FREQUENCY_HZ = 1000.0


@dataclass(frozen=True)
class _Columns:
    """Where each quantity is in a table's rows."""

    header: list
    col: dict
    fcol: str
    dcol: str | None
    shape_cols: dict
    sigma_cols: dict
    reference_column: str | None
    ignored: list


@dataclass(frozen=True)
class _Row:
    """One mode as read: number, frequency [Hz], damping, uncertainties, reference and resolutions, shape."""

    mode: int
    freq: float
    damp: float
    sigmas: list
    ref: tuple | None
    res: tuple
    shape: list


def _text_rows(p: Path) -> tuple[list, list]:
    """The data lines ``(line number, text)`` of the file (comments and blank lines dropped) and their CSV rows."""
    if not p.is_file():
        raise DataFileError(f"{p}: no such file")
    text = read_utf8(p, DataFileError, encoding="utf-8-sig")
    if "\x00" in text:
        raise DataFileError(f"{p}: line {text[:text.index(chr(0))].count(chr(10)) + 1}: NUL byte (a binary file?)")
    lines = [(i + 1, ln) for i, ln in enumerate(text.splitlines()) if ln.strip() and not ln.lstrip().startswith("#")]
    if len(lines) < 2:
        raise DataFileError(f"{p}: no data rows (a header line and at least one mode are needed)")
    try:
        rows = list(csv.reader([ln for _, ln in lines]))
    except csv.Error as exc:
        raise DataFileError(f"{p}: malformed CSV: {exc}") from None
    return lines, rows


def _columns(p: Path, header: list, hline: int, spec: StructureSpec, reference_column: str | None) -> _Columns:
    """Check the header and find the columns of the mode, frequency, damping, shapes, uncertainties, reference."""
    for i, h in enumerate(header):
        if not h:
            raise DataFileError(f"{p}: line {hline}: column {i + 1} has no name (header: {header})")
        if header.index(h) != i:
            raise DataFileError(f"{p}: line {hline}: column {h!r} appears twice (columns {header.index(h) + 1} "
                                f"and {i + 1})")
    col = {h: i for i, h in enumerate(header)}
    if "mode" not in col:
        raise DataFileError(f"{p}: no 'mode' column (columns: {header})")
    fcol = next((c for c in _FREQ if c in col), None)
    if fcol is None:
        raise DataFileError(f"{p}: no frequency column (one of {_FREQ}); columns: {header}")
    dcol = next((c for c in _DAMP if c in col), None)
    shape_cols = {}
    for h in header:
        for pre in ("shape_", "phi_"):
            if h.startswith(pre):
                tail = h[len(pre):]
                if not tail.isdigit():
                    raise DataFileError(f"{p}: column {h!r}: expected {pre}<point id>")
                pid = int(tail)
                if pid not in spec.points:
                    raise DataFileError(f"{p}: column {h!r}: point id {pid} is not a point of {spec.name!r} "
                                        f"(points: {sorted(spec.points)})")
                shape_cols[pid] = col[h]
    sigma_cols = {c: col[c] for c in ("frequency_sigma_hz", "damping_sigma") if c in col}
    if "damping_sigma" in sigma_cols and dcol is None:
        raise DataFileError(f"{p}: column 'damping_sigma' without a damping column (one of {_DAMP})")
    if reference_column is not None and reference_column not in col:
        raise DataFileError(f"{p}: no column {reference_column!r} for the reference frequencies (columns: {header})")
    if reference_column is not None and reference_column in (fcol, "mode", dcol):
        raise DataFileError(f"{p}: the reference column {reference_column!r} is the table's own {reference_column} "
                            "column: name the reference model's frequencies")
    used = {"mode", fcol, dcol, reference_column} | {header[i] for i in shape_cols.values()} | set(sigma_cols)
    ignored = [h for h in header if h not in used]
    return _Columns(header, col, fcol, dcol, shape_cols, sigma_cols, reference_column, ignored)


def _number(p: Path, lineno: int, row: list, name: str, idx: int, *, allow_empty: bool = False) -> float:
    """The finite number in field ``idx`` of a row (NaN for a blank field where ``allow_empty``)."""
    s = row[idx].strip()
    if allow_empty and s == "":
        return float("nan")
    try:
        v = float(s)
    except ValueError:
        raise DataFileError(f"{p}: line {lineno}, column {name!r}: not a number: {s!r}") from None
    if not math.isfinite(v):
        raise DataFileError(f"{p}: line {lineno}, column {name!r}: not finite: {s!r}")
    return v


def _row(p: Path, lineno: int, row: list, c: _Columns) -> _Row:
    """Read and check one mode's row."""
    col, fcol, dcol, ref_col = c.col, c.fcol, c.dcol, c.reference_column
    if len(row) != len(c.header):
        raise DataFileError(f"{p}: line {lineno}: {len(row)} fields, the header has {len(c.header)}")

    def num(name: str, idx: int, *, allow_empty: bool = False) -> float:
        return _number(p, lineno, row, name, idx, allow_empty=allow_empty)

    mv = num("mode", col["mode"])
    if mv != int(mv) or mv < 1:
        raise DataFileError(f"{p}: line {lineno}, column 'mode': expected a positive integer, got {row[col['mode']]!r}")
    fv = num(fcol, col[fcol])
    if fv <= 0:
        raise DataFileError(f"{p}: line {lineno}, column {fcol!r}: frequency must be > 0 Hz, got {fv}")
    if fv > MAX_MODAL_FREQUENCY_HZ:
        raise DataFileError(f"{p}: line {lineno}, column {fcol!r}: {fv:g} Hz is above the "
                            f"{MAX_MODAL_FREQUENCY_HZ:g} Hz Nyquist frequency of the PC-1000 at 2000 samples/s "
                            "(Sec. 5.3): not a measured mode (a unit slip?)")
    dv = num(dcol, col[dcol], allow_empty=True) if dcol else float("nan")
    if math.isfinite(dv) and not 0.0 <= dv < 1.0:
        raise DataFileError(f"{p}: line {lineno}, column {dcol!r}: damping ratio must be in [0, 1), got {dv}")
    sig = []
    for name, idx in c.sigma_cols.items():
        sv = num(name, idx, allow_empty=True)
        if math.isfinite(sv) and sv < 0:
            raise DataFileError(f"{p}: line {lineno}, column {name!r}: an uncertainty must be >= 0, got {sv}")
        sig.append(sv)
    ref = None
    if ref_col is not None:
        rv = num(ref_col, col[ref_col])
        if rv <= 0:
            raise DataFileError(f"{p}: line {lineno}, column {ref_col!r}: a reference frequency must be "
                                f"> 0 Hz, got {rv}")
        ref = (rv, printed_resolution(row[col[ref_col]]))
    res = (printed_resolution(row[col[fcol]]),
           printed_resolution(row[col[dcol]]) if dcol and math.isfinite(dv) else float("nan"))
    return _Row(int(mv), fv, dv, sig, ref, res, [num(c.header[i], i) for i in c.shape_cols.values()])


def _modal_data(p: Path, c: _Columns, rows: list) -> ModalData:
    """Check the modes together (no repeated mode or frequency, no zero shape) and sort them by frequency."""
    modes = [r.mode for r in rows]
    freq = [r.freq for r in rows]
    if len(set(modes)) != len(modes):
        raise DataFileError(f"{p}: column 'mode': repeated mode numbers {sorted(m for m in set(modes) if modes.count(m) > 1)}")
    dupf = sorted({f for f in freq if freq.count(f) > 1})
    if dupf:
        raise DataFileError(f"{p}: column {c.fcol!r}: repeated frequency {dupf[0]:g} Hz (a duplicated row?)")
    order = np.argsort(freq)
    sig_arr = np.array([r.sigmas for r in rows], dtype=float).reshape(len(modes), len(c.sigma_cols))[order]
    sig_of = {name: sig_arr[:, j] for j, name in enumerate(c.sigma_cols)}
    notes = []
    if c.ignored:
        notes.append(f"columns not used: {c.ignored}")
    sh = np.array([r.shape for r in rows], dtype=float).T[:, order] if c.shape_cols else None
    if sh is not None and np.any(np.all(sh == 0, axis=0)):
        raise DataFileError(f"{p}: a mode shape is zero at every point")
    res = [r.res for r in rows]
    refs = [r.ref for r in rows if r.ref is not None]
    return ModalData(str(p), np.array(modes)[order], np.array(freq)[order], np.array([r.damp for r in rows])[order], sh,
                     tuple(c.shape_cols), notes, freq_sigma_hz=sig_of.get("frequency_sigma_hz"),
                     damping_sigma=sig_of.get("damping_sigma"),
                     freq_resolution_hz=np.array([r[0] for r in res])[order],
                     damping_resolution=np.array([r[1] for r in res])[order],
                     reference_hz=np.array([r[0] for r in refs])[order] if refs else None,
                     reference_resolution_hz=np.array([r[1] for r in refs])[order] if refs else None,
                     reference_column=c.reference_column)


def read_modal_csv(path: str | Path, spec: StructureSpec, *, reference_column: str | None = None) -> ModalData:
    """Read a modal table (CSV) and check it against the structure.

    Columns: ``mode`` (positive integers), a frequency column
    (``frequency_hz`` or ``experimental_hz``) [Hz], optional damping
    (``damping_ratio`` or ``damping_experimental``), optional shape columns
    ``shape_<point id>`` (or ``phi_<point id>``), optional standard
    uncertainties ``frequency_sigma_hz`` [Hz] and ``damping_sigma`` [-]
    (non-negative; blank = not given). Lines starting with ``#`` are
    comments; other columns are ignored (and listed in the notes). The file
    may start with a UTF-8 byte-order mark.

    Parameters
    ----------
    path : str or Path
        The CSV file.
    spec : StructureSpec
        The structure (shape point ids are checked against it).
    reference_column : str, optional
        A column of reference-model frequencies [Hz] (e.g. ``analytical_hz``, the
        published analysis the measurement was compared with): read into
        ``reference_hz``; every row must have a positive value.

    Returns
    -------
    ModalData
        Sorted by frequency.

    Raises
    ------
    DataFileError
        Missing file or column, a file that is not UTF-8, a repeated or empty
        column name, a row with the wrong number of fields, a non-numeric or
        non-finite value, a non-positive frequency or one above
        :data:`MAX_MODAL_FREQUENCY_HZ` (1000 Hz), a damping ratio outside
        [0, 1), a negative uncertainty, repeated mode numbers or
        frequencies, a shape column for a point the structure does not have,
        a shape that is zero at every point. The message names the file,
        line and column and the value.
    """
    p = Path(path)
    lines, rows = _text_rows(p)
    c = _columns(p, [h.strip() for h in rows[0]], lines[0][0], spec, reference_column)
    return _modal_data(p, c, [_row(p, lineno, row, c) for (lineno, _), row in zip(lines[1:], rows[1:])])
