"""The base of the loop blocks of :mod:`vlab.lab.blocks`: channel count, named signals, input checks.

Every block carries a vector of ``size`` channels; inputs must have shape
``(size,)`` and be finite (a non-finite input is a diverged loop:
:class:`~vlab.errors.SimulationError`), parameters are finite scalars
broadcast to every channel or one value per channel.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import ModelError, SimulationError


def positive(value: float, *, what: str) -> float:
    """``value`` as a float, checked to be positive and finite (a period, step, corner frequency or level).

    Parameters
    ----------
    value : float
        The number to check.
    what : str
        Its name for the message, e.g. ``"dac.period_s"``.

    Returns
    -------
    float

    Raises
    ------
    ModelError
        Not a positive finite number.
    """
    v = float(value)
    if not math.isfinite(v) or v <= 0.0:
        raise ModelError(f"{what} must be a positive finite number, got {value!r}")
    return v


def _size(size: int, *, what: str) -> int:
    if isinstance(size, bool) or int(size) != size or size < 1:
        raise ModelError(f"{what}: size must be a positive integer, got {size!r}")
    return int(size)


class Block:
    """Base of the loop blocks: a name, a channel count, input checks.

    Parameters
    ----------
    size : int
        Number of channels; inputs and outputs have shape ``(size,)``.
    name : str
        Name of the block in messages.

    Raises
    ------
    ModelError
        ``size`` not a positive integer.
    """

    #: Name of the input signal.
    INPUT = "u"
    #: Name of the output signal.
    OUTPUT = "y"

    def __init__(self, *, size: int, name: str) -> None:
        self.name = str(name)
        self.size = _size(size, what=self.name)

    def _vector(self, value, *, signal: str) -> np.ndarray:
        """``value`` as a float vector of shape (size,), or a ModelError naming the signal."""
        arr = np.asarray(value, dtype=float)
        if arr.shape != (self.size,):
            raise ModelError(f"{self.name}.{signal}: expected shape ({self.size},), got {arr.shape}")
        return arr

    def _input(self, u) -> np.ndarray:
        arr = self._vector(u, signal=self.INPUT)
        if not math.isfinite(arr.sum()):  # one reduction: a NaN or inf anywhere makes the sum non-finite
            if not np.all(np.isfinite(arr)):
                raise SimulationError(f"{self.name}.{self.INPUT}: non-finite input {arr}")
        return arr.copy()

    def _initial(self, value, *, what: str = "initial_value") -> np.ndarray:
        """A scalar (broadcast) or a (size,) vector of finite parameter values."""
        arr = np.asarray(value, dtype=float)
        arr = np.full(self.size, float(arr)) if arr.ndim == 0 else self._vector(arr, signal=what).copy()
        if not np.all(np.isfinite(arr)):
            raise ModelError(f"{self.name}.{what} must be finite, got {arr}")
        return arr

    def __repr__(self) -> str:
        return f"{type(self).__name__}(name={self.name!r}, size={self.size})"
