"""GLB bytes for the pages: a head (+ animation) written through :func:`mimika.io.gltf.write_gltf`
into a temporary folder named with this process's id, which :func:`sweep_temp_dirs` removes
after a server that was killed."""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

_TEMP = "mimika-studio-"


@contextlib.contextmanager
def temp_dir() -> Iterator[Path]:
    """A temporary folder for one export, named with this process's id (see
    :func:`sweep_temp_dirs`)."""
    with tempfile.TemporaryDirectory(prefix=f"{_TEMP}{os.getpid()}-") as d:
        yield Path(d)


def sweep_temp_dirs() -> int:
    """Remove the export folders of servers that were killed; returns how many."""
    from mimika.io.atomic import pid_alive

    n = 0
    base = Path(tempfile.gettempdir())
    with contextlib.suppress(OSError):
        for p in base.glob(_TEMP + "*-*"):
            pid = p.name[len(_TEMP):].split("-", 1)[0]
            if pid.isdigit() and p.is_dir() and not pid_alive(int(pid)):
                shutil.rmtree(p, ignore_errors=True)
                n += 1
    return n


def gltf_bytes(rig: Any, track: Any, *, name: str = "mimika", keep: bool = False) -> bytes:
    """``rig``'s head (+ ``track``'s animation) as GLB bytes, through :func:`write_gltf`;
    with ``keep`` (a download), an avatar file is written again with the animation added
    (:mod:`mimika.io.gltf_avatar`) instead of in the page's layout."""
    from mimika.face.heads.gltf_export import avatar_export
    from mimika.io.gltf import write_gltf
    from mimika.io.gltf_avatar import write_avatar_gltf
    from mimika.render.appearance import export_appearance

    with temp_dir() as d:
        kept = avatar_export(rig, track) if keep else None
        if kept is not None:
            return write_avatar_gltf(d / f"{name}.glb", kept, track).read_bytes()
        attributes, extras = export_appearance(rig.head)
        return write_gltf(d / f"{name}.glb", rig, track, attributes=attributes,
                          extras=extras).read_bytes()
