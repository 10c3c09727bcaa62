"""The uniform result objects of ``vlab reproduce``.

Every reproduced table is a :class:`TableResult`: a list of :class:`Row`
(one published number, vlab's number, their difference and a flag), notes,
and the tolerance within which a row counts as agreeing. The flags say what
vlab's number rests on:

``calibrated``
    The number (or the numbers it is computed from) was a target of vlab's
    model calibration, so agreement is partly built in (BCC: Tables 1
    analytical and 8 with the Table 7 gains, README; grid: Table 3
    analytical and the Guyan column of Table 5).
``reconstructed``
    It rests on the reconstructed grid geometry (README: Figure 5 is not in
    the available text; 9.2 % rms frequency error).
``assumed``
    It rests on data the dissertation does not publish and vlab assumes:
    measured mode shapes (a virtual modal test), the BCC's reduction masters,
    the damping of unmeasured modes, the laboratory structure of a virtual
    experiment.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

FLAGS = ("calibrated", "reconstructed", "assumed")

#: What each flag means (reproduce.json and report.md).
FLAG_TEXT = {
    "calibrated": "vlab's model was fitted to this published number (agreement partly built in)",
    "reconstructed": "rests on the reconstructed grid geometry",
    "assumed": "rests on data the dissertation does not publish (measured shapes, masters, damping of unmeasured "
               "modes, the laboratory structure)",
}


def _num(x) -> float | None:
    """A finite float or None."""
    if x is None:
        return None
    v = float(x)
    return v if math.isfinite(v) else None


def join_flags(*flags: str) -> str:
    """Join flag words (``"calibrated"``, ``"reconstructed"``, ``"assumed"``) as ``"a,b"``.

    Parameters
    ----------
    *flags : str
        Flag words or comma-separated lists of them (empty strings allowed).

    Returns
    -------
    str
        The distinct words in first-seen order, joined by commas.

    Raises
    ------
    ValueError
        For an unknown flag word.
    """
    words: list[str] = []
    for f in flags:
        for w in (s.strip() for s in f.split(",")):
            if not w:
                continue
            if w not in FLAGS:
                raise ValueError(f"unknown flag {w!r}; use one of {FLAGS}")
            if w not in words:
                words.append(w)
    return ",".join(words)


@dataclass(frozen=True)
class Row:
    """One published number against vlab's.

    Attributes
    ----------
    row, column : str
        Where the number sits in the published table (e.g. ``"mode 3"``, ``"LQDRF"``).
    published : float or None
        The dissertation's value as printed (None where it prints none).
    ours : float or None
        vlab's value in the same units (None where vlab has none).
    flag : str
        Comma-separated flag words (see the module docstring); empty if none.
    """

    row: str
    column: str
    published: float | None
    ours: float | None
    flag: str = ""

    def __post_init__(self) -> None:
        object.__setattr__(self, "published", _num(self.published))
        object.__setattr__(self, "ours", _num(self.ours))
        object.__setattr__(self, "flag", join_flags(self.flag))

    @property
    def difference(self) -> float | None:
        """``ours - published`` (None if either is missing)."""
        if self.published is None or self.ours is None:
            return None
        return self.ours - self.published

    @property
    def relative(self) -> float | None:
        """``ours / published - 1`` (None if either is missing or the published value is 0)."""
        if self.published is None or self.ours is None or self.published == 0.0:
            return None
        return self.ours / self.published - 1.0

    def as_dict(self) -> dict:
        """JSON-ready dict: row, column, published, ours, difference, relative, flag."""
        return {"row": self.row, "column": self.column, "published": self.published, "ours": self.ours,
                "difference": self.difference, "relative": self.relative, "flag": self.flag}


@dataclass(frozen=True)
class TableResult:
    """One reproduced table.

    Attributes
    ----------
    name : str
        The dissertation's name (``"Table 8"``, ``"Sec. 3.3"``).
    title : str
        What it shows.
    rows : tuple of Row
    notes : tuple of str
        How vlab's numbers were obtained and why they may differ.
    tolerance : float
        A row agrees when ``|relative| <= tolerance`` (``tolerance_kind ==
        "relative"``) or ``|difference| <= tolerance`` ("absolute").
    tolerance_kind : {"relative", "absolute"}
    source : str
        The CSV of the published numbers in ``assets/data``.
    """

    name: str
    title: str
    rows: tuple[Row, ...]
    notes: tuple[str, ...] = ()
    tolerance: float = 0.1
    tolerance_kind: str = "relative"
    source: str = ""

    def __post_init__(self) -> None:
        if self.tolerance_kind not in ("relative", "absolute"):
            raise ValueError(f"{self.name}: tolerance_kind must be 'relative' or 'absolute', got {self.tolerance_kind!r}")
        object.__setattr__(self, "rows", tuple(self.rows))
        object.__setattr__(self, "notes", tuple(self.notes))

    def _err(self, r: Row) -> float | None:
        if self.tolerance_kind == "relative":
            # a published zero cannot be compared relatively: use the absolute difference then
            return abs(r.relative) if r.relative is not None else (
                abs(r.difference) if r.difference is not None else None)
        return abs(r.difference) if r.difference is not None else None

    def agreement(self) -> dict:
        """Summary of the agreement.

        Returns
        -------
        dict
            ``n_rows``, ``n_compared`` (rows with both numbers), ``n_within``
            (within the tolerance), ``fraction_within``, ``median_error`` and
            ``max_error`` (|relative| or |difference| as ``tolerance_kind``),
            ``tolerance``, ``tolerance_kind``, ``flags`` (the flag words used).
        """
        errs = [e for e in (self._err(r) for r in self.rows) if e is not None]
        n_within = sum(e <= self.tolerance + 1e-12 for e in errs)
        flags = join_flags(*(r.flag for r in self.rows))
        return {
            "n_rows": len(self.rows), "n_compared": len(errs), "n_within": int(n_within),
            "fraction_within": (n_within / len(errs)) if errs else None,
            "median_error": float(np.median(errs)) if errs else None,
            "max_error": float(np.max(errs)) if errs else None,
            "tolerance": self.tolerance, "tolerance_kind": self.tolerance_kind, "flags": flags,
        }

    def value(self, row: str, column: str) -> Row:
        """The row at (``row``, ``column``). Raises KeyError if absent."""
        for r in self.rows:
            if r.row == row and r.column == column:
                return r
        raise KeyError(f"{self.name}: no row ({row!r}, {column!r})")

    def as_dict(self) -> dict:
        """JSON-ready dict: name, title, source, notes, agreement, rows."""
        return {"name": self.name, "title": self.title, "source": self.source, "notes": list(self.notes),
                "agreement": self.agreement(), "rows": [r.as_dict() for r in self.rows]}


@dataclass(frozen=True)
class ReproduceResult:
    """What :func:`vlab.reproduce.reproduce` produced.

    Attributes
    ----------
    out_dir : Path
        The output folder (report.md, reproduce.json, figures/).
    tables : tuple of TableResult
    limit_cycle : object
        :class:`vlab.reproduce.limit_cycle.LimitCycleResult`.
    figures : tuple of Path
    settings : dict
        fast, plant, lab, resolutions, durations, seeds.
    runtime_s : float
        Wall-clock time of the run [s].
    measured : tuple of MeasuredDiagnosis
        The dissertation's measurements diagnosed as real data (:mod:`vlab.reproduce.measured`).
    """

    out_dir: Path
    tables: tuple[TableResult, ...]
    limit_cycle: object
    figures: tuple[Path, ...] = ()
    settings: dict = field(default_factory=dict)
    runtime_s: float = 0.0
    measured: tuple = ()

    def table(self, name: str) -> TableResult:
        """The table called ``name`` (e.g. ``"Table 8"``). Raises KeyError if absent."""
        for t in self.tables:
            if t.name == name:
                return t
        raise KeyError(f"no reproduced table {name!r}; have {[t.name for t in self.tables]}")
