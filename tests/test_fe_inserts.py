"""Mass of a grillage element with rigid inserts against the closed form of a rigid bar.

An element whose nodes are ``L = a1 + Lf + a2`` apart, with rigid inserts of
lengths ``a1`` and ``a2`` at its ends (Sec. 2.1.1, "two one inch rigid
inserts"), carries the beam's mass per length ``rho*A`` over the whole length
``L``. In a rigid-body motion the cubic shape functions of the flexible part
are exact, so ``1/2 v^T M v`` must equal the kinetic energy of a uniform
slender bar of length ``L``: ``1/2 rho*A * integral_0^L wdot(s)^2 ds`` plus,
for a rotation with a component along the bar, ``1/2 rho*Ip * L * (twist
rate)^2``. The closed form is written out here, independently of vlab.

The inserts' mass, already on the node DOFs, must not be carried across the
offset a second time (that would give 10 % too much rotary inertia at BCC
point 7).
"""

from __future__ import annotations

import numpy as np
import pytest

from vlab.fe.assembly import _element_matrices

RHO_A = 1.7  # kg/m
RHO_IP = 3.1e-4  # kg*m
A1, LF, A2 = 0.03, 0.5, 0.08  # m: unequal inserts
L_TOTAL = A1 + LF + A2
ZERO = (0.0, 0.0)


def _mass(direction: tuple[float, float]) -> np.ndarray:
    """Global 6x6 mass of the element, no pre-stress (``[w1, rx1, ry1, w2, rx2, ry2]``)."""
    _, me = _element_matrices(2.0, 1.0, RHO_A, RHO_IP, LF, None, ZERO, ZERO, ZERO, 0.0, (A1, A2), direction)
    return np.asarray(me)


def _rigid_velocity(direction, node1, w0_rate, omega, pivot):
    """Global node velocities of the rigid motion ``wdot(r) = w0_rate + (omega x (r - pivot))_z``.

    ``omega = (omega_x, omega_y)`` is an in-plane angular velocity [rad/s];
    node 2 lies at ``node1 + L_TOTAL * e``.
    """
    e = np.asarray(direction, float)
    r1 = np.asarray(node1, float)
    r2 = r1 + L_TOTAL * e
    ox, oy = omega

    def wdot(r):
        d = r - np.asarray(pivot, float)
        return w0_rate + ox * d[1] - oy * d[0]

    return np.array([wdot(r1), ox, oy, wdot(r2), ox, oy])


def _closed_form(direction, node1, w0_rate, omega, pivot) -> float:
    """Kinetic energy [J] of a uniform slender bar of length L_TOTAL in the same rigid motion."""
    e = np.asarray(direction, float)
    ox, oy = omega
    # along the bar, s from node 1: wdot(s) = c0 + c1*s
    d1 = np.asarray(node1, float) - np.asarray(pivot, float)
    c0 = w0_rate + ox * d1[1] - oy * d1[0]
    c1 = ox * e[1] - oy * e[0]  # bending slope rate (omega x e)_z
    twist = ox * e[0] + oy * e[1]  # rate of rotation about the bar's axis
    L = L_TOTAL
    bending = 0.5 * RHO_A * (c0**2 * L + c0 * c1 * L**2 + c1**2 * L**3 / 3.0)
    torsion = 0.5 * RHO_IP * L * twist**2
    return bending + torsion


DIRECTIONS = {
    "along y (as the BCC)": (0.0, 1.0),
    "rotated 37 deg": (np.cos(np.radians(37.0)), np.sin(np.radians(37.0))),
    "rotated 200 deg": (np.cos(np.radians(200.0)), np.sin(np.radians(200.0))),
}


def _perp(direction):
    """In-plane angular velocity of unit rate that rotates the bar in bending (omega perpendicular to e)."""
    ex, ey = direction
    return (ey, -ex)  # (omega x e)_z = ey*ey + ex*ex = 1


@pytest.mark.parametrize("name", list(DIRECTIONS))
@pytest.mark.parametrize("motion", ["translation", "rotation about node 1", "rotation about node 2",
                                    "rotation about the centre", "twist about the axis", "general"])
def test_rigid_body_kinetic_energy_matches_uniform_bar(name, motion):
    direction = DIRECTIONS[name]
    e = np.asarray(direction)
    node1 = np.array([0.2, -0.4])
    if motion == "translation":
        w0, omega, pivot = 0.7, (0.0, 0.0), node1
    elif motion == "twist about the axis":
        w0, omega, pivot = 0.0, tuple(2.3 * e), node1
    elif motion == "general":
        w0, omega, pivot = -0.4, (1.3, -0.6), (0.05, 0.11)
    else:
        s = {"rotation about node 1": 0.0, "rotation about node 2": L_TOTAL,
             "rotation about the centre": L_TOTAL / 2.0}[motion]
        w0, omega, pivot = 0.0, tuple(1.9 * np.asarray(_perp(direction))), node1 + s * e
    v = _rigid_velocity(direction, node1, w0, omega, pivot)
    got = 0.5 * v @ _mass(direction) @ v
    want = _closed_form(direction, node1, w0, omega, pivot)
    assert want > 0.0
    assert got == pytest.approx(want, rel=1e-10)


def test_closed_form_rotary_inertia_about_the_end_and_centre():
    """The test's own closed form reduces to the textbook m L^2/3 and m L^2/12 of a slender bar."""
    m = RHO_A * L_TOTAL
    direction = (0.0, 1.0)
    om = _perp(direction)
    node1 = np.zeros(2)
    e = np.asarray(direction)
    assert _closed_form(direction, node1, 0.0, om, node1) == pytest.approx(0.5 * m * L_TOTAL**2 / 3.0, rel=1e-14)
    assert _closed_form(direction, node1, 0.0, om, node1 + 0.5 * L_TOTAL * e) == pytest.approx(
        0.5 * m * L_TOTAL**2 / 12.0, rel=1e-14)


def test_bcc_rotary_inertia_at_the_clamp():
    """BCC point 7: the two 1-in inserts add rho*A*a^3/3 each about the point, not 7/3 of it.

    Rotating only the ``rx`` of point 7 (every other DOF held) moves the two
    flexible elements' ends by ``a`` and the inserts rigidly: the diagonal
    entry is the inserts' ``2 rho*A*a^3/3`` plus the flexible elements'
    consistent mass seen through the offset, written out here from the
    Hermite mass matrix (Przemieniecki Eq. 11.42) with ``w_end = a*b``.
    """
    from vlab.fe import build_fe_model
    from vlab.spec import load_spec

    spec = load_spec("bcc")
    fe = build_fe_model(spec)
    sec = spec.sections["steel_beam"]
    rho_a = sec.rho_a
    a = 0.0254
    lf = 10 * 0.0254 - a
    # flexible element with its insert at its node-b end (element 6-7) and at its node-a end (7-8):
    # DOFs of the end next to point 7 in the Hermite mass: [w, b] with w = -a*b (end b) or +a*b (end a).
    # Hermite end block [[156, 22L], [22L, 4L^2]] * rho_a*L/420 (sign of the coupling flips at end b).
    c = rho_a * lf / 420.0
    end_a = c * (156.0 * a**2 + 2 * 22.0 * lf * a + 4.0 * lf**2)
    end_b = c * (156.0 * a**2 + 2 * 22.0 * lf * a + 4.0 * lf**2)
    inserts = 2.0 * rho_a * a**3 / 3.0
    i = fe.dofs.index(7, "rx")
    # lumped contributions at point 7 that are not the beam's: the crosspiece and coil only act on w
    assert all(lm.inertia_rx is None for lm in spec.masses if lm.point == 7)
    assert fe.m[i, i] == pytest.approx(end_a + end_b + inserts, rel=1e-12)
