"""Any glTF / GLB / VRM character as a head: ``--head avatar.glb``.

Meshes become head objects (eye meshes — by name, material or eye bone — rotate for AU61–64;
teeth and tongue are ``teeth``; the rest ``face``), brought into mimika's frame by the rule of
:mod:`mimika.face.rigging.frame`. Morph targets are matched to AUs by name
(:mod:`mimika.face.morphs`: FACS, ARKit-52, Oculus visemes, VRM expressions) and AUs no morph
covers fall back to seed-002 fields carried onto the mesh by its landmarks
(:mod:`mimika.face.rigging.assemble`). Head AUs follow the skin's head bone where there is one.
Each part carries its material's base colour as a texture (the image times the colour factor,
or a 1×1 image of the factor) with the glTF alpha mode; the renderer's material (skin, lips,
sclera …, chosen by name) gives the shading. Normal maps are kept, unused, in
``head.meta["materials"]``.
"""

from __future__ import annotations

import logging
import re
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from mimika.errors import DataError
from mimika.face.head import Head, MeshObject, Part, Texture
from mimika.face.heads.gltf_scene import GltfScene, SceneMaterial, SceneMesh, read_gltf
from mimika.face.morphs import MorphMatch, classify
from mimika.face.rigging.assemble import AvatarRig, build_rig, head_anchors
from mimika.face.rigging.features import find_face, sphere_fit
from mimika.face.rigging.frame import Frame, detect_frame, frame_from_points
from mimika.face.rigging.generate import Shapes, template_landmarks
from mimika.face.rigging.landmarks import landmarks68

log = logging.getLogger(__name__)

__all__ = ["EXTENSIONS", "load_gltf_head", "mesh_category", "render_material"]

EXTENSIONS = (".glb", ".gltf", ".vrm")
_EYE = re.compile(r"eye(?!brow|lash|line|_?lid|shadow)|iris|pupil|cornea|sclera", re.I)
_TEETH = re.compile(r"teeth|tooth|tongue|gum", re.I)
#: renderer material (render/data/materials.json) by words in a glTF material/mesh name
_RENDER_KEYS = (("cornea", "cornea"), ("pupil", "pupil"), ("iris", "iris"),
                ("sclera", "sclera"), ("eyewhite", "sclera"), ("lash", "lash"),
                ("brow", "brow"), ("hair", "hair"), ("lip", "lips"), ("tongue", "tongue"),
                ("gum", "gums"), ("teeth", "teeth"), ("tooth", "teeth"), ("eye", "sclera"),
                ("mouth", "mouth"), ("skin", "skin"), ("head", "skin"), ("face", "skin"),
                ("body", "skin"))


def render_material(name: str, category: str) -> str:
    """The renderer's material (its shading: skin, lips, sclera …) for a glTF material
    ``name``: by the words in it, else skin for face objects, sclera for eyes."""
    low = name.lower().replace("_", "").replace(" ", "")
    for word, key in _RENDER_KEYS:
        if word in low:
            return key
    return {"eyes": "sclera", "teeth": "teeth"}.get(category, "skin")


_ALPHA = {"OPAQUE": "opaque", "MASK": "mask", "BLEND": "blend"}
#: renderer materials whose texture alpha is a gloss map, not opacity
_GLOSS_ALPHA = ("skin", "lips")


def part_texture(mat: SceneMaterial, key: str) -> tuple[Texture, str]:
    """The part's texture — the base-colour image times the base-colour factor, or a 1×1
    image of the factor — and its alpha mode (glTF OPAQUE | MASK | BLEND)."""
    f = np.asarray(mat.base_color, float)
    img = mat.base_color_image
    if img is None:
        img = np.ones((1, 1, 4))
    else:
        img = img.astype(float) / 255.0
        if img.shape[2] == 3:
            img = np.concatenate([img, np.ones((*img.shape[:2], 1))], axis=2)
        rgb = img[..., :3]
        img[..., :3] = np.where(rgb <= 0.04045, rgb / 12.92, ((rgb + 0.055) / 1.055) ** 2.4)
    img = img * f  # linear colour × factor, alpha × factor
    rgb = np.clip(img[..., :3], 0, 1)
    img[..., :3] = np.where(rgb <= 0.0031308, 12.92 * rgb, 1.055 * rgb ** (1 / 2.4) - 0.055)
    mode = _ALPHA.get(mat.alpha_mode.upper(), "opaque")
    if mode == "opaque" or key in _GLOSS_ALPHA:
        img = img[..., :3]
        mode = "opaque" if key in _GLOSS_ALPHA else mode
    return Texture(np.round(np.clip(img, 0, 1) * 255).astype(np.uint8), mat.name), mode


def _bone(scene: GltfScene, vrm_name: str, pattern: str) -> int | None:
    if vrm_name in scene.bones:
        return scene.bones[vrm_name]
    rx = re.compile(pattern, re.I)
    for i, n in enumerate(scene.node_names):
        if rx.search(re.split(r"[.:|]", n)[-1]):
            return i
    return None


def mesh_category(m: SceneMesh, scene: GltfScene, eye_bones: set[int]) -> str:
    """eyes (held by an eye bone, or named/made of eye, iris, pupil …), teeth (teeth, tongue,
    gums) or face."""
    mats = " ".join(scene.materials[k].name for k, _ in m.primitives if 0 <= k <
                    len(scene.materials))
    if m.joints is not None and eye_bones:
        w = np.where(np.isin(m.joints, list(eye_bones)), m.weights, 0.0).sum(1)
        if np.mean(w > 0.5) > 0.9:
            return "eyes"
    if _EYE.search(m.name) and not _TEETH.search(m.name):
        return "eyes"
    if _TEETH.search(m.name) or (_TEETH.search(mats) and not _EYE.search(m.name)):
        return "teeth"
    if _EYE.search(mats) and not re.search(r"skin|face|head|body", mats, re.I):
        return "eyes"
    return "face"


def _centroid(v: np.ndarray, d: np.ndarray) -> np.ndarray:
    mag = np.linalg.norm(d, axis=1)
    if not len(mag) or mag.max() <= 0:  # a morph that moves nothing
        return v.mean(0) if len(v) else np.zeros(3)
    sel = mag >= 0.3 * mag.max()
    return (v[sel] * mag[sel, None]).sum(0) / mag[sel].sum()


def _morph_points(m: SceneMesh, matches: Mapping[int, MorphMatch]) -> dict | None:
    """Eye and mouth positions (file units) from blink and jaw/mouth morphs, or None."""
    by = {mt.name: k for k, mt in matches.items()}
    for blink in ("eyeBlink", "AU45", "AU43", "AU46"):
        if f"{blink}_L" in by and f"{blink}_R" in by:
            break
    else:
        return None
    mouth = next((n for n in ("jawOpen", "AU27", "AU26", "viseme_aa", "AU25") if n in by), None)
    if mouth is None:
        return None
    pts = {s: _centroid(m.vertices, m.morph_deltas[by[f"{blink}_{s[-1]}"]])
           for s in ("eye_L", "eye_R")}
    pts["mouth"] = _centroid(m.vertices, m.morph_deltas[by[mouth]])
    return pts


def _frame(scene: GltfScene, face: SceneMesh, matches: Mapping[int, MorphMatch],
           path: Path) -> Frame:
    """The head frame: from the blink and jaw morphs when the face has them (exact for any
    shape of eye opening), else from the eye and mouth openings."""
    faces = np.concatenate([f for _, f in face.primitives])
    pts = _morph_points(face, matches)
    if pts is None:
        return detect_frame(face.vertices, faces, kind="gltf", unit="m",
                            vrm_version=scene.vrm_version, where=str(path))
    fr = frame_from_points(pts, "m", str(path))
    # eye and mouth rims from the openings, now that the frame is known
    feat = find_face(fr.apply(face.vertices), faces)
    near = feat is not None and all(
        np.linalg.norm(a - b) < 0.35 * fr.features.eye_distance
        for a, b in ((feat.eye_L, fr.features.eye_L), (feat.eye_R, fr.features.eye_R)))
    return Frame(fr.scale, fr.rotation, fr.translation, feat if near else fr.features,
                 fr.unit, [*fr.notes, "frame from the blink and jaw morphs"])


def _shapes(scene: GltfScene, objects: list[tuple[SceneMesh, str]], frame: Frame
            ) -> tuple[Shapes, dict[str, str], list[dict]]:
    """Canonical shapes (object → head-frame deltas), their origins and the morph table."""
    shapes: Shapes = {}
    origin: dict[str, str] = {}
    rows: list[dict] = []

    def add(name: str, obj: str, d: np.ndarray, raw: str) -> None:
        shapes.setdefault(name, {})[obj] = d.astype(np.float32)
        origin.setdefault(name, raw)

    for m, oname in objects:
        hv = frame.apply(m.vertices)
        for k, raw in enumerate(m.morph_names):
            mt = classify(raw)
            d = frame.apply_vector(m.morph_deltas[k])
            if mt is not None and not np.any(np.abs(d) > 1e-7):  # moves nothing: no coverage
                rows.append({"mesh": oname, "morph": raw, "kind": "empty", "as": mt.name,
                             "how": "all-zero morph; the fallback field takes over"})
                continue
            row = {"mesh": oname, "morph": raw, "kind": mt.kind if mt else "unused",
                   "as": mt.name if mt else "", "how": mt.how if mt else ""}
            rows.append(row)
            if mt is None:
                continue
            name = mt.name
            if name[-2:] in ("_L", "_R"):
                x = _centroid(hv, d)[0]
                if (x < -0.3 and name[-1] == "L") or (x > 0.3 and name[-1] == "R"):
                    name = name[:-1] + ("R" if name[-1] == "L" else "L")
                    row["as"] = name
                    row["how"] += " (side by where it moves)"
            if name in shapes and oname in shapes[name]:
                row["kind"], row["how"] = "duplicate", f"{name} already from another morph"
                continue
            add(name, oname, d, raw)
    index = {id(m): i for i, m in enumerate(scene.meshes)}
    for expr, binds in scene.expressions.items():
        mt = classify(expr, expression=True)
        if mt is None or mt.name in shapes or not binds:
            continue
        for m, oname in objects:
            acc = None
            for mi, k, w in binds:
                if mi == index[id(m)] and m.morph_deltas is not None and k < len(m.morph_deltas):
                    d = w * frame.apply_vector(m.morph_deltas[k])
                    acc = d if acc is None else acc + d
            if acc is not None:
                add(mt.name, oname, acc, f"VRM {expr}")
        rows.append({"mesh": "(VRM)", "morph": expr, "kind": mt.kind, "as": mt.name,
                     "how": mt.how})
    return shapes, origin, rows


def _head_weight(scene: GltfScene, objects: list[tuple[SceneMesh, str]], head_node: int | None,
                 verts: list[np.ndarray], anchors: Mapping[str, np.ndarray]) -> np.ndarray:
    """Per vertex: how much it follows head motion (skin weight of the head bone and its
    children; 1 for meshes parented under the head; else the chin → neck-base fall-off)."""
    below = scene.descendants(head_node) if head_node is not None else set()
    top, bot = float(anchors["chin"][1]), float(anchors["neck_base"][1])
    out = []
    for (m, _), v in zip(objects, verts, strict=True):
        if head_node is not None and m.joints is not None:
            out.append(np.where(np.isin(m.joints, list(below)), m.weights, 0.0).sum(1)
                       / np.maximum(m.weights.sum(1), 1e-9))
        elif head_node is not None and m.node in below:
            out.append(np.ones(len(v)))
        else:
            t = np.clip((v[:, 1] - bot) / max(top - bot, 1e-6), 0.0, 1.0)
            out.append(t * t * (3 - 2 * t))
    return np.concatenate(out).astype(np.float32)


def load_gltf_head(path: str | Path) -> tuple[Head, AvatarRig]:
    """The head and AU rig of a glTF/GLB/VRM file (see the module doc)."""
    p = Path(path)
    scene = read_gltf(p)
    eye_bones = {b for b in (_bone(scene, "leftEye", r"^(left_?eye|eye_?l(eft)?|l_?eye)$"),
                             _bone(scene, "rightEye", r"^(right_?eye|eye_?r(ight)?|r_?eye)$"))
                 if b is not None}
    cats = [mesh_category(m, scene, eye_bones) for m in scene.meshes]
    face_ids = [i for i, c in enumerate(cats) if c == "face"]
    if not face_ids:
        raise DataError(f"{p}: every mesh looks like eyes or teeth; no face mesh to animate")
    matches = {i: {k: mt for k, n in enumerate(m.morph_names) if (mt := classify(n))
                   and m.morph_deltas is not None and np.any(m.morph_deltas[k] != 0)}
               for i, m in enumerate(scene.meshes)}
    face_i = max(face_ids, key=lambda i: (len(matches[i]), len(scene.meshes[i].vertices)))
    face = scene.meshes[face_i]
    frame = _frame(scene, face, matches[face_i], p)
    names: dict[str, int] = {}
    objects: list[tuple[SceneMesh, str]] = []
    for m in scene.meshes:
        base = re.sub(r"[^\w.-]", "_", m.name) or "mesh"
        names[base] = names.get(base, 0) + 1
        objects.append((m, base if names[base] == 1 else f"{base}.{names[base] - 1}"))
    skin_name = objects[face_i][1]
    verts = [frame.apply(m.vertices) for m, _ in objects]
    shapes, origin, rows = _shapes(scene, objects, frame)
    lm_idx, lm_pts = landmarks68(verts[face_i], frame.features, template_landmarks())
    eyes: dict[str, np.ndarray] = {}
    mesh_objs: list[MeshObject] = []
    materials: dict[str, object] = {}
    for (m, oname), v, cat in zip(objects, verts, cats, strict=True):
        parts = []
        for k, f in m.primitives:
            mat = scene.materials[k] if 0 <= k < len(scene.materials) else None
            key = render_material(mat.name if mat else m.name, cat)
            if mat is None:
                parts.append(Part(key, f))
                continue
            materials[mat.name] = mat
            tex, mode = part_texture(mat, key)
            parts.append(Part(key, f, tex, mode))
        pivot = None
        if cat == "eyes":
            pivot = sphere_fit(v)[0]
            side = "eye_L" if pivot[0] > 0 else "eye_R"
            eyes.setdefault(side, pivot)
        # glTF's v runs down the image, mimika's up; no UVs: the flat colour's 1×1 texture
        uvs = (np.zeros((len(v), 2)) if m.uvs is None else
               np.c_[m.uvs[:, 0], 1.0 - m.uvs[:, 1]])
        mesh_objs.append(MeshObject(oname, cat, v.astype(np.float32), tuple(parts), pivot, uvs))
    for side, pt in (("eye_L", frame.features.eye_L), ("eye_R", frame.features.eye_R)):
        eyes.setdefault(side, pt - [0.0, 0.0, 1.2])  # no eye mesh: behind the opening
    anchors = head_anchors(verts[face_i], lm_pts, eyes)
    head_node = _bone(scene, "head", r"^(head|.*_head)$")
    if head_node is not None:  # head AUs turn about the head bone
        anchors["neck_pivot"] = frame.apply(scene.node_position(head_node))
    weight = _head_weight(scene, objects, head_node, verts, anchors)
    head = Head(p.stem, tuple(mesh_objs), lm_idx, anchors, landmark_object=skin_name,
                description=f"glTF character from {p}",
                meta={"source": str(p), "frame": frame.describe(), "frame_obj": frame,
                      "morphs": rows, "materials": materials,
                      "parts": {o.name: [scene.materials[k].name if 0 <= k < len(
                          scene.materials) else "default" for k, _ in m.primitives]
                          for (m, _), o in zip(objects, mesh_objs, strict=True)},
                      "head_bone": scene.node_names[head_node] if head_node is not None
                      else None})
    rig, cover = build_rig(head, shapes, origin, head_weight=weight)
    head.meta["coverage"] = cover
    log.info("%s: %s; %d of its morphs used", p, frame.describe(),
             sum(r["kind"] not in ("unused", "duplicate", "empty") for r in rows))
    return head, rig
