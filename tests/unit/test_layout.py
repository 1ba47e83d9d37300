"""The package's layout holds: every arrow between rooms points one way, no module outgrows a
reading.

A room is a sub-package of ``handeye_pick`` (``cell``, ``scene``, ``config``...) or one of its
top-level modules (``safety``, ``geometry``...). Imports are read from the source, those inside
functions included (a lazy import is an arrow all the same).
"""

from __future__ import annotations

import ast
from pathlib import Path

SRC = Path(__file__).resolve().parents[2] / "src"
PACKAGE = SRC / "handeye_pick"
MAX_MODULE_LINES = 600


def _module_name(path: Path) -> str:
    parts = path.relative_to(SRC).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _room(module: str) -> str | None:
    """The room of a ``handeye_pick`` module: its first name below the package."""
    parts = module.split(".")
    if parts[0] != "handeye_pick":
        return None
    return parts[1] if len(parts) > 1 else "handeye_pick"


def _imported(path: Path) -> set[str]:
    """Every module ``path`` imports by absolute name, at any depth of its code."""
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module is not None and node.level == 0:
            found.add(node.module)
            found.update(f"{node.module}.{alias.name}" for alias in node.names)
    return found


def room_arrows() -> dict[str, dict[str, set[str]]]:
    """room -> room it imports -> the importing modules (for the message)."""
    arrows: dict[str, dict[str, set[str]]] = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        module = _module_name(path)
        here = _room(module)
        for target in _imported(path):
            there = _room(target)
            if here is None or there is None or there in (here, "handeye_pick"):
                continue
            if not (PACKAGE / there).is_dir() and not (PACKAGE / f"{there}.py").is_file():
                continue  # "from handeye_pick import Cell" names a symbol, not a room
            arrows.setdefault(here, {}).setdefault(there, set()).add(module)
    return arrows


def loops(arrows: dict[str, dict[str, set[str]]]) -> list[list[str]]:
    """The strongly connected groups of more than one room (Tarjan's algorithm)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    groups: list[list[str]] = []

    def visit(room: str) -> None:
        index[room] = low[room] = len(index)
        stack.append(room)
        for other in arrows.get(room, {}):
            if other not in index:
                visit(other)
                low[room] = min(low[room], low[other])
            elif other in stack:
                low[room] = min(low[room], index[other])
        if low[room] == index[room]:
            group = []
            while True:
                member = stack.pop()
                group.append(member)
                if member == room:
                    break
            if len(group) > 1:
                groups.append(sorted(group))

    for room in sorted(arrows):
        if room not in index:
            visit(room)
    return groups


def test_every_arrow_between_rooms_points_one_way() -> None:
    arrows = room_arrows()
    found = loops(arrows)
    details = [
        f"{a} -> {b} in {sorted(arrows[a][b])}"
        for group in found
        for a in group
        for b in group
        if b in arrows.get(a, {})
    ]
    assert not found, "rooms that import each other: " + "; ".join(details)


def test_the_loop_finder_sees_a_loop_of_three_and_a_lazy_import(tmp_path: Path) -> None:
    arrows = {"a": {"b": {"x"}}, "b": {"c": {"y"}}, "c": {"a": {"z"}}, "d": {"a": {"w"}}}
    assert loops(arrows) == [["a", "b", "c"]]
    lazy = tmp_path / "m.py"
    lazy.write_text("def f():\n    from handeye_pick.cell.session import Cell\n")
    assert "handeye_pick.cell.session" in _imported(lazy)


def test_the_layout_has_the_rooms_the_docs_name() -> None:
    """The lower rooms the session, the config and the scene stand on."""
    arrows = room_arrows()
    assert "steps" in arrows["scene"]
    assert "hand_eye" in arrows["config"]
    assert "cell" in arrows["calibration"]  # the collect procedure drives a session
    assert "cell" not in arrows.get("hand_eye", {})


def test_no_module_outgrows_one_reading() -> None:
    too_long = {
        str(path.relative_to(SRC)): n
        for path in PACKAGE.rglob("*.py")
        if (n := len(path.read_text(encoding="utf-8").splitlines())) > MAX_MODULE_LINES
    }
    assert not too_long, f"modules over {MAX_MODULE_LINES} lines: {too_long}"
