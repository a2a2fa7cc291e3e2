"""Data flows one way: sensors → interaction → sim → render → jostle.

Every import in every module (including those inside functions) is checked, so a lazy import cannot
sneak a dependency in the wrong direction.
"""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
ORDER = ["sensors", "interaction", "sim", "render", "jostle"]


def _imports(path: Path) -> list[tuple[int, str]]:
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    found: list[tuple[int, str]] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [(node.lineno, a.name) for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            found.append((node.lineno, node.module))
        elif isinstance(node, ast.ImportFrom) and node.level > 0:
            found.append((node.lineno, "." * node.level + (node.module or "")))
    return found


def test_every_package_exists() -> None:
    for pkg in ORDER:
        assert (ROOT / pkg / "__init__.py").is_file(), pkg


@pytest.mark.parametrize("pkg", ORDER)
def test_imports_flow_left_to_right(pkg: str) -> None:
    mine = ORDER.index(pkg)
    wrong = []
    files = sorted((ROOT / pkg).rglob("*.py"))
    assert files
    for path in files:
        for line, module in _imports(path):
            if module.startswith("."):
                depth = len(module) - len(module.lstrip("."))
                if depth > len(path.relative_to(ROOT).parts) - 1:
                    wrong.append(f"{path.relative_to(ROOT)}:{line}: relative import leaves the package")
                continue
            head = module.split(".")[0]
            if head in ORDER and ORDER.index(head) > mine:
                wrong.append(f"{path.relative_to(ROOT)}:{line}: {pkg} imports {module}")
    assert not wrong, "\n".join(wrong)


def test_keyframes_never_import_drawing() -> None:
    """Inside render/: the drawing (render.gl) uses the keyframe sets (render.keyframes), never the reverse."""
    wrong = [f"{path.relative_to(ROOT)}:{line}: imports {module}"
             for path in sorted((ROOT / "render" / "keyframes").rglob("*.py"))
             for line, module in _imports(path) if module == "render.gl" or module.startswith("render.gl.")]
    assert not wrong, "\n".join(wrong)


def test_the_checker_catches_a_wrong_import(tmp_path: Path) -> None:
    bad = tmp_path / "m.py"
    bad.write_text("def f():\n    from render.gl.renderer import Renderer\n    import jostle.app\n")
    heads = [m.split(".")[0] for _, m in _imports(bad)]
    assert heads == ["render", "jostle"]


def test_importing_sensors_pulls_in_no_hardware_backend() -> None:
    code = (
        "import sys, sensors, sensors.registry, interaction.types, sim.snapshot\n"
        "bad = [m for m in ('cv2', 'depthai', 'serial', 'pybullet', 'pyglet') if m in sys.modules]\n"
        "print(','.join(bad))\n"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, check=True)
    assert r.stdout.strip() == "", f"importing the contracts pulled in: {r.stdout.strip()}"
