"""controllers: documentation and dependency hygiene of the public API."""

from __future__ import annotations

import importlib
import inspect
import pathlib
import re
import subprocess
import sys

import pytest

import controllers
from controllers import errors

PKG_DIR = pathlib.Path(controllers.__file__).parent
#: Every module of the package (each declares ``__all__``, empty where it has no public names).
MODULES = sorted(p.stem for p in PKG_DIR.glob("*.py") if p.stem != "__init__")


def test_modules_are_found():
    assert {"errors", "statespace", "performance", "lq", "drf", "realization", "pycontrol"} <= set(MODULES)


def _public(kind):
    """``("<module>.<name>", object)`` of each name in the modules' ``__all__`` for which ``kind(object)`` holds."""
    for name in MODULES:
        mod = importlib.import_module(f"controllers.{name}")
        for attr in mod.__all__:
            obj = getattr(mod, attr)
            if kind(obj):
                yield f"{name}.{attr}", obj


@pytest.mark.parametrize("qualname, func", list(_public(inspect.isfunction)))
def test_every_public_function_documents_its_parameters(qualname, func):
    """numpydoc: every parameter named in the docstring; errors and returns documented."""
    doc = inspect.getdoc(func)
    assert doc, f"{qualname} has no docstring"
    params = [p for p in inspect.signature(func).parameters if p not in ("self",)]
    missing = [p for p in params if not re.search(rf"\b{re.escape(p)}\b", doc)]
    assert not missing, f"{qualname}: undocumented parameters {missing}"
    if not qualname.startswith("errors.") or qualname == "errors.check_matrix":
        assert "Raises" in doc, f"{qualname}: no Raises section"


def test_every_public_class_and_method_has_a_docstring():
    for qualname, cls in _public(inspect.isclass):
        assert inspect.getdoc(cls), qualname
        for mname, meth in vars(cls).items():
            if mname.startswith("_") or not callable(meth) and not isinstance(meth, property):
                continue
            assert inspect.getdoc(meth), f"{qualname}.{mname}"


def test_errors_subclass_value_error():
    for cls in (errors.ShapeError, errors.MatrixPropertyError, errors.StabilizabilityError,
                errors.RiccatiError, errors.InfeasibleDampingError):
        assert issubclass(cls, ValueError) and issubclass(cls, errors.ControllerError)


def test_no_mujoco_or_vlab_dependency():
    """The design module never imports mujoco or vlab (statically and at run time)."""
    for path in PKG_DIR.glob("*.py"):
        src = path.read_text()
        assert not re.search(r"^\s*(import|from)\s+(mujoco|vlab)\b", src, re.M), path.name
    code = (
        "import sys\n"
        + "".join(f"import controllers.{m}\n" for m in MODULES)
        + "bad = [m for m in sys.modules if m.split('.')[0] in ('mujoco', 'vlab', 'slycot')]\n"
        + "assert not bad, bad\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


def test_package_import_has_no_side_effects():
    code = "import sys, controllers; print(sorted(m for m in sys.modules if m.startswith('controllers')))"
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True)
    assert out.stdout.strip() == "['controllers']"
