"""The fit of the grid's parameters to Tables 3 and 5: residuals, bounded least squares, the report and
``python -m vlab.grid_fit``.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.optimize

from ..errors import ModelError, ReductionError
from ..fe import FEModel, build_fe_model, modal_analysis
from ..models import master_indices
from ..reference import column
from ..spec import load_spec, spec_from_dict
from .modes import TOP_BENDING_MODE, TOP_TORSION_MODE, ModeCharacter, guyan_frequencies_hz, match_modes, mode_characters
from .parameters import GRID_PARAMETERS, apply_parameters, current_parameters


@dataclass(frozen=True)
class GridFit:
    """Result of :func:`fit_grid`.

    Attributes
    ----------
    values : dict
        Fitted parameters, thesis units (see :data:`GRID_PARAMETERS`).
    frequencies_hz : ndarray, shape (12,)
        Model frequencies in frequency order [Hz].
    matched_hz : ndarray, shape (12,)
        Model frequencies matched to Table 3 mode numbers [Hz].
    guyan_hz : ndarray, shape (12,)
        Guyan-reduced model frequencies [Hz].
    characters : list of ModeCharacter
        Character of the model modes in frequency order.
    on_bound : tuple of str
        Parameters within 0.5 % (of the range, or of the log range) of a bound.
    near_bound : tuple of str
        Parameters within 5 % of a bound (including those on it).
    rms_table3 : float
        RMS relative error of ``matched_hz`` against Table 3 analytical.
    rms_guyan : float
        RMS relative error of ``guyan_hz`` against Table 5 Guyan.
    """

    values: dict[str, float]
    frequencies_hz: np.ndarray
    matched_hz: np.ndarray
    guyan_hz: np.ndarray
    characters: list[ModeCharacter]
    on_bound: tuple[str, ...]
    near_bound: tuple[str, ...]
    rms_table3: float
    rms_guyan: float


def _to_x(values: dict[str, float]) -> np.ndarray:
    return np.array([np.log(values[p[0]]) if p[4] else values[p[0]] for p in GRID_PARAMETERS])


def _from_x(x: np.ndarray) -> dict[str, float]:
    return {p[0]: float(np.exp(v) if p[4] else v) for p, v in zip(GRID_PARAMETERS, x)}


def _bounds() -> tuple[np.ndarray, np.ndarray]:
    lo = np.array([np.log(p[1]) if p[4] else p[1] for p in GRID_PARAMETERS])
    hi = np.array([np.log(p[2]) if p[4] else p[2] for p in GRID_PARAMETERS])
    return lo, hi


def evaluate(doc: dict[str, Any], values: dict[str, float]) -> tuple[FEModel, np.ndarray, np.ndarray, np.ndarray]:
    """Build the model for ``values``.

    Parameters
    ----------
    doc : dict
        A grid TOML document (``StructureSpec.raw``).
    values : dict of str to float
        Fitted parameters in thesis units (:data:`GRID_PARAMETERS`).

    Returns
    -------
    fe : FEModel
        The model built.
    matched_hz : ndarray, shape (12,)
        Model frequencies matched to the Table 3 mode numbers (:func:`match_modes`).
    guyan_hz : ndarray, shape (12,)
        Frequencies of the Guyan-reduced model.
    penalty : ndarray, shape (12,)
        Character violations (0 when satisfied): Table 3 mode 1 must be the
        pendulum mode (swing MAC >= 0.8); no mode other than 7 and 8 may have
        more than 30 % of its kinetic energy in top-beam bending or in
        anti-phase top-beam torsion.

    Raises
    ------
    ModelError, SpecError
        Parameters that give an invalid spec or an unstable model.
    """
    fe = build_fe_model(spec_from_dict(apply_parameters(doc, values)))
    matched, index, ch = match_modes(fe)
    guyan = guyan_frequencies_hz(fe.m, fe.k, master_indices(fe, "guyan"))
    pen = np.zeros(12)
    for slot, j in enumerate(index):
        if slot + 1 in (TOP_BENDING_MODE, TOP_TORSION_MODE):
            continue
        c = ch[j]
        tors = c.top_torsion if c.rx_phase < 0 else 0.0
        pen[slot] = max(0.0, c.top_bending - 0.3) + max(0.0, tors - 0.3)
    pen[0] += max(0.0, 0.8 - ch[index[0]].swing_mac)
    return fe, matched, guyan, pen


def residuals(doc: dict[str, Any], values: dict[str, float], weight_guyan: float = 0.5) -> np.ndarray:
    """Residuals of the fit, shape (36,).

    Relative frequency errors against Table 3 analytical (12), weighted
    relative errors against Table 5 Guyan (12) and the character penalties of
    :func:`evaluate` (12).

    Parameters
    ----------
    doc, values
        As :func:`evaluate`.
    weight_guyan : float
        Weight of the Table 5 residuals [-].

    Returns
    -------
    ndarray, shape (36,)
        Dimensionless residuals; 10 everywhere for a model that cannot be built.
    """
    f3 = column("table3_grid_frequencies.csv", "analytical_hz")
    f5 = column("table5_grid_reduced_frequencies.csv", "guyan_hz")
    try:
        _, matched, guyan, pen = evaluate(doc, values)
    except (ModelError, ReductionError):
        return np.full(36, 10.0)  # unstable or singular model: far from the data
    return np.concatenate([matched / f3 - 1.0, weight_guyan * (guyan / f5 - 1.0), pen])


#: Extra starting points of the local fit, as changes to the values in grid.toml.
_STARTS: tuple[dict[str, float], ...] = (
    {},
    {"pitch": 13.0, "half_span": 1.3},
    {"plate_width": 24.0, "plate_height": 24.0, "top_kga": 1.0e4},
)


def fit_grid(doc: dict[str, Any] | None = None, *, weight_guyan: float = 0.5, global_search: bool = False,
             seed: int = 2) -> GridFit:
    """Fit the grid's unknown parameters by bounded least squares.

    The residuals (:func:`residuals`) switch when modes change order, so the
    cost has many local minima. By default the fit is local (trust-region
    least squares, ``scipy.optimize.least_squares``) from the values in the
    document and from the perturbed starts of ``_STARTS``; the values shipped
    in ``grid.toml`` came from a global search (``global_search=True``:
    differential evolution over the bounds, then the local polish; about ten
    minutes on two cores).

    Parameters
    ----------
    doc : dict, optional
        Parsed grid TOML; defaults to the shipped ``grid.toml``.
    weight_guyan : float
        Weight of the Table 5 Guyan residuals relative to Table 3's.
    global_search : bool
        Run differential evolution first.
    seed : int
        Seed of the global search (deterministic for a given seed).

    Returns
    -------
    GridFit

    Source: Table 3 (analytical), Table 5 (Guyan column), Sec. 2.2.1-2.2.2, 3.3.
    """
    doc = doc if doc is not None else load_spec("grid").raw
    lo, hi = _bounds()
    base = current_parameters(doc)

    def fun(x: np.ndarray) -> np.ndarray:
        return residuals(doc, _from_x(x), weight_guyan)

    starts = [np.clip(_to_x({**base, **st}), lo + 1e-9, hi - 1e-9) for st in _STARTS]
    if global_search:
        de = scipy.optimize.differential_evolution(
            lambda x: float(np.sum(fun(x) ** 2)), list(zip(lo, hi)), popsize=10, maxiter=50, seed=seed,
            polish=False, tol=1e-6,
        )
        starts.insert(0, de.x)
    best = None
    for x0 in starts:
        sol = scipy.optimize.least_squares(fun, x0, bounds=(lo, hi), x_scale=(hi - lo) / 10, diff_step=1e-4)
        if best is None or sol.cost < best.cost:
            best = sol
    return summarize(doc, _from_x(best.x))


def summarize(doc: dict[str, Any], values: dict[str, float]) -> GridFit:
    """Evaluate ``values`` (thesis units) and collect the :class:`GridFit` record.

    Parameters
    ----------
    doc, values
        As :func:`evaluate`.

    Returns
    -------
    GridFit
        Frequencies [Hz] against Tables 3 and 5, characters, parameters on or near a bound.
    """
    fe, matched, guyan, _ = evaluate(doc, values)
    modes = modal_analysis(fe.m, fe.k, 12)
    ch = mode_characters(fe, modes.shapes)
    f3 = column("table3_grid_frequencies.csv", "analytical_hz")
    f5 = column("table5_grid_reduced_frequencies.csv", "guyan_hz")
    lo, hi = _bounds()
    x = _to_x(values)
    margin = [min(v - a, b - v) / (b - a) for v, a, b in zip(x, lo, hi)]
    on = tuple(p[0] for p, d in zip(GRID_PARAMETERS, margin) if d < 5e-3)
    near = tuple(p[0] for p, d in zip(GRID_PARAMETERS, margin) if d < 5e-2)
    return GridFit(
        values=values,
        frequencies_hz=modes.frequencies_hz,
        matched_hz=matched,
        guyan_hz=guyan,
        characters=ch,
        on_bound=on,
        near_bound=near,
        rms_table3=float(np.sqrt(np.mean((matched / f3 - 1.0) ** 2))),
        rms_guyan=float(np.sqrt(np.mean((guyan / f5 - 1.0) ** 2))),
    )


def report(fit: GridFit) -> str:
    """The fit as text: parameters with bounds, per-mode table, Guyan column."""
    f3 = column("table3_grid_frequencies.csv", "analytical_hz")
    f5 = column("table5_grid_reduced_frequencies.csv", "guyan_hz")
    lines = ["parameter        value        bounds               unit"]
    for name, lo, hi, unit, _log, meaning in GRID_PARAMETERS:
        flag = "  ON BOUND" if name in fit.on_bound else ("  near bound" if name in fit.near_bound else "")
        lines.append(f"{name:14s} {fit.values[name]:11.4g}  [{lo:8.3g}, {hi:8.3g}]  {unit:9s} {meaning}{flag}")
    lines.append("")
    lines.append("mode  vlab Hz  Table3 analyt.  error %  mode character (model modes in frequency order)")
    for i in range(12):
        c = fit.characters[i]
        lines.append(
            f"{i + 1:4d}  {fit.frequencies_hz[i]:7.3f}  {f3[i]:14.3f}  {100 * (fit.frequencies_hz[i] / f3[i] - 1):+7.2f}"
            f"  {c.label} (bend {c.top_bending:.2f}, torsion {c.top_torsion:.2f}, rx phase {c.rx_phase:+.2f},"
            f" swing MAC {c.swing_mac:.2f})"
        )
    lines.append("")
    lines.append("Table 3 mode  matched vlab Hz  Table3 analyt.  error %   Guyan vlab Hz  Table5 Guyan  error %")
    for i in range(12):
        lines.append(
            f"{i + 1:12d}  {fit.matched_hz[i]:15.3f}  {f3[i]:14.3f}  {100 * (fit.matched_hz[i] / f3[i] - 1):+7.2f}"
            f"   {fit.guyan_hz[i]:13.3f}  {f5[i]:12.3f}  {100 * (fit.guyan_hz[i] / f5[i] - 1):+7.2f}"
        )
    lines.append("")
    lines.append(f"rms error vs Table 3 analytical (matched modes): {100 * fit.rms_table3:.2f} %")
    lines.append(f"rms error vs Table 5 Guyan column:              {100 * fit.rms_guyan:.2f} %")
    lines.append("parameters on a bound: " + (", ".join(fit.on_bound) or "none"))
    lines.append("parameters within 5 % of a bound: " + (", ".join(fit.near_bound) or "none"))
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """``python -m vlab.grid_fit [--check | --global]``.

    Without options: local fit from the values in ``grid.toml`` (about a
    minute); ``--check``: evaluate ``grid.toml`` as it is; ``--global``:
    differential evolution first (slow). Prints the parameters, those on a
    bound and the per-mode tables.

    Parameters
    ----------
    argv : list of str, optional
        Arguments without the program name (default ``sys.argv[1:]``).

    Returns
    -------
    int
        0 on success, 2 (usage on stderr) for other arguments.
    """
    argv = sys.argv[1:] if argv is None else argv
    if argv not in ([], ["--check"], ["--global"]):
        print("usage: python -m vlab.grid_fit [--check | --global]", file=sys.stderr)
        return 2
    doc = load_spec("grid").raw
    if argv == ["--check"]:
        fit = summarize(doc, current_parameters(doc))
    else:
        fit = fit_grid(doc, global_search=argv == ["--global"])
    print(report(fit))
    return 0
