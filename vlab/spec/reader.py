"""Reading one TOML table of a structure file: :class:`TableReader` and the checked values.

A :class:`TableReader` reads the fields of one table and raises
:class:`vlab.errors.SpecError` naming the file and the dotted field
(``"bcc.toml: field 'members[0].section': ..."``); it converts every physical
value ``{ value, unit, source }`` to SI and refuses a value outside
:data:`vlab.spec.PLAUSIBLE_RANGES`. The functions below read the values several tables
share: a direction, a DOF name, a point id, a list of point ids, a number in a range, a fraction in [0, 1).
"""

from __future__ import annotations

import math
from typing import Any

from .. import units
from ..errors import SpecError
from .structure import DOF_NAMES, Quantity

_KIND_UNITS = {
    "length": {"m", "in", "mm"},
    "force": {"N", "lbf"},
    "mass": {"kg", "lbf*s^2/in", "lbm", "lbf", "N"},  # lbf/N: a weight, divided by g
    "stiffness": {"N/m", "lbf/in"},
    "rot_stiffness": {"N*m/rad", "lbf*in/rad"},
    "rigidity": {"N*m^2", "lbf*in^2"},
    "modulus": {"Pa", "psi"},
    "density": {"kg/m^3", "lbf/in^3"},
    "inertia": {"kg*m^2", "lbf*s^2*in"},
    "shear_force": {"N", "lbf"},
    "ratio": {"1"},
    "time": {"s"},
    "frequency": {"Hz"},
}

#: Plausible range [SI] of each kind of value in a structure definition. The lab's
#: structures (Sec. 2: metre-sized steel and aluminium frames, cables and coils) lie
#: well inside; the bounds are wide enough for validation models (strings of density
#: 1 kg/m^3, EI 1e-7 N m^2) and catch the slips of units or exponents that make a
#: model meaningless (EI x 1e30 gives modes at 0 Hz and 3e15 Hz). Lengths 1 um .. 1 km;
#: moduli 1 kPa .. 10 TPa (diamond: 1.2 TPa); densities 1e-3 .. 1e5 kg/m^3 (osmium:
#: 22 600); masses 1 ug .. 1000 t; rigidities 1e-15 .. 1e10 N m^2 (BCC beam: 26,
#: grid top beam: 8.4e3); springs 1e-9 .. 1e12 N/m or N m/rad; tensions and shear
#: stiffnesses 1 uN .. 100 MN (kGA up to 1e12 N); inertias 1e-15 .. 1e6 kg m^2; times (the hardware's
#: delays) 1 ns .. 1000 s; frequencies (its lags' corners) 1 mHz .. 10 MHz.
PLAUSIBLE_RANGES: dict[str, tuple[float, float, str]] = {
    "length": (1e-6, 1e3, "m"),
    "force": (1e-6, 1e8, "N"),
    "mass": (1e-9, 1e6, "kg"),
    "stiffness": (1e-9, 1e12, "N/m"),
    "rot_stiffness": (1e-9, 1e12, "N*m/rad"),
    "rigidity": (1e-15, 1e10, "N*m^2"),
    "modulus": (1e3, 1e13, "Pa"),
    "density": (1e-3, 1e5, "kg/m^3"),
    "inertia": (1e-15, 1e6, "kg*m^2"),
    "shear_force": (1e-6, 1e12, "N"),
    "ratio": (0.0, 1.0, "1"),
    "time": (1e-9, 1e3, "s"),
    "frequency": (1e-3, 1e7, "Hz"),
}


class TableReader:
    """Reads one TOML table with field-path aware errors.

    Parameters
    ----------
    file : str
        File name named in errors (``"<dict>"`` for a document built in code).
    table : dict
        The table as parsed.
    path : str
        Dotted path of the table in the document (``""`` for the top level).

    Raises
    ------
    SpecError
        If ``table`` is not a dict.
    """

    def __init__(self, file: str, table: dict[str, Any], path: str):
        self.file, self.table, self.path = file, table, path
        if not isinstance(table, dict):
            self.fail("", f"expected a table, got {type(table).__name__}")
        self._used: set[str] = set()

    def fail(self, key: str, msg: str) -> None:
        """Raise the SpecError of field ``key`` (``""``: the table itself) with message ``msg``.

        Parameters
        ----------
        key : str
            Field name within this table.
        msg : str
            What is wrong.

        Raises
        ------
        SpecError
            Always: ``"<file>: field '<path>.<key>': <msg>"``.
        """
        where = f"{self.path}.{key}" if key and self.path else (key or self.path)
        raise SpecError(f"{self.file}: field '{where}': {msg}")

    def has(self, key: str) -> bool:
        """True if the table has field ``key``.

        Parameters
        ----------
        key : str
            Field name.
        """
        return key in self.table

    def raw(self, key: str, default: Any = ..., *, types: tuple[type, ...] = ()) -> Any:
        """The value of field ``key`` as parsed, marked as read.

        Parameters
        ----------
        key : str
            Field name.
        default : optional
            Value when the field is absent (omitted: the field is required).
        types : tuple of type
            Accepted Python types (empty: any).

        Returns
        -------
        Any

        Raises
        ------
        SpecError
            If the field is missing (and required) or of another type.
        """
        self._used.add(key)
        if key not in self.table:
            if default is ...:
                self.fail(key, "missing")
            return default
        v = self.table[key]
        if types and not isinstance(v, types):
            self.fail(key, f"expected {'/'.join(t.__name__ for t in types)}, got {v!r}")
        return v

    def str(self, key: str, default: Any = ...) -> str:
        """A string field (see :meth:`raw` for ``key`` and ``default``)."""
        return self.raw(key, default, types=(str,))

    def int(self, key: str, default: Any = ...) -> int:
        """An integer field, booleans refused (see :meth:`raw` for ``key`` and ``default``)."""
        v = self.raw(key, default, types=(int,))
        if isinstance(v, bool):
            self.fail(key, f"expected an integer, got {v!r}")
        return v

    def sub(self, key: str, default: Any = ...) -> "TableReader | None":
        """The reader of sub-table ``key``, or None when ``default`` is None and it is absent.

        Parameters
        ----------
        key : str
            Field name of the sub-table.
        default : optional
            Value when absent (omitted: the sub-table is required).
        """
        v = self.raw(key, default, types=(dict,))
        if v is None:
            return None
        return TableReader(self.file, v, f"{self.path}.{key}" if self.path else key)

    def quantity(self, key: str, kind: str, *, positive: bool = True, optional: bool = False) -> Quantity | None:
        """A physical value ``{ value, unit, source }`` converted to SI.

        Parameters
        ----------
        key : str
            Field name.
        kind : str
            Kind of value, a key of :data:`vlab.spec.PLAUSIBLE_RANGES` (``"length"``, ``"mass"``, ...).
        positive : bool
            Require a value > 0 (else >= 0).
        optional : bool
            Return None when the field is absent.

        Returns
        -------
        Quantity or None

        Raises
        ------
        SpecError
            If the table is malformed, the source empty, the unit not one of ``kind``, the sign wrong or
            the SI value outside :data:`vlab.spec.PLAUSIBLE_RANGES`.
        """
        if optional and key not in self.table:
            self._used.add(key)
            return None
        q = self.sub(key)
        value = q.raw("value", types=(int, float))
        if isinstance(value, bool) or not math.isfinite(value):
            q.fail("value", f"expected a finite number, got {value!r}")
        unit = q.str("unit")
        source = q.str("source")
        if not source.strip():
            q.fail("source", "empty: every value needs its source (table, section, 'assumed: ...' or 'calibrated: ...')")
        q.done()
        if unit not in _KIND_UNITS[kind]:
            q.fail("unit", f"{unit!r} is not a unit of {kind}; use one of {sorted(_KIND_UNITS[kind])}")
        si = float(value) * units.factor(unit, where=f"{self.file}: field '{q.path}.unit'")
        if kind == "mass" and unit in ("lbf", "N"):
            si = units.weight_to_mass(float(value) * units.factor(unit))
        if positive and si <= 0.0:
            q.fail("value", f"must be positive, got {value!r}")
        if not positive and si < 0.0:
            q.fail("value", f"must not be negative, got {value!r}")
        lo, hi, si_unit = PLAUSIBLE_RANGES[kind]
        if not math.isfinite(si) or si > hi or (si < lo and not (si == 0.0 and not positive)):
            q.fail("value", f"{value!r} {unit} = {si:.4g} {si_unit} is outside the plausible range "
                            f"[{lo:g}, {hi:g}] {si_unit} of a {kind.replace('_', ' ')} in a laboratory structure "
                            "(a unit or exponent slip?)")
        return Quantity(si, source)

    def entries(self, key: str, default: Any = ...):
        """The readers of the tables of array ``key`` (``[[key]]``), each checked by :meth:`done` after its turn.

        Parameters
        ----------
        key : str
            Field name of the array of tables.
        default : optional
            Value when absent, as in :meth:`raw` (``[]``: the array is optional).

        Yields
        ------
        i : int
            Index of the entry in the array.
        r : TableReader
            Its reader (path ``<key>[<i>]`` below this table); its unknown fields
            raise SpecError when the loop moves on to the next entry.
        """
        for i, t in enumerate(self.raw(key, default, types=(list,))):
            r = TableReader(self.file, t, f"{self.path}.{key}[{i}]" if self.path else f"{key}[{i}]")
            yield i, r
            r.done()

    def done(self) -> None:
        """Raise SpecError naming the first field of the table that was never read (an unknown field)."""
        extra = set(self.table) - self._used
        if extra:
            self.fail(sorted(extra)[0], f"unknown field (known here: {sorted(self._used)})")


def read_direction(r: TableReader, key: str) -> tuple[float, float]:
    """The unit vector of field ``key``, given as ``[x, y]`` in the plane; ``gravity`` may be zero.

    Parameters
    ----------
    r : TableReader
    key : str
        Field name (``"direction"`` of a string, ``"gravity"`` of ``[structure]``).

    Returns
    -------
    (float, float)
        The normalised vector; (0, 0) for a zero ``gravity`` (no gravity, for validation models).

    Raises
    ------
    SpecError
        If it is not two finite numbers, or a zero vector other than ``gravity``.
    """
    v = r.raw(key, types=(list,))
    if len(v) != 2 or not all(is_number(x) for x in v):
        r.fail(key, f"expected [x, y], got {v!r}")
    if not all(math.isfinite(x) for x in v):
        r.fail(key, f"expected finite [x, y], got {v!r}")
    n = math.hypot(*v)
    if n == 0:
        if key == "gravity":
            return (0.0, 0.0)  # no gravity: for validation models
        r.fail(key, "zero vector")
    return (v[0] / n, v[1] / n)


def read_dof(r: TableReader, key: str, value: str) -> str:
    """``value`` if it is a DOF name of :data:`vlab.spec.DOF_NAMES`, else SpecError naming field ``key``.

    Parameters
    ----------
    r : TableReader
    key : str
        Field name named in the error.
    value : str
        The DOF name read.
    """
    if value not in DOF_NAMES:
        r.fail(key, f"unknown DOF {value!r}; use one of {DOF_NAMES}")
    return value


def read_point(r: TableReader, key: str, points: dict) -> int:
    """The point id of field ``key``, one of ``points`` (SpecError naming the field otherwise).

    Parameters
    ----------
    r : TableReader
    key : str
        Field name.
    points : dict
        Point id -> coordinates of the structure.
    """
    pid = r.int(key)
    if pid not in points:
        r.fail(key, f"unknown point id {pid}; points are {sorted(points)}")
    return pid


def read_number(r: TableReader, key: str, default: Any = ..., *, low: float = 0.0, low_open: bool = True,
                high: float = math.inf, high_open: bool = False) -> float:
    """A finite real number of table ``r`` within (low, high), as a float; SpecError naming the field.

    Parameters
    ----------
    r : TableReader
    key : str
        Field name.
    default : optional
        Value when absent (omitted: required).
    low, high : float
        Bounds.
    low_open, high_open : bool
        Whether the bound itself is excluded.
    """
    v = r.raw(key, default, types=(int, float))
    if isinstance(v, bool) or not math.isfinite(v):
        r.fail(key, f"expected a finite number, got {v!r}")
    if v < low or (low_open and v == low) or v > high or (high_open and v == high):
        r.fail(key, f"must lie in {'(' if low_open else '['}{low:g}, {high:g}{')' if high_open else ']'}, got {v!r}")
    return float(v)


def is_number(v: Any) -> bool:
    """Whether the TOML value ``v`` (as read) is a number: an int or a float, not a boolean (``True`` is an int)."""
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def is_fraction(v: Any) -> bool:
    """Whether the TOML value ``v`` is a number (:func:`is_number`) in [0, 1): a damping ratio, a relative
    uncertainty."""
    return is_number(v) and 0.0 <= v < 1.0


def read_damping_ratio(r: TableReader, key: str) -> int | float:
    """A required damping ratio of table ``r``, in [0, 1) [-]; SpecError naming the field.

    Parameters
    ----------
    r : TableReader
    key : str
        Field name.

    Returns
    -------
    int or float
        The value as written (the caller converts it).

    Raises
    ------
    SpecError
        The field is missing, not a number, or outside [0, 1).
    """
    ratio = r.raw(key, types=(int, float))
    if not is_fraction(ratio):
        r.fail(key, f"a damping ratio must be in [0, 1), got {ratio!r}")
    return ratio


def read_points_list(r: TableReader, key: str, points: dict, default: Any = ...) -> tuple[int, ...]:
    """A list of known, distinct point ids (SpecError naming the field and the bad id).

    Parameters
    ----------
    r, key, points
        As :func:`read_point`.
    default : optional
        Ids when absent (omitted: required), taken as they are.
    """
    ids = r.raw(key, default, types=(list, tuple))
    if ids is default:
        return tuple(ids)  # the caller's default (already checked)
    for pid in ids:
        if not isinstance(pid, int) or isinstance(pid, bool) or pid not in points:
            r.fail(key, f"unknown point id {pid!r}; points are {sorted(points)}")
    if len(set(ids)) != len(ids):
        r.fail(key, f"repeated point ids in {list(ids)}")
    return tuple(ids)
