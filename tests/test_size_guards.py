"""A structure whose FE model would not fit a machine is refused before any work, naming the sizes."""

from __future__ import annotations

import dataclasses
import time

import numpy as np
import pytest

from vlab.errors import ResourceError
from vlab.fe import build_fe_model
from vlab.fe.size import MAX_DOFS
from vlab.spec import load_spec


def test_a_model_beyond_the_limit_is_refused_at_once():
    spec = load_spec("grid")
    big = dataclasses.replace(spec, members=tuple(dataclasses.replace(m, elements_per_segment=200)
                                                  for m in spec.members))
    t = time.perf_counter()
    with pytest.raises(ResourceError, match=r"about \d+ degrees of freedom .* more than 6000"):
        build_fe_model(big)
    assert time.perf_counter() - t < 5.0     # before the statics and the assembly
    # the shipped structures are far below it
    assert len(build_fe_model(spec).dofs) < MAX_DOFS / 10


def test_the_command_line_names_the_sizes_and_exits_2(tmp_path):
    from typer.testing import CliRunner

    from vlab.cli import app

    path = tmp_path / "fine_grid.toml"
    assert CliRunner().invoke(app, ["init", "grid", str(path)]).exit_code == 0
    text = path.read_text()
    n = text.count("elements_per_segment = 1")
    assert n > 5
    path.write_text(text.replace("elements_per_segment = 1", "elements_per_segment = 200"))
    res = CliRunner().invoke(app, ["modes", str(path), "--json"])
    assert res.exit_code == 2, res.output
    assert "degrees of freedom" in res.output and "elements_per_segment" in res.output


def test_the_statics_solve_is_the_least_squares_solution():
    """The in-plane solve against numpy's least squares: equal on a regular system, the minimum-norm
    solution of a singular but consistent one (a mechanism whose loads balance)."""
    from vlab.fe.statics import _solve_symmetric

    rng = np.random.default_rng(1)
    a = rng.standard_normal((40, 40))
    k = a @ a.T + 40 * np.eye(40)
    f = rng.standard_normal(40)
    assert np.allclose(_solve_symmetric(k, f), np.linalg.lstsq(k, f, rcond=None)[0], rtol=1e-10, atol=1e-12)
    b = rng.standard_normal((40, 30))
    k1 = b @ b.T                                   # rank 30
    f1 = k1 @ rng.standard_normal(40)              # in its range
    x = _solve_symmetric(k1, f1)
    assert np.allclose(k1 @ x, f1, atol=1e-8)
    assert np.allclose(x, np.linalg.pinv(k1) @ f1, atol=1e-8)


def _chain(n: int):
    from vlab.sim.plan import Body, Joint, Plan

    bodies = {}
    parent = None
    for i in range(n):
        name = f"b{i}"
        bodies[name] = Body(name, np.zeros(3), parent, "", joints=[Joint(f"j{i}", "hinge", np.array([1.0, 0, 0]),
                                                                         np.zeros(3))])
        parent = name
    return Plan(bodies, {}, [], [], [], [], [], 0)


def test_a_plant_deeper_than_mujoco_compiles_is_refused_before_compiling():
    from vlab.sim.planner import MAX_TREE_DEPTH, check_plant_size

    spec = load_spec("bcc")
    check_plant_size(spec, _chain(MAX_TREE_DEPTH))
    with pytest.raises(ResourceError, match=r"1024 bodies deep, more than MuJoCo compiles \(1023\)"):
        check_plant_size(spec, _chain(MAX_TREE_DEPTH + 1))


def test_a_plant_whose_linearisation_is_too_large_is_refused():
    from vlab.fe.size import MAX_DOFS
    from vlab.sim.planner import check_plant_size

    plan = _chain(MAX_DOFS // 2 + 1)
    # a wide tree (every body on the world), so that only the size is at fault
    for body in plan.bodies.values():
        body.parent = None
    with pytest.raises(ResourceError, match=r"linearisation would have about 6002 degrees of freedom"):
        check_plant_size(load_spec("bcc"), plan)


@pytest.mark.long
def test_mujoco_compiles_a_chain_of_the_limit_and_refuses_one_more():
    """MuJoCo's own depth limit, measured (about 25 s); the default run checks vlab's guard at the same
    number (test_a_plant_deeper_than_mujoco_compiles_is_refused_before_compiling)."""
    import mujoco

    from vlab.sim.planner import MAX_TREE_DEPTH

    def chain(n):
        ms = mujoco.MjSpec()
        body = ms.worldbody
        for _ in range(n):
            body = body.add_body(pos=[0, 0, 0.01])
            body.add_joint(type=mujoco.mjtJoint.mjJNT_HINGE, axis=[1, 0, 0])
            body.add_geom(size=[0.01, 0, 0], mass=0.01)
        return ms

    chain(MAX_TREE_DEPTH).compile()
    with pytest.raises(Exception, match="depth limit"):
        chain(MAX_TREE_DEPTH + 1).compile()


def test_plant_estimate_grows_with_the_cube_of_the_states():
    from vlab.sim.estimate import BASE_S, plant_estimate

    small, large = plant_estimate(100), plant_estimate(200)
    assert (large["time_s"] - BASE_S) / (small["time_s"] - BASE_S) == pytest.approx(8.0)
    assert large["memory_bytes"] == 48.0 * 400 ** 2
    assert plant_estimate(100, crosscheck=True)["time_s"] > small["time_s"]
