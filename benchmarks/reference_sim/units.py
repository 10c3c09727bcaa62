"""Unit conversion of the structure files' ``{value, unit, source}`` entries to SI.

The structure files state inch-pound values (dissertation Sec. 2.1). Weights in lbf
are converted to masses with standard gravity (a body weighing 1 lbf has a mass of
0.45359237 kg), weight densities in lbf/in^3 to mass densities in kg/m^3.
This module imports numpy only; it never imports vlab.
"""

from __future__ import annotations

G_STANDARD = 9.80665
"""Standard gravity [m/s^2] (CGPM 1901)."""

INCH_M = 0.0254
"""One inch [m] (exact)."""

LBF_N = 4.4482216152605
"""One pound-force [N] (exact: 0.45359237 kg x 9.80665 m/s^2)."""

LB_KG = 0.45359237
"""Mass of a body weighing one lbf under standard gravity [kg]."""

PSI_PA = LBF_N / INCH_M**2
"""One psi [Pa]."""

_LENGTH = {"in": INCH_M, "m": 1.0, "mm": 1e-3}
_FORCE = {"lbf": LBF_N, "N": 1.0}


class UnitError(ValueError):
    """A structure-file entry with a missing or unknown unit."""


def entry_value(entry, where: str) -> float:
    """The number of a ``{value, unit, source}`` entry, in its own unit.

    Parameters
    ----------
    entry : dict or float
        A table with a ``value`` key, or a bare number.
    where : str
        The entry's place in the file, for the error message.

    Returns
    -------
    float

    Raises
    ------
    UnitError
        Neither a number nor a table with a numeric ``value``.
    """
    if isinstance(entry, (int, float)) and not isinstance(entry, bool):
        return float(entry)
    if isinstance(entry, dict) and isinstance(entry.get("value"), (int, float)):
        return float(entry["value"])
    raise UnitError(f"{where}: expected a number or {{value, unit}}, found {entry!r}")


def to_si(entry, kind: str, where: str) -> float:
    """Convert a structure-file entry to SI.

    Parameters
    ----------
    entry : dict
        ``{value, unit, source}``.
    kind : {"length", "force", "weight_as_mass", "weight_density_as_density",
            "stress", "flexural_rigidity"}
        What the entry is: a length [m], a force [N], a weight turned into a mass
        [kg], a weight density turned into a mass density [kg/m^3], a modulus [Pa]
        or a bending stiffness EI [N m^2].
    where : str
        The entry's place in the file, for the error message.

    Returns
    -------
    float
        The SI value.

    Raises
    ------
    UnitError
        A unit this kind does not accept (named with the entry's place).
    """
    value = entry_value(entry, where)
    unit = entry.get("unit") if isinstance(entry, dict) else None
    table = {
        "length": _LENGTH,
        "force": _FORCE,
        "weight_as_mass": {"lbf": LB_KG, "kg": 1.0},
        "weight_density_as_density": {"lbf/in^3": LB_KG / INCH_M**3, "kg/m^3": 1.0},
        "stress": {"psi": PSI_PA, "Pa": 1.0},
        "flexural_rigidity": {"lbf*in^2": LBF_N * INCH_M**2, "N*m^2": 1.0},
    }
    if kind not in table:
        raise UnitError(f"{where}: unknown quantity kind {kind!r}")
    if unit not in table[kind]:
        raise UnitError(f"{where}: unit {unit!r} is not one of {sorted(table[kind])}")
    return value * table[kind][unit]
