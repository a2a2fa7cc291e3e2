"""The rooms of jostle/: who may import the command line, the benches and the virtual performer, and
no import circles between modules.

Rooms: ``jostle.cli`` (the ``jostle`` command) may import everything; ``jostle.bench`` (benchmarks,
soak, baseline, fits) may import the layers, the performer and the composition root; nothing else
imports either. The layers (sensors, interaction, sim, render) never import the performer or the
benches (tests/test_import_direction.py checks the layers' order).
"""

from __future__ import annotations

import ast
import importlib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ["sensors", "interaction", "sim", "render", "jostle"]
LAYERS = ["sensors", "interaction", "sim", "render"]


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _modules() -> dict[str, Path]:
    return {_module_name(p): p for pkg in PACKAGES for p in sorted((ROOT / pkg).rglob("*.py"))}


def _imports(name: str, path: Path, known: dict[str, Path]) -> list[tuple[int, str]]:
    """Every module of the repository that ``name`` imports (also inside functions), with the line.

    ``from package import x`` counts as importing ``package.x`` when that is a module."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found: list[tuple[int, str]] = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), filename=str(path))):
        if isinstance(node, ast.Import):
            found += [(node.lineno, a.name) for a in node.names if a.name in known]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")[: len(package.split(".")) - (node.level - 1)]
                base = ".".join(anchor + ([base] if base else []))
            for a in node.names:
                target = f"{base}.{a.name}"
                if target in known:
                    found.append((node.lineno, target))
                elif base in known:
                    found.append((node.lineno, base))
    return found


def _room_rule_breaks(room: str, allowed: tuple[str, ...]) -> list[str]:
    known = _modules()
    wrong = []
    for name, path in known.items():
        if name.startswith(allowed):
            continue
        for line, target in _imports(name, path, known):
            if target == room or target.startswith(room + "."):
                wrong.append(f"{path.relative_to(ROOT)}:{line}: imports {target}")
    return wrong


def test_only_the_command_line_imports_the_command_line() -> None:
    assert not _room_rule_breaks("jostle.cli", ("jostle.cli",))


def test_only_the_command_line_and_the_benches_import_the_benches() -> None:
    assert not _room_rule_breaks("jostle.bench", ("jostle.cli", "jostle.bench"))


@pytest.mark.parametrize("room", ["jostle.performer", "jostle.bench", "jostle.cli"])
def test_the_layers_never_import_the_rooms_of_jostle(room: str) -> None:
    assert not _room_rule_breaks(room, ("jostle",))  # every module outside jostle/ is in a layer


def test_every_bench_of_the_table_imports_and_has_its_two_functions() -> None:
    from jostle.bench.table import BENCHES

    for name, (module, description) in BENCHES.items():
        assert importlib.import_module(module.__name__) is module, name
        assert module.__name__.startswith("jostle.bench."), name
        assert callable(module.add_arguments) and callable(module.run), name
        assert description, name


def _graph(scope: tuple[str, ...]) -> dict[str, list[str]]:
    """Module → the modules it imports, among those whose names start with one of ``scope``."""
    known = _modules()
    return {n: sorted({t for _, t in _imports(n, p, known) if t != n and t.startswith(scope)})
            for n, p in known.items() if n.startswith(scope)}


def _cycles(graph: dict[str, list[str]]) -> list[list[str]]:
    """The import circles of ``graph``: its strongly connected components of two or more (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph.get(v, []):
            if w not in index:
                visit(w)
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
            if len(component) > 1:
                found.append(sorted(component))

    for v in graph:
        if v not in index:
            visit(v)
    return found


def test_no_import_circles() -> None:
    """Between any modules of the five packages (imports run one way between packages, so a circle
    can only lie inside one, but the whole graph is searched)."""
    assert _cycles(_graph(tuple(PACKAGES))) == []


def test_the_cycle_finder_finds_a_circle() -> None:
    graph = {"a": ["b"], "b": ["c"], "c": ["a"], "d": ["a"], "e": []}
    assert _cycles(graph) == [["a", "b", "c"]]
    known = _modules()
    targets = [t for _, t in _imports("jostle.cli.commands", known["jostle.cli.commands"], known)]
    assert "jostle.cli.bench" in targets  # ``from jostle.cli import bench`` is an import of the module
