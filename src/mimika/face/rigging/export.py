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
    vals = d[ids].astype(np.float32)
    lo, hi = vals.min(0), vals.max(0)
    if len(ids) < len(d):  # the vertices left out are 0
        lo, hi = np.minimum(lo, 0), np.maximum(hi, 0)
    b.accessors.append({
        "componentType": 5126, "count": len(d), "type": "VEC3",
        "min": lo.astype(float).tolist(), "max": hi.astype(float).tolist(),
        "sparse": {"count": len(ids),
                   "indices": {"bufferView": _view(b, ids), "componentType": 5125},
                   "values": {"bufferView": _view(b, vals)}}})
    return len(b.accessors) - 1


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
            new_index[i] = _sparse(b, raw)
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
