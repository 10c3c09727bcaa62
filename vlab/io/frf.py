"""The frequency response function as data: :class:`FRF`, response per unit force on a frequency grid.

The type every FRF in vlab has, whether measured (the H1 estimator of
:mod:`vlab.measure.frf`), read from a UFF 58 file (:mod:`vlab.io.uff`) or
computed from a model. Velocity and displacement FRFs convert into each other
by integration or differentiation in the frequency domain, as Sec. 5.4.1 did
(VFRF -> DFRF). Time dependence ``exp(+i omega t)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import MeasurementError

#: Response quantity -> unit of the FRF (response per force).
FRF_UNITS = {"displacement": "m/N", "velocity": "(m/s)/N", "acceleration": "(m/s^2)/N"}

def _frozen(a, dtype) -> np.ndarray:
    arr = np.array(a, dtype=dtype, copy=True)
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True, eq=False)
class FRF:
    """A frequency response function (response per unit force) on a frequency grid.

    Parameters
    ----------
    freq_hz : array_like, shape (n_freq,)
        Frequencies [Hz], strictly increasing, >= 0.
    h : array_like, shape (n_freq,)
        Complex FRF in SI units (see :attr:`unit`).
    response : {"displacement", "velocity", "acceleration"}
        Response quantity (numerator); the denominator is force [N].
    coherence : array_like, shape (n_freq,), optional
        Ordinary coherence in [0, 1]; ``None`` for an analytical FRF.
    output_name, input_name : str
        Channel names, e.g. ``"vel6"`` and ``"force9"``.
    output_point, input_point : int, optional
        Structure point ids of response and force.
    n_averages : int, optional
        Number of blocks averaged.

    Raises
    ------
    MeasurementError
        Inconsistent shapes, non-increasing or negative frequencies, unknown
        response quantity.
    """

    freq_hz: np.ndarray
    h: np.ndarray
    response: str = "velocity"
    coherence: np.ndarray | None = None
    output_name: str = "output"
    input_name: str = "input"
    output_point: int | None = None
    input_point: int | None = None
    n_averages: int | None = None

    def __post_init__(self) -> None:
        f = _frozen(self.freq_hz, float)
        h = _frozen(self.h, complex)
        name = self.name
        if f.ndim != 1 or h.shape != f.shape:
            raise MeasurementError(f"FRF {name}: freq_hz {f.shape} and h {h.shape} must be equal 1-D shapes")
        if f.size and (np.any(np.diff(f) <= 0) or f[0] < 0 or not np.all(np.isfinite(f))):
            raise MeasurementError(f"FRF {name}: freq_hz must be finite, >= 0 and strictly increasing")
        if self.response not in FRF_UNITS:
            raise MeasurementError(f"FRF {name}: unknown response {self.response!r}; known: {', '.join(FRF_UNITS)}")
        object.__setattr__(self, "freq_hz", f)
        object.__setattr__(self, "h", h)
        if self.coherence is not None:
            c = _frozen(self.coherence, float)
            if c.shape != f.shape:
                raise MeasurementError(f"FRF {name}: coherence shape {c.shape} != freq_hz shape {f.shape}")
            object.__setattr__(self, "coherence", c)

    @property
    def name(self) -> str:
        """``"output/input"``, e.g. ``"vel6/force9"``."""
        return f"{self.output_name}/{self.input_name}"

    @property
    def unit(self) -> str:
        """Unit of :attr:`h`, e.g. ``"(m/s)/N"``."""
        return FRF_UNITS[self.response]

    @property
    def magnitude(self) -> np.ndarray:
        """``|h|``, shape (n_freq,)."""
        return np.abs(self.h)

    @property
    def omega(self) -> np.ndarray:
        """Angular frequency ``2 pi f`` [rad/s], shape (n_freq,)."""
        return 2.0 * np.pi * self.freq_hz

    def band(self, f_low_hz: float, f_high_hz: float) -> FRF:
        """Copy restricted to ``f_low_hz <= f <= f_high_hz``.

        Raises
        ------
        MeasurementError
            If no frequency lies in the band.
        """
        sel = (self.freq_hz >= f_low_hz) & (self.freq_hz <= f_high_hz)
        if not np.any(sel):
            raise MeasurementError(f"FRF {self.name}: no line in [{f_low_hz}, {f_high_hz}] Hz")
        return self._with(self.freq_hz[sel], self.h[sel],
                          None if self.coherence is None else self.coherence[sel], self.response)

    def _with(self, f, h, c, response) -> FRF:
        return FRF(freq_hz=f, h=h, response=response, coherence=c, output_name=self.output_name,
                   input_name=self.input_name, output_point=self.output_point,
                   input_point=self.input_point, n_averages=self.n_averages)

    def _require(self, response: str, method: str) -> None:
        """MeasurementError naming ``method`` unless this FRF's response is ``response``."""
        if self.response != response:
            raise MeasurementError(f"FRF {self.name}: {method} needs a {response} FRF, not {self.response}")

    def to_displacement(self) -> FRF:
        """Displacement FRF (DFRF) from a velocity FRF (VFRF): ``H_d = H_v / (i 2 pi f)``.

        The 0 Hz line, where the division is undefined, is dropped.
        Source: Sec. 5.4.1 ("The VFRFs were then integrated in the frequency domain").

        Raises
        ------
        MeasurementError
            If :attr:`response` is not ``"velocity"``.
        """
        self._require("velocity", "to_displacement")
        keep = self.freq_hz > 0
        f = self.freq_hz[keep]
        c = None if self.coherence is None else self.coherence[keep]
        return self._with(f, self.h[keep] / (2j * np.pi * f), c, "displacement")

    def to_velocity(self) -> FRF:
        """Velocity FRF from a displacement FRF: ``H_v = i 2 pi f H_d``.

        Raises
        ------
        MeasurementError
            If :attr:`response` is not ``"displacement"``.
        """
        self._require("displacement", "to_velocity")
        return self._with(self.freq_hz, self.h * (2j * np.pi * self.freq_hz), self.coherence, "velocity")

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, FRF):
            return NotImplemented
        same_c = (self.coherence is None and other.coherence is None) or (
            self.coherence is not None and other.coherence is not None
            and np.array_equal(self.coherence, other.coherence))
        return (np.array_equal(self.freq_hz, other.freq_hz) and np.array_equal(self.h, other.h)
                and same_c and self.response == other.response
                and (self.output_name, self.input_name, self.output_point, self.input_point,
                     self.n_averages)
                == (other.output_name, other.input_name, other.output_point, other.input_point,
                    other.n_averages))

    __hash__ = None  # type: ignore[assignment]
