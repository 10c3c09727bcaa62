"""Shared inputs of the reproduction: models, designs, the laboratory structure, measured modes.

One :class:`ReproContext` per run holds the nominal FE models, every
controller design (made once, with the thesis's settings, by
:func:`vlab.design.design_controller`), the *laboratory structure* a virtual
experiment runs on, and the *measured modes* that stand in for the
dissertation's unpublished modal test (Sec. 5.4.1, Figs. 6-16).

The laboratory structure (``lab``)
    ``"as-measured"`` (default): the FE model with its first natural
    frequencies moved to the published experimental ones (Table 1: 6 modes;
    Table 3: 12 modes) by a spectral shift that keeps every mode shape,
    ``k' = k + m Phi diag(w_exp^2 - w^2) Phi^T m`` (mass-normalised
    ``Phi``), and the published experimental damping (Tables 1, 3). It
    stands in for the 1990 structures, whose frequencies are the measured
    ones: analysis on the nominal model then differs from "experiment" the
    way the dissertation's analysis differed from its laboratory.
    ``"nominal"``: the FE model itself (then an exact-reduction analysis of the
    grid is the experiment's own model and its peak ratios are close to 1).

The measured modes (grid, Tables 4, 6, 15-18, 21)
    A virtual modal test in the manner of Sec. 5.4.1, on the laboratory
    structure: force at joint 4, displacement FRFs (analytical, with the
    structure's damping) at the reduction's master DOFs (joint translations;
    for the Guyan masters also the bearing rotations, which the thesis got
    from the plate displacement divided by its lever arm), read at each
    natural frequency of the laboratory structure: the peak level ``|H_j|``
    with the sign of its phase relative to the largest response, scaled to a
    unit maximum over the translations. The shapes are perturbed by modal
    overlap (damping up to 4.5 %) and by modes that joint 4 barely excites
    (the top-beam modes 7 and 8, which the thesis also measured poorly). They
    are paired with the Table 3 experimental frequencies; 11 modes as in the
    thesis (Figs. 6-16, "eleven experimental modes", Sec. 3.3). Flagged
    ``assumed``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..analysis import velocity_frf
from ..fe.damping import modal_damping_matrix, open_loop_ratios
from ..design import ControllerDesign, DesignModel, design_controller, design_model
from ..errors import ModelError
from ..fe import FEModel, modal_analysis
from ..models import master_indices, nominal_fe_model
from ..reference import column

LABS = ("as-measured", "nominal")
#: Number of measured grid modes used (Sec. 3.3: "Eleven experimental modes were used").
N_MEASURED_MODES = 11


@dataclass(frozen=True)
class LabStructure:
    """The structure a virtual experiment runs on (SI).

    Attributes
    ----------
    kind : str
        ``"as-measured"`` or ``"nominal"``.
    m, c, k : ndarray, shape (n, n)
        Mass [kg], damping [N*s/m], stiffness [N/m] (FE DOF order).
    frequencies_hz : ndarray, shape (n,)
        Its natural frequencies [Hz].
    description : str
    """

    kind: str
    m: np.ndarray
    c: np.ndarray
    k: np.ndarray
    frequencies_hz: np.ndarray
    description: str


@dataclass(frozen=True)
class MeasuredModes:
    """Virtual measured modes at a reduction's master DOFs.

    Attributes
    ----------
    freq_hz : ndarray, shape (n_m,)
        Frequencies paired with the shapes [Hz] (Table 3 experimental).
    shapes : ndarray, shape (n_R, n_m)
        Shapes at the masters (unit maximum over the translations).
    labels : tuple
        Master DOF labels ``(point, dof)``.
    picked_at_hz : ndarray, shape (n_m,)
        Frequencies at which the peaks were read [Hz].
    description : str
    """

    freq_hz: np.ndarray
    shapes: np.ndarray
    labels: tuple
    picked_at_hz: np.ndarray
    description: str


def published_experimental_hz(fe: FEModel) -> np.ndarray:
    """Published experimental natural frequencies of a structure [Hz] (Table 1 or Table 3).

    Parameters
    ----------
    fe : FEModel
        Model of a shipped structure; its spec names the reference table.

    Returns
    -------
    ndarray, shape (n_modes,)
    """
    return column(fe.spec.reference["frequencies"], "experimental_hz")


def lab_structure(fe: FEModel, kind: str = "as-measured") -> LabStructure:
    """The laboratory structure of a virtual experiment (see the module docstring).

    Parameters
    ----------
    fe : FEModel
        Nominal FE model.
    kind : {"as-measured", "nominal"}

    Returns
    -------
    LabStructure

    Raises
    ------
    ModelError
        Unknown ``kind``, or the shift would reorder the modes.
    """
    if kind not in LABS:
        raise ModelError(f"unknown laboratory structure {kind!r}; use one of {LABS}")
    modes = modal_analysis(fe.m, fe.k)
    k = np.array(fe.k, dtype=float)
    if kind == "as-measured":
        f_exp = published_experimental_hz(fe)
        n = len(f_exp)
        w_new = 2 * np.pi * f_exp
        mphi = fe.m @ modes.shapes[:, :n]
        k = k + mphi @ np.diag(w_new**2 - modes.omega[:n] ** 2) @ mphi.T
        k = 0.5 * (k + k.T)
        f_all = np.concatenate([f_exp, modes.frequencies_hz[n:]])
        if np.any(np.diff(f_all) <= 0):
            raise ModelError(f"{fe.spec.name}: moving the first {n} frequencies to the measured ones reorders the modes")
        desc = (f"FE model with its first {n} natural frequencies moved to the published experimental values "
                f"({fe.spec.reference['frequencies']}), mode shapes unchanged; damping {fe.spec.damping.source}")
    else:
        desc = f"nominal FE model; damping {fe.spec.damping.source}"
    c = modal_damping_matrix(fe.m, k, open_loop_ratios(fe.spec, fe.n))
    freq = modal_analysis(fe.m, k).frequencies_hz
    return LabStructure(kind, np.asarray(fe.m), c, k, freq, desc)


def virtual_modal_test(fe: FEModel, lab: LabStructure, method: str = "guyan",
                       n_modes: int = N_MEASURED_MODES) -> MeasuredModes:
    """Measured mode shapes at a reduction's masters by peak picking (Sec. 5.4.1).

    Parameters
    ----------
    fe : FEModel
        Nominal FE model (DOF map, spec).
    lab : LabStructure
        The structure that is "measured".
    method : {"guyan", "exact"}
        Whose master DOFs are measured.
    n_modes : int
        Number of modes (11 for the grid, as in the thesis).

    Returns
    -------
    MeasuredModes
        Shapes ``(n_R, n_modes)`` paired with the published experimental frequencies.

    Raises
    ------
    ModelError
        A mode with no translation response.
    """
    idx = master_indices(fe, method)
    labels = tuple(fe.dofs.labels[i] for i in idx)
    exc = fe.spec.instrumentation.excitation
    u = fe.force_input([exc])
    f_pick = lab.frequencies_hz[:n_modes]
    sel = np.zeros((len(idx), fe.n))
    sel[np.arange(len(idx)), idx] = 1.0
    h_vel = velocity_frf(lab.m, lab.c, lab.k, u, sel, f_pick)[:, :, 0]  # (n_modes, n_R)
    h = h_vel / (2j * np.pi * f_pick[:, None])  # displacement (Sec. 5.4.1: VFRFs integrated)
    trans = [i for i, (_p, d) in enumerate(labels) if d == "w"]
    shapes = np.empty((len(idx), n_modes))
    for r in range(n_modes):
        hr = h[r]
        ref = trans[int(np.argmax(np.abs(hr[trans])))]
        s = np.abs(hr) * np.sign(np.real(hr * np.conj(hr[ref])))
        peak = np.max(np.abs(s[trans]))
        if peak == 0.0:
            raise ModelError(f"virtual modal test: mode {r + 1} has no translation response at the masters")
        shapes[:, r] = s / peak
    f_exp = published_experimental_hz(fe)[:n_modes]
    desc = (f"virtual modal test on the {lab.kind} laboratory structure: force at point {exc}, analytical "
            f"displacement FRFs at the {method} masters read at its natural frequencies (peak level with the sign "
            f"of the phase), unit maximum over the translations; paired with the published experimental "
            f"frequencies ({fe.spec.reference['frequencies']})")
    return MeasuredModes(f_exp, shapes, labels, f_pick, desc)


class ReproContext:
    """Models, designs, laboratory structures and measured modes of one reproduction run.

    Parameters
    ----------
    lab : {"as-measured", "nominal"}
        Laboratory structure of the virtual experiments and the virtual modal test.
    seed : int
        Seed of the DRF optimisers' multi-start.

    Notes
    -----
    Designs are cached by ``(structure, controller, model)``.
    """

    def __init__(self, *, lab: str = "as-measured", seed: int = 0) -> None:
        if lab not in LABS:
            raise ModelError(f"unknown laboratory structure {lab!r}; use one of {LABS}")
        self.lab_kind = lab
        self.seed = seed
        self._designs: dict = {}
        self._models: dict = {}
        self._labs: dict = {}
        self._measured: MeasuredModes | None = None

    def fe(self, structure: str) -> FEModel:
        """The nominal FE model of ``structure`` (``"bcc"`` or ``"grid"``)."""
        return nominal_fe_model(structure)

    def lab(self, structure: str) -> LabStructure:
        """The laboratory structure of ``structure`` (cached)."""
        if structure not in self._labs:
            self._labs[structure] = lab_structure(self.fe(structure), self.lab_kind)
        return self._labs[structure]

    def measured_modes(self) -> MeasuredModes:
        """The grid's measured modes at the Guyan masters (cached)."""
        if self._measured is None:
            grid = self.fe("grid")
            self._measured = virtual_modal_test(grid, lab_structure(grid, "as-measured"), "guyan")
        return self._measured

    def measured_modes_at(self, method: str) -> MeasuredModes:
        """The grid's measured modes at the ``method`` masters ("guyan" or "exact")."""
        if method == "guyan":
            return self.measured_modes()
        grid = self.fe("grid")
        return virtual_modal_test(grid, lab_structure(grid, "as-measured"), method)

    def design_model(self, structure: str, model: str) -> DesignModel:
        """The SI design model of ``structure`` for ``model`` (full, exact, guyan, corrected-guyan), cached.

        Parameters
        ----------
        structure : str
            ``"bcc"`` or ``"grid"``.
        model : str
            Design model; corrected-guyan uses :meth:`measured_modes`.

        Returns
        -------
        DesignModel
        """
        key = (structure, model)
        if key not in self._models:
            mm = self._mm(model)
            self._models[key] = design_model(self.fe(structure), model, measured_modes=mm)
        return self._models[key]

    def _mm(self, model: str):
        if model != "corrected-guyan":
            return None
        mm = self.measured_modes()
        return mm.freq_hz, mm.shapes

    def design(self, structure: str, controller: str, model: str | None = None) -> ControllerDesign:
        """A controller designed with the thesis's settings (cached).

        Parameters
        ----------
        structure : str
            ``"bcc"`` or ``"grid"``.
        controller : str
            One of :data:`vlab.design.CONTROLLERS`.
        model : str, optional
            Design model (None: the thesis's default, see
            :func:`vlab.design.design_controller`).

        Returns
        -------
        ControllerDesign

        Raises
        ------
        ModelError, ReductionError, controllers.errors.ControllerError
            From :func:`vlab.design.design_controller`.
        """
        key = (structure, controller, model)
        if key not in self._designs:
            self._designs[key] = design_controller(
                self.fe(structure), controller, model=model, measured_modes=self._mm(model or ""), seed=self.seed)
        return self._designs[key]
