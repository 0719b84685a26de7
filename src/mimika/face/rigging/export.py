"""Write a rigged head as GLB: mimika's glTF export (FACS AU morph targets, neck/head skin,
eye nodes) plus the ARKit-52 morph targets under their ARKit names, so Unreal Live Link,
three.js and TalkingHead-style players drive it directly."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from mimika.face.morphs import ARKIT_52, canonical_arkit
from mimika.face.rig import Rig
from mimika.face.rigging.generate import Shapes

__all__ = ["arkit_shapes", "write_rigged"]


def arkit_shapes(shapes: Shapes) -> dict[str, dict[str, np.ndarray]]:
    """The ARKit-52 shapes (ARKit names) among ``shapes`` (ICT names), in ARKit order."""
    return {a: shapes[canonical_arkit(a)] for a in ARKIT_52 if canonical_arkit(a) in shapes}


def write_rigged(path: str | Path, rig: Rig, extra: Mapping[str, Mapping[str, np.ndarray]]
                 ) -> tuple[Path, list[str]]:
    """Write ``rig``'s head with its AU morphs plus ``extra`` morphs (name → object → deltas
    in cm) to ``path`` (.glb or .gltf); returns the path and the names of the extra morphs."""
    from mimika.io.gltf import _ARRAY, _FLOAT, SCALE, _Builder, build_gltf, save_gltf

    p = Path(path)
    doc, binary = build_gltf(rig, name=p.stem)
    b = _Builder()
    b.bin, b.views, b.accessors = bytearray(binary), doc["bufferViews"], doc["accessors"]
    written: list[str] = []
    for mesh in doc["meshes"]:
        obj = mesh["name"]
        new = [(n, d[obj]) for n, d in extra.items()
               if obj in d and np.abs(d[obj]).max() > 1e-6]
        if not new:
            continue
        prims = mesh["primitives"]
        targets = list(prims[0].get("targets", []))
        targets += [{"POSITION": b.add((d * SCALE).astype(np.float32), "VEC3", _FLOAT,
                                       target=_ARRAY, minmax=True)} for _, d in new]
        for prim in prims:
            prim["targets"] = targets
        names = [*mesh.get("extras", {}).get("targetNames", []), *(n for n, _ in new)]
        mesh["extras"] = {**mesh.get("extras", {}), "targetNames": names}
        mesh["weights"] = [0.0] * len(targets)
        written += [n for n, _ in new if n not in written]
    while len(b.bin) % 4:
        b.bin.append(0)
    doc["extras"] = {**doc.get("extras", {}), "arkit": written}
    return save_gltf(p, doc, bytes(b.bin)), written
