"""Analytical frequency responses of the open and closed loop.

The dissertation computed closed-loop FRFs of the continuous-time loop (Sec.
6.1: "the corresponding analytical results for the full order model").
vlab adds the sampled-data prediction: the 2 kHz controller engine (Eq. 5.1)
seen through its sampler, the computation delay (1.35 periods, Sec. 5.3), the
zero-order hold and the RC smoothing filter (677 Hz). The excitation enters
as an analog signal added to one control channel before the amplifier
(Fig. 21), so it is not sampled.

Conventions: controller output ``u = -K y`` in the continuous case, i.e. the
continuous controller transfer matrix here is ``K(s)`` with the sign
convention of Eq. (4.30) (DRF: ``K = D``). For the discrete engine of Eq.
(5.1), ``u_k = F11 y_k + F12 x_k`` (so ``F11 = -D`` for DRF).
"""

from __future__ import annotations

import numpy as np

from .errors import ModelError
from .lab.blocks import PC1000_DELAY_PERIODS, RC_CORNER_HZ


def velocity_frf(
    m: np.ndarray, c: np.ndarray, k: np.ndarray, inputs: np.ndarray, outputs: np.ndarray, freq_hz: np.ndarray
) -> np.ndarray:
    """Velocity FRF of ``m q'' + c q' + k q = U f`` observed as ``v = Cv q'``.

    Parameters
    ----------
    m, c, k : ndarray, shape (n, n)
        Mass [kg], damping [N*s/m], stiffness [N/m].
    inputs : ndarray, shape (n, n_in)
        Load distribution U (force inputs).
    outputs : ndarray, shape (n_out, n)
        Velocity selection Cv.
    freq_hz : ndarray, shape (n_f,)
        Frequencies [Hz].

    Returns
    -------
    ndarray, complex, shape (n_f, n_out, n_in)
        ``H(w) = Cv (j w) (k - w^2 m + j w c)^-1 U`` [m/s/N].

    Raises
    ------
    ModelError
        On inconsistent shapes.
    """
    n = m.shape[0]
    if inputs.shape[0] != n or outputs.shape[1] != n:
        raise ModelError(f"velocity_frf: U must be ({n}, n_in) and Cv (n_out, {n}); got {inputs.shape}, {outputs.shape}")
    out = np.empty((len(freq_hz), outputs.shape[0], inputs.shape[1]), dtype=complex)
    for i, f in enumerate(np.asarray(freq_hz, dtype=float)):
        w = 2 * np.pi * f
        dyn = k - w**2 * m + 1j * w * c
        out[i] = 1j * w * outputs @ np.linalg.solve(dyn, inputs)
    return out


def continuous_controller_frf(
    freq_hz: np.ndarray, *, d: np.ndarray | None = None, a: np.ndarray | None = None,
    b: np.ndarray | None = None, c: np.ndarray | None = None,
) -> np.ndarray:
    """Transfer matrix ``K(jw)`` of a continuous controller, ``u = -K y``.

    Either a static gain ``d`` (DRF, Eq. 4.30) or an observer-based
    controller ``x' = a x + b y``, ``u = -c x`` (LQG, Eqs. 4.8-4.11: a = A - BF - KC,
    b = K, c = F).

    Parameters
    ----------
    freq_hz : array_like, shape (n_f,)
        Frequencies [Hz].
    d : ndarray, shape (n_u, n_y), optional
        Direct rate feedback gain D [N*s/m] (``y`` in m/s, ``u`` in N); used
        when given, ``a``, ``b``, ``c`` are then ignored.
    a : ndarray, shape (n_x, n_x), optional
        Controller (observer) state matrix [1/s].
    b : ndarray, shape (n_x, n_y), optional
        Controller input matrix (Kalman filter gain K), acting on ``y`` [m/s].
    c : ndarray, shape (n_u, n_x), optional
        Controller output matrix (regulator gain), force [N] per unit state.

    Returns
    -------
    ndarray, complex, shape (n_f, n_u, n_y)
        ``K(jw)`` [N/(m/s)].

    Raises
    ------
    ModelError
        If neither ``d`` nor all of ``a``, ``b`` and ``c`` are given.
    """
    freq_hz = np.asarray(freq_hz, dtype=float)
    if d is not None:
        return np.broadcast_to(np.asarray(d, dtype=complex), (len(freq_hz), *np.shape(d))).copy()
    if a is None or b is None or c is None:
        raise ModelError("continuous_controller_frf needs d, or a, b and c")
    eye = np.eye(a.shape[0])
    return np.array([c @ np.linalg.solve(2j * np.pi * f * eye - a, b) for f in freq_hz])


def sampled_data_controller_frf(
    freq_hz: np.ndarray,
    f11: np.ndarray,
    f12: np.ndarray,
    f21: np.ndarray,
    f22: np.ndarray,
    period_s: float,
    *,
    delay_periods: float = PC1000_DELAY_PERIODS,
    filter_hz: float | None = RC_CORNER_HZ,
) -> np.ndarray:
    """Equivalent ``K(jw)`` (``u = -K y``) of the digital engine with its analog chain.

    ``K(jw) = -[F11 + F12 (z I - F22)^-1 F21]_{z = e^{jwT}} * e^{-jw tau} * ZOH(jw) * RC(jw)``
    with ``ZOH(jw) = (1 - e^{-jwT}) / (jwT)`` (sampler 1/T times hold), ``tau`` the
    computation delay and ``RC(jw) = 1 / (1 + jw / w_c)``. Valid below the
    Nyquist frequency (aliasing neglected: structural content < 25 Hz, 2 kHz
    sampling).

    Parameters
    ----------
    freq_hz : array_like, shape (n_f,)
        Frequencies [Hz], below the Nyquist frequency ``1 / (2 T)``. A complex ``f - j sigma / (2 pi)``
        evaluates ``K`` at ``s = sigma + j 2 pi f`` (every factor is analytic in ``s``).
    f11, f12, f21, f22 : ndarray
        Eq. (5.1) partitions, shapes (n_u, n_y), (n_u, n_x), (n_x, n_y), (n_x, n_x).
    period_s : float
        Sampling period T [s].
    delay_periods : float
        Computation delay in sampling periods; default :data:`vlab.lab.blocks.PC1000_DELAY_PERIODS`, 1.35
        (Sec. 5.3: "The actual time delay through the PC-1000 was found to be 1.35 Delta t, where Delta t
        is the sampling period").
    filter_hz : float or None
        RC corner frequency [Hz]; default :data:`vlab.lab.blocks.RC_CORNER_HZ` (Sec. 5.3: 677 Hz); None for
        no filter.

    Returns
    -------
    ndarray, complex, shape (n_f, n_u, n_y)
        ``K(jw)`` [N/(m/s)] when ``F11``-``F22`` map ``y`` [m/s] to ``u`` [N].

    Source: Eqs. (5.1) and (5.13) (``z = e^{s T}``), Sec. 5.3 (delay 1.35 T,
    677 Hz RC filter, zero-order hold DAC).
    """
    freq_hz = np.asarray(freq_hz)
    freq_hz = freq_hz.astype(complex if np.iscomplexobj(freq_hz) else float)
    nx = f22.shape[0]
    out = np.empty((len(freq_hz), *f11.shape), dtype=complex)
    for i, f in enumerate(freq_hz):
        w = 2 * np.pi * f
        z = np.exp(1j * w * period_s)
        kz = f11.astype(complex)
        if nx:
            kz = kz + f12 @ np.linalg.solve(z * np.eye(nx) - f22, f21)
        wt = w * period_s
        zoh = 1.0 if wt == 0 else (1 - np.exp(-1j * wt)) / (1j * wt)
        chain = np.exp(-1j * w * delay_periods * period_s) * zoh
        if filter_hz is not None:
            chain = chain / (1 + 1j * f / filter_hz)
        out[i] = -kz * chain
    return out


def closed_loop_frf(g_fb: np.ndarray, g_out: np.ndarray, k: np.ndarray, excitation: int) -> np.ndarray:
    """Closed-loop FRF from an excitation force added to one actuator channel.

    With the plant ``y_fb = G_fb f`` (feedback sensors), ``y_out = G_out f`` and
    ``f = u + e_j f_exc``, ``u = -K y_fb``:
    ``y_out / f_exc = G_out (I + K G_fb)^-1 e_j``.

    Parameters
    ----------
    g_fb : ndarray, shape (n_f, n_y, n_u)
        Plant FRF to the feedback sensors.
    g_out : ndarray, shape (n_f, n_o, n_u)
        Plant FRF to the measured outputs.
    k : ndarray, shape (n_f, n_u, n_y)
        Controller ``K(jw)``.
    excitation : int
        Index of the actuator channel the excitation is added to.

    Returns
    -------
    ndarray, complex, shape (n_f, n_o)

    Source: Fig. 21 (excitation added to one control signal before the amplifier).
    """
    nu = g_fb.shape[2]
    e = np.zeros(nu)
    e[excitation] = 1.0
    out = np.empty((g_fb.shape[0], g_out.shape[1]), dtype=complex)
    for i in range(g_fb.shape[0]):
        f = np.linalg.solve(np.eye(nu) + k[i] @ g_fb[i], e)
        out[i] = g_out[i] @ f
    return out


def closed_loop_modes(
    m: np.ndarray, c: np.ndarray, k: np.ndarray, inputs: np.ndarray, outputs: np.ndarray, controller: dict | None
) -> tuple[np.ndarray, np.ndarray]:
    """Closed-loop frequencies and damping ratios of the plant's modes (continuous loop).

    Plant ``m q'' + c q' + k q = U u``, sensors ``y = Cv q'``, controller
    ``u = -K(s) y`` given as ``{"d": D}`` or ``{"a", "b", "c"}`` (see
    :func:`continuous_controller_frf`); None = open loop. Each open-loop mode
    is paired with its closed-loop eigenvalue by eigenvector overlap
    (:func:`controllers.performance.spillover`).

    Parameters
    ----------
    m, c, k : ndarray, shape (n, n)
        Mass [kg], damping [N*s/m] and stiffness [N/m] of the plant.
    inputs : ndarray, shape (n, n_u)
        Load distribution U (force inputs at the actuators).
    outputs : ndarray, shape (n_y, n)
        Velocity selection Cv (collocated sensors).
    controller : dict or None
        ``{"d": D}`` with D (n_u, n_y) [N*s/m], or ``{"a", "b", "c"}`` as in
        :func:`continuous_controller_frf`; None for the open loop.

    Returns
    -------
    freq_hz, zeta : ndarray, shape (n,)
        Undamped natural frequency |lambda|/2pi [Hz] and damping ratio of each
        plant mode, in open-loop frequency order.

    Source: Eqs. (4.16), (4.24), (4.35).
    """
    from controllers.performance import spillover

    n = m.shape[0]
    minv = np.linalg.inv(m)
    a = np.block([[-minv @ c, -minv @ k], [np.eye(n), np.zeros((n, n))]])
    b = np.vstack([minv @ inputs, np.zeros_like(inputs)])
    cv = np.hstack([outputs, np.zeros_like(outputs)])
    if controller is None:
        acl = a
    elif "d" in controller:
        acl = a - b @ controller["d"] @ cv
    else:
        ac, bc, cc = controller["a"], controller["b"], controller["c"]
        acl = np.block([[a, -b @ cc], [bc @ cv, ac]])
    rep = spillover(a, acl)
    lam = rep.closed_loop_eigenvalues
    return np.abs(lam) / (2 * np.pi), rep.closed_loop_damping
