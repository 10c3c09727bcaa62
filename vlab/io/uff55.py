"""UFF dataset 55: mode shapes at structure points (normal or complex modes, the shape in Z).

Written in ASCII ``E13.5`` (6 significant digits); read back with the
frequencies, damping ratios and point ids checked.

Source: UFF dataset 55 description (SDRC/I-DEAS, https://www.ceas3.uc.edu/sdrluff/);
pyuff (Slavic et al., https://github.com/ladisk/pyuff).
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import DataFileError
from .uff_files import RECORD_RE, check_target, id_lines, record_label, read_uff, write_uff

# --------------------------------------------------------------------------- mode shapes
@dataclass(frozen=True, eq=False)
class ModeShapes:
    """Mode shapes at structure points (the content of UFF 55 records).

    Parameters
    ----------
    freq_hz : array_like, shape (n_modes,)
        Natural frequencies [Hz].
    shapes : array_like, shape (n_points, n_modes)
        Out-of-plane (Z) shape values, real (normal modes) or complex.
    point_ids : array_like of int, shape (n_points,)
        Structure point of each row.
    damping_ratio : array_like, shape (n_modes,), optional
        Viscous damping ratios [-]; zeros by default.
    description : str
        Free text (UFF ID line 1, at most 80 characters).

    Raises
    ------
    DataFileError
        Inconsistent shapes, duplicate point ids, non-finite values.
    """

    freq_hz: np.ndarray
    shapes: np.ndarray
    point_ids: np.ndarray
    damping_ratio: np.ndarray | None = None
    description: str = ""

    def __post_init__(self) -> None:
        f = np.array(self.freq_hz, dtype=float).reshape(-1)
        sh = np.array(self.shapes)
        sh = sh.astype(complex if np.iscomplexobj(sh) else float)
        pid = np.array(self.point_ids)
        if sh.ndim != 2 or sh.shape[1] != f.size or pid.shape != (sh.shape[0],):
            raise DataFileError(f"ModeShapes: shapes {sh.shape} must be (n_points={pid.size}, "
                                f"n_modes={f.size})")
        if not np.all(np.equal(np.mod(pid, 1), 0)) or len(set(pid.tolist())) != pid.size:
            raise DataFileError(f"ModeShapes: point_ids must be distinct integers, got {pid.tolist()}")
        z = np.zeros(f.size) if self.damping_ratio is None else np.array(self.damping_ratio, dtype=float)
        if z.shape != f.shape:
            raise DataFileError(f"ModeShapes: damping_ratio shape {z.shape} != ({f.size},)")
        if not (np.all(np.isfinite(f)) and np.all(np.isfinite(sh)) and np.all(np.isfinite(z))):
            raise DataFileError("ModeShapes: non-finite values")
        for name, arr in (("freq_hz", f), ("shapes", sh), ("point_ids", pid.astype(int)),
                          ("damping_ratio", z)):
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    @property
    def n_modes(self) -> int:
        """Number of modes."""
        return int(self.freq_hz.size)


def write_mode_shapes(path: str | os.PathLike, modes: ModeShapes, *, overwrite: bool = False) -> Path:
    """Write mode shapes as UFF 55 records, one per mode (values in Z, 6 significant digits).

    Real shapes are written as normal modes (analysis type 2: frequency,
    viscous damping ratio); complex shapes as complex modes (type 3,
    eigenvalue ``-zeta omega_n + i omega_n sqrt(1 - zeta^2)``).

    Parameters
    ----------
    path : str or path-like
        Target file.
    modes : ModeShapes
        Shapes to write; ``point_ids`` become the UFF nodes.
    overwrite : bool
        Replace an existing file.

    Returns
    -------
    Path
        ``path``, the UFF 55 file written.

    Raises
    ------
    DataFileError
        Target exists and ``overwrite`` is False, description too long, pyuff failure.
    """
    p = Path(path)
    check_target(p, overwrite)
    cplx = np.iscomplexobj(modes.shapes)
    desc = modes.description or "NONE"
    dsets = []
    nodes = modes.point_ids
    for r in range(modes.n_modes):
        z = modes.shapes[:, r]
        zeros = np.zeros_like(z)
        d = dict(type=55, model_type=1, data_ch=2, spec_data_type=8, node_nums=nodes,
                 r1=zeros, r2=zeros, r3=z, load_case=1, mode_n=r + 1)
        if cplx:
            wn = 2 * np.pi * modes.freq_hz[r]
            zeta = modes.damping_ratio[r]
            d.update(analysis_type=3, eig=complex(-zeta * wn, wn * math.sqrt(max(1 - zeta**2, 0.0))))
        else:
            d.update(analysis_type=2, freq=modes.freq_hz[r], modal_m=0.0,
                     modal_damp_vis=modes.damping_ratio[r], modal_damp_his=0.0)
        d.update(id_lines(desc, "vlab ModeShapes", r + 1, modes.n_modes))
        dsets.append(d)
    write_uff(p, dsets)
    return p


def read_mode_shapes(path: str | os.PathLike, *, points: Sequence[int] | None = None) -> ModeShapes:
    """Read UFF 55 normal or complex modes (Z component) into :class:`ModeShapes`.

    Parameters
    ----------
    path : str or path-like
        UFF file.
    points : sequence of int, optional
        Point ids of the structure; a node outside them is refused.

    Returns
    -------
    ModeShapes

    Raises
    ------
    DataFileError
        Missing, malformed or truncated file; no dataset 55 of analysis
        type 2 or 3; records over different nodes; a node that is not a
        positive integer, repeats, or is not in ``points``; a record without
        Z values; non-finite or all-zero shapes; a frequency that is not
        positive and finite; a damping ratio outside [0, 1); a repeated mode
        number. The message names the file, the record and the value.
    """
    p, sets = read_uff(path)
    recs = [s for s in sets if s.get("type") == 55 and s.get("analysis_type") in (2, 3)]
    if not recs:
        raise DataFileError(f"{p}: no dataset-55 normal or complex mode record")
    counts = {int(m.group(2)) for s in recs if (m := RECORD_RE.match(str(s.get("id5", "")).strip()))}
    if counts and counts != {len(recs)}:
        raise DataFileError(f"{p}: truncated UFF: {len(recs)} mode record(s), ID lines announce {counts}")
    if "node_nums" not in recs[0]:
        raise DataFileError(f"{p}: mode record 1 has no node numbers")
    nodes = np.asarray(recs[0]["node_nums"], dtype=float)
    if nodes.size == 0:
        raise DataFileError(f"{p}: mode record 1 has no node")
    badn = np.flatnonzero(~np.isfinite(nodes) | (nodes < 1) | (nodes != np.round(nodes)))
    if badn.size:
        raise DataFileError(f"{p}: mode record 1: node {float(nodes[badn[0]]):g} is not a point id (positive integers)")
    nodes = nodes.astype(int)
    dup = sorted({n for n in nodes.tolist() if nodes.tolist().count(n) > 1})
    if dup:
        raise DataFileError(f"{p}: mode record 1: node {dup[0]} appears more than once")
    if points is not None:
        unknown = [n for n in nodes.tolist() if n not in set(points)]
        if unknown:
            raise DataFileError(f"{p}: node {unknown[0]} is not a point of the structure "
                                f"(points: {sorted(points)})")
    freqs, zetas, cols, numbers = [], [], [], []
    for i, s in enumerate(recs, start=1):
        mode_n = s.get("mode_n", i)
        where = f"mode record {i} (mode {mode_n})"
        nn = np.asarray(s.get("node_nums", []), dtype=float)
        if not np.array_equal(nn, nodes):
            raise DataFileError(f"{p}: mode {mode_n} is given at different nodes than mode 1")
        if int(s.get("data_ch", 2) or 2) not in (2, 3) or "r3" not in s:
            raise DataFileError(f"{p}: {where}: data characteristic {s.get('data_ch')!r} holds no Z value "
                                "(3 DOF translation, data_ch = 2, expected)")
        z = np.asarray(s["r3"])
        if z.size != nodes.size:
            raise DataFileError(f"{p}: mode {mode_n}: {z.size} values for {nodes.size} nodes")
        bad = np.flatnonzero(~np.isfinite(z))
        if bad.size:
            raise DataFileError(f"{p}: {where}: non-finite shape value {z[bad[0]]} at node {nodes[bad[0]]}")
        if not np.any(z != 0):
            raise DataFileError(f"{p}: {where}: the shape is zero at every node")
        if s["analysis_type"] == 2:
            fr, zeta = float(s.get("freq", np.nan)), float(s.get("modal_damp_vis", 0.0))
        else:
            lam = complex(s.get("eig", np.nan))
            fr = abs(lam) / (2 * np.pi)
            zeta = -lam.real / abs(lam) if lam != 0 and np.isfinite(abs(lam)) else 0.0
        if not (math.isfinite(fr) and fr > 0):
            raise DataFileError(f"{p}: {where}: natural frequency {fr!r} Hz is not a positive finite number")
        if not (math.isfinite(zeta) and 0.0 <= zeta < 1.0):
            raise DataFileError(f"{p}: {where}: damping ratio {zeta!r} is outside [0, 1)")
        if mode_n in numbers:
            raise DataFileError(f"{p}: {where}: mode number {mode_n} repeats")
        numbers.append(mode_n)
        freqs.append(fr)
        zetas.append(zeta)
        cols.append(z)
    desc = record_label(recs[0], "")
    try:
        return ModeShapes(freq_hz=np.array(freqs), shapes=np.column_stack(cols), point_ids=nodes,
                          damping_ratio=np.array(zetas), description=desc)
    except DataFileError as exc:
        raise DataFileError(f"{p}: {exc}") from exc
