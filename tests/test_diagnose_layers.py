"""The import graph of vlab.diagnose runs one way, along its data flow, and has no cycles.

Layers, lowest first (a module may import its own layer and the layers below it, never one above):

0. ``cost``     -- the time and memory of a diagnosis, estimated from its sizes (``cost.py``)
0. ``policy``   -- the decision policy: every threshold, from the false-alarm rate (``policy.py``)
0. ``model``    -- the lab in the frequency domain and the nominal lab (``model/``)
1. ``data``     -- recordings, their replay on a plant, the reference (``data/``)
2. ``problem``  -- context, residuals, noise limits, floors (``problem/``)
3. ``effects``  -- the library of hypotheses, one module per effect family (``effects/``)
4. ``fit``      -- fit, rank, locate, the decision rules, the plant refits (``fit/``)
5. ``validate`` -- the validation rerun (``validate.py``)
6. ``instability_cause`` -- the cause of a self-excited oscillation: unstable loops, reruns (``instability_cause.py``)
7. ``thresholds`` -- the detection threshold of one effect: the mismatch test on its noise-free data (``thresholds.py``)
8. ``naming``   -- the look-alikes an effect must beat to be named (``naming.py``)
9. ``detectability`` -- the smallest size of each effect the mismatch test detects, and names (``detectability.py``)
10. ``report``   -- result, report text, figures (``report/``)
11. ``decision`` -- the mismatch tests, the gates a choice must pass, its remainder (``decision.py``)
12. ``reading``  -- stage 1: the data, the nominal lab, the reference (``reading.py``)
13. ``explain``  -- stages 3-5: screen, fit, select, the plant check (``explain.py``)
14. ``pipeline`` -- :func:`vlab.diagnose.diagnose`, the stages in order (``pipeline.py``)
15. the package ``vlab.diagnose`` itself (``__init__.py``: its public names)

Every import counts: at module level, inside functions (lazy) and under ``TYPE_CHECKING``. Within the
effects layer the families (``structural``, ``beyond_spec``, ``chain``) import only the base
(``hypothesis``) and ``specedit``; the registry ``hypotheses`` imports them, never the reverse.
The checks are tested on small made-up graphs too, so that they can fail.
"""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = "vlab.diagnose"
ROOT = Path(__file__).resolve().parent.parent / "vlab" / "diagnose"

LAYERS = ("cost", "policy", "model", "data", "problem", "effects", "fit", "validate", "instability_cause", "thresholds", "naming", "detectability", "report", "decision", "reading", "explain", "pipeline")
#: Rank of the package's own ``__init__`` (above every layer: it re-exports the public names).
TOP = len(LAYERS)

FAMILIES = ("structural", "beyond_spec", "chain")
FAMILY_MAY_IMPORT = ("hypothesis", "specedit")


def module_name(path: Path) -> str:
    """Dotted name of a module file of the package (a package's ``__init__.py`` is the package)."""
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join([PACKAGE] + parts)


def modules() -> dict[str, Path]:
    """Every module of the package: dotted name -> file."""
    return {module_name(p): p for p in sorted(ROOT.rglob("*.py"))}


def imports_of(name: str, path: Path, known: set[str]) -> set[str]:
    """Modules of the package that ``name`` (file ``path``) imports anywhere in its code.

    ``from X import y`` counts as an import of ``X.y`` when that is a module of the package, else of ``X``.
    """
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - (node.level - 1)]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            targets = [f"{mod}.{a.name}" if f"{mod}.{a.name}" in known else mod for a in node.names]
        else:
            continue
        for t in targets:
            # ``import vlab.diagnose.x.y`` imports the deepest module of the package it names
            while t and t not in known and t.startswith(PACKAGE + "."):
                t = t.rpartition(".")[0]
            if t in known and t != name:
                out.add(t)
    return out


def graph() -> dict[str, set[str]]:
    """Module -> the package modules it imports."""
    mods = modules()
    return {name: imports_of(name, path, set(mods)) for name, path in mods.items()}


def layer_of(name: str) -> int:
    """Rank of a module's layer (:data:`LAYERS`; :data:`TOP` for the package itself)."""
    if name == PACKAGE:
        return TOP
    first = name[len(PACKAGE) + 1:].split(".")[0]
    if first not in LAYERS:
        raise AssertionError(f"{name} is in no layer: add it to LAYERS (and to the docstring's order)")
    return LAYERS.index(first)


def cycles(g: dict[str, set[str]]) -> list[list[str]]:
    """The import cycles of ``g``: strongly connected components with more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in g.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(g):
        if v not in index:
            visit(v)
    return out


def back_edges(g: dict[str, set[str]]) -> list[str]:
    """Imports of a higher layer by a lower one, as ``"a (layer) -> b (layer)"``."""
    out = []
    for a in sorted(g):
        for b in sorted(g[a]):
            if layer_of(b) > layer_of(a):
                la = LAYERS[layer_of(a)] if layer_of(a) < TOP else "package"
                lb = LAYERS[layer_of(b)] if layer_of(b) < TOP else "package"
                out.append(f"{a} ({la}) -> {b} ({lb})")
    return out


def family_edges(g: dict[str, set[str]]) -> list[str]:
    """Imports of an effect family module beyond the base class and ``specedit`` within the effects layer."""
    eff = f"{PACKAGE}.effects."
    allowed = {eff + m for m in FAMILY_MAY_IMPORT}
    return [f"{a} -> {b}" for a in sorted(g) if a[len(eff):] in FAMILIES and a.startswith(eff)
            for b in sorted(g[a]) if b.startswith(eff) and b not in allowed]


def test_every_module_is_in_a_layer():
    for name in modules():
        layer_of(name)  # raises for a module outside the layers


def test_no_import_cycles():
    assert cycles(graph()) == []


def test_lower_layers_never_import_higher_ones():
    assert back_edges(graph()) == []


def test_effect_families_import_only_the_base_and_specedit():
    g = graph()
    assert f"{PACKAGE}.effects.structural" in g and f"{PACKAGE}.effects.hypotheses" in g  # the names exist
    assert family_edges(g) == []


def test_the_graph_sees_lazy_imports():
    # data/reference.py imports the replay inside replay_reference only; the graph must see it
    g = graph()
    assert f"{PACKAGE}.data.replay" in g[f"{PACKAGE}.data.reference"]
    assert f"{PACKAGE}.report.markdown" in g[f"{PACKAGE}.report.figures"]


def test_the_checks_can_fail():
    p = PACKAGE
    g = {f"{p}.model.labmodel": set(), f"{p}.problem.residuals": {f"{p}.model.labmodel"},
         f"{p}.effects.hypotheses": {f"{p}.problem.residuals"}}
    assert cycles(g) == [] and back_edges(g) == []
    g[f"{p}.problem.residuals"].add(f"{p}.effects.hypotheses")  # the back-edge problem -> library of old
    assert back_edges(g) == [f"{p}.problem.residuals (problem) -> {p}.effects.hypotheses (effects)"]
    assert cycles(g) == [[f"{p}.effects.hypotheses", f"{p}.problem.residuals"]]
    g2 = {f"{p}.effects.chain": {f"{p}.effects.structural"}, f"{p}.effects.structural": set()}
    assert family_edges(g2) == [f"{p}.effects.chain -> {p}.effects.structural"]


def test_imports_are_resolved_like_python(tmp_path):
    """Relative imports from a subpackage's module and its ``__init__``, ``from . import module``, and
    absolute imports of the package resolve to the modules they load."""
    known = {f"{PACKAGE}.fit.rules", f"{PACKAGE}.effects.specedit", f"{PACKAGE}.effects", f"{PACKAGE}.data.replay",
             f"{PACKAGE}.fit", f"{PACKAGE}.fit.selection", PACKAGE}
    src = ("from ..effects import specedit\n"
           "from .rules import NONLINEAR\n"
           "def f():\n"
           "    from ..data.replay import reruns\n"
           "    import vlab.diagnose.fit.rules\n"
           "from ...errors import ModelError\n")
    f = tmp_path / "selection.py"
    f.write_text(src)
    assert imports_of(f"{PACKAGE}.fit.selection", f, known) == {
        f"{PACKAGE}.effects.specedit", f"{PACKAGE}.fit.rules", f"{PACKAGE}.data.replay"}
    init = tmp_path / "__init__.py"
    init.write_text("from .rules import select\n")
    assert imports_of(f"{PACKAGE}.fit", init, known) == {f"{PACKAGE}.fit.rules"}
