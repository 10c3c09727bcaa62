"""Cross-check of the MuJoCo plant against the FE model of the same spec.

Two checks:

* **Modal** -- the FE modes (:func:`vlab.fe.modal_analysis`) and the plant's
  linearised modes (:func:`vlab.sim.linearize.modes`) are compared at the
  structure's points (``w`` DOFs / ``p<ID>`` sites). Modes are paired by the
  Modal Assurance Criterion: one assignment maximising the total MAC
  (Hungarian algorithm) over *all* FE and plant modes in a common band
  (:func:`vlab.sim.pairing.pair_band`), so that a plant mode is not taken by a neighbouring
  FE mode while its own FE partner lies just above the compared modes; no
  pair below a MAC threshold. Each pair reports the frequency error and MAC.
  Plant modes in the band without an FE counterpart (the BCC crosspiece
  arms' anti-symmetric bending, absent from the FE's single-DOF crosspiece)
  are reported with their frequency and why. The FE reference is the spec's
  (thesis) mesh or the spec meshed at the plant's resolution
  (:func:`plant_resolution_spec`).
* **Time domain** -- the first mode's frequency from a simulated free decay
  (initial displacement in the mode's shape, zero crossings of ``w`` at its
  largest point), and its damping ratio from the logarithmic decrement
  (:mod:`vlab.sim.decay`); repeated over discretisations by
  :mod:`vlab.sim.convergence`.

Sources: MAC, Allemang & Brown (1982); the limits :data:`TOL_PCT` and :data:`MIN_MAC` (their
source: :data:`TOLERANCE_SOURCE`);
Ewins, *Modal Testing*, Sec. 4.2 (logarithmic decrement).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import SimulationError
from ..spec import StructureSpec
from .builder import build_plant
from .linearize import SimModes, modes
from .options import SimOptions
from .pairing import BAND_MARGIN, UnpairedMode, fe_band, pair_band
from .plant import Plant

#: Largest absolute frequency error [%] of a plant mode against its FE partner that the cross-check accepts.
TOL_PCT = 2.0
#: Smallest MAC [-] of an accepted pair.
MIN_MAC = 0.9
#: Where :data:`TOL_PCT` and :data:`MIN_MAC` come from (printed and written with a cross-check).
TOLERANCE_SOURCE = ("frequency: the accuracy the shipped plants were built to (BCC and grid within 1.5 % one-to-one, "
                    "docs/plants.md), with margin; MAC: 'in excess of 0.9' for correlated modes (Ewins, Modal "
                    "Testing: Theory, Practice and Application, 2000, Ch. 8)")


@dataclass(frozen=True)
class ModePair:
    """One row of the modal cross-check.

    Attributes
    ----------
    fe_mode : int
        FE mode number (1-based).
    fe_hz : float
        FE frequency [Hz].
    sim_mode : int or None
        Plant mode number (1-based), None if unpaired.
    sim_hz : float
        Plant frequency [Hz] (nan if unpaired).
    error_pct : float
        ``100 (sim - fe) / fe`` [%].
    mac : float
        MAC at the structure points [-].
    sim_zeta : float
        Plant damping ratio [-].
    """

    fe_mode: int
    fe_hz: float
    sim_mode: int | None
    sim_hz: float
    error_pct: float
    mac: float
    sim_zeta: float


@dataclass(frozen=True)
class CrossCheck:
    """Result of :func:`crosscheck`.

    Attributes
    ----------
    structure : str
    pairs : tuple of ModePair
        One per compared FE mode (the first ``n_modes``).
    points : tuple of int
        Points used for the MAC.
    sim_modes : SimModes
    fe_frequencies_hz : ndarray, shape (n_fe,)
        FE frequencies [Hz] of the modes in the FE band.
    mesh : str
        FE reference: ``"spec"`` (the spec's, i.e. the thesis's, mesh) or ``"plant"``
        (meshed at the plant's resolution, :func:`plant_resolution_spec`).
    fe_elements : dict of str to int
        Elements per segment of each member in the FE reference.
    unpaired : tuple of UnpairedMode
        Plant modes in the band with no FE partner.
    band_hz : float
        Upper edge of the plant band of the pairing [Hz] (:func:`pair_band`).
    """

    structure: str
    pairs: tuple[ModePair, ...]
    points: tuple[int, ...]
    sim_modes: SimModes
    fe_frequencies_hz: np.ndarray
    mesh: str = "spec"
    fe_elements: dict = field(default_factory=dict)
    unpaired: tuple[UnpairedMode, ...] = ()
    band_hz: float = math.nan

    def max_error_pct(self) -> float:
        """Largest ``|frequency error|`` [%] over the pairs (inf if any FE mode is unpaired)."""
        return max((abs(p.error_pct) if p.sim_mode is not None else math.inf) for p in self.pairs)

    def min_mac(self) -> float:
        """Smallest MAC over the pairs (0 if any FE mode is unpaired)."""
        return min((p.mac if p.sim_mode is not None else 0.0) for p in self.pairs)

    def passed(self, tol_pct: float = TOL_PCT, min_mac: float = MIN_MAC) -> bool:
        """True when every FE mode is paired within ``tol_pct`` [%] and with MAC >= ``min_mac``.

        Parameters
        ----------
        tol_pct : float
            Largest allowed ``|frequency error|`` [%] (default :data:`TOL_PCT`).
        min_mac : float
            Smallest allowed MAC [-] (default :data:`MIN_MAC`; source: :data:`TOLERANCE_SOURCE`).
        """
        return self.max_error_pct() <= tol_pct and self.min_mac() >= min_mac

    def table(self) -> str:
        """A plain-text table (mode, FE Hz, plant mode, plant Hz, error %, MAC, zeta), then the unpaired plant modes."""
        ref = "spec (thesis) mesh" if self.mesh == "spec" else "mesh at the plant's resolution"
        lines = [f"{self.structure}: MuJoCo plant vs FE model, {ref}",
                 " FE mode   FE [Hz]  plant mode  plant [Hz]  error [%]    MAC    zeta"]
        for p in self.pairs:
            sm = "-" if p.sim_mode is None else str(p.sim_mode)
            lines.append(f"{p.fe_mode:8d} {p.fe_hz:9.4f} {sm:>11} {p.sim_hz:11.4f} {p.error_pct:+10.3f} "
                         f"{p.mac:7.4f} {p.sim_zeta:7.4f}")
        if self.unpaired:
            lines.append(f"plant modes up to {self.band_hz:.4g} Hz without an FE partner:")
            for u in self.unpaired:
                lines.append(f"  plant mode {u.sim_mode} ({u.sim_hz:.4f} Hz): {u.reason}")
        else:
            lines.append(f"every plant mode up to {self.band_hz:.4g} Hz has an FE partner")
        return "\n".join(lines)


#: Smallest number of elements per segment of the FE reference at the plant's resolution: a one-element
#: segment is the thesis mesh itself, whose grid top beam is 1.2 % stiff in mode 7 against a converged mesh,
#: while the plant has at least two links (each with a shear slide and a bending hinge) per segment.
MIN_PLANT_RESOLUTION_ELEMENTS = 2


def plant_resolution_spec(plant: Plant, *, min_elements: int = MIN_PLANT_RESOLUTION_ELEMENTS) -> StructureSpec:
    """The plant's spec meshed at least as finely as the plant resolves each member.

    Each member gets ``max(its elements_per_segment, the plant's links per
    segment, min_elements)`` elements per segment (the crosspiece stays the FE
    model's single-DOF model).

    Parameters
    ----------
    plant : Plant
        A built plant (:attr:`BuildInfo.links`: links per segment of each member).
    min_elements : int
        Floor on the elements per segment (:data:`MIN_PLANT_RESOLUTION_ELEMENTS`).

    Returns
    -------
    StructureSpec
        A copy of ``plant.spec`` with the members' ``elements_per_segment`` raised.

    Raises
    ------
    SimulationError
        If ``min_elements < 1``.
    """
    if isinstance(min_elements, bool) or not isinstance(min_elements, int) or min_elements < 1:
        raise SimulationError(f"plant_resolution_spec: min_elements = {min_elements!r} must be an integer >= 1")
    spec = plant.spec
    links = plant.info.links
    return spec.replace(members=tuple(
        dataclasses.replace(m, elements_per_segment=max(m.elements_per_segment, int(links.get(m.id, 0)), min_elements))
        for m in spec.members))


def crosscheck(spec_or_plant: StructureSpec | Plant, n_modes: int, *, options: SimOptions | None = None,
               points: list[int] | None = None, mesh: str = "spec", min_mac: float = 0.5,
               margin: float = BAND_MARGIN) -> CrossCheck:
    """Compare the first ``n_modes`` FE modes with the plant's modes, paired one-to-one in a common band.

    FE and plant modes in the band set by FE mode ``n_modes`` are paired by
    :func:`pair_band` (one assignment maximising the total MAC; no pair below
    ``min_mac``); plant modes in the band left without a partner are reported
    in :attr:`CrossCheck.unpaired`.

    Parameters
    ----------
    spec_or_plant : StructureSpec or Plant
        A spec (a plant is built with ``options``) or a built plant.
    n_modes : int
        Number of FE modes compared.
    options : SimOptions, optional
        Build options when a spec is given.
    points : list of int, optional
        Points for the MAC; default all points whose ``w`` is free in the FE model.
    mesh : {"spec", "plant"}
        FE reference: the spec's own mesh (the thesis's) or the spec meshed at
        the plant's resolution (:func:`plant_resolution_spec`).
    min_mac, margin : float
        As :func:`pair_band`.

    Returns
    -------
    CrossCheck

    Raises
    ------
    SimulationError
        If the plant cannot be built, settled or linearised, ``mesh`` is unknown or
        ``n_modes`` exceeds the FE model's modes.
    ModelError
        If the FE model cannot be built.

    Source: MAC, Allemang & Brown (1982); limits :data:`TOL_PCT`, :data:`MIN_MAC`.
    """
    from ..fe import modal_analysis

    if mesh not in ("spec", "plant"):
        raise SimulationError(f"crosscheck: mesh = {mesh!r}: expected 'spec' or 'plant'")
    plant = spec_or_plant if isinstance(spec_or_plant, Plant) else build_plant(spec_or_plant, options)
    spec = plant.spec if mesh == "spec" else plant_resolution_spec(plant)
    fe = fe_reference(spec)
    if points is None:
        points = [p for p in sorted(spec.points) if (p, "w") in fe.dofs]
    rows = [fe.dofs.index(p, "w") for p in points]
    fe_all = modal_analysis(fe.m, fe.k)
    if not 1 <= n_modes <= fe_all.frequencies_hz.size:
        raise SimulationError(f"crosscheck: n_modes = {n_modes} not in 1..{fe_all.frequencies_hz.size} "
                              f"(modes of the FE model of {spec.name!r})")
    fe_edge, n_fe = fe_band(fe_all.frequencies_hz, n_modes, margin)
    f_fe = fe_all.frequencies_hz[:n_fe]
    phi_fe = fe_all.shapes[rows, :n_fe]
    cap = 2 * plant.model.nv
    n_sim = min(3 * n_modes + 6, cap)
    sm = modes(plant.model, points, n_sim)
    while sm.frequencies_hz.size == n_sim and sm.frequencies_hz[-1] <= fe_edge and n_sim < cap:
        n_sim = min(2 * n_sim, cap)
        sm = modes(plant.model, points, n_sim)
    bp = pair_band(f_fe, phi_fe, sm.frequencies_hz, sm.shapes, n_modes, min_mac=min_mac, margin=margin)
    out = []
    for r in range(n_modes):
        j, mac = bp.fe_to_sim[r], bp.macs[r]
        f0 = float(f_fe[r])
        if j is None:
            out.append(ModePair(r + 1, f0, None, math.nan, math.nan, mac, math.nan))
        else:
            f = float(sm.frequencies_hz[j])
            out.append(ModePair(r + 1, f0, j + 1, f, 100 * (f - f0) / f0, mac, float(sm.damping_ratios[j])))
    elements = {m.id: m.elements_per_segment for m in spec.members}
    return CrossCheck(spec.name, tuple(out), tuple(points), sm, np.asarray(f_fe), mesh, elements, bp.unpaired,
                      bp.band_hz)


def fe_reference(spec: StructureSpec):
    """The FE model of ``spec`` (the structure the plant was built from) used as cross-check reference:
    :func:`vlab.fe.build_fe_model`, whose :class:`~vlab.errors.ModelError` it raises.

    Its crosspiece single-DOF model carries the arms' exact participating mass
    (:func:`vlab.fe.crosspiece.cantilever_tip_mass_sdof`), which the plant's
    flexible arms converge to.
    """
    from ..fe import build_fe_model

    return build_fe_model(spec)
