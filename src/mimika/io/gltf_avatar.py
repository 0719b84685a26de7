"""glTF export that keeps the user's avatar: the source file written again with mimika's
animation added, so the output replaces the input in its pipeline (TalkingHead, three-vrm,
Blender, Unity, Unreal).

The source document is kept as it was (:mod:`mimika.io.gltf_repack`: nodes and their names,
the whole skeleton and its skins, materials and textures in their own format, extensions and
extras); what the export adds is described in glTF terms by an :class:`AvatarExport`, which
the face layer makes from a rig and a track (:mod:`mimika.face.heads.gltf_export`):

* :class:`MorphTarget` — morph targets the avatar lacks (shapes mimika generated for AUs its
  own morphs do not cover), appended to a mesh under their name, or written into a target of
  the same name that moves nothing;
* per node the animated morph weights (its mesh's own targets first), local rotations and
  translations (the file's own neck, head and eye joints), in one animation ``mimika``
  placed first (the file's own animations follow).
"""

from __future__ import annotations

import logging
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

import mimika
from mimika.errors import ParameterError
from mimika.io.gltf import _Animation, save_gltf, timing_extras
from mimika.io.gltf_repack import repack
from mimika.io.gltf_source import load_source
from mimika.tracks import AUTrack

log = logging.getLogger(__name__)

__all__ = ["AvatarExport", "MorphTarget", "build_avatar_gltf", "write_avatar_gltf"]


@dataclass
class MorphTarget:
    """A morph target for glTF mesh ``mesh``: per primitive index its POSITION deltas (n, 3)
    in the mesh's own space (primitives left out do not move); ``replaces``: the index of an
    existing target of that name that moves nothing, which these deltas fill."""

    mesh: int
    name: str
    deltas: dict[int, np.ndarray]
    replaces: int | None = None


@dataclass
class AvatarExport:
    """What to write over source file ``source``: new morph targets and, per node, animated
    morph weights (T, targets of its mesh after ``targets``), local rotations (T, 4: x, y, z,
    w) and translations (T, 3), T being the track's frames; ``trs``: nodes stored as a matrix
    that are animated, with the translation, rotation and scale to store instead;
    ``extras``: added to the document's extras under ``mimika``."""

    source: Path
    targets: list[MorphTarget] = field(default_factory=list)
    weights: dict[int, np.ndarray] = field(default_factory=dict)
    rotations: dict[int, np.ndarray] = field(default_factory=dict)
    translations: dict[int, np.ndarray] = field(default_factory=dict)
    trs: dict[int, tuple[list[float], list[float], list[float]]] = field(default_factory=dict)
    extras: dict[str, Any] = field(default_factory=dict)


def _add_targets(doc: dict[str, Any], b: Any, targets: list[MorphTarget]) -> None:
    """Write ``targets`` into ``doc``'s meshes: appended (named in ``extras.targetNames``,
    ``weights`` extended), or filling an empty target of the same name."""
    for t in targets:
        mesh = doc["meshes"][t.mesh]
        prims = mesh["primitives"]
        n_old = len(prims[0].get("targets", []))
        names = list((mesh.get("extras") or {}).get("targetNames") or [])
        if len(names) != n_old:
            names = [f"morph{k}" for k in range(n_old)]
        made: dict[int, int] = {}  # primitives sharing a vertex array share the target
        for pi, prim in enumerate(prims):
            pos = prim["attributes"]["POSITION"]
            if pos not in made:
                d = t.deltas.get(pi)
                made[pos] = b.add_sparse(d if d is not None else np.zeros(
                    (doc["accessors"][pos]["count"], 3), np.float32))
            acc = made[pos]
            tl = prim.setdefault("targets", [])
            if t.replaces is not None:
                tl[t.replaces] = {**tl[t.replaces], "POSITION": acc}
            else:
                tl.append({"POSITION": acc})
        if t.replaces is None:
            names.append(t.name)
            if "weights" in mesh:
                mesh["weights"] = [*mesh["weights"], 0.0]
            mesh.setdefault("extras", {})["targetNames"] = names


def _animation(b: Any, track: AUTrack, ex: AvatarExport) -> dict[str, Any]:
    anim = _Animation(b, track, [])

    def keys(a: np.ndarray) -> np.ndarray:
        a = np.asarray(a, np.float32)
        return np.repeat(a, 2, axis=0) if len(a) == 1 and anim.n == 2 else a

    for node, w in sorted(ex.weights.items()):
        anim.add(node, "weights", keys(w).reshape(-1), "SCALAR")
    for node, q in sorted(ex.rotations.items()):
        q = keys(q)
        anim.add(node, "rotation", q / np.linalg.norm(q, axis=1, keepdims=True), "VEC4")
    for node, t in sorted(ex.translations.items()):
        anim.add(node, "translation", keys(t), "VEC3")
    out = anim.doc()
    out["extras"] = timing_extras(track)
    return out


def build_avatar_gltf(ex: AvatarExport, track: AUTrack | None) -> tuple[dict, bytes]:
    """The glTF document and binary buffer of ``ex``'s source with its additions (and,
    with a track of frames, the animation)."""
    src = load_source(ex.source)
    doc, b = repack(src)
    _add_targets(doc, b, ex.targets)
    nodes = doc.get("nodes", [])
    for ni, (t, r, s) in ex.trs.items():
        nd = nodes[ni]
        nd.pop("matrix", None)
        nd.update({"translation": t, "rotation": r, "scale": s})
    if track is not None and track.n_frames:
        n_targets = {ni: len(doc["meshes"][nodes[ni]["mesh"]]["primitives"][0].get(
            "targets", [])) for ni in ex.weights}
        for ni, w in ex.weights.items():
            if w.shape[1] != n_targets[ni]:
                raise ValueError(f"node {ni}: {w.shape[1]} weights for {n_targets[ni]} "
                                 "morph targets")
        doc["animations"] = [_animation(b, track, ex), *doc.get("animations", [])]
        scene = doc.get("scenes", [{}])[doc.get("scene", 0)]
        scene["extras"] = {**(scene.get("extras") or {}), **timing_extras(track)}
    asset = doc.setdefault("asset", {"version": "2.0"})
    asset["generator"] = f"mimika {mimika.__version__}" + (
        f" (from {asset['generator']})" if asset.get("generator") else "")
    if ex.extras:
        doc["extras"] = {**(doc.get("extras") or {}), "mimika": ex.extras}
    for key in ("bufferViews", "accessors", "images"):
        if key in doc and not doc[key]:
            del doc[key]
    while len(b.bin) % 4:
        b.bin.append(0)
    return doc, bytes(b.bin)


def write_avatar_gltf(path: str | os.PathLike, ex: AvatarExport, track: AUTrack | None
                      ) -> Path:
    """Write ``ex`` (and ``track``'s animation) to ``path`` — ``.glb`` (``.vrm``: a VRM is a
    GLB) or ``.gltf`` (its buffer a base64 data URI) — atomically. Returns the path."""
    p = Path(path)
    if p.suffix.lower() not in (".glb", ".gltf", ".vrm"):
        raise ParameterError(f"glTF output {str(p)!r} must end in .glb, .gltf or .vrm")
    doc, binary = build_avatar_gltf(ex, track)
    return save_gltf(p, doc, binary)
