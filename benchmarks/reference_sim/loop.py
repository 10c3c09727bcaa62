"""The digital control loop of Sec. 5.3: Eq. (5.1) at 2 kHz with the PC-1000's delay.

Timing (Sec. 5.3): the sensors are sampled at t_k = k dt; the output u_k computed
from them reaches the zero-order hold after the computation delay D dt (D = 1.35)
and is held until u_{k+1} replaces it, i.e. over [(k + D) dt, (k + 1 + D) dt). With
m = floor(D) and f = D - m, period k holds u_{k-m-1} over its first f dt and
u_{k-m} over the rest. The plant between samples is integrated exactly in its
eigen-coordinates (:class:`.plant.Diagonal`). This module never imports vlab.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .plant import Diagonal


class ControllerError(ValueError):
    """A design file that does not describe an Eq. (5.1) controller."""


@dataclass(frozen=True)
class Controller:
    """Eq. (5.1): u_k = F11 y_k + F12 x_k, x_{k+1} = F21 y_k + F22 x_k.

    Attributes
    ----------
    f11 : ndarray, shape (n_act, n_sens)
        [N/(m/s)]: y are the collocated velocities [m/s], u the force commands [N].
    f12 : ndarray, shape (n_act, n_x)
    f21 : ndarray, shape (n_x, n_sens)
    f22 : ndarray, shape (n_x, n_x)
    period_s : float
        Sampling period dt [s].
    """

    f11: np.ndarray
    f12: np.ndarray
    f21: np.ndarray
    f22: np.ndarray
    period_s: float

    @classmethod
    def zero(cls, n: int, period_s: float = 0.0005) -> "Controller":
        """The open loop: every block zero, n actuator and sensor channels."""
        z = np.zeros((0, 0))
        return cls(np.zeros((n, n)), np.zeros((n, 0)), np.zeros((0, n)), z, period_s)

    @classmethod
    def from_design_json(cls, path: str | Path) -> "Controller":
        """Read a controller from ``vlab design ... --json`` output.

        Parameters
        ----------
        path : str or Path
            JSON with ``period_s`` and either ``F11``, ``F12``, ``F21``, ``F22`` or a
            direct-rate-feedback gain ``gain_n_s_per_m`` (n_act, n_act) [N s/m],
            the damping the DRF adds: the force is -gain times the velocity, so
            F11 = -gain (Eq. 4.30; the sign is checked by the closed-loop damping
            in ``tests/test_reference_sim.py``).

        Returns
        -------
        Controller

        Raises
        ------
        ControllerError
            Neither form, or blocks of inconsistent shape.
        OSError, json.JSONDecodeError
            Unreadable file.
        """
        doc = json.loads(Path(path).read_text())
        dt = float(doc.get("period_s", 0.0005))
        if all(k in doc for k in ("F11", "F12", "F21", "F22")):
            blocks = [np.atleast_2d(np.asarray(doc[k], float)) for k in ("F11", "F12", "F21", "F22")]
            f11, f12, f21, f22 = blocks
            if f12.size == 0:
                f12 = np.zeros((f11.shape[0], 0))
                f21 = np.zeros((0, f11.shape[1]))
                f22 = np.zeros((0, 0))
        elif "gain_n_s_per_m" in doc:
            gain = np.asarray(doc["gain_n_s_per_m"], float)
            n = gain.shape[0]
            f11, f12, f21, f22 = -gain, np.zeros((n, 0)), np.zeros((0, n)), np.zeros((0, 0))
        else:
            raise ControllerError(f"{path}: no F11..F22 and no gain_n_s_per_m")
        if (f12.shape[0] != f11.shape[0] or f21.shape[1] != f11.shape[1]
                or f22.shape != (f21.shape[0], f12.shape[1])):
            raise ControllerError(f"{path}: F11..F22 shapes {f11.shape}, {f12.shape}, "
                                  f"{f21.shape}, {f22.shape} do not fit together")
        return cls(f11, f12, f21, f22, dt)


def split_delay(delay_periods: float):
    """(m, f): whole periods and the fraction of the computation delay.

    Raises
    ------
    ValueError
        A negative delay.
    """
    if delay_periods < 0:
        raise ValueError(f"delay must be >= 0 periods, got {delay_periods}")
    m = int(np.floor(delay_periods + 1e-12))
    return m, max(delay_periods - m, 0.0)


def run_loop(diag: Diagonal, sensor_rows, ctrl: Controller, delay_periods: float,
             y_exc: np.ndarray, noise: np.ndarray) -> tuple:
    """Closed loop at the controller rate, exact between samples.

    Parameters
    ----------
    diag : Diagonal
        The plant; inputs 0..n_act-1 are the DAC channels.
    sensor_rows : sequence of int
        Output rows of the collocated velocities, in the controller's order, then
        any further outputs to sample at t_k (not fed back).
    ctrl : Controller
    delay_periods : float
        Computation delay D [periods] (Sec. 5.3: 1.35).
    y_exc : ndarray, shape (n_k, n_rows)
        Sensor velocities [m/s] at t_k caused by the excitation alone (from rest).
    noise : ndarray, shape (n_k, n_rows)
        Sensor noise [m/s] added to each sample.

    Returns
    -------
    u : ndarray, shape (n_k, n_act)
        Controller outputs [N].
    y : ndarray, shape (n_k, n_rows)
        The samples at t_k (with noise); the first n_sens are what the controller read.
    """
    dt = ctrl.period_s
    m, f = split_delay(delay_periods)
    n_act, n_sens = ctrl.f11.shape
    ph, _ = diag.hold_factors(dt)
    ph_late, g_late = diag.hold_factors((1 - f) * dt)
    _, g_early = diag.hold_factors(f * dt)
    bt = diag.bt[:, :n_act]
    g1 = (ph_late * g_early)[:, None] * bt
    g2 = g_late[:, None] * bt
    cs = diag.ct[list(sensor_rows)]
    n_k = y_exc.shape[0]
    u = np.zeros((n_k + m + 2, n_act))
    y = np.zeros_like(y_exc)
    eta = np.zeros(len(diag.lam), complex)
    xc = np.zeros(ctrl.f22.shape[0])
    off = m + 1
    for k in range(n_k):
        y[k] = np.real(cs @ eta) + y_exc[k] + noise[k]
        ys = y[k, :n_sens]
        u[k + off] = ctrl.f11 @ ys + ctrl.f12 @ xc
        xc = ctrl.f21 @ ys + ctrl.f22 @ xc
        eta = ph * eta + g1 @ u[k + off - m - 1] + g2 @ u[k + off - m]
    return u[off:off + n_k], y


def dac_signal(u: np.ndarray, delay_periods: float, factor: int) -> np.ndarray:
    """The held DAC output on a fine grid of ``factor`` steps per period.

    Parameters
    ----------
    u : ndarray, shape (n_k, n_act)
        Controller outputs [N].
    delay_periods : float
        Computation delay D [periods].
    factor : int
        Fine steps per controller period.

    Returns
    -------
    ndarray, shape (n_k * factor, n_act)
        The held value over each fine step; a step in which the output changes holds
        the time-weighted mean (exact when D * factor is an integer).
    """
    m, f = split_delay(delay_periods)
    n_k, n_act = u.shape
    pad = np.vstack([np.zeros((m + 1, n_act)), u])
    early = np.repeat(pad[:n_k], factor, axis=0)
    late = np.repeat(pad[1:n_k + 1], factor, axis=0)
    o = np.tile(np.arange(factor), n_k)
    w = np.clip(f * factor - o, 0.0, 1.0)[:, None]
    return w * early + (1 - w) * late
