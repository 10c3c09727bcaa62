"""The hanging-grid MuJoCo plant: topology, pendulum plates, in-plane redundants, cross-check.

Targets (issue "MuJoCo models of both structures"): the first 12 modes within
2 % of the FE model and MAC >= 0.95 at the structure points. The default plant
is the forest topology (linear closures at member ends); ``tree`` is the former
build (spanning tree, loop welds through in-plane releases), kept as an option.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from vlab.sim import MujocoPlant, SimOptions, build_plant, crosscheck, free_decay, free_run, linearize, modes, settle
from vlab.spec import STRUCTURES_DIR, load_spec

pytestmark = pytest.mark.skipif(not (STRUCTURES_DIR / "grid.toml").exists(),
                                reason="assets/structures/grid.toml not present")


@pytest.fixture(scope="module")
def spec():
    return load_spec("grid")


@pytest.fixture(scope="module")
def bare(spec):
    """Plant without modal damping (fast to build)."""
    return build_plant(spec, SimOptions(modal_damping=False))


@pytest.fixture(scope="module")
def tree(spec):
    """The former build (commit 3c4910a): spanning tree, loop welds, a torsion hinge at every Gauss point."""
    return build_plant(spec, SimOptions(modal_damping=False, topology="tree", torsion_hinges="all",
                                        integrator="implicitfast"))


def test_topology(bare, spec):
    """Forest: the top beam one chain hung at point 17, the lattice points hung, bars closed at their far ends."""
    m = bare.model
    assert bare.info.topology == "forest"
    assert bare.info.root == 13
    assert bare.info.n_loops == 9  # 30 segments, 22 points: 30 - 22 + 1 loops
    assert m.opt.integrator == mujoco.mjtIntegrator.mjINT_EULER
    assert m.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_EULERDAMP
    hung = sorted(int(m.body(b).name[1:]) for b in range(1, m.nbody) if m.body_parentid[b] == 0)
    assert hung == list(range(1, 13)) + [17]
    types = {int(m.eq_type[i]) for i in range(m.neq)}
    assert types == {int(mujoco.mjtEq.mjEQ_TENDON)}
    names = [m.equality(i).name for i in range(m.neq)]
    assert len(names) == 21 * 3 + 2  # w, rx, ry at each bar's far end; w at bearings 13 and 22
    assert "support13.w" in names and "support22.w" in names
    assert not any(name.startswith("close.top_beam") for name in names)  # the top beam stays continuous
    np.testing.assert_allclose(m.eq_solref[0], [2 * m.opt.timestep, 1.0])
    np.testing.assert_allclose(m.eq_solimp[0], [0.9999, 0.9999, 0.001, 0.5, 2.0])
    joints = [m.joint(j).name for j in range(m.njnt)]
    assert not any(".cut" in j or ".release" in j for j in joints)  # no in-plane releases
    for p in range(1, 13):
        assert m.sensor(f"vel{p}").id >= 0
    assert bare.actuator_points == (1, 2, 4, 5, 8)
    for p in spec.points:
        assert m.site(f"p{p}").id >= 0


def test_closures_hold_to_first_order(bare):
    """A closure's tendon is w (or a rotation) of the bar's end minus that of the junction: zero along any
    joint motion to first order, second order in it (the in-plane gap the closure leaves free)."""
    m = bare.model
    d = bare.make_data()
    closures = [m.equality(i).name[len("close."):-len(".w")] for i in range(m.neq)
                if m.equality(i).name.startswith("close.") and m.equality(i).name.endswith(".w")]
    assert len(closures) == 21
    rng = np.random.default_rng(1)
    for eps in (1e-3, 1e-4):
        d.qpos[:] = m.qpos0 + eps * rng.standard_normal(m.nv)
        mujoco.mj_fwdPosition(m, d)
        for c in closures:
            tag, q = c.rsplit(".", 1)
            gap = d.site_xpos[m.site(f"{tag}.stub{q}.end").id][2] - d.site_xpos[m.site(f"J{q}.end.{tag}").id][2]
            assert abs(d.ten_length[m.tendon(f"close.{c}.w").id] - gap) < 20 * eps**2, c


def test_tree_topology(tree):
    """The former build: 9 loop welds and the connect at bearing 22, each through an in-plane release."""
    m = tree.model
    assert tree.info.topology == "tree" and tree.info.n_loops == 9
    welds = [m.equality(i).name for i in range(m.neq) if m.eq_type[i] == mujoco.mjtEq.mjEQ_WELD]
    assert len(welds) == 9
    assert m.equality("support22").type[0] == mujoco.mjtEq.mjEQ_CONNECT
    np.testing.assert_allclose(m.eq_solref[0], [2 * m.opt.timestep, 1.0])
    np.testing.assert_allclose(m.eq_solimp[0], [0.9999, 0.9999, 0.001, 0.5, 2.0])
    assert m.nv == 208 and tree.info.n_prestress == 10  # 9 loop cuts + the reaction of bearing 22
    names = [m.joint(j).name for j in range(m.njnt)]
    assert sum(n.endswith(".rz") and ".cut" in n for n in names) == 9
    assert "J22.release.x" in names
    assert m.jnt_stiffness[m.joint("root13.rx").id] == 0.0  # the pendulum plate, no joint spring


def test_pendulum_stiffness_comes_from_gravity(spec, bare):
    """The plates hang W/g at Y = k/W below the bearing axis; no joint spring or spring tendon is added."""
    m = bare.model
    for j in range(m.njnt):
        if not m.joint(j).name.endswith((".bend", ".twist", ".shear")):
            assert m.jnt_stiffness[j] == 0.0, m.joint(j).name
    assert not any(m.tendon(i).name.startswith("spring.") for i in range(m.ntendon))
    plate = next(x for x in spec.masses if x.id == "plate13")
    spring = next(x for x in spec.springs if x.id == "pendulum13")
    ecc = spring.stiffness.si / (plate.mass.si * 9.80665)
    d = settle(m)
    assert d.site_xpos[m.site("pendulum13.plate").id][1] == pytest.approx(-ecc, abs=1e-9)
    f_g = modes(m, sorted(spec.points), 1, data=d).frequencies_hz[0]
    # without gravity the swing about the bearing axis is a rigid-body motion (eigenvalue 1 of the step map)
    no_g = build_plant(spec, SimOptions(modal_damping=False, gravity=False))
    lin = linearize(no_g.model, settle(no_g.model))
    lam = np.linalg.eigvals(lin.A)
    assert np.min(np.abs(lam - 1.0)) < 1e-6
    assert modes(no_g.model, sorted(spec.points), 1, linear=lin).frequencies_hz[0] > f_g


def test_inplane_redundants_are_in_equilibrium(bare):
    d = settle(bare.model)
    assert np.max(np.abs(d.qacc)) < 1e-6
    assert bare.info.n_prestress == 23  # the 21 bars' far ends + the reactions of bearings 13 and 22


def test_cross_check_one_to_one_against_both_fe_meshes(spec, bare):
    """Modes paired one-to-one by MAC over a common band, against the thesis mesh and the plant's resolution.

    Measured, tree plant (two links per 0.373 m top-beam segment, four on the 0.746 m
    one, one on the 22 mm ones; 208 DOF, 187 with one link throughout): thesis mesh -- all 12 modes within 1.35 %
    (mode 7, -1.35 %: the FE's one-element top-beam segments), mode 12 -0.25 %, MAC >= 0.998; FE at the
    plant's resolution (top beam 4, bars 3-4 elements per segment) -- all 12 within 0.18 %, mode 12
    +0.03 %, MAC >= 0.998. With one link per top-beam segment (the former default) mode 12 was -3.28 %
    (thesis mesh) and -2.99 % (plant resolution), MAC 0.91/0.90: see the next test. The forest plant
    (165 DOF): thesis mesh within 1.34 %, plant resolution within 0.20 %, MAC >= 0.998.
    """
    thesis = crosscheck(bare, 12)
    fine = crosscheck(bare, 12, mesh="plant")
    for cc in (thesis, fine):
        assert [p.sim_mode for p in cc.pairs] == list(range(1, 13)), cc.table()
        assert cc.unpaired == (), cc.table()
        assert abs(cc.pairs[11].error_pct) <= 0.5, cc.table()
        assert cc.min_mac() >= 0.99, cc.table()
    assert thesis.max_error_pct() <= 1.5, thesis.table()  # the goal, 2 %, one-to-one
    assert fine.max_error_pct() <= 0.25, fine.table()
    assert fine.fe_elements["top_beam"] == bare.info.links["top_beam"] == 4
    assert fine.fe_elements["bar_1_3"] == 3 and fine.fe_elements["bar_10_11"] == 4
    for topology in ("tree", "forest"):
        own_weight = build_plant(spec, SimOptions(modal_damping=False, inplane_redundants=False, topology=topology))
        # the tree: all weight down the spanning tree; the forest: each chain carries its own weight only
        assert crosscheck(own_weight, 12).max_error_pct() > 5.0, topology  # the wrong geometric stiffness


def test_tree_and_forest_have_the_same_modes(bare, tree):
    """The forest (one torsion hinge per segment, explicit damping) against the former tree build: the 12
    cross-check frequencies agree within 0.1 % (measured 0.06 %), the shapes at the points with MAC >= 0.999."""
    pts = sorted(bare.spec.points)
    a, b = modes(bare.model, pts, 12), modes(tree.model, pts, 12)
    np.testing.assert_allclose(a.frequencies_hz, b.frequencies_hz, rtol=1e-3)
    for i in range(12):
        x, y = a.shapes[:, i], b.shapes[:, i]
        assert abs(x @ y) ** 2 / ((x @ x) * (y @ y)) >= 0.999, i


def test_top_beam_gets_two_links_where_it_bends(spec, bare):
    """The planner gives the shear-flexible top beam the two-link minimum of the bars (planner.MIN_LINKS) on its
    0.373 m segments and 4 links (of at most 0.2 m) on the 0.746 m one; the 22 mm segments at the bearings,
    short against the section's shear length (planner.SHEAR_SHORT_PHI), keep one."""
    joints = [bare.model.joint(j).name for j in range(bare.model.njnt)]
    for seg, n in (("13-14", 1), ("14-15", 1), ("15-16", 2), ("16-17", 2), ("17-18", 4), ("21-22", 1)):
        bends = sorted(name for name in joints if name.startswith(f"top_beam.{seg}.") and name.endswith(".bend"))
        assert len(bends) == n, (seg, bends)
    assert bare.model.nv == 165  # 208 in the former tree build (releases, a torsion hinge at every Gauss point)
    # the automatic step still divides the lab's 0.5 ms sample
    assert bare.timestep_s == pytest.approx(5e-4, rel=1e-12)


def test_one_link_per_top_beam_segment_misses_mode_12(spec):
    """The former default, one link per top-beam segment, puts mode 12 about 3 % low against the FE model at the
    plant's resolution (measured -2.99 %, MAC 0.896): the cause the planner's two-link minimum removes."""
    plant = build_plant(spec, SimOptions(modal_damping=False, member_segments={"top_beam": 1}))
    cc = crosscheck(plant, 12, mesh="plant")
    assert [p.sim_mode for p in cc.pairs] == list(range(1, 13)), cc.table()
    assert max(abs(p.error_pct) for p in cc.pairs[:11]) <= 0.25, cc.table()
    assert cc.pairs[11].error_pct <= -2.5, cc.table()


@pytest.mark.long
def test_damped_grid(spec):
    plant = build_plant(spec)
    cc = crosscheck(plant, 12)
    for p in cc.pairs:  # exact modal damping: within 0.2 % (the tree's loop welds shifted a few ratios by ~2 %)
        assert p.sim_zeta == pytest.approx(spec.damping.modal_ratios[p.fe_mode - 1], rel=0.05)
    j = cc.pairs[0].sim_mode
    fd = free_decay(plant, j, amplitude_m=1e-4, sim_modes=cc.sim_modes)
    assert fd.frequency_hz == pytest.approx(cc.sim_modes.frequencies_hz[j - 1], rel=2e-3)


@pytest.mark.long
def test_grid_sixty_seconds_no_energy_growth(spec):
    """60 s free vibration: the energy never rises above its start and decays.

    In the tree plant the modal initial displacement violated the loop welds at
    second order (~ amplitude^2), and the welds' constraint work is not part of
    MuJoCo's energy: at 1 mm the books showed a 1.5 % blip in the first 10 ms, at
    0.1 mm 0.015 % -- hence the small amplitude (the forest's closures are linear).
    """
    plant = build_plant(spec)
    run = free_run(plant, 60.0, amplitude_m=1e-4, sample_every=200)
    assert run.max_growth <= 1e-3
    assert run.energy[-1] < 1e-3 * run.energy[0]


def _impulse_response(plant, impulse_ns: float, seconds: float = 1.5) -> np.ndarray:
    """Velocity [m/s] at point 1 after a 10 ms force pulse of ``impulse_ns`` [N s] at point 4."""
    run = MujocoPlant(plant)
    dt = run.timestep_s
    u = np.zeros(len(run.actuator_points))
    k = run.actuator_points.index(4)
    pulse = int(round(0.01 / dt))
    v = np.empty(int(round(seconds / dt)))
    for i in range(v.size):
        u[k] = impulse_ns / (pulse * dt) if i < pulse else 0.0
        run.set_forces(u)
        run.step()
        v[i] = run.velocities((1,))[0]
    return v


def test_forced_response_scales_with_the_force(bare):
    """A 100x larger pulse gives a 100x larger response, in the forest (linear closures) and in the tree (the
    in-plane releases of the loop welds).

    Without the releases the welds enforced the deflected shape's in-plane foreshortening
    rigidly: at 10 mN s the response per newton differed by ~40 % from the one at
    0.1 mN s (README: plant linearity).
    """
    small = _impulse_response(bare, 1e-4)
    large = _impulse_response(bare, 1e-2)
    assert np.linalg.norm(large / 1e-2 - small / 1e-4) <= 1e-3 * np.linalg.norm(small / 1e-4)


def test_forced_response_scales_with_the_force_in_the_tree(tree):
    """As above, for the former build (the in-plane releases of its loop welds)."""
    small = _impulse_response(tree, 1e-4)
    large = _impulse_response(tree, 1e-2)
    assert np.linalg.norm(large / 1e-2 - small / 1e-4) <= 1e-3 * np.linalg.norm(small / 1e-4)


def test_modes_just_above_the_damped_ones_get_the_default_ratio(spec):
    """Modes 13-14 (10.2 and 12 Hz) are damped at the default ratio, as the FE model damps them.

    With the hinge damping alone they kept ~0.06 % and, brought into the 10 Hz
    test band by a changed spec (a softened top-beam joint), rang 4x longer than
    in the FE model (vlab.sim.damping.ABOVE_DAMPED).
    """
    from vlab.sim.damping import ABOVE_DAMPED

    r = build_plant(spec).damping
    n = len(spec.damping.modal_ratios)
    top = max(f for f, m in zip(r.frequencies_hz, r.spec_modes) if m == n)
    above = [(f, z) for f, m, z in zip(r.frequencies_hz, r.spec_modes, r.target_ratios) if m is None and f > top]
    assert len(above) >= 2
    for f, z in above:
        assert f <= ABOVE_DAMPED * 1.02 * top
        assert z == spec.damping.default_ratio


def test_forward_and_centred_linearisations_give_the_same_modes(spec, bare):
    """The default forward-difference linearisation (half the steps) keeps the grid's modes of the centred one."""
    d = settle(bare.model)
    pts = sorted(spec.points)
    fwd = modes(bare.model, pts, 20, data=d, linear=linearize(bare.model, d))
    cen = modes(bare.model, pts, 20, data=d, linear=linearize(bare.model, d, centred=True))
    assert np.max(np.abs(fwd.frequencies_hz / cen.frequencies_hz - 1.0)) < 1e-8
    assert np.max(np.abs(fwd.damping_ratios - cen.damping_ratios)) < 1e-8
