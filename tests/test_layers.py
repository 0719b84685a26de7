"""Lower layers never import upper ones (the module map of the architecture): every import in
the package, at module level or inside a function, outside ``if TYPE_CHECKING:`` blocks."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "mimika"
#: package → the packages it must not import
FORBIDDEN = {
    "facs": ("face", "render", "speech"),
    "face": ("render", "speech"),
    "knowledge": ("render",),
    "markup": ("render",),
    "timeline": ("render",),
    "speech": ("face", "render"),
    "behaviour": ("render",),
    "learn": ("studio",),
    "render": ("speech", "learn"),
    "io": ("render", "face"),
    "web": ("studio", "serve"),
    "serve": ("studio",),
    "studio": ("serve",),
}


def _type_checking(node: ast.If) -> bool:
    t = node.test
    return (isinstance(t, ast.Name) and t.id == "TYPE_CHECKING") or (
        isinstance(t, ast.Attribute) and t.attr == "TYPE_CHECKING")


def imported(path: Path) -> list[tuple[int, str]]:
    """``(line, module)`` of every ``mimika.*`` import in ``path`` that runs."""
    out: list[tuple[int, str]] = []

    def visit(node: ast.AST) -> None:
        if isinstance(node, ast.If) and _type_checking(node):
            for child in node.orelse:
                visit(child)
            return
        if isinstance(node, ast.Import):
            out.extend((node.lineno, a.name) for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            out.append((node.lineno, node.module))
        for child in ast.iter_child_nodes(node):
            visit(child)

    visit(ast.parse(path.read_text("utf-8")))
    return [(n, m) for n, m in out if m == "mimika" or m.startswith("mimika.")]


@pytest.mark.parametrize("package", sorted(FORBIDDEN))
def test_a_layer_imports_no_layer_above_it(package):
    bad = []
    for path in sorted((SRC / package).rglob("*.py")):
        for line, module in imported(path):
            parts = module.split(".")
            if len(parts) > 1 and parts[1] in FORBIDDEN[package]:
                bad.append(f"{path.relative_to(SRC.parent)}:{line} imports {module}")
    assert not bad, "\n".join(bad)


def test_the_check_sees_imports_inside_functions(tmp_path):
    f = tmp_path / "m.py"
    f.write_text("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n"
                 "    from mimika.render import Renderer\n"
                 "def g():\n    from mimika.render.context import get_context\n")
    assert imported(f) == [(5, "mimika.render.context")]


def test_io_loads_no_upper_layer_at_run_time():
    """Importing every io/ module (and what it imports in turn) loads nothing from above."""
    mods = sorted(p.stem for p in (SRC / "io").glob("*.py") if p.stem != "__init__")
    code = ("import sys\n" + "".join(f"import mimika.io.{m}\n" for m in mods) +
            "import mimika.io.gltf_ext.meshopt, mimika.io.gltf_ext.webp\n"
            "up = sorted(m for m in sys.modules if m.startswith(('mimika.face', "
            "'mimika.studio', 'mimika.render')))\nprint(','.join(up))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env={"PYTHONPATH": str(SRC.parent)}, check=True,
                         timeout=120).stdout.strip()
    assert out == "", f"io/ pulls in {out}"
