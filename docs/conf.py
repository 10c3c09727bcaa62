"""Sphinx configuration of the vlab documentation.

Build (from the repository root, after ``pip install -e ".[docs]"``)::

    sphinx-build -W --keep-going -b html docs docs/_build/html

Markdown pages are read by myst-parser, numpydoc docstrings by numpydoc
through autodoc, and the command-line reference is generated from the typer
app ``vlab.cli:app`` by sphinxcontrib-typer (see ``index.md``, "About these
docs", for why not sphinx-click).
"""

from __future__ import annotations

import inspect
import os
import sys
import types
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))  # the vlab of this checkout, whether installed or not
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import vlab  # noqa: E402

project = "vlab"
author = "the vlab developers"
copyright = "the vlab developers (MIT licence)"
release = vlab.__version__
version = release

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.viewcode",
    "numpydoc",
    "sphinxcontrib.typer",
]

highlight_language = "text"  # untagged code blocks are terminal output, not Python
source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
root_doc = "index"
exclude_patterns = ["_build", "Thumbs.db", ".DS_Store"]

myst_enable_extensions = ["colon_fence"]  # ::: admonitions
myst_heading_anchors = 3  # links such as experiments.md#the-lqg-controller

# API reference: autodoc reads the docstrings, numpydoc renders their sections.
autodoc_default_options = {"members": True, "member-order": "bysource", "show-inheritance": True}
autodoc_typehints = "none"  # the numpydoc Parameters sections carry the types and units
numpydoc_show_class_members = False  # autodoc lists the members already
numpydoc_validation_checks: set[str] = set()

html_theme = "furo"
html_title = f"vlab {release}"


def _entry_point_docstring(app, what, name, obj, options, lines):
    """``vlab.design`` and ``vlab.diagnose`` are callable modules once their subpackage is imported.

    Calling them calls the entry point (``__wrapped__``, see ``vlab/__init__.py``);
    document that function's docstring, not the module's.
    """
    wrapped = getattr(obj, "__wrapped__", None)
    if what == "function" and isinstance(obj, types.ModuleType) and wrapped is not None:
        lines[:] = inspect.cleandoc(wrapped.__doc__ or "").splitlines()


def _entry_point_signature(app, what, name, obj, options, signature, return_annotation):
    """The entry point's signature for ``vlab.design``/``vlab.diagnose`` (the first result wins)."""
    wrapped = getattr(obj, "__wrapped__", None)
    if what == "function" and isinstance(obj, types.ModuleType) and wrapped is not None:
        sig = inspect.signature(wrapped)  # shown without annotations, as autodoc_typehints = "none"
        plain = [p.replace(annotation=inspect.Parameter.empty) for p in sig.parameters.values()]
        return str(sig.replace(parameters=plain, return_annotation=inspect.Signature.empty)), None
    return None


# numpydoc's signature handler also parses the *module* docstring of the callable module
# ``vlab.diagnose`` (whose "Modules" heading it does not know); the entry point's own docstring is
# what the page shows (above), so that parse's complaint is noise.
warnings.filterwarnings("ignore", message="Unknown section Modules in the docstring of vlab.diagnose",
                        category=UserWarning)


def setup(app):
    # before numpydoc's handlers (priority 500)
    app.connect("autodoc-process-docstring", _entry_point_docstring, priority=100)
    app.connect("autodoc-process-signature", _entry_point_signature, priority=100)
