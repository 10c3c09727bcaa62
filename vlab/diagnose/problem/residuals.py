"""The fitting problem: weighted residuals of a laboratory state against the measured data.

FRF data (recordings or UFF FRFs): for every usable line and channel the
complex log ratio ``e = ln(H_model / H_measured)`` (real part: log magnitude,
imaginary part: phase, wrapped), each part divided by its standard deviation
``sqrt((sigma_rel^2 + floor_line^2) / 2)``. ``sigma_rel`` is the measured relative
noise of the line (:mod:`vlab.diagnose.data.measured`), ``floor`` a relative model error each modal
term is allowed, ``floor_line`` its effect on the line, larger where the terms cancel
(:mod:`vlab.diagnose.model.cancellation`). Lines with ``sigma_rel > 0.5`` (SNR below 2) are not used. To first
order in the noise the log ratio is the relative complex error, whose parts
over their standard deviations are normal; where the noise is not small its
tail is heavier (``ln(1 + eps)`` as ``|eps|`` nears 1), so every chi-square and
largest line judged against a limit (:meth:`Problem.chi2`, :meth:`Problem.peak` with ``test``) is of the
relative error; the fits and the comparisons between fitted labs keep the log ratio.

Modal data: per measured mode ``ln(f_model / f_meas) / sigma_f``, and when
given ``ln(zeta_model / zeta_meas) / sigma_zeta`` and ``(1 - MAC) / sigma_MAC``
of the shapes. The model's modes are followed through a modification by MAC
against the nominal modes (mode tracking), so measured mode ``n`` is always
compared with the mode that is nominal mode ``n``.

The sum of squares is a chi-square statistic when the weights are the noise: it drives the fits and
the information criteria (:mod:`vlab.diagnose.fit.estimate`) and, with its largest single term
(:meth:`Problem.peak`), decides whether there is a mismatch at all. Its minimum in a stiffness or a mass
of a lightly damped structure is a narrow well; the *smoothed* error (:meth:`Problem.scores`, a Gaussian
in ``ln f`` of :data:`SMOOTH_REL_WIDTH`, which widens every resonance as added damping would) has a broad
minimum near it, which a coarse scan finds.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ...errors import ModelError, SpecError
from ...measure.mac import mac, pair_modes
from ..data.frfestimate import POOL_WIDTH
from ..data.measured import MAX_RELATIVE_NOISE, FrfData, ModalData
from ..data.run import DiagnosisRun
from ..model.cancellation import line_floor as floor_of_lines
from ..model.labmodel import LabState, natural_frequencies, predict_frf
from ..model.modelform import ROUNDING_SIGMA, model_form_uncertainty
from ..policy import DEFAULT_POLICY, DecisionPolicy
from .context import Context
from .forms import PENALTY, line_residual, whitened, whitener
from .misfits import log_misfit
from .nuisance import nuisance_test, own_modes, profile

#: Standard deviation, in ``ln f``, of the Gaussian smoothing of the smoothed error (:meth:`Problem.scores`)
#: (10 %: 0.4 Hz at 4 Hz). A chosen scale, not fitted: ten half-power bandwidths of a 0.5 % damped mode.
SMOOTH_REL_WIDTH = 0.1


class Problem:
    """Residuals of lab states against one data set.

    Parameters
    ----------
    data : FrfData or ModalData
    base : LabState
        The nominal lab.
    ctx : Context
    floor : float
        Relative model error allowed each modal term of an FRF [1] (0.005 = 0.5 %).
    line_floor : ndarray, shape (n_f, n_o), optional
        The relative model error each line is allowed [1]: default ``floor`` amplified where the terms of
        ``base`` cancel (:func:`vlab.diagnose.model.cancellation.line_floor`); given, that of another
        problem on the same data (a plant refit compares chi-squares with the FE problem's). Another shape
        raises ValueError.
    use_phase : bool
        Include the phase of FRFs.
    freq_sigma : float, optional
        Relative standard deviation of a measured natural frequency (modal data) [1]; default: the
        table's ``frequency_sigma_hz`` column, else the printed rounding of each frequency.
    damping_sigma : float, optional
        Relative standard deviation of a measured damping ratio (modal data) [1]; default: the
        table's ``damping_sigma`` column, else the printed rounding of each ratio.
    shape_sigma : float
        Standard deviation of ``1 - MAC`` of a measured shape (modal data).
    model_form_frf : FrfModelForm, optional
        FRF data: the model-form uncertainty of the nominal model's FRFs, a low-rank covariance
        (:func:`vlab.diagnose.model.modelform.frf_model_form`): the residuals are whitened by the
        full covariance, noise and floor (per line) plus the model form (correlated across lines), so
        that their sum of squares is chi-square with N degrees of freedom under the null; None: none
        (the data are known to come from the model itself).
    modal_model_form : bool
        Modal data: weigh each residual by the model-form uncertainty too (False: measurement only).
    profile_nominal : bool
        FRF data with a model form: the nominal lab's chi-square and largest line (:meth:`chi2`,
        :meth:`peak` of ``base``) are those of its modes' most likely frequencies and damping within their
        model-form uncertainty (:meth:`nominal_profile`, nonlinear), not of the linear whitening: a
        frequency error of a mode with 0.1 % damping moves its peak lines far beyond first order.
    profile_start : ndarray, shape (k,), optional
        Start of :meth:`nominal_profile`'s search [standard uncertainties]: a nearby problem's optimum
        (:mod:`vlab.diagnose.thresholds`); default 0.
    policy : DecisionPolicy
        Every limit of the decision (:mod:`vlab.diagnose.policy`; default: a false-alarm rate of 1 %).
    run : DiagnosisRun, optional
        The run context whose reruns the problem's recording is played back into
        (:mod:`vlab.diagnose.data.run`; default: a new, empty one).
    guard_s : float, optional
        Time before the analysed records that a rerun must start at, at least [s]
        (:func:`vlab.diagnose.data.replay.rerun_window`; None: its default).
    replay_plant : {"linear", "mujoco"}, optional
        The plant the reference was replayed on (None: no replay; the data are compared with the FE model
        or a measured baseline).

    Attributes
    ----------
    n_obs : int
        Number of real residuals N.
    freq_sigma_meas, freq_sigma_model : ndarray, shape (n_m,)
        Modal data: the measurement and model-form parts of each frequency's relative standard
        uncertainty (:mod:`vlab.diagnose.model.modelform`); a residual is weighted by their root sum
        of squares.
    damping_sigma_meas, damping_sigma_model : ndarray, shape (n_m,)
        The same for each damping ratio (the model part inf where the spec assumes the damping:
        that residual is then not compared).
    freq_sigma_total, damping_sigma_total : ndarray, shape (n_m,)
        Their root sums of squares (the weights).
    damping_compared : ndarray of bool, shape (n_m,)
        Modes whose damping enters the residual.
    model_form : ModelFormUncertainty
        Modal data: the model-form uncertainty of the nominal model's modes.
    """

    def __init__(self, data: FrfData | ModalData, base: LabState, ctx: Context, *, floor: float = 0.005,
                 use_phase: bool = True, freq_sigma: float | None = None, damping_sigma: float | None = None,
                 shape_sigma: float = 0.05, model_form_frf=None, modal_model_form: bool = True,
                 profile_nominal: bool = False, policy: DecisionPolicy = DEFAULT_POLICY,
                 run: DiagnosisRun | None = None, guard_s: float | None = None, replay_plant: str | None = None,
                 line_floor: np.ndarray | None = None, profile_start: np.ndarray | None = None):
        self.data, self.base, self.ctx = data, base, ctx
        self.policy = policy
        self.run = DiagnosisRun() if run is None else run
        self.guard_s, self.replay_plant = guard_s, replay_plant
        self.floor, self.use_phase = float(floor), bool(use_phase)
        self.freq_sigma, self.damping_sigma, self.shape_sigma = freq_sigma, damping_sigma, shape_sigma
        self.n_evaluations, self.modal_model_form = 0, bool(modal_model_form)
        self.model_form_frf, self.model_var, self._whiten = None, None, None
        self.profile_nominal, self._profile, self.profile_start = bool(profile_nominal), None, profile_start
        self.model_form = None  # the ModelFormUncertainty behind model_var (set by whoever computed it)
        self._base_scores: tuple[float, float] | None = None  # scores of the nominal lab (:meth:`base_scores`)
        self._smooth = None  # kernel of the smoothed error, made on first use (:meth:`_smoother`)
        self._fitted: dict = {}  # (id(hyp), params) -> (hyp, state) (:meth:`fitted_state`)
        if isinstance(data, FrfData):
            srel = data.sigma_rel
            self.mask = (srel <= MAX_RELATIVE_NOISE) & (np.abs(data.h) > 0)
            if self.mask.sum() < 3:
                raise ModelError(f"{data.source}: fewer than three lines with a signal-to-noise ratio above 2")
            self.model_form_frf = model_form_frf
            self.model_var = None if model_form_frf is None else model_form_frf.variance
            mv = 0.0 if self.model_var is None else self.model_var
            fl = np.asarray(line_floor, dtype=float) if line_floor is not None else floor_of_lines(
                base, data.freq_hz, self.floor, excitation_point=data.excitation_point,
                output_points=data.output_points)
            if fl.shape != data.h.shape:
                raise ValueError(f"line_floor has shape {fl.shape}, the data's FRFs {data.h.shape}")
            self.line_floor = fl
            self.part_sigma = np.sqrt((srel**2 + fl**2) / 2.0)[self.mask]
            self.weight_mag = 1.0 / (srel**2 + fl**2 + mv)
            self._whiten = self._whitener()
            self.n_obs = int(self.mask.sum()) * (2 if use_phase else 1)
        else:
            self._nominal_modes(base)
            if data.reference_hz is not None:
                self.data = data = self._referred(data)
            self._modal_sigmas(base)
            n = len(data.freq_hz)
            self.n_obs = n + int(self.damping_compared.sum()) + (n if data.shapes is not None else 0)

    def _whitener(self, part_sigma: np.ndarray | None = None):
        """The model form's whitener for parts of standard deviation ``part_sigma`` (default the data's),
        :func:`.forms.whitener`; None without model form."""
        mf = self.model_form_frf
        if mf is None:
            return None
        ps = self.part_sigma if part_sigma is None else part_sigma
        return whitener(mf.sens[self.mask], mf.sigma, ps, self.use_phase)

    # ------------------------------------------------------------------ modal helpers
    def _nominal_modes(self, base: LabState) -> None:
        data: ModalData = self.data
        n_need = int(max(data.modes)) + 4
        f, z, phi = natural_frequencies(base, n_need)
        if len(f) < int(max(data.modes)):
            raise ModelError(f"{data.source}: mode {int(max(data.modes))} asked for, the model has {len(f)} modes")
        self._n_track = min(n_need, len(f))
        self._labels0 = base.fe.dofs.labels
        self._phi0 = phi
        self._nominal_f = f
        self._nominal_z = z
        if data.shapes is not None:
            rows = [base.fe.dofs.index(p, "w") for p in data.shape_points]
            m = mac(phi[rows, :], data.shapes)
            pairs = pair_modes(m)
            self._meas_to_nominal = {j: i for i, j, _ in pairs}
        else:
            self._meas_to_nominal = {j: int(data.modes[j]) - 1 for j in range(len(data.modes))}

    def _referred(self, d: ModalData) -> ModalData:
        """The table referred to the model through its reference column: ``f_meas * f_model / f_reference``.

        The reference model's own difference from vlab's nominal model (its calibration residual) cancels,
        as the nominal plant's does when a recording is referred through its replay; what remains to explain
        is the measured change from the reference, and vlab's model predicts what an effect changes. The
        relative uncertainties of the measured and the reference frequency add in quadrature (each from its
        ``frequency_sigma_hz`` column or its printed rounding)."""
        f_nom = np.array([self._nominal_f[self._meas_to_nominal[j]] if j in self._meas_to_nominal else np.nan
                          for j in range(len(d.freq_hz))])
        with np.errstate(invalid="ignore"):
            rel_m = (d.freq_sigma_hz / d.freq_hz if d.freq_sigma_hz is not None else np.full(len(d.freq_hz), np.nan))
        rel_m = np.where(np.isfinite(rel_m), rel_m, ROUNDING_SIGMA * d.freq_resolution_hz / d.freq_hz)
        rel_r = ROUNDING_SIGMA * d.reference_resolution_hz / d.reference_hz
        f = d.freq_hz * f_nom / d.reference_hz
        if not np.all(np.isfinite(f)):
            raise ModelError(f"{d.source}: a mode of the table could not be paired with the model's")
        return replace(d, freq_hz=f, freq_sigma_hz=f * np.hypot(rel_m, rel_r), reference_hz=None,
                       notes=list(d.notes) + [f"frequencies referred to the model through the column "
                                              f"{d.reference_column!r}: f_measured * f_model / f_reference"])

    def _modal_sigmas(self, base: LabState) -> None:
        """Measurement and model-form standard uncertainties of every modal residual (relative)."""
        d: ModalData = self.data
        n = len(d.freq_hz)

        def measured(override, sigma, resolution, value):
            if override is not None:
                return np.full(n, float(override))
            out = np.full(n, np.nan)
            if sigma is not None:
                out = np.asarray(sigma, dtype=float) / value
            if resolution is not None:
                out = np.where(np.isfinite(out), out, ROUNDING_SIGMA * np.asarray(resolution, dtype=float) / value)
            return np.where(np.isfinite(out), out, 0.0)

        with np.errstate(divide="ignore", invalid="ignore"):
            self.freq_sigma_meas = measured(self.freq_sigma, d.freq_sigma_hz, d.freq_resolution_hz, d.freq_hz)
            self.damping_sigma_meas = measured(self.damping_sigma, d.damping_sigma, d.damping_resolution, d.damping)
        self.model_form = model_form_uncertainty(base.spec, self._nominal_f)
        if not self.modal_model_form:
            for k in ("calibration", "discretisation"):
                self.model_form = self.model_form.without(k, "not used: the data are known to come from the model")
        if d.reference_column is not None:  # referred: the reference's calibration residual cancels
            self.model_form = self.model_form.without("calibration", f"cancels: compared with the reference column "
                                                                     f"{d.reference_column!r}")
        idx = np.array([self._meas_to_nominal.get(j, -1) for j in range(n)])
        ok = idx >= 0
        self.freq_sigma_model = np.where(ok, self.model_form.frequency_rel[np.maximum(idx, 0)], 0.0)
        self.damping_sigma_model = np.where(ok, self.model_form.damping_rel[np.maximum(idx, 0)], np.inf)
        self.freq_sigma_total = np.hypot(self.freq_sigma_meas, self.freq_sigma_model)
        if np.any(self.freq_sigma_total <= 0):
            raise ModelError(f"{d.source}: a natural frequency with zero uncertainty (give frequency_sigma_hz)")
        self.damping_sigma_total = np.hypot(self.damping_sigma_meas, self.damping_sigma_model)
        # damping residuals: where the table gives a ratio and the model states one (not an assumed default)
        self.damping_compared = np.isfinite(d.damping) & (d.damping > 0) & np.isfinite(self.damping_sigma_total) & (self.damping_sigma_total > 0)

    def uncertainty(self) -> dict:
        """What the residuals are weighted by, and which part dominates.

        Returns
        -------
        dict
            Modal data: per measured mode ``frequency_sigma_measurement_rel``,
            ``frequency_sigma_model_form_rel``, ``damping_sigma_measurement_rel``,
            ``damping_sigma_model_form_rel`` (relative [1]; None where not
            compared), the model-form ``sources`` and ``dominant``
            (``"measurement"`` or ``"model form"``, by the summed variances of the
            frequencies). FRF data: ``noise_sigma_median_rel`` (median relative
            noise of the used lines), ``model_floor_rel`` (the relative model
            error allowed a line) and ``dominant`` (``"noise"`` or ``"model form"``).
        """
        if isinstance(self.data, FrfData):
            med = float(np.median(self.data.sigma_rel[self.mask]))
            mf = 0.0 if self.model_var is None else float(np.median(np.sqrt(self.model_var[self.mask])))
            mx = 0.0 if self.model_var is None else float(np.max(np.sqrt(self.model_var[self.mask])))
            model = math.hypot(self.floor, mf)
            return {"noise_sigma_median_rel": med, "model_floor_rel": self.floor,
                    "model_form_sigma_median_rel": mf, "model_form_sigma_max_rel": mx,
                    "model_form": "none (data from the model itself)" if self.model_var is None else "derived",
                    "sources": {} if self.model_form is None else dict(self.model_form.sources),
                    "nominal_profile": nuisance_test(self),
                    "dominant": "model form" if model > med else "noise"}
        zc = self.damping_compared
        return {"modes": [int(m) for m in self.data.modes],
                "frequency_sigma_measurement_rel": self.freq_sigma_meas.tolist(),
                "frequency_sigma_model_form_rel": self.freq_sigma_model.tolist(),
                "damping_sigma_measurement_rel": [float(v) if c else None for v, c in zip(self.damping_sigma_meas, zc)],
                "damping_sigma_model_form_rel": [float(v) if c else None for v, c in zip(self.damping_sigma_model, zc)],
                "sources": dict(self.model_form.sources),
                "dominant": ("model form" if np.sum(self.freq_sigma_model**2) > np.sum(self.freq_sigma_meas**2)
                             else "measurement")}

    def model_modes(self, state: LabState) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """Frequencies [Hz], damping ratios and shapes at the measured points of the modes of ``state``
        paired with each measured mode (NaN where no mode could be paired).

        Returns
        -------
        freq_hz, zeta : ndarray, shape (n_m,)
        shapes : ndarray, shape (n_p, n_m) or None
        """
        data: ModalData = self.data
        f, z, phi = natural_frequencies(state, self._n_track + 2)
        labels = state.fe.dofs.labels
        if labels == self._labels0:
            a, b = self._phi0, phi
        else:
            idx = {lab: i for i, lab in enumerate(labels)}
            common = [(i, idx[lab]) for i, lab in enumerate(self._labels0) if lab in idx]
            a = self._phi0[[i for i, _ in common], :]
            b = phi[[j for _, j in common], :]
        m = mac(a, b)
        track = {i: j for i, j, _ in pair_modes(m)}
        n = len(data.freq_hz)
        fo, zo = np.full(n, np.nan), np.full(n, np.nan)
        so = None if data.shapes is None else np.full((len(data.shape_points), n), np.nan)
        rows = [state.fe.dofs.index(p, "w") for p in data.shape_points] if data.shapes is not None else []
        for jm in range(n):
            i0 = self._meas_to_nominal.get(jm)
            jj = track.get(i0) if i0 is not None else None
            if jj is None:
                continue
            fo[jm], zo[jm] = f[jj], z[jj]
            if so is not None:
                so[:, jm] = phi[rows, jj]
        return fo, zo, so

    # ------------------------------------------------------------------ core
    def state_for(self, hyp, x) -> LabState:
        """The lab with hypothesis ``hyp`` of size ``x`` [SI] (the nominal lab for None).

        ``hyp`` is a :class:`~vlab.diagnose.effects.hypothesis.Hypothesis` or None; only its
        ``apply(state, x, ctx)`` is used, so the problem layer does not import the library above it.
        """
        if hyp is None:
            return self.base
        return hyp.apply(self.base, np.asarray(x, dtype=float), self.ctx)

    def __getstate__(self) -> dict:
        """The problem without its fitted-state memo (a worker process rebuilds what it asks for)."""
        return {**self.__dict__, "_fitted": {}}

    def fitted_state(self, hyp) -> LabState:
        """:meth:`state_for` at ``hyp.params_``, one object while they stay (a choice's tests ask it again)."""
        key = (id(hyp), np.asarray(hyp.params_, dtype=float).tobytes())
        if key not in self._fitted or self._fitted[key][0] is not hyp:
            self._fitted[key] = (hyp, self.state_for(hyp, hyp.params_))
        return self._fitted[key][1]

    def predict(self, state: LabState) -> np.ndarray:
        """FRFs of the lab ``state`` on the data's lines, shape (n_f, n_o) (FRF data)."""
        d: FrfData = self.data
        return predict_frf(state, d.freq_hz, excitation_point=d.excitation_point, output_points=d.output_points)

    def residual(self, state: LabState, *, test: bool = False) -> np.ndarray:
        """Weighted residuals of the lab ``state``, shape (n_obs,): FRF data's log ratio (the fits'), with
        ``test`` its relative error (the statistics', :mod:`.forms`). A model that cannot be built gives a
        large constant."""
        self.n_evaluations += 1
        try:
            if isinstance(self.data, FrfData):
                return self._frf_residual(self.predict(state), test)
            r = self._modal_residual(state)
        except (ModelError, SpecError, np.linalg.LinAlgError, ValueError):
            return np.full(self.n_obs, PENALTY)
        return np.where(np.isfinite(r), r, PENALTY)

    def frf_chi2(self, h: np.ndarray, extra_var: np.ndarray | None = None) -> float:
        """Chi-square [1] of FRFs ``h`` (shape (n_f, n_o), [(m/s)/N], compared with ``data.h``) on the fits'
        footing: ``|r|^2`` of :meth:`frf_residual` with its ``extra_var``. Raises ValueError for another shape."""
        r = self.frf_residual(h, extra_var)
        return float(r @ r)

    def frf_residual(self, h: np.ndarray, extra_var: np.ndarray | None = None, *, test: bool = False) -> np.ndarray:
        """Weighted residuals of FRFs ``h`` (shape (n_f, n_o), [(m/s)/N], compared with ``data.h``), shape
        (n_obs,): the noise, the floor and the whitened model form of :meth:`chi2` (FRF data only), with
        ``extra_var`` (shape (n_f, n_o), a relative complex variance [1] per line, e.g. a rerun plant's own
        uncertainty) added to each line's noise; the fits' log ratio, with ``test`` the tests' relative error
        (:mod:`.forms`: the form :meth:`peak_limit` and :meth:`noise_chi2` hold for); a line that is not
        finite counts as :meth:`residual`'s does. Raises ValueError for another shape."""
        h = np.asarray(h)
        if h.shape != self.data.h.shape:
            raise ValueError(f"FRFs of shape {h.shape} compared with data of shape {self.data.h.shape}")
        if extra_var is None:
            r = self._frf_residual(h, test)
        else:
            ps = np.sqrt(self.part_sigma**2 + np.asarray(extra_var, dtype=float)[self.mask] / 2.0)
            r = line_residual(h[self.mask], self.data.h[self.mask], ps, form="relative" if test else "log",
                              use_phase=self.use_phase)
            r = whitened(r, self._whitener(ps))
        return np.where(np.isfinite(r), r, PENALTY)

    def _frf_residual(self, hm: np.ndarray, test: bool = False) -> np.ndarray:
        r = self.line_residual(hm[self.mask], test=test)
        return whitened(r, getattr(self, "_whiten", None))

    def _modal_residual(self, state: LabState) -> np.ndarray:
        d: ModalData = self.data
        fo, zo, so = self.model_modes(state)
        parts = [np.log(fo / d.freq_hz) / self.freq_sigma_total]
        nz = self.damping_compared  # a damping the model only assumes is not compared
        if nz.any():
            parts.append(np.log(zo[nz] / d.damping[nz]) / self.damping_sigma_total[nz])
        if d.shapes is not None:
            macs = np.array([mac(so[:, j], d.shapes[:, j])[0, 0] if np.all(np.isfinite(so[:, j])) else 0.0
                             for j in range(len(d.freq_hz))])
            parts.append((1.0 - macs) / self.shape_sigma)
        return np.concatenate(parts)

    def chi2(self, state: LabState, *, test: bool = False) -> float:
        """Sum of squared weighted residuals of the lab ``state``: on the fits' footing (the log ratio), with
        ``test`` the statistic a limit judges (the relative error, :mod:`.forms`; for the nominal lab with
        ``profile_nominal`` of its profile, with the nuisance parameters' penalty, :meth:`nominal_profile`)."""
        if test and self.profiles(state):
            r, x = self.nominal_profile()
            return float(r @ r + x @ x)
        r = self.residual(state, test=test)
        return float(r @ r)

    def profiles(self, state: LabState) -> bool:
        """Whether ``state``'s test statistics are :meth:`nominal_profile`'s (the nominal lab, profiled)."""
        return (self.profile_nominal and state is self.base and self.model_form_frf is not None
                and self.model_form_frf.sigma.size > 0)

    def nominal_profile(self) -> tuple[np.ndarray, np.ndarray]:
        """The nominal lab's residual at its modes' most likely frequencies and damping ratios.

        ``min_x |r(x)|^2 + |x|^2`` over the model-form parameters of :attr:`model_form_frf` (each mode's
        frequency or damping ratio scaled by ``exp(sigma_k x_k)``, ``x_k`` in units of its standard
        uncertainty), ``r`` the residual weighted by the noise and the floor alone: the nuisance parameters
        profiled out (nonlinear least squares, scipy.optimize.least_squares). Under the null hypothesis
        (the structure is the model within its model-form uncertainty) the minimum is about chi-square with
        N degrees of freedom (exactly so for a linear model). Cached.

        Returns
        -------
        r : ndarray, shape (n_obs,)
            The residual at the optimum (not whitened).
        x : ndarray, shape (k,)
            The parameters' most likely values in units of their standard uncertainty.
        """
        if self._profile is not None:
            return self._profile
        # the nominal prediction changed as the perturbed modes change theirs
        pm0, scale = own_modes(self, self.base)
        self._profile = profile(self, self.base, pm0, scale, start=self.profile_start)
        return self._profile

    def line_residual(self, h_used: np.ndarray, *, test: bool = False) -> np.ndarray:
        """Residual of predicted FRFs weighted by the noise and the floor alone, not whitened by the model
        form, shape (n_obs,): the log ratio, with ``test`` the relative error (:mod:`.forms`).

        Parameters
        ----------
        h_used : ndarray, complex, shape (n_used,)
            Predicted FRFs on the used lines and channels [(m/s)/N].
        test : bool
            The tests' form instead of the fits'.
        """
        return line_residual(h_used, self.data.h[self.mask], self.part_sigma, form="relative" if test else "log",
                             use_phase=self.use_phase)

    def _smoother(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Kernel ``W`` (n_f, n_f), its masked row sums (n_f, n_o) and the smoothed data (n_f, n_o), cached."""
        if self._smooth is None:
            lf = np.log(np.maximum(self.data.freq_hz, 1e-9))
            w = np.exp(-0.5 * ((lf[:, None] - lf[None, :]) / SMOOTH_REL_WIDTH) ** 2)
            m = self.mask.astype(float)
            norm = np.maximum(w @ m, 1e-300)
            self._smooth = (w, norm, (w @ (m * self.data.h)) / norm)
        return self._smooth

    def base_scores(self) -> tuple[float, float]:
        """:meth:`scores` of the nominal lab ``base``, computed once (the screening's value at an effect's null).

        Returns
        -------
        (float, float)
            Its chi-square [1] and smoothed error (as :meth:`scores`).
        """
        if self._base_scores is None:
            self._base_scores = self.scores(self.base)
        return self._base_scores

    def scores(self, state: LabState) -> tuple[float, float]:
        """``(chi2, smoothed error)`` of the lab ``state`` from one prediction.

        The smoothed error is the RMS of ``ln|S H_model / S H_measured|`` over
        the used lines and channels, ``S`` the complex frequency smoothing of
        :data:`SMOOTH_REL_WIDTH` (only the used lines enter it): a guide for
        scanning one parameter, not a statistic (see the module docstring).
        For modal data it is the chi-square. A model that cannot be built
        gives ``(chi2 of the penalty, inf)``.
        """
        if not isinstance(self.data, FrfData):
            c = self.chi2(state)
            return c, c
        self.n_evaluations += 1
        try:
            hm = self.predict(state)
        except (ModelError, SpecError, np.linalg.LinAlgError, ValueError):
            return float(self.n_obs * PENALTY**2), float("inf")
        r = self._frf_residual(hm)
        w, norm, sd = self._smoother()
        sm = (w @ (self.mask * hm)) / norm
        with np.errstate(divide="ignore", invalid="ignore"):
            e = np.log(np.abs(sm[self.mask] / sd[self.mask]))
        smooth = float(np.sqrt(np.mean(e**2))) if np.all(np.isfinite(e)) else float("inf")
        return float(r @ r), smooth

    def misfit(self, state: LabState) -> float:
        """Misfit of the lab ``state``.

        FRF data: weighted RMS of ``log10|H_model / H_meas|`` [decades] (weights ``weight_mag``); modal data:
        RMS of ``ln(f_model / f_meas)``."""
        try:
            if isinstance(self.data, FrfData):
                hm = self.predict(state)
                return log_misfit(hm[self.mask], self.data.h[self.mask], self.weight_mag[self.mask])
            fo, _, _ = self.model_modes(state)
            e = np.log(fo / self.data.freq_hz)
            e = e[np.isfinite(e)]
            return float(np.sqrt(np.mean(e**2))) if e.size else float("nan")
        except (ModelError, SpecError, np.linalg.LinAlgError, ValueError):
            return float("nan")

    def noise_dof(self) -> tuple[float | None, int]:
        """``(nu, shared)``: the degrees of freedom of the data's estimated noise variance (None: known or
        none) and how many real residuals share one estimate (a pool of lines, times 2 with phase)."""
        nu = getattr(self.data, "var_dof", None) if isinstance(self.data, FrfData) else None
        lines = min(POOL_WIDTH, self.data.h.shape[0]) if isinstance(self.data, FrfData) else POOL_WIDTH
        return nu, lines * (2 if self.use_phase else 1)

    def noise_chi2(self) -> float:
        """Largest chi-square the nominal model may have for the data to count as 'within the noise' [1]:
        the policy's :meth:`~vlab.diagnose.policy.DecisionPolicy.chi2_limit` of :attr:`n_obs` residuals,
        with the degrees of freedom of an estimated noise variance (:attr:`FrfData.var_dof`)."""
        nu, shared = self.noise_dof()
        if nu is not None and nu <= 4:  # a few lines pooled: no finite variance for the Satterthwaite form
            return self.policy.chi2_limit_simulated(self.n_obs, nu, shared)
        return self.policy.chi2_limit(self.n_obs, nu, shared)

    def nuisance_limit(self, k: int) -> float:
        """Largest ``|x|^2`` of ``k`` profiled model-form parameters under the null [1]
        (:meth:`~vlab.diagnose.policy.DecisionPolicy.nuisance_limit` with the data's ``nu``)."""
        return self.policy.nuisance_limit(k, self.noise_dof()[0])

    def peak(self, state: LabState, *, test: bool = False) -> float:
        """Largest squared residual of one observation of the lab ``state``: for FRF data the largest
        ``re^2 + im^2`` of one line and channel (chi-square with 2 degrees of freedom under noise, 1 without
        phase), for modal data the largest squared residual. A local mismatch (one resonance of a
        top-beam segment) can stand far out of the noise while adding little to the total chi-square. ``test``
        as in :meth:`chi2`."""
        if test and self.profiles(state):
            return self.peak_of(self.nominal_profile()[0])
        return self.peak_of(self.residual(state, test=test))

    def peak_of(self, r: np.ndarray) -> float:
        """Largest squared residual of one observation in the residual vector ``r`` (shape (n_obs,)): of one
        line and channel, real and imaginary parts together, for FRF data with phase (see :meth:`peak`)."""
        if isinstance(self.data, FrfData) and self.use_phase:
            n = r.size // 2
            r2 = r[:n] ** 2 + r[n:] ** 2
        else:
            r2 = r**2
        return float(np.max(r2))

    def peak_limit(self) -> float:
        """Largest :meth:`peak` the nominal model may have for the data to count as 'within the noise' [1].

        The policy's :meth:`~vlab.diagnose.policy.DecisionPolicy.line_limit` over the ``n`` observations
        (Šidák: the chance that the largest of ``n`` independent noise-only residuals exceeds it is the
        test's rate); ``dof`` = 2 for FRF lines with phase, else 1; ``dof F(dof, nu)`` with a noise variance
        estimated with ``nu`` degrees of freedom (:attr:`FrfData.var_dof`)."""
        if isinstance(self.data, FrfData) and self.use_phase:
            n, dof = self.n_obs // 2, 2
        else:
            n, dof = self.n_obs, 1
        return self.policy.line_limit(n, dof, getattr(self.data, "var_dof", None))

    def within_noise(self, state: LabState) -> bool:
        """Whether the lab ``state`` explains the data within the noise: its chi-square is within
        :meth:`noise_chi2` and no single observation exceeds :meth:`peak_limit`."""
        return self.chi2(state, test=True) <= self.noise_chi2() and self.peak(state, test=True) <= self.peak_limit()

    def information(self, chi2: float, k: int) -> tuple[float, float]:
        """``(AIC, BIC) = (chi2 + 2k, chi2 + k ln N)`` (Akaike 1974; Schwarz 1978)."""
        return chi2 + 2.0 * k, chi2 + k * math.log(self.n_obs)
