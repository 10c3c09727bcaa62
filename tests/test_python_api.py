"""The Python API: ``import vlab`` gives the documented entry points; the tutorial runs."""

from __future__ import annotations

import inspect
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg

import vlab

DOC = Path(__file__).resolve().parents[1] / "docs" / "python-api.md"
ENTRY = ("load_spec", "modes", "design", "run_experiment", "diagnose", "update", "verify_update", "export_mjcf")


def test_entry_points_are_callable_and_documented():
    for name in ENTRY:
        f = getattr(vlab, name)
        assert callable(f), name
        doc = inspect.getdoc(f if inspect.isfunction(f) else f.__wrapped__)
        assert "Parameters" in doc and "Returns" in doc and "Raises" in doc, name
        inspect.signature(f)


def test_design_and_diagnose_stay_subpackages_and_callable():
    import vlab.design as design_module
    import vlab.diagnose.report  # noqa: F401 - imports the subpackage

    assert hasattr(design_module, "design_controller") and callable(vlab.design)
    assert hasattr(vlab.diagnose, "report") and callable(vlab.diagnose)
    assert list(inspect.signature(vlab.diagnose).parameters)[:2] == ["structure", "recording"]


def test_import_is_lazy():
    code = "import sys, vlab; print(any(m in sys.modules for m in ('numpy', 'scipy', 'mujoco', 'vlab.fe')))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         cwd=Path(__file__).resolve().parents[1]).stdout
    assert out.strip() == "False"


def test_modes_equal_an_independent_eigen_solution():
    """vlab.modes against scipy's generalized symmetric eigensolver on the same FE matrices."""
    from vlab.models import nominal_fe_model

    f, shapes = vlab.modes("bcc", 6)
    fe = nominal_fe_model("bcc")
    w2 = scipy.linalg.eigh(fe.k, fe.m, eigvals_only=True)[:6]
    np.testing.assert_allclose(f, np.sqrt(w2) / (2 * np.pi), rtol=1e-9)
    np.testing.assert_allclose(shapes.T @ fe.m @ shapes, np.eye(6), atol=1e-8)


def test_run_experiment_refuses_lqr_and_bad_values():
    import pytest

    from vlab.errors import OptionError

    with pytest.raises(OptionError, match="lqg"):
        vlab.run_experiment("bcc", "lqr", plant="linear")
    with pytest.raises(OptionError, match="noise_m_s"):
        vlab.run_experiment("bcc", "none", plant="linear", noise_m_s=-1.0)


def test_tutorial_code_runs(capsys):
    """Every ``python`` block of docs/python-api.md, in order, in one namespace (linear plant: fast)."""
    blocks = re.findall(r"```python\n(.*?)```", DOC.read_text(), flags=re.S)
    assert len(blocks) >= 4
    ns: dict = {}
    for b in blocks:
        exec(compile(b, str(DOC), "exec"), ns)  # noqa: S102 - the tutorial's own code
    out = capsys.readouterr().out
    assert "Beam Cross-Cable" in out and "mismatch: False" in out and "bcc.xml" in out
    names = set(re.findall(r"vlab\.(\w+)\(", "".join(blocks)))
    assert names <= set(ENTRY), names - set(ENTRY)


@pytest.mark.parametrize(("kw", "named"), [({"delay_periods": -1.0}, "delay_periods must be a finite number >= 0"),
                                           ({"noise_m_s": "abc"}, "noise_m_s must be a finite number >= 0, got 'abc'"),
                                           ({"duration_s": 0.0}, "duration_s must be a finite number > 0"),
                                           ({"period_s": float("nan")}, "period_s must be a finite number > 0"),
                                           ({"seed": 2**32}, "seed must be an integer")])
def test_run_experiment_refuses_bad_numbers_by_name_before_any_work(kw, named):
    from vlab.errors import OptionError

    with pytest.raises(OptionError, match=re.escape(named)):
        vlab.run_experiment("bcc", **kw)
