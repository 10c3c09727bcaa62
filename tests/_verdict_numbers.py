"""Whether the numbers of a diagnosis's verdict are its JSON's (the check of tests/test_verdict_numbers.py)."""

from __future__ import annotations

import math
import re

import numpy as np

#: a number standing alone: not part of a name (chi2, H1) or of another number
NUMBER = re.compile(r"(?<![A-Za-z_\d.])[-+]?\d+(?:\.\d+)?(?:e[-+]?\d+)?(?![A-Za-z_\d])")


def _leaves(obj, numbers: list, strings: list, derived: list) -> None:
    """Collect the numbers and strings of ``obj`` and what the verdict may derive from them: a list's length,
    the ratio of two numbers of one dict (a misfit before over after), the difference of one key's numbers
    over the dicts of one list (the scores of the ranked fits)."""
    if isinstance(obj, dict):
        vals = [float(v) for v in obj.values()
                if isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)]
        derived.extend(a / b for a in vals for b in vals if b != 0.0)
        for v in obj.values():
            _leaves(v, numbers, strings, derived)
    elif isinstance(obj, list):
        derived.append(len(obj))
        rows = [v for v in obj if isinstance(v, dict)]
        for key in {k for r in rows for k, v in r.items() if isinstance(v, float)}:
            col = [r[key] for r in rows if isinstance(r.get(key), float)]
            derived.extend(a - b for a in col for b in col)
        for v in obj:
            _leaves(v, numbers, strings, derived)
    elif isinstance(obj, str):
        strings.append(obj)
    elif isinstance(obj, (int, float)) and not isinstance(obj, bool) and math.isfinite(obj):
        numbers.append(float(obj))


def _digits(token: str) -> int:
    mant = token.lstrip("+-").split("e")[0].replace(".", "").lstrip("0")
    return max(len(mant), 1)


def _rounds_to(value: float, candidates: np.ndarray, digits: int) -> bool:
    """Whether some candidate rounds to ``value`` at ``digits`` significant digits (or fewer: trailing zeros)."""
    if value == 0.0:
        return bool(np.any(np.abs(candidates) < 5e-4))
    half = 0.5 * 10.0 ** (math.floor(math.log10(abs(value))) - digits + 1)
    return bool(np.any(np.abs(candidates - value) <= half * (1 + 1e-9)))


def unexplained_numbers(text: str, res: dict) -> list[str]:
    """The numbers of ``text`` that are not a number of ``res`` (or 100 x one, its square root, what
    :func:`_leaves` derives), nor written in one of its strings, each compared at the digits the text shows."""
    numbers, strings, derived = [], [], []
    _leaves(res, numbers, strings, derived)
    x = np.array(numbers, dtype=float)
    allowed = np.abs(np.concatenate([x, 100.0 * x, np.sqrt(np.abs(x)), np.array(derived, dtype=float)]))
    in_strings = {t for s in strings for t in re.findall(NUMBER, s)}
    return [t for t in re.findall(NUMBER, text)
            if t not in in_strings and not _rounds_to(abs(float(t)), allowed, _digits(t))]
