"""Lower layers stand alone: importing every io/ module loads nothing from face/ or studio/."""

import subprocess
import sys
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src"


def test_io_imports_no_upper_layer():
    mods = sorted(p.stem for p in (SRC / "mimika" / "io").glob("*.py") if p.stem != "__init__")
    code = ("import sys\n" + "".join(f"import mimika.io.{m}\n" for m in mods) +
            "import mimika.io.gltf_ext.meshopt, mimika.io.gltf_ext.webp\n"
            "up = sorted(m for m in sys.modules if m.startswith(('mimika.face', "
            "'mimika.studio', 'mimika.render')))\nprint(','.join(up))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env={"PYTHONPATH": str(SRC)}, check=True, timeout=120).stdout.strip()
    assert out == "", f"io/ pulls in {out}"
