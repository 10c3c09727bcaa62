"""The structure, the RC filters and the amplifiers as one continuous LTI system.

State: modal coordinates of the (possibly changed) structure and their rates, and
one RC-filter state per actuator channel (Sec. 5.3: single-stage passive RC, 677
Hz). Inputs: the DAC outputs of the actuator channels [N, the controller's force
command] and the excitation force [N] at the excitation coil. The system is
diagonalised once (complex eigenvectors) and simulated exactly for inputs held
constant over each fine step (zero-order hold; Franklin, Powell & Workman,
*Digital Control of Dynamic Systems*, 3rd ed., Sec. 4.3.3), one first-order
recursion per eigenvalue. This module never imports vlab.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.signal

from .fe import FEModel, modes


def modal_damping_matrix(model: FEModel, ratios, default_ratio: float,
                         overrides: dict | None = None) -> np.ndarray:
    """Viscous damping matrix with given modal damping ratios.

    Parameters
    ----------
    model : FEModel
        The nominal structure whose modes carry the damping.
    ratios : sequence of float
        Damping ratios of modes 1..len(ratios) [1] (Table 1).
    default_ratio : float
        Ratio of the higher modes [1].
    overrides : dict[int, float], optional
        Mode number (1-based) -> ratio: a concealed damping change.

    Returns
    -------
    c : ndarray, shape (n_dof, n_dof)
        c = m Phi diag(2 zeta omega) Phi^T m (Phi mass-normalised; Craig & Kurdila,
        *Fundamentals of Structural Dynamics*, 2006, Sec. 10.4).
    """
    freq, phi = modes(model)
    zeta = np.full(len(freq), float(default_ratio))
    zeta[: len(ratios)] = ratios
    for mode, z in (overrides or {}).items():
        zeta[int(mode) - 1] = z
    mp = model.m @ phi
    return mp @ np.diag(2 * zeta * 2 * np.pi * freq) @ mp.T


@dataclass(frozen=True)
class Plant:
    """Continuous plant x' = A x + B u, y = C x + D u (SI).

    Attributes
    ----------
    a : ndarray, shape (n_x, n_x)
    b : ndarray, shape (n_x, n_act + 1)
        Inputs: the DAC outputs of the actuator channels [N], then the excitation
        force [N].
    c : ndarray, shape (n_y, n_x)
    d : ndarray, shape (n_y, n_act + 1)
    outputs : tuple
        Output labels ``(point, "vel")`` [m/s] or ``(point, "acc")`` [m/s^2].
    """

    a: np.ndarray
    b: np.ndarray
    c: np.ndarray
    d: np.ndarray
    outputs: tuple


def build_plant(model: FEModel, c_damp: np.ndarray, actuators, excitation: int,
                outputs, rc_corner_hz: float = 677.0, amp_gains=None) -> Plant:
    """Assemble the continuous plant.

    Parameters
    ----------
    model : FEModel
        The structure as it is (with concealed effects).
    c_damp : ndarray, shape (n_dof, n_dof)
        Damping matrix [N s/m ...].
    actuators : sequence of int
        Actuator points (coils, force along w).
    excitation : int
        Point of the excitation force.
    outputs : sequence of tuple
        ``(point, "vel")`` or ``(point, "acc")``.
    rc_corner_hz : float
        RC-filter corner [Hz] (Sec. 5.3: 677 Hz); ``inf`` = no filter.
    amp_gains : sequence of float, optional
        Amplifier gain of each actuator channel [N/N] (default 1). The excitation enters at the
        amplifier input (Sec. 5.3): where its point is an actuator's, that channel's gain scales it too.

    Returns
    -------
    Plant

    Raises
    ------
    ValueError
        An unknown output quantity or a non-positive corner frequency.
    """
    n_act = len(actuators)
    gains = np.ones(n_act) if amp_gains is None else np.asarray(amp_gains, float)
    freq, phi = modes(model)
    n = len(freq)
    om2 = (2 * np.pi * freq) ** 2
    cm = phi.T @ c_damp @ phi
    bq = np.zeros((n, n_act + 1))
    for j, q in enumerate(list(actuators) + [excitation]):
        bq[:, j] = phi[model.index(q, "w")]
    if not rc_corner_hz > 0:
        raise ValueError(f"RC corner must be > 0 Hz, got {rc_corner_hz!r}")
    wc = 2 * np.pi * rc_corner_hz
    a = np.zeros((2 * n + n_act, 2 * n + n_act))
    a[:n, n:2 * n] = np.eye(n)
    a[n:2 * n, :n] = -np.diag(om2)
    a[n:2 * n, 2 * n:] = bq[:, :n_act] * gains
    a[n:2 * n, n:2 * n] = -cm
    b = np.zeros((2 * n + n_act, n_act + 1))
    acts = list(actuators)
    b[n:2 * n, n_act] = bq[:, n_act] * (gains[acts.index(excitation)] if excitation in acts else 1.0)
    if np.isfinite(wc):
        a[2 * n:, 2 * n:] = -wc * np.eye(n_act)
        b[2 * n:, :n_act] = wc * np.eye(n_act)
    else:
        a[n:2 * n, 2 * n:] = 0.0
        b[n:2 * n, :n_act] = bq[:, :n_act] * gains
    c = np.zeros((len(outputs), 2 * n + n_act))
    d = np.zeros((len(outputs), n_act + 1))
    for i, (q, kind) in enumerate(outputs):
        row = phi[model.index(q, "w")]
        if kind == "vel":
            c[i, n:2 * n] = row
        elif kind == "acc":
            c[i] = row @ a[n:2 * n]
            d[i] = row @ b[n:2 * n]
        else:
            raise ValueError(f"output quantity must be 'vel' or 'acc', got {kind!r}")
    return Plant(a=a, b=b, c=c, d=d, outputs=tuple(outputs))


class Diagonal:
    """The plant in eigen-coordinates: eta' = lam eta + bt u, y = Re(ct eta) + d u.

    Only one eigenvalue of each complex-conjugate pair is kept; its output counts
    twice (real inputs and outputs).

    Parameters
    ----------
    plant : Plant

    Raises
    ------
    ValueError
        A defective or badly conditioned eigenvector matrix (cond > 1e10).
    """

    def __init__(self, plant: Plant):
        lam, v = scipy.linalg.eig(plant.a)
        if np.linalg.cond(v) > 1e10:
            raise ValueError("plant matrix is close to defective (eigenvector condition > 1e10)")
        vinv = np.linalg.inv(v)
        keep = lam.imag >= 0
        self.lam = lam[keep]
        self.bt = (vinv @ plant.b)[keep]
        weight = np.where(self.lam.imag > 0, 2.0, 1.0)
        self.ct = (plant.c @ v)[:, keep] * weight
        self.d = plant.d

    def hold_factors(self, dt: float):
        """exp(lam dt) and (exp(lam dt) - 1)/lam: the ZOH transition and input factor.

        Parameters
        ----------
        dt : float
            Interval [s].

        Returns
        -------
        phi, gam : ndarray, shape (n_eig,)
        """
        phi = np.exp(self.lam * dt)
        return phi, (phi - 1.0) / self.lam

    def periodic_start(self, u_period: np.ndarray, h: float) -> np.ndarray:
        """Eigen-state at the start of the periodic steady state of a periodic input.

        Parameters
        ----------
        u_period : ndarray, shape (n_p, n_in)
            One period of held inputs.
        h : float
            Fine step [s].

        Returns
        -------
        eta0 : ndarray, shape (n_eig,)
            eta0 = eta_P / (1 - exp(lam P h)), eta_P the state after one period from
            rest (the fixed point of one period's map).
        """
        ph, gm = self.hold_factors(h)
        w = u_period @ self.bt.T
        eta = np.zeros(len(self.lam), complex)
        for i in range(len(self.lam)):
            _, zf = scipy.signal.lfilter([0.0, gm[i]], [1.0, -ph[i]], w[:, i], zi=[0.0])
            eta[i] = zf[0]
        return eta / (1.0 - ph ** u_period.shape[0])

    def simulate(self, u: np.ndarray, h: float, decimate: int = 1, sos=None,
                 outputs=None, eta0=None) -> np.ndarray:
        """Outputs for inputs held over each fine step, from rest.

        Parameters
        ----------
        u : ndarray, shape (n_t, n_in)
            Input samples; u[j] is held over [j h, (j+1) h).
        h : float
            Fine step [s].
        decimate : int
            Keep every ``decimate``-th output sample (t = 0, decimate h, ...).
        sos : ndarray, optional
            Second-order sections of a digital filter applied to the outputs at the
            fine rate before decimation (an anti-alias filter).
        outputs : sequence of int, optional
            Output rows to compute (default all).
        eta0 : ndarray, shape (n_eig,), optional
            Initial eigen-state (default: rest).

        Returns
        -------
        y : ndarray, shape (ceil(n_t / decimate), n_out)
            y(t_j) = C x(t_j) + D u[j], at t_j = j h before the input u[j] acts on x.
        """
        eta0 = np.zeros(len(self.lam), complex) if eta0 is None else eta0
        rows = np.arange(self.ct.shape[0]) if outputs is None else np.asarray(outputs)
        ph, gm = self.hold_factors(h)
        w = u @ self.bt.T
        y = np.zeros((len(range(0, u.shape[0], decimate)), len(rows)))
        for i in range(len(self.lam)):
            eta, _ = scipy.signal.lfilter([0.0, gm[i]], [1.0, -ph[i]], w[:, i], zi=[eta0[i]])
            if sos is not None:
                eta = scipy.signal.sosfilt(sos, eta)
            y += np.real(np.outer(eta[::decimate], self.ct[rows, i]))
        uf = u if sos is None else scipy.signal.sosfilt(sos, u, axis=0)
        y += uf[::decimate] @ self.d[rows].T
        return y
