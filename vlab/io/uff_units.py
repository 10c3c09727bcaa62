"""Units of UFF 58 records: the header's data characteristics and the file's units record, honoured or refused.

vlab reads SI data (N, m/s, s, Hz). A dataset-58 record says what its
abscissa, ordinate and ordinate denominator hold in two ways, both checked
here so that nothing is assumed:

- the data-characteristic records (header records 8, 9 and 10): a
  specific data type, the length and force unit exponents (the dimension in
  the file's unit system) and an axis units label;
- the file's units record (dataset 164): the factors that convert the file's
  length, force and temperature units to SI.

Honoured: a frequency abscissa labelled ``rad/s`` (divided by 2 pi) or
``kHz`` (times 1000); a label left empty or ``NONE`` (the format's own unit:
s for time, Hz for frequency, the unit system's for the rest). Refused,
naming the file, record and field: a units record that is not SI (factors
other than 1), any other abscissa label, a denominator labelled other than N
(``lbf``), unit exponents that contradict the specific data type.

Source: UFF dataset 58 and 164 descriptions (SDRC/I-DEAS, "Universal File
Datasets Summary", https://www.ceas3.uc.edu/sdrluff/).
"""

from __future__ import annotations

import math
from pathlib import Path

from ..errors import DataFileError

#: Abscissa unit labels of a frequency axis and their factor to Hz (compared case-insensitively, spaces removed).
FREQUENCY_LABELS = {"": 1.0, "none": 1.0, "hz": 1.0, "1/s": 1.0, "cps": 1.0, "khz": 1e3,
                    "rad/s": 1.0 / (2.0 * math.pi), "rad/sec": 1.0 / (2.0 * math.pi),
                    "radians/s": 1.0 / (2.0 * math.pi)}
#: Abscissa unit labels of a time axis (seconds only).
TIME_LABELS = {"", "none", "s", "sec", "seconds"}
#: Unit labels of an FRF's force denominator (newtons only).
FORCE_LABELS = {"", "none", "n"}
#: (length, force) unit exponents of each specific data type vlab reads (time/frequency are dimensionless here).
EXPONENTS = {8: (1, 0), 11: (1, 0), 12: (1, 0), 13: (0, 1), 9: (0, 1), 17: (0, 0), 18: (0, 0)}
#: Relative tolerance of a units record's SI factors.
SI_TOLERANCE = 1e-6


def _label(s: dict, key: str) -> str:
    return "".join(str(s.get(key, "") or "").split()).lower()


def _exponent(p: Path, s: dict, key: str, where: str) -> int:
    v = s.get(key, 0)
    try:
        f = float(v or 0)
    except (TypeError, ValueError):
        raise DataFileError(f"{p}: {where}: {key} {v!r} is not an integer unit exponent") from None
    if not math.isfinite(f) or f != int(f):
        raise DataFileError(f"{p}: {where}: {key} {v!r} is not an integer unit exponent")
    return int(f)


def check_units_records(p: Path, sets: list[dict]) -> None:
    """Refuse a file whose units record (dataset 164) is not SI.

    Parameters
    ----------
    p : Path
        The file (for messages).
    sets : list of dict
        Every dataset pyuff read from it.

    Raises
    ------
    DataFileError
        A dataset 164 whose length or force factor is not 1 (names the units
        description, code and factors).
    """
    for s in sets:
        if s.get("type") != 164:
            continue
        factors = {k: s.get(k) for k in ("length", "force")}
        bad = {k: v for k, v in factors.items()
               if not isinstance(v, (int, float)) or not math.isclose(float(v), 1.0, rel_tol=SI_TOLERANCE)}
        if bad:
            desc = str(s.get("units_description", "") or "").strip()
            raise DataFileError(
                f"{p}: units record (dataset 164) {desc!r} (units code {s.get('units_code')}) has "
                + ", ".join(f"{k} factor {v!r}" for k, v in bad.items())
                + ": its data are not in SI; vlab reads SI files only (N, m, s): convert the file")


def units_system(p: Path, sets: list[dict]) -> tuple[float, float, str] | None:
    """The unit system a file's units record (dataset 164) states, as its factors to SI.

    Record 2 of dataset 164 holds "unit factors for converting universal file
    units to SI: to convert from universal file units to SI divide by the
    appropriate factor": a value of length exponent ``a`` and force exponent
    ``b`` is ``value / (length ** a * force ** b)`` in SI (time is in seconds
    in every unit system of the format). ``p`` and ``sets`` as in :func:`check_units_records`.

    Returns
    -------
    (length, force, description) or None
        The length and force factors [file unit per SI unit] and the units
        description; None without a units record.

    Raises
    ------
    DataFileError
        A factor that is not a positive finite number, or two units records
        that disagree (names the file and the factors).
    """
    found = None
    for s in sets:
        if s.get("type") != 164:
            continue
        desc = str(s.get("units_description", "") or "").strip()
        vals = []
        for k in ("length", "force"):
            v = s.get(k)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not (math.isfinite(v) and v > 0):
                raise DataFileError(f"{p}: units record (dataset 164) {desc!r}: {k} factor {v!r} is not a positive "
                                    "number")
            vals.append(float(v))
        here = (vals[0], vals[1], desc)
        if found is not None and not all(math.isclose(a, b, rel_tol=SI_TOLERANCE) for a, b in zip(found[:2], here[:2])):
            raise DataFileError(f"{p}: two units records (dataset 164) disagree: {found[2]!r} (length factor "
                                f"{found[0]!r}, force factor {found[1]!r}) and {desc!r} (length factor {vals[0]!r}, "
                                f"force factor {vals[1]!r})")
        found = found or here
    return found


def exponents(p: Path, s: dict, prefix: str, where: str) -> tuple[int, int]:
    """The (length, force) unit exponents of one axis of a record (both 0: not given).

    Parameters
    ----------
    p, s, prefix, where
        As :func:`check_exponents`.

    Returns
    -------
    (int, int)

    Raises
    ------
    DataFileError
        An exponent that is not an integer (names the field and value).
    """
    return _exponent(p, s, f"{prefix}_len_unit_exp", where), _exponent(p, s, f"{prefix}_force_unit_exp", where)


def check_exponents(p: Path, s: dict, prefix: str, code: int, where: str) -> None:
    """Refuse length/force unit exponents that contradict the specific data type ``code``.

    Exponents both 0 mean "not given" (many writers leave them so).

    Parameters
    ----------
    p : Path
        The file.
    s : dict
        The dataset-58 record as pyuff reads it.
    prefix : str
        ``"ordinate"``, ``"orddenom"`` or ``"abscissa"`` (pyuff's field prefix).
    code : int
        The specific data type of that axis.
    where : str
        Record name for messages.

    Raises
    ------
    DataFileError
        Naming the fields and their values.
    """
    got = (_exponent(p, s, f"{prefix}_len_unit_exp", where), _exponent(p, s, f"{prefix}_force_unit_exp", where))
    want = EXPONENTS.get(code)
    if want is None or got == (0, 0) or got == want:
        return
    raise DataFileError(f"{p}: {where}: {prefix}_len_unit_exp {got[0]}, {prefix}_force_unit_exp {got[1]} "
                        f"contradict its specific data type {code} (exponents {want[0]}, {want[1]})")


def frequency_factor(p: Path, s: dict, where: str) -> float:
    """The factor that turns the record's frequency abscissa into Hz (from its units label).

    Parameters
    ----------
    p, s, where
        As :func:`check_exponents`; ``s`` is the FRF record.

    Returns
    -------
    float
        1 for Hz (or no label), 1/(2 pi) for rad/s, 1000 for kHz.

    Raises
    ------
    DataFileError
        Any other label (names it), or abscissa unit exponents that are not 0.
    """
    check_exponents(p, s, "abscissa", 18, where)
    lab = _label(s, "abscissa_axis_units_lab")
    if lab not in FREQUENCY_LABELS:
        raise DataFileError(f"{p}: {where}: frequency axis in {s.get('abscissa_axis_units_lab')!r}; vlab reads "
                            "Hz, kHz or rad/s")
    return FREQUENCY_LABELS[lab]


def check_time_axis(p: Path, s: dict, where: str) -> None:
    """Refuse a time abscissa not in seconds. ``p``, ``s`` (the time-response record) and ``where`` as in :func:`check_exponents`.

    Raises
    ------
    DataFileError
        A units label other than s (names it), or unit exponents that are not 0.
    """
    check_exponents(p, s, "abscissa", 17, where)
    if _label(s, "abscissa_axis_units_lab") not in TIME_LABELS:
        raise DataFileError(f"{p}: {where}: time axis in {s.get('abscissa_axis_units_lab')!r}; vlab reads "
                            "time in s")


def check_force_denominator(p: Path, s: dict, where: str) -> None:
    """Refuse an FRF whose force denominator is not in newtons. ``p``, ``s`` (the FRF record) and ``where`` as in :func:`check_exponents`.

    Raises
    ------
    DataFileError
        A denominator units label other than N (``lbf``: names it), or
        exponents that are not a force's.
    """
    code = int(s.get("orddenom_spec_data_type", 0) or 0)
    check_exponents(p, s, "orddenom", code or 13, where)
    if _label(s, "orddenom_axis_units_lab") not in FORCE_LABELS:
        raise DataFileError(f"{p}: {where}: per {s.get('orddenom_axis_units_lab')!r}; vlab reads FRFs per N "
                            "(SI only): convert the file")


__all__ = ["check_units_records", "units_system", "exponents", "check_exponents", "frequency_factor", "check_time_axis",
           "check_force_denominator"]
