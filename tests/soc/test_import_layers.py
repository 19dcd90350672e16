"""The import graph: no module imports a higher layer, and no circle among modules; imports
inside functions count for both.

Layers, low to high: soc's base modules (errors, constants, metrics, user_cache) < soc.gl <
soc.scenes < soc.culling < soc.rendering < soc.models < soc.methods < soc's face (culler,
fly, the package itself, testing, viz) < lod < experiments.
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
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


def modules(root: Path = ROOT, packages: tuple[str, ...] = PACKAGES) -> dict[str, Path]:
    """Every module of ``packages`` under ``root``: dotted name -> file (a package is its
    ``__init__.py``)."""
    out = {}
    for pkg in packages:
        for p in (root / pkg).rglob("*.py"):
            name = ".".join(p.relative_to(root).with_suffix("").parts)
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
    module, else a.b; relative imports are resolved against the module's package).

    ``top_level_only``: only the statements of the module's body (what runs when it is
    loaded); else every import statement anywhere in the file — inside functions, methods,
    ``if TYPE_CHECKING:`` blocks and ``try:`` blocks too.
    """

    def resolve(name: str) -> str:
        while name and name not in mods:
            name = name.rpartition(".")[0]
        return name

    me = next(m for m, p in mods.items() if p == path)
    package = me if path.name == "__init__.py" else me.rpartition(".")[0]
    tree = ast.parse(path.read_text())
    nodes = tree.body if top_level_only else list(ast.walk(tree))
    found = set()
    for node in nodes:
        if isinstance(node, ast.Import):
            found |= {resolve(a.name) for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:  # from . import x, from ..a import b
                parts = package.split(".")
                up = parts[: len(parts) - node.level + 1]
                base = ".".join([*up, base] if base else up)
            found |= {resolve(f"{base}.{a.name}") for a in node.names}
    return {m for m in found if m}


def import_circles(root: Path = ROOT, packages: tuple[str, ...] = PACKAGES) -> list[list[str]]:
    """The import circles among the modules of ``packages``: each strongly connected component
    of more than one module of the graph of *every* import (:func:`imports` with
    ``top_level_only=False``: function-level and ``TYPE_CHECKING`` imports count, since each
    is a dependency a reader must follow), as one circle through it."""
    mods = modules(root, packages)
    graph = {m: sorted(imports(p, mods, top_level_only=False) - {m}) for m, p in mods.items()}
    # Tarjan's strongly connected components, iteratively (no recursion limit).
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    components = []
    for start in sorted(graph):
        if start in index:
            continue
        work = [(start, 0)]
        while work:
            m, i = work.pop()
            if i == 0:
                index[m] = low[m] = len(index)
                stack.append(m)
                on_stack.add(m)
            if i < len(graph[m]):
                work.append((m, i + 1))
                n = graph[m][i]
                if n not in index:
                    work.append((n, 0))
                elif n in on_stack:
                    low[m] = min(low[m], index[n])
                continue
            if work:  # m is done: its parent learns how low m reaches
                parent = work[-1][0]
                low[parent] = min(low[parent], low[m])
            if low[m] == index[m]:
                comp = []
                while True:
                    n = stack.pop()
                    on_stack.discard(n)
                    comp.append(n)
                    if n == m:
                        break
                if len(comp) > 1:
                    components.append(sorted(comp))
    return [_circle_through(sorted(c), graph) for c in sorted(components)]


def _circle_through(component: list[str], graph: dict[str, list[str]]) -> list[str]:
    """One circle of imports inside a strongly connected ``component``, from its first module
    back to it (breadth-first, so the shortest)."""
    inside = set(component)
    first = component[0]
    came_from = {first: None}
    queue = [first]
    while queue:
        m = queue.pop(0)
        for n in graph[m]:
            if n == first:
                path = [m]
                while came_from[path[-1]] is not None:
                    path.append(came_from[path[-1]])
                return [*reversed(path), first]
            if n in inside and n not in came_from:
                came_from[n] = m
                queue.append(n)
    raise AssertionError(f"{component} is not strongly connected")


def test_no_module_imports_a_higher_layer():
    mods = modules()
    upward = [
        f"{m} (layer {layer(m)}) imports {i} (layer {layer(i)})"
        for m, p in mods.items()
        for i in imports(p, mods, top_level_only=False)
        if layer(i) > layer(m)
    ]
    assert not upward, "\n".join(sorted(upward))


def test_no_import_circles():
    """No circle among soc's, lod's and experiments' modules, counting every import (inside
    functions too): within each package the files import downward only."""
    circles = import_circles()
    assert not circles, "import circles:\n" + "\n".join(" -> ".join(c) for c in circles)


def _write_package(root: Path, files: dict[str, str]) -> None:
    for name, text in files.items():
        path = root / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)


def test_a_circle_through_a_function_level_import_is_found(tmp_path):
    """pkg.low imports pkg.high inside a function, pkg.high imports pkg.low at load time: a
    circle, though importing either module works. pkg.leaf imports downward only."""
    _write_package(
        tmp_path,
        {
            "pkg/__init__.py": "",
            "pkg/low.py": "def f():\n    from pkg.high import g\n    return g\n",
            "pkg/high.py": "from pkg import low\n\ndef g():\n    return low\n",
            "pkg/leaf.py": "import pkg.high\n",
        },
    )
    assert import_circles(tmp_path, ("pkg",)) == [["pkg.high", "pkg.low", "pkg.high"]]


def test_a_circle_through_relative_and_type_checking_imports_is_found(tmp_path):
    """Three modules in a subpackage, one edge a relative import, one under TYPE_CHECKING."""
    _write_package(
        tmp_path,
        {
            "pkg/__init__.py": "",
            "pkg/sub/__init__.py": "",
            "pkg/sub/a.py": "from . import b\n",
            "pkg/sub/b.py": "from pkg.sub.c import X\n",
            "pkg/sub/c.py": (
                "from typing import TYPE_CHECKING\n"
                "if TYPE_CHECKING:\n    from ..sub.a import b\nX = 1\n"
            ),
        },
    )
    assert import_circles(tmp_path, ("pkg",)) == [
        ["pkg.sub.a", "pkg.sub.b", "pkg.sub.c", "pkg.sub.a"]
    ]


def test_downward_imports_make_no_circle(tmp_path):
    _write_package(
        tmp_path,
        {
            "pkg/__init__.py": "from pkg.top import f\n",
            "pkg/base.py": "X = 1\n",
            "pkg/mid.py": "from pkg.base import X\n",
            "pkg/top.py": "def f():\n    from pkg import mid\n    return mid\n",
        },
    )
    assert import_circles(tmp_path, ("pkg",)) == []


def test_the_layer_rule_sees_a_violation():
    assert layer("soc.culling.hiz_gpu") > layer("soc.gl.context")
    assert layer("soc.methods.masked") > layer("soc.culling.masked")
    assert layer("soc.culler") > layer("soc.methods.base")
    assert layer("experiments.harness") > layer("lod.chain") > layer("soc.fly")
