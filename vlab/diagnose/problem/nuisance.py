"""The model-form parameters profiled out: a lab's modes moved within their model-form uncertainty.

A lab state is compared with FRF data within the model's own uncertainty
by letting each uncertain modal parameter of
:class:`vlab.diagnose.model.modelform.FrfModelForm` (a mode's frequency,
damping ratio, or shape at a point) move, in units ``x_k`` of its standard
uncertainty, to where the data put it, at the cost ``|x|^2``::

    min_x |r(x)|^2 + |x|^2

with ``r`` the residual weighted by the noise and the floor alone (not
whitened). Under the null hypothesis the minimum is about chi-square with N
degrees of freedom and ``|x|^2`` about chi-square with k. The Jacobian is
taken by forward differences, every parameter's at once
(:func:`vlab.diagnose.model.modal_changes.changed_mode_frfs`: a parameter
changes one mode's term of the modal sum). The nominal lab's
decision uses it (:meth:`vlab.diagnose.problem.residuals.Problem.nominal_profile`),
and so does the question whether a selected effect leaves more than its own
model form (:func:`within_model_accuracy`): an effect that moves a lightly
damped mode leaves, at that mode's peak, a difference between the plant it was
modelled on and the real structure that first order does not reach.

Source: profile likelihood with the nuisance parameters as Gaussian priors
(Kennedy & O'Hagan, J. R. Stat. Soc. B 63 (2001) 425-464); nonlinear least
squares: scipy.optimize.least_squares (trust-region reflective).
"""

from __future__ import annotations

import weakref
from dataclasses import replace

import numpy as np
import scipy.optimize

from ...errors import ModelError
from ..model.labmodel import LabState, PointModes, point_modes_of
from ..model.modal_changes import MOVED_REFERENCE, changed_mode_frfs, moved_like, moved_modes
from ..model.modelform import BAND_MARGIN, FrfModelForm

#: Evaluations of the profile per parameter at most.
NFEV_PER_PARAMETER = 60
#: Relative step of the Jacobian's forward differences (scipy's ``diff_step``: the step of ``x`` is this times
#: ``max(1, |x|)``, in units of the parameter's standard uncertainty).
DIFF_STEP = 1e-3


def parameters(mf: FrfModelForm, pm: PointModes) -> list[tuple[str, int | None, int | None]]:
    """``(kind, mode index in pm, point row)`` of each parameter of ``mf``, its mode paired with the mode of
    ``pm`` nearest in frequency to the one ``mf`` perturbs (None where ``pm`` has no mode within 20 %, or not
    the point); the same mode where ``pm`` are the reference modes moved
    (:func:`vlab.diagnose.model.modal_changes.moved_like`).

    Parameters
    ----------
    mf : FrfModelForm
        Labels ``f<r>``, ``zeta<r>``, ``phi<r>@<point>`` (mode numbers of ``mf.modes``).
    pm : PointModes
        The modes to move (``mf.modes`` itself, or those of a modified lab).

    Returns
    -------
    list of (str, int or None, int or None)
    """
    ref = mf.modes.omega if mf.modes is not None else pm.omega
    one_for_one = pm.source == MOVED_REFERENCE and len(pm.omega) == len(ref)  # the reference's modes, moved
    out = []
    for lab in mf.labels:
        kind = "phi" if lab.startswith("phi") else "zeta" if lab.startswith("zeta") else "f"
        head, _, pt = lab[len(kind):].partition("@")
        r0 = int(head) - 1
        r = None
        if one_for_one:
            r = r0
        elif r0 < len(ref) and len(pm.omega):
            i = int(np.argmin(np.abs(np.log(np.maximum(pm.omega, 1e-300) / ref[r0]))))
            r = i if abs(np.log(pm.omega[i] / ref[r0])) <= np.log(1.2) else None
        j = None
        if pt:
            j = pm.points.index(int(pt)) if int(pt) in pm.points else None
            r = r if j is not None else None
        out.append((kind, r, j))
    return out


def profile(problem, state: LabState, pm0: PointModes, scale=None,
            start: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``state`` with its modes ``pm0`` moved within the model form of ``problem`` to fit its data (module notes).

    Parameters
    ----------
    problem : Problem
        FRF data with ``model_form_frf``; its unwhitened relative error (:meth:`Problem.line_residual` with
        ``test``) is used.
    state : LabState
        The lab whose modes move.
    pm0 : PointModes
        Its modes (``state.point_modes``, or the reference modes the model form was derived on).
    scale : ndarray, complex, shape (n_used,), optional
        Multiplies the prediction on the used lines (the nominal lab: its FE prediction over the prediction
        with ``pm0``, so that the moves change it as they change the reference's).
    start : ndarray, shape (k,), optional
        The search's start in units of the parameters' standard uncertainty (a previous optimum of this
        function on nearby data; ignored when its length is not ``k``); default 0.

    Returns
    -------
    r : ndarray, shape (n_obs,)
        The residual at the optimum (not whitened).
    x : ndarray, shape (k,)
        The parameters' values in units of their standard uncertainty (0 for a parameter without a mode).
    """
    mf = problem.model_form_frf
    which = parameters(mf, pm0)
    mask = problem.mask
    live = [i for i, (_k, r, _j) in enumerate(which) if r is not None]
    sigma = np.array([mf.sigma[i] for i in live])

    def changes(xl: np.ndarray) -> list:
        return [(which[i][0], which[i][1], which[i][2], s * xi) for i, s, xi in zip(live, sigma, xl)]

    def plain(xl: np.ndarray) -> np.ndarray:
        h = problem.predict(replace(state, point_modes=moved_modes(pm0, changes(xl))))[mask]
        return problem.line_residual(h if scale is None else scale * h, test=True)

    def jac(xl: np.ndarray) -> np.ndarray:
        # forward differences of every parameter at once (module notes); steps as scipy's '2-point'
        step = DIFF_STEP * np.where(xl >= 0, 1.0, -1.0) * np.maximum(1.0, np.abs(xl))
        h0, hs = changed_mode_frfs(state, moved_modes(pm0, changes(xl)), changes(step),
                                   problem.data.freq_hz, excitation_point=problem.data.excitation_point,
                                   output_points=problem.data.output_points, ref=pm0)
        s_ = 1.0 if scale is None else scale
        r0 = problem.line_residual(s_ * h0[mask], test=True)
        cols = [(problem.line_residual(s_ * hi[mask], test=True) - r0) / st for hi, st in zip(hs, step)]
        return np.vstack([np.stack(cols, axis=1), np.eye(len(xl))])

    x = np.zeros(len(which))
    if not live:
        return plain(np.zeros(0)), x
    x_start = np.zeros(len(live)) if start is None or np.size(start) != len(which) else np.asarray(start)[live]
    sol = scipy.optimize.least_squares(lambda xl: np.concatenate([plain(xl), xl]), x_start, jac=jac,
                                       method="trf", x_scale=1.0, max_nfev=NFEV_PER_PARAMETER * len(live))
    x[live] = sol.x
    return plain(sol.x), x


def own_modes(problem, state: LabState) -> tuple[PointModes, np.ndarray | None]:
    """The modes of ``state`` that the model form of ``problem`` moves, and the scale of :func:`profile`.

    A lab carrying its modes (``state.point_modes``, a refit on the plant's linearisation) moves those,
    unscaled. Otherwise the modes are the reference modes the model form was derived on (``mf.modes``) for a
    lab with the nominal structure (a chain effect, a mode's damping), and for a lab of a changed structure
    those reference modes moved as its FE modes move from the nominal lab's (from those of the lab the model
    form was anchored at, ``mf.anchor``)
    (:func:`vlab.diagnose.model.modal_changes.moved_like`): every lab then moves the same parameters, the
    nominal lab's, and their profiles compare on one footing (the reference may hold modes the FE model
    lacks, such as the MuJoCo BCC's second crosspiece arm). Without reference modes, the lab's own FE modes
    at the measured points and actuators. The scale is the lab's FE prediction over its prediction with
    those modes on the used lines, so that the moves change the prediction as they change the modes.

    Parameters
    ----------
    problem : Problem
        FRF data with ``model_form_frf``.
    state : LabState

    Returns
    -------
    pm0 : PointModes
    scale : ndarray, complex, shape (n_used,), or None
    """
    if state.point_modes is not None:
        return state.point_modes, None
    mf = problem.model_form_frf
    if mf.modes is None:
        pts = tuple(dict.fromkeys(tuple(problem.data.output_points) + state.actuators))
        pm0 = point_modes_of(state, pts, "the lab's FE model")
    elif state.fe is (problem.base if mf.anchor is None else mf.anchor).fe:
        pm0 = mf.modes
    else:  # a changed structure: the reference modes moved as its FE modes move (the nominal lab's footing)
        top = float(np.max(problem.data.freq_hz)) * BAND_MARGIN
        pm0 = moved_like(mf.modes, _anchor_fe_modes(problem), point_modes_of(state, mf.modes.points), top)
    mask = problem.mask
    return pm0, problem.predict(state)[mask] / problem.predict(replace(state, point_modes=pm0))[mask]


def _anchor_fe_modes(problem) -> PointModes:
    """The FE modes, at the model form's points, of the lab its reference modes stand for (its ``anchor``, by
    default the nominal lab), once per problem and model form."""
    mf = problem.model_form_frf
    memo = _PROFILES.setdefault(problem, {})
    key = ("anchor FE modes", id(mf))
    if key not in memo or memo[key][0] is not mf:
        anchor = problem.base if mf.anchor is None else mf.anchor
        memo[key] = (mf, point_modes_of(anchor, mf.modes.points, "the FE model of the model form's lab"))
    return memo[key][1]


def profile_state(problem, state: LabState) -> tuple[np.ndarray, np.ndarray, int]:
    """:func:`profile` of ``state`` on its own modes (:func:`own_modes`, which takes ``problem`` and ``state``).

    Returns
    -------
    r : ndarray, shape (n_obs,)
        The residual at the optimum (not whitened).
    x : ndarray, shape (k_all,)
        The parameters in units of their standard uncertainty.
    k : int
        The parameters that have a mode to move (the degrees of freedom of ``|x|^2``).
    """
    memo = _PROFILES.setdefault(problem, {})
    hit = memo.get(id(state))
    if hit is not None and hit[0] is state and hit[1] is problem.model_form_frf:
        return hit[2]
    pm0, scale = own_modes(problem, state)
    k = sum(r is not None for _kind, r, _j in parameters(problem.model_form_frf, pm0))
    r, x = profile(problem, state, pm0, scale)
    memo[id(state)] = (state, problem.model_form_frf, (r, x, k))
    return r, x, k


#: :func:`profile_state`'s results per problem (weakly: a problem's go with it) and lab state (by identity: a
#: state is immutable); the selection's tests ask the same state more than once.
_PROFILES: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


def profiled_statistic(problem, state: LabState) -> float:
    """The mismatch test's statistic of ``state``: ``S = |r|^2 + |x|^2`` [1] after its modes are moved within
    their model form (:func:`profile_state`) -- the chi-square of the residual plus that of the moves, the
    quantity :func:`within_model_accuracy` compares with the problem's limit.

    Raises ModelError or SpecError where ``state``'s modes cannot be computed (as :func:`profile_state`)."""
    r, x, _ = profile_state(problem, state)
    return float(r @ r + x @ x)


def profiled(problem, state: LabState) -> bool:
    """Whether ``state`` is compared with the data of ``problem`` with its modes profiled: the problem carries
    a model form, and the lab carries its own modes or the problem's mismatch test profiled the nominal lab's
    (``profile_nominal``): a choice is then judged by the statistic that declared the mismatch."""
    mf = problem.model_form_frf
    return (mf is not None and mf.sigma.size > 0
            and (state.point_modes is not None or bool(getattr(problem, "profile_nominal", False))))


def within_model_accuracy(problem, state: LabState) -> bool:
    """Whether ``state`` explains ``problem``'s data within the noise and the model's own uncertainty: after
    its modes (:func:`own_modes`) are moved within their model form (:func:`profile`), the chi-square and
    the largest line are within the problem's limits and the moves within the policy's
    :meth:`~vlab.diagnose.policy.DecisionPolicy.nuisance_limit` -- the three tests of the mismatch.

    Parameters
    ----------
    problem : Problem
        FRF data; where the lab is not profiled (:func:`profiled`) this is :meth:`Problem.within_noise`.
    state : LabState

    Returns
    -------
    bool
    """
    if not profiled(problem, state):
        return problem.within_noise(state)
    r, x, k = profile_state(problem, state)
    return (float(r @ r + x @ x) <= problem.noise_chi2() and problem.peak_of(r) <= problem.peak_limit()
            and float(x @ x) <= problem.nuisance_limit(k))


def improves_on_nominal(problem, state: LabState, k: int = 1) -> bool:
    """Whether ``state`` (``k`` parameters fitted) explains ``problem``'s data better than the nominal lab by
    the statistic of the mismatch test that profiles the nominal lab's modes: both labs' modes moved within
    their model form (:func:`profile`), the fall ``S_nominal - S_state`` of ``S = |r|^2 + |x|^2`` must pass the
    policy's likelihood-ratio limit for ``k`` parameters (:meth:`~vlab.diagnose.policy.DecisionPolicy.needed`).
    True where the nominal lab is not profiled (the fit's own footing decides then). Both labs move the same
    parameters (:func:`own_modes`: a lab of a changed structure moves the reference modes as changed by its
    change), so the two statistics are on one footing. The limit is not scaled by an overdispersion: ``S``
    is the tests' statistic, whose weights the mismatch test holds to be the noise and the model form.

    Parameters
    ----------
    problem : Problem
    state : LabState
    k : int
        The parameters ``state`` adds to the nominal lab.

    Returns
    -------
    bool

    Source: the likelihood-ratio test (Wilks 1938) on the profile likelihood of the module notes.
    """
    if not (profiled(problem, problem.base) and profiled(problem, state)):
        return True
    r0, x0 = problem.nominal_profile()
    r, x, _k = profile_state(problem, state)
    return problem.policy.needed(float(r0 @ r0 + x0 @ x0), float(r @ r + x @ x), k)


def moves_left(problem, state: LabState) -> float:
    """First-order estimate of the squared moves ``|x|^2`` that :func:`profile` would need for ``state``:
    the nominal lab's moves (:meth:`Problem.nominal_profile`) less what ``state`` itself moves its modes'
    frequencies and damping ratios, in units of their standard uncertainty (the shapes' moves are kept).
    A cheap ordering of candidates for :func:`within_model_accuracy`, not a test.

    Parameters
    ----------
    problem : Problem
        FRF data with ``model_form_frf``, its nominal lab profiled.
    state : LabState
        A lab of the same structure's points (its own FE modes are computed).

    Returns
    -------
    float
        ``|x_nominal - d|^2`` [1], ``d_i = ln(p_state / p_nominal) / sigma_i`` for each frequency or damping
        parameter ``p`` whose mode both labs have; inf where the modes cannot be computed.
    """
    mf = problem.model_form_frf
    _r, x0 = problem.nominal_profile()
    pts = tuple(dict.fromkeys(tuple(problem.data.output_points) + state.actuators))
    try:
        pm_n = point_modes_of(problem.base, pts, "the nominal FE model")
        pm_s = point_modes_of(state, pts, "the lab's FE model")
    except (ModelError, ValueError, np.linalg.LinAlgError):
        return float("inf")
    d = np.zeros_like(x0)
    for i, ((kind, rn, _j), (_k, rs, _js)) in enumerate(zip(parameters(mf, pm_n), parameters(mf, pm_s))):
        if kind == "phi" or rn is None or rs is None:
            continue
        a, b = (pm_s.omega[rs], pm_n.omega[rn]) if kind == "f" else (pm_s.zeta[rs], pm_n.zeta[rn])
        if a > 0 and b > 0 and mf.sigma[i] > 0:
            d[i] = np.log(a / b) / mf.sigma[i]
    return float(np.sum((x0 - d) ** 2))


def nuisance_test(problem) -> dict | None:
    """Whether the nominal lab's modes must move beyond their model-form uncertainty to fit the data.

    The profiled parameters (:meth:`Problem.nominal_profile`, in units of their standard uncertainty) are,
    under the null hypothesis, about standard normal: ``|x|^2`` is tested against the policy's
    :meth:`~vlab.diagnose.policy.DecisionPolicy.nuisance_limit` (one of its three mismatch tests). The
    total chi-square alone has little power here: eight standard deviations on a few modes add ~200
    to a chi-square of ~1000 residuals, inside its margin.

    Parameters
    ----------
    problem : Problem

    Returns
    -------
    dict or None
        ``nuisance_chi2``, ``nuisance_limit``, ``beyond`` (bool), ``largest`` (label of the parameter
        that moved most), ``largest_sigmas`` (its value in standard uncertainties), ``largest_limit``
        (:meth:`~vlab.diagnose.policy.DecisionPolicy.move_limit`, of its square) and
        ``largest_beyond`` (bool); None without a profiled model form.
    """
    if not problem.profiles(problem.base):
        return None
    _r, x = problem.nominal_profile()
    k, nu = len(x), problem.noise_dof()[0]
    lim, lim1 = problem.nuisance_limit(k), problem.policy.move_limit(k, nu)
    j = int(np.argmax(np.abs(x)))
    c2 = float(x @ x)
    return {"nuisance_chi2": c2, "nuisance_limit": lim, "beyond": c2 > lim,
            "largest": problem.model_form_frf.labels[j], "largest_sigmas": float(x[j]), "largest_limit": lim1,
            "largest_beyond": float(x[j]) ** 2 > lim1}
