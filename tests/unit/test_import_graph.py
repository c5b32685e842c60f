"""src/uhrisim has no import circles, of modules or of packages, and imports only downwards
through its layers (docs/layout.md).

The graph is read from the source with ``ast`` (nothing is imported): one node per module
(a package is its ``__init__``), and an edge for every ``import``/``from ... import`` of a
uhrisim module anywhere in a module — at module level, inside functions, under
``TYPE_CHECKING`` — since a lazy or type-only import is a dependency all the same.
``from uhrisim.pkg import name`` is an edge to ``uhrisim.pkg.name`` when that is a module,
else to ``uhrisim.pkg``; a package's ``__init__`` importing its submodules is an edge from
the package to them.

Layers (docs/layout.md, "The layers"): core → dynamics, control, world, sensors,
autonomy, perception, vehicles → teamwork → assistant → scenario → sim → ros → record, viz,
bridges, envs → app, experiments, bench, batch → cli. A module may import its own layer and
those below it; within a layer the DAG checks alone keep the order.
"""

from __future__ import annotations

import ast
import textwrap
from collections.abc import Iterable, Mapping
from pathlib import Path

SRC = Path(__file__).resolve().parents[2] / "src"

#: Bottom to top. Keys are the top-level names under ``uhrisim``; "" is the root package
#: (its ``__init__`` holds only the version). Place every new package here.
LAYERS: tuple[tuple[str, ...], ...] = (
    ("", "core"),
    ("dynamics", "control", "world", "sensors", "autonomy", "perception", "vehicles"),
    ("teamwork",),
    ("assistant",),
    ("scenario",),
    ("sim",),
    ("ros",),
    ("record", "viz", "bridges", "envs"),
    ("app", "experiments", "bench", "batch"),
    ("cli", "__main__"),
)
LAYER_OF = {name: rank for rank, names in enumerate(LAYERS) for name in names}

def module_files(src: Path, package: str) -> dict[str, tuple[Path, bool]]:
    """Dotted module name -> (file, is a package) for every module of ``package``."""
    modules = {}
    for path in sorted((src / package).rglob("*.py")):
        parts = list(path.relative_to(src).with_suffix("").parts)
        is_package = parts[-1] == "__init__"
        if is_package:
            parts.pop()
        modules[".".join(parts)] = (path, is_package)
    return modules


def _nearest_module(name: str, modules: Mapping[str, object]) -> str | None:
    """``name`` if it is a module, else its closest enclosing package (None: not ours)."""
    while name and name not in modules:
        name = name.rpartition(".")[0]
    return name or None


def import_graph(src: Path = SRC, package: str = "uhrisim") -> dict[str, set[str]]:
    """Module -> the modules of ``package`` it imports (see the module docstring)."""
    modules = module_files(src, package)
    graph: dict[str, set[str]] = {}
    for name, (path, is_package) in modules.items():
        here = name if is_package else name.rpartition(".")[0]
        targets: set[str | None] = set()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
            if isinstance(node, ast.Import):
                targets.update(_nearest_module(alias.name, modules) for alias in node.names)
            elif isinstance(node, ast.ImportFrom):
                if node.level:  # relative: from . import x, from ..pkg import y
                    base = here.split(".")[: len(here.split(".")) - (node.level - 1)]
                    source = ".".join([*base, *([node.module] if node.module else [])])
                else:
                    source = node.module or ""
                for alias in node.names:
                    submodule = f"{source}.{alias.name}"
                    targets.add(submodule if submodule in modules
                                else _nearest_module(source, modules))
        graph[name] = {t for t in targets if t is not None and t != name}
    return graph


def cycles(graph: Mapping[str, Iterable[str]], limit: int = 200) -> list[list[str]]:
    """The elementary cycles of ``graph``, each as [a, b, ..., a] starting at its smallest
    module (at most ``limit`` of them): strongly connected components first (Tarjan), then
    every simple path back to the start inside each."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    components: list[list[str]] = []

    def connect(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                connect(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            components.append(component)

    for v in sorted(graph):
        if v not in index:
            connect(v)
    found: list[list[str]] = []
    for component in components:
        members = set(component)
        if len(members) == 1 and component[0] not in graph.get(component[0], ()):
            continue
        for start in sorted(members):
            allowed = {m for m in members if m >= start}
            paths = [[start]]
            while paths and len(found) < limit:
                path = paths.pop()
                for w in sorted(graph.get(path[-1], ()), reverse=True):
                    if w == start:
                        found.append([*path, start])
                    elif w in allowed and w not in path:
                        paths.append([*path, w])
    return found[:limit]


def layer(module: str) -> int:
    """The layer of a uhrisim module (KeyError: its top-level name has no layer)."""
    parts = module.split(".")
    return LAYER_OF[parts[1] if len(parts) > 1 else ""]


def upward_imports(graph: Mapping[str, Iterable[str]]) -> dict[tuple[str, str], str]:
    """Every import of a higher layer by a lower one: (importer, imported) -> layers."""
    return {(a, b): f"layer {layer(a)} imports layer {layer(b)}"
            for a, targets in graph.items() for b in targets if layer(b) > layer(a)}


GRAPH = import_graph()


def test_graph_sees_every_kind_of_import(tmp_path: Path) -> None:
    """The graph builder on a small package: module-level, function-level, TYPE_CHECKING,
    relative and package imports all count; every circle is found."""
    pkg = tmp_path / "pkg"
    (pkg / "sub").mkdir(parents=True)
    files = {
        "__init__.py": "from pkg.a import A\n",
        "a.py": "from typing import TYPE_CHECKING\nA = 1\n"
                "if TYPE_CHECKING:\n    from pkg.b import B\n",
        "b.py": "def f():\n    from . import a\nB = 2\n",
        "c.py": "import pkg.sub.d\nfrom pkg import a, sub\n",
        "sub/__init__.py": "from .d import D\n",
        "sub/d.py": "from ..c import C\nD = 3\nimport os\n",
    }
    for name, text in files.items():
        (pkg / name).write_text(textwrap.dedent(text))
    graph = import_graph(tmp_path, "pkg")
    assert graph == {
        "pkg": {"pkg.a"},
        "pkg.a": {"pkg.b"},
        "pkg.b": {"pkg.a"},
        "pkg.c": {"pkg.sub.d", "pkg.a", "pkg.sub"},
        "pkg.sub": {"pkg.sub.d"},
        "pkg.sub.d": {"pkg.c"},
    }
    assert sorted(cycles(graph)) == [["pkg.a", "pkg.b", "pkg.a"],
                                     ["pkg.c", "pkg.sub", "pkg.sub.d", "pkg.c"],
                                     ["pkg.c", "pkg.sub.d", "pkg.c"]]


def test_graph_of_src_is_read() -> None:
    """Not vacuous: known edges of each kind are in the graph of src/uhrisim."""
    assert "uhrisim.sim.build" in GRAPH["uhrisim.sim.simulation"]  # module level
    assert "uhrisim.sensors.sonar.sonar" in GRAPH["uhrisim.sim.build"]  # in a function
    assert "uhrisim.sensors.sonar.ping" in GRAPH["uhrisim.sim.hooks"]  # TYPE_CHECKING
    assert "uhrisim.bridges.ros2.bridge" in GRAPH["uhrisim.bridges.ros2"]  # package, relative
    assert len(GRAPH) > 100


def test_src_has_no_import_circles() -> None:
    found = cycles(GRAPH)
    chains = "\n".join("  " + " → ".join(cycle) for cycle in found)
    assert not found, f"{len(found)} import circle(s) in src/uhrisim:\n{chains}"


def test_core_imports_nothing_else_of_uhrisim() -> None:
    outside = sorted(f"{a} → {b}" for a, targets in GRAPH.items() if layer(a) == 0
                     for b in targets if layer(b) != 0 or b == "uhrisim")
    assert not outside, "core (and the root package) import only core:\n" + "\n".join(outside)


def test_every_package_has_a_layer() -> None:
    names = {m.split(".")[1] if "." in m else "" for m in GRAPH}
    assert names <= set(LAYER_OF), f"give these a layer in LAYERS: {sorted(names - set(LAYER_OF))}"


def test_lower_layers_never_import_higher_ones() -> None:
    upward = sorted(f"{a} → {b} ({why})" for (a, b), why in upward_imports(GRAPH).items())
    assert not upward, "imports against the layer order of docs/layout.md:\n" + "\n".join(
        upward)


def package_graph(graph: Mapping[str, Iterable[str]], src: Path = SRC,
                  package: str = "uhrisim") -> dict[str, set[str]]:
    """Package -> the packages it imports (a module belongs to the package holding it; a
    package and its own subpackages are one family, not an edge)."""
    modules = module_files(src, package)

    def home(module: str) -> str:
        return module if modules[module][1] else module.rpartition(".")[0]

    out: dict[str, set[str]] = {}
    for a, targets in graph.items():
        for b in targets:
            pa, pb = home(a), home(b)
            if pa != pb and not pb.startswith(f"{pa}.") and not pa.startswith(f"{pb}."):
                out.setdefault(pa, set()).add(pb)
    return out


def test_packages_have_no_import_circles() -> None:
    """Not only modules: no package imports one that imports it back (the recorder and
    the ROS 2 bridge, the loop and the figures once did)."""
    found = cycles(package_graph(GRAPH))
    chains = "\n".join("  " + " → ".join(cycle) for cycle in found)
    assert not found, f"{len(found)} package circle(s) in src/uhrisim:\n{chains}"


def test_package_graph_is_read() -> None:
    graph = package_graph(GRAPH)
    assert "uhrisim.ros" in graph["uhrisim.record"] and "uhrisim.ros" in graph[
        "uhrisim.bridges.ros2"]
    assert "uhrisim.sim" in graph["uhrisim.app"]
