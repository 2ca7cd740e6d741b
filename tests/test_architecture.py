"""``plant/`` is built in floors, each importing only the floors below it, and its modules import one
another without a cycle; nothing in ``plant`` imports ``design``. Read from the source (ast), so an import
inside a function counts as much as one at the top."""

from __future__ import annotations

import ast
from pathlib import Path

PLANT = Path(__file__).resolve().parents[1] / "plant"
#: the floors from the bottom up; the base modules (errors, grid, arguments) sit under every floor
FLOORS = ("host", "physics", "data", "estimate", "experiment", "identify", "diagnose")


def _floor(module: str) -> int:
    """0 for the base (``plant``, ``plant.errors``, ``plant.grid``, ``plant.arguments``), else 1 + the floor's index."""
    parts = module.split(".")
    return FLOORS.index(parts[1]) + 1 if len(parts) > 1 and parts[1] in FLOORS else 0


def _modules() -> dict[str, Path]:
    out = {}
    for path in PLANT.rglob("*.py"):
        rel = path.relative_to(PLANT.parent).with_suffix("")
        name = ".".join(rel.parts[:-1] if rel.name == "__init__" else rel.parts)
        out[name] = path
    return out


def _imports(path: Path) -> set[str]:
    found = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            found.add(node.module)
            found |= {f"{node.module}.{a.name}" for a in node.names}
        elif isinstance(node, ast.Import):
            found |= {a.name for a in node.names}
    return found


def _graph() -> dict[str, set[str]]:
    mods = _modules()
    return {m: {i for i in _imports(p) if i in mods and i != m and i != "plant"} for m, p in mods.items()}


def test_plant_is_in_floors_with_a_doc_each():
    top = {p.stem for p in PLANT.glob("*.py")}
    assert top == {"__init__", "errors", "grid", "arguments"}, top
    for floor in FLOORS:
        doc = ast.get_docstring(ast.parse((PLANT / floor / "__init__.py").read_text(encoding="utf-8")))
        assert doc and "May import" in doc, floor


def test_each_floor_imports_only_downward_and_never_design():
    mods = _modules()
    wrong = []
    for m, path in mods.items():
        for i in _imports(path):
            if i.split(".")[0] == "design":
                wrong.append(f"{m} imports {i}")
            elif i.startswith("plant.") and _floor(i) > _floor(m):
                wrong.append(f"{m} (floor {_floor(m)}) imports {i} (floor {_floor(i)})")
    assert not wrong, "\n".join(sorted(wrong))


def test_no_import_cycle_in_plant():
    graph = _graph()
    state: dict[str, int] = {}

    def visit(m: str, path: list[str]) -> None:
        state[m] = 1
        for n in sorted(graph[m]):
            assert state.get(n) != 1, " -> ".join([*path, m, n])
            if n not in state:
                visit(n, [*path, m])
        state[m] = 2

    for m in sorted(graph):
        if m not in state:
            visit(m, [])
