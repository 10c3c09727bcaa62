"""Units of measured time histories: the labels acquisition systems write and their factors to SI.

A time history from an acquisition system names its unit in a label (a UFF
record's ordinate axis units label, a CSV column's ``[unit]``). vlab converts
every sample to SI on reading (N, m, m/s, m/s^2) with the factors below and
refuses a label it does not know, naming it: nothing is assumed.

Labels are compared without case and without spaces; ``^`` and ``**`` are
the same, and a trailing ``2`` after ``s`` reads as ``s^2`` (``m/s2``).
``g`` is the standard acceleration of gravity, 9.80665 m/s^2 (the CGPM's
conventional value, 3rd CGPM 1901). ``lbf`` is the pound-force,
4.4482216152605 N, and ``in`` the international inch, 0.0254 m (NIST Special
Publication 811, 2008, Appendix B.8).

Source: NIST SP 811, *Guide for the Use of the International System of Units*, Appendix B.
"""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType

from ..units import G_SI as STANDARD_GRAVITY_M_S2
from ..units import INCH_M
from ..units import LBF_N as POUND_FORCE_N

_LENGTHS = {"m": 1.0, "mm": 1e-3, "cm": 1e-2, "um": 1e-6, "µm": 1e-6, "in": INCH_M, "ft": 0.3048}

#: Unit label (normalised by :func:`normalise_label`) -> factor to SI, by quantity.
UNIT_FACTORS: Mapping[str, Mapping[str, float]] = MappingProxyType({
    "displacement": MappingProxyType({**_LENGTHS, "micron": 1e-6, "mil": 1e-3 * INCH_M}),
    "velocity": MappingProxyType({**{f"{k}/s": v for k, v in _LENGTHS.items()}, "ips": INCH_M}),
    "acceleration": MappingProxyType({**{f"{k}/s^2": v for k, v in _LENGTHS.items()},
                                      "g": STANDARD_GRAVITY_M_S2, "mg": 1e-3 * STANDARD_GRAVITY_M_S2}),
    "force": MappingProxyType({"n": 1.0, "kn": 1e3, "mn": 1e-3, "lbf": POUND_FORCE_N,
                               "kgf": STANDARD_GRAVITY_M_S2}),
})

#: Labels that mean "no unit given" (the file's own unit system decides).
NO_UNIT = frozenset({"", "none"})


def normalise_label(label) -> str:
    """A unit label as :data:`UNIT_FACTORS` spells it: lower case, no spaces, ``s^2`` for ``s**2``/``s2``/``s²``.

    Parameters
    ----------
    label : object
        The label as written (None reads as empty).

    Returns
    -------
    str
    """
    s = "".join(str(label or "").split()).lower().replace("**", "^").replace("²", "^2")
    if s.endswith("/s2"):
        s = s[:-3] + "/s^2"
    return s.replace("μ", "µ")  # Greek mu and the micro sign


def unit_factor(quantity: str, label) -> float | None:
    """The factor that turns a value of ``quantity`` in the unit ``label`` into SI.

    Parameters
    ----------
    quantity : {"force", "displacement", "velocity", "acceleration"}
    label : str
        The unit as written (``"g"``, ``"mm/s"``, ``"lbf"``).

    Returns
    -------
    float or None
        SI value = value x factor; None where the label is empty or ``NONE``.

    Raises
    ------
    KeyError
        An unknown quantity, or a label that is not a unit of it (the caller
        names its file and field; :func:`known_labels` lists what is read).
    """
    s = normalise_label(label)
    if s in NO_UNIT:
        return None
    table = UNIT_FACTORS[quantity]
    if s not in table:
        raise KeyError(s)
    return float(table[s])


def known_labels(quantity: str) -> list[str]:
    """The unit labels read for ``quantity``, sorted (for messages).

    Raises
    ------
    KeyError
        Unknown quantity.
    """
    return sorted(UNIT_FACTORS[quantity])


__all__ = ["STANDARD_GRAVITY_M_S2", "INCH_M", "POUND_FORCE_N", "UNIT_FACTORS", "NO_UNIT", "normalise_label",
           "unit_factor", "known_labels"]
