"""The linear model of the whole laboratory: structure, hardware chain and controller.

A :class:`LabState` is everything a hypothesis can change: the structure
(spec and the FE model built from it), the open-loop modal damping, point
dashpots, and the hardware chain of Fig. 21 (delay, RC filter, amplifier
gains and lags, sensor gains and lags, saturation). :func:`predict_frf`
turns a state into the FRFs an experiment measures, in the frequency domain::

    plant      G(w)   = j w Phi diag(1 / (w_r^2 - w^2 + 2 j zeta_r w_r w)) Phi^T    (+ dashpots, Woodbury;
                        a changed structure's damping coupling of the modes near the band exactly)
    actuators  A(w)   = diag(g_amp g_a,i L_a,i(w) n_i)    L_a = (1 - c) / (1 - c e^{-jwh}), c = e^{-2 pi f_a h}
    sensors    S(w)   = diag(g_s,i L_s,i(w))              L_s = (1 - a) / (1 - a e^{-jwT}), a = e^{-2 pi f_s T}
    controller K(w)   = sampled-data K of Eq. (5.1) with hold, delay and RC filter (vlab.analysis);
                        a per-channel delay d_i multiplies row i (output channel i) by e^{-j w d_i T}
    force      f      = (I + A K S G_fb)^-1 A e_exc ZOH(w) x
    measured   v      = S_out G_out f                   S_out: S(w) at a sensor (actuator) point, 1 elsewhere

``ZOH(w) = (1 - e^{-jwT}) / (jwT)`` is the hold of the excitation command
over a controller period (the recorded force is that command), ``n_i`` the
equivalent gain of a saturating amplifier (Gaussian-input describing
function, ``erf(L / (sqrt(2) sigma_i))``).

Source: Eq. (3.1) with proportional damping (Sec. 2.1.2); Fig. 21 and Sec.
5.3 for the chain; Woodbury identity for local dashpots (Golub & Van Loan,
*Matrix Computations*, 4th ed., Sec. 2.1.4); describing function of a
saturation for Gaussian input: Gelb & Vander Velde, *Multiple-Input
Describing Functions*, 1968, ch. 6.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.special

from ...analysis import sampled_data_controller_frf
from ...fe.damping import structural_damping, structural_ratios
from ...errors import ModelError
from ...fe import FEModel, Modes, build_fe_model, modal_analysis
from ...lab.chain_frf import actuator_path as chain_actuator_path, output_delay, sensor_path as chain_sensor_path
from ...lab.loop import HardwareChain, check_design_period
from ...spec import StructureSpec, input_gains


@dataclass(frozen=True)
class PointModes:
    """Modes of the structure from a model other than the FE model (the MuJoCo plant's linearisation).

    Attributes
    ----------
    omega : ndarray, shape (n,)
        Undamped natural frequencies [rad/s].
    zeta : ndarray, shape (n,)
        Modal damping ratios [1].
    shapes : ndarray, shape (n_points, n)
        Out-of-plane displacement at ``points`` of the mass-normalised modes
        (``phi^T M phi = 1``) [m/sqrt(kg)], so that the receptance is
        ``sum_r shapes[o, r] shapes[i, r] / (omega_r^2 - w^2 + 2 j zeta_r omega_r w)``.
    points : tuple of int
        Point ids of the rows of ``shapes``.
    source : str
        Where the modes come from (for reports).
    coupling : ndarray or None
        Off-diagonal modal damping ``phi_r^T C phi_s`` [1/s], shape (n, n), zero diagonal: the damping a
        changed structure keeps couples its modes (:mod:`vlab.fe.damping`); None: classical damping.
    """

    omega: np.ndarray
    zeta: np.ndarray
    shapes: np.ndarray
    points: tuple[int, ...]
    source: str = ""
    coupling: np.ndarray | None = None

    def rows(self, points) -> np.ndarray:
        """Rows of ``shapes`` at ``points``, shape (len(points), n). Raises ModelError for a point not carried."""
        idx = {p: i for i, p in enumerate(self.points)}
        missing = [p for p in points if p not in idx]
        if missing:
            raise ModelError(f"points {missing} are not among the points {list(self.points)} of the modes of "
                             f"{self.source or 'the other model'}")
        return self.shapes[[idx[p] for p in points], :]

    def at(self, points) -> "PointModes":
        """These modes with the shapes at ``points`` only (copies of the arrays). Raises ModelError as :meth:`rows`."""
        pts = tuple(points)
        return replace(self, omega=np.array(self.omega, dtype=float), zeta=np.array(self.zeta, dtype=float),
                       shapes=self.rows(pts), points=pts)


@dataclass(frozen=True)
class LabState:
    """The laboratory as one hypothesis sees it (immutable).

    Attributes
    ----------
    spec : StructureSpec
        Structure definition (possibly modified by a hypothesis).
    fe : FEModel
        FE model of ``spec`` (or a modified copy of it, e.g. pre-stress scaled).
    chain : HardwareChain
        Hardware chain (delay, filter, gains, lags, saturation).
    design : ControllerDesign or None
        The nominal controller (None: open loop).
    dashpots : tuple of (int, float)
        Point dashpots ``(point, c [N*s/m])`` on the out-of-plane DOF.
    frictions : tuple of (int, float, float)
        Coulomb friction ``(point, F [N], c_eq [N*s/m])``: the frequency-domain
        model uses the equivalent dashpot ``c_eq``, a rerun the friction force.
    step_s : float or None
        Physics step of the plant [s] (the linear plant of an experiment uses
        half a period). The loop applies the RC filter's exact average over
        each step (the continuous filter's phase) and the actuator lag's
        exact step average at this step, which the model includes; a
        comparison through the MuJoCo plant sets that plant's step.
    rms_force_n : dict
        Actuator point -> RMS command force [N] used by the saturation describing function
        (filled in by :func:`with_command_rms`).
    point_modes : PointModes or None
        Modes of the structure to use instead of the FE model's (the MuJoCo
        plant's own linearisation, :mod:`vlab.diagnose.fit.plantfit`); dropped by
        :meth:`with_spec`, since they belong to one spec.
    mjcf : str or None
        An MJCF file of the nominal MuJoCo plant (``vlab diagnose --mjcf``):
        MuJoCo reruns load it instead of building the plant from ``spec``.
        Dropped by :meth:`with_spec`: an effect that edits the spec cannot be
        carried by the file.
    """

    spec: StructureSpec
    fe: FEModel
    chain: HardwareChain
    design: object | None = None
    dashpots: tuple[tuple[int, float], ...] = ()
    frictions: tuple[tuple[int, float, float], ...] = ()
    step_s: float | None = None
    rms_force_n: dict = field(default_factory=dict)
    point_modes: PointModes | None = None
    mjcf: str | None = None

    def __post_init__(self) -> None:
        check_design_period(self.design, self.chain)  # Eq. (5.1)'s coefficients hold at one period only

    @property
    def h_s(self) -> float:
        """Physics step [s] (half the controller period unless given)."""
        return self.step_s if self.step_s else self.chain.period_s / 2.0

    @property
    def actuators(self) -> tuple[int, ...]:
        """Actuator (and collocated feedback sensor) points, channel order."""
        return tuple(self.spec.instrumentation.actuators)

    def with_spec(self, spec: StructureSpec) -> "LabState":
        """Copy with a new spec and its FE model (built here). Raises ModelError/SpecError."""
        return replace(self, spec=spec, fe=build_fe_model(spec), point_modes=None, mjcf=None)


def _modal(state: LabState) -> tuple[Modes, np.ndarray]:
    """All modes of ``state`` (:func:`vlab.fe.modal_analysis`) and their open-loop damping ratios: the spec's,
    or, for a changed structure, those the unchanged structure's damping matrix gives them
    (:func:`vlab.fe.damping.structural_ratios`)."""
    md = modal_analysis(state.fe.m, state.fe.k)
    return md, structural_ratios(state.fe, md, state.spec)


def _coupling(state: LabState, md: Modes) -> np.ndarray | None:
    """Off-diagonal modal damping of a changed structure (:attr:`PointModes.coupling`), None for a structure
    that has its own classical damping."""
    d = state.spec.damping
    if d is None or d.basis is None:
        return None
    phi = md.shapes
    cm = phi.T @ structural_damping(state.fe, state.spec) @ phi
    np.fill_diagonal(cm, 0.0)
    return cm


#: Modes whose damping coupling is taken exactly: those below this multiple of the highest frequency of an FRF.
COUPLED_BAND = 2.5


def frequencies(freq_hz) -> np.ndarray:
    """``freq_hz`` as a float array, or complex where given complex: ``f - j sigma / (2 pi)`` stands for the
    Laplace variable ``s = sigma + j 2 pi f`` (every response of this module is analytic in ``s``; a shifted
    Nyquist contour evaluates them there, :func:`vlab.diagnose.model.nyquist.loop_stability`)."""
    f = np.asarray(freq_hz)
    return f.astype(complex if np.iscomplexobj(f) else float)


def _coupled_block(omega, zeta, ph, w, coupling, idx) -> np.ndarray:
    """Receptance [m/N] of the modes ``idx`` with their damping coupling, shape (n_f, n_p, n_p): the state-space
    modes of ``q'' + C_m q' + Omega^2 q = Phi^T f`` (``C_m`` = diag(2 zeta omega) + coupling), summed exactly."""
    n = len(idx)
    om = omega[idx]
    cm = coupling[np.ix_(idx, idx)] + np.diag(2.0 * zeta[idx] * om)
    a = np.block([[np.zeros((n, n)), np.eye(n)], [-np.diag(om**2), -cm]])
    lam, v = np.linalg.eig(a)
    b = np.vstack([np.zeros((n, ph.shape[0])), ph[:, idx].T])          # (2n, n_p)
    left = ph[:, idx] @ v[:n, :]                                         # (n_p, 2n): displacement rows
    right = np.linalg.solve(v, b)                                        # (2n, n_p)
    g = 1.0 / (1j * w[:, None] - lam[None, :])                           # (n_f, 2n)
    n_p = ph.shape[0]
    lr = (left.T[:, :, None] * right[:, None, :]).reshape(2 * n, n_p * n_p)  # left[a, k] right[k, b]
    return (g @ lr).reshape(w.size, n_p, n_p)                            # one product: sum over k


def modal_receptance(omega, zeta, ph, w, coupling=None) -> np.ndarray:
    """Receptance between the points of ``ph`` (shape (n_p, n)) at ``w`` [rad/s], shape (n_f, n_p, n_p) [m/N]:
    the classical modal sum, with the modes below :data:`COUPLED_BAND` times the top of ``w`` taken with
    their damping coupling when ``coupling`` is given (the rest stay classical: far from the band the
    coupling moves nothing).

    ``omega`` [rad/s] and ``zeta`` [1] have shape (n,), ``ph`` holds the mass-normalised shapes at the points
    [m/sqrt(kg)], ``coupling`` the off-diagonal modal damping [1/s], shape (n, n), or None. Source: Eq. (3.1)
    (modal superposition); the coupled block: :func:`_coupled_block`."""
    den = omega[None, :] ** 2 - w[:, None] ** 2 + 2j * zeta[None, :] * omega[None, :] * w[:, None]
    r = 1.0 / den
    idx = np.array([], dtype=int)
    if coupling is not None and w.size:
        idx = np.flatnonzero(omega <= COUPLED_BAND * np.max(w.real))
        if idx.size < 2:
            idx = np.array([], dtype=int)
        r[:, idx] = 0.0
    n_p = ph.shape[0]
    pp = (ph[:, None, :] * ph[None, :, :]).reshape(n_p * n_p, -1).T     # (n, n_p^2): ph[a, k] ph[b, k]
    alpha = np.empty((w.size, n_p * n_p), dtype=complex)
    alpha.real, alpha.imag = r.real @ pp, r.imag @ pp                    # two real products over the modes
    alpha = alpha.reshape(w.size, n_p, n_p)
    if idx.size:
        alpha = alpha + _coupled_block(omega, zeta, ph, w, coupling, idx)
    return alpha


def natural_frequencies(state: LabState, n: int | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Open-loop natural frequencies [Hz], damping ratios and mass-normalised shapes of ``state``.

    Parameters
    ----------
    state : LabState
        The lab; its FE model (``m`` [kg], ``k`` [N/m]) and spec damping ratios.
    n : int, optional
        Number of lowest modes (all by default).

    Returns
    -------
    freq_hz : ndarray, shape (n,)
    zeta : ndarray, shape (n,)
        Open-loop damping ratios (Sec. 2.1.2, Table 1/3; of a changed structure, from the unchanged one's
        damping matrix: :func:`vlab.fe.damping.structural_ratios`).
    phi : ndarray, shape (n_dof, n)
        Shapes with ``phi^T m phi = I``.

    Raises
    ------
    ModelError
        Unstable model (clearly negative eigenvalue) or a singular mass matrix.

    Source: Eq. (3.4) via :func:`vlab.fe.modal_analysis`.
    """
    md, zeta = _modal(state)
    n = len(md.omega) if n is None else min(n, len(md.omega))
    return md.frequencies_hz[:n], zeta[:n], md.shapes[:, :n]


def point_modes_of(state: LabState, points, source: str = "the FE model") -> PointModes:
    """The modes of the structure of ``state`` at ``points``: its own point modes (the MuJoCo plant's
    linearisation) when it carries them, else its FE model's with the spec's damping.

    Parameters
    ----------
    state : LabState
    points : sequence of int
        Point ids of the rows of the shapes (out-of-plane).
    source : str
        What the FE model's modes are called in reports.

    Returns
    -------
    PointModes
        Angular frequencies [rad/s], damping ratios [1], mass-normalised shapes [m/sqrt(kg)], shape
        (len(points), n_modes); arrays of its own.

    Raises
    ------
    ModelError
        A point the state's point modes do not carry, an unknown or constrained point, an unstable model.

    Source: Eq. (3.4) via :func:`natural_frequencies`.
    """
    pts = tuple(points)
    if state.point_modes is not None:
        return state.point_modes.at(pts)
    fr, zeta, phi = natural_frequencies(state)
    return PointModes(2 * np.pi * fr, np.array(zeta, dtype=float), phi[state.fe.dofs.indices(pts, "w"), :], pts,
                      source)


def structure_modes(state: LabState) -> tuple[np.ndarray, np.ndarray]:
    """Natural frequencies [Hz] and damping ratios [1] of the structure :func:`plant_frf` uses for ``state``:
    ``state.point_modes`` when set (the MuJoCo plant's linearisation), else the FE model's with the spec's
    damping; each shape (n_modes,), in the model's order.

    Raises ModelError as :func:`natural_frequencies`. Source: Eq. (3.4) via :func:`vlab.fe.modal_analysis`."""
    if state.point_modes is not None:
        return state.point_modes.omega / (2 * math.pi), np.asarray(state.point_modes.zeta, dtype=float)
    md, zeta = _modal(state)
    return md.omega / (2 * math.pi), zeta


def plant_frf(state: LabState, freq_hz: np.ndarray, out_points, in_points) -> np.ndarray:
    """Open-loop velocity FRF of the structure (no chain), ``v_out / f_in``.

    Parameters
    ----------
    state : LabState
    freq_hz : ndarray, shape (n_f,)
    out_points, in_points : sequence of int
        Points of the velocities and of the forces (out-of-plane).

    Returns
    -------
    ndarray, complex, shape (n_f, n_out, n_in) [(m/s)/N]

    Raises
    ------
    ModelError
        Unknown or constrained point, unstable model.
    """
    w = 2 * np.pi * frequencies(freq_hz)
    dash = [(p, c) for p, c in state.dashpots if c > 0.0] + [(p, c) for p, _f, c in state.frictions if c > 0.0]
    d_pts = [p for p, _ in dash]
    all_pts = list(out_points) + list(in_points) + d_pts
    if state.point_modes is not None:
        pm = state.point_modes
        omega, zeta, ph, coupling = pm.omega, pm.zeta, pm.rows(all_pts), pm.coupling
    else:
        md, zeta = _modal(state)
        omega, ph = md.omega, md.shapes[state.fe.dofs.indices(all_pts, "w"), :]        # (n_p, n)
        coupling = _coupling(state, md)
    alpha = modal_receptance(omega, zeta, ph, w, coupling)                              # (n_f, n_p, n_p)
    no, ni = len(out_points), len(in_points)
    io = slice(0, no)
    ii = slice(no, no + ni)
    a_oi = alpha[:, io, ii]
    if dash:
        idd = slice(no + ni, no + ni + len(dash))
        c = np.array([cc for _, cc in dash])
        a_od, a_di, a_dd = alpha[:, io, idd], alpha[:, idd, ii], alpha[:, idd, idd]
        zinv = np.zeros((len(w), len(dash), len(dash)), dtype=complex)
        for j in range(len(dash)):
            zinv[:, j, j] = 1.0 / (1j * w * c[j])
        corr = np.linalg.solve(zinv + a_dd, a_di)
        a_oi = a_oi - a_od @ corr
    return 1j * w[:, None, None] * a_oi


_CORE_CACHE: dict = {}


def _controller_core(design, period_s: float, f: np.ndarray) -> np.ndarray:
    """``K(z)`` with hold, without delay and filter; cached per design object and grid."""
    key = (id(design), period_s, f.size, hash(f.tobytes()))
    hit = _CORE_CACHE.get(key)
    if hit is not None and hit[0] is design:
        return hit[1]
    k = sampled_data_controller_frf(f, design.f11, design.f12, design.f21, design.f22, period_s,
                                    delay_periods=0.0, filter_hz=None)
    if len(_CORE_CACHE) > 32:
        _CORE_CACHE.clear()
    _CORE_CACHE[key] = (design, k)
    return k


def controller_frf(state: LabState, freq_hz: np.ndarray) -> np.ndarray | None:
    """Equivalent continuous ``K(jw)`` (``u = -K y``) of the digital controller with the chain's delay and RC filter.

    Parameters
    ----------
    state : LabState
        Lab with its design and chain.
    freq_hz : ndarray, shape (n_f,)
        Frequencies [Hz].

    Returns
    -------
    ndarray, complex, shape (n_f, n_act, n_act), or None in open loop. A per-channel delay
    (``chain.channel_delay_periods``) multiplies the row of its output channel by ``e^{-j w d_i T}``
    in place of the global delay.

    Source: :func:`vlab.analysis.sampled_data_controller_frf` (Eq. 5.1, Sec. 5.3).
    """
    d = state.design
    if d is None:
        return None
    f = frequencies(freq_hz)
    core = _controller_core(d, state.chain.period_s, f)
    return core * output_delay(state.chain, state.actuators, f)[:, :, None]


def zoh(freq_hz: np.ndarray, period_s: float) -> np.ndarray:
    """Zero-order hold ``(1 - e^{-jwT}) / (jwT)`` at ``freq_hz`` [Hz] for a period ``period_s`` [s], shape (n_f,)."""
    wt = 2 * np.pi * frequencies(freq_hz) * period_s
    out = np.ones_like(wt, dtype=complex)
    nz = wt != 0
    out[nz] = (1 - np.exp(-1j * wt[nz])) / (1j * wt[nz])
    return out


def actuator_path(state: LabState, freq_hz: np.ndarray) -> np.ndarray:
    """Diagonal of ``A(w)`` of ``state`` at ``freq_hz`` [Hz]: amplifier gain x channel gain x lag
    (:func:`vlab.lab.chain_frf.actuator_path`) x saturation gain x the coil's own gain of the structure
    file (:func:`vlab.spec.input_gains`, part of the plant), shape (n_f, n_act)."""
    sat = np.array([_saturation_gain(state, p) for p in state.actuators]) * input_gains(state.spec, state.actuators)
    return chain_actuator_path(state.chain, state.actuators, frequencies(freq_hz), state.h_s) * sat[None, :]


def sensor_path(state: LabState, freq_hz: np.ndarray) -> np.ndarray:
    """Diagonal of ``S(w)`` of ``state`` at ``freq_hz`` [Hz]: sensor gain x discrete first-order lag
    (:func:`vlab.lab.chain_frf.sensor_path`), shape (n_f, n_act)."""
    return chain_sensor_path(state.chain, state.actuators, frequencies(freq_hz))


def _saturation_gain(state: LabState, point: int) -> float:
    lim = state.chain.limit_of(point)
    sigma = state.rms_force_n.get(point)
    if lim is None or not sigma:
        return 1.0
    return float(scipy.special.erf(lim / (math.sqrt(2.0) * sigma)))


def predict_frf(state: LabState, freq_hz: np.ndarray, *, excitation_point: int,
                output_points, return_forces: bool = False):
    """FRFs from the excitation command to the measured velocities, as the experiment measures them.

    Parameters
    ----------
    state : LabState
    freq_hz : ndarray, shape (n_f,)
        Frequencies [Hz] (below the Nyquist frequency of the controller).
    excitation_point : int
        Actuator point whose channel carries the excitation (Fig. 21).
    output_points : sequence of int, length n_o
        Points whose velocity is recorded.
    return_forces : bool
        Also return the actuator forces and commands per unit excitation.

    Returns
    -------
    h : ndarray, complex, shape (n_f, n_o)
        ``v_out / x`` [(m/s)/N]; at an output point that is a feedback
        sensor (an actuator point) the sensor's gain and lag are included,
        as the loop records that sensor's signal.
    (f, cmd) : ndarray, complex, shape (n_f, n_act), only with ``return_forces``
        Coil forces and amplifier commands per unit excitation.

    Raises
    ------
    ModelError
        Excitation point not an actuator; unknown or constrained output point.
    """
    acts = state.actuators
    if excitation_point not in acts:
        raise ModelError(f"excitation point {excitation_point} is not an actuator point {acts}")
    f = np.asarray(freq_hz, dtype=float)
    outs = tuple(output_points)
    g = plant_frf(state, f, outs + acts, acts)
    return closed_loop_frf(state, f, g, excitation_point=excitation_point, output_points=outs,
                           return_forces=return_forces)


def closed_loop_frf(state: LabState, freq_hz: np.ndarray, g: np.ndarray, *, excitation_point: int,
                    output_points, return_forces: bool = False):
    """:func:`predict_frf` from the plant's FRFs ``g``: the chain, the controller and the loop of ``state``
    closed around them (module notes), for one plant or a stack of them.

    Parameters
    ----------
    state : LabState
        The lab whose chain, controller and coil gains close the loop (its structure's modes are not used:
        they are in ``g``).
    freq_hz : ndarray, shape (n_f,)
        Frequencies [Hz].
    g : ndarray, complex, shape (..., n_f, n_o + n_act, n_act)
        Velocity FRFs ``v / f`` [(m/s)/N] from the coil forces to the output points followed by the actuator
        points (:func:`plant_frf` with ``output_points + state.actuators`` and ``state.actuators``).
    excitation_point : int
    output_points : sequence of int, length n_o
    return_forces : bool

    Returns
    -------
    As :func:`predict_frf`, each array with the leading dimensions of ``g``.

    Raises
    ------
    ModelError
        Excitation point not an actuator.
    """
    acts = state.actuators
    if excitation_point not in acts:
        raise ModelError(f"excitation point {excitation_point} is not an actuator point {acts}")
    f = np.asarray(freq_hz, dtype=float)
    outs = tuple(output_points)
    g_out, g_fb = g[..., : len(outs), :], g[..., len(outs):, :]
    na = len(acts)
    e = np.zeros(na, dtype=complex)
    e[acts.index(excitation_point)] = 1.0
    a = actuator_path(state, f)
    hold = zoh(f, state.chain.period_s)
    k = controller_frf(state, f)
    drive = a * e[None, :] * hold[:, None]                            # A e ZOH  (n_f, na)
    if k is None:
        force = np.array(np.broadcast_to(drive, g.shape[:-3] + drive.shape))
        cmd = np.array(np.broadcast_to(e[None, :] * hold[:, None], force.shape))
    else:
        s = sensor_path(state, f)
        loop = a[:, :, None] * k * s[:, None, :]                     # A K S  (n_f, na, na)
        mat = np.eye(na) + loop @ g_fb
        rhs = np.broadcast_to(drive[:, :, None], mat.shape[:-1] + (1,))
        force = np.linalg.solve(mat, rhs)[..., 0]
        cmd = force / a
    h = np.einsum("...foa,...fa->...fo", g_out, force)
    # a recorded channel at a feedback sensor is that sensor's signal (gain and lag), open loop too
    sens_out = [(o, acts.index(p)) for o, p in enumerate(outs) if p in acts]
    if sens_out:
        s = sensor_path(state, f)
        for o, i in sens_out:
            h[..., o] = h[..., o] * s[:, i]
    if return_forces:
        return h, (force, cmd)
    return h


def with_command_rms(state: LabState, freq_hz: np.ndarray, force_amplitude: np.ndarray, *,
                     excitation_point: int, iterations: int = 4) -> LabState:
    """State with the RMS amplifier command per channel filled in (for the saturation describing function).

    Parameters
    ----------
    state : LabState
        Lab whose chain has a force limit, ``amplifier_limit_n`` or per channel
        ``channel_limit_n`` (else returned unchanged).
    freq_hz : ndarray, shape (n_f,)
        Excited lines [Hz].
    force_amplitude : ndarray, shape (n_f,)
        Excitation amplitude per line [N] (one-sided: RMS^2 = sum |X|^2 / 2).
    excitation_point : int
        Actuator carrying the excitation.
    iterations : int
        Fixed-point iterations between RMS and equivalent gain.

    Returns
    -------
    LabState
        A copy whose ``rms_force_n`` holds the RMS of excitation plus control
        command on each channel, iterated with the equivalent gains.
    """
    if not state.chain.saturates:
        return state
    st = replace(state, rms_force_n={})
    outs = state.actuators
    for _ in range(iterations):
        _, (force, cmd) = predict_frf(st, freq_hz, excitation_point=excitation_point, output_points=outs,
                                      return_forces=True)
        rms = np.sqrt(0.5 * np.sum(np.abs(cmd * force_amplitude[:, None]) ** 2, axis=0))
        st = replace(st, rms_force_n={p: float(r) for p, r in zip(state.actuators, rms)})
    return st
