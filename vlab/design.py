"""The dissertation's controller designs on vlab's models.

Glue between the lab's models (SI) and the stand-alone design package
:mod:`controllers`: the design model (full FE, exact or Guyan reduction,
corrected Guyan) is converted to the thesis's unit system (inch, lbf,
centisecond; Sec. 3.1) where its weights Q and R mean what they meant in
1990, the design is made there, and the gains and the Eq. (5.1)
realization are converted back to SI for the digital loop (2 kHz; LQG 1 kHz, Sec. 5.3).

Thesis settings (Sec. 6.1, 6.2):

- BCC: zeta_L = 0.03 on n_m = 6 modes; LQR Q = I, R = 0.22 I; Kalman filter
  V1 = 1e-6 I, V2 = 5e-4 I, alpha = 0.2; LQDRF initial conditions in the
  shape of the first 6 modes.
- Grid: zeta_L = 0.03 on n_m = 5 modes; Q = 0.01 I, R = 0.84 I (exact
  reduction) or 1.387 I (corrected Guyan); V1 = 1e-10 I, V2 = 0.5 I,
  alpha = 0.05; n_f = 5.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from controllers.drf import lqdrf, mfdrf
from controllers.lq import lqg, lqr, reduced_on_full
from controllers.performance import feedback_performance, modes as cl_modes
from controllers.statespace import modal_initial_states, state_space

from .fe.damping import modal_damping_matrix, open_loop_ratios
from .errors import ModelError, ReductionError, SpecError
from .fe import FEModel
from .models import master_indices, reduce_model
from .units import CS_S, INCH_M, LBF_N

CONTROLLERS = ("lqr", "lqg", "mfdrf", "lqdrf", "lqdrf-diag")
DESIGN_MODELS = ("full", "exact", "guyan", "corrected-guyan")
#: Sampling period of the DRF controllers in the laboratory [s] (Sec. 5.3: 2000 samples/s).
PERIOD_S = 0.5e-3
#: Sampling period [s] at which the laboratory ran each controller (Sec. 5.3): the DRF laws "at the maximum
#: sampling rate of 2000 samples per second", LQG discretised "at Delta t = 0.001 seconds" (Eqs. 5.11-5.12,
#: 1000 samples per second). ``"none"`` (open loop) and LQR (never run: it needs the full state) take 0.5 ms.
THESIS_PERIOD_S = {"none": PERIOD_S, "lqr": PERIOD_S, "lqg": 1e-3, "mfdrf": PERIOD_S, "lqdrf": PERIOD_S,
                   "lqdrf-diag": PERIOD_S}


def thesis_period_s(controller: str) -> float:
    """The sampling period [s] the dissertation's laboratory used for ``controller`` (Sec. 5.3).

    MFDRF and LQDRF ran at 2000 samples per second (0.5 ms); LQG was
    discretised and run at ``Delta t = 0.001`` s (1000 samples per second,
    the text after Eq. 5.12). The PC-1000's computation delay is 1.35
    sampling periods in both cases (Sec. 5.3: "1.35 Delta t, where Delta t is
    the sampling period"), so it scales with the period.

    Parameters
    ----------
    controller : str
        ``"none"`` (open loop) or one of :data:`CONTROLLERS`.

    Returns
    -------
    float
        The period [s]: 1e-3 for ``"lqg"``, 5e-4 otherwise.

    Raises
    ------
    ModelError
        Unknown controller name.
    """
    if controller not in THESIS_PERIOD_S:
        raise ModelError(f"unknown controller {controller!r}; use 'none' or one of {CONTROLLERS}")
    return THESIS_PERIOD_S[controller]


@dataclass(frozen=True)
class ThesisSettings:
    """Design settings of one structure (thesis units: in, lbf, cs).

    Values of Sec. 6.1 (BCC) and Sec. 6.2 (grid); the weights are meaningful
    only in the thesis unit system (states in in and in/cs, forces in lbf).

    Attributes
    ----------
    zeta_min : float
        Minimum closed-loop damping ratio zeta_L [-] required of the first
        ``n_modes`` modes (0.03; the constraint of Eqs. 4.32 and 4.38).
    n_modes : int
        Number n_m of modes the damping constraint applies to.
    n_f : int
        Number of modal initial conditions (first open-loop mode shapes, 1 in
        maximum deflection, Sec. 4.1) for the performance indices J_i (Eq. 4.37).
    q_scale : float
        State weight ``Q = q_scale I`` (BCC: 1; grid: 0.01).
    r : float
        Control weight ``R = r I`` (BCC: 0.22; grid: 0.84).
    v1 : float
        State excitation noise intensity ``V1 = v1 I`` of the Kalman filter (Eq. 4.9).
    v2 : float
        Measurement noise intensity ``V2 = v2 I`` of the Kalman filter (Eq. 4.9).
    alpha : float
        Alpha shift of the Kalman filter poles [1/cs] (Eq. 4.9; BCC 0.2, grid 0.05).
    default_model : str
        Design model used when none is asked for (``"exact"``).
    r_corrected : float or None
        Control weight for designs on the corrected Guyan model (grid: 1.387,
        Table 15); None = use ``r``.
    """

    zeta_min: float
    n_modes: int
    n_f: int
    q_scale: float
    r: float
    v1: float
    v2: float
    alpha: float
    default_model: str
    r_corrected: float | None = None


THESIS_SETTINGS = {
    "bcc": ThesisSettings(0.03, 6, 6, 1.0, 0.22, 1e-6, 5e-4, 0.2, "exact"),
    "grid": ThesisSettings(0.03, 5, 5, 0.01, 0.84, 1e-10, 0.5, 0.05, "exact", r_corrected=1.387),
}

#: Settings of a structure whose file has no ``[design]`` value for them: the BCC's (Sec. 6.1: zeta_L = 0.03
#: on 6 modes, Q = I, R = 0.22 I, V1 = 1e-6 I, V2 = 5e-4 I, alpha = 0.2 1/cs), meaningful for a metre-sized
#: laboratory beam in the thesis units (in, lbf, cs); the design model is the full FE model unless the file has
#: ``[reduction]`` masters (then the exact reduction).
DEFAULT_SETTINGS = THESIS_SETTINGS["bcc"]


def design_settings(spec, n_dof: int | None = None, model: str | None = None) -> ThesisSettings:
    """Controller-design settings of a structure: its ``[design]`` table over the defaults.

    A structure file's ``[design]`` values (``zeta_min``, ``n_modes``, ``n_f``,
    ``q_scale``, ``r``, ``v1``, ``v2``, ``alpha``, ``default_model``,
    ``r_corrected``; :data:`vlab.spec.DESIGN_FIELDS`) override, per field, the
    thesis's settings of a shipped structure of that name (Secs. 6.1, 6.2:
    :data:`THESIS_SETTINGS`), else :data:`DEFAULT_SETTINGS` with the full FE
    model as design model where the file gives no ``[reduction]`` masters.
    A file without a ``[design]`` table takes every default.

    Given the design model's size ``n_dof``, a mode count the file does not
    set (``n_modes``, ``n_f``; 6 by default) is capped at ``n_dof`` (a model
    with three DOFs has three modes to damp and three modal initial
    conditions), and one the file sets beyond ``n_dof`` is refused.

    Parameters
    ----------
    spec : StructureSpec
        The structure (``spec.design_settings``, ``spec.name``, ``spec.master_dofs``).
    n_dof : int, optional
        Number of DOFs of the design model (None: no cap, no check).
    model : str, optional
        The design model's name, for the error message.

    Returns
    -------
    ThesisSettings
        Weights in the thesis unit system (in, lbf, cs).

    Raises
    ------
    SpecError
        The structure has no ``[instrumentation]`` (no actuators to design for),
        or its ``[design]`` ``n_modes`` or ``n_f`` exceeds ``n_dof`` (names the
        file, the field, the value and the design model).
    """
    import dataclasses

    if spec.instrumentation is None:
        raise SpecError(f"{spec._file()}: no [instrumentation] table: a controller needs actuators and sensors")
    base = THESIS_SETTINGS.get(spec.name)
    if base is None:
        base = dataclasses.replace(DEFAULT_SETTINGS, default_model="exact" if spec.master_dofs.get("exact") else "full")
    st = dataclasses.replace(base, **spec.design_settings)
    if n_dof is None:
        return st
    counts = {}
    for name in ("n_modes", "n_f"):
        value = getattr(st, name)
        if value <= n_dof:
            continue
        if name in spec.design_settings:
            raise SpecError(f"{spec._file()}: field 'design.{name}': {value} is more than the {n_dof} DOFs of the "
                            f"design model ({model or 'default'}); give at most {n_dof}, or a larger design model "
                            f"(more [reduction] masters, or default_model = \"full\")")
        counts[name] = n_dof
    return dataclasses.replace(st, **counts)


@dataclass(frozen=True)
class DesignModel:
    """A second-order model in SI with its DOF labels (the design basis).

    ``m q'' + c q' + k q = U u`` (Eq. 3.1) on n_d DOFs: the full FE model or a
    reduced one.

    Attributes
    ----------
    name : str
        ``"full"``, ``"exact"``, ``"guyan"`` or ``"corrected-guyan"``.
    m : ndarray, shape (n_d, n_d)
        Mass matrix [kg] (rotational DOFs [kg*m^2]).
    c : ndarray, shape (n_d, n_d)
        Damping matrix [N*s/m] (open-loop modal damping of the spec).
    k : ndarray, shape (n_d, n_d)
        Stiffness matrix [N/m] (rotational DOFs [N*m/rad]).
    labels : tuple of (node, dof), length n_d
        Label of every DOF, e.g. ``(5, "w")``.
    actuator_rows : tuple of int, length n_c
        Index of each actuator's ``w`` DOF in the model, in actuator order
        (the non-zero rows of U).
    """

    name: str
    m: np.ndarray
    c: np.ndarray
    k: np.ndarray
    labels: tuple
    actuator_rows: tuple[int, ...]


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
    performance_index : ndarray, shape (n_f,)
        J_i (thesis units: the integral over time in cs of the quadratic form
        in the thesis states and lbf, Eqs. 4.7, 4.20, 4.33) for modal initial
        conditions.
    gamma, beta : float or None
        MFDRF objective ``gamma`` [lbf*s/in] (max row sum of ``|D|``, Table 7)
        and LQDRF objective ``beta`` (thesis units, like ``performance_index``).
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
    performance_index: np.ndarray
    gamma: float | None
    beta: float | None
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


def _unit_scaling(labels) -> np.ndarray:
    """diag S with q_SI = S q_thesis: inch for translations, 1 for rotations."""
    return np.array([INCH_M if dof == "w" else 1.0 for _node, dof in labels])


def _state_scaling(labels) -> np.ndarray:
    """SI value of one thesis state unit, shape (2 n_d,): ``x_SI = s_x * x_thesis`` for ``x = [q'; q]``.

    Velocities: 1 in/cs = 0.0254 / 0.01 m/s, 1 rad/cs = 100 rad/s; positions:
    1 in = 0.0254 m, 1 rad = 1 rad (Sec. 3.1 units).
    """
    s = _unit_scaling(labels)
    return np.concatenate([s / CS_S, s])


def state_labels(labels) -> tuple[str, ...]:
    """Names and SI units of the states ``x = [q'; q]`` of a design model (Eqs. 3.2-3.3).

    Parameters
    ----------
    labels : sequence of (node, dof), length n_d
        DOF labels of the design model; ``"w"`` is a translation [m], any
        other dof a rotation [rad].

    Returns
    -------
    tuple of str, length 2 n_d
        ``"d<dof>/dt@<node> [m/s]"`` (or ``[rad/s]``) for the velocities, then
        ``"<dof>@<node> [m]"`` (or ``[rad]``) for the displacements.
    """
    vel = tuple(f"d{d}/dt@{nd} [{'m/s' if d == 'w' else 'rad/s'}]" for nd, d in labels)
    pos = tuple(f"{d}@{nd} [{'m' if d == 'w' else 'rad'}]" for nd, d in labels)
    return vel + pos


def to_thesis_units(a: np.ndarray, labels) -> np.ndarray:
    """Convert a SI mass/damping/stiffness matrix to in-lbf units: ``S a S / (lbf * in)``.

    ``S = diag(s_i)`` with ``s_i`` = 1 in in metres for translations (``w``)
    and 1 for rotations, so that ``q_SI = S q_thesis`` (Sec. 3.1 units; the
    time unit stays the second here, :func:`controllers.statespace.state_space`
    applies the centisecond).

    Parameters
    ----------
    a : ndarray, shape (n_d, n_d)
        Mass [kg], damping [N*s/m] or stiffness [N/m] matrix (rotational DOFs
        in rad).
    labels : sequence of (node, dof), length n_d
        DOF labels; a dof of ``"w"`` is a translation, anything else a rotation.

    Returns
    -------
    ndarray, shape (n_d, n_d)
        The matrix in lbf*s^2/in, lbf*s/in or lbf/in (rotations in rad).
    """
    s = _unit_scaling(labels)
    return a * np.outer(s, s) / (LBF_N * INCH_M)


def design_model(fe: FEModel, model: str, *, measured_modes=None) -> DesignModel:
    """The SI design model of ``fe``: full, exact, guyan or corrected-guyan.

    Damping: the spec's open-loop modal damping ratios (Tables 1, 3), applied
    as proportional damping on the full model and projected (Guyan) or by
    Eq. 3.6 (exact). ``corrected-guyan`` needs ``measured_modes`` =
    (frequencies_hz (n_m,), shapes (n_R, n_m) at the Guyan masters).

    Parameters
    ----------
    fe : FEModel
        The full FE model; its spec gives the actuators, damping and masters.
    model : str
        ``"full"``, ``"exact"``, ``"guyan"`` or ``"corrected-guyan"`` (Sec. 3).
    measured_modes : (ndarray, ndarray), optional
        Measured frequencies [Hz], shape (n_m,), and mode shapes at the Guyan
        masters, shape (n_R, n_m), for the Baruch correction (Eqs. 3.17-3.20).

    Returns
    -------
    DesignModel

    Raises
    ------
    ReductionError
        Unknown model, or corrected-guyan without measured modes, or masters
        that do not include every actuator.
    """
    spec = fe.spec
    acts = spec.instrumentation.actuators
    ratios = open_loop_ratios(spec, fe.n)
    if model == "full":
        c = modal_damping_matrix(fe.m, fe.k, ratios)
        rows = tuple(fe.dofs.index(p, "w") for p in acts)
        return DesignModel("full", fe.m, c, fe.k, fe.dofs.labels, rows)
    if model not in DESIGN_MODELS:
        raise ReductionError(f"unknown design model {model!r}; use one of {DESIGN_MODELS}")
    base = "exact" if model == "exact" else "guyan"
    idx = master_indices(fe, base)
    labels = tuple(fe.dofs.labels[i] for i in idx)
    if model == "exact":
        red = reduce_model(fe, "exact", zeta=ratios[: len(idx)])
        c = np.asarray(red.c)
    else:
        red = reduce_model(fe, "guyan")
        t = np.asarray(red.T)
        c = t.T @ modal_damping_matrix(fe.m, fe.k, ratios) @ t
    m, k = np.asarray(red.m), np.asarray(red.k)
    if model == "corrected-guyan":
        if measured_modes is None:
            raise ReductionError("corrected-guyan needs measured modes (frequencies and shapes at the Guyan masters)")
        from .correction import baruch_correction

        freq, shapes = measured_modes
        cor = baruch_correction(m, k, shapes, freq, zeta=ratios[: len(freq)])
        m, k = np.asarray(cor.m), np.asarray(cor.k)
        c = np.asarray(cor.c) if cor.c is not None else c
    try:
        rows = tuple(labels.index((p, "w")) for p in acts)
    except ValueError:
        raise ReductionError(f"{spec.name}: the {model} masters {labels} do not include every actuator {acts}") from None
    return DesignModel(model, m, c, k, labels, rows)


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
    u = np.zeros((n, len(dm.actuator_rows)))
    for j, r in enumerate(dm.actuator_rows):
        u[r, j] = 1.0
    ss = state_space(m, c, k, u, time_unit_s=CS_S)
    a, b, cm = ss.A, ss.B, ss.C
    q = st.q_scale * np.eye(2 * n)
    r_val = st.r_corrected if (model == "corrected-guyan" and st.r_corrected) else st.r
    r = r_val * np.eye(len(dm.actuator_rows))
    length_dofs = [i for i, (_n, d) in enumerate(dm.labels) if d == "w"]
    x0 = modal_initial_states(m, k, st.n_f, length_dofs=length_dofs)
    extra: dict = {}
    gamma = beta = None
    if controller in ("mfdrf", "lqdrf", "lqdrf-diag"):
        if controller == "mfdrf":
            des = mfdrf(a, b, cm, zeta_min=st.zeta_min, n_modes=st.n_modes,
                        n_starts=32 if n_starts is None else n_starts, seed=seed,
                        Q=q, R=r, initial_states=x0, time_unit_s=CS_S)
        else:
            des = lqdrf(a, b, cm, q, r, x0, zeta_min=st.zeta_min, n_modes=st.n_modes,
                        diagonal=controller == "lqdrf-diag", n_starts=4 if n_starts is None else n_starts, seed=seed,
                        time_unit_s=CS_S)
        d_si = des.gain_per_s * LBF_N / INCH_M
        gamma = float(des.gamma * CS_S)  # lb*s/in
        beta = des.beta
        perf = des.performance_index if des.performance_index is not None else feedback_performance(
            a, b, des.gain @ cm, q, r, x0)
        return ControllerDesign(
            name, controller, model, d_si, des.damping_ratios, des.frequencies_hz, np.asarray(perf),
            gamma, beta, des.converged, des.message,
            -d_si, np.zeros((len(d_si), 0)), np.zeros((0, len(d_si))), np.zeros((0, 0)),
            {"d": d_si}, {"gain_thesis_lb_s_per_in": des.gain_per_s, "active_constraints": des.active_constraints},
            (), period,
        )
    # SI value of one thesis state unit: [q' (in/cs or rad/cs); q (in or rad)] -> [m/s or rad/s; m or rad]
    sx = _state_scaling(dm.labels)
    labels = state_labels(dm.labels)
    if controller == "lqr":
        des = lqr(a, b, q, r, time_unit_s=CS_S)
        modes_cl = cl_modes(a - b @ des.gain, time_unit_s=CS_S)
        perf = np.einsum("ij,ik,kj->j", x0, des.riccati, x0)
        f_si = des.gain * LBF_N / sx
        return ControllerDesign(
            name, controller, model, f_si, modes_cl.damping_ratios, modes_cl.frequencies_hz, perf, None, None,
            True, "LQR needs the full state; realise it as LQG for an experiment",
            np.zeros((len(dm.actuator_rows), 0)), np.zeros((len(dm.actuator_rows), 0)), np.zeros((0, 0)),
            np.zeros((0, 0)), {}, {"gain_thesis_lbf_per_thesis_state": des.gain}, labels, period,
        )
    # LQG on the design model
    des = lqg(a, b, cm, q, r, st.v1 * np.eye(2 * n), st.v2 * np.eye(len(dm.actuator_rows)), alpha=st.alpha,
              time_unit_s=CS_S)
    real = des.realize(period)
    perf = des.performance_index(x0)
    f11 = np.asarray(real.F11) * LBF_N / INCH_M
    f12 = np.asarray(real.F12) * LBF_N
    f21 = np.asarray(real.F21) / INCH_M
    f22 = np.asarray(real.F22)
    at = des.controller_matrix
    f_si = des.regulator.gain * LBF_N / sx
    # the controller with its state in SI: x_SI = diag(sx) x_th; y_th [in/cs] = y [m/s] * CS_S / INCH_M
    cont = {"a": (sx[:, None] * at / sx[None, :]) / CS_S, "b": sx[:, None] * des.estimator.gain / INCH_M,
            "c": f_si}
    extra["gain_thesis_lbf_per_thesis_state"] = des.regulator.gain
    extra["kalman_poles_max_real_per_s"] = float(np.max(des.estimator.eigenvalues.real) / CS_S)
    damping, freqs = des.damping_ratios, des.frequencies_hz
    if model != "full":
        # the reduced controller closed around the full model (Eqs. 4.23-4.29), as Tables 8 and 12 report
        full = design_model(fe, "full")
        mf, cf, kf = (to_thesis_units(x, full.labels) for x in (full.m, full.c, full.k))
        uf = np.zeros((mf.shape[0], len(full.actuator_rows)))
        for j, rr in enumerate(full.actuator_rows):
            uf[rr, j] = 1.0
        sf = state_space(mf, cf, kf, uf, time_unit_s=CS_S)
        rof = reduced_on_full(sf.A, sf.B, sf.C, np.eye(sf.A.shape[0]) * st.q_scale, des)
        sp = rof.spillover
        damping = sp.closed_loop_damping
        freqs = np.abs(sp.closed_loop_eigenvalues) / (2 * np.pi * CS_S)  # eigenvalues in 1/cs
        extra["spillover_destabilised_modes"] = list(sp.destabilised)
        extra["spillover_lowered_modes"] = list(sp.lowered)
        extra["reduced_model_damping_ratios"] = des.damping_ratios
    return ControllerDesign(
        name, controller, model, f_si, damping, freqs,
        np.asarray(perf), None, None, True, "LQG (Eqs. 4.8-4.22)", f11, f12, f21, f22, cont, extra, labels, period,
    )
