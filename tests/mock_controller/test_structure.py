"""Import structure: no import cycle in mocks/ or src/handeye_pick, and the simulators never
import handeye_pick (they must not share pose maths with the code under test).

Read from the source, not by importing: every import statement counts, also one inside a
function or under `if TYPE_CHECKING:` (a cycle only for typing is still a cycle in the design).
`from pkg import name` is an import of pkg.name when that is a module, else of pkg. Importing a
submodule is not counted as importing its package's __init__, which re-exports submodules as
any package does.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
# (folder that holds the top-level package, the package): the trees checked.
TREES = [(ROOT, "mocks"), (ROOT / "src", "handeye_pick")]


def _modules(import_root: Path, package: str) -> dict[str, Path]:
    """Every module of `package` by dotted name; a package's name is its __init__.py's."""
    modules: dict[str, Path] = {}
    for path in sorted((import_root / package).rglob("*.py")):
        parts = path.relative_to(import_root).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        modules[".".join(parts)] = path
    return modules


def _imported(module: str, path: Path, modules: dict[str, Path]) -> set[str]:
    """The dotted names `module` imports anywhere in its source, relative imports resolved;
    `from pkg import name` gives pkg.name when that is one of `modules`, else pkg."""
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    names: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = package.split(".")
                base = ".".join([*parts[: len(parts) - node.level + 1], *filter(None, [base])])
            for alias in node.names:
                name = f"{base}.{alias.name}"
                names.add(name if name in modules else base)
    return names


def _graph(import_root: Path, package: str) -> dict[str, set[str]]:
    """Module -> the modules of the same tree it imports."""
    modules = _modules(import_root, package)
    return {name: _imported(name, path, modules) & modules.keys()
            for name, path in modules.items()}


def _find_cycle(graph: dict[str, set[str]]) -> list[str]:
    """One import cycle as [a, b, ..., a], or [] when there is none."""
    finished: set[str] = set()
    path: list[str] = []

    def visit(module: str) -> list[str]:
        if module in path:
            return [*path[path.index(module):], module]
        if module in finished:
            return []
        path.append(module)
        for imported in sorted(graph[module]):
            cycle = visit(imported)
            if cycle:
                return cycle
        path.pop()
        finished.add(module)
        return []

    for module in sorted(graph):
        cycle = visit(module)
        if cycle:
            return cycle
    return []


def test_the_cycle_finder_finds_a_cycle() -> None:
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert _find_cycle(graph) == ["a", "b", "c", "a"]
    assert _find_cycle({"a": {"b"}, "b": set()}) == []


def test_the_graph_sees_type_checking_and_from_imports() -> None:
    graph = _graph(ROOT, "mocks")
    assert "mocks.ur_controller.dashboard" in graph["mocks.ur_controller.controller"]
    # camera.py imports SimulatedController only under TYPE_CHECKING, from the package.
    assert "mocks.ur_controller" in graph["mocks.camera.camera"]


@pytest.mark.parametrize(("import_root", "package"), TREES, ids=[p for _, p in TREES])
def test_no_import_cycle(import_root: Path, package: str) -> None:
    cycle = _find_cycle(_graph(import_root, package))
    assert cycle == [], "import cycle: " + " -> ".join(cycle)


def test_the_simulators_never_import_handeye_pick() -> None:
    modules = _modules(ROOT, "mocks")
    offenders = {name: sorted(m for m in _imported(name, path, modules)
                              if m.split(".")[0] == "handeye_pick")
                 for name, path in modules.items()}
    assert {name: found for name, found in offenders.items() if found} == {}
