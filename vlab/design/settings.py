"""The thesis's design settings (Sec. 6.1, 6.2) and sampling periods (Sec. 5.3); a structure file's
``[design]`` table overrides them (:func:`design_settings`).
"""

from __future__ import annotations

from dataclasses import dataclass

from ..errors import ModelError, SpecError
from ..spec import DESIGN_OPTIONS
from .weights import thesis_weights

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
    q_by_state, v1_by_state : tuple of 4 float or None
        Per kind of state (:data:`vlab.design.weights.STATE_KINDS`: translational velocity and
        displacement, rotation rate and angle), the diagonal of ``Q`` and ``V1`` in thesis units, from a
        ``units = "SI"`` ``[design]`` table (:mod:`vlab.design.weights`); None = ``q_scale I``, ``v1 I``.
    weights_units : str or None
        The unit system the structure file's ``[design]`` weights were written in (``"SI"``,
        ``"thesis"``); None = the file gives none (the defaults above).
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
    q_by_state: tuple[float, float, float, float] | None = None
    v1_by_state: tuple[float, float, float, float] | None = None
    weights_units: str | None = None


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
    ``default_model`` and the weights, in the unit system its ``units`` names:
    :data:`vlab.spec.DESIGN_WEIGHTS_THESIS` as they are, :data:`vlab.spec.DESIGN_WEIGHTS_SI`
    converted by :func:`vlab.design.weights.thesis_weights`) override, per field, the
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
    given = dict(spec.design_settings)
    units = given.pop("units", None)
    options = {k: given.pop(k) for k in DESIGN_OPTIONS if k in given}
    st = dataclasses.replace(base, **options, **thesis_weights(given, units, base))
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
