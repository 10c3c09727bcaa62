"""Refit a mode-moving parameter on the validation plant's own linearisation before the MuJoCo rerun.

The hypotheses are fitted on the FE model (:mod:`vlab.diagnose.fit.estimate`), which
is fast. The MuJoCo plant built from the same spec is another
discretisation: its natural frequencies differ from the FE model's by up to
about 1-2 % in some modes (``vlab crosscheck grid``). A baseline recording
removes that offset where the modes are (:func:`vlab.diagnose.data.measured.refer_to_model`),
but a mode that an effect moves far (a softened joint moves two top-beam
modes of the grid by 20 %) leaves its offset behind, and the FE fit absorbs
the offset into the parameter: on the grid's joint 18 the FE fit found
5.65 kN m/rad for a plant drawn at 6.06 kN m/rad, right to 7 %, but the
MuJoCo rerun with that value put two resonances about 2 % off and lowered the misfit
only 2x.

So, before a MuJoCo rerun, the one parameter of a spec-level, mode-moving
effect (:attr:`vlab.diagnose.effects.hypothesis.Hypothesis.moves_modes`; in a pair,
the one such part, the other held) is fitted again to the same data with
the structure's FRFs taken from the *plant's* linearisation
(:func:`plant_modes`: MuJoCo's modes at the settled state, mass-normalised,
with the plant's own modal damping) and the rest of the lab (hardware
chain, controller) as before; data referred through a baseline are referred
to the plant's linearisation instead of the FE model. The fit is a
chi-square scan of :data:`SCAN_POINTS` values within ``+-SCAN_HALF_WIDTH``
(in ``ln p``) of the FE value, followed outward step by step while its least
chi-square lies at its edge, then a bounded Brent search between the best
scan point's neighbours. The FE value is one of the scan points, so the
refit never ends worse on the plant's linearisation than the FE value.

Why not ``mujoco.minimize.least_squares`` (mujoco 4.0, Levenberg-Marquardt on the
residual vector with a finite-difference Jacobian) for the search: tried in place
of the Brent step, bounded to the same bracket, on the joint-18 refit of
tests/test_diagnose_plantfit.py, it crawled along the narrow chi-square well
of a lightly damped mode (99 iterations, 201 linearisations, chi-square 3.04)
where the scan and Brent took 11 (chi-square 1.57; the same stiffness to
0.02 %); with its default tolerances it stopped after 2 iterations at
chi-square 97. ``mujoco.sysid`` fits rollouts in the time domain, not a
linearisation's FRFs. So the one-parameter search stays derivative-free.

The refitted value is the value the rerun uses (``validated.parameters``) and,
for a recording the MuJoCo plant made, the diagnosis's answer (``selected``, with
the FE model's value beside it as ``fe_fit``; :meth:`DiagnosisResult._selected_entries`
of :mod:`vlab.diagnose.report.result`). For a recording that names no vlab plant the
answer is fitted on the structure's own model instead
(:mod:`vlab.diagnose.fit.onstructure`): the plant's discretisation, referred into the
data by its replay, is in the refitted value (an added mass of an independent
simulator's recording 4-46 % high).

What is decided on the plant with these refits is in
:mod:`vlab.diagnose.fit.plantchoice` (a selected pair or single effect against
its parts or look-alikes) and :mod:`vlab.diagnose.fit.plantpair` (a second
effect found there). The refits of several candidates run in two processes
(:func:`map_on_plant`).

Source: the two-model idea is that of model updating with a reference model
(Friswell & Mottershead, *Finite Element Model Updating in Structural
Dynamics*, 1995, ch. 1): a parameter is only meaningful for the model it was
fitted on, so it is refitted on the model that is rerun.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.optimize

from ...errors import ModelError, SimulationError, SpecError
from ...spec import StructureSpec
from ..data.measured import FrfData
from ..effects.hypothesis import Combination, Hypothesis
from ..model.labmodel import LabState, PointModes
from ..problem.residuals import Problem
from .rules import NONLINEAR

#: Half-width of the scan in ``ln p`` around the FE-fitted value (+-12 %: the FE/MuJoCo
#: frequency offsets moved the grid's joint stiffness by 7 %). A chosen range, not fitted; a least chi-square
#: at its edge is followed outward (:func:`_bracketed`).
SCAN_HALF_WIDTH = 0.12

#: Scan values (odd: the FE value is the middle one); the spacing (6 %) is half the
#: width of a chi-square well in a joint stiffness of the grid (:mod:`vlab.diagnose.problem.residuals`).
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
        from ...sim import build_plant, linearize, modes, settle
        from ...sim.linearize import site_jacobian_w
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
    return PointModes(sm.omega, sm.damping_ratios, w, tuple(pts), "the MuJoCo plant's linearisation",
                      _plant_coupling(spec, plant, sm.joint_shapes))


def _plant_coupling(spec: StructureSpec, plant, phi: np.ndarray) -> np.ndarray | None:
    """Off-diagonal modal damping [1/s] of the plant of a changed structure (its kept hinge and modal damping
    in its own modes ``phi``, shape (nv, n)), None for a structure with its own damping
    (:attr:`vlab.diagnose.model.labmodel.PointModes.coupling`)."""
    if spec.damping is None or spec.damping.basis is None:
        return None
    md = plant.modal_damping
    c = np.diag(np.asarray(plant.model.dof_damping, dtype=float))
    if md is not None:
        c = c + md.matrix()
    cm = phi.T @ c @ phi
    np.fill_diagonal(cm, 0.0)
    return cm


def refit_index(h: Hypothesis, part: Hypothesis | None = None, *, chain: bool = False) -> int | None:
    """Index into ``h.params_`` of the parameter to refit on the plant, or None.

    That of the one spec-level, mode-moving, one-parameter effect of ``h`` (a
    pair qualifies when all its parts are spec-level and exactly one moves
    modes, or ``part``, one of its parts, moves modes); with ``chain``, also the one parameter of a single
    effect of the hardware chain (a recording the MuJoCo plant made: the chain acts in that plant's loop,
    :class:`PlantModel`); None otherwise.
    """
    if chain and not isinstance(h, Combination) and h.in_chain and h.effect not in NONLINEAR and h.n_params == 1:
        return 0
    parts = h.parts if isinstance(h, Combination) else (h,)
    if not all(p.spec_level for p in parts):
        return None
    movers = [p for p in parts if p.moves_modes and p.n_params == 1]
    if part is not None:
        movers = [p for p in movers if p.label == part.label]
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
        Starting (in general the FE-fitted) and refitted values [SI].
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
    start : str
        Where ``fe_value`` came from: ``"FE fit"``, or for a second effect found on the plant
        (:mod:`vlab.diagnose.fit.plantpair`) the fit on the data referred through the first.
    plant_state : LabState or None
        The lab with those parameters and the plant's modes (:meth:`PlantModel.state`): what ``chi2`` was
        computed with; None where the refit was not evaluated on the plant.
    plant_problem : Problem or None
        The data on the plant's linearisation (:attr:`PlantModel.problem`), the footing of ``chi2``.
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
    start: str = "FE fit"
    plant_state: LabState | None = field(default=None, repr=False, compare=False)
    plant_problem: Problem | None = field(default=None, repr=False, compare=False)

    def as_dict(self) -> dict:
        """JSON-ready summary."""
        return {"parameter": self.name, "fe_value": self.fe_value, "value": self.value,
                "change": self.value / self.fe_value - 1.0, "chi2_fe_value": self.chi2_fe_value,
                "chi2": self.chi2, "n_evaluations": self.n_evaluations, "seconds": self.seconds,
                "on": "the MuJoCo plant's linearisation", "start": self.start}


class PlantModel:
    """The lab with the structure's modes taken from the plant's linearisation, scored on a problem's data.

    Parameters
    ----------
    problem : Problem
        With FRF data (recording or FRFs); its nominal lab, context and weights are used.
    modes_of : callable ``(spec, points) -> PointModes``
        The plant's modes (default :func:`plant_modes`).
    chain_refit : bool
        Refit a single effect of the hardware chain too (:func:`refit_index` with ``chain``): for a recording
        the MuJoCo plant made, compared with that plant. The data were referred through the plant's replay,
        so a change of the chain is the change it makes in the *plant's* loop; fitted in the FE model's loop,
        whose FRFs differ from the plant's by tens of per cent at lightly damped peaks, it carries that
        difference to second order (the referral's error, :func:`vlab.diagnose.data.measured.refer_to_model`),
        which can bias a lag's corner and order a delay before the lag that made the data.

    Attributes
    ----------
    fe_problem : Problem
        The problem given (on the FE model).
    problem : Problem
        The same data on the plant's linearisation: data referred through a
        baseline (``h = H_rec H_FE / H_base``) are referred to the plant's
        nominal linearisation instead (``h H_plant / H_FE``, variance scaled
        with them).

    Raises
    ------
    ModelError
        Modal data, or the plant of the nominal spec cannot be built or linearised.
    """

    def __init__(self, problem: Problem, *, modes_of=plant_modes, chain_refit: bool = False):
        self.chain_refit = bool(chain_refit)
        data = problem.data
        if not isinstance(data, FrfData):
            raise ModelError("a refit on the plant needs FRF data (a recording or FRFs), not a modal table")
        self.fe_problem, self.base, self.ctx, self._modes_of = problem, problem.base, problem.ctx, modes_of
        self.points = tuple(dict.fromkeys(tuple(data.output_points) + self.base.actuators))
        self._nominal_modes = modes_of(self.base.spec, self.points)
        nominal = replace(self.base, point_modes=self._nominal_modes)
        if data.h_recorded is not None:
            ratio = problem.predict(nominal) / problem.predict(self.base)
            data = replace(data, h=data.h * ratio, var=data.var * np.abs(ratio) ** 2)
        self.problem = Problem(data, nominal, self.ctx, floor=problem.floor, use_phase=problem.use_phase,
                               model_form_frf=problem.model_form_frf, policy=problem.policy,
                               line_floor=getattr(problem, "line_floor", None))
        self.n_linearisations = 1

    def state(self, h: Hypothesis | None, x) -> LabState:
        """The lab with ``h`` of size ``x`` [SI] (nominal for None) and the plant's modes of its spec.

        Raises ModelError/SpecError when the plant cannot be built or linearised."""
        st = self.base if h is None else h.apply(self.base, np.asarray(x, dtype=float), self.ctx)
        if st.spec is self.base.spec:  # a chain effect: the structure is the nominal one
            return replace(st, point_modes=self._nominal_modes)
        self.n_linearisations += 1
        return replace(st, point_modes=self._modes_of(st.spec, self.points))

    def chi2(self, h: Hypothesis | None, x) -> float:
        """Chi-square of ``h`` of size ``x`` on the plant's linearisation (infinity where it cannot be built)."""
        return self._chi2_state(h, x)[0]

    def _chi2_state(self, h: Hypothesis | None, x) -> tuple[float, LabState | None]:
        """:meth:`chi2` and the lab it was computed with (None where it cannot be built)."""
        try:
            st = self.state(h, x)
            return self.problem.chi2(st), st
        except (ModelError, SpecError):
            return math.inf, None

    def _log_bounds(self, h: Hypothesis, x0: np.ndarray, i: int) -> tuple[float, float]:
        """The range of ``h``'s parameter ``i`` (its search space) in ``ln(p / x0[i])``, ``x0[i] > 0``; a lower
        bound at or below zero is no bound in ``ln p``."""
        _, lo, hi = h.space(self.base, self.ctx)
        low = math.log(lo[i] / x0[i]) if lo[i] > 0 else -math.inf
        return low, (math.log(hi[i] / x0[i]) if hi[i] > 0 else -math.inf)

    def refit(self, h: Hypothesis, x0, index: int | None = None, *, half_width: float = SCAN_HALF_WIDTH,
              points: int = SCAN_POINTS) -> PlantRefit | None:
        """Refit one parameter of ``h``, starting from ``x0`` [SI] (the FE fit), the others held.

        ``index`` picks the parameter (default :func:`refit_index`: the one mode-moving parameter of ``h``, or
        with :attr:`chain_refit` the one parameter of a single chain effect).

        A chi-square scan of ``points`` values (odd; default :data:`SCAN_POINTS`)
        within ``+-half_width`` in ``ln p`` (default :data:`SCAN_HALF_WIDTH`),
        followed outward while the least lies at its edge (:func:`_bracketed`, within the parameter's range),
        then a bounded Brent search (:data:`XTOL`) between the best
        scan point's neighbours; the least chi-square seen is kept, so the
        result is never worse than ``x0``.

        Returns
        -------
        PlantRefit or None
            None when ``h`` has no such parameter (:func:`refit_index`) or it is not positive.
        """
        i = refit_index(h, chain=self.chain_refit) if index is None else index
        x0 = np.asarray(x0, dtype=float)
        if i is None or not float(x0[i]) > 0.0:
            return None
        t0 = time.perf_counter()
        n0 = self.n_linearisations
        seen: dict[float, float] = {}
        best: list = [math.inf, None]  # the least chi-square evaluated and its lab (the plant's modes)

        def params(u: float) -> np.ndarray:
            x = x0.copy()
            x[i] = x0[i] * math.exp(u)
            return x

        def chi2(u: float) -> float:
            u = float(u)
            if u not in seen:
                seen[u], st = self._chi2_state(h, params(u))
                if seen[u] < best[0]:
                    best[:] = [seen[u], st]
            return seen[u]

        step = half_width / (points // 2)
        grid = step * np.arange(-(points // 2), points // 2 + 1)  # 0 (the FE value) exactly in the middle
        u_b = _bracketed(chi2, grid, step, self._log_bounds(h, x0, i))
        scipy.optimize.minimize_scalar(chi2, bounds=(u_b - step, u_b + step), method="bounded",
                                       options={"xatol": XTOL})
        u_best = min(seen, key=seen.get)  # the least chi-square seen, scan points included
        x = params(u_best)
        return PlantRefit(h.param_names[i], float(x0[i]), float(x[i]), x, h.apply(self.base, x, self.ctx),
                          chi2(0.0), seen[u_best], self.n_linearisations - n0, time.perf_counter() - t0,
                          plant_state=best[1], plant_problem=self.problem)


def _bracketed(chi2, grid: np.ndarray, step: float, bounds: tuple[float, float]) -> float:
    """The scan point of least ``chi2`` on ``grid`` (in ``ln p``), stepped on outward by ``step`` while the
    least lies at the scan's edge and the chi-square keeps falling (within ``bounds``): a minimum at the edge of
    a chosen range is not bracketed, and the Brent search between its neighbours would end at that edge."""
    vals = {float(u): chi2(u) for u in grid}
    u_b = min(vals, key=vals.get)
    for side in (-1.0, 1.0):
        while u_b == (min(vals) if side < 0 else max(vals)):
            u = u_b + side * step
            if not bounds[0] <= u <= bounds[1]:
                break
            vals[u] = chi2(u)
            if not vals[u] < vals[u_b]:
                break
            u_b = u
    return u_b


def refit_parts(model: PlantModel, pair: Combination, r: PlantRefit, parts) -> PlantRefit:
    """The pair's refit ``r`` improved by refitting, in turn, the mode-moving parameter of each of ``parts``
    (parts of ``pair``) with the others at their values in ``r`` (coordinate descent, one pass); a part's
    refit is kept only where it lowers the plant chi-square. ``name``, ``fe_value``, ``chi2_fe_value`` and
    ``start`` stay those of ``r``; ``value`` follows the parameter ``r`` names.

    Parameters
    ----------
    model : PlantModel
    pair : Combination
        Fitted pair (``params_`` set).
    r : PlantRefit
        Its refit so far (``params`` shape ``(pair.n_params,)``, SI).
    parts : sequence of Hypothesis
        Parts of ``pair`` to refit, in this order (those without a mode-moving parameter are skipped).

    Returns
    -------
    PlantRefit
        ``r`` or a better one (never a higher plant chi-square).
    """
    j = pair.param_names.index(r.name)
    for part in parts:
        i = refit_index(pair, part)
        r1 = None if i is None else model.refit(pair, r.params, i)
        if r1 is not None and r1.chi2 < r.chi2:
            r = replace(r, value=float(r1.params[j]), params=r1.params, state=r1.state, chi2=r1.chi2,
                        plant_state=r1.plant_state, plant_problem=r1.plant_problem,
                        n_evaluations=r.n_evaluations + r1.n_evaluations,
                        seconds=r.seconds + r1.seconds)
    return r


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
        spec cannot be linearised (:class:`PlantModel`, :meth:`PlantModel.refit`).
    """
    if refit_index(h) is None:
        return None
    try:
        model = PlantModel(problem, modes_of=modes_of)
    except (ModelError, SpecError):
        return None
    return model.refit(h, h.params_)


@dataclass(frozen=True)
class PlantScore:
    """Chi-square and parameter count of a fit on the plant (what :func:`vlab.diagnose.fit.rules.evidence` reads).

    Attributes
    ----------
    chi2_ : float
        Chi-square on the plant's linearisation.
    n_params : int
        Number of fitted parameters.
    """

    chi2_: float
    n_params: int


def _job(fn, model: PlantModel, *args):
    """Worker of :func:`map_on_plant`: ``fn(model, *args)``, None where the plant cannot be built."""
    try:
        return fn(model, *args)
    except (ModelError, SpecError):
        return None


def map_on_plant(fn, model: PlantModel, jobs: list, *, workers: int = 2) -> list:
    """``fn(model, *job)`` for each of ``jobs``, in parallel processes (each refit on the plant's
    linearisation builds and linearises a MuJoCo plant per evaluation, 0.3 s for the grid).

    Parameters
    ----------
    fn : callable ``(PlantModel, *job) -> object``
        A module-level function (sent to the worker processes by name).
    model : PlantModel
    jobs : list of tuple
    workers : int
        Processes (a background rerun of the nominal lab, :func:`vlab.diagnose.data.rerun_jobs.start_background_rerun`,
        may still hold a core for their first seconds); one process where a pool cannot start or the
        model cannot be sent to one (a test's own ``modes_of``).

    Returns
    -------
    list
        One result per job, in order; None where ``fn`` raised :class:`ModelError` or :class:`SpecError`.

    Raises
    ------
    Exception
        Any other error of ``fn`` (from the worker process that ran it).
    """
    if workers > 1 and len(jobs) > 1 and _picklable((fn, model, jobs)):
        from concurrent.futures import ProcessPoolExecutor
        from concurrent.futures.process import BrokenProcessPool

        try:
            with ProcessPoolExecutor(min(workers, len(jobs))) as ex:
                return list(ex.map(_job, *zip(*[(fn, model, *job) for job in jobs])))
        except (OSError, BrokenProcessPool):
            pass  # no process pool here: one process
    return [_job(fn, model, *job) for job in jobs]


def _picklable(obj) -> bool:
    """Whether ``obj`` can be sent to a worker process (a local function or a test's own ``modes_of``
    cannot)."""
    import pickle

    try:
        pickle.dumps(obj)
    except (pickle.PicklingError, AttributeError, TypeError):
        return False
    return True
