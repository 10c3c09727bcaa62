"""Cross-check of the MuJoCo plant against the FE model of the same spec.

Two checks:

* **Modal** -- the FE modes (:func:`vlab.fe.modal_analysis`) and the plant's
  linearised modes (:func:`vlab.sim.linearize.modes`) are compared at the
  structure's points (``w`` DOFs / ``p<ID>`` sites). Modes are paired by the
  Modal Assurance Criterion: one assignment maximising the total MAC
  (Hungarian algorithm) over *all* FE and plant modes in a common band
  (:func:`pair_band`), so that a plant mode is not taken by a neighbouring
  FE mode while its own FE partner lies just above the compared modes; no
  pair below a MAC threshold. Each pair reports the frequency error and MAC.
  Plant modes in the band without an FE counterpart (the BCC crosspiece
  arms' anti-symmetric bending, absent from the FE's single-DOF crosspiece)
  are reported with their frequency and why. The FE reference is the spec's
  (thesis) mesh or the spec meshed at the plant's resolution
  (:func:`plant_resolution_spec`).
* **Time domain** -- the first mode's frequency from a simulated free decay
  (initial displacement in the mode's shape, zero crossings of ``w`` at its
  largest point), and its damping ratio from the logarithmic decrement.

Sources: MAC, Allemang & Brown (1982); DESIGN.md (cross-check targets);
Ewins, *Modal Testing*, Sec. 4.2 (logarithmic decrement).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import mujoco
import numpy as np
import scipy.optimize

from ..errors import SimulationError
from ..spec import StructureSpec
from .builder import Plant, SimOptions, build_plant
from .linearize import SimModes, modes, settle

#: Largest absolute frequency error [%] of a plant mode against its FE partner that the cross-check accepts.
TOL_PCT = 2.0
#: Smallest MAC [-] of an accepted pair.
MIN_MAC = 0.9
#: Where :data:`TOL_PCT` and :data:`MIN_MAC` come from (printed and written with a cross-check).
TOLERANCE_SOURCE = ("frequency: the accuracy the shipped plants were built to (BCC and grid within 1.5 % one-to-one, "
                    "docs/plants.md), with margin; MAC: 'in excess of 0.9' for correlated modes (Ewins, Modal "
                    "Testing: Theory, Practice and Application, 2000, Ch. 8)")


def mac_matrix(phi_a: np.ndarray, phi_b: np.ndarray) -> np.ndarray:
    """MAC between every column of ``phi_a`` and of ``phi_b``.

    Parameters
    ----------
    phi_a : ndarray, shape (n_points, n_a)
    phi_b : ndarray, shape (n_points, n_b)

    Returns
    -------
    ndarray, shape (n_a, n_b)
        ``|a^H b|^2 / (a^H a  b^H b)``; 0 where a shape is zero at all points.

    Raises
    ------
    SimulationError
        If the two sets have different numbers of points.
    """
    a = np.asarray(phi_a)
    b = np.asarray(phi_b)
    if a.shape[0] != b.shape[0]:
        raise SimulationError(f"MAC: shapes have {a.shape[0]} and {b.shape[0]} points")
    na = np.sum(np.abs(a) ** 2, axis=0)
    nb = np.sum(np.abs(b) ** 2, axis=0)
    cross = np.abs(a.conj().T @ b) ** 2
    den = np.outer(na, nb)
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.where(den > 1e-30 * max(den.max(initial=0.0), 1e-300), cross / den, 0.0)
    return np.clip(out, 0.0, 1.0)


def pair_modes(fe_shapes: np.ndarray, sim_shapes: np.ndarray, *, min_mac: float = 0.5
               ) -> list[tuple[int | None, float]]:
    """Pair FE modes with plant modes one-to-one by MAC (assignment maximising the total MAC).

    The assignment is over the columns given: give both sides the same
    frequency band (:func:`pair_band`), or a plant mode whose FE partner was
    left out can be taken by a neighbouring FE mode.

    Parameters
    ----------
    fe_shapes : ndarray, shape (n_points, n_fe)
    sim_shapes : ndarray, shape (n_points, n_sim)
    min_mac : float
        Candidate pairs with a lower MAC are excluded before the assignment
        (an FE mode with no candidate left is unpaired, never forced).

    Returns
    -------
    list of (int or None, float)
        For each FE mode: the index of its plant mode (None if unpaired) and the
        MAC of the pair (if unpaired: its largest MAC with any plant mode).

    Raises
    ------
    SimulationError
        If the two sets have different numbers of points.

    Source: MAC, Allemang & Brown (1982); assignment by
    :func:`scipy.optimize.linear_sum_assignment` (Hungarian method).
    """
    mac = mac_matrix(fe_shapes, sim_shapes)
    out: list[tuple[int | None, float]] = [
        (None, float(mac[r].max()) if mac.shape[1] else 0.0) for r in range(mac.shape[0])]
    if mac.size == 0:
        return out
    gain = np.where(mac >= min_mac, mac, 0.0)
    rows, cols = scipy.optimize.linear_sum_assignment(-gain)
    for r, c in zip(rows, cols):
        if mac[r, c] >= min_mac:
            out[r] = (int(c), float(mac[r, c]))
    return out


#: Relative margin of the pairing band above the highest compared FE mode: plant modes up to
#: ``(1 + BAND_MARGIN) f_n`` and FE modes up to ``(1 + BAND_MARGIN)^2 f_n`` take part in the assignment,
#: so that a plant mode just above ``f_n`` can go to its own FE partner rather than to FE mode n (the
#: grid's FE mode 13, 10.15 Hz, 2.7 % above mode 12). A chosen margin, not fitted.
BAND_MARGIN = 0.10


@dataclass(frozen=True)
class UnpairedMode:
    """A plant mode in the band with no FE partner.

    Attributes
    ----------
    sim_mode : int
        Plant mode number (1-based).
    sim_hz : float
        Its frequency [Hz].
    best_fe_mode : int or None
        FE mode (1-based, in the band) with the largest MAC with it; None if no FE mode is in the band.
    best_mac : float
        That MAC [-].
    reason : str
        Why it stays unpaired: no FE mode in the band has MAC >= the threshold
        (a shape the FE model does not have), or its best FE mode is paired
        with another plant mode of larger total MAC.
    """

    sim_mode: int
    sim_hz: float
    best_fe_mode: int | None
    best_mac: float
    reason: str


@dataclass(frozen=True)
class BandPairing:
    """Result of :func:`pair_band`.

    Attributes
    ----------
    fe_to_sim : tuple of (int or None)
        For each FE mode in the FE band (0-based, frequency order): its plant mode (0-based) or None.
    macs : tuple of float
        MAC of each FE mode's pair (if unpaired: its largest MAC in the band) [-].
    unpaired : tuple of UnpairedMode
        Plant modes in the plant band without an FE partner.
    band_hz : float
        Upper edge of the plant band [Hz]; the FE band reaches ``fe_band_hz``.
    fe_band_hz : float
        Upper edge of the FE band [Hz].
    """

    fe_to_sim: tuple[int | None, ...]
    macs: tuple[float, ...]
    unpaired: tuple[UnpairedMode, ...]
    band_hz: float
    fe_band_hz: float


def _fe_band(fe_hz: np.ndarray, n_modes: int, margin: float) -> tuple[float, int]:
    """The FE band of :func:`pair_band`: its upper edge ``(1 + margin)^2 f_n`` [Hz] and the FE modes in it.

    ``f_n`` is the ``n_modes``-th of the ascending FE frequencies ``fe_hz`` [Hz]; the count is at least ``n_modes``.
    """
    fe_band = (1.0 + margin) ** 2 * float(fe_hz[n_modes - 1])
    return fe_band, max(n_modes, int(np.count_nonzero(fe_hz <= fe_band)))


def pair_band(fe_hz: np.ndarray, fe_shapes: np.ndarray, sim_hz: np.ndarray, sim_shapes: np.ndarray,
              n_modes: int, *, min_mac: float = 0.5, margin: float = BAND_MARGIN) -> BandPairing:
    """One-to-one MAC pairing of FE and plant modes over a common frequency band.

    The band is set by the ``n_modes``-th FE frequency ``f_n``: plant modes up
    to ``(1 + margin) f_n`` and FE modes up to ``(1 + margin)^2 f_n`` (wider, so
    that a plant mode at the band's edge finds an FE partner lying a little
    higher) enter one assignment maximising the total MAC
    (:func:`pair_modes`); pairs below ``min_mac`` are not formed. Plant modes
    in their band left without an FE partner are reported with the FE mode
    they resemble most.

    Parameters
    ----------
    fe_hz : ndarray, shape (n_fe,)
        FE natural frequencies [Hz], ascending; ``n_fe >= n_modes``.
    fe_shapes : ndarray, shape (n_points, n_fe)
        FE shapes at the compared points.
    sim_hz : ndarray, shape (n_sim,)
        Plant natural frequencies [Hz], ascending.
    sim_shapes : ndarray, shape (n_points, n_sim)
        Plant shapes at the same points.
    n_modes : int
        FE modes whose pairs are wanted (the band is set by the last of them).
    min_mac : float
        Smallest MAC of a pair [-].
    margin : float
        Relative band margin [-] (:data:`BAND_MARGIN`).

    Returns
    -------
    BandPairing

    Raises
    ------
    SimulationError
        If ``n_modes`` is not in ``1..n_fe``, the shapes and frequencies disagree
        in count, or the two sets of shapes have different numbers of points.

    Source: MAC, Allemang & Brown (1982); Hungarian assignment
    (:func:`scipy.optimize.linear_sum_assignment`).
    """
    fe_hz = np.asarray(fe_hz, dtype=float)
    sim_hz = np.asarray(sim_hz, dtype=float)
    fe_shapes = np.asarray(fe_shapes)
    sim_shapes = np.asarray(sim_shapes)
    if fe_shapes.ndim != 2 or fe_shapes.shape[1] != fe_hz.size:
        raise SimulationError(f"pair_band: {fe_hz.size} FE frequencies but FE shapes of shape {fe_shapes.shape}")
    if sim_shapes.ndim != 2 or sim_shapes.shape[1] != sim_hz.size:
        raise SimulationError(f"pair_band: {sim_hz.size} plant frequencies but plant shapes of shape {sim_shapes.shape}")
    if not 1 <= n_modes <= fe_hz.size:
        raise SimulationError(f"pair_band: n_modes = {n_modes} not in 1..{fe_hz.size} (FE modes given)")
    if not margin >= 0.0:
        raise SimulationError(f"pair_band: margin = {margin!r} must be >= 0")
    band = (1.0 + margin) * float(fe_hz[n_modes - 1])
    fe_band, n_fe = _fe_band(fe_hz, n_modes, margin)
    n_sim = int(np.count_nonzero(sim_hz <= band))
    # plant modes above the band stay candidates of the FE modes above it (n_sim_c >= n_sim)
    n_sim_c = max(n_sim, int(np.count_nonzero(sim_hz <= fe_band)))
    pairs = pair_modes(fe_shapes[:, :n_fe], sim_shapes[:, :n_sim_c], min_mac=min_mac)
    taken = {j: r for r, (j, _m) in enumerate(pairs) if j is not None}
    mac = mac_matrix(fe_shapes[:, :n_fe], sim_shapes[:, :n_sim])
    unpaired = []
    for j in range(n_sim):
        if j in taken:
            continue
        r = int(np.argmax(mac[:, j])) if n_fe else None
        best = float(mac[r, j]) if r is not None else 0.0
        if r is None or best < min_mac:
            why = f"no FE mode in the band has MAC >= {min_mac:g}: a shape the FE model does not have"
        else:
            other = pairs[r][0]
            why = (f"its best FE mode {r + 1} (MAC {best:.3f}) is paired with plant mode {other + 1} "
                   f"(MAC {pairs[r][1]:.3f}, larger total MAC)")
        unpaired.append(UnpairedMode(j + 1, float(sim_hz[j]), None if r is None else r + 1, best, why))
    return BandPairing(tuple(j for j, _m in pairs), tuple(m for _j, m in pairs), tuple(unpaired), band, fe_band)


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
    min_mac : float
        Smallest MAC of a pair [-].
    margin : float
        Relative band margin [-] (:data:`BAND_MARGIN`).

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

    Source: MAC, Allemang & Brown (1982); DESIGN.md (cross-check targets).
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
    fe_band, n_fe = _fe_band(fe_all.frequencies_hz, n_modes, margin)
    f_fe = fe_all.frequencies_hz[:n_fe]
    phi_fe = fe_all.shapes[rows, :n_fe]
    cap = 2 * plant.model.nv
    n_sim = min(3 * n_modes + 6, cap)
    sm = modes(plant.model, points, n_sim)
    while sm.frequencies_hz.size == n_sim and sm.frequencies_hz[-1] <= fe_band and n_sim < cap:
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


@dataclass(frozen=True)
class FreeDecay:
    """Result of :func:`free_decay`.

    Attributes
    ----------
    frequency_hz : float
        Mean frequency from the zero crossings [Hz].
    damping_ratio : float
        From the logarithmic decrement of successive peaks [-].
    point : int
        Point whose ``w`` was analysed.
    t : ndarray, shape (n,)
        Times [s].
    w : ndarray, shape (n,)
        Out-of-plane displacement at ``point`` [m].
    """

    frequency_hz: float
    damping_ratio: float
    point: int
    t: np.ndarray
    w: np.ndarray


def free_decay(plant: Plant, mode: int = 1, *, amplitude_m: float = 1e-3, duration_s: float | None = None,
               sim_modes: SimModes | None = None) -> FreeDecay:
    """Simulate a free decay from a displacement in one mode's shape.

    Parameters
    ----------
    plant : Plant
    mode : int
        Plant mode number (1-based) of the initial shape.
    amplitude_m : float
        Largest initial out-of-plane displacement [m].
    duration_s : float, optional
        Length of the run [s]; default 20 periods.
    sim_modes : SimModes, optional
        The plant's modes (computed when omitted).

    Returns
    -------
    FreeDecay

    Raises
    ------
    SimulationError
        If the run diverges or shows fewer than 4 zero crossings.
    """
    model = plant.model
    pts = sorted(plant.spec.points)
    if sim_modes is None:
        sim_modes = modes(model, pts, mode)
    d0 = settle(model)
    phi = sim_modes.joint_shapes[:, mode - 1]
    shape = sim_modes.shapes[:, mode - 1]
    k = int(np.argmax(np.abs(shape)))
    point = sim_modes.points[k]
    from .linearize import site_jacobian_w

    jw = site_jacobian_w(model, d0, [f"p{point}"])[0]
    scale = amplitude_m / float(jw @ phi)
    d = mujoco.MjData(model)
    d.qpos[:] = d0.qpos
    mujoco.mj_integratePos(model, d.qpos, phi * scale, 1.0)
    mujoco.mj_forward(model, d)
    f0 = sim_modes.frequencies_hz[mode - 1]
    if duration_s is None:
        duration_s = 20.0 / f0
    n = int(round(duration_s / model.opt.timestep))
    sid = model.site(f"p{point}").id
    z0 = float(d0.site_xpos[sid, 2])
    w = np.empty(n + 1)
    w[0] = d.site_xpos[sid, 2] - z0
    from .damping import load_modal_damping

    md = load_modal_damping(model)
    for i in range(n):
        if md is None:
            mujoco.mj_step(model, d)
        else:
            md.step(model, d)
        w[i + 1] = d.site_xpos[sid, 2] - z0
    if not np.all(np.isfinite(w)):
        raise SimulationError("free decay diverged (non-finite displacement): timestep too large for the chain")
    t = np.arange(n + 1) * model.opt.timestep
    s = np.sign(w)
    idx = np.flatnonzero((s[:-1] > 0) & (s[1:] <= 0))  # downward zero crossings
    if idx.size < 3:
        raise SimulationError(f"free decay: only {idx.size} zero crossings in {duration_s:.3g} s")
    tc = t[idx] + w[idx] / (w[idx] - w[idx + 1]) * model.opt.timestep
    periods = np.diff(tc)
    freq = 1.0 / float(np.mean(periods))
    # peaks between crossings -> logarithmic decrement
    peaks = np.array([np.max(np.abs(w[a:b])) for a, b in zip(idx[:-1], idx[1:])])
    if peaks.size >= 2 and peaks[-1] > 0:
        delta = math.log(peaks[0] / peaks[-1]) / (peaks.size - 1)
        zeta = delta / math.sqrt(4 * math.pi**2 + delta**2)
    else:
        zeta = math.nan
    return FreeDecay(freq, zeta, point, t, w)


def fe_reference(spec: StructureSpec):
    """The FE model used as cross-check reference (:func:`vlab.fe.build_fe_model`).

    Its crosspiece single-DOF model carries the arms' exact participating mass
    (:func:`vlab.fe.crosspiece.cantilever_tip_mass_sdof`), which the plant's
    flexible arms converge to.

    Parameters
    ----------
    spec : StructureSpec
        The structure the plant was built from.

    Returns
    -------
    FEModel

    Raises
    ------
    ModelError
        If the FE model cannot be assembled.
    """
    from ..fe import build_fe_model

    return build_fe_model(spec)


@dataclass(frozen=True)
class StudyRow:
    """One discretisation of :func:`convergence_study`.

    Attributes
    ----------
    segments : int
        Links per member segment (crosspiece arms alike).
    layout : str
        Hinge layout (``"gauss"`` or ``"uniform"``).
    timestep_s : float
        Step used [s] (automatic unless given).
    nv : int
        Degrees of freedom.
    f_max_hz : float
        Highest hinge-spring frequency [Hz].
    errors_pct : tuple of float
        Frequency error of each FE mode [%].
    macs : tuple of float
        MAC of each FE mode.
    decay_hz : float
        First-mode frequency from a free decay [Hz] (nan if not run).
    us_per_step : float
        Wall time of one bare ``mj_step`` [us] (nan if not measured).
    """

    segments: int
    layout: str
    timestep_s: float
    nv: int
    f_max_hz: float
    errors_pct: tuple[float, ...]
    macs: tuple[float, ...]
    decay_hz: float
    us_per_step: float

    @property
    def max_error_pct(self) -> float:
        """Largest ``|error|`` [%]."""
        return max(abs(e) for e in self.errors_pct)

    @property
    def min_mac(self) -> float:
        """Smallest MAC."""
        return min(self.macs)


def convergence_study(spec: StructureSpec, n_modes: int, *, segments=(2, 3, 4), layouts=("gauss",),
                      timesteps=(None,), decay: bool = False, speed_steps: int = 0) -> list[StudyRow]:
    """Cross-check the plant for several segment counts, hinge layouts and timesteps.

    Parameters
    ----------
    spec : StructureSpec
    n_modes : int
        FE modes compared.
    segments : sequence of int
        Links per member segment (and per crosspiece arm), for every member
        (see :class:`~vlab.sim.builder.SimOptions`).
    layouts : sequence of str
        Hinge layouts.
    timesteps : sequence of float or None
        Steps [s]; None = automatic.
    decay : bool
        Also measure the first mode's frequency from a free decay.
    speed_steps : int
        Steps timed per row (0: no timing).

    Returns
    -------
    list of StudyRow

    Raises
    ------
    SimulationError
        If a combination cannot be built or is unstable (timestep too large).
    """
    import time

    from .timestep import hinge_omega_max

    rows = []
    for layout in layouts:
        for n in segments:
            for dt in timesteps:
                opts = SimOptions(segments_per_element=n, crosspiece_segments=n, hinge_layout=layout,
                                  timestep_s=dt, modal_damping=False, stiffness_damping_s=0.0,
                                  check_timestep=dt is None)
                plant = build_plant(spec, opts)
                cc = crosscheck(plant, n_modes)
                omega, _ = hinge_omega_max(plant.model)
                f_decay = math.nan
                if decay:
                    j = cc.pairs[0].sim_mode or 1
                    f_decay = free_decay(plant, j, sim_modes=cc.sim_modes).frequency_hz
                us = math.nan
                if speed_steps:
                    d = mujoco.MjData(plant.model)
                    t0 = time.perf_counter()
                    mujoco.mj_step(plant.model, d, nstep=speed_steps)
                    us = (time.perf_counter() - t0) / speed_steps * 1e6
                rows.append(StudyRow(n, layout, plant.timestep_s, plant.model.nv, omega / (2 * math.pi),
                                     tuple(p.error_pct for p in cc.pairs), tuple(p.mac for p in cc.pairs),
                                     f_decay, us))
    return rows
