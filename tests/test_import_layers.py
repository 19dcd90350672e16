"""The import graph: no module imports a higher layer (lazy imports inside functions count),
and no circle among the imports that run when a module is loaded.

Layers, low to high: soc's base modules (errors, constants, metrics, user_cache) < soc.gl <
soc.scenes < soc.culling < soc.rendering < soc.models < soc.methods < soc's face (culler,
fly, the package itself, testing, viz) < lod < experiments.
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("soc", "lod", "experiments")
LAYERS = (
    ("soc.errors", "soc.constants", "soc.metrics", "soc.user_cache"),
    ("soc.gl",),
    ("soc.scenes",),
    ("soc.culling",),
    ("soc.rendering",),
    ("soc.models",),
    ("soc.methods",),
    ("soc",),  # the face: soc/__init__, culler, fly, testing, viz
    ("lod",),
    ("experiments",),
)


def modules() -> dict[str, Path]:
    out = {}
    for pkg in PACKAGES:
        for p in (ROOT / pkg).rglob("*.py"):
            name = ".".join(p.relative_to(ROOT).with_suffix("").parts)
            out[name.removesuffix(".__init__")] = p
    return out


def layer(module: str) -> int:
    """The layer of ``module``: the most specific prefix in :data:`LAYERS`."""
    best, rank = -1, -1
    for i, prefixes in enumerate(LAYERS):
        for p in prefixes:
            if (module == p or module.startswith(p + ".")) and len(p) > best:
                best, rank = len(p), i
    assert rank >= 0, module
    return rank


def imports(path: Path, mods: dict[str, Path], top_level_only: bool) -> set[str]:
    """The project modules ``path`` imports (``from a.b import c`` counts a.b.c when c is a
    module, else a.b)."""

    def resolve(name: str) -> str:
        while name and name not in mods:
            name = name.rpartition(".")[0]
        return name

    tree = ast.parse(path.read_text())
    nodes = tree.body if top_level_only else list(ast.walk(tree))
    found = set()
    for node in nodes:
        if isinstance(node, ast.Import):
            found |= {resolve(a.name) for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            found |= {resolve(f"{node.module}.{a.name}") for a in node.names}
    return {m for m in found if m}


def test_no_module_imports_a_higher_layer():
    mods = modules()
    upward = [
        f"{m} (layer {layer(m)}) imports {i} (layer {layer(i)})"
        for m, p in mods.items()
        for i in imports(p, mods, top_level_only=False)
        if layer(i) > layer(m)
    ]
    assert not upward, "\n".join(sorted(upward))


def test_no_import_circles_at_load_time():
    mods = modules()
    graph = {m: imports(p, mods, top_level_only=True) - {m} for m, p in mods.items()}
    # A package importing its own submodules (its face) is not a circle with them.
    for m in graph:
        graph[m] = {i for i in graph[m] if not (m and i.startswith(m + "."))} | {
            i for i in graph[m] if i.startswith(m + ".") and m not in graph.get(i, ())
        }
    state: dict[str, int] = {}
    cycles = []

    def visit(m: str, stack: list[str]) -> None:
        state[m] = 1
        for i in sorted(graph.get(m, ())):
            if state.get(i) == 1:
                cycles.append(" -> ".join([*stack[stack.index(i) :], i]))
            elif i not in state:
                visit(i, [*stack, i])
        state[m] = 2

    for m in sorted(graph):
        if m not in state:
            visit(m, [m])
    assert not cycles, "\n".join(cycles)


def test_the_layer_rule_sees_a_violation():
    assert layer("soc.culling.hiz_gpu") > layer("soc.gl.context")
    assert layer("soc.methods.masked") > layer("soc.culling.masked")
    assert layer("soc.culler") > layer("soc.methods.base")
    assert layer("experiments.harness") > layer("lod.chain") > layer("soc.fly")
