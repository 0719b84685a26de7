"""Write a rigged head as the file it was read from, with its blendshapes added.

``mimika rig`` leaves the input as it was — position, orientation, its meshes, their vertex
order, UVs, materials, nodes and skeleton — and adds morph targets: the FACS AUs (``AU01`` …
``AU46``, ``AU12L``/``AU12R``: one per AU and side, the rig's own shapes) and the ARKit-52 set
under ARKit names (sparse accessors), so ``mimika --head``, Unreal Live Link, three.js and
TalkingHead-style players drive it. A glTF/GLB/VRM input is written again by the faithful
export (:mod:`mimika.io.gltf_avatar`); an OBJ is first written as a plain GLB twin
(:func:`write_bare_glb`: one mesh, the OBJ's vertices in their order, a copy appended for
each further texture coordinate a vertex has at a UV seam, its ``usemtl`` groups as
primitives) in metres, and that is written again.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from mimika.face.morphs import ARKIT_52, canonical_arkit
from mimika.face.rig import Rig
from mimika.face.rigging.generate import Shapes

__all__ = ["BareMesh", "arkit_shapes", "au_shapes", "write_bare_glb", "write_obj",
           "write_rigged"]

#: head AUs move the head, not a morph
_HEAD_AUS = tuple(f"AU{n}" for n in range(51, 59))


@dataclass(frozen=True)
class BareMesh:
    """A mesh for :func:`write_bare_glb`: positions (N, 3) in metres, triangles per material
    name, texture coordinates (N, 2) in glTF's convention (v down) or None."""

    name: str
    vertices: np.ndarray
    parts: Sequence[tuple[str, np.ndarray]]
    uvs: np.ndarray | None = None


def write_bare_glb(path: str | Path, meshes: Sequence[BareMesh]) -> Path:
    """A GLB of ``meshes`` and nothing else: one node per mesh (no transform), one primitive
    per material (a plain material of that name), the vertices shared by the primitives."""
    from mimika.io.gltf import _ARRAY, _ELEMENTS, _FLOAT, _UINT, _Builder, save_gltf

    b = _Builder()
    materials: dict[str, int] = {}
    doc: dict = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": []}],
                 "nodes": [], "meshes": []}
    for m in meshes:
        attrs = {"POSITION": b.add(np.asarray(m.vertices, np.float32), "VEC3", _FLOAT,
                                   target=_ARRAY, minmax=True)}
        if m.uvs is not None:
            attrs["TEXCOORD_0"] = b.add(np.asarray(m.uvs, np.float32), "VEC2", _FLOAT,
                                        target=_ARRAY)
        prims = []
        for mat, f in m.parts:
            idx = np.asarray(f, np.uint32).reshape(-1)
            prims.append({"attributes": attrs, "mode": 4,
                          "indices": b.add(idx, "SCALAR", _UINT, target=_ELEMENTS, minmax=True),
                          "material": materials.setdefault(mat, len(materials))})
        doc["meshes"].append({"name": m.name, "primitives": prims})
        doc["nodes"].append({"name": m.name, "mesh": len(doc["meshes"]) - 1})
        doc["scenes"][0]["nodes"].append(len(doc["nodes"]) - 1)
    doc["materials"] = [{"name": n, "pbrMetallicRoughness": {"metallicFactor": 0.0}}
                        for n in materials]
    doc["accessors"], doc["bufferViews"] = b.accessors, b.views
    doc["buffers"] = [{"byteLength": len(b.bin)}]
    return save_gltf(path, doc, bytes(b.bin))


def write_obj(path: str | Path, v: np.ndarray, f: np.ndarray, uvs: np.ndarray | None = None,
              face_uvs: np.ndarray | None = None,
              groups: Sequence[tuple[str, int]] | None = None) -> Path:
    """A plain OBJ of vertices ``v`` and triangles ``f`` (0-based), with texture coordinates
    ``uvs`` indexed per corner by ``face_uvs`` (default: per vertex) when given, and
    ``groups``: (material, number of triangles) in the order of ``f``, as ``usemtl``."""
    p = Path(path)
    f = np.asarray(f, np.int64) + 1
    t = None if uvs is None else f if face_uvs is None else np.asarray(face_uvs, np.int64) + 1
    lines = [f"f {a}/{x} {b}/{y} {c}/{z}\n" for (a, b, c), (x, y, z) in zip(f, t, strict=True)
             ] if t is not None else [f"f {a} {b} {c}\n" for a, b, c in f]
    start = 0
    for name, n in groups or ():
        lines[start] = f"usemtl {name}\n" + lines[start]
        start += n
    with open(p, "w") as fh:
        fh.write("".join(f"v {a:.6f} {b:.6f} {c:.6f}\n" for a, b, c in np.asarray(v)))
        if uvs is not None:
            fh.write("".join(f"vt {a:.6f} {b:.6f}\n" for a, b in np.asarray(uvs)))
        fh.write("".join(lines))
    return p


def arkit_shapes(shapes: Shapes) -> dict[str, dict[str, np.ndarray]]:
    """The ARKit-52 shapes (ARKit names) among ``shapes`` (ICT names), in ARKit order."""
    return {a: shapes[canonical_arkit(a)] for a in ARKIT_52 if canonical_arkit(a) in shapes}


def au_shapes(rig: Rig) -> dict[str, dict[str, np.ndarray]]:
    """The shape part of every AU and side the rig models (``AU12``, ``AU12L``, ``AU12R``;
    not the head's motion nor the eyes' turns): AU morph targets, object → deltas (cm)."""
    out: dict[str, dict[str, np.ndarray]] = {}
    for code in rig.supported:
        if code[:4] in _HEAD_AUS:
            continue
        d = {o: x for o, x in rig.shape_deltas(code).items() if np.abs(x).max() > 1e-6}
        if d:
            out[code] = d
    return out


def write_rigged(path: str | Path, rig: Rig, extra: Mapping[str, Mapping[str, np.ndarray]]
                 ) -> tuple[Path, list[str]]:
    """Write the file ``rig``'s head was rigged from (``head.meta["gltf"]``) to ``path``
    (.glb or .gltf) with the rig's AU morphs plus ``extra`` morphs (name → object → deltas
    in cm, head frame) added; returns the path and the names of the ``extra`` morphs."""
    from mimika.face.heads.gltf_export import avatar_export
    from mimika.io.gltf_avatar import write_avatar_gltf

    added: dict[str, dict[str, tuple[np.ndarray, np.ndarray]]] = {}
    for name, per in {**au_shapes(rig), **extra}.items():
        sparse = {}
        for obj, d in per.items():
            idx = np.flatnonzero(np.abs(d).max(1) > 1e-6)
            if len(idx):
                sparse[obj] = (idx, np.asarray(d[idx], np.float32))
        if sparse:
            added[name] = sparse
    view = SimpleNamespace(head=rig.head, generated=added, supported=rig.supported,
                           table=getattr(rig, "table", {}))
    ex = avatar_export(view, None)
    if ex is None:
        raise ValueError(f"{rig.head.name}: not read by mimika rig (no source file to write)")
    ex.extras["arkit"] = [n for n in extra if n in added]
    return write_avatar_gltf(path, ex, None), ex.extras["arkit"]
