"""Test helper: import a glTF/GLB into headless Blender and get back what Blender built.

    from blender_app import blender_import, needs_blender

    @needs_blender
    def test_x(tmp_path):
        rep = blender_import(path, mimika_timing=True)
        skin = rep.object("skin")            # one object's entry (KeyError if absent)
        assert "AU12" in skin["shape_keys"]

Blender is Debian's ``blender`` package (``scripts/setup-blender.sh`` installs it as root);
without it the tests skip with the reason. The report comes from ``tools/blender_inspect.py``
(scene fps and range, objects with shape keys / vertex groups / modifiers / materials,
armature bones, actions and their frame ranges, materials and images).
"""

from __future__ import annotations

import json
import shutil
import subprocess
from dataclasses import dataclass
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[1] / "tools" / "blender_inspect.py"
BLENDER = shutil.which("blender")


def _missing() -> str | None:
    if BLENDER is None:
        return ("blender is not installed (Debian: apt-get install blender python3-numpy; "
                "scripts/setup-blender.sh does it as root)")
    return None


needs_blender = pytest.mark.skipif(_missing() is not None, reason=_missing() or "")


@dataclass
class BlenderReport:
    """What Blender made of an imported file (see tools/blender_inspect.py)."""

    data: dict

    def __getitem__(self, key: str):
        return self.data[key]

    def object(self, name: str) -> dict:
        for o in self.data["objects"]:
            if o["name"] == name:
                return o
        names = ", ".join(o["name"] for o in self.data["objects"])
        raise KeyError(f"no object {name!r} in Blender's scene (objects: {names})")

    def objects(self, type: str | None = None) -> list[dict]:
        return [o for o in self.data["objects"] if type is None or o["type"] == type]

    def action(self, name: str) -> dict:
        for a in self.data["actions"]:
            if a["name"] == name:
                return a
        raise KeyError(f"no action {name!r} (actions: "
                       f"{', '.join(a['name'] for a in self.data['actions'])})")


def blender_import(path: str | Path, *, mimika_timing: bool = False,
                   timeout: float = 300) -> BlenderReport:
    """Import ``path`` (.glb/.gltf) into an empty scene of headless Blender; with
    ``mimika_timing`` the way docs/formats.md tells users (fps and range from the extras)."""
    if BLENDER is None:
        pytest.skip(_missing() or "")
    cmd = [BLENDER, "-b", "--factory-startup", "-noaudio", "--python-exit-code", "1",
           "--python", str(SCRIPT), "--", str(path)]
    if mimika_timing:
        cmd.append("--mimika-timing")
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    line = next((x for x in r.stdout.splitlines() if x.startswith("BLENDER_REPORT ")), None)
    if r.returncode or line is None:
        raise AssertionError(f"Blender failed to import {path} (exit {r.returncode}):\n"
                             f"{r.stdout[-3000:]}\n{r.stderr[-3000:]}")
    return BlenderReport(json.loads(line[len("BLENDER_REPORT "):]))
