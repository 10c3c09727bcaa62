"""The character of the grid's modes (pendulum, top-beam bending and torsion, grid) and their pairing with
the Table 3 mode numbers (Sec. 2.2.2); the Guyan-condensed frequencies of Table 5.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..fe import FEModel, modal_analysis
from ..reduction import GuyanReduction

#: Table 3 modes that are top-beam bending and torsion (Sec. 2.2.2), 1-based.
TOP_BENDING_MODE = 7
TOP_TORSION_MODE = 8

#: Number of model modes searched for the top-beam modes.
N_SEARCH = 16


def guyan_frequencies_hz(m: np.ndarray, k: np.ndarray, masters: list[int]) -> np.ndarray:
    """Natural frequencies of the Guyan-condensed model (:class:`vlab.reduction.GuyanReduction`).

    Parameters
    ----------
    m, k : ndarray, shape (n, n)
        Full mass [kg, ...] and stiffness [N/m, ...] matrices.
    masters : list of int
        Global indices of the ``n_R`` master DOFs.

    Returns
    -------
    ndarray, shape (n_R,)
        Frequencies [Hz], ascending.

    Raises
    ------
    ReductionError
        If the slave stiffness partition is singular.

    Source: Guyan (1965); Eqs. 3.9-3.16 of the dissertation.
    """
    r = GuyanReduction(m, k, masters).reduce()
    return modal_analysis(r.m, r.k).frequencies_hz


@dataclass(frozen=True)
class ModeCharacter:
    """Energy shares and label of one mode.

    Attributes
    ----------
    label : str
        ``"pendulum"``, ``"top-beam bending"``, ``"top-beam torsion"`` or ``"grid"``.
    top_bending : float
        Share of the kinetic energy in the top beam's ``w`` and ``ry`` DOFs.
    top_torsion : float
        Share of the kinetic energy in the top beam's ``rx`` DOFs (incl. plates).
    rx_phase : float
        ``rx13 * rx22 / max(rx13^2, rx22^2)``: +1 in phase, -1 anti-phase.
    swing_mac : float
        Mass-weighted MAC with a rigid swing about the top-beam axis.
    """

    label: str
    top_bending: float
    top_torsion: float
    rx_phase: float
    swing_mac: float


def mode_characters(fe: FEModel, shapes: np.ndarray) -> list[ModeCharacter]:
    """Classify mode shapes of the grid.

    Parameters
    ----------
    fe : FEModel
        The grid model (top beam on points 13-22).
    shapes : ndarray, shape (n, n_modes)
        Mode shapes.

    Returns
    -------
    list of ModeCharacter
        One per column. A mode is "top-beam torsion" when more than 40 % of its
        kinetic energy is in the top beam's rotations about its axis with the
        plates in anti-phase, "top-beam bending" when more than 40 % is in the
        top beam's out-of-plane bending, "pendulum" when its MAC with the rigid
        swing about the top-beam axis exceeds 0.5, else "grid".
    """
    top = range(13, 23)
    bend = [fe.dofs.index(p, d) for p in top for d in ("w", "ry") if (p, d) in fe.dofs]
    tors = [fe.dofs.index(p, "rx") for p in top]
    swing = np.zeros(fe.n)
    for i, (node, d) in enumerate(fe.dofs.labels):
        if d == "w":
            swing[i] = fe.mesh.nodes[node][1]
        elif d == "rx":
            swing[i] = 1.0
    mw = fe.m @ swing
    i13, i22 = fe.dofs.index(13, "rx"), fe.dofs.index(22, "rx")
    out = []
    for j in range(shapes.shape[1]):
        phi = shapes[:, j]
        mphi = fe.m @ phi
        total = phi @ mphi
        eb = float(phi[bend] @ mphi[bend] / total)
        et = float(phi[tors] @ mphi[tors] / total)
        a, b = phi[i13], phi[i22]
        phase = float(a * b / max(a * a, b * b, 1e-300))
        mac = float((swing @ mphi) ** 2 / (total * (swing @ mw)))
        if et > 0.4 and phase < 0.0:
            label = "top-beam torsion"
        elif eb > 0.4:
            label = "top-beam bending"
        elif mac > 0.5:
            label = "pendulum"
        else:
            label = "grid"
        out.append(ModeCharacter(label, eb, et, phase, mac))
    return out


def _first_above(score: np.ndarray, threshold: float) -> int:
    """Index of the first score above ``threshold``, else of the largest score."""
    above = np.flatnonzero(score > threshold)
    return int(above[0]) if above.size else int(np.argmax(score))


def match_modes(fe: FEModel, n_ref: int = 12) -> tuple[np.ndarray, np.ndarray, list[ModeCharacter]]:
    """Model modes matched to the Table 3 mode numbers.

    The lowest mode with more than half of its kinetic energy in top-beam
    bending is Table 3 mode 7 (first top-beam bending), the lowest anti-phase
    mode with more than half in top-beam torsion mode 8 (where no mode
    reaches one half, the one with the largest share); the others fill modes
    1-6 and 9-12 in frequency order.

    Parameters
    ----------
    fe : FEModel
        The grid model.
    n_ref : int
        Number of Table 3 modes (12).

    Returns
    -------
    freq_hz : ndarray, shape (n_ref,)
        Matched model frequencies [Hz].
    index : ndarray of int, shape (n_ref,)
        Model mode number (0-based, in frequency order) of each Table 3 mode.
    characters : list of ModeCharacter
        Characters of the first :data:`N_SEARCH` model modes.
    """
    modes = modal_analysis(fe.m, fe.k, N_SEARCH)
    ch = mode_characters(fe, modes.shapes)
    torsion_score = np.array([c.top_torsion if c.rx_phase < 0 else 0.0 for c in ch])
    it = _first_above(torsion_score, 0.5)
    bend_score = np.array([c.top_bending if j != it else -1.0 for j, c in enumerate(ch)])
    ib = _first_above(bend_score, 0.5)
    rest = [j for j in range(N_SEARCH) if j not in (ib, it)]
    index = np.empty(n_ref, dtype=int)
    slots = [i for i in range(n_ref) if i not in (TOP_BENDING_MODE - 1, TOP_TORSION_MODE - 1)]
    for s, j in zip(slots, rest):
        index[s] = j
    index[TOP_BENDING_MODE - 1] = ib
    index[TOP_TORSION_MODE - 1] = it
    return modes.frequencies_hz[index], index, ch

