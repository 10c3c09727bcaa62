"""Every public function and method of vlab (all modules but the CLI) documents its parameters (numpydoc habit)."""

from __future__ import annotations

import importlib
import inspect
import pkgutil

import pytest

import vlab

#: every module of vlab but the command line's (their options are documented by their ``help=``)
MODULES = sorted(m.name for m in pkgutil.walk_packages(vlab.__path__, "vlab.")
                 if m.name != "vlab.cli" and not m.name.startswith("vlab.cli."))


def _public(module):
    for name, obj in vars(module).items():
        if name.startswith("_") or getattr(obj, "__module__", None) != module.__name__:
            continue
        if inspect.isfunction(obj):
            yield name, obj, inspect.getdoc(obj) or ""
        elif inspect.isclass(obj):
            cls_doc = inspect.getdoc(obj) or ""
            yield name, obj, cls_doc
            if "__init__" in vars(obj):
                yield f"{name}.__init__", obj.__init__, cls_doc
            for k, v in vars(obj).items():
                if inspect.isfunction(v) and not k.startswith("_"):
                    yield f"{name}.{k}", v, inspect.getdoc(v) or ""


@pytest.mark.parametrize("modname", MODULES)
def test_parameters_are_documented(modname):
    module = importlib.import_module(modname)
    assert inspect.getdoc(module)
    missing = []
    for name, obj, doc in _public(module):
        if not doc:
            missing.append(f"{name}: no docstring")
            continue
        if inspect.isclass(obj):
            continue
        for p in inspect.signature(obj).parameters:
            if p not in ("self", "cls") and p not in doc:
                missing.append(f"{name}({p})")
    assert not missing, f"{modname}: undocumented {missing}"
