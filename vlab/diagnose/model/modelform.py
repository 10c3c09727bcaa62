"""Model-form uncertainty of a structure's model: how far its natural frequencies and damping may lie
from the real structure's when nothing is wrong with the structure.

A diagnosis compares data with a model. The data carry measurement noise; the
model carries its own error, which no measurement removes.
Both enter the decision "mismatch / no mismatch" and every interval:
``sigma^2 = sigma_measurement^2 + sigma_model^2`` per observation.

The model's part is derived from what is known about the model, never
chosen:

``calibration``
    Stated by the structure's author in the spec's ``[model_form]`` table
    (``frequency_rel``, ``source``), else the residual standard error of the model against the published data it
    was calibrated to -- the spec's ``[reference] frequencies`` table,
    column ``analytical_hz`` (BCC: Table 1 analytical, :mod:`vlab.calibration`;
    grid: Table 3 analytical, :mod:`vlab.grid_fit`):
    ``s = sqrt(mean(ln(f_model / f_reference)^2))`` over the table's modes,
    one value for every mode (pooled: one residual per mode is a single
    draw, not a standard deviation). It is a lower bound: the calibrated
    parameters were fitted to these residuals.
``discretisation``
    ``|ln(f / f_refined)|`` per mode, ``f_refined`` from the same spec with
    every member cut into twice as many elements per segment (the FE
    model's own discretisation error, of the order of the difference to a
    finer mesh for a converging beam element).
``plant``
    The MuJoCo plant's own discretisation (its default hinges and step against
    a converged plant: finer hinges, 25 us step), per mode, from
    ``assets/model_form/<structure>.json`` (written by
    ``python benchmarks/plant_model_form.py``); used where a recording is
    compared through the plant's replay (the FE model's discretisation then
    cancels in the referral, the plant's does not).
``damping``
    The model's open-loop damping ratios are measured values written into
    the spec (``[damping] modal_ratios``, Table 1 / Table 3 experimental):
    their uncertainty is their printed rounding, ``resolution / sqrt(12)``
    (uniform rounding error). A mode whose damping the spec only assumes
    (``default_ratio``) has no model damping to compare: infinite sigma.

Not included, and said so in the report: the difference between the
published analysis and the real structure (the thesis's experimental vs
analytical columns) -- that is the data a diagnosis of Table 1 or 3
examines, so it cannot also set the tolerance it is judged against; the
uncertainty of parameters the calibration did not fit (material constants,
dimensions), which the spec does not state.

Source: the decomposition of a model's error into parameter and model-form
parts follows Kennedy & O'Hagan, "Bayesian calibration of computer models",
J. R. Stat. Soc. B 63 (2001) 425-464; rounding as a uniform error: GUM
(JCGM 100:2008) Sec. 4.3.7 and F.2.2.1.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

import json
from dataclasses import replace as _replace

from ...errors import DataFileError, ModelError
from ...fe import build_fe_model, modal_analysis
from ...spec import ASSETS_DIR, MAX_ELEMENTS_PER_SEGMENT, StructureSpec
from .labmodel import LabState, PointModes, point_modes_of
from .modal_changes import changed_mode_frfs, moved_modes
from .shapemixing import shape_sigma_at

#: Folder of the plants' measured discretisation (``python benchmarks/plant_model_form.py``).
MODEL_FORM_DIR = ASSETS_DIR / "model_form"
#: Relative step of the finite-difference sensitivities of an FRF to a mode's frequency and damping.
SENSITIVITY_STEP = 1e-6
#: Modes within this factor of the data's band enter the FRF model-form variance.
BAND_MARGIN = 1.5

#: Standard deviation of a uniform rounding error, as a fraction of the printed resolution (GUM F.2.2.1).
ROUNDING_SIGMA = 1.0 / math.sqrt(12.0)


def printed_resolution(text: str) -> float:
    """The resolution a number is printed to: one unit in its last written digit (``"1.899"`` -> 0.001, ``"0.04"``
    -> 0.01, ``"1.5e-3"`` -> 1e-4, ``"1200"`` -> 1: trailing zeros of an integer are taken as written).

    Parameters
    ----------
    text : str
        A decimal number as written in a file.

    Returns
    -------
    float
        The resolution, in the number's own unit; NaN for text that is not a decimal number.
    """
    s = text.strip().lower().lstrip("+-")
    mant, _, exp = s.partition("e")
    try:
        e = int(exp) if exp else 0
        float(mant)
    except ValueError:
        return float("nan")
    decimals = len(mant.partition(".")[2])
    return 10.0 ** (e - decimals)


def _float_resolution(x: float) -> float:
    """:func:`printed_resolution` of a float as Python writes it most briefly (a value read from TOML).

    A TOML float keeps no trailing zeros ("0.010" is read as 0.01), so this is an upper bound of the
    resolution it was written with."""
    return printed_resolution(repr(float(x)))


@dataclass(frozen=True)
class ModelFormUncertainty:
    """Model-form standard uncertainty of the first ``n`` modes of a structure's model.

    Attributes
    ----------
    frequency_rel : ndarray, shape (n,)
        Relative standard uncertainty of each natural frequency [1]
        (``sqrt(calibration^2 + discretisation^2)``), modes in frequency order.
    damping_rel : ndarray, shape (n,)
        Relative standard uncertainty of each open-loop damping ratio [1]; inf
        where the spec assumes the damping instead of stating a measured value.
    components : dict of str -> ndarray, shape (n,)
        ``"calibration"``, ``"discretisation"`` (relative, frequency) and
        ``"damping"``.
    sources : dict of str -> str
        Where each component comes from, in words.
    """

    frequency_rel: np.ndarray
    damping_rel: np.ndarray
    components: dict
    sources: dict

    def without(self, component: str, why: str) -> "ModelFormUncertainty":
        """A copy with the frequency component ``component`` removed (``why`` replaces its source)."""
        comp = {**self.components, component: np.zeros_like(self.frequency_rel)}
        freq = np.sqrt(sum(v**2 for k, v in comp.items() if k != "damping"))
        return ModelFormUncertainty(freq, self.damping_rel, comp, {**self.sources, component: why})

    def describe(self, frequency_rel=None) -> str:
        """One sentence: the frequency uncertainty's range [%] (of ``frequency_rel``, e.g. the modes an FRF model
        form uses, where given; else of every mode) and its sources."""
        f = self.frequency_rel if frequency_rel is None or not np.size(frequency_rel) else np.asarray(frequency_rel)
        parts = "; ".join(f"{k}: {v}" for k, v in self.sources.items())
        return (f"model-form uncertainty of the natural frequencies {100 * f.min():.3g}-{100 * f.max():.3g} % "
                f"(1 sigma; {parts})")


def calibration_residual(spec: StructureSpec, freq_hz: np.ndarray) -> tuple[float, str] | None:
    """Residual standard error of the model's frequencies against the spec's calibration reference.

    Parameters
    ----------
    spec : StructureSpec
        Its ``reference["frequencies"]`` names a table in ``assets/data`` with
        an ``analytical_hz`` column (the published analysis the model was
        calibrated to); modes are paired by order.
    freq_hz : ndarray, shape (n,)
        The model's natural frequencies [Hz], in order (n at least the table's rows).

    Returns
    -------
    (float, str) or None
        ``sqrt(mean(ln(f / f_ref)^2))`` [1] and the source in words; None when
        the spec names no such table or column.

    Raises
    ------
    DataFileError
        The named table exists but is malformed.
    """
    from ...reference import column, read_table

    fn = spec.reference.get("frequencies") if spec.reference else None
    if not fn:
        return None
    try:
        ref = column(fn, "analytical_hz")
    except DataFileError:
        if "analytical_hz" not in read_table(fn):
            return None
        raise
    n = min(len(ref), len(freq_hz))
    if n == 0:
        return None
    r = np.log(np.asarray(freq_hz[:n]) / ref[:n])
    return float(np.sqrt(np.mean(r**2))), f"calibration residual against {fn} (analytical_hz, {n} modes)"


def discretisation_error(spec: StructureSpec, n: int) -> np.ndarray:
    """``|ln(f / f_refined)|`` of the first ``n`` modes, the refined mesh with twice the elements per segment
    (where the spec cannot carry it, the mesh with half as many: a bound from above; where there is no coarser
    one either, the ModelError of the refined mesh is raised).

    Parameters
    ----------
    spec : StructureSpec
    n : int
        Number of modes.

    Returns
    -------
    ndarray, shape (n,)
        Relative difference [1]; modes beyond the refined model's count get the largest value found.
    """
    fe0 = build_fe_model(spec)
    try:
        fe1 = build_fe_model(remeshed(spec, 2.0))
    except ModelError:  # no finer mesh fits (an element shorter than a rigid insert): the coarser one bounds it
        coarse = remeshed(spec, 0.5)
        if coarse == spec:  # no coarser one either: nothing bounds it
            raise
        fe1 = build_fe_model(coarse)
    f0 = modal_analysis(fe0.m, fe0.k, n).frequencies_hz
    f1 = modal_analysis(fe1.m, fe1.k, n).frequencies_hz
    k = min(len(f0), len(f1))
    out = np.full(n, 0.0)
    out[:k] = np.abs(np.log(f0[:k] / f1[:k]))
    out[k:] = out[:k].max(initial=0.0)
    return out


def remeshed(spec: StructureSpec, factor: float) -> StructureSpec:
    """``spec`` with every member's elements per segment scaled by ``factor`` (rounded; at least 1, at most
    :data:`vlab.spec.MAX_ELEMENTS_PER_SEGMENT`). Building its FE model raises ModelError where an element would
    be shorter than a rigid insert."""
    return spec.replace(members=tuple(dataclasses.replace(m, elements_per_segment=int(min(
        MAX_ELEMENTS_PER_SEGMENT, max(1, round(factor * m.elements_per_segment))))) for m in spec.members))


def damping_uncertainty(spec: StructureSpec, n: int) -> np.ndarray:
    """Relative standard uncertainty of the spec's open-loop damping ratios of the first ``n`` modes.

    Measured ratios (``[damping] modal_ratios``) carry their printed rounding
    (``resolution / sqrt(12) / zeta``); assumed ones (``default_ratio``) inf.

    Returns
    -------
    ndarray, shape (n,)
    """
    out = np.full(n, np.inf)
    if spec.damping is None:
        return out
    for i, z in enumerate(list(spec.damping.modal_ratios)[:n]):
        if z > 0:
            out[i] = ROUNDING_SIGMA * _float_resolution(z) / z
    return out


def _nearest(ref_hz: np.ndarray, f_hz: float, tol: float = 0.03) -> int | None:
    """Index of the entry of ``ref_hz`` nearest to ``f_hz`` in log frequency, if within ``tol`` (relative)."""
    if np.size(ref_hz) == 0:
        return None
    j = int(np.argmin(np.abs(np.log(np.asarray(ref_hz) / f_hz))))
    return j if abs(math.log(ref_hz[j] / f_hz)) < tol else None


def _plant_table(spec: StructureSpec, column: str) -> tuple[np.ndarray, np.ndarray, str] | None:
    """``(frequency_default_hz, column)`` of every mode of ``assets/model_form/<name>.json`` (the band's
    ``modes`` and the ``above_band_modes``) and the file name; None without the file. Raises DataFileError
    (naming the file) when it is malformed."""
    path = MODEL_FORM_DIR / f"{spec.name}.json"
    if not path.is_file():
        return None
    try:
        obj = json.loads(path.read_text())
        rows = list(obj["modes"]) + list(obj.get("above_band_modes", []))
        f_d = np.array([float(m["frequency_default_hz"]) for m in rows])
        val = np.array([float(m[column]) for m in rows])
    except (ValueError, KeyError, TypeError) as exc:
        raise DataFileError(f"{path}: malformed plant model-form file ({exc!r}): regenerate it with "
                            f"python benchmarks/plant_model_form.py {spec.name}") from None
    return f_d, val, path.name


def plant_shape_uncertainty(spec: StructureSpec, freq_hz: np.ndarray) -> np.ndarray | None:
    """Relative uncertainty of each mode's shape from the plant's discretisation: ``sqrt(1 - MAC)`` of the
    default plant's mode against the converged one's (``assets/model_form/<name>.json``), per mode of
    ``freq_hz`` (nearest default-plant frequency within 3 %; 0 where none). None without the file.

    Parameters
    ----------
    spec : StructureSpec
    freq_hz : ndarray, shape (n,)
        The modes' frequencies [Hz].

    Raises
    ------
    DataFileError
        The file is malformed.

    Returns
    -------
    ndarray, shape (n,) or None
        ``|phi_default - phi_converged| / |phi|`` to first order [1].
    """
    table = _plant_table(spec, "mac")
    if table is None:
        return None
    f_d, mac, _name = table
    out = np.zeros(len(freq_hz))
    for i, f in enumerate(np.asarray(freq_hz)):
        j = _nearest(f_d, f)
        if j is not None:
            out[i] = math.sqrt(max(0.0, 1.0 - min(mac[j], 1.0)))
    return out


def plant_discretisation(spec: StructureSpec, freq_hz: np.ndarray) -> tuple[np.ndarray, str] | None:
    """``|ln(f_default / f_converged)|`` of the MuJoCo plant per mode, from ``assets/model_form/<name>.json``.

    Each model mode takes the entry whose default-plant frequency is nearest to its own (within 3 %), else the
    largest of the entries up to its frequency (the discretisation grows with frequency), or the lowest entry's.

    Parameters
    ----------
    spec : StructureSpec
    freq_hz : ndarray, shape (n,)
        The model's natural frequencies [Hz].

    Returns
    -------
    (ndarray, shape (n,), str) or None
        The relative differences [1] and their source; None when the structure has no such file.

    Raises
    ------
    DataFileError
        The file exists but is malformed (names the file and field).
    """
    table = _plant_table(spec, "frequency_rel")
    if table is None or table[0].size == 0:
        return None
    f_d, rel, name = table
    out = np.full(len(freq_hz), rel.max())
    for i, f in enumerate(np.asarray(freq_hz)):
        j = _nearest(f_d, f) if f > 0 else int(np.argmin(f_d))
        below = rel[f_d <= f]
        out[i] = rel[j] if j is not None else below.max() if below.size else rel[np.argmin(f_d)]
    return out, f"the default MuJoCo plant against a converged one ({name}, {f_d.size} modes)"


_CACHE: dict = {}

#: Frequency components combined for each kind of comparison: with the FE model itself (a modal table,
#: a recording without a replay) or through the MuJoCo plant's replay, where the FE model's discretisation
#: cancels and the plant's remains.
COMPONENTS = {"fe": ("calibration", "discretisation"), "plant": ("calibration", "plant")}


def model_form_uncertainty(spec: StructureSpec, freq_hz: np.ndarray, *,
                           compared_with: str = "fe") -> ModelFormUncertainty:
    """The model-form uncertainty of the model built from ``spec`` (see the module docstring).

    Parameters
    ----------
    spec : StructureSpec
    freq_hz : ndarray, shape (n,)
        The model's first ``n`` natural frequencies [Hz] (as the diagnosis computed them).
    compared_with : {"fe", "plant"}
        What the data are compared with (:data:`COMPONENTS`).

    Returns
    -------
    ModelFormUncertainty
        Cached per spec object, frequencies and ``compared_with``.

    Raises
    ------
    DataFileError
        The spec's calibration reference table or the plant's model-form file is malformed.
    ModelError
        Unknown ``compared_with``.
    """
    if compared_with not in COMPONENTS:
        raise ModelError(f"unknown comparison {compared_with!r}; use one of {sorted(COMPONENTS)}")
    n = len(freq_hz)
    key = (id(spec), tuple(np.asarray(freq_hz, dtype=float).round(9)), compared_with)  # the plant part reads them
    hit = _CACHE.get(key)
    if hit is not None and hit[0] is spec:
        return hit[1]
    if spec.model_form is not None:  # stated by the structure's author: replaces the calibration residual
        vals = list(spec.model_form.frequency_rel)
        comp = {"calibration": np.array((vals + [vals[-1]] * n)[:n])}
        sources = {"calibration": f"stated in the spec's [model_form]: {spec.model_form.source}"}
    else:
        fe = build_fe_model(spec)  # the FE model's modes pair with the reference table by order, another model's may not
        cal = calibration_residual(spec, modal_analysis(fe.m, fe.k, max(n, 1)).frequencies_hz)
        comp = {"calibration": np.full(n, cal[0] if cal else 0.0)}
        sources = {"calibration": cal[1] if cal else "none: the spec names no calibration reference "
                   "([reference] frequencies with an analytical_hz column) and states no [model_form]"}
    comp["damping"] = damping_uncertainty(spec, n)
    if compared_with == "fe":
        comp["discretisation"] = discretisation_error(spec, n)
        sources["discretisation"] = "the FE model against one with twice the elements per segment"
    else:
        pl = plant_discretisation(spec, np.asarray(freq_hz))
        comp["plant"] = pl[0] if pl else np.zeros(n)
        sources["plant"] = pl[1] if pl else ("none: no measured plant discretisation "
                                             f"(python benchmarks/plant_model_form.py {spec.name})")
    sources["damping"] = "printed rounding of the spec's measured damping ratios; assumed ones not compared"
    freq = np.sqrt(sum(comp[k] ** 2 for k in COMPONENTS[compared_with]))
    out = ModelFormUncertainty(freq, comp["damping"], comp, sources)
    _CACHE[key] = (spec, out)  # the spec is kept, so its id is not reused while cached
    return out


def damping_by_frequency(unc: ModelFormUncertainty, fe_freq_hz: np.ndarray,
                         freq_hz: np.ndarray) -> ModelFormUncertainty:
    """``unc`` (per FE mode) carried over to another model's modes ``freq_hz`` for the damping: each takes
    the damping uncertainty of the FE mode nearest in frequency (within 3 %), else inf (not profiled).

    Parameters
    ----------
    unc : ModelFormUncertainty
        Its ``damping_rel`` per FE mode.
    fe_freq_hz : ndarray, shape (n_fe,)
        The FE modes' frequencies [Hz].
    freq_hz : ndarray, shape (n,)
        The other model's frequencies [Hz]; ``unc.frequency_rel`` must already be per these modes.

    Returns
    -------
    ModelFormUncertainty
    """
    fe = np.asarray(fe_freq_hz, dtype=float)
    z = np.full(len(freq_hz), np.inf)
    n_fe = min(len(fe), len(unc.damping_rel))
    for i, f in enumerate(np.asarray(freq_hz, dtype=float)):
        j = _nearest(fe[:n_fe], f)
        if j is not None:
            z[i] = unc.damping_rel[j]
    return ModelFormUncertainty(unc.frequency_rel, z, {**unc.components, "damping": z}, unc.sources)


@dataclass(frozen=True)
class FrfModelForm:
    """The model-form uncertainty of FRFs as a low-rank covariance: the sensitivities of ``ln H`` to each
    uncertain modal parameter and that parameter's standard uncertainty.

    ``cov(ln H_i, ln H_j) = sum_k S_ik conj(S_jk) sigma_k^2``: a frequency error of one mode moves every
    line near it together, so the lines' model-form errors are correlated, not independent.

    Attributes
    ----------
    sens : ndarray, complex, shape (n_f, n_o, k)
        ``d ln H / d ln p_k`` at every line and channel (real part: log magnitude; imaginary: phase [rad]).
    sigma : ndarray, shape (k,)
        Relative standard uncertainty of each parameter ``p_k`` (a mode's frequency or damping ratio) [1].
    labels : tuple of str
        ``"f<r>"``, ``"zeta<r>"`` or ``"phi<r>@<point>"`` (mode number r, from 1, of ``modes``) per
        parameter: a mode's frequency, damping ratio, or its shape at one point (changed by
        ``sigma x`` times the shape's RMS over the points).
    modes : PointModes
        The modal model the parameters belong to (the FE model's, or the reference plant's linearisation).
    anchor : LabState or None
        The lab whose structure ``modes`` stand for (:func:`model_form_at`); None: the nominal lab of the
        problem that carries this model form.
    """

    sens: np.ndarray
    sigma: np.ndarray
    labels: tuple[str, ...]
    modes: PointModes | None = None
    anchor: LabState | None = None

    @property
    def variance(self) -> np.ndarray:
        """Variance of ``ln H`` per line and channel, shape (n_f, n_o) [1] (the diagonal of the covariance)."""
        return np.sum(np.abs(self.sens) ** 2 * self.sigma**2, axis=-1)


def perturbed_modes(pm: PointModes, which: str, r: int, j: int | None, u: float) -> PointModes:
    """``pm`` with one parameter of mode ``r`` changed by the relative amount ``u``: its angular frequency
    (``"f"``) or damping ratio (``"zeta"``) scaled by ``exp(u)``, or its shape at the ``j``-th point
    (``"phi"``) moved by ``u`` times the shape's RMS over the points.

    Parameters
    ----------
    pm : PointModes
    which : {"f", "zeta", "phi"}
    r : int
        Mode index (from 0).
    j : int or None
        Row of the point in ``pm.shapes`` (``"phi"`` only).
    u : float
        The relative change [1].

    Returns
    -------
    PointModes
    """
    return moved_modes(pm, [(which, r, j, u)])


def frf_model_form(state: LabState, freq_hz: np.ndarray, *, excitation_point: int, output_points,
                   uncertainty: ModelFormUncertainty, modes: PointModes | None = None,
                   shape_rel: np.ndarray | None = None) -> FrfModelForm:
    """The model-form uncertainty of the lab ``state``'s FRFs, from that of its modes.

    First-order propagation (GUM, JCGM 100:2008, Eq. (13), with the correlations): each mode within
    :data:`BAND_MARGIN` of the lines contributes its frequency and, where the spec states it, its damping
    ratio as an uncertain parameter; ``d ln H / d ln p`` by a forward difference
    (:data:`SENSITIVITY_STEP`) of the whole closed-loop prediction
    (:func:`vlab.diagnose.model.labmodel.predict_frf`) with that one parameter changed.

    Parameters
    ----------
    state : LabState
        The nominal lab (its FE modes are used).
    freq_hz : ndarray, shape (n_f,)
        The data's lines [Hz].
    excitation_point : int
    output_points : sequence of int, length n_o
    uncertainty : ModelFormUncertainty
        Per mode of ``modes`` (or of the FE model), in frequency order.
    modes : PointModes, optional
        The modes to perturb: those of the plant the data were referred through (its linearisation,
        with modes the FE model does not have, such as the MuJoCo BCC's crosspiece-arm mode at 8.6 Hz);
        default the FE model's.
    shape_rel : ndarray, shape (n_modes,) or (n_pts, n_modes), optional
        Relative uncertainty of each mode's shape (:func:`plant_shape_uncertainty`), or of its entry at each
        point (rows: the points ``output_points`` then the lab's actuators, once each); each point of each
        in-band mode with a positive value becomes a parameter. Default: shapes exact.

    Returns
    -------
    FrfModelForm

    Raises
    ------
    ValueError
        A two-dimensional ``shape_rel`` whose rows are not one per point.
    """
    f = np.asarray(freq_hz, dtype=float)
    pts = tuple(dict.fromkeys(tuple(output_points) + state.actuators))
    pm0 = point_modes_of(state, pts, "the nominal FE model") if modes is None else _replace(modes.at(pts),
                                                                                            coupling=None)
    fr = pm0.omega / (2 * np.pi)
    kw = {"excitation_point": excitation_point, "output_points": output_points}
    lo, hi = f.min() / BAND_MARGIN, f.max() * BAND_MARGIN
    n_u = len(uncertainty.frequency_rel)
    params, sig, labels = [], [], []
    for r in np.flatnonzero((fr >= lo) & (fr <= hi)):
        sf = uncertainty.frequency_rel[min(r, n_u - 1)]
        sz = uncertainty.damping_rel[r] if r < n_u else np.inf
        ss = shape_sigma_at(shape_rel, r, pts)
        for which, j, s_p in [("f", None, sf), ("zeta", None, sz)] + [("phi", j, ss[j]) for j in range(len(pts))]:
            if not np.isfinite(s_p) or s_p <= 0:
                continue
            params.append((which, int(r), j))
            sig.append(s_p)
            labels.append(f"{which}{r + 1}" + (f"@{pts[j]}" if j is not None else ""))
    return FrfModelForm(_sensitivities(state, pm0, params, f, kw), np.array(sig), tuple(labels), pm0)


def _sensitivities(state: LabState, pm: PointModes, params: list, f: np.ndarray, kw: dict) -> np.ndarray:
    """``d ln H / d ln p`` of the modal parameters ``params`` (``(kind, mode index, point row)``, as
    :func:`vlab.diagnose.model.modal_changes.moved_modes`) of ``pm``, shape (n_f, n_o, k): forward differences
    (:data:`SENSITIVITY_STEP`) of :func:`predict_frf` of ``state`` with those modes, all at once
    (:func:`~vlab.diagnose.model.modal_changes.changed_mode_frfs`); 0 where not finite."""
    changes = [(which, r, j, SENSITIVITY_STEP) for which, r, j in params]
    h0, hs = changed_mode_frfs(state, pm, changes, f, **kw)
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.log(hs / h0[None]) / SENSITIVITY_STEP
    return np.moveaxis(np.where(np.isfinite(s), s, 0.0), 0, -1)


def model_form_at(mff: FrfModelForm, state: LabState, freq_hz: np.ndarray, *, excitation_point: int,
                  output_points) -> FrfModelForm:
    """The model form ``mff`` (:func:`frf_model_form`) anchored at the lab ``state``'s own mode frequencies
    (:func:`vlab.diagnose.model.labmodel.point_modes_of` at ``mff``'s points): the same parameters and standard
    uncertainties, each sensitivity taken with ``mff``'s modes moved to ``state``'s frequencies and shapes, mode by
    mode in frequency order (damping ratios kept); ``freq_hz`` (shape (n_f,), [Hz]), ``excitation_point``
    and ``output_points`` as there. Why: :mod:`vlab.diagnose.fit.anchored`. Raises ModelError where ``state``
    cannot be built or lacks the points."""
    f = np.asarray(freq_hz, dtype=float)
    kw = {"excitation_point": excitation_point, "output_points": output_points}
    pts = mff.modes.points if mff.modes is not None else tuple(dict.fromkeys(tuple(output_points) + state.actuators))
    own = point_modes_of(state, pts, "the evaluated lab")
    pm = mff.modes if mff.modes is not None else point_modes_of(state, pts)
    n = min(len(pm.omega), len(own.omega))
    # the frequencies and shapes travel; the peaks' widths stay the anchor's, so that the covariance's size
    # (its determinant, which the fit does not carry) does not follow a fitted damping
    shapes = pm.shapes.copy()
    shapes[:, :n] = own.shapes[:, :n]
    pm = _replace(pm, omega=np.concatenate([own.omega[:n], pm.omega[n:]]), shapes=shapes)
    params = []
    for label in mff.labels:
        which = "zeta" if label.startswith("zeta") else ("phi" if label.startswith("phi") else "f")
        mode, _, point = label[len(which):].partition("@")
        params.append((which, int(mode) - 1, pts.index(int(point)) if point else None))
    return FrfModelForm(_sensitivities(state, pm, params, f, kw), np.asarray(mff.sigma), tuple(mff.labels), pm,
                        anchor=state)
