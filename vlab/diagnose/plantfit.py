"""Refit a mode-moving parameter on the validation plant's own linearisation before the MuJoCo rerun.

The hypotheses are fitted on the FE model (:mod:`vlab.diagnose.fit`), which
is fast. The MuJoCo plant built from the same spec is another
discretisation: its natural frequencies differ from the FE model's by up to
about 1-2 % in some modes (``vlab crosscheck grid``). A baseline recording
removes that offset where the modes are (:func:`vlab.diagnose.data.refer_to_model`),
but a mode that an effect moves far (a softened joint moves two top-beam
modes of the grid by 20 %) leaves its offset behind, and the FE fit absorbs
the offset into the parameter: on the grid's joint 18 the FE fit found
5.65 kN m/rad for a plant drawn at 6.06 kN m/rad, right to 7 %, but the
MuJoCo rerun with that value put a resonance 1 % off and lowered the misfit
only 2x.

So, before a MuJoCo rerun, the one parameter of a spec-level, mode-moving
effect (:attr:`vlab.diagnose.hypothesis.Hypothesis.moves_modes`; in a pair,
the one such part, the other held) is fitted again to the same data with
the structure's FRFs taken from the *plant's* linearisation
(:func:`plant_modes`: MuJoCo's modes at the settled state, mass-normalised,
with the plant's own modal damping) and the rest of the lab (hardware
chain, controller) as before; data referred through a baseline are referred
to the plant's linearisation instead of the FE model. The fit is a
chi-square scan of :data:`SCAN_POINTS` values within ``+-SCAN_HALF_WIDTH``
(in ``ln p``) of the FE value, then a bounded Brent search between the best
scan point's neighbours. The FE value is one of the scan points, so the
refit never ends worse on the plant's linearisation than the FE value.

The FE-fitted parameters stay the diagnosis's answer (``selected``); the
refitted value is reported with the validation (``validated.parameters``)
as the value the rerun used.

Source: the two-model idea is that of model updating with a reference model
(Friswell & Mottershead, *Finite Element Model Updating in Structural
Dynamics*, 1995, ch. 1): a parameter is only meaningful for the model it was
fitted on, so it is refitted on the model that is rerun.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace

import numpy as np
import scipy.optimize

from ..errors import ModelError, SimulationError, SpecError
from ..spec import StructureSpec
from .data import FrfData
from .hypothesis import Combination, Hypothesis
from .labmodel import LabState, PointModes
from .problem import Problem

#: Half-width of the scan in ``ln p`` around the FE-fitted value (+-12 %: the FE/MuJoCo
#: frequency offsets moved the grid's joint stiffness by 7 %). A chosen range, not fitted.
SCAN_HALF_WIDTH = 0.12

#: Scan values (odd: the FE value is the middle one); the spacing (6 %) is half the
#: width of a chi-square well in a joint stiffness of the grid (:mod:`vlab.diagnose.problem`).
SCAN_POINTS = 5

#: Tolerance of the Brent search in ``ln p`` (0.4 %).
XTOL = 0.004


def plant_modes(spec: StructureSpec, points) -> PointModes:
    """Modes of the MuJoCo plant built from ``spec`` at ``points``, from its linearisation.

    Parameters
    ----------
    spec : StructureSpec
    points : sequence of int
        Points whose out-of-plane displacement forms the shapes.

    Returns
    -------
    PointModes
        All structural modes of the plant (:func:`vlab.sim.modes`; those its
        modal damping was designed on, :attr:`vlab.sim.Plant.modes`, when it
        has one), shapes mass-normalised (``phi^T M phi = 1`` in joint space)
        [m/sqrt(kg)], with the plant's damping ratios.

    Raises
    ------
    ModelError
        MuJoCo is not installed, or the plant cannot be built or linearised.
    """
    try:
        from ..sim import build_plant, linearize, modes, settle
        from ..sim.linearize import site_jacobian_w
    except ImportError as exc:  # pragma: no cover - depends on the installation
        raise ModelError(f"MuJoCo plant unavailable: {exc}") from None
    pts = list(points)
    try:
        plant = build_plant(spec)
        data = settle(plant.model)
        # the modes its damping was designed on (vlab.sim.damping), else a linearisation of its own
        sm = plant.modes or modes(plant.model, pts, data=data, linear=linearize(plant.model, data))
    except SimulationError as exc:
        raise ModelError(f"the MuJoCo plant of {spec.name!r} cannot be linearised: {exc}") from None
    w = site_jacobian_w(plant.model, data, [f"p{p}" for p in pts]) @ sm.joint_shapes
    return PointModes(sm.omega, sm.damping_ratios, w, tuple(pts), "the MuJoCo plant's linearisation")


def refit_index(h: Hypothesis) -> int | None:
    """Index into ``h.params_`` of the parameter to refit on the plant, or None.

    That of the one spec-level, mode-moving, one-parameter effect of ``h`` (a
    pair qualifies when all its parts are spec-level and exactly one moves
    modes); None otherwise.
    """
    parts = h.parts if isinstance(h, Combination) else (h,)
    if not all(p.spec_level for p in parts):
        return None
    movers = [p for p in parts if p.moves_modes and p.n_params == 1]
    if len(movers) != 1:
        return None
    return sum(p.n_params for p in parts[: parts.index(movers[0])])


@dataclass(frozen=True)
class PlantRefit:
    """A parameter refitted on the plant's linearisation.

    Attributes
    ----------
    name : str
        Parameter name (SI unit in the name; ``first.``/``second.`` in a pair).
    fe_value, value : float
        FE-fitted and refitted values [SI].
    params : ndarray, shape (k,)
        All parameters of the hypothesis with the refitted one [SI].
    state : LabState
        The lab with those parameters (its FE model; the MuJoCo plant is built from its spec).
    chi2_fe_value, chi2 : float
        Chi-square on the plant's linearisation at the FE value and at the refitted one.
    n_evaluations : int
        Linearisations made.
    seconds : float
        Wall time.
    """

    name: str
    fe_value: float
    value: float
    params: np.ndarray
    state: LabState
    chi2_fe_value: float
    chi2: float
    n_evaluations: int
    seconds: float

    def as_dict(self) -> dict:
        """JSON-ready summary."""
        return {"parameter": self.name, "fe_value": self.fe_value, "value": self.value,
                "change": self.value / self.fe_value - 1.0, "chi2_fe_value": self.chi2_fe_value,
                "chi2": self.chi2, "n_evaluations": self.n_evaluations, "seconds": self.seconds,
                "on": "the MuJoCo plant's linearisation"}


def refit_on_plant(problem: Problem, h: Hypothesis, *, modes_of=plant_modes) -> PlantRefit | None:
    """Refit the mode-moving parameter of the fitted hypothesis ``h`` on the plant's linearisation.

    Parameters
    ----------
    problem : Problem
        With FRF data (recording or FRFs); its nominal lab and weights are used.
    h : Hypothesis
        Fitted (``params_`` set).
    modes_of : callable ``(spec, points) -> PointModes``
        The plant's modes (default :func:`plant_modes`).

    Returns
    -------
    PlantRefit or None
        None when ``h`` has no such parameter (:func:`refit_index`), the data
        are modal, the parameter is not positive, or the plant of the nominal
        spec cannot be linearised.

    Notes
    -----
    Data referred through a baseline (``h = H_rec H_FE / H_base``) are
    referred to the plant's nominal linearisation instead
    (``h H_plant / H_FE``) and their variance scaled with them. A value whose
    plant cannot be built or linearised scores infinity.
    """
    i = refit_index(h)
    data = problem.data
    if i is None or not isinstance(data, FrfData) or not float(h.params_[i]) > 0.0:
        return None
    t0 = time.perf_counter()
    base, ctx = problem.base, problem.ctx
    pts = tuple(dict.fromkeys(tuple(data.output_points) + base.actuators))
    try:
        nominal = replace(base, point_modes=modes_of(base.spec, pts))
    except (ModelError, SpecError):
        return None
    if data.h_recorded is not None:
        ratio = problem.predict(nominal) / problem.predict(base)
        data = replace(data, h=data.h * ratio, var=data.var * np.abs(ratio) ** 2)
    on_plant = Problem(data, nominal, ctx, floor=problem.floor, use_phase=problem.use_phase)
    x0 = np.asarray(h.params_, dtype=float)
    seen: dict[float, float] = {}

    def params(u: float) -> np.ndarray:
        x = x0.copy()
        x[i] = x0[i] * math.exp(u)
        return x

    def chi2(u: float) -> float:
        u = float(u)
        if u not in seen:
            try:
                st = h.apply(base, params(u), ctx)
                seen[u] = on_plant.chi2(replace(st, point_modes=modes_of(st.spec, pts)))
            except (ModelError, SpecError):
                seen[u] = math.inf
        return seen[u]

    step = SCAN_HALF_WIDTH / (SCAN_POINTS // 2)
    grid = step * np.arange(-(SCAN_POINTS // 2), SCAN_POINTS // 2 + 1)  # 0 (the FE value) exactly in the middle
    b = int(np.argmin([chi2(u) for u in grid]))
    scipy.optimize.minimize_scalar(chi2, bounds=(grid[b] - step, grid[b] + step), method="bounded",
                                   options={"xatol": XTOL})
    u_best = min(seen, key=seen.get)  # the least chi-square seen, scan points included
    x = params(u_best)
    return PlantRefit(h.param_names[i], float(x0[i]), float(x[i]), x, h.apply(base, x, ctx), chi2(0.0),
                      seen[u_best], len(seen), time.perf_counter() - t0)
