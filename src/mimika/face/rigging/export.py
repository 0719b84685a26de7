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
    return b.add_bytes(np.ascontiguousarray(arr).tobytes())


def _repack(doc: dict, binary: bytes, b) -> object:
    """Copy every accessor of ``doc`` into builder ``b``, morph targets as sparse accessors
    (mimika's export writes them dense: 12 bytes per vertex per AU and side, most of them 0)."""
    sparse_ids = {t["POSITION"] for m in doc["meshes"] for pr in m["primitives"]
                  for t in pr.get("targets", [])}
    views = doc["bufferViews"]
    if doc.get("images") or len({a["bufferView"] for a in doc["accessors"]}) != len(views):
        b.bin, b.views, b.accessors = bytearray(binary), views, doc["accessors"]
        return b  # views that are not accessors (images): keep the layout as it is
    new_index = {}
    for i, acc in enumerate(doc["accessors"]):
        v = views[acc["bufferView"]]
        width = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}[acc["type"]]
        dt = {5126: np.float32, 5125: np.uint32, 5123: np.uint16}[acc["componentType"]]
        raw = np.frombuffer(binary, dt, acc["count"] * width, v["byteOffset"]).reshape(
            acc["count"], width)
        if i in sparse_ids:
            new_index[i] = b.add_sparse(raw)
            continue
        vi = _view(b, raw)
        if "target" in v:
            b.views[vi]["target"] = v["target"]
        b.accessors.append({**acc, "bufferView": vi})
        new_index[i] = len(b.accessors) - 1
    remap = new_index.__getitem__
    for m in doc["meshes"]:
        for pr in m["primitives"]:
            pr["attributes"] = {k: remap(a) for k, a in pr["attributes"].items()}
            pr["indices"] = remap(pr["indices"])
            if "targets" in pr:
                pr["targets"] = [{"POSITION": remap(t["POSITION"])} for t in pr["targets"]]
    for sk in doc.get("skins", []):
        sk["inverseBindMatrices"] = remap(sk["inverseBindMatrices"])
    for an in doc.get("animations", []):
        for sm in an["samplers"]:
            sm["input"], sm["output"] = remap(sm["input"]), remap(sm["output"])
    doc["bufferViews"], doc["accessors"] = b.views, b.accessors
    return b


def write_rigged(path: str | Path, rig: Rig, extra: Mapping[str, Mapping[str, np.ndarray]]
                 ) -> tuple[Path, list[str]]:
    """Write ``rig``'s head with its AU morphs plus ``extra`` morphs (name → object → deltas
    in cm) to ``path`` (.glb or .gltf); returns the path and the names of the extra morphs."""
    from mimika.io.gltf import SCALE, _Builder, build_gltf, save_gltf

    p = Path(path)
    doc, binary = build_gltf(rig, name=p.stem)
    b = _repack(doc, binary, _Builder())
    written: list[str] = []
    for mesh in doc["meshes"]:
        obj = mesh["name"]
        new = [(n, d[obj]) for n, d in extra.items()
               if obj in d and np.abs(d[obj]).max() > 1e-6]
        if not new:
            continue
        prims = mesh["primitives"]
        targets = list(prims[0].get("targets", []))
        targets += [{"POSITION": b.add_sparse(d * SCALE)} for _, d in new]
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
