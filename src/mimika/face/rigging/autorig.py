"""``mimika rig``: give a face mesh with no facial morphs FACS and ARKit blendshapes.

1. Read the mesh (OBJ, glTF/GLB/VRM); split its meshes into connected pieces (the copies of
   a vertex at a UV seam welded: :func:`~mimika.face.rigging.features.weld`).
2. Find the face and bring it into mimika's frame (:mod:`~mimika.face.rigging.frame`), or take
   the eyes and mouth from a landmarks file.
3. Sort the pieces: eyeballs (round, behind an eye opening) turn for AU61–64; teeth and tongue
   (inside the mouth) follow the jaw, the lower ones as their own objects; the rest is face.
4. Place the 68 landmarks and carry the shipped per-shape fields onto the mesh
   (:mod:`~mimika.face.rigging.generate`): the 53 ICT shapes, from which the ARKit-52 set (all
   but ``tongueOut``) and the FACS AUs (``facs/data/ict_aus.json``) are composed.
5. Keep where each object came from, so the output is the input with morphs added
   (:func:`~mimika.face.rigging.export.write_rigged`): same place, meshes, vertex order, UVs.
"""

from __future__ import annotations

import json
import logging
import tempfile
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
from mimika.face.rigging.features import find_face, sphere_fit, weld
from mimika.face.rigging.frame import Frame, detect_frame, frame_from_points
from mimika.face.rigging.generate import Shapes, generate_shapes, template
from mimika.face.rigging.landmarks import landmarks68

log = logging.getLogger(__name__)

__all__ = ["RiggedMesh", "read_landmarks", "rig_mesh"]


@dataclass
class RiggedMesh:
    """The rigged head, its AU rig, the generated shapes (ICT names) and what was found. The
    head's ``meta["gltf"]`` is the file :func:`~mimika.face.rigging.export.write_rigged`
    writes again (the input, or an OBJ's GLB twin)."""

    head: Head
    rig: AvatarRig
    shapes: Shapes
    frame: Frame
    seconds: dict[str, float] = field(default_factory=dict)


@dataclass
class _Source:
    """One mesh of the input as the output keeps it: vertices (file units), triangles per
    material, UVs (mimika's convention: v up), category, and glTF materials per part."""

    name: str
    vertices: np.ndarray
    parts: list[tuple[str, np.ndarray]]
    uvs: np.ndarray | None = None
    category: str = "face"
    materials: list | None = None


@dataclass
class _Piece:
    """A connected piece of a source mesh (seams welded): its vertices' indices there."""

    src: int
    index: np.ndarray
    name: str
    vertices: np.ndarray  # file units
    parts: list[tuple[str, np.ndarray]]  # material name, faces (local indices)
    uvs: np.ndarray | None = None
    category: str = "face"
    materials: list | None = None  # glTF: the SceneMaterial of each part (or None)
    weld: np.ndarray | None = None  # per vertex, a label shared by the copies of a position


def _split(si: int, s: _Source) -> list[_Piece]:
    """The connected pieces of source mesh ``s`` (UV-seam copies welded; vertices no
    triangle uses left out)."""
    n = len(s.vertices)
    rep = weld(s.vertices)
    tris = [f for _, f in s.parts]
    groups = np.concatenate([np.full(len(f), k) for k, f in enumerate(tris)])
    f = np.concatenate(tris).astype(np.int64)
    fw = rep[f]
    e = np.concatenate([fw[:, [0, 1]], fw[:, [1, 2]]])
    g = sparse.coo_matrix((np.ones(len(e)), (e[:, 0], e[:, 1])), shape=(n, n))
    _, lab = connected_components(g, directed=False)
    face_lab = lab[fw[:, 0]]
    pieces = []
    for k in np.unique(face_lab):
        fk = f[face_lab == k]
        used = np.unique(fk)
        remap = np.full(n, -1, np.int64)
        remap[used] = np.arange(len(used))
        gk = groups[face_lab == k]
        parts = [(s.parts[gi][0], remap[fk[gk == gi]]) for gi in np.unique(gk)]
        mats = None if s.materials is None else [s.materials[gi] for gi in np.unique(gk)]
        labels = np.unique(rep[used], return_inverse=True)[1]
        pieces.append(_Piece(si, used, s.name, s.vertices[used], parts,
                             None if s.uvs is None else s.uvs[used], s.category, mats,
                             labels if len(np.unique(labels)) < len(used) else None))
    return pieces


def _obj_source(path: Path) -> _Source:
    """An OBJ as one mesh the way glTF holds it: the file's vertices in their order, then a
    copy for each further texture coordinate a vertex takes at a UV seam."""
    from mimika.io.obj import read_obj

    m = read_obj(path)
    if len(m.faces) == 0:
        raise DataError(f"{path}: the mesh has no faces")
    v, f = m.vertices.astype(float), m.faces.astype(np.int64)
    uv = None
    if m.uvs is not None and m.face_uvs is not None:
        n = len(v)
        corners = np.c_[f.reshape(-1), m.face_uvs.reshape(-1)]
        pairs, inv = np.unique(corners, axis=0, return_inverse=True)
        inv = inv.reshape(-1)
        first = np.full(len(pairs), len(corners))
        np.minimum.at(first, inv, np.arange(len(corners)))
        order = np.lexsort((first, pairs[:, 0]))  # per vertex, its first corner's pair first
        head = np.r_[True, pairs[order[1:], 0] != pairs[order[:-1], 0]]
        primary = np.zeros(len(pairs), bool)
        primary[order[head]] = True
        new = pairs[:, 0].copy()
        extra = np.flatnonzero(~primary)
        new[extra] = n + np.arange(len(extra))
        v = np.concatenate([v, v[pairs[extra, 0]]])
        uv = np.zeros((len(v), 2))
        uv[new] = m.uvs[pairs[:, 1]]
        f = new[inv].reshape(-1, 3)
    parts = [(m.groups[g], f[m.face_groups == g]) for g in np.unique(m.face_groups)]
    return _Source(path.stem, v, parts, uv)


def _read(path: Path) -> tuple[list[_Source], object | None, str, int | None]:
    """The input's meshes, its glTF scene (None for OBJ), unit and VRM version."""
    ext = path.suffix.lower()
    if ext == ".obj":
        return [_obj_source(path)], None, "cm", None
    if ext in (".glb", ".gltf", ".vrm"):
        from mimika.face.heads.gltf import mesh_category
        from mimika.face.heads.gltf_scene import read_gltf
        from mimika.face.heads.roles import motion, name_role

        sc = read_gltf(path)
        sources = []
        for m in sc.meshes:
            mats = [sc.materials[k] if 0 <= k < len(sc.materials) else None
                    for k, _ in m.primitives]
            parts = [(mat.name if mat else "default", f)
                     for mat, (_, f) in zip(mats, m.primitives, strict=True)]
            uv = None if m.uvs is None else np.c_[m.uvs[:, 0], 1.0 - m.uvs[:, 1]]
            role = name_role(m.name, m.mesh_name)
            cat = mesh_category(m, sc, set())
            if cat == "face" and role is not None and motion(role.role) == "none":
                cat = "body"  # hair, glasses, clothes: no fields
            sources.append(_Source(m.name, m.vertices, parts, uv, cat, mats))
        return sources, sc, "m", sc.vrm_version
    raise DataError(f"{path}: mimika rig reads .obj, .glb, .gltf and .vrm meshes")


def _twin(path: Path, src: _Source, scale_m: float, folder: Path) -> Path:
    """The OBJ's GLB twin (positions × ``scale_m`` to metres) in ``folder``."""
    from mimika.face.rigging.export import BareMesh, write_bare_glb

    uv = None if src.uvs is None else np.c_[src.uvs[:, 0], 1.0 - src.uvs[:, 1]]
    return write_bare_glb(folder / f"{path.stem}.glb",
                          [BareMesh(src.name, src.vertices * scale_m, src.parts, uv)])


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


def _keep_source(head: Head, path: Path, sources: list[_Source], scene: object | None,
                 frame: Frame, where: dict[str, tuple[int, np.ndarray | None]]) -> None:
    """``head.meta["gltf"]``: the file the output is written over — the input, or an OBJ's
    GLB twin (in a folder that lives as long as the head, ``meta["twin"]``) — and where
    each object's vertices are in it (None: the whole mesh)."""
    from mimika.face.heads.gltf_export import AvatarSource
    from mimika.face.heads.gltf_scene import read_gltf

    if scene is None:
        folder = tempfile.TemporaryDirectory(prefix="mimika-rig-")
        head.meta["twin"] = folder
        path = _twin(path, sources[0], frame.scale / 100.0, Path(folder.name))
        scene = read_gltf(path)
        frame = Frame(100.0, frame.rotation, frame.translation, frame.features, "m",
                      frame.notes)
    bones: dict[str, int | None] = dict.fromkeys(("head", "neck", "eye_L", "eye_R"))
    head.meta["gltf"] = AvatarSource(path, scene, scene.node_world, frame, dict(where), {},
                                     bones)


def rig_mesh(path: str | Path, *, landmarks: str | Path | None = None, style: str = "ict",
             strength: float = 1.0) -> RiggedMesh:
    """Rig the mesh at ``path`` (see the module doc); ``style``: whose shapes the fields were
    fitted on (:data:`~mimika.face.rigging.generate.STYLES`); ``strength``: a factor on every
    generated shape."""
    t0 = time.perf_counter()
    p = Path(path)
    if not p.is_file():
        raise DataError(f"{p}: no such file")
    sources, scene, unit, vrm = _read(p)
    pieces = [pc for si, s in enumerate(sources) for pc in _split(si, s)]
    pieces.sort(key=lambda pc: (pc.category != "face", -len(pc.vertices)))
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
        objs.append(MeshObject(name, pc.category, v, parts, pivot, pc.uvs, pc.weld))
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
    whole = [len(pc.index) == len(sources[pc.src].vertices) for pc in pieces]
    _keep_source(head, p, sources, scene, frame,
                 {o.name: (pc.src, None if w else pc.index)
                  for o, pc, w in zip(objs, pieces, whole, strict=True)})
    t2 = time.perf_counter()
    shapes = generate_shapes(head, style=style)
    if strength != 1.0:
        shapes = {n: {o: (d * strength).astype(np.float32) for o, d in per.items()}
                  for n, per in shapes.items()}
    t3 = time.perf_counter()
    rig, cover = build_rig(head, shapes, {n: f"{n} (fields)" for n in shapes})
    head.meta["coverage"] = cover
    secs = {"frame": t1 - t0, "landmarks": t2 - t1, "fields": t3 - t2,
            "rig": time.perf_counter() - t3}
    log.info("rigged %s in %.1f s (%s)", p, sum(secs.values()),
             ", ".join(f"{k} {v:.1f} s" for k, v in secs.items()))
    return RiggedMesh(head, rig, shapes, frame, secs)
