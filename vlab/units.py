"""Unit conversion between the dissertation's system and SI.

The dissertation (Sec. 2-3) works in inch, lbf, lbf*s^2/in ("slinch") and, for
state-space design, a time unit of one centisecond (Sec. 3.1: "the time unit
employed was 10^-2 second (cs)"). vlab is SI inside; these factors convert.

All factors are exact by definition (inch = 0.0254 m, lbf = 4.4482216152605 N,
standard gravity g = 9.80665 m/s^2).
"""

from __future__ import annotations

import math

from .errors import SpecError

INCH_M = 0.0254                     #: [m] per inch
LBF_N = 4.4482216152605             #: [N] per lbf
G_SI = 9.80665                      #: [m/s^2] standard gravity
G_IN = G_SI / INCH_M                #: [in/s^2] standard gravity, 386.0886
SLINCH_KG = LBF_N / INCH_M          #: [kg] per lbf*s^2/in, 175.1268
LBF_PER_IN_N_PER_M = LBF_N / INCH_M  #: [N/m] per lbf/in
LBF_S_PER_IN = LBF_N / INCH_M       #: [N*s/m] per lbf*s/in (Table 7 gains)
LBF_IN2_NM2 = LBF_N * INCH_M**2     #: [N*m^2] per lbf*in^2 (EI, GJ)
LBF_IN_NM = LBF_N * INCH_M          #: [N*m] per lbf*in (moments, rotational stiffness)
CS_S = 0.01                         #: [s] per centisecond

#: Known unit strings in structure files, and their factor to SI.
_FACTORS: dict[str, float] = {
    # length
    "m": 1.0, "in": INCH_M, "mm": 1e-3,
    # force / weight
    "N": 1.0, "lbf": LBF_N,
    # mass
    "kg": 1.0, "lbf*s^2/in": SLINCH_KG, "lbm": 0.45359237,
    # weight given as force, converted to mass by standard gravity
    # (handled in to_si with kind="weight")
    # stiffness
    "N/m": 1.0, "lbf/in": LBF_PER_IN_N_PER_M,
    "N*m/rad": 1.0, "lbf*in/rad": LBF_IN_NM,
    # flexural / torsional rigidity
    "N*m^2": 1.0, "lbf*in^2": LBF_IN2_NM2,
    # modulus
    "Pa": 1.0, "psi": LBF_N / INCH_M**2,
    # density
    "kg/m^3": 1.0, "lbf/in^3": LBF_N / G_SI / INCH_M**3,  # weight density -> mass density
    # damping
    "N*s/m": 1.0, "lbf*s/in": LBF_S_PER_IN,
    # mass moment of inertia
    "kg*m^2": 1.0, "lbf*s^2*in": SLINCH_KG * INCH_M**2,
    # angle, dimensionless, time, frequency
    "rad": 1.0, "deg": 3.141592653589793 / 180.0, "1": 1.0, "s": 1.0, "Hz": 1.0,
}


def factor(unit: str, *, where: str = "") -> float:
    """Return the factor that converts a value in ``unit`` to SI.

    Parameters
    ----------
    unit : str
        One of the unit strings of :data:`_FACTORS` (e.g. ``"in"``, ``"lbf*in^2"``).
    where : str
        Context for the error message (file and field).

    Raises
    ------
    SpecError
        If the unit is unknown; the message lists the known units.
    """
    try:
        return _FACTORS[unit]
    except KeyError:
        known = ", ".join(sorted(_FACTORS))
        raise SpecError(f"{where}: unknown unit {unit!r}; known units: {known}") from None


def weight_to_mass(weight_n: float) -> float:
    """Mass [kg] of a body whose weight is ``weight_n`` [N] under standard gravity."""
    return weight_n / G_SI


def format_duration(seconds: float) -> str:
    """``seconds`` as ``"N s"``, ``"N min"``, ``"N h"`` or ``"N days"`` (two significant figures); ``"unknown"`` if not finite."""
    for unit, size in (("days", 86400.0), ("h", 3600.0), ("min", 60.0)):
        if seconds >= size:
            return f"{seconds / size:.2g} {unit}"
    return f"{seconds:.2g} s" if math.isfinite(seconds) else "unknown"


def format_bytes(n: float) -> str:
    """``n`` bytes as ``"N B"``, ``"N kB"``, ... ``"N PB"`` (decimal prefixes, three significant figures)."""
    for unit in ("B", "kB", "MB", "GB", "TB"):
        if abs(n) < 1000:
            return f"{n:.3g} {unit}"
        n /= 1000.0
    return f"{n:.3g} PB"
