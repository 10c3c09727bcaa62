"""A changed structure keeps the unchanged one's damping matrix (vlab.fe.damping), in the FE model and the plant.

Checked against independent computations: the complex eigenvalues of the non-classically damped FE system
(M', C0, K') for the FE projection, and MuJoCo's own finite-difference linearisation of the damped changed
plant for the plant's projected ratios.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

from vlab.diagnose.effects import specedit
from vlab.fe import build_fe_model, modal_analysis
from vlab.fe.damping import open_loop_ratios, structural_damping, structural_ratios
from vlab.spec import load_spec


@pytest.fixture(scope="module")
def bcc():
    return load_spec("bcc")


def _state_space_ratios(m, c, k, n):
    """Damping ratios of the n lowest modes from the eigenvalues of the first-order system (no projection)."""
    nd = m.shape[0]
    a = np.block([[np.zeros((nd, nd)), np.eye(nd)], [-np.linalg.solve(m, k), -np.linalg.solve(m, c)]])
    lam = scipy.linalg.eigvals(a)
    lam = lam[lam.imag > 1e-9]
    lam = lam[np.argsort(np.abs(lam))][:n]
    return -lam.real / np.abs(lam)


def test_an_edit_names_the_unchanged_structure_as_its_damping_basis(bcc):
    one = specedit.add_mass(bcc, 6, 0.2)
    two = specedit.add_spring(one, 7, "w", 50.0)
    assert one.damping.basis is bcc and two.damping.basis is bcc  # the structure before the first change
    three = specedit.set_modal_damping(two, 1, 0.01)
    assert three.damping.basis is bcc and three.damping.modal_ratios[0] == 0.01
    assert bcc.damping.basis is None  # the original is untouched


def test_an_unchanged_structure_keeps_its_own_ratios(bcc):
    fe = build_fe_model(bcc)
    md = modal_analysis(fe.m, fe.k)
    assert np.array_equal(structural_ratios(fe, md), open_loop_ratios(bcc, fe.n))


@pytest.mark.parametrize("edit", ["mass", "spring", "member"])
def test_fe_ratios_of_a_changed_structure_match_the_damped_eigenvalues(bcc, edit):
    """The projection phi'^T C0 phi' / (2 omega') against the exact eigenvalues of (M', C0, K'): equal to
    second order in the damping (here within 1e-3 relative)."""
    changed = {"mass": lambda s: specedit.add_mass(s, 6, 0.3),
               "spring": lambda s: specedit.add_spring(s, 7, "w", 200.0),
               "member": lambda s: specedit.scale_member(s, s.members[0].id, 1.3)}[edit](bcc)
    fe = build_fe_model(changed)
    md = modal_analysis(fe.m, fe.k)
    z_proj = structural_ratios(fe, md)[:6]
    z_exact = _state_space_ratios(fe.m, structural_damping(fe), fe.k, 6)
    assert z_proj == pytest.approx(z_exact, rel=1e-3)
    # and they moved: the ratios are not the spec's any more (a fixed ratio is a different damping model)
    assert np.max(np.abs(z_proj / open_loop_ratios(bcc, 6) - 1)) > 0.01


def test_an_added_mass_lowers_the_first_ratio_with_its_frequency(bcc):
    """A mass at a point that barely changes the first mode's shape: zeta' ~ zeta omega'/omega (Adhikari 2000)."""
    fe0, fe1 = build_fe_model(bcc), build_fe_model(specedit.add_mass(bcc, 6, 0.3))
    m0, m1 = modal_analysis(fe0.m, fe0.k), modal_analysis(fe1.m, fe1.k)
    z1 = structural_ratios(fe1, m1)[0]
    z0 = open_loop_ratios(bcc, 1)[0]
    assert z1 < z0
    assert z1 == pytest.approx(z0 * m1.omega[0] / m0.omega[0], rel=0.01)


def test_the_plant_of_a_changed_structure_keeps_the_damping_and_its_ratios_are_mujocos(bcc):
    """The changed plant carries the unchanged plant's modal damping and hinge damping; the ratios it reports
    (projected) agree with the eigenvalues of MuJoCo's finite-difference linearisation of the damped plant."""
    from vlab.sim import build_plant, linearize, modes, settle

    p0 = build_plant(bcc)
    changed = specedit.add_mass(bcc, 6, 0.3)
    p1 = build_plant(changed)
    assert np.array_equal(p0.modal_damping.A, p1.modal_damping.A)
    assert np.array_equal(p0.model.dof_damping, p1.model.dof_damping)
    d = settle(p1.model)
    lin = modes(p1.model, sorted(changed.points), data=d, linear=linearize(p1.model, d))
    n = 7
    assert p1.modes.frequencies_hz[:n] == pytest.approx(lin.frequencies_hz[:n], rel=1e-3)
    assert p1.modes.damping_ratios[:n] == pytest.approx(lin.damping_ratios[:n], rel=2e-3)
    # the FE model and the plant agree on the first mode's new ratio (each with its own projection)
    fe1 = build_fe_model(changed)
    z_fe = structural_ratios(fe1, modal_analysis(fe1.m, fe1.k))[0]
    assert p1.modes.damping_ratios[0] == pytest.approx(z_fe, rel=0.01)


def test_the_fe_frf_of_a_changed_structure_is_the_direct_solution(bcc):
    """The modal FRF of a changed structure (classical sum plus the damping coupling of the modes near the band,
    vlab.diagnose.model.labmodel.plant_frf) against the direct solution j w (K - w^2 M + j w C0)^-1 at the
    points, with the unchanged structure's damping matrix C0 carried over (no modes at all)."""
    from vlab.diagnose.model.labmodel import LabState, plant_frf
    from vlab.lab.loop import HardwareChain

    changed = specedit.add_mass(bcc, 6, 0.3)
    fe = build_fe_model(changed)
    state = LabState(changed, fe, HardwareChain(), None)
    f = np.linspace(0.5, 25.0, 400)
    pts = (5, 6, 7, 9)
    h = plant_frf(state, f, pts, (9,))[:, :, 0]
    c = structural_damping(fe)
    rows = fe.dofs.indices(pts, "w")
    col = fe.dofs.indices((9,), "w")[0]
    direct = np.array([1j * w * np.linalg.solve(fe.k - w**2 * fe.m + 1j * w * c, np.eye(fe.n)[:, col])[rows]
                       for w in 2 * np.pi * f])
    rel = np.abs(h - direct) / np.max(np.abs(direct), axis=0)
    assert np.max(rel) < 2e-3
    # the classical sum alone (each mode with its projected ratio) misses the coupling of the close modes
    from vlab.diagnose.model import labmodel

    md = modal_analysis(fe.m, fe.k)
    ph = md.shapes[fe.dofs.indices(pts + (9,), "w"), :]
    w = 2 * np.pi * f
    classical = labmodel.modal_receptance(md.omega, structural_ratios(fe, md), ph, w)[:, :len(pts), -1] \
        * 1j * w[:, None]
    assert np.max(np.abs(classical - direct) / np.max(np.abs(direct), axis=0)) > 5 * np.max(rel)


def test_the_coupled_receptance_equals_a_direct_solve():
    """The state-space modal sum of the damping-coupled modes (``_coupled_block``) against an independent
    reference: at each frequency, ``Phi_p (Omega^2 - w^2 I + i w C_m)^-1 Phi_p^T`` solved directly."""
    from vlab.diagnose.model.labmodel import _coupled_block

    rng = np.random.default_rng(3)
    n, n_p = 10, 4
    om = np.sort(rng.uniform(5.0, 60.0, n))
    zeta = np.full(n, 0.01)
    ph = rng.standard_normal((n_p, n))
    c = 0.05 * rng.standard_normal((n, n))
    c = c + c.T
    np.fill_diagonal(c, 0.0)
    w = np.linspace(1.0, 70.0, 200)
    got = _coupled_block(om, zeta, ph, w, c, np.arange(n))
    cm = c + np.diag(2.0 * zeta * om)
    ref = np.array([ph @ np.linalg.solve(np.diag(om**2) - wk**2 * np.eye(n) + 1j * wk * cm, ph.T) for wk in w])
    assert got.shape == (w.size, n_p, n_p)
    np.testing.assert_allclose(got, ref, rtol=1e-10, atol=1e-12 * np.abs(ref).max())


def test_the_classical_receptance_equals_a_direct_solve():
    """The classical modal sum of ``modal_receptance`` against ``Phi_p (Omega^2 - w^2 I + i w diag(2 zeta omega))^-1
    Phi_p^T`` solved at each frequency, on the real axis and at complex frequencies (a shifted contour)."""
    from vlab.diagnose.model.labmodel import modal_receptance

    rng = np.random.default_rng(4)
    n, n_p = 12, 5
    om = np.sort(rng.uniform(5.0, 80.0, n))
    zeta = rng.uniform(0.002, 0.05, n)
    ph = rng.standard_normal((n_p, n))
    for w in (np.linspace(1.0, 90.0, 150), np.linspace(1.0, 90.0, 150) - 0.3j):
        got = modal_receptance(om, zeta, ph, w)
        cm = np.diag(2.0 * zeta * om)
        ref = np.array([ph @ np.linalg.solve(np.diag(om**2) - wk**2 * np.eye(n) + 1j * wk * cm, ph.T) for wk in w])
        np.testing.assert_allclose(got, ref, rtol=1e-10, atol=1e-12 * np.abs(ref).max())


def test_the_carried_damping_matrix_is_cached_read_only():
    """The unchanged structure's matrix carried to a changed one is computed once and cannot be edited in place
    (a caller adding dashpots copies it)."""
    spec = load_spec("bcc")
    changed = specedit.add_mass(spec, 6, 0.1)
    fe = build_fe_model(changed)
    a, b = structural_damping(fe, changed), structural_damping(fe, changed)
    assert a is b and not a.flags.writeable
    with pytest.raises(ValueError):
        a[0, 0] += 1.0


@pytest.mark.parametrize("n", [2, 4])
def test_a_member_split_on_a_mesh_with_interior_nodes_keeps_the_damping_matrix(bcc, n):
    """A segment scaled by 1 is the same structure: with ``n`` elements per segment the split renames the
    interior nodes (``"<member>.<segment>.<k>"`` of the new pieces), which are carried by place, so the damping
    matrix and the modal ratios are the unchanged structure's (the spec's 0.004, 0.002, ...)."""
    import dataclasses

    fine = bcc.replace(members=tuple(dataclasses.replace(m, elements_per_segment=n) for m in bcc.members))
    split = specedit.scale_segments(fine, {(8, 9): 1.0})
    fe0, fe1 = build_fe_model(fine), build_fe_model(split)
    assert fe0.dofs.labels != fe1.dofs.labels and fe0.n == fe1.n
    order = [fe0.dofs._index[lab] if lab in fe0.dofs else None for lab in fe1.dofs.labels]
    assert None in order  # some DOFs are renamed
    md = modal_analysis(fe1.m, fe1.k)
    np.testing.assert_allclose(structural_ratios(fe1, md, split)[:6], open_loop_ratios(bcc, 6), rtol=1e-6)
    c1 = structural_damping(fe1, split)
    c0 = structural_damping(fe0, fine)

    def place(fe, lab):  # a DOF without a mesh node (the crosspiece's) keeps its label
        if lab[0] not in fe.mesh.nodes:
            return lab
        x, y = fe.mesh.nodes[lab[0]]
        return round(x, 9), round(y, 9), lab[1]

    where0 = {place(fe0, lab): j for j, lab in enumerate(fe0.dofs.labels)}
    perm = np.array([where0[place(fe1, lab)] for lab in fe1.dofs.labels])
    assert sorted(perm) == list(range(fe0.n))
    np.testing.assert_allclose(c1, c0[np.ix_(perm, perm)], rtol=1e-10, atol=1e-14)  # entry by entry
