"""The PC-1000 controller engine: one matrix-vector product per sample (Eq. 5.1).

The PC-1000's array processor multiplies a constant coefficient matrix by the
vector of sensor signals and internal states at every sample (Sec. 5.3)::

    [ u_k       ]   [ F11  F12 ] [ y_k ]
    [ x_{k+1}   ] = [ F21  F22 ] [ x_k ]                    (5.1)

DRF controllers (MFDRF, LQDRF) use ``F11 = -D`` alone (no internal state);
LQG uses ``F12 = -F_R``, ``F21``, ``F22`` from Eqs. (5.2)-(5.4) and
``F11 = 0``. The hardware held at most 16 inputs, 16 outputs and 32 states.
"""

from __future__ import annotations

import math

import numpy as np
from controllers.realization import Eq51Sizes

from ..errors import ModelError, SimulationError

#: PC-1000 capacity (Sec. 5.3): 16 sensor inputs, 16 actuator outputs, 32 internal states.
PC1000_MAX_INPUTS = 16
PC1000_MAX_OUTPUTS = 16
PC1000_MAX_STATES = 32


def _matrix(name: str, value, shape: tuple[int, int]) -> np.ndarray:
    """``value`` as a float matrix of ``shape`` or a ModelError naming the matrix."""
    arr = np.array(value, dtype=float, copy=True)
    if arr.ndim != 2 or arr.shape != shape:
        raise ModelError(f"{name}: expected shape {shape}, found {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ModelError(f"{name}: contains non-finite entries")
    arr.setflags(write=False)
    return arr


class ControllerEngine(Eq51Sizes):
    """Discrete-time controller ``u_k = F11 y_k + F12 x_k``, ``x_{k+1} = F21 y_k + F22 x_k``.

    Eq. (5.1) of Sec. 5.3, executed once per sampling period ``period_s``.
    Signals: input ``y`` (sensor velocities [m/s], shape (n_y,)), output
    ``u`` (actuator force commands [N], shape (n_u,)), state ``x``
    (shape (n_x,), ``n_x`` may be 0).

    Parameters
    ----------
    F11 : array_like, shape (n_u, n_y)
        Direct feedthrough [N/(m/s)].
    F12 : array_like, shape (n_u, n_x), optional
        State to output.
    F21 : array_like, shape (n_x, n_y), optional
        Input to next state.
    F22 : array_like, shape (n_x, n_x), optional
        State transition.
    period_s : float
        Sampling period [s] (0.5e-3 at 2000 samples/s; LQG on the PC-1000 was
        discretised at 1e-3, Sec. 5.3). Keyword-only.
    initial_state : array_like, shape (n_x,), optional
        ``x_0``; zeros by default.

    ``F12``, ``F21`` and ``F22`` are given together or not at all (then
    ``n_x = 0``: a static gain).

    Raises
    ------
    ModelError
        A matrix of the wrong shape (the message names it and shows expected
        vs found shape), non-finite entries, a non-positive period, or only
        some of F12/F21/F22 given.

    Notes
    -----
    The engine does not model the PC-1000's 1.35-period delay nor its DAC;
    chain it with :class:`vlab.lab.blocks.SampleDelay`. Source: Eq. (5.1),
    Sec. 5.3; block layout after Drake's discrete systems.
    """

    def __init__(self, F11, F12=None, F21=None, F22=None, *, period_s: float,
                 initial_state=None) -> None:
        f11 = np.asarray(F11, dtype=float)
        if f11.ndim != 2:
            raise ModelError(f"F11: expected a 2-D (n_u, n_y) matrix, found shape {f11.shape}")
        n_u, n_y = f11.shape
        given = [m is not None for m in (F12, F21, F22)]
        if any(given) and not all(given):
            missing = [n for n, g in zip(("F12", "F21", "F22"), given) if not g]
            raise ModelError(f"F12, F21 and F22 must be given together; missing {', '.join(missing)}")
        if all(given):
            f22 = np.asarray(F22, dtype=float)
            if f22.ndim != 2 or f22.shape[0] != f22.shape[1]:
                raise ModelError(f"F22: expected a square (n_x, n_x) matrix, found shape {f22.shape}")
            n_x = f22.shape[0]
        else:
            n_x = 0
            F12, F21, F22 = np.zeros((n_u, 0)), np.zeros((0, n_y)), np.zeros((0, 0))
        self.F11 = _matrix("F11", F11, (n_u, n_y))
        self.F12 = _matrix("F12", F12, (n_u, n_x))
        self.F21 = _matrix("F21", F21, (n_x, n_y))
        self.F22 = _matrix("F22", F22, (n_x, n_x))
        p = float(period_s)
        if not math.isfinite(p) or p <= 0:
            raise ModelError(f"period_s must be a positive finite time [s], got {period_s!r}")
        self.period_s = p
        if initial_state is None:
            x0 = np.zeros(n_x)
        else:
            x0 = np.array(initial_state, dtype=float)
            if x0.shape != (n_x,):
                raise ModelError(f"initial_state: expected shape ({n_x},), found {x0.shape}")
        self._x0 = x0
        self.reset()

    @classmethod
    def from_gain(cls, D, *, period_s: float) -> ControllerEngine:
        """Direct rate feedback ``u = -D y`` (MFDRF, LQDRF; Eq. 4.30, Sec. 5.3).

        Parameters
        ----------
        D : array_like, shape (n_u, n_y)
            Gain matrix [N/(m/s)]; positive (semi-)definite for a dissipative
            collocated controller (Tables 7, 11). Note the sign: the engine's
            ``F11 = -D``.
        period_s : float
            Sampling period [s].

        Raises
        ------
        ModelError
            If ``D`` is not a finite 2-D matrix.
        """
        d = np.asarray(D, dtype=float)
        if d.ndim != 2:
            raise ModelError(f"D: expected a 2-D (n_u, n_y) matrix, found shape {d.shape}")
        return cls(-d, period_s=period_s)

    # -- sizes (n_inputs, n_outputs, n_states: Eq51Sizes) ---------------------
    @property
    def sample_rate_hz(self) -> float:
        """``1 / period_s`` [Hz]."""
        return 1.0 / self.period_s

    @property
    def coefficient_matrix(self) -> np.ndarray:
        """The full matrix ``[[F11, F12], [F21, F22]]`` of Eq. (5.1), shape (n_u+n_x, n_y+n_x)."""
        return np.block([[self.F11, self.F12], [self.F21, self.F22]])

    def fits_pc1000(self) -> bool:
        """Whether the sizes fit the PC-1000 (16 inputs, 16 outputs, 32 states)."""
        return (self.n_inputs <= PC1000_MAX_INPUTS and self.n_outputs <= PC1000_MAX_OUTPUTS
                and self.n_states <= PC1000_MAX_STATES)

    def spectral_radius(self) -> float:
        """Largest ``|eig(F22)|``; < 1 for a stable internal (estimator) dynamics. 0 if ``n_x = 0``."""
        if self.n_states == 0:
            return 0.0
        return float(np.max(np.abs(np.linalg.eigvals(self.F22))))

    # -- state ----------------------------------------------------------------
    def reset(self, initial_state=None) -> None:
        """Set ``x`` to ``initial_state`` (shape (n_x,)) or the constructor's value; ``k = 0``."""
        if initial_state is None:
            self._x = self._x0.copy()
        else:
            x = np.array(initial_state, dtype=float)
            if x.shape != (self.n_states,):
                raise ModelError(f"initial_state: expected shape ({self.n_states},), found {x.shape}")
            self._x = x
        self.n_ticks = 0

    @property
    def state(self) -> np.ndarray:
        """Current internal state ``x_k``, shape (n_x,) (a copy)."""
        return self._x.copy()

    def _y(self, y) -> np.ndarray:
        arr = np.asarray(y, dtype=float)
        if arr.shape != self.F21.shape[1:]:
            raise ModelError(f"y: expected shape ({self.n_inputs},), found {arr.shape}")
        # one reduction per tick: a NaN or inf anywhere makes the sum non-finite (an overflowing sum of finite
        # values is told apart by the full check)
        if not math.isfinite(arr.sum()) and not np.all(np.isfinite(arr)):
            raise SimulationError(f"controller input y is non-finite at tick {self.n_ticks}: {arr}")
        return arr

    def output(self, y) -> np.ndarray:
        """``u_k = F11 y_k + F12 x_k`` for sensor vector ``y`` (shape (n_y,)); no state change."""
        return self.F11 @ self._y(y) + self.F12 @ self._x

    def update(self, y) -> None:
        """``x <- F21 y_k + F22 x_k``; advances the tick counter."""
        self._x = self.F21 @ self._y(y) + self.F22 @ self._x
        self.n_ticks += 1

    def step(self, y) -> np.ndarray:
        """One tick of Eq. (5.1): return ``u_k`` (shape (n_u,)) for sensors ``y`` (shape (n_y,)); update ``x``."""
        yk = self._y(y)
        self.n_ticks += 1
        if not self._x.size:  # a static gain (DRF): F12 x = 0 and no state to advance
            return self.F11 @ yk
        u = self.F11 @ yk + self.F12 @ self._x
        self._x = self.F21 @ yk + self.F22 @ self._x
        return u

    def step_trusted(self, y: np.ndarray, out: np.ndarray) -> np.ndarray:
        """:meth:`step` without its input check, writing ``u_k`` into ``out``; for a loop that checked ``y``.

        Parameters
        ----------
        y : ndarray, shape (n_y,)
            Finite sensor signals [m/s] (the caller has checked them: the
            closed loop checks every velocity it reads).
        out : ndarray, shape (n_u,)
            Receives ``u_k`` [N] (e.g. the loop's row of recorded commands).

        Returns
        -------
        ndarray
            ``out``. The same products as :meth:`step`, bit for bit; the state
            and tick counter advance as there.
        """
        self.n_ticks += 1
        if not self._x.size:
            return np.dot(self.F11, y, out=out)
        np.add(self.F11 @ y, self.F12 @ self._x, out=out)
        self._x = self.F21 @ y + self.F22 @ self._x
        return out

    def simulate(self, Y) -> np.ndarray:
        """Run the engine over a sequence of sensor samples.

        Parameters
        ----------
        Y : array_like, shape (n_steps, n_y)
            Sensor samples ``y_0 .. y_{n_steps-1}``.

        Returns
        -------
        ndarray, shape (n_steps, n_u)
            Outputs ``u_0 .. u_{n_steps-1}``; the state is left at ``x_{n_steps}``.

        Raises
        ------
        ModelError
            Wrong shape of ``Y``.
        SimulationError
            Non-finite samples.
        """
        Y = np.asarray(Y, dtype=float)
        if Y.ndim != 2 or Y.shape[1] != self.n_inputs:
            raise ModelError(f"Y: expected shape (n_steps, {self.n_inputs}), found {Y.shape}")
        if not np.all(np.isfinite(Y)):
            raise SimulationError("controller input sequence Y has non-finite samples")
        U = np.empty((Y.shape[0], self.n_outputs))
        direct = Y @ self.F11.T
        if self.n_states == 0:
            self.n_ticks += Y.shape[0]
            return direct
        x = self._x
        for k in range(Y.shape[0]):
            U[k] = direct[k] + self.F12 @ x
            x = self.F21 @ Y[k] + self.F22 @ x
        self._x = x
        self.n_ticks += Y.shape[0]
        return U

    def __repr__(self) -> str:
        return (f"ControllerEngine(n_y={self.n_inputs}, n_u={self.n_outputs}, "
                f"n_x={self.n_states}, period_s={self.period_s!r})")
