"""The controller designs: LQR, LQG, MFDRF, LQDRF and diagonal LQDRF on a design model with the
thesis's settings (:func:`design_controller`), realised in SI for the digital loop (Eq. 5.1).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from controllers.drf import lqdrf, mfdrf
from controllers.lq import lqg, lqr, reduced_on_full
from controllers.performance import feedback_performance, modes as cl_modes
from controllers.statespace import modal_initial_states, state_space

from ..errors import ModelError
from ..fe import FEModel
from ..spec import input_gains, output_gains
from ..units import CS_S, INCH_M, LBF_N
from .model import DesignModel, design_model, performance_index_si, state_labels, state_scaling, to_thesis_units
from .settings import CONTROLLERS, PERIOD_S, ThesisSettings, design_settings, thesis_period_s
from .weights import process_noise, state_weight


@dataclass(frozen=True)
class ControllerDesign:
    """A designed controller, its numbers and its SI realization.

    Attributes
    ----------
    structure, controller, model : str
    gain : ndarray
        SI. DRF: ``D`` (n_c, n_c) [N*s/m], ``u = -D y`` with ``y`` in m/s.
        LQR/LQG: the regulator gain ``F`` (n_c, 2n_d) [N per SI state],
        ``u = -F x`` with ``x = [q'; q]`` in SI: m/s (rad/s for rotational
        DOFs) for the first n_d columns, m (rad) for the last n_d, DOFs in
        the order of the design model's labels (:attr:`state_labels`). The
        thesis gain ``F_th`` (lbf per state in in/cs, rad/cs, in, rad) is
        ``F = LBF_N * F_th / s_x`` with ``s_x`` the SI value of one thesis
        state unit (0.0254 / 0.01 m/s, 1 / 0.01 rad/s, 0.0254 m, 1 rad).
    damping_ratios, frequencies_hz : ndarray, shape (n_modes,)
        Closed loop on the design model (LQG on a reduced model: the reduced
        controller closed around the full model, as Tables 8 and 12).
        Damping ratios [-], frequencies [Hz].
    performance_index_thesis_units : ndarray, shape (n_f,)
        J_i in the dissertation's units (the integral over time in cs of the
        quadratic form in the thesis states and lbf, Eqs. 4.7, 4.20, 4.33) for
        modal initial conditions of 1 in peak deflection; in SI:
        :attr:`performance_index_s`.
    gamma_lb_s_per_in, beta_thesis_units : float or None
        MFDRF objective ``gamma`` [lbf*s/in] (max row sum of ``|D|``, as Table 7
        gives it; in SI: :attr:`gamma_n_s_per_m`) and LQDRF objective ``beta``
        (the units of ``performance_index_thesis_units``; in SI: :attr:`beta_s`).
    converged : bool
        Whether the design's optimiser converged (always True for LQR/LQG).
    message : str
        The optimiser's or the design's message.
    f11, f12, f21, f22 : ndarray
        Eq. (5.1) coefficients with ``y`` in m/s and ``u`` in N, realised at
        :attr:`period_s` (Eqs. 5.2-5.5 for LQG); the controller state of LQG
        stays in thesis state units (it is internal to the engine).
    continuous : dict
        Continuous controller for analysis, ``u = -K(s) y`` (y in m/s, u in
        N): ``{"d": D}`` [N*s/m] or ``{"a", "b", "c"}`` with ``x' = a x + b y``,
        ``u = -c x``, ``K(s) = c (sI - a)^-1 b``, whose state ``x`` is the SI
        estimate of ``[q'; q]`` (``a`` [1/s], ``b`` [SI state/s per m/s],
        ``c`` = ``gain`` [N per SI state]).
    extra : dict
        Further numbers of the design, every key with its unit:
        ``"gain_thesis_lb_s_per_in"`` and ``"active_constraints"`` (indices,
        DRF), ``"gain_thesis_lbf_per_thesis_state"`` (LQR/LQG: ``F_th`` in
        lbf per thesis state unit, Sec. 3.1: in/cs or rad/cs for the
        velocities, in or rad for the displacements, columns in the order of
        :attr:`state_labels`, whose units are the SI ones of ``gain``),
        ``"kalman_poles_max_real_per_s"`` and the spillover results (LQG).
    state_labels : tuple of str
        LQR/LQG: name and SI unit of each column of ``gain``, e.g.
        ``"dw/dt@5 [m/s]"`` or ``"rx@6 [rad]"``; empty for DRF (columns =
        sensors, the actuator points in order).
    period_s : float
        Sampling period [s] at which ``f11``-``f22`` were realised (default
        :func:`thesis_period_s` of the controller: LQG 1 ms, DRF 0.5 ms).
    """

    structure: str
    controller: str
    model: str
    gain: np.ndarray
    damping_ratios: np.ndarray
    frequencies_hz: np.ndarray
    performance_index_thesis_units: np.ndarray
    gamma_lb_s_per_in: float | None
    beta_thesis_units: float | None
    converged: bool
    message: str
    f11: np.ndarray
    f12: np.ndarray
    f21: np.ndarray
    f22: np.ndarray
    continuous: dict = field(default_factory=dict)
    extra: dict = field(default_factory=dict)
    state_labels: tuple = ()
    period_s: float = PERIOD_S

    @property
    def gamma_n_s_per_m(self) -> float | None:
        """The DRF objective ``gamma`` in SI [N*s/m] (the largest row sum of ``|D|``); None for LQ designs."""
        from ..units import INCH_M, LBF_N

        return None if self.gamma_lb_s_per_in is None else float(self.gamma_lb_s_per_in) * LBF_N / INCH_M

    @property
    def performance_index_s(self) -> np.ndarray:
        """``J_i`` in SI, shape (n_f,) [s]: modal initial conditions of 1 m peak deflection, the SI weights
        (:func:`vlab.design.performance_index_si`)."""
        return performance_index_si(self.performance_index_thesis_units)

    @property
    def beta_s(self) -> float | None:
        """The LQDRF bound ``beta`` in SI [s] (as :attr:`performance_index_s`); None for other designs."""
        return None if self.beta_thesis_units is None else float(performance_index_si(self.beta_thesis_units))


def design_controller(
    fe: FEModel,
    controller: str,
    *,
    model: str | None = None,
    measured_modes=None,
    seed: int = 0,
    n_starts: int | None = None,
    period_s: float | None = None,
) -> ControllerDesign:
    """Design one of the thesis's controllers for ``fe`` with the thesis's settings.

    Parameters
    ----------
    fe : FEModel
        The nominal FE model: a shipped structure ("bcc", "grid") or any
        structure file (settings: :func:`design_settings`).
    controller : {"lqr", "lqg", "mfdrf", "lqdrf", "lqdrf-diag"}
    model : str, optional
        Design model (full, exact, guyan, corrected-guyan); default: DRF on
        the full model for the BCC (Sec. 6.1), everything else on the
        structure's default reduction.
    measured_modes : (ndarray, ndarray), optional
        For corrected-guyan: measured frequencies [Hz] and shapes at the masters.
    seed, n_starts : int
        Reproducible multi-start of the DRF optimisers; ``n_starts`` defaults
        to 32 for MFDRF (its min-max problem has many local minima, and a
        start costs milliseconds: with one start the BCC design stops at
        gamma = 0.0507 instead of 0.04964 lb*s/in, with 4 starts for about
        half of the seeds) and 4 for LQDRF.
    period_s : float, optional
        Sampling period [s] of the Eq. (5.1) realization (LQG: Eqs. 5.2-5.5
        integrate the observer over one period); default
        :func:`thesis_period_s` (LQG 1 ms, DRF 0.5 ms, Sec. 5.3). The DRF
        realization ``F11 = -D`` does not depend on it.

    Returns
    -------
    ControllerDesign

    Raises
    ------
    ModelError
        Unknown controller, or a ``period_s`` that is not a positive finite number.
    SpecError
        A structure without ``[instrumentation]``, or whose ``[design]``
        ``n_modes`` or ``n_f`` exceeds the design model's DOFs
        (:func:`design_settings`).
    ReductionError
        Unknown design model.
    controllers.errors.ControllerError
        From the design package (unstabilisable pair, infeasible damping, ...).
    """
    if controller not in CONTROLLERS:
        raise ModelError(f"unknown controller {controller!r}; use one of {CONTROLLERS}")
    p = _problem(fe, controller, model, measured_modes, period_s)
    if controller in ("mfdrf", "lqdrf", "lqdrf-diag"):
        return _drf_design(p, seed, n_starts)
    if controller == "lqr":
        return _lqr_design(p)
    return _lqg_design(fe, p)


DRF_CONTROLLERS = ("mfdrf", "lqdrf", "lqdrf-diag")
#: A rate-feedback gain of 1 lbf*s/in (the thesis's unit, Tables 7, 11, 15) in N*s/m.
LB_S_PER_IN_SI = LBF_N / INCH_M


def drf_of_gain(fe: FEModel, controller: str, gain_n_s_per_m, *, model: str | None = None,
                period_s: float | None = None, source: str = "a given gain") -> ControllerDesign:
    """The direct rate feedback of a given gain ``D`` -- the gains a laboratory ran, or an earlier design's --
    as :func:`design_controller` returns its own: the closed loop on the same design model, its performance
    indices, the realization ``F11 = -D`` (Eq. 5.1).

    Parameters
    ----------
    fe : FEModel
    controller : {"mfdrf", "lqdrf", "lqdrf-diag"}
        The law the gain belongs to (its design settings choose the design model and the performance weights).
    gain_n_s_per_m : array_like, shape (n_c, n_c)
        ``D`` [N*s/m], ``u = -D y`` with ``y`` the collocated velocities [m/s], actuators in the structure's
        order.
    model, period_s
        As :func:`design_controller`.
    source : str
        Where the gain came from (the design's message).

    Returns
    -------
    ControllerDesign
        ``converged`` True (nothing was optimised); ``gamma_lb_s_per_in`` the gain's largest row sum of
        ``|D|`` (Eq. 4.31); ``beta_thesis_units`` None.

    Raises
    ------
    ModelError
        Not a DRF controller, or a gain of another shape than (n_c, n_c), or not finite.
    """
    if controller not in DRF_CONTROLLERS:
        raise ModelError(f"a gain matrix describes a direct rate feedback ({', '.join(DRF_CONTROLLERS)}), "
                         f"not {controller!r}")
    p = _problem(fe, controller, model, None, period_s)
    n_c = p.b.shape[1]
    d_si = np.asarray(gain_n_s_per_m, dtype=float)
    if d_si.shape != (n_c, n_c) or not np.all(np.isfinite(d_si)):
        raise ModelError(f"the {controller} gain must be a finite ({n_c}, {n_c}) matrix for the structure's {n_c} "
                         f"actuators [N*s/m], got shape {d_si.shape}")
    d_thesis = d_si / LB_S_PER_IN_SI
    d_cs = d_thesis / CS_S  # lbf per (in/cs): the design's own unit system
    md = cl_modes(p.a - p.b @ d_cs @ p.cm, time_unit_s=CS_S)
    perf = feedback_performance(p.a, p.b, d_cs @ p.cm, p.q, p.r, p.x0)
    gamma = float(np.max(np.sum(np.abs(d_thesis), axis=1)))
    return ControllerDesign(
        p.name, controller, p.model, d_si, md.damping_ratios, md.frequencies_hz, np.asarray(perf), gamma, None,
        True, f"the gain of {source} (not designed)",
        -d_si, np.zeros((n_c, 0)), np.zeros((0, n_c)), np.zeros((0, 0)),
        {"d": d_si}, {"gain_thesis_lb_s_per_in": d_thesis}, (), p.period,
    )


@dataclass(frozen=True)
class _Problem:
    """A design problem in the thesis unit system: the design model, its settings, ``(A, B, C)``, the LQ
    weights ``Q``, ``R`` and the initial states of the performance index."""

    name: str
    controller: str
    model: str
    dm: DesignModel
    st: ThesisSettings
    a: np.ndarray
    b: np.ndarray
    cm: np.ndarray
    q: np.ndarray
    r: np.ndarray
    x0: np.ndarray
    n: int
    period: float


def _input_output(spec, dm: DesignModel, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Input matrix ``U`` (Eq. 3.1) and velocity output matrix ``Cv`` of the collocated pairs, shape (n, n_c)
    and (n_c, n): ones at the actuators' rows times the coils' gains (``U``) and the sensors' gains (``Cv``)
    of the structure file's ``[hardware]`` table (:mod:`vlab.spec.hardware`; ones without one)."""
    acts = spec.instrumentation.actuators
    gi, go = input_gains(spec, acts), output_gains(spec, acts)
    u = np.zeros((n, len(dm.actuator_rows)))
    cv = np.zeros((len(dm.actuator_rows), n))
    for j, r in enumerate(dm.actuator_rows):
        u[r, j], cv[j, r] = gi[j], go[j]
    return u, cv


def _problem(fe: FEModel, controller: str, model: str | None, measured_modes, period_s: float | None) -> _Problem:
    """The design problem of :func:`design_controller` (settings, period and model checked)."""
    name = fe.spec.name
    st = design_settings(fe.spec)
    period = thesis_period_s(controller) if period_s is None else period_s
    if not (isinstance(period, (int, float, np.floating)) and np.isfinite(period) and period > 0):
        raise ModelError(f"period_s must be a positive number of seconds, got {period_s!r}")
    period = float(period)
    if model is None:
        thesis_bcc = name == "bcc" and "default_model" not in fe.spec.design_settings
        model = "full" if (thesis_bcc and controller in ("mfdrf", "lqdrf", "lqdrf-diag", "lqr")) else st.default_model
    dm = design_model(fe, model, measured_modes=measured_modes)
    m, c, k = (to_thesis_units(a, dm.labels) for a in (dm.m, dm.c, dm.k))
    n = m.shape[0]
    st = design_settings(fe.spec, n, model)
    u, cv = _input_output(fe.spec, dm, n)
    ss = state_space(m, c, k, u, Cv=cv, time_unit_s=CS_S)
    q = state_weight(st, dm.labels)
    r_val = st.r_corrected if (model == "corrected-guyan" and st.r_corrected) else st.r
    r = r_val * np.eye(len(dm.actuator_rows))
    length_dofs = [i for i, (_n, d) in enumerate(dm.labels) if d == "w"]
    x0 = modal_initial_states(m, k, st.n_f, length_dofs=length_dofs)
    return _Problem(name, controller, model, dm, st, ss.A, ss.B, ss.C, q, r, x0, n, period)


def _drf_design(p: _Problem, seed: int, n_starts: int | None) -> ControllerDesign:
    """MFDRF, LQDRF or diagonal LQDRF (Sec. 4.2): the gain ``D`` [N*s/m], realised as ``F11 = -D``."""
    st, a, b, cm, q, r, x0 = p.st, p.a, p.b, p.cm, p.q, p.r, p.x0
    if p.controller == "mfdrf":
        des = mfdrf(a, b, cm, zeta_min=st.zeta_min, n_modes=st.n_modes,
                    n_starts=32 if n_starts is None else n_starts, seed=seed,
                    Q=q, R=r, initial_states=x0, time_unit_s=CS_S)
    else:
        des = lqdrf(a, b, cm, q, r, x0, zeta_min=st.zeta_min, n_modes=st.n_modes,
                    diagonal=p.controller == "lqdrf-diag", n_starts=4 if n_starts is None else n_starts, seed=seed,
                    time_unit_s=CS_S)
    d_si = des.gain_per_s * LB_S_PER_IN_SI
    gamma = float(des.gamma * CS_S)  # lb*s/in
    perf = des.performance_index if des.performance_index is not None else feedback_performance(
        a, b, des.gain @ cm, q, r, x0)
    return ControllerDesign(
        p.name, p.controller, p.model, d_si, des.damping_ratios, des.frequencies_hz, np.asarray(perf),
        gamma, des.beta, des.converged, des.message,
        -d_si, np.zeros((len(d_si), 0)), np.zeros((0, len(d_si))), np.zeros((0, 0)),
        {"d": d_si}, {"gain_thesis_lb_s_per_in": des.gain_per_s, "active_constraints": des.active_constraints},
        (), p.period,
    )


def _lqr_design(p: _Problem) -> ControllerDesign:
    """The LQR (Sec. 4.1.1): full-state gain, no realization (an experiment runs it as LQG)."""
    # SI value of one thesis state unit: [q' (in/cs or rad/cs); q (in or rad)] -> [m/s or rad/s; m or rad]
    sx = state_scaling(p.dm.labels)
    des = lqr(p.a, p.b, p.q, p.r, time_unit_s=CS_S)
    modes_cl = cl_modes(p.a - p.b @ des.gain, time_unit_s=CS_S)
    perf = np.einsum("ij,ik,kj->j", p.x0, des.riccati, p.x0)
    f_si = des.gain * LBF_N / sx
    n_act = len(p.dm.actuator_rows)
    return ControllerDesign(
        p.name, p.controller, p.model, f_si, modes_cl.damping_ratios, modes_cl.frequencies_hz, perf, None, None,
        True, "LQR needs the full state; realise it as LQG for an experiment",
        np.zeros((n_act, 0)), np.zeros((n_act, 0)), np.zeros((0, 0)),
        np.zeros((0, 0)), {}, {"gain_thesis_lbf_per_thesis_state": des.gain}, state_labels(p.dm.labels), p.period,
    )


def _lqg_design(fe: FEModel, p: _Problem) -> ControllerDesign:
    """The LQG (Eqs. 4.8-4.22) realised at ``p.period`` (Eqs. 5.2-5.5); on a reduced model, its damping and
    frequencies with the controller closed around the full model (Eqs. 4.23-4.29, Tables 8 and 12)."""
    st = p.st
    sx = state_scaling(p.dm.labels)
    des = lqg(p.a, p.b, p.cm, p.q, p.r, process_noise(st, p.dm.labels), st.v2 * np.eye(len(p.dm.actuator_rows)),
              alpha=st.alpha, time_unit_s=CS_S)
    real = des.realize(p.period)
    perf = des.performance_index(p.x0)
    f11 = np.asarray(real.F11) * LBF_N / INCH_M
    f12 = np.asarray(real.F12) * LBF_N
    f21 = np.asarray(real.F21) / INCH_M
    f22 = np.asarray(real.F22)
    at = des.controller_matrix
    f_si = des.regulator.gain * LBF_N / sx
    # the controller with its state in SI: x_SI = diag(sx) x_th; y_th [in/cs] = y [m/s] * CS_S / INCH_M
    cont = {"a": (sx[:, None] * at / sx[None, :]) / CS_S, "b": sx[:, None] * des.estimator.gain / INCH_M,
            "c": f_si}
    extra: dict = {"gain_thesis_lbf_per_thesis_state": des.regulator.gain,
                   "kalman_poles_max_real_per_s": float(np.max(des.estimator.eigenvalues.real) / CS_S)}
    damping, freqs = des.damping_ratios, des.frequencies_hz
    if p.model != "full":
        # the reduced controller closed around the full model (Eqs. 4.23-4.29), as Tables 8 and 12 report
        full = design_model(fe, "full")
        mf, cf, kf = (to_thesis_units(x, full.labels) for x in (full.m, full.c, full.k))
        uf, cvf = _input_output(fe.spec, full, mf.shape[0])
        sf = state_space(mf, cf, kf, uf, Cv=cvf, time_unit_s=CS_S)
        rof = reduced_on_full(sf.A, sf.B, sf.C, state_weight(st, full.labels), des)
        sp = rof.spillover
        damping = sp.closed_loop_damping
        freqs = np.abs(sp.closed_loop_eigenvalues) / (2 * np.pi * CS_S)  # eigenvalues in 1/cs
        extra["spillover_destabilised_modes"] = list(sp.destabilised)
        extra["spillover_lowered_modes"] = list(sp.lowered)
        extra["reduced_model_damping_ratios"] = des.damping_ratios
    return ControllerDesign(
        p.name, p.controller, p.model, f_si, damping, freqs, np.asarray(perf), None, None, True,
        "LQG (Eqs. 4.8-4.22)", f11, f12, f21, f22, cont, extra, state_labels(p.dm.labels), p.period,
    )
