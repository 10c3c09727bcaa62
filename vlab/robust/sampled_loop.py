"""The linearised sampled-data closed loop of Fig. 21: exact discrete model, poles, damping, FRF, energy index.

The structure (FE model, modal damping of the spec, Sec. 2.1.2) is written in
its mass-normalised modes, state ``x = [eta'; eta]``. Between the DAC and the
coils sits the 677 Hz RC filter (state ``r``, ``r' = w_c (v - r)``); the coil
force is ``g_a * r`` (actuator gains), the sensors read ``g_s * U^T q'``
(sensor gains). Over one period ``T`` the DAC holds ``u[k-m-1]`` for ``f T``
and ``u[k-m]`` for ``(1 - f) T`` (delay ``D = m + f`` periods, Sec. 5.3), and
the excitation force ``e_k`` is held over the period (added before the
amplifier, Fig. 21). With ``s = [x; r]``, ``s' = A s + B_v v + B_e e`` and
``E(t) = exp(A t)``, ``G(t) = int_0^t exp(A t') dt'``, the exact step is::

    s[k+1] = E(T) s[k] + E((1-f) T) G(f T) B_v u[k-m-1] + G((1-f) T) B_v u[k-m] + G(T) B_e e[k]
    u[k]   = F11 y[k] + F12 xc[k],   xc[k+1] = F21 y[k] + F22 xc[k],   y[k] = C s[k]       (Eq. 5.1)

with the past commands ``u[k-1] .. u[k-m-1]`` as states. The closed loop is
one matrix ``A_cl``; its eigenvalues ``z`` give stability (``|z| < 1``) and
``s = ln(z) / T`` the damping ``-Re s / |s|`` and frequency ``|s| / 2 pi`` of
each mode (Eq. 5.13's ``z = e^{sT}``). The FRF from excitation to a sampled
response is ``C_o (z I - A_cl)^-1 B_e`` at ``z = e^{j w T}`` -- what the H1
estimate of the lab measures (Sec. 5.4) -- and an energy index is
``J = T sum_k E_k`` (structural energy ``E = (|eta'|^2 + w^2 |eta|^2) / 2``)
summed over unit modal-velocity initial conditions of the compared modes, by
the discrete Lyapunov equation ``P = A_cl^T P A_cl + T Q``.

Which closed-loop eigenvalue is "mode r": the one nearest (in the s-plane) to
mode r of the continuous closed loop (:func:`vlab.analysis.closed_loop_modes`,
which pairs by eigenvector overlap, Eq. 4.35's spillover analysis).

Source: Eqs. (3.2)-(3.3) (state space), (5.1), (5.13), Sec. 5.3 (delay 1.35
periods, 677 Hz RC filter, zero-order hold); the step of a piecewise-constant
input is the standard exact discretisation (e.g. Franklin, Powell & Workman,
*Digital Control of Dynamic Systems*, 3rd ed., 1998, Sec. 4.3.4, fractional delay).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np
import scipy.linalg

from ..analysis import closed_loop_modes
from ..errors import ModelError


@dataclass(frozen=True)
class Plant:
    """A structure in modal coordinates with its channels (SI).

    Attributes
    ----------
    omega : ndarray, shape (n,)
        Natural frequencies [rad/s].
    zeta : ndarray, shape (n,)
        Open-loop modal damping ratios [-].
    b : ndarray, shape (n, n_act)
        ``Phi^T U``: modal force of a unit force at each actuator [1/sqrt(kg)].
    c_out : ndarray, shape (n,)
        ``u_p^T Phi``: response point's displacement per modal coordinate [1/sqrt(kg)].
    m, c, k : ndarray, shape (n_dof, n_dof)
        Physical matrices [kg, N*s/m, N/m] (for the continuous pairing).
    u : ndarray, shape (n_dof, n_act)
        Force input matrix of the actuators.
    """

    omega: np.ndarray
    zeta: np.ndarray
    b: np.ndarray
    c_out: np.ndarray
    m: np.ndarray
    c: np.ndarray
    k: np.ndarray
    u: np.ndarray


def modal_plant(m: np.ndarray, k: np.ndarray, zeta: np.ndarray, u: np.ndarray, u_out: np.ndarray) -> Plant:
    """Mass-normalised modes of ``(m, k)`` with modal damping ``zeta`` (Sec. 2.1.2).

    Parameters
    ----------
    m, k : ndarray, shape (n, n)
        Mass [kg] and stiffness [N/m] matrices.
    zeta : ndarray, shape (n,)
        Modal damping ratios [-] in frequency order.
    u : ndarray, shape (n, n_act)
        Actuator force input matrix.
    u_out : ndarray, shape (n,)
        Response point's displacement selector.

    Returns
    -------
    Plant

    Raises
    ------
    ModelError
        A matrix pair that is not positive definite.
    """
    try:
        w2, phi = scipy.linalg.eigh(k, m)
    except np.linalg.LinAlgError as exc:
        raise ModelError(f"modal_plant: (m, k) is not a positive-definite pair: {exc}") from None
    if np.any(w2 <= 0):
        raise ModelError(f"modal_plant: non-positive eigenvalue {w2.min():.3g} (a mechanism)")
    omega = np.sqrt(w2)
    c = m @ phi @ np.diag(2 * zeta * omega) @ phi.T @ m
    return Plant(omega, np.asarray(zeta, float), phi.T @ u, phi.T @ u_out, m, c, k, u)


def _expm_int(a: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray]:
    """``exp(A t)`` and ``int_0^t exp(A s) ds`` from one block exponential (Van Loan)."""
    n = a.shape[0]
    big = np.zeros((2 * n, 2 * n))
    big[:n, :n] = a * t
    big[:n, n:] = np.eye(n) * t
    e = scipy.linalg.expm(big)
    return e[:n, :n], e[:n, n:]


@dataclass(frozen=True)
class SampledLoop:
    """The closed loop ``X[k+1] = A_cl X[k] + B_e e[k]``, response ``C_o X[k]`` (velocity [m/s]).

    Attributes
    ----------
    a_cl : ndarray, shape (n_cl, n_cl)
    b_e : ndarray, shape (n_cl,)
    c_o : ndarray, shape (n_cl,)
        Response-point velocity row.
    poles : ndarray, complex, shape (n_cl,)
        Eigenvalues z of ``a_cl``.
    period_s : float
        T [s].
    n_modes_plant : int
        Structural modes n (the first 2n states are ``[eta'; eta]``).
    omega : ndarray, shape (n,)
        Open-loop natural frequencies [rad/s].
    """

    a_cl: np.ndarray
    b_e: np.ndarray
    c_o: np.ndarray
    poles: np.ndarray
    period_s: float
    n_modes_plant: int
    omega: np.ndarray

    @property
    def spectral_radius(self) -> float:
        """``max |z|``: the loop is asymptotically stable iff < 1."""
        return float(np.max(np.abs(self.poles)))

    def frf(self, freq_hz: np.ndarray) -> np.ndarray:
        """Sampled velocity FRF ``C_o (z I - A_cl)^-1 B_e`` at ``z = exp(j 2 pi f T)``, shape (n_f,) [(m/s)/N].

        Parameters
        ----------
        freq_hz : array_like, shape (n_f,)
            Frequencies [Hz].

        Raises
        ------
        ModelError
            A frequency at or above the Nyquist frequency ``1 / (2 T)``.
        """
        f = np.asarray(freq_hz, dtype=float)
        if np.any(f >= 0.5 / self.period_s):
            raise ModelError(f"frf: frequencies must be below the Nyquist frequency {0.5 / self.period_s:g} Hz")
        lam, left, right = self._modal
        z = np.exp(2j * np.pi * f * self.period_s)
        return (left * right) @ (1.0 / (z[None, :] - lam[:, None]))

    @cached_property
    def _modal(self):
        lam, v = np.linalg.eig(self.a_cl)
        return lam, self.c_o @ v, np.linalg.solve(v, self.b_e)

    def energy_index(self, n_modes: int) -> float:
        """``J`` [J*s]: summed structural energy over time, unit modal velocity of each of the first ``n_modes``.

        ``inf`` for an unstable loop. Source: discrete Lyapunov equation
        (``scipy.linalg.solve_discrete_lyapunov``); the state weighting is the
        structure's energy (a performance index in the sense of Eq. 4.7, with
        no control weighting).
        """
        if self.spectral_radius >= 1.0:
            return math.inf
        n = self.n_modes_plant
        q = np.zeros(self.a_cl.shape[0])
        q[:n] = 0.5
        q[n:2 * n] = 0.5 * self.omega ** 2
        p = scipy.linalg.solve_discrete_lyapunov(self.a_cl.T, self.period_s * np.diag(q))
        return float(np.trace(p[:n_modes, :n_modes]))


def sampled_loop(plant: Plant, design, *, period_s: float, delay_periods: float, filter_hz: float | None,
                 actuator_gain: np.ndarray, sensor_gain: np.ndarray, excitation: int) -> SampledLoop:
    """The exact discrete closed loop of ``plant`` with the Eq. (5.1) engine of ``design`` (module notes).

    Parameters
    ----------
    plant : Plant
    design : object with ``f11`` (n_act, n_act), ``f12``, ``f21``, ``f22`` or None
        The controller realised at ``period_s`` (:class:`vlab.design.ControllerDesign`); None: open loop.
    period_s : float
        T [s].
    delay_periods : float
        D >= 0 [periods].
    filter_hz : float or None
        RC corner [Hz] (None: no filter).
    actuator_gain, sensor_gain : ndarray, shape (n_act,)
        Channel gains [-].
    excitation : int
        Actuator channel of the excitation.

    Returns
    -------
    SampledLoop

    Raises
    ------
    ModelError
        A negative delay, non-positive period or corner, gains of the wrong shape.
    """
    if not (period_s > 0 and math.isfinite(period_s)):
        raise ModelError(f"period_s must be positive, got {period_s!r}")
    if not (delay_periods >= 0 and math.isfinite(delay_periods)):
        raise ModelError(f"delay_periods must be finite and >= 0, got {delay_periods!r}")
    n, n_act = plant.b.shape
    ga = np.asarray(actuator_gain, dtype=float)
    gs = np.asarray(sensor_gain, dtype=float)
    if ga.shape != (n_act,) or gs.shape != (n_act,):
        raise ModelError(f"actuator_gain and sensor_gain must have shape ({n_act},); got {ga.shape}, {gs.shape}")
    om, ze = plant.omega, plant.zeta
    bf = plant.b * ga                                        # (n, n_act): modal force per coil command
    a_p = np.block([[np.diag(-2 * ze * om), np.diag(-om ** 2)], [np.eye(n), np.zeros((n, n))]])
    b_p = np.vstack([bf, np.zeros((n, n_act))])
    if filter_hz is not None:
        if not filter_hz > 0:
            raise ModelError(f"filter_hz must be > 0, got {filter_hz!r}")
        wc = 2 * math.pi * filter_hz
        a = np.block([[a_p, b_p], [np.zeros((n_act, 2 * n)), -wc * np.eye(n_act)]])
        b_v = np.vstack([np.zeros((2 * n, n_act)), wc * np.eye(n_act)])
    else:
        a, b_v = a_p, b_p
    n_s = a.shape[0]
    b_e = np.zeros(n_s)
    b_e[:2 * n] = b_p[:, excitation]
    mi = int(math.floor(delay_periods + 1e-9))
    frac = max(0.0, delay_periods - mi)
    e_t, g_t = _expm_int(a, period_s)
    e_b, g_b = _expm_int(a, (1 - frac) * period_s)
    _, g_a = _expm_int(a, frac * period_s)
    gam_old = e_b @ g_a @ b_v
    gam_new = g_b @ b_v
    c_y = np.zeros((n_act, n_s))
    c_y[:, :n] = gs[:, None] * (plant.b.T)                 # y = g_s U^T Phi eta'
    if design is None:
        f11 = np.zeros((n_act, n_act))
        f12, f21, f22 = np.zeros((n_act, 0)), np.zeros((0, n_act)), np.zeros((0, 0))
    else:
        f11, f12, f21, f22 = design.f11, design.f12, design.f21, design.f22
    n_x = f22.shape[0]
    n_b = (mi + 1) * n_act                                   # buffer u[k-1] .. u[k-m-1]
    n_cl = n_s + n_x + n_b
    i_x, i_b = n_s, n_s + n_x
    k_u = np.zeros((n_act, n_cl))                            # u[k] = k_u X[k]
    k_u[:, :n_s] = f11 @ c_y
    k_u[:, i_x:i_b] = f12
    a_cl = np.zeros((n_cl, n_cl))
    a_cl[:n_s, :n_s] = e_t
    old = np.zeros((n_act, n_cl))
    old[:, i_b + mi * n_act: i_b + (mi + 1) * n_act] = np.eye(n_act)
    if mi == 0:
        new = k_u
    else:
        new = np.zeros((n_act, n_cl))
        new[:, i_b + (mi - 1) * n_act: i_b + mi * n_act] = np.eye(n_act)
    a_cl[:n_s] += gam_old @ old + gam_new @ new
    a_cl[i_x:i_b, :n_s] = f21 @ c_y
    a_cl[i_x:i_b, i_x:i_b] = f22
    a_cl[i_b:i_b + n_act] = k_u
    if mi > 0:
        a_cl[i_b + n_act:, i_b:i_b + mi * n_act] = np.eye(mi * n_act)
    b_cl = np.zeros(n_cl)
    b_cl[:n_s] = g_t @ b_e
    c_o = np.zeros(n_cl)
    c_o[:n] = plant.c_out
    return SampledLoop(a_cl, b_cl, c_o, np.linalg.eigvals(a_cl), float(period_s), n, om)


def mode_damping(loop: SampledLoop, plant: Plant, design, n_modes: int, *, actuator_gain, sensor_gain
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Damping ratio [-] and frequency [Hz] of the first ``n_modes`` structural modes of the sampled loop.

    Each mode is the sampled-loop eigenvalue nearest in the s-plane to that
    mode of the continuous closed loop (:func:`vlab.analysis.closed_loop_modes`
    on the same plant and gains); real eigenvalues count (an over-damped mode,
    damping ratio 1).

    Parameters
    ----------
    loop : SampledLoop
    plant : Plant
    design : ControllerDesign or None
        Its ``continuous`` controller is used for the pairing (None: open loop).
    n_modes : int
    actuator_gain, sensor_gain : array_like, shape (n_act,)
        As given to :func:`sampled_loop`.

    Returns
    -------
    zeta, freq_hz : ndarray, shape (n_modes,)
    """
    u = plant.u * np.asarray(actuator_gain)
    y = (plant.u * np.asarray(sensor_gain)).T
    ctrl = None if design is None else design.continuous
    f_c, z_c = closed_loop_modes(plant.m, plant.c, plant.k, u, y, ctrl)
    w_c = 2 * np.pi * f_c[:n_modes]
    s_c = w_c * (-z_c[:n_modes] + 1j * np.sqrt(np.clip(1 - z_c[:n_modes] ** 2, 0.0, None)))
    # the upper half-plane and the real axis: an over-damped mode (continuous damping ratio 1) is a real pole
    z = loop.poles[(np.abs(loop.poles) > 1e-12) & (loop.poles.imag >= 0)]
    s = np.log(z.astype(complex)) / loop.period_s
    zeta = np.empty(n_modes)
    freq = np.empty(n_modes)
    for r in range(n_modes):
        j = int(np.argmin(np.abs(s - s_c[r])))
        zeta[r] = -s[j].real / abs(s[j])
        freq[r] = abs(s[j]) / (2 * np.pi)
    return zeta, freq


def peak_windows(centre_hz, half_width: float = 0.1) -> tuple[np.ndarray, np.ndarray]:
    """Search band of each mode's peak: ``centre (1 +- half_width)``, cut halfway to a closer neighbour.

    Parameters
    ----------
    centre_hz : array_like, shape (n_modes,)
        Frequencies of the modes [Hz] (any order).
    half_width : float
        Relative half-width [-].

    Returns
    -------
    low_hz, high_hz : ndarray, shape (n_modes,)
    """
    c = np.asarray(centre_hz, dtype=float)
    lo, hi = c * (1 - half_width), c * (1 + half_width)
    for r in range(c.size):
        others = np.delete(c, r)
        below, above = others[others < c[r]], others[others >= c[r]]
        if below.size:
            lo[r] = max(lo[r], 0.5 * (c[r] + below.max()))
        if above.size:
            hi[r] = min(hi[r], 0.5 * (c[r] + above.min()))
    return lo, hi


def peak_levels(loop: SampledLoop, centre_hz: np.ndarray, *, half_width: float = 0.1, n_points: int = 400,
                displacement: bool = True) -> np.ndarray:
    """Peak |H| near each mode, in :func:`peak_windows`, shape (n_modes,) [m/N or (m/s)/N].

    ``centre_hz`` (n_modes,) [Hz] and ``half_width`` [-] give the windows
    (:func:`peak_windows`), searched on ``n_points`` frequencies each.

    ``displacement`` divides the velocity FRF by ``j w`` (the BCC's compared
    quantity, Fig. 22). NaN for an unstable loop. Source: peak levels as
    compared in Table 10 (Sec. 6.1).
    """
    if loop.spectral_radius >= 1.0:
        return np.full(len(centre_hz), np.nan)
    lo, hi = peak_windows(centre_hz, half_width)
    out = np.empty(len(centre_hz))
    for r in range(len(centre_hz)):
        f = np.linspace(lo[r], hi[r], n_points)
        h = loop.frf(f)
        if displacement:
            h = h / (2j * np.pi * f)
        out[r] = np.max(np.abs(h))
    return out
