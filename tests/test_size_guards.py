"""A structure whose FE model would not fit a machine is refused before any work, naming the sizes."""

from __future__ import annotations

import dataclasses
import time

import pytest

from vlab.errors import ResourceError
from vlab.fe import build_fe_model
from vlab.fe.assembly import MAX_DOFS
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
