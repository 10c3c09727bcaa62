"""Finite-element model of the Beam Cross-Cable's out-of-plane motion.

An independent model written from the dissertation (Sec. 2.1, 2.1.1) and the
structure file's numbers; it never imports vlab. The out-of-plane displacement is
``w`` (z), the bending rotation ``rx = dw/dy`` (y up, along the hanging beam).

* Beam: Euler-Bernoulli elements with cubic Hermite shape functions and consistent
  mass (Przemieniecki, *Theory of Matrix Structural Analysis*, 1968, Ch. 11), each
  10-in segment split into ``elements_per_segment`` elements.
* Gravity and cable tension: the geometric stiffness of the axial tension N(y),
  which grows from the bottom cables' tension by the weight below y
  (V = 1/2 int N w'^2 dy), integrated exactly by 3-point Gauss quadrature.
* Clamp: two rigid inserts of the stated length on either side of point 7
  (Sec. 2.1.1), as master-slave constraints, with their own mass, rotary inertia
  and tension stiffness N a.
* Crosspiece: the two 15-in arms as Euler-Bernoulli cantilevers clamped at point 7
  (only their symmetric bending couples to the beam in this 2-D model: one arm
  element set with twice the stiffness and mass), tip masses, the arms' torsional
  rotary inertia about the crosspiece axis (it turns with the beam slope at 7), and
  the gravity coupling of the arms' deflection with that slope (V = -g theta
  sum m v_rel).
* Cables: strings in tension (stiffness T/l, consistent mass), anchored at the far
  end, ``cable_elements`` elements each.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg

from .params import BccParams

_GAUSS_X, _GAUSS_W = np.polynomial.legendre.leggauss(3)


class ModelError(ValueError):
    """An FE model that cannot be built (bad mesh option, bad effect location)."""


@dataclass(frozen=True)
class FEModel:
    """Assembled mass and stiffness matrices over the independent DOFs.

    Attributes
    ----------
    m, k : ndarray, shape (n_dof, n_dof)
        Mass [kg, kg m, kg m^2] and stiffness [N/m, N, N m] matrices.
    labels : tuple
        One label per DOF: ``(point, "w")``, ``(point, "rx")`` for the grid points
        (first, points 1..9 in order), then ``("beam", y_m, "w"|"rx")``,
        ``("arm", x_m, "w"|"rx")`` and ``("cable", name, i)`` for internal nodes.
    top_tension_n : float
        Tension of the top cables [N] (bottom tension plus the weight).
    """

    m: np.ndarray
    k: np.ndarray
    labels: tuple
    top_tension_n: float

    def index(self, point: int, dof: str = "w") -> int:
        """Index of a grid point's DOF (``"w"`` or ``"rx"``)."""
        return self.labels.index((point, dof))


def hermite(s: np.ndarray, length: float):
    """Cubic Hermite shape functions and their first derivative on [0, L].

    Parameters
    ----------
    s : ndarray, shape (n,)
        Positions along the element [m].
    length : float
        Element length L [m].

    Returns
    -------
    n, dn : ndarray, shape (n, 4)
        Values and slopes of the shape functions of DOFs (w_a, rx_a, w_b, rx_b).
    """
    x = np.asarray(s, dtype=float) / length
    n = np.stack([1 - 3 * x**2 + 2 * x**3, length * (x - 2 * x**2 + x**3),
                  3 * x**2 - 2 * x**3, length * (-(x**2) + x**3)], axis=1)
    dn = np.stack([(-6 * x + 6 * x**2) / length, 1 - 4 * x + 3 * x**2,
                   (6 * x - 6 * x**2) / length, -2 * x + 3 * x**2], axis=1)
    return n, dn


def beam_element(ei: float, mu: float, length: float, tension) -> tuple:
    """Stiffness (bending + tension) and consistent mass of one beam element.

    Parameters
    ----------
    ei : float
        Bending stiffness [N m^2].
    mu : float
        Mass per length [kg/m].
    length : float
        Element length [m].
    tension : callable
        N(s) [N]: axial tension at distance s [m] from the element's first node.

    Returns
    -------
    k, m : ndarray, shape (4, 4)
        DOFs (w_a, rx_a, w_b, rx_b). k = bending (Przemieniecki 1968, Ch. 5) plus
        geometric int N N'^T N' ds; m = mu int N^T N ds (consistent mass).
    """
    L = length
    kb = ei / L**3 * np.array([[12, 6 * L, -12, 6 * L], [6 * L, 4 * L**2, -6 * L, 2 * L**2],
                               [-12, -6 * L, 12, -6 * L], [6 * L, 2 * L**2, -6 * L, 4 * L**2]])
    s = (_GAUSS_X + 1) * L / 2
    w = _GAUSS_W * L / 2
    n, dn = hermite(s, L)
    tens = np.array([tension(si) for si in s])
    kg = (dn * (w * tens)[:, None]).T @ dn
    s5, w5 = np.polynomial.legendre.leggauss(5)
    n5, _ = hermite((s5 + 1) * L / 2, L)
    m = mu * (n5 * (w5 * L / 2)[:, None]).T @ n5
    return kb + kg, m


def tension_at(p: BccParams, y: float) -> float:
    """Axial tension of the beam at height y [N]: bottom tension plus the weight below.

    Parameters
    ----------
    p : BccParams
    y : float
        Height above point 9 [m], not at a grid point (where the tension jumps).

    Returns
    -------
    float
        N(y) [N].
    """
    below = p.beam_mu_kg_m * y
    for point, h in p.heights_m.items():
        if h < y:
            below += p.point_masses_kg.get(point, 0.0) + p.added_masses_kg.get(point, 0.0)
            if point == p.insert_point:
                below += p.crosspiece_mass_kg()
    return p.bottom_tension_n + below * p.gravity_m_s2


def _layout(p: BccParams, per_segment: int, arm_elements: int, cable_elements: int):
    """DOF labels and the beam's node rows (bottom-up) with the rigid-insert slaves.

    A node row is a dict {dof index: coefficient}: the nodal DOF as a combination of
    the independent DOFs (a slave at distance d from point 7: w = w_7 + d rx_7).
    """
    labels = [(q, d) for q in sorted(p.heights_m) for d in ("w", "rx")]
    idx = {lab: i for i, lab in enumerate(labels)}
    pts = sorted(p.heights_m, key=lambda q: p.heights_m[q])
    a = p.insert_length_m
    beam = []
    for lo, hi in zip(pts[:-1], pts[1:]):
        y0, y1 = p.heights_m[lo], p.heights_m[hi]
        start = y0 + (a if lo == p.insert_point else 0.0)
        stop = y1 - (a if hi == p.insert_point else 0.0)
        seg = []
        for j, y in enumerate(np.linspace(start, stop, per_segment + 1)):
            end = lo if j == 0 else hi if j == per_segment else None
            if end is not None:
                d = y - p.heights_m[end]
                w, r = idx[(end, "w")], idx[(end, "rx")]
                seg.append((y, {w: 1.0, r: d} if d else {w: 1.0}, {r: 1.0}))
            else:
                labels += [("beam", float(y), "w"), ("beam", float(y), "rx")]
                seg.append((y, {len(labels) - 2: 1.0}, {len(labels) - 1: 1.0}))
        beam.append((lo, hi, seg))
    arm = [(0.0, {idx[(p.insert_point, "w")]: 1.0}, {})]
    for x in np.linspace(0.0, p.arm_length_m, arm_elements + 1)[1:]:
        labels += [("arm", float(x), "w"), ("arm", float(x), "rx")]
        arm.append((float(x), {len(labels) - 2: 1.0}, {len(labels) - 1: 1.0}))
    cables = {}
    for name, point in (("top", pts[-1]), ("bottom", pts[0])):
        rows = [{idx[(point, "w")]: 1.0}]
        for i in range(1, cable_elements):
            labels.append(("cable", name, i))
            rows.append({len(labels) - 1: 1.0})
        cables[name] = rows + [{}]
    return labels, beam, arm, cables


def _matrix(rows, n):
    t = np.zeros((len(rows), n))
    for i, row in enumerate(rows):
        for j, c in row.items():
            t[i, j] = c
    return t


def _add_beam(p, beam, k, m):
    """Beam elements (bending, tension, consistent mass) with the segments' EI factors."""
    n = k.shape[0]
    for lo, hi, seg in beam:
        factor = p.ei_factors.get((hi, lo), p.ei_factors.get((lo, hi), 1.0))
        for (ya, wa, ra), (yb, wb, rb) in zip(seg[:-1], seg[1:]):
            ke, me = beam_element(p.beam_ei_nm2 * factor, p.beam_mu_kg_m, yb - ya,
                                  lambda s, y=ya: tension_at(p, y + s))
            t = _matrix([wa, ra, wb, rb], n)
            k += t.T @ ke @ t
            m += t.T @ me @ t


def _add_inserts(p, k, m, wi, ri):
    """Two rigid inserts of length a on either side of the clamp point."""
    a, yc, mu = p.insert_length_m, p.heights_m[p.insert_point], p.beam_mu_kg_m
    for sign in (+1.0, -1.0):
        mass = mu * a
        m[wi, wi] += mass
        m[wi, ri] += sign * mass * a / 2
        m[ri, wi] += sign * mass * a / 2
        m[ri, ri] += mass * a**2 / 3
        k[ri, ri] += a * tension_at(p, yc + sign * a / 2)


def _add_crosspiece(p, arm, k, m, wi, ri):
    """Crosspiece arms (symmetric bending), tips, clamp, torsion inertia, gravity coupling."""
    n = k.shape[0]
    cnt = p.arm_count
    f = np.zeros(n)
    for (xa, wa, ra), (xb, wb, rb) in zip(arm[:-1], arm[1:]):
        L = xb - xa
        ke, me = beam_element(cnt * p.arm_ei_nm2, cnt * p.arm_mu_kg_m, L, lambda s: 0.0)
        t = _matrix([wa, ra, wb, rb], n)
        k += t.T @ ke @ t
        m += t.T @ me @ t
        f += cnt * p.arm_mu_kg_m * np.array([L / 2, L**2 / 12, L / 2, -(L**2) / 12]) @ t
    tip = next(iter(arm[-1][1]))
    m[tip, tip] += cnt * p.tip_mass_kg
    f[tip] += cnt * p.tip_mass_kg
    f[wi] -= cnt * (p.arm_mu_kg_m * p.arm_length_m + p.tip_mass_kg)
    m[wi, wi] += p.clamp_mass_kg
    m[ri, ri] += (cnt * p.arm_mu_kg_m * p.arm_length_m
                  * (p.arm_width_m**2 + p.arm_thickness_m**2) / 12)
    e = np.zeros(n)
    e[ri] = 1.0
    k -= p.gravity_m_s2 * (np.outer(e, f) + np.outer(f, e))


def _add_cables(p, cables, k, m, top_tension):
    n = k.shape[0]
    spec = {"top": (p.top_length_m, p.top_mu_kg_m, top_tension),
            "bottom": (p.bottom_length_m, p.bottom_mu_kg_m, p.bottom_tension_n)}
    for name, rows in cables.items():
        length, mu, tens = spec[name]
        le = length / (len(rows) - 1)
        for ra, rb in zip(rows[:-1], rows[1:]):
            t = _matrix([ra, rb], n)
            k += t.T @ (tens / le * np.array([[1.0, -1.0], [-1.0, 1.0]])) @ t
            m += t.T @ (mu * le / 6 * np.array([[2.0, 1.0], [1.0, 2.0]])) @ t


def assemble(p: BccParams, elements_per_segment: int = 4, arm_elements: int = 6,
             cable_elements: int = 1) -> FEModel:
    """Assemble the BCC's FE model.

    Parameters
    ----------
    p : BccParams
        Physical parameters (with any concealed structural effects).
    elements_per_segment : int
        Beam elements per 10-in segment (>= 1); a segment next to the clamp has its
        9-in flexible part split so.
    arm_elements : int
        Elements along a crosspiece arm (>= 1).
    cable_elements : int
        String elements per cable pair (>= 1; 1 = the end-point stiffness T/L).

    Returns
    -------
    FEModel

    Raises
    ------
    ModelError
        A mesh count below 1, an effect at an unknown point, or matrices that are
        not symmetric positive definite.
    """
    for name, val in (("elements_per_segment", elements_per_segment),
                      ("arm_elements", arm_elements), ("cable_elements", cable_elements)):
        if int(val) != val or val < 1:
            raise ModelError(f"{name} must be an integer >= 1, got {val!r}")
    for point in list(p.added_masses_kg) + [q for q, _ in p.springs]:
        if point not in p.heights_m:
            raise ModelError(f"effect at unknown point {point!r} (points: {sorted(p.heights_m)})")
    labels, beam, arm, cables = _layout(p, elements_per_segment, arm_elements, cable_elements)
    n = len(labels)
    k, m = np.zeros((n, n)), np.zeros((n, n))
    idx = {lab: i for i, lab in enumerate(labels)}
    wi, ri = idx[(p.insert_point, "w")], idx[(p.insert_point, "rx")]
    _add_beam(p, beam, k, m)
    _add_inserts(p, k, m, wi, ri)
    _add_crosspiece(p, arm, k, m, wi, ri)
    top_tension = p.bottom_tension_n + p.total_weight_n()
    _add_cables(p, cables, k, m, top_tension)
    for q, mass in list(p.point_masses_kg.items()) + list(p.added_masses_kg.items()):
        m[idx[(q, "w")], idx[(q, "w")]] += mass
    for (q, d), stiff in p.springs.items():
        if d not in ("w", "rx"):
            raise ModelError(f"spring dof must be 'w' or 'rx', got {d!r}")
        k[idx[(q, d)], idx[(q, d)]] += stiff
    k, m = (k + k.T) / 2, (m + m.T) / 2
    if np.linalg.eigvalsh(m)[0] <= 0 or np.linalg.eigvalsh(k)[0] <= 0:
        raise ModelError("assembled mass or stiffness matrix is not positive definite")
    return FEModel(m=m, k=k, labels=tuple(labels), top_tension_n=top_tension)


def modes(model: FEModel, n: int | None = None):
    """Undamped natural frequencies and mass-normalised mode shapes.

    Parameters
    ----------
    model : FEModel
    n : int, optional
        Number of modes (default: all).

    Returns
    -------
    freq_hz : ndarray, shape (n,)
        Natural frequencies [Hz], ascending.
    phi : ndarray, shape (n_dof, n)
        Mode shapes, phi^T m phi = I.
    """
    lam, phi = scipy.linalg.eigh(model.k, model.m)
    n = len(lam) if n is None else n
    return np.sqrt(lam[:n]) / (2 * np.pi), phi[:, :n]
