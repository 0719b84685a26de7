"""``mimika rig``: give a face mesh with no facial morphs FACS and ARKit blendshapes.

1. Read the mesh (OBJ, glTF/GLB/VRM); split OBJ meshes into connected pieces.
2. Find the face and bring it into mimika's frame (:mod:`~mimika.face.rigging.frame`), or take
   the eyes and mouth from a landmarks file.
3. Sort the pieces: eyeballs (round, behind an eye opening) turn for AU61–64; teeth and tongue
   (inside the mouth) follow the jaw, the lower ones as their own objects; the rest is face.
4. Place the 68 landmarks and carry the shipped per-shape fields onto the mesh
   (:mod:`~mimika.face.rigging.generate`): the 53 ICT shapes, from which the ARKit-52 set (all
   but ``tongueOut``) and the FACS AUs (``facs/data/ict_aus.json``) are composed.
"""

from __future__ import annotations

import json
import logging
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy import sparse
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from mimika.errors import DataError
from mimika.face.head import Head, MeshObject, Part
from mimika.face.rigging.assemble import AvatarRig, build_rig, head_anchors
from mimika.face.rigging.features import find_face, sphere_fit
from mimika.face.rigging.frame import Frame, detect_frame, frame_from_points
from mimika.face.rigging.generate import Shapes, generate_shapes, template
from mimika.face.rigging.landmarks import landmarks68

log = logging.getLogger(__name__)

__all__ = ["RiggedMesh", "read_landmarks", "rig_mesh"]


@dataclass
class RiggedMesh:
    """The rigged head, its AU rig, the generated shapes (ICT names) and what was found."""

    head: Head
    rig: AvatarRig
    shapes: Shapes
    frame: Frame
    seconds: dict[str, float] = field(default_factory=dict)


@dataclass
class _Piece:
    name: str
    vertices: np.ndarray  # file units
    parts: list[tuple[str, np.ndarray]]  # material name, faces (local indices)
    uvs: np.ndarray | None = None
    category: str = "face"
    materials: list | None = None  # glTF: the SceneMaterial of each part (or None)


def _split(v: np.ndarray, f: np.ndarray, groups: np.ndarray, names: tuple[str, ...],
           uvs: np.ndarray | None, stem: str) -> list[_Piece]:
    """Connected pieces of one mesh, largest first (unused vertices dropped)."""
    n = len(v)
    e = np.concatenate([f[:, [0, 1]], f[:, [1, 2]]])
    g = sparse.coo_matrix((np.ones(len(e)), (e[:, 0], e[:, 1])), shape=(n, n))
    _, lab = connected_components(g, directed=False)
    face_lab = lab[f[:, 0]]
    pieces = []
    for k in np.unique(face_lab):
        fk = f[face_lab == k]
        used = np.unique(fk)
        remap = np.full(n, -1, np.int64)
        remap[used] = np.arange(len(used))
        gk = groups[face_lab == k]
        parts = [(names[gi], remap[fk[gk == gi]]) for gi in np.unique(gk)]
        pieces.append(_Piece(stem, v[used], parts, None if uvs is None else uvs[used]))
    pieces.sort(key=lambda p: -len(p.vertices))
    return pieces


def _read(path: Path) -> tuple[list[_Piece], str, int | None]:
    """Pieces, the file's unit and its VRM version."""
    ext = path.suffix.lower()
    if ext == ".obj":
        from mimika.io.obj import read_obj

        m = read_obj(path)
        if len(m.faces) == 0:
            raise DataError(f"{path}: the mesh has no faces")
        return (_split(m.vertices.astype(float), m.faces.astype(np.int64),
                       m.face_groups, m.groups, m.vertex_uvs(), path.stem), "cm", None)
    if ext in (".glb", ".gltf", ".vrm"):
        from mimika.face.heads.gltf import mesh_category
        from mimika.face.heads.gltf_scene import read_gltf

        sc = read_gltf(path)
        pieces = []
        for m in sc.meshes:
            mats = [sc.materials[k] if 0 <= k < len(sc.materials) else None
                    for k, _ in m.primitives]
            parts = [(mat.name if mat else "default", f)
                     for mat, (_, f) in zip(mats, m.primitives, strict=True)]
            uv = None if m.uvs is None else np.c_[m.uvs[:, 0], 1.0 - m.uvs[:, 1]]
            pieces.append(_Piece(m.name, m.vertices, parts, uv, mesh_category(m, sc, set()),
                                 mats))
        pieces.sort(key=lambda p: (p.category != "face", -len(p.vertices)))
        return pieces, "m", sc.vrm_version
    raise DataError(f"{path}: mimika rig reads .obj, .glb, .gltf and .vrm meshes")


def read_landmarks(path: str | Path) -> dict[str, np.ndarray]:
    """A landmarks file: JSON ``{"eye_L": [x, y, z], "eye_R": …, "mouth": …}`` in the mesh's
    own coordinates (``eye_L`` is the subject's left eye; ``mouth`` the middle of the lips),
    optionally ``"landmarks68"``: the 68 Multi-PIE points, used as they are."""
    p = Path(path)
    try:
        doc = json.loads(p.read_text("utf-8"))
        pts = {k: np.asarray(doc[k], float).reshape(3) for k in ("eye_L", "eye_R", "mouth")}
        if "landmarks68" in doc:
            pts["landmarks68"] = np.asarray(doc["landmarks68"], float).reshape(68, 3)
    except OSError as e:
        raise DataError(f"cannot read landmarks file {p}: {e.strerror}") from None
    except json.JSONDecodeError as e:
        raise DataError(f"{p}:{e.lineno}:{e.colno}: invalid JSON: {e.msg}") from None
    except (KeyError, TypeError, ValueError) as e:
        raise DataError(f"{p}: landmarks need eye_L, eye_R and mouth as [x, y, z] (and "
                        f"optionally landmarks68: 68 of them) ({type(e).__name__}: {e})"
                        ) from None
    return pts


def _classify(pieces: list[_Piece], frame: Frame) -> None:
    """Eyeballs: round pieces centred within 2 cm of an eye opening; teeth/tongue: pieces
    whose centre lies in the mouth (within its half-width of the mouth centre, behind it)."""
    ft = frame.features
    d = ft.eye_distance
    for pc in pieces[1:]:
        if pc.category != "face":
            continue
        v = frame.apply(pc.vertices)
        c, r = sphere_fit(v)
        resid = np.abs(np.linalg.norm(v - c, axis=1) - r).mean() if len(v) > 8 else np.inf
        near_eye = min(np.linalg.norm(c - ft.eye_L), np.linalg.norm(c - ft.eye_R))
        if resid < 0.15 * r and near_eye < 0.35 * d and 0.1 * d < r < 0.35 * d:
            pc.category = "eyes"
            continue
        cen = v.mean(0)
        rel = cen - ft.mouth
        if abs(rel[0]) < 0.5 * d and -0.6 * d < rel[1] < 0.3 * d and -0.9 * d < rel[2] < 0.2 * d:
            pc.category = "teeth"


def _part(material: str, faces: np.ndarray, category: str, mat=None) -> Part:
    """A renderer part; a glTF material keeps its base-colour texture and alpha mode."""
    from mimika.face.heads.gltf import part_texture, render_material

    key = render_material(material, category)
    return Part(key, faces) if mat is None else Part(key, faces, *part_texture(mat, key))


def rig_mesh(path: str | Path, *, landmarks: str | Path | None = None, style: str = "ict"
             ) -> RiggedMesh:
    """Rig the mesh at ``path`` (see the module doc); ``style``: whose shapes the fields were
    fitted on (:data:`~mimika.face.rigging.generate.STYLES`)."""
    t0 = time.perf_counter()
    p = Path(path)
    if not p.is_file():
        raise DataError(f"{p}: no such file")
    pieces, unit, vrm = _read(p)
    face = pieces[0]
    faces = np.concatenate([f for _, f in face.parts])
    given = None
    if landmarks is not None:
        pts = read_landmarks(landmarks)
        given = pts.pop("landmarks68", None)
        frame = frame_from_points(pts, unit, str(landmarks))
        feat = find_face(frame.apply(face.vertices), faces)
        if feat is not None and np.linalg.norm(feat.eye_L - frame.features.eye_L) < \
                0.35 * frame.features.eye_distance:
            frame = Frame(frame.scale, frame.rotation, frame.translation, feat, frame.unit,
                          frame.notes)
    else:
        frame = detect_frame(face.vertices, faces, kind="gltf" if unit == "m" else "obj",
                             unit=unit, vrm_version=vrm, where=str(p))
    t1 = time.perf_counter()
    _classify(pieces, frame)
    objs: list[MeshObject] = []
    eyes: dict[str, np.ndarray] = {}
    used: dict[str, int] = {}
    for i, pc in enumerate(pieces):
        # OBJ pieces are named after the file: call them by what they are
        base = "skin" if i == 0 else pc.category if pc.name == p.stem else pc.name
        used[base] = used.get(base, 0) + 1
        name = base if used[base] == 1 else f"{base}.{used[base] - 1}"
        v = frame.apply(pc.vertices).astype(np.float32)
        parts = tuple(_part(m, f, pc.category, mat) for (m, f), mat in
                      zip(pc.parts, pc.materials or [None] * len(pc.parts), strict=True))
        pivot = None
        if pc.category == "eyes":
            pivot = sphere_fit(v)[0]
            eyes.setdefault("eye_L" if pivot[0] > 0 else "eye_R", pivot)
        objs.append(MeshObject(name, pc.category, v, parts, pivot, pc.uvs))
    skin_v = objs[0].vertices.astype(float)
    if given is not None:
        _, lm_idx = cKDTree(skin_v).query(frame.apply(given))
        lm_pts = skin_v[lm_idx]
    else:
        lm_idx, lm_pts = landmarks68(skin_v, frame.features, **template(style), faces=faces)
    for side, pt in (("eye_L", frame.features.eye_L), ("eye_R", frame.features.eye_R)):
        eyes.setdefault(side, pt - [0.0, 0.0, 1.2])
    head = Head(p.stem, tuple(objs), lm_idx, head_anchors(skin_v, lm_pts, eyes),
                landmark_object="skin", description=f"rigged by mimika from {p}",
                meta={"source": str(p), "frame": frame.describe(), "frame_obj": frame})
    t2 = time.perf_counter()
    shapes = generate_shapes(head, style=style)
    t3 = time.perf_counter()
    rig, cover = build_rig(head, shapes, {n: f"{n} (fields)" for n in shapes})
    head.meta["coverage"] = cover
    secs = {"frame": t1 - t0, "landmarks": t2 - t1, "fields": t3 - t2,
            "rig": time.perf_counter() - t3}
    log.info("rigged %s in %.1f s (%s)", p, sum(secs.values()),
             ", ".join(f"{k} {v:.1f} s" for k, v in secs.items()))
    return RiggedMesh(head, rig, shapes, frame, secs)
