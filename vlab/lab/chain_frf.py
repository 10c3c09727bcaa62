"""The hardware chain of Fig. 21 in the frequency domain, channel by channel.

The loop (:mod:`vlab.lab.loop`) applies per-channel gains, delays and first-order lags in time; these are
the same blocks as frequency responses, for a prediction that includes them (the experiment's analysis,
:mod:`vlab.experiment.runner`, and the diagnosis's lab model, :mod:`vlab.diagnose.model.labmodel`)::

    actuators  A_i(w) = g_amp g_a,i L_a,i(w)     L_a = ((1 - g) + (g - c) e^{-jwh}) / (1 - c e^{-jwh}),
                                                 c = e^{-2 pi f_a h},  g = (1 - c) / (2 pi f_a h)
    sensors    S_i(w) = g_s,i L_s,i(w)           L_s = (1 - a) / (1 - a e^{-jwT}),  a = e^{-2 pi f_s T}
    output     D_i(w) = e^{-j w d_i T} / (1 + j f / f_RC)    (delay d_i [periods] and RC filter of channel i)

``h`` is the physics step, ``T`` the controller period. The coil's lag is a continuous first-order lag,
whose output the plant holds over each physics step at its exact step average (``L_a``: the average
of the lag's response to an input held over the step, :func:`vlab.lab.batch_chain.lag_step`); the
sensor lag runs once per period as the recursion ``L_s``. Frequencies may be complex,
``f - j sigma / (2 pi)`` standing for the Laplace variable ``s = sigma + j 2 pi f``.

Source: Fig. 21 and Sec. 5.3 (the chain); the lags are the operations the loop runs
(:class:`vlab.lab.batch_chain.ChainRun`): the sensor's recursion ``y[n] = a y[n-1] + (1 - a) x[n]``, the
coil's end-of-step value ``y[n] = c y[n-1] + (1 - c) x[n]`` and step average ``x[n] + g (y[n-1] - x[n])``.
"""

from __future__ import annotations

import math

import numpy as np

from .batch_chain import lag_mean_weight
from .loop import HardwareChain


def _f(freq_hz) -> np.ndarray:
    f = np.asarray(freq_hz)
    return f.astype(complex if np.iscomplexobj(f) else float)


def _lags(corners_hz, freq_hz, step_s: float, mean: bool) -> np.ndarray:
    """``((1 - g) + (g - c) z^-1) / (1 - c z^-1)`` per channel, ``z = e^{jw step}``, ``c = e^{-2 pi f_c step}``;
    ``g = c`` (the recursion, :func:`discrete_lags`) or, with ``mean``, the step average's weight
    (:func:`step_mean_lags`). Shapes and units as those."""
    f = _f(freq_hz)
    out = np.ones((len(f), len(corners_hz)), dtype=complex)
    for i, fc in enumerate(corners_hz):
        if fc:
            c = math.exp(-2 * math.pi * fc * step_s)
            g = float(lag_mean_weight(fc, step_s)) if mean else c
            zi = np.exp(-2j * np.pi * f * step_s)
            out[:, i] = ((1 - g) + (g - c) * zi) / (1 - c * zi)
    return out


def discrete_lags(corners_hz, freq_hz, step_s: float) -> np.ndarray:
    """Discrete first-order lags ``(1 - c) / (1 - c e^{-jw step})``, ``c = e^{-2 pi f_c step}``, per channel:
    the recursion ``y[n] = c y[n-1] + (1 - c) x[n]`` (the sensor lag, once per controller period).

    Parameters
    ----------
    corners_hz : sequence of float or None, length n_ch
        Corner frequency [Hz] of each channel's lag (None or 0: no lag, 1).
    freq_hz : ndarray, shape (n_f,)
        Frequencies [Hz] (real, or complex for a shifted contour).
    step_s : float
        Step of the recursion [s].

    Returns
    -------
    ndarray, complex, shape (n_f, n_ch)
    """
    return _lags(corners_hz, freq_hz, step_s, mean=False)


def step_mean_lags(corners_hz, freq_hz, step_s: float) -> np.ndarray:
    """Continuous first-order lags of corners ``corners_hz`` held over steps of ``step_s`` at their exact step
    average, per channel: ``((1 - g) + (g - c) z^-1) / (1 - c z^-1)``, ``z = e^{jw step}``,
    ``c = e^{-2 pi f_c step}``, ``g = (1 - c) / (2 pi f_c step)`` (the coil lag of
    :func:`vlab.lab.batch_chain.lag_step`; to second order in ``step``, the continuous ``1 / (1 + jw / w_c)``).

    Parameters
    ----------
    corners_hz, freq_hz, step_s
        As :func:`discrete_lags`.

    Returns
    -------
    ndarray, complex, shape (n_f, n_ch)
    """
    return _lags(corners_hz, freq_hz, step_s, mean=True)


def actuator_path(chain: HardwareChain, actuators, freq_hz, step_s: float) -> np.ndarray:
    """``A_i(w)`` of every actuator channel: amplifier gain x channel gain x actuator lag.

    Parameters
    ----------
    chain : HardwareChain
    actuators : sequence of int, length n_act
        Actuator point ids, channel order.
    freq_hz : ndarray, shape (n_f,)
        Frequencies [Hz].
    step_s : float
        Physics step h [s] of the plant (the step over which the coil lag's output is averaged).

    Returns
    -------
    ndarray, complex, shape (n_f, n_act) [1]
    """
    f = _f(freq_hz)
    g = np.array([chain.amplifier_gain * chain.actuator_gain.get(p, 1.0) for p in actuators], dtype=complex)
    return g[None, :] * step_mean_lags([chain.actuator_lag_of(p) for p in actuators], f, step_s)


def sensor_path(chain: HardwareChain, sensors, freq_hz) -> np.ndarray:
    """``S_i(w)`` of every feedback sensor: sensor gain x sensor lag (one recursion per controller period).

    Parameters
    ----------
    chain : HardwareChain
    sensors : sequence of int, length n_s
        Feedback sensor point ids (the actuator points of the collocated pairs).
    freq_hz : ndarray, shape (n_f,)
        Frequencies [Hz].

    Returns
    -------
    ndarray, complex, shape (n_f, n_s) [1]
    """
    f = _f(freq_hz)
    g = np.array([chain.sensor_gain.get(p, 1.0) for p in sensors], dtype=complex)
    return g[None, :] * discrete_lags([chain.sensor_lag_of(p) for p in sensors], f, chain.period_s)


def output_delay(chain: HardwareChain, actuators, freq_hz) -> np.ndarray:
    """``D_i(w)``: each output channel's delay from sample to DAC output and the RC filter.

    Multiplying row i of the sampled-data controller without delay and filter (Eq. 5.1 with the hold)
    gives the controller the loop runs.

    Parameters
    ----------
    chain : HardwareChain
        Its ``delay_of`` each channel [periods], ``period_s`` and ``filter_hz`` (None: no filter).
    actuators, freq_hz
        As :func:`actuator_path`.

    Returns
    -------
    ndarray, complex, shape (n_f, n_act) [1]
    """
    f = _f(freq_hz)
    d = np.array([chain.delay_of(p) for p in actuators], dtype=float)
    out = np.exp(-2j * np.pi * f[:, None] * d[None, :] * chain.period_s)
    if chain.filter_hz:
        # the loop applies the filter's exact average over each physics step (no lead)
        out = out / (1 + 1j * f / chain.filter_hz)[:, None]
    return out


def chain_closed_loop_frf(g_fb: np.ndarray, g_out: np.ndarray, k_core: np.ndarray, chain: HardwareChain,
                          actuators, excitation: int, freq_hz, step_s: float) -> np.ndarray:
    """Closed-loop FRF from the excitation command to the outputs through the whole chain.

    ``f = (I + A D K S G_fb)^-1 A e``, ``v = G_out f`` (``e`` the excitation channel; the hold of the
    excitation command is not included, as in :func:`vlab.analysis.closed_loop_frf`).

    Parameters
    ----------
    g_fb : ndarray, complex, shape (n_f, n_act, n_act)
        Plant from coil forces to the feedback sensors' velocities [(m/s)/N].
    g_out : ndarray, complex, shape (n_f, n_o, n_act)
        Plant from coil forces to the outputs.
    k_core : ndarray, complex, shape (n_f, n_act, n_act) or None
        Sampled-data controller (``u = -K y``) with its hold, without delay and filter; None: open loop.
    chain : HardwareChain
    actuators : sequence of int, length n_act
        Channel order.
    excitation : int
        Index (in ``actuators``) of the excited channel.
    freq_hz : ndarray, shape (n_f,)
        Frequencies [Hz].
    step_s : float
        Physics step [s] (the step over which the actuator lag is averaged).

    Returns
    -------
    ndarray, complex, shape (n_f, n_o): the outputs per unit excitation command.
    """
    a = actuator_path(chain, actuators, freq_hz, step_s)
    rhs = np.zeros_like(a)
    rhs[:, excitation] = a[:, excitation]
    if k_core is None:
        force = rhs
    else:
        s = sensor_path(chain, actuators, freq_hz)
        loop = (a * output_delay(chain, actuators, freq_hz))[:, :, None] * k_core * s[:, None, :]
        mat = np.eye(len(actuators))[None] + loop @ g_fb
        force = np.linalg.solve(mat, rhs[:, :, None])[:, :, 0]
    return np.einsum("foa,fa->fo", g_out, force)
