"""The dissertation's published tables, as shipped in ``assets/data/*.csv``.

Each CSV starts with ``#`` comment lines naming the table; the first
non-comment line holds the column names. Values are in the thesis's units as
printed (Hz, damping ratio, lb-s/in for gains).
"""

from __future__ import annotations

import csv
from functools import lru_cache

import numpy as np

from .errors import DataFileError
from .spec import DATA_DIR
from .units import LBF_S_PER_IN


@lru_cache(maxsize=None)
def read_table(filename: str) -> dict[str, tuple]:
    """Read one published table.

    Parameters
    ----------
    filename : str
        File name in ``assets/data`` (e.g. ``"table1_bcc_frequencies.csv"``).

    Returns
    -------
    dict
        Column name -> tuple of values (floats where they parse, else str).

    Raises
    ------
    DataFileError
        If the file is missing or a row has the wrong number of fields.
    """
    path = DATA_DIR / filename
    if not path.exists():
        raise DataFileError(f"{path}: reference table not found")
    lines = [ln for ln in path.read_text().splitlines() if ln.strip() and not ln.startswith("#")]
    rows = list(csv.reader(lines))
    header, body = rows[0], rows[1:]
    cols: dict[str, list] = {h: [] for h in header}
    for i, row in enumerate(body, start=2):
        if len(row) != len(header):
            raise DataFileError(f"{path}: data row {i} has {len(row)} fields, expected {len(header)}")
        for h, v in zip(header, row):
            try:
                cols[h].append(float(v))
            except ValueError:
                cols[h].append(v)
    return {h: tuple(v) for h, v in cols.items()}


def column(filename: str, name: str, *, numeric_rows_only: bool = True) -> np.ndarray:
    """One column as a float array (rows whose first field is not numeric dropped).

    Parameters
    ----------
    filename : str
        File name in ``assets/data`` (e.g. ``"table8_bcc_damping.csv"``).
    name : str
        Column name (from the header line).
    numeric_rows_only : bool
        Keep only rows whose first field is a number (drops e.g. an
        "Avg. Error" row); False keeps every row.

    Returns
    -------
    ndarray, shape (n_rows,)
        The values in the table's units as printed (Hz, damping ratio, ...).

    Raises
    ------
    DataFileError
        If the file is missing or malformed, or has no column ``name``.
    ValueError
        If a kept value is not a number.
    """
    t = read_table(filename)
    first = next(iter(t.values()))
    keep = [i for i, v in enumerate(first) if isinstance(v, float)] if numeric_rows_only else range(len(first))
    if name not in t:
        raise DataFileError(f"{DATA_DIR / filename}: no column {name!r}; columns are {list(t)}")
    return np.array([t[name][i] for i in keep], dtype=float)


def bcc_gain(controller: str) -> np.ndarray:
    """Table 7 gain matrix D of the BCC in SI [N*s/m], actuator/sensor order (5, 7, 9).

    Raises DataFileError for an unknown controller (mfdrf or lqdrf).
    """
    t = read_table("table7_bcc_gains.csv")
    rows = [i for i, c in enumerate(t["controller"]) if c == controller]
    if not rows:
        raise DataFileError(f"table 7 has no controller {controller!r} (mfdrf, lqdrf)")
    d = np.array([[t[f"sensor_{p}"][i] for p in (5, 7, 9)] for i in rows])
    return d * LBF_S_PER_IN
