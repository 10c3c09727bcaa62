"""Pairing of two sets of mode shapes by the Modal Assurance Criterion (MAC), one-to-one over a common band.

:func:`mac_matrix` compares every shape with every other; :func:`pair_modes`
finds the one-to-one assignment that maximises the total MAC (Hungarian
algorithm); :func:`pair_band` does so over a common frequency band, so that
a mode is not taken by a neighbour while its own partner lies just above the
compared modes, and reports the modes left without a partner. Used by the
FE cross-check (:mod:`vlab.sim.crosscheck`), the damping design
(:mod:`vlab.sim.damping`) and the virtual modal test
(:mod:`vlab.sim.modaltest`).

Sources: MAC, Allemang & Brown (1982); Hungarian assignment
(:func:`scipy.optimize.linear_sum_assignment`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.optimize

from ..errors import SimulationError

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

def fe_band(fe_hz: np.ndarray, n_modes: int, margin: float) -> tuple[float, int]:
    """The FE band of :func:`pair_band`: its upper edge and the number of FE modes in it.

    Parameters
    ----------
    fe_hz : ndarray, shape (n_fe,)
        FE natural frequencies [Hz], ascending.
    n_modes : int
        FE modes whose pairs are wanted, ``1 <= n_modes <= n_fe``.
    margin : float
        Relative band margin [-] (:data:`BAND_MARGIN`).

    Returns
    -------
    edge_hz : float
        ``(1 + margin)^2 f_n`` [Hz], ``f_n`` the ``n_modes``-th FE frequency.
    count : int
        FE modes up to the edge, at least ``n_modes``.
    """
    edge = (1.0 + margin) ** 2 * float(fe_hz[n_modes - 1])
    return edge, max(n_modes, int(np.count_nonzero(fe_hz <= edge)))



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
    fe_edge, n_fe = fe_band(fe_hz, n_modes, margin)
    n_sim = int(np.count_nonzero(sim_hz <= band))
    # plant modes above the band stay candidates of the FE modes above it (n_sim_c >= n_sim)
    n_sim_c = max(n_sim, int(np.count_nonzero(sim_hz <= fe_edge)))
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
    return BandPairing(tuple(j for j, _m in pairs), tuple(m for _j, m in pairs), tuple(unpaired), band, fe_edge)
