"""The value of a chosen effect on the structure's own model, for a recording whose source is not a vlab plant.

A recording is referred to the model through a replay of its own force
(:func:`vlab.diagnose.data.reference.replay_reference`): ``H_ref = H_rec H_model /
H_replay``. To first order in the mode frequencies that referral moves each
resonance of the data by ``omega_model - omega_replay``, so a parameter fitted to
the referred data carries the difference between the recording's source and the
replay plant: ``delta_fit = delta_true + (omega_source - omega_replay)`` mapped
onto the effect's sensitivity. Where the source *is* the replay plant (a vlab
MuJoCo recording) the term is zero, and the MuJoCo replay, whose loop, hold and
estimator are the recording's, is the right reference. Where the source is
another code or a real structure, the MuJoCo plant's rigid-link discretisation
(its frequencies 0.04-0.4 % from the converged FE model's, ``vlab crosscheck``)
enters every mode-moving parameter: an added mass of 2-5x its detection threshold
shifts the resonances by a few tenths of a percent, the same order.

So, for a recording that names no vlab plant, the chosen effect's value is
fitted again on the *structure's* model -- the FE model of the structure file,
its mesh refined until its discretisation is negligible against the model form
(:func:`converged_lab`: a value is a property of the structure, not of a mesh) --
with the data referred through that model's own linear replay (the same loop,
chain and estimator; no simulator's discretisation put in), and the model form
anchored at the fitted lab's own modes (:mod:`vlab.diagnose.fit.anchored`). That
value is the answer; the
plant's value (:mod:`vlab.diagnose.fit.plantfit`) stays the value the validation
rerun uses. The two references differ by their model form, which the fit's
statistical interval does not carry, so the reported 95 % interval spans the
plant's value as well (a two-model estimate of the value's model-form
uncertainty).

Source: a parameter is meaningful for the model it was fitted on (Friswell &
Mottershead, *Finite Element Model Updating in Structural Dynamics*, 1995,
ch. 1); the referral is the reference-state method of Doebling et al.
(LA-13070-MS, 1996, Sec. 3).
"""

from __future__ import annotations

import copy
import time
from dataclasses import dataclass, replace

import numpy as np

from ...errors import VlabError
from ...fe import build_fe_model, modal_analysis
from ..effects.hypothesis import Combination, Hypothesis
from ..model.labmodel import LabState
from ..model.modelform import remeshed
from ..problem.residuals import Problem
from .anchored import fit_anchored
from .estimate import fit_hypothesis
from .robust import t_fit

#: Share of the smallest model-form frequency uncertainty below which a mesh counts as converged: the
#: discretisation then adds at most 1 % to any mode's frequency variance.
CONVERGED_SHARE = 0.1
#: Most degrees of freedom of the refined model (each fit evaluation solves its modes).
MAX_REFINED_DOFS = 600
#: Modes above the band by this factor do not enter the convergence test (as the FRF model form's margin).
BAND_MARGIN = 1.5


@dataclass(frozen=True)
class StructureFit:
    """A chosen effect fitted again on the structure's model (the FE model, data referred through its replay).

    Attributes
    ----------
    params : ndarray, shape (k,)
        The fitted parameters [SI], in the hypothesis's order.
    ci95 : ndarray, shape (k, 2)
        Their 95 % intervals from the fit [SI] (NaN where undetermined).
    chi2 : float
        The least-squares chi-square on the structure's problem at ``params`` (on the t likelihood not the
        objective minimised).
    reference : str
        What the data were referred through, in words.
    seconds : float
        Wall time of the fit [s].
    likelihood : str
        The likelihood the value maximises, in words (:mod:`vlab.diagnose.fit.robust`).
    t_dof, t_scale : float or None
        The Student-t likelihood's degrees of freedom and scale [1], None on the normal likelihood.
    chi2_limit : float or None
        The mismatch test's total chi-square limit on the structure's problem [1] (None: not known).
    chi2_least : float or None
        The least chi-square reached there [1] (the least-squares fit's; ``chi2`` is at the reported value,
        which on the t likelihood is not the least-squares optimum).
    """

    params: np.ndarray
    ci95: np.ndarray
    chi2: float
    reference: str
    seconds: float
    likelihood: str = "normal likelihood (least squares)"
    t_dof: float | None = None
    t_scale: float | None = None
    chi2_limit: float | None = None
    chi2_least: float | None = None

    @property
    def adequate(self) -> bool:
        """Whether the structure's model, at its best value, leaves its data within the mismatch test's limit
        there (True where the limit is not known): a model its own data reject at the test's false-alarm rate is
        no model of them, and its value no estimate."""
        best = self.chi2 if self.chi2_least is None else min(self.chi2, self.chi2_least)
        return self.chi2_limit is None or not best > self.chi2_limit

    def as_dict(self) -> dict:
        """JSON-ready summary (parameters and their 95 % intervals SI, in the hypothesis's order)."""
        return {"parameters": [float(v) for v in self.params],
                "ci95": [[float(a), float(b)] for a, b in self.ci95], "chi2": float(self.chi2),
                "reference": self.reference, "seconds": float(self.seconds), "likelihood": self.likelihood,
                "t_dof": None if self.t_dof is None else float(self.t_dof),
                "t_scale": None if self.t_scale is None else float(self.t_scale),
                "chi2_limit": None if self.chi2_limit is None else float(self.chi2_limit),
                "chi2_least": None if self.chi2_least is None else float(self.chi2_least)}


def fit_on_structure(problem: Problem, h: Hypothesis, reference: str) -> StructureFit | None:
    """Fit the chosen hypothesis ``h`` again on the structure's problem.

    A single effect is fitted from its own trial values (the structure's optimum may lie outside a local
    search from the chosen value: an added mass 30 % apart) or from the chosen value where that scores
    better on the structure's problem than the trials' fit (a value beyond the trials' range); a pair from the
    chosen parameters, by a local fit; each with the model form anchored at the fitted lab
    (:func:`vlab.diagnose.fit.anchored.fit_anchored`). The value is then that of the Student-t likelihood of
    the same residuals, its degrees of freedom and scale estimated with it
    (:func:`vlab.diagnose.fit.robust.t_fit`: a few lines misfit by the model's form beyond their variance
    no longer pull a value whose information lies elsewhere), where it fits better than the nominal lab on
    that likelihood; else the least-squares value.

    Parameters
    ----------
    problem : Problem
        The data referred through the structure's own (linear FE) replay, against the FE model at the
        structure file's mesh.
    h : Hypothesis
        The chosen effect, fitted (``params_`` set); it is not changed (a copy is fitted).
    reference : str
        What ``problem``'s data were referred through (kept in the result).

    Returns
    -------
    StructureFit or None
        None when ``h`` has no parameter, the fit fails (a model the structure cannot carry) or its value does
        not fit the structure's data better than the nominal model.
    """
    if h.n_params == 0:
        return None
    t = time.perf_counter()
    g = copy.deepcopy(h)
    try:
        x0 = np.asarray(h.params_, dtype=float)
        if not isinstance(g, Combination) and problem.chi2(problem.state_for(h, x0)) >= \
                fit_hypothesis(copy.deepcopy(h), problem).chi2_:
            x0 = None  # the trials' fit scores better than the chosen value: start from the trials
        g, footing = fit_anchored(g, problem, starts=None if x0 is None else x0[None, :])
    except (VlabError, ValueError, np.linalg.LinAlgError):
        return None
    if not np.all(np.isfinite(g.params_)) or not g.chi2_ < footing.chi2(footing.base):
        return None
    try:
        tf = t_fit(g, footing, np.asarray(g.params_, dtype=float))
    except (VlabError, ValueError, np.linalg.LinAlgError):
        tf = None
    limit = float(problem.noise_chi2())
    if tf is None or not np.all(np.isfinite(tf.params)) or not tf.nll < tf.nll_nominal:
        return StructureFit(np.asarray(g.params_, dtype=float), np.asarray(g.ci95_, dtype=float), float(g.chi2_),
                            reference, time.perf_counter() - t, chi2_limit=limit, chi2_least=float(g.chi2_))
    return StructureFit(tf.params, tf.ci95, footing.chi2(footing.state_for(g, tf.params)), reference,
                        time.perf_counter() - t, tf.describe(), tf.dof, tf.scale, chi2_limit=limit,
                        chi2_least=float(g.chi2_))


def spanning(ci95: np.ndarray, *values: np.ndarray) -> np.ndarray:
    """The intervals ``ci95`` widened to hold ``values`` (other reference models' estimates of the same parameters).

    Parameters
    ----------
    ci95 : ndarray, shape (k, 2)
        Statistical 95 % intervals [SI]; a NaN row (undetermined) stays NaN.
    *values : ndarray, shape (k,)
        Estimates of the same parameters on other reference models [SI].

    Returns
    -------
    ndarray, shape (k, 2)
    """
    out = np.array(ci95, dtype=float, copy=True)
    for v in values:
        v = np.asarray(v, dtype=float)
        out[:, 0] = np.where(np.isfinite(out[:, 0]), np.minimum(out[:, 0], v), out[:, 0])
        out[:, 1] = np.where(np.isfinite(out[:, 1]), np.maximum(out[:, 1], v), out[:, 1])
    return out


def converged_lab(lab: LabState, band_hz: tuple[float, float], frequency_sigma: float) -> tuple[LabState, int, float]:
    """``lab`` with its FE model's mesh refined until converged in the band.

    The elements per segment of every member are doubled while the modes up to :data:`BAND_MARGIN` times the
    band's top move by more than :data:`CONVERGED_SHARE` of ``frequency_sigma`` (relative) from one mesh to
    the next, while the refined model stays within :data:`MAX_REFINED_DOFS` and while the spec can carry it
    (an element no shorter than a rigid insert).

    Parameters
    ----------
    lab : LabState
        With the structure file's spec and FE model.
    band_hz : (float, float)
        The data's band [Hz].
    frequency_sigma : float
        The smallest relative standard uncertainty of a frequency in the model form [1].

    Returns
    -------
    lab : LabState
        The refined lab (``lab`` itself when its mesh is converged).
    factor : int
        The refinement factor of the elements per segment.
    change : float
        The largest relative frequency change of the last doubling in the band [1].

    Raises
    ------
    ModelError
        ``lab``'s own FE model has no modes.
    """
    tol = CONVERGED_SHARE * float(frequency_sigma)
    spec, fe, factor, change = lab.spec, lab.fe, 1, float("inf")
    f_top = BAND_MARGIN * float(band_hz[1])
    f0 = modal_analysis(fe.m, fe.k).frequencies_hz
    while True:
        fine = remeshed(spec, 2.0)
        try:
            fe1 = build_fe_model(fine)
        except VlabError:  # a mesh the spec cannot carry (an element shorter than a rigid insert): the last one
            break
        if fe1.n > MAX_REFINED_DOFS or fine == spec:
            break
        f1 = modal_analysis(fe1.m, fe1.k).frequencies_hz
        k = int(np.sum(f0 <= f_top))
        change = float(np.max(np.abs(np.log(f0[:k] / f1[:k])), initial=0.0))
        spec, fe, f0, factor = fine, fe1, f1, 2 * factor
        if change <= tol:
            break
    return (lab if factor == 1 else replace(lab, spec=spec, fe=fe, point_modes=None)), factor, change
