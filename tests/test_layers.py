"""The package's import graph, read from the source with ast: no cycles, layers in order.

DESIGN.md: each layer imports only from layers above it, not even through a
deferred (function-level) import.  Every import statement counts, at any
depth, TYPE_CHECKING blocks included.
"""

from __future__ import annotations

import ast
from pathlib import Path

SRC = Path(__file__).resolve().parent.parent / "src"
PKG = "openimp"


def modules() -> dict[str, Path]:
    """Every module of the package by dotted name (a package by its own name)."""
    out = {}
    for p in sorted((SRC / PKG).rglob("*.py")):
        rel = p.relative_to(SRC).with_suffix("").parts
        name = ".".join(rel[:-1] if rel[-1] == "__init__" else rel)
        out[name] = p
    return out


def imports(mods: dict[str, Path]) -> dict[str, set[str]]:
    """module -> the package modules it imports (a module importing its own package, as
    every submodule's ``from openimp.x import y`` resolves to, is not an edge)."""
    graph: dict[str, set[str]] = {m: set() for m in mods}
    for m, path in mods.items():
        is_pkg = path.name == "__init__.py"
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            targets: list[str] = []
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    parts = m.split(".") if is_pkg else m.split(".")[:-1]
                    parts = parts[: len(parts) - (node.level - 1)]
                    base = ".".join([*parts, base] if base else parts)
                targets = [base] + [f"{base}.{a.name}" for a in node.names]
            for t in targets:
                if t in mods and t != m and not m.startswith(t + "."):
                    graph[m].add(t)
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph[v]:
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

    for v in graph:
        if v not in index:
            visit(v)
    return out


def test_cycle_finder_finds_a_cycle():
    """The finder itself: a -> b -> c -> a is one cycle, d alone is none."""
    g = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert cycles(g) == [["a", "b", "c"]]


def test_no_import_cycles():
    """No module of openimp imports, directly or through others, a module that imports it."""
    found = cycles(imports(modules()))
    # a package __init__ re-exporting its own submodules is not a cycle of substance
    found = [c for c in found if not all(x == c[0] or x.startswith(c[0] + ".") for x in c)]
    assert not found, "import cycles: " + "; ".join(" <-> ".join(c) for c in found)


#: DESIGN.md's layers, top first: a module may import only from its own layer and above.
LAYERS = [
    ("openimp.errors", "openimp.results", "openimp._jit", "openimp.limits", "openimp.files",
     "openimp.workspace", "openimp._interrupt", "openimp._announce"),
    ("openimp.spatial", "openimp.mat4", "openimp.linalg", "openimp.massprops"),
    ("openimp.joints",),
    ("openimp.model",),
    ("openimp.topology",),
    ("openimp.system",),
    ("openimp.motion", "openimp.kinematics"),
    ("openimp.dynamics",),
    ("openimp.contact",),
    ("openimp.studies",),
    # pictures of results: the IMP runner renders DRAW, ANIMATE and PLOT with them
    ("openimp.viz",),
    ("openimp.imp",),
    ("openimp.io", "openimp.cli", "openimp._warm", "openimp"),
]


def layer(name: str) -> int | None:
    best = None
    for k, group in enumerate(LAYERS):
        for g in group:
            if name == g or name.startswith(g + "."):
                if best is None or len(g) > best[1]:
                    best = (k, len(g))
    return None if best is None else best[0]


def test_every_module_has_a_layer():
    """A new module is placed in DESIGN.md's table (and here) before it is imported."""
    missing = [m for m in modules() if layer(m) is None]
    assert not missing, f"modules with no layer: {missing}"


def test_layers_import_only_upward():
    """Each layer imports only from layers above it (or its own)."""
    graph = imports(modules())
    bad = []
    for m, targets in graph.items():
        lm = layer(m)
        for t in targets:
            lt = layer(t)
            if lm is not None and lt is not None and lt > lm and m != PKG:
                bad.append(f"{m} -> {t}")
    assert not bad, "imports from a lower layer: " + ", ".join(sorted(bad))
