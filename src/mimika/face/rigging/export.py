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


def _view(b, arr: np.ndarray) -> int:
    a = np.ascontiguousarray(arr)
    while len(b.bin) % 4:
        b.bin.append(0)
    b.views.append({"buffer": 0, "byteOffset": len(b.bin), "byteLength": a.nbytes})
    b.bin += a.tobytes()
    return len(b.views) - 1


def _sparse(b, d: np.ndarray) -> int:
    """A sparse VEC3 accessor of deltas ``d`` (N, 3): only the vertices that move are stored
    (a face shape moves a few thousand of a body's vertices)."""
    ids = np.flatnonzero(np.abs(d).max(1) > 0).astype(np.uint32)
    vals = d[ids]
    b.accessors.append({
        "componentType": 5126, "count": len(d), "type": "VEC3",
        "min": np.minimum(vals.min(0), 0).astype(float).tolist(),
        "max": np.maximum(vals.max(0), 0).astype(float).tolist(),
        "sparse": {"count": len(ids),
                   "indices": {"bufferView": _view(b, ids), "componentType": 5125},
                   "values": {"bufferView": _view(b, vals.astype(np.float32))}}})
    return len(b.accessors) - 1


def write_rigged(path: str | Path, rig: Rig, extra: Mapping[str, Mapping[str, np.ndarray]]
                 ) -> tuple[Path, list[str]]:
    """Write ``rig``'s head with its AU morphs plus ``extra`` morphs (name → object → deltas
    in cm) to ``path`` (.glb or .gltf); returns the path and the names of the extra morphs."""
    from mimika.io.gltf import SCALE, _Builder, build_gltf, save_gltf

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
        targets += [{"POSITION": _sparse(b, (d * SCALE).astype(np.float32))} for _, d in new]
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
