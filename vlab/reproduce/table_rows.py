"""What the table groups of :mod:`vlab.reproduce.tables` share: controller names and labels, the flags
of a row, and the published rows (modes, gains) and titles read from ``assets/data/table*.csv``.
"""

from __future__ import annotations

import numpy as np

from ..reference import read_table
from ..spec import DATA_DIR
from .context import ReproContext
from .results import Row

#: Controller names of the thesis's columns -> vlab controller ids.
CONTROLLER_OF = {"lqr": "lqr", "lqg": "lqg", "mfdrf": "mfdrf", "lqdrf": "lqdrf", "lqdrf_diag": "lqdrf-diag"}
LABEL = {"lqr": "LQR", "lqg": "LQG", "mfdrf": "MFDRF", "lqdrf": "LQDRF", "lqdrf_diag": "diagonal LQDRF",
         "lqdrf-diag": "diagonal LQDRF"}

RECON = "reconstructed"
CAL = "calibrated"
ASSUMED = "assumed"


def mode_rows(filename: str) -> tuple[dict, list[int]]:
    """Published table and the indices of its numeric ``mode`` rows.

    Parameters
    ----------
    filename : str
        File in ``assets/data`` with a ``mode`` column.

    Returns
    -------
    table : dict
        Column name -> values (:func:`vlab.reference.read_table`).
    index : list of int
        Rows whose ``mode`` is a number (not a summary row).
    """
    t = read_table(filename)
    idx = [i for i, v in enumerate(t["mode"]) if isinstance(v, float)]
    return t, idx


def gain_rows(filename: str, controller: str, sensors: tuple[int, ...]) -> np.ndarray:
    """Published gain matrix (lb-s/in) of one controller of Tables 7, 11, 15.

    Parameters
    ----------
    filename : str
        File in ``assets/data`` with ``controller`` and ``sensor_<point>`` columns.
    controller : str
        Thesis controller name (``"mfdrf"``, ``"lqdrf"``, ``"lqdrf_diag"``).
    sensors : tuple of int
        Sensor points, the order of the columns.

    Returns
    -------
    ndarray, shape (n_actuators, n_sensors)
    """
    t = read_table(filename)
    rows = [i for i, c in enumerate(t["controller"]) if c == controller]
    return np.array([[t[f"sensor_{s}"][i] for s in sensors] for i in rows])


def gain_table_rows(ctx: ReproContext, structure: str, filename: str, controllers: tuple[str, ...],
                     model: str | None, flag: str) -> list[Row]:
    """Published DRF gains of Tables 7, 11, 15 against vlab's designs on ``model`` (lb-s/in), row by row.

    One row per (actuator a, "<controller> sensor s"); a diagonal LQDRF has its diagonal terms only.

    Parameters
    ----------
    ctx : ReproContext
        Models and designs of the run.
    structure : str
        ``"bcc"`` or ``"grid"``.
    filename : str
        The published gain table in ``assets/data``.
    controllers : tuple of str
        Thesis controller names (keys of :data:`CONTROLLER_OF`).
    model : str or None
        Design model (``"exact"``, ``"corrected-guyan"``; None: the structure's default).
    flag : str
        Flag of every row.

    Returns
    -------
    list of Row
    """
    acts = tuple(ctx.fe(structure).spec.instrumentation.actuators)
    rows = []
    for c in controllers:
        pub = gain_rows(filename, c, acts)
        ours = np.asarray(ctx.design(structure, CONTROLLER_OF[c], model).extra["gain_thesis_lb_s_per_in"])
        for i, a in enumerate(acts):
            for j, s in enumerate(acts):
                if c == "lqdrf_diag" and i != j:
                    continue
                rows.append(Row(f"actuator {a}", f"{LABEL[c]} sensor {s}", pub[i, j], ours[i, j], flag))
    return rows


def t_title(filename: str) -> str:
    """The title comment of a published CSV (without the leading ``#``).

    Parameters
    ----------
    filename : str
        File in ``assets/data``.

    Returns
    -------
    str
    """
    for line in (DATA_DIR / filename).read_text().splitlines():
        if line.startswith("#"):
            return line.lstrip("# ").strip()
    return filename

