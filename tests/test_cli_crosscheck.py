"""`vlab crosscheck --json`: the pairing against both FE references and the unpaired MuJoCo modes."""

from __future__ import annotations

import json
import math

import pytest
from typer.testing import CliRunner

from _json_numbers import json_numbers

from vlab.cli import app

runner = CliRunner()


def test_crosscheck_json_shows_both_references_and_the_unpaired_mode():
    res = runner.invoke(app, ["crosscheck", "bcc", "--json"])
    assert res.exit_code == 0, res.output
    out = json.loads(res.stdout)
    assert set(out["references"]) == {"thesis_mesh", "plant_resolution"}
    assert out["references"]["thesis_mesh"]["fe_elements_per_segment"] == {"beam": 1}
    assert out["references"]["plant_resolution"]["fe_elements_per_segment"] == {"beam": 2}
    for ref in out["references"].values():
        pairs = ref["pairs"]
        assert [p["fe_mode"] for p in pairs] == [1, 2, 3, 4, 5, 6]
        assert [p["mujoco_mode"] for p in pairs] == [1, 2, 4, 5, 6, 7]  # mode 3: the arms' anti-symmetric bending
        for p in pairs:
            assert p["error_pct"] == pytest.approx((p["mujoco_hz"] - p["fe_hz"]) / p["fe_hz"] * 100, rel=1e-12)
        assert ref["max_abs_error_pct"] == max(abs(p["error_pct"]) for p in pairs)
        (u,) = ref["unpaired_mujoco_modes"]
        assert u["mujoco_mode"] == 3 and u["mujoco_hz"] < pairs[2]["mujoco_hz"]
        assert u["mujoco_hz"] <= ref["pairing_band_hz"]
    # within the cross-check's tolerance, and the JSON says so with the tolerance and its source
    tol = out["tolerance"]
    assert tol["max_abs_error_pct"] > 0 and 0 < tol["min_mac"] < 1 and tol["source"]
    assert all(r["max_abs_error_pct"] <= tol["max_abs_error_pct"] and r["min_mac"] >= tol["min_mac"]
               for r in out["references"].values())
    assert out["within_tolerance"] is True and out["beyond_tolerance"] == {}
    # every number's key names its unit, or is a dimensionless ratio / a mode or element count
    dimensionless = {"relative_error", "mac", "best_mac", "min_mac", "free_decay_mode1_damping", "fe_mode",
                     "mujoco_mode", "best_fe_mode", "beam"}
    for key, v in json_numbers(out, ""):
        assert math.isfinite(v)
        assert key in dimensionless or key.endswith(("_hz", "_pct", "_s")) or key in ("fe", "mujoco"), key
