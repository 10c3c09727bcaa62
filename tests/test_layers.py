"""vlab's import graph runs one way, along its data flow, and its modules can be read in one sitting.

Layers, lowest first (a module may import its own layer and the layers below, never one above; every
import counts: module level, inside functions and under ``TYPE_CHECKING``):

0. base -- errors, units, the file-safety helpers of ``vlab.io`` (atomic writes, confinement, manifests)
1. spec -- the structure definition, the published reference data
2. formats -- the rest of ``vlab.io`` (UFF/CSV readers and writers, the Recording and FRF types), ``vlab.viz``
3. models -- FE model, reduction, correction, the design models, calibration
4. sim -- the MuJoCo plant
5. lab -- the sampled-data loop, its hardware chain and excitations
6. measure -- FRF estimation, modal fits, instability detection
7. analysis, design
8. experiment -- the experiment runner and its results; the ``vlab init`` templates
9. diagnose, robust, reproduce, update
10. the command line and the package's own ``__init__`` (its public names)

Within ``vlab.sim`` the import graph has no cycle. Modules of vlab and
of the design package ``controllers/`` stay under :data:`MAX_MODULE_LINES` lines and functions under
:data:`MAX_FUNCTION_LINES` (docstring included).
The checks are also run on small made-up inputs so that they can fail.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent / "vlab"
#: The packages whose module and function sizes are checked: vlab and the controller design package.
SIZED_ROOTS: tuple[Path, ...] = (ROOT, ROOT.parent / "controllers")

#: Module-name prefixes and their rank; the longest matching prefix decides.
RANKS: dict[str, int] = {
    "vlab.errors": 0, "vlab.units": 0, "vlab.io.atomic": 0, "vlab.io.confine": 0, "vlab.io.manifest": 0,
    "vlab.spec": 1, "vlab.reference": 1,
    "vlab.io": 2, "vlab.viz": 2,
    "vlab.fe": 3, "vlab.reduction": 3, "vlab.correction": 3, "vlab.models": 3, "vlab.calibration": 3,
    "vlab.grid_fit": 3,
    "vlab.sim": 4,
    "vlab.lab": 5,
    "vlab.measure": 6,
    "vlab.analysis": 7, "vlab.design": 7,
    "vlab.experiment": 8, "vlab.templates": 8,
    "vlab.diagnose": 9, "vlab.robust": 9, "vlab.reproduce": 9, "vlab.model_update": 9,
    "vlab.cli": 10, "vlab": 10,
}

MAX_MODULE_LINES = 600
MAX_FUNCTION_LINES = 100

#: Upward imports still in the tree, as (importer, imported) module names. New ones fail the test; an
#: entry that no longer occurs fails :func:`test_no_stale_exceptions`, so the list can only shrink.
KNOWN_UPWARD: set[tuple[str, str]] = set()
#: Modules over the size limit, and functions as "module:function", still in the tree (same rule).
KNOWN_LONG_MODULES: set[str] = set()
KNOWN_LONG_FUNCTIONS: set[str] = set()


def module_name(path: Path, root: Path = ROOT) -> str:
    """Dotted name of a module file under ``root`` (a package's ``__init__.py`` is the package)."""
    parts = [root.name] + list(path.relative_to(root).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def rank(name: str) -> int:
    """Rank of a module by its longest matching prefix in :data:`RANKS` (``vlab`` itself matches only itself).

    Raises
    ------
    KeyError
        For a module no prefix covers (a new top-level module must be given its layer).
    """
    best = None
    for prefix in RANKS:
        covers = name == prefix or (prefix != "vlab" and name.startswith(prefix + "."))
        if covers and (best is None or len(prefix) > len(best)):
            best = prefix
    if best is None:
        raise KeyError(f"{name}: no layer in RANKS")
    return RANKS[best]


def imported(name: str, tree: ast.Module, is_package: bool, known: set[str]) -> set[str]:
    """Every module of ``known`` that ``name`` imports anywhere in its code (``from pkg import sub`` counts
    as the submodule where ``sub`` is one, else as the package)."""
    here = name.split(".") if is_package else name.split(".")[:-1]
    out: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = here[: len(here) - (node.level - 1)]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            if mod.split(".")[0] != "vlab":
                continue
            for alias in node.names:
                out.add(f"{mod}.{alias.name}" if f"{mod}.{alias.name}" in known else mod)
    return out & known


def graph(root: Path = ROOT) -> dict[str, set[str]]:
    """Import graph of the package under ``root``: module -> the package's modules it imports."""
    files = {module_name(p, root): p for p in sorted(root.rglob("*.py"))}
    known = set(files)
    edges: dict[str, set[str]] = {}
    for name, path in files.items():
        refs = imported(name, ast.parse(path.read_text(encoding="utf-8")), path.name == "__init__.py", known)
        edges[name] = refs - {name}
    return edges


def upward(edges: dict[str, set[str]]) -> set[tuple[str, str]]:
    """The edges that import a higher layer."""
    return {(a, b) for a, targets in edges.items() for b in targets if rank(b) > rank(a)}


def cycle_in(edges: dict[str, set[str]], prefix: str) -> list[str] | None:
    """One import cycle among the modules under ``prefix`` (a list of names), or None."""
    nodes = {n for n in edges if n == prefix or n.startswith(prefix + ".")}
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(n: str) -> list[str] | None:
        state[n] = 1
        stack.append(n)
        for m in sorted(edges[n] & nodes):
            if m == prefix:  # the package's __init__ re-exports: not part of a module cycle
                continue
            if state.get(m) == 1:
                return stack[stack.index(m):] + [m]
            if m not in state and (found := visit(m)):
                return found
        stack.pop()
        state[n] = 2
        return None

    for n in sorted(nodes - {prefix}):
        if n not in state and (found := visit(n)):
            return found
    return None


def long_code(roots: tuple[Path, ...] = SIZED_ROOTS) -> tuple[set[str], set[str]]:
    """Modules over :data:`MAX_MODULE_LINES` and functions ("module:function") over :data:`MAX_FUNCTION_LINES`
    in the packages ``roots``."""
    modules, functions = set(), set()
    for root, path in sorted((root, path) for root in roots for path in root.rglob("*.py")):
        text = path.read_text(encoding="utf-8")
        name = module_name(path, root)
        if len(text.splitlines()) > MAX_MODULE_LINES:
            modules.add(name)
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                if node.end_lineno - node.lineno + 1 > MAX_FUNCTION_LINES:
                    functions.add(f"{name}:{node.name}")
    return modules, functions


@pytest.fixture(scope="module")
def edges() -> dict[str, set[str]]:
    return graph()


def test_every_module_has_a_layer(edges):
    for name in edges:
        rank(name)


def test_no_upward_import(edges):
    new = upward(edges) - KNOWN_UPWARD
    assert not new, "imports of a higher layer:\n" + "\n".join(f"  {a} -> {b} ({rank(a)} -> {rank(b)})"
                                                                for a, b in sorted(new))


def test_sim_has_no_import_cycle(edges):
    assert cycle_in(edges, "vlab.sim") is None, " -> ".join(cycle_in(edges, "vlab.sim"))


def test_module_and_function_sizes():
    modules, functions = long_code()
    assert modules <= KNOWN_LONG_MODULES, f"modules over {MAX_MODULE_LINES} lines: {sorted(modules - KNOWN_LONG_MODULES)}"
    assert functions <= KNOWN_LONG_FUNCTIONS, (f"functions over {MAX_FUNCTION_LINES} lines: "
                                               f"{sorted(functions - KNOWN_LONG_FUNCTIONS)}")


def test_no_stale_exceptions(edges):
    modules, functions = long_code()
    stale = (KNOWN_UPWARD - upward(edges)) | {(m, "") for m in KNOWN_LONG_MODULES - modules} | {
        (f, "") for f in KNOWN_LONG_FUNCTIONS - functions}
    assert not stale, f"fixed, remove from the known lists: {sorted(stale)}"


# The checks on made-up packages, so that each can fail.

def _write(root: Path, files: dict[str, str]) -> Path:
    for rel, text in files.items():
        p = root / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(text)
    return root


def test_checks_find_upward_imports_cycles_and_long_code(tmp_path):
    root = _write(tmp_path / "vlab", {
        "__init__.py": "",
        "errors.py": "",
        "spec.py": "from .errors import x\n",
        "sim/__init__.py": "from .a import f\n",
        "sim/a.py": "def f():\n    from .b import g\n",
        "sim/b.py": "from . import a\nfrom ..lab.loop import run\n",
        "lab/__init__.py": "",
        "lab/loop.py": "def run():\n" + "    x = 1\n" * 120,
    })
    design = _write(tmp_path / "controllers", {
        "__init__.py": "",
        "lq.py": "x = 1\n" * 601,
    })
    e = graph(root)
    assert upward(e) == {("vlab.sim.b", "vlab.lab.loop")}
    assert cycle_in(e, "vlab.sim") in (["vlab.sim.a", "vlab.sim.b", "vlab.sim.a"],
                                      ["vlab.sim.b", "vlab.sim.a", "vlab.sim.b"])
    assert cycle_in(e, "vlab.lab") is None
    modules, functions = long_code((root,))
    assert modules == set() and functions == {"vlab.lab.loop:run"}
    assert long_code((root, design)) == ({"controllers.lq"}, {"vlab.lab.loop:run"})
    with pytest.raises(KeyError, match="no layer"):
        rank("vlab.newthing")
