"""``plant/`` and ``design/`` are built in floors: each unit (a subpackage, or a module at the package's top)
declares in its docstring what it may import (a line ``May import: ``a``, ``b``.``, where a package's name
covers all of it), the imports stay within what is declared, the declared floors stack without a circle, and
the modules import one another without a cycle; nothing in ``plant`` imports ``design``. Read from the source
(ast), so an import inside a function counts as much as one at the top."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("plant", "design")


def _modules(package: str) -> dict[str, Path]:
    out = {}
    for path in (ROOT / package).rglob("*.py"):
        rel = path.relative_to(ROOT).with_suffix("")
        out[".".join(rel.parts[:-1] if rel.name == "__init__" else rel.parts)] = path
    return out


def _unit(module: str) -> str:
    """``plant.physics.chain`` -> ``plant.physics``; ``design.problem`` -> itself; ``plant`` -> itself."""
    return ".".join(module.split(".")[:2])


def _units(package: str) -> dict[str, Path]:
    """Each unit and the file that declares its floor (the subpackage's ``__init__`` or the module)."""
    return {m: p for m, p in _modules(package).items() if _unit(m) == m}


def _declared(path: Path) -> set[str] | None:
    """The names of the unit's ``May import:`` line (empty for "nothing"), None without one."""
    doc = ast.get_docstring(ast.parse(path.read_text(encoding="utf-8"))) or ""
    match = re.search(r"May import:(.*?)\.(\s|$)", doc, re.S)
    if match is None:
        return None
    return set(re.findall(r"``([\w.]+)``", match.group(1)))


def _imports(path: Path) -> set[str]:
    found = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            found.add(node.module)
        elif isinstance(node, ast.Import):
            found |= {a.name for a in node.names}
    return {i for i in found if i.split(".")[0] in PACKAGES}


def _allowed(target: str, own: str, declared: set[str]) -> bool:
    unit = _unit(target)
    return (unit == own or target == target.split(".")[0] == own.split(".")[0]      # the package's own top
            or unit in declared or target.split(".")[0] in declared)


@pytest.mark.parametrize("package", PACKAGES)
def test_every_unit_declares_its_floor(package):
    missing = [u for u, p in _units(package).items() if _declared(p) is None]
    assert not missing, f"no 'May import:' line in the docstring of {missing}"
    units = set(_units(package)) | set(PACKAGES)
    unknown = {u: sorted(_declared(p) - units) for u, p in _units(package).items() if _declared(p) - units}
    assert not unknown, f"declared names that are no unit: {unknown}"


@pytest.mark.parametrize("package", PACKAGES)
def test_imports_stay_within_the_declared_floors(package):
    units = _units(package)
    wrong = []
    for m, path in _modules(package).items():
        own = _unit(m)
        declared = _declared(units[own])
        for i in sorted(_imports(path)):
            if package == "plant" and i.split(".")[0] == "design":
                wrong.append(f"{m} imports {i} (plant never imports design)")
            elif not _allowed(i, own, declared):
                wrong.append(f"{m} imports {i}, which {own} does not declare")
    assert not wrong, "\n".join(wrong)


def _assert_acyclic(graph: dict[str, set[str]]) -> None:
    state: dict[str, int] = {}

    def visit(m: str, path: list[str]) -> None:
        state[m] = 1
        for n in sorted(graph.get(m, ())):
            assert state.get(n) != 1, " -> ".join([*path, m, n])
            if n not in state:
                visit(n, [*path, m])
        state[m] = 2

    for m in sorted(graph):
        if m not in state:
            visit(m, [])


def test_the_declared_floors_stack_without_a_circle():
    graph = {}
    for package in PACKAGES:
        for u, p in _units(package).items():
            graph[u] = {d for d in _declared(p) if d != u and d not in PACKAGES}
    _assert_acyclic(graph)


@pytest.mark.parametrize("package", PACKAGES)
def test_no_import_cycle_between_modules(package):
    mods = _modules(package)
    graph = {m: {i for i in _imports(p) if i in mods and i != m and i != package} for m, p in mods.items()}
    _assert_acyclic(graph)
