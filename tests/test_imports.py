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
    assert loaded_after("from mimika.timeline.easing import get_interpolator; "
                        "get_interpolator('learned')") == []
