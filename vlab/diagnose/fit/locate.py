"""Locating a mismatch: which modes, which sensors, which band, which loop, where on the structure.

- **Modes**: resonances are picked on the mode indicator ``sum_o |H_o|^2`` of
  the measured and of the predicted FRFs, paired by frequency, and each
  pair is curve-fitted on its strongest channel
  (:func:`vlab.measure.fit_modes`): frequency, damping and peak-level
  errors (a fit that converged on another resonance's peak is replaced by
  the picked peak, with no damping). A mode is flagged when the weighted residual of the lines around
  it exceeds the noise (mean chi-square per real residual above 4).
  Modal tables are compared mode by mode directly.
- **Sensors**: mean chi-square per channel (per-channel FRF error) and
  COMAC of the paired modes (Lieven & Ewins 1988, :func:`vlab.measure.comac`).
- **Band**: the span of lines whose residual exceeds the noise.
- **Where**: sensitivity-based error localisation (Friswell & Mottershead,
  *Finite Element Model Updating in Structural Dynamics*, 1995, Sec. 7.3
  and ch. 8; the "best subset" single-parameter criterion of Lallement &
  Piranda, IMAC 8 (1990) 579-585): the sensitivities ``S_rj = d ln f_r / d
  p_j`` of the natural frequencies to a local mass, a grounded spring, a
  joint flexibility and each member segment's rigidity are computed by
  perturbing the spec; for each candidate the measured frequency errors
  ``delta_r = ln(f_meas / f_pred)`` are fitted by that one column and the
  share of ``|delta|^2`` it explains ranks the candidates.
- **Loop**: "open" for open-loop data; for closed-loop data "closed" when
  the explaining effect acts only in the controller path (delay, sensor
  lag or gain) and "both" when it is in the structure or the actuators
  (decided in :mod:`vlab.diagnose.pipeline` once effects are fitted).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ...errors import MeasurementError, ModelError, SpecError
from ...measure.mac import comac, mac, pair_modes
from ...measure.modal import find_peaks, peak_levels
from ...measure.modal_fit import fit_modes
from ..data.measured import FrfData
from ..effects import specedit
from ..model.labmodel import LabState, natural_frequencies, predict_frf
from ..problem.context import Context
from ..problem.misfits import log_misfit
from ..problem.residuals import Problem
from .resonances import unpaired_peaks

#: Mean chi-square per real residual above which lines, modes or channels count as mismatched.
FLAG = 4.0


@dataclass
class ModeError:
    """Predicted vs measured parameters of one mode.

    ``freq_error`` and ``damping_error`` are relative (measured / predicted - 1);
    ``peak_ratio`` is predicted / measured peak level (Tables 10, 19-21);
    ``chi2_per_residual`` is the mean weighted squared residual near the mode.

    Attributes
    ----------
    mode : int
    freq_predicted_hz, freq_measured_hz : float
        [Hz].
    damping_predicted, damping_measured : float
    peak_ratio : float
    channel : int or None
        Output point the mode was fitted on.
    chi2_per_residual : float
    flagged : bool
        Mismatched (``chi2_per_residual > FLAG``).
    """

    mode: int
    freq_predicted_hz: float
    freq_measured_hz: float
    damping_predicted: float
    damping_measured: float
    peak_ratio: float = float("nan")
    channel: int | None = None
    chi2_per_residual: float = float("nan")
    flagged: bool = False

    @property
    def freq_error(self) -> float:
        """``f_meas / f_pred - 1``."""
        return self.freq_measured_hz / self.freq_predicted_hz - 1.0

    @property
    def damping_error(self) -> float:
        """``zeta_meas / zeta_pred - 1``."""
        return self.damping_measured / self.damping_predicted - 1.0

    def as_dict(self) -> dict:
        """JSON-ready."""
        return {"mode": self.mode, "frequency_predicted_hz": self.freq_predicted_hz,
                "frequency_measured_hz": self.freq_measured_hz, "frequency_error": self.freq_error,
                "damping_predicted": self.damping_predicted, "damping_measured": self.damping_measured,
                "damping_error": self.damping_error, "peak_ratio": self.peak_ratio, "channel": self.channel,
                "chi2_per_residual": self.chi2_per_residual, "mismatch": self.flagged}


@dataclass
class Location:
    """Everything :func:`locate` found (see the module docstring).

    Attributes
    ----------
    modes : list of ModeError
    channels : dict
        Output point -> {"chi2_per_residual", "misfit_decades", "comac"}.
    band_hz : list of float or None
        ``[low, high]`` of the mismatched lines [Hz].
    sensitivity : list of dict
        Candidates ranked by the share of the frequency errors they explain:
        ``{"parameter", "point"/"member"/"segment", "explained"}``.
    extra : list of dict
        Resonances of the data the nominal lab does not have (:func:`extra_resonances`).
    points, members : list
        Located points (ids) and members (``"member"`` or ``"member[a-b]"``).
    places : frozenset of int
        The points the first-order localisation points at (:func:`located_point_ids`): the located points
        and the end points of the located segments.
    """

    modes: list = field(default_factory=list)
    channels: dict = field(default_factory=dict)
    band_hz: list | None = None
    sensitivity: list = field(default_factory=list)
    points: list = field(default_factory=list)
    members: list = field(default_factory=list)
    extra: list = field(default_factory=list)
    places: frozenset = frozenset()


# ----------------------------------------------------------------------------- modes
def _mif(h: np.ndarray) -> np.ndarray:
    return np.sqrt(np.sum(np.abs(h) ** 2, axis=1))


def _at_own_peak(f_fit: float, peaks_hz: np.ndarray, j: int) -> bool:
    """Whether a curve-fitted frequency ``f_fit`` [Hz] stayed at its own picked peak ``peaks_hz[j]``: nearer it
    than half the distance to the nearest other picked peak (``peaks_hz``, shape (n,), [Hz]).

    A single-mode fit of a heavily damped mode spans its neighbours (three half-power bandwidths of a
    damping ratio of 0.13 at 1.62 Hz reach from 0.4 to 2.9 Hz) and can converge onto the next resonance:
    on the MuJoCo grid the grid's mode 3, picked at 1.625 Hz, was fitted at
    2.745 Hz, mode 4's peak, and its frequency error (+67 %) then drove the sensitivity ranking (the
    grounded spring that explained it best "explained" 51 % and pruned the true one away)."""
    if not np.isfinite(f_fit):
        return False
    others = np.delete(np.asarray(peaks_hz, dtype=float), j)
    if others.size == 0:
        return True
    return abs(f_fit - peaks_hz[j]) < 0.5 * float(np.min(np.abs(others - peaks_hz[j])))


def _referred_mode(d: FrfData, ch: int, f_rec: float, f_base: float, pred: tuple[float, float],
                   half_hz: float, reach_hz: float) -> tuple[float, float, float] | None:
    """A mode of FRF data referred through a baseline or replay (``H = H_rec H_model / H_base``,
    :func:`vlab.diagnose.data.measured.refer_to_model`), its modal parameters referred instead of its lines:
    the recorded and the baseline FRFs each curve-fitted at their own peak on channel ``ch`` (the largest
    line within ``reach_hz`` of the guesses ``f_rec``, ``f_base`` [Hz]: half the way to the model's next
    resonance), and ``f = f_model f_rec / f_base``, ``zeta = zeta_model zeta_rec / zeta_base``, peak ratio
    ``peak_base / peak_rec`` (peak levels as measured, :func:`vlab.measure.modal.peak_levels`; ``pred``: the
    model's fitted ``(f, zeta)``; ``half_hz``: the peak-level band [Hz]).

    The line-by-line referral is exact to first order only where ``H_model / H_base`` is near one; at a
    lightly damped mode that the baseline's plant places more than a half-power bandwidth off the model's
    (a MuJoCo plant's mode 6 of the BCC 0.4 % above the FE model's, its bandwidth 0.2 %), the referred lines
    carry the two plants' resonances and a fit on them reads a damping three times too small. The ratio of
    the two fits is the same referral, made on the poles.

    Returns
    -------
    (float, float, float) or None
        Frequency [Hz], damping ratio [1] and peak ratio (predicted / measured) [1]; None where a fit
        fails or leaves its own peak.
    """
    f = d.freq_hz

    def own_peak(h: np.ndarray, guess: float) -> float:
        near = np.abs(f - guess) <= reach_hz
        return float(f[near][np.argmax(np.abs(h[near, ch]))]) if near.any() else guess

    peaks = own_peak(d.h_recorded, f_rec), own_peak(d.h_baseline, f_base)
    try:
        rec = fit_modes(f, d.h_recorded[:, ch], [peaks[0]], name=d.source)[0]
        base = fit_modes(f, d.h_baseline[:, ch], [peaks[1]], name="baseline")[0]
        levels = [peak_levels(f, h[:, ch], [x.freq_hz], half_band_hz=half_hz)[0]
                  for h, x in ((d.h_baseline, base), (d.h_recorded, rec))]
    except MeasurementError:
        return None
    if not all(abs(x.freq_hz - p) < reach_hz for x, p in zip((rec, base), peaks)):
        return None
    return (pred[0] * rec.freq_hz / base.freq_hz, pred[1] * rec.damping_ratio / base.damping_ratio,
            levels[0] / levels[1])


def frf_modes(problem: Problem, nominal: LabState) -> list[ModeError]:
    """Per-mode frequency, damping and peak errors of the FRF data of ``problem`` against the lab ``nominal``.

    Modes are numbered as the nearest open-loop natural frequency of the nominal model."""
    d: FrfData = problem.data
    f = d.freq_hz
    hp = problem.predict(nominal)
    lo, hi = f[0], f[-1]
    fine = np.linspace(lo, hi, max(2000, 8 * f.size))
    hf = predict_frf(nominal, fine, excitation_point=d.excitation_point, output_points=d.output_points)
    pred = find_peaks(fine, _mif(hf), prominence_db=3.0, name="prediction")
    try:
        meas = find_peaks(f, _mif(d.h), prominence_db=3.0, name=d.source)
    except MeasurementError:
        meas = []
    fp = np.array([p.freq_hz for p in pred])
    fm = np.array([p.freq_hz for p in meas])
    out = []
    if fp.size == 0:
        return out
    used = set()
    pairs = []
    for i in np.argsort(fp):
        if fm.size == 0:
            break
        j = int(np.argmin(np.abs(fm - fp[i]) / fp[i]))
        if j in used or abs(fm[j] - fp[i]) / fp[i] > 0.25:
            continue
        used.add(j)
        pairs.append((i, j))
    r = problem.residual(nominal)
    npart = int(problem.mask.sum())
    lines_r2 = np.zeros(problem.mask.shape)
    re = r[:npart] ** 2 + (r[npart:] ** 2 if r.size > npart else 0.0)
    lines_r2[problem.mask] = re
    per = 2 if problem.use_phase else 1
    df = float(np.median(np.diff(f)))
    f_open, _, _ = natural_frequencies(nominal)
    for i, j in pairs:
        mode = int(np.argmin(np.abs(f_open - fp[i]))) + 1  # number of the nearest open-loop mode
        k = int(np.argmin(np.abs(f - fm[j])))
        ch = int(np.argmax(np.abs(d.h[k])))
        try:
            fits = fit_modes(f, d.h[:, ch], [fm[j]], name=d.source)[0]
            fitp = fit_modes(f, hp[:, ch], [fp[i]], name="prediction")[0]
            fmeas, zmeas, fpred, zpred = fits.freq_hz, fits.damping_ratio, fitp.freq_hz, fitp.damping_ratio
        except MeasurementError:
            fmeas, zmeas, fpred, zpred = fm[j], np.nan, fp[i], np.nan
        # a curve fit that left its own peak for another resonance's describes that one, not this mode
        if not _at_own_peak(fmeas, fm, j):
            fmeas, zmeas = fm[j], np.nan
        if not _at_own_peak(fpred, fp, i):
            fpred, zpred = fp[i], np.nan
        half = max(3 * abs(zpred if np.isfinite(zpred) else 0.02) * fpred, 2 * df)
        try:
            pm = peak_levels(f, d.h[:, ch], [fmeas], half_band_hz=half)[0]
            pp = peak_levels(f, hp[:, ch], [fpred], half_band_hz=half)[0]
            ratio = pp / pm
        except MeasurementError:
            ratio = np.nan
        if d.h_recorded is not None and d.h_baseline is not None and np.isfinite(zpred):
            others = np.delete(fp, i)
            reach = 0.5 * float(np.min(np.abs(others - fp[i]))) if others.size else half
            referred = _referred_mode(d, ch, fmeas, fpred, (fpred, zpred), half, reach)
            if referred is not None:
                fmeas, zmeas, ratio = referred
        near = (np.abs(f - fpred) <= half) | (np.abs(f - fmeas) <= half)
        m = problem.mask[near]
        c2 = float(lines_r2[near][m].sum() / max(per * m.sum(), 1))
        out.append(ModeError(mode, float(fpred), float(fmeas), float(zpred), float(zmeas), float(ratio),
                             int(d.output_points[ch]), c2, c2 > FLAG))
    return out


def table_modes(problem: Problem, nominal: LabState) -> list[ModeError]:
    """Per-mode errors of the modal table of ``problem`` against the lab ``nominal`` (mode tracking by MAC)."""
    d = problem.data
    fo, zo, _ = problem.model_modes(nominal)
    out = []
    for j in range(len(d.freq_hz)):
        e = np.log(d.freq_hz[j] / fo[j]) / problem.freq_sigma_total[j] if np.isfinite(fo[j]) else np.inf
        c2 = float(e**2)
        zd = d.damping[j]
        if problem.damping_compared[j] and np.isfinite(zo[j]) and zo[j] > 0:
            c2 = 0.5 * (c2 + (np.log(zd / zo[j]) / problem.damping_sigma_total[j]) ** 2)
        out.append(ModeError(int(d.modes[j]), float(fo[j]), float(d.freq_hz[j]), float(zo[j]), float(zd),
                             chi2_per_residual=c2, flagged=c2 > FLAG))
    return out


# ----------------------------------------------------------------------------- sensors and band
def channel_errors(problem: Problem, nominal: LabState, modes: list[ModeError]) -> dict:
    """Per output point of ``problem``'s FRF data against the lab ``nominal``: mean chi-square per residual,
    weighted RMS log10 error, and COMAC over the paired ``modes``."""
    d: FrfData = problem.data
    hp = problem.predict(nominal)
    r = problem.residual(nominal)
    npart = int(problem.mask.sum())
    r2 = np.zeros(problem.mask.shape)
    r2[problem.mask] = r[:npart] ** 2 + (r[npart:] ** 2 if r.size > npart else 0.0)
    per = 2 if problem.use_phase else 1
    cm = np.full(len(d.output_points), np.nan)
    if len(modes) >= 2:
        f = d.freq_hz
        ka = [int(np.argmin(np.abs(f - m.freq_predicted_hz))) for m in modes]
        kb = [int(np.argmin(np.abs(f - m.freq_measured_hz))) for m in modes]
        a = np.array([_real_shape(hp[k]) for k in ka]).T
        b = np.array([_real_shape(d.h[k]) for k in kb]).T
        try:
            cm = comac(a, b)
        except MeasurementError:
            pass
    out = {}
    for j, p in enumerate(d.output_points):
        m = problem.mask[:, j]
        out[int(p)] = {"chi2_per_residual": float(r2[m, j].sum() / max(per * m.sum(), 1)),
                       "misfit_decades": log_misfit(hp[m, j], d.h[m, j], problem.weight_mag[m, j]),
                       "comac": float(cm[j])}
    return out


def _real_shape(row: np.ndarray) -> np.ndarray:
    """Real shape from complex FRF values at a resonance (rotated to the dominant phase)."""
    k = int(np.argmax(np.abs(row)))
    return np.real(row * np.exp(-1j * np.angle(row[k])))


def mismatched_band(problem: Problem, nominal: LabState) -> list | None:
    """``[low, high]`` [Hz] of the lines of ``problem`` whose residual against ``nominal`` (summed over channels)
    exceeds the noise, or None."""
    d = problem.data
    if not isinstance(d, FrfData):
        return None
    r = problem.residual(nominal)
    npart = int(problem.mask.sum())
    r2 = np.zeros(problem.mask.shape)
    r2[problem.mask] = r[:npart] ** 2 + (r[npart:] ** 2 if r.size > npart else 0.0)
    per = 2 if problem.use_phase else 1
    n_used = np.maximum(problem.mask.sum(axis=1), 1)
    line = r2.sum(axis=1) / (per * n_used)
    bad = np.flatnonzero(line > FLAG)
    if bad.size == 0:
        return None
    return [float(d.freq_hz[bad[0]]), float(d.freq_hz[bad[-1]])]


# ----------------------------------------------------------------------------- sensitivity
def _tracked_freqs(state: LabState, phi0: np.ndarray, labels0, n: int) -> np.ndarray:
    f, _, phi = natural_frequencies(state, n + 3)
    labels = state.fe.dofs.labels
    if labels == labels0:
        a, b = phi0, phi
    else:
        idx = {lab: i for i, lab in enumerate(labels)}
        common = [(i, idx[lab]) for i, lab in enumerate(labels0) if lab in idx]
        a, b = phi0[[i for i, _ in common], :], phi[[j for _, j in common], :]
    out = np.full(phi0.shape[1], np.nan)
    for i, j, _ in pair_modes(mac(a, b)):
        out[i] = f[j]
    return out


def sensitivity_localisation(nominal: LabState, ctx: Context, modes: list[ModeError], *,
                             rel_step: float = 0.01) -> list[dict]:
    """Rank local structural parameters by the share of the frequency errors each explains alone.

    Parameters
    ----------
    nominal : LabState
    ctx : Context
    modes : list of ModeError
        Paired modes with predicted and measured frequencies.
    rel_step : float
        Size of the finite-difference perturbation (mass: fraction of the
        total mass; spring: fraction of the point stiffness; rigidity:
        relative change).

    Returns
    -------
    list of dict
        ``{"parameter", "point"/"member", "explained"}``, best first; empty
        when fewer than one mode is paired or the errors are zero.

    Notes
    -----
    ``explained_j = (S_j^T delta)^2 / (|S_j|^2 |delta|^2)`` restricted to
    physical sizes: a mass, a spring and a joint flexibility can only be
    added (``theta >= 0``); a rigidity may go either way. (A mass need not
    lower every frequency: on a hanging structure its weight stiffens.)
    """
    ok = [m for m in modes if np.isfinite(m.freq_measured_hz) and np.isfinite(m.freq_predicted_hz)]
    if not ok:
        return []
    f0, _, phi0 = natural_frequencies(nominal)
    # nominal mode index of each paired mode: nearest nominal natural frequency
    idx = [int(np.argmin(np.abs(f0 - m.freq_predicted_hz))) for m in ok]
    n = max(idx) + 1
    phi0 = phi0[:, :n]
    labels0 = nominal.fe.dofs.labels
    delta = np.array([np.log(m.freq_measured_hz / m.freq_predicted_hz) for m in ok])
    if not np.any(delta):
        return []
    base = np.log(f0[idx])
    spec = nominal.spec
    free = [p for p in sorted(spec.points) if (p, "w") in nominal.fe.dofs]
    # (info, edit, sign, to_si): to_si maps the multiple theta of the perturbation to the hypothesis parameter [SI]
    cands: list = []
    for p in free:
        dm = rel_step * ctx.point_mass.get(p, ctx.total_mass_kg)
        cands.append(({"parameter": "mass", "point": p, "effect": "added_mass", "location": {"point": p}},
                      lambda s, p=p, dm=dm: specedit.add_mass(s, p, dm), -1, lambda t, dm=dm: t * dm))
        kp = ctx.point_stiffness.get(p)
        if kp:
            dk = rel_step * kp
            cands.append(({"parameter": "stiffness", "point": p, "effect": "support_stiffness",
                           "location": {"point": p, "dof": "w"}},
                          lambda s, p=p, dk=dk: specedit.add_spring(s, p, "w", dk), +1, lambda t, dk=dk: t * dk))
    for p in sorted(spec.points):
        segs = specedit.joint_segments(spec, p)
        if len(segs) >= 2:
            kj = float(np.mean([ei / length for _a, _b, length, ei in segs])) / rel_step
            cands.append(({"parameter": "joint", "point": p, "effect": "joint_flexibility", "location": {"point": p}},
                          lambda s, p=p, kj=kj: specedit.soften_joint(s, p, kj), -1,
                          lambda t, kj=kj: kj / t if t > 0 else float("nan")))
    for m in spec.members:
        ei = spec.sections[m.section].ei.si
        for a, b in zip(m.points[:-1], m.points[1:]):
            whole = len(m.points) == 2
            name = m.id if whole else f"{m.id}[{a}-{b}]"
            loc = {"member": m.id} if whole else {"member": m.id, "segment": [a, b]}
            cands.append(({"parameter": "rigidity", "member": name, "effect": "member_stiffness", "location": loc},
                          lambda s, a=a, b=b: specedit.scale_segments(s, {(a, b): 1.0 + rel_step}), 0,
                          lambda t, ei=ei: ei * max(1.0 + t * rel_step, 0.05)))
    out = []
    for info, edit, sign, to_si in cands:
        try:
            st = nominal.with_spec(edit(spec))
            fj = _tracked_freqs(st, phi0, labels0, n)[idx]
        except (ModelError, SpecError):
            continue
        col = np.log(fj) - base
        if not np.all(np.isfinite(col)) or not np.any(col):
            continue
        theta = float(col @ delta) / float(col @ col)
        if sign and theta < 0:
            expl, est = 0.0, float("nan")
        else:
            expl = float((col @ delta) ** 2 / ((col @ col) * (delta @ delta)))
            est = float(to_si(theta))
        out.append({**info, "explained": expl, "estimate": est})
    out.sort(key=lambda d: -d["explained"])
    return out


def located_places(ranked: list[dict], *, share: float = 0.9, top: int = 4) -> tuple[list[int], list[str]]:
    """Points and members (at most ``top`` each) of the ``ranked`` sensitivity candidates explaining at least
    ``share`` of the best one."""
    if not ranked or ranked[0]["explained"] <= 0:
        return [], []
    best = ranked[0]["explained"]
    pts, mems = [], []
    for d in ranked:
        if d["explained"] < share * best:
            break
        if "point" in d and d["point"] not in pts and len(pts) < top:
            pts.append(d["point"])
        if "member" in d and d["member"] not in mems and len(mems) < top:
            mems.append(d["member"])
    return pts, mems


def located_point_ids(ranked: list[dict], *, share: float = 0.9, top: int = 4) -> frozenset:
    """The point ids of the places :func:`located_places` names: its points and the end points of its
    member segments (a whole member's are not a place).

    Parameters
    ----------
    ranked : list of dict
        The sensitivity candidates, best first (:attr:`Location.sensitivity`).
    share, top : float, int
        As :func:`located_places`.

    Returns
    -------
    frozenset of int
    """
    pts, mems = located_places(ranked, share=share, top=top)
    segs = [d["location"]["segment"] for d in ranked if d.get("member") in mems and "segment" in d.get("location", {})]
    return frozenset(pts) | frozenset(int(p) for seg in segs for p in seg)


def at_places(location: dict, places) -> bool:
    """Whether a hypothesis's ``location`` stands at one of the point ids ``places``: its point, or both end
    points of its member segment (a whole member or a channel does not).

    Parameters
    ----------
    location : dict
        A hypothesis's location (``point``, or ``member`` with ``segment``, or ``channel``, ...).
    places : collection of int
        Point ids (:func:`located_point_ids`).

    Returns
    -------
    bool
    """
    if "point" in location:
        return location["point"] in places
    seg = location.get("segment")
    return seg is not None and all(p in places for p in seg)


def locate(problem: Problem, nominal: LabState) -> Location:
    """Modes, channels, band and structural location of the mismatch between ``problem``'s data and the lab
    ``nominal`` (see the module docstring)."""
    loc = Location()
    if isinstance(problem.data, FrfData):
        loc.modes = frf_modes(problem, nominal)
        loc.channels = channel_errors(problem, nominal, loc.modes)
        loc.band_hz = mismatched_band(problem, nominal)
    else:
        loc.modes = table_modes(problem, nominal)
        bad = [m for m in loc.modes if m.flagged]
        if bad:
            loc.band_hz = [min(m.freq_measured_hz for m in bad), max(m.freq_measured_hz for m in bad)]
    loc.sensitivity = sensitivity_localisation(nominal, problem.ctx, loc.modes)
    loc.points, loc.members = located_places(loc.sensitivity)
    loc.places = located_point_ids(loc.sensitivity)
    if isinstance(problem.data, FrfData):
        loc.extra = extra_resonances(problem, nominal)
    return loc


def resonance_limit(problem: Problem) -> float:
    """The squared standardised rise [1] a measured peak must exceed to be a resonance rather than noise
    (:func:`~vlab.diagnose.fit.resonances.stands_out`): the policy's line limit over every line and channel
    of the data, one degree of freedom (:meth:`vlab.diagnose.policy.DecisionPolicy.line_limit`).

    Parameters
    ----------
    problem : Problem
        With FRF data and its decision policy.

    Returns
    -------
    float
    """
    d: FrfData = problem.data
    return problem.policy.line_limit(d.h.size, 1, getattr(d, "var_dof", None))


def extra_resonances(problem: Problem, nominal: LabState, *, prominence_db: float = 6.0) -> list[dict]:
    """Resonances in the measured FRFs that the nominal lab does not have: a new or a split resonance.

    The measured FRF is compared with its reference on the same lines (the nominal plant's replay or a
    baseline where the data were referred through one, so that resonances the plant has and the FE model
    lacks are in both; else the nominal lab's FRF) by :func:`~vlab.diagnose.fit.resonances.unpaired_peaks`;
    a measured peak must stand out of the recording's own noise (:func:`resonance_limit`).

    Parameters
    ----------
    problem : Problem
        With FRF data.
    nominal : LabState
    prominence_db : float
        Smallest peak prominence [dB] (:func:`vlab.measure.modal.find_peaks`).

    Returns
    -------
    list of dict
        As :func:`unpaired_peaks`.
    """
    d: FrfData = problem.data
    model = predict_frf(nominal, d.freq_hz, excitation_point=d.excitation_point, output_points=d.output_points)
    meas, var = d.as_recorded()
    if getattr(d, "h_recorded", None) is not None:
        # data referred through a reference (the replay or a baseline, H = H_rec H_model / H_ref): compare the
        # recording with that reference, on the same plant, so that resonances the plant has and the FE model
        # lacks (the MuJoCo BCC's crosspiece arms) are in both
        with np.errstate(divide="ignore", invalid="ignore"):
            model = np.where(np.abs(d.h) > 0, d.h_recorded * model / d.h, model)
    return unpaired_peaks(d.freq_hz, meas, model, d.output_points, prominence_db=prominence_db, var=var,
                          limit=resonance_limit(problem))
