"""`import mimika` and the CLI stay light: heavy libraries load only where they are used."""

import subprocess
import sys

HEAVY = ("torch", "moderngl", "fastapi", "dask", "distributed", "espeakng_loader", "matplotlib",
         "av", "scipy.optimize")


def loaded_after(code: str) -> list[str]:
    probe = f"import sys; {code}; print(','.join(m for m in {HEAVY!r} if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True)
    return [m for m in out.stdout.strip().split(",") if m]


def test_import_mimika_loads_nothing_heavy():
    assert loaded_after("import mimika, mimika.tracks, mimika.facs") == []


def test_cli_parser_loads_nothing_heavy():
    assert loaded_after("import mimika.cli; mimika.cli.build_parser()") == []


def test_learned_easing_registers_without_torch():
    assert loaded_after("import mimika.learn; from mimika.timeline.easing import "
                        "get_interpolator; get_interpolator('learned')") == []
    assert loaded_after("import mimika.cli; mimika.cli.build_parser(); from mimika.timeline "
                        "import get_interpolator; get_interpolator('learned')") == []


def test_timeline_never_imports_learn():
    """Layering: the timeline is below learn; 'learned' is registered from above."""
    import ast
    from pathlib import Path

    import mimika.timeline

    for f in Path(mimika.timeline.__file__).parent.glob("*.py"):
        for node in ast.walk(ast.parse(f.read_text())):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import) else
                     [node.module or ""] if isinstance(node, ast.ImportFrom) else [])
            assert not any(n.startswith("mimika.learn") for n in names), f
    code = ("import sys; import mimika.timeline as t; "
            "print('mimika.learn' in sys.modules, 'learned' in t.easing_names())")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.split() == ["False", "False"]
