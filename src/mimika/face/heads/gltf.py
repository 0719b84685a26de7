"""Any glTF / GLB / VRM character as a head: ``--head avatar.glb``.

Meshes become head objects with a role (:mod:`.roles`: skin, eyes, teeth, tongue, hair, brows,
lashes, beard, glasses, body, clothes — by name, else by shape), split where one mesh's
materials name several (:mod:`.gltf_parts`), brought into mimika's frame by the rule of
:mod:`mimika.face.rigging.frame`; raised arms are lowered through the skeleton
(:mod:`.gltf_pose`). Morph targets are matched to AUs by name (:mod:`mimika.face.morphs`:
FACS, ARKit-52, Oculus visemes; VRM expressions by :mod:`.vrm`) and AUs no morph covers fall
back to seed-002 fields carried onto the skin by its landmarks
(:mod:`mimika.face.rigging.assemble`) — brows, lashes and beard follow the skin, hair,
glasses, body and clothes do not take them. Eyes turn as eyeballs about their bone or
sphere centre: their own eye-look morphs, which would turn them a second time, are not used.
Head AUs follow the skin's head bone (and half its neck) where there is one. Each part
carries its material's base colour as a texture (the image times the colour factor, or a 1×1
image of the factor) with the glTF alpha mode; the renderer's material (skin, lips, sclera
…, chosen by name; ``toon`` for MToon and unlit) gives the shading. Normal maps are kept,
unused, in ``head.meta["materials"]``.
"""

from __future__ import annotations

import logging
import re
from collections.abc import Collection, Mapping
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from mimika.errors import DataError
from mimika.face.head import Head, MeshObject, Part, Texture
from mimika.face.heads.gltf_export import AvatarSource, Bind, Links
from mimika.face.heads.gltf_parts import (
    Piece,
    eye_pivot,
    mesh_role,
    pieces,
    skin_fields,
    split_sides,
)
from mimika.face.heads.gltf_pose import lower_arms
from mimika.face.heads.gltf_scene import GltfScene, SceneMaterial, SceneMesh, read_gltf
from mimika.face.heads.roles import Role, bone_pattern, geometry_role, name_role
from mimika.face.heads.roles import category as role_category
from mimika.face.heads.roles import table as role_table
from mimika.face.heads.vrm import expression_shape, look_au
from mimika.face.heads.vrm import table as vrm_table
from mimika.face.morphs import MorphMatch, classify
from mimika.face.rigging.assemble import AvatarRig, build_rig, head_anchors
from mimika.face.rigging.features import find_face
from mimika.face.rigging.frame import Frame, detect_frame, frame_from_points
from mimika.face.rigging.generate import Shapes, template_landmarks
from mimika.face.rigging.landmarks import landmarks68
from mimika.face.rigs.blendshape import load_table

log = logging.getLogger(__name__)

__all__ = ["EXTENSIONS", "load_gltf_head", "mesh_category", "render_material"]

EXTENSIONS = (".glb", ".gltf", ".vrm")
#: the eye AUs (turns)
EYE_AUS = ("AU61", "AU62", "AU63", "AU64")
#: a face mesh reaching this far below the chin is a body too (cm)
BODY_BELOW_CHIN_CM = 25.0
#: renderer material (render/data/materials.json) by words in a glTF material/mesh name
_RENDER_KEYS = (("cornea", "cornea"), ("pupil", "pupil"), ("iris", "iris"),
                ("sclera", "sclera"), ("eyewhite", "sclera"), ("lash", "lash"),
                ("brow", "brow"), ("hair", "hair"), ("lip", "lips"), ("tongue", "tongue"),
                ("gum", "gums"), ("teeth", "teeth"), ("tooth", "teeth"), ("eye", "sclera"),
                ("mouth", "mouth"), ("skin", "skin"), ("head", "skin"), ("face", "skin"),
                ("body", "skin"))


#: renderer material by role (or category) when the material's name says nothing
_ROLE_KEYS = {"eyes": "sclera", "teeth": "teeth", "tongue": "tongue", "hair": "hair",
              "beard": "hair", "brows": "brow", "lashes": "lash", "glasses": "cloth",
              "clothes": "cloth", "body": "skin_body"}


def render_material(name: str, category: str, toon: bool = False) -> str:
    """The renderer's material (its shading: skin, lips, sclera …) for a glTF material
    ``name``: ``toon`` for MToon/unlit ones, else by the words in it, else by the object's
    role or category (``category``: skin for face objects, sclera for eyes …)."""
    if toon:
        return "toon"
    low = name.lower().replace("_", "").replace(" ", "")
    for word, key in _RENDER_KEYS:
        if word in low:
            return key
    return _ROLE_KEYS.get(category, "skin")


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


def _bone(scene: GltfScene, kind: str) -> int | None:
    """The node of humanoid bone ``kind`` (head, neck, eye_L, eye_R): VRM's, else by name."""
    vrm = role_table()["vrm_bones"][kind]
    if vrm in scene.bones:
        return scene.bones[vrm]
    rx = bone_pattern(kind)
    hits = [i for i, n in enumerate(scene.node_names) if rx.search(re.split(r"[.:|]", n)[-1])]
    # a skin's joint first, then a node that holds no mesh (Ready Player Me's mesh node
    # Wolf3D_Head is named like a head bone)
    joints = {int(j) for m in scene.meshes if m.bind is not None for j in m.bind.joint_nodes}
    meshes = {m.node for m in scene.meshes}
    return next((i for i in hits if i in joints), next((i for i in hits if i not in meshes),
                                                       hits[0] if hits else None))


def mesh_category(m: SceneMesh, scene: GltfScene, eye_bones: set[int]) -> str:
    """eyes, teeth (teeth, tongue) or face (every other role) for a whole mesh, by its eye
    bone, names and materials (:mod:`.roles`)."""
    role = mesh_role(m, scene, eye_bones) or name_role(
        *(scene.materials[k].name for k, _ in m.primitives if 0 <= k < len(scene.materials)))
    cat = role_category(role.role) if role else "face"
    return cat if cat in ("eyes", "teeth") else "face"


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


def _side_checked(name: str, hv: np.ndarray, d: np.ndarray, row: dict) -> str:
    """``name`` with its side swapped when it moves the other side of the face."""
    if name[-2:] in ("_L", "_R"):
        x = _centroid(hv, d)[0]
        if (x < -0.3 and name[-1] == "L") or (x > 0.3 and name[-1] == "R"):
            name = name[:-1] + ("R" if name[-1] == "L" else "L")
            row["as"] = name
            row["how"] += " (side by where it moves)"
    return name


def _shapes(scene: GltfScene, parts: list[Piece], frame: Frame
            ) -> tuple[Shapes, dict[str, str], list[dict], Links]:
    """Canonical shapes (object → head-frame deltas), their origins, the morph table and
    the file's morphs each shape is made of, per object."""
    shapes: Shapes = {}
    origin: dict[str, str] = {}
    rows: list[dict] = []
    links: Links = {}

    def add(name: str, obj: str, d: np.ndarray, raw: str, binds: list[Bind]) -> None:
        shapes.setdefault(name, {})[obj] = d.astype(np.float32)
        origin.setdefault(name, raw)
        links.setdefault(name, {})[obj] = binds

    moves = {i: np.any(np.abs(m.morph_deltas) > 0, axis=(1, 2)) for i, m in
             enumerate(scene.meshes) if m.morph_deltas is not None}
    for pc in parts:
        m = pc.mesh
        hv = frame.apply(m.vertices)
        for k, raw in enumerate(m.morph_names):
            mt = classify(raw)
            d = frame.apply_vector(m.morph_deltas[k])
            if mt is not None and not np.any(np.abs(d) > 1e-7):  # moves nothing: no coverage
                if not moves[pc.src][k]:  # (split pieces: said once, for the whole mesh)
                    rows.append({"mesh": pc.name, "morph": raw, "kind": "empty",
                                 "as": mt.name,
                                 "how": "all-zero morph; the fallback field takes over"})
                continue
            row = {"mesh": pc.name, "morph": raw, "kind": mt.kind if mt else "unused",
                   "as": mt.name if mt else "", "how": mt.how if mt else ""}
            rows.append(row)
            if mt is None:
                continue
            name = _side_checked(mt.name, hv, d, row)
            if name in shapes and pc.name in shapes[name]:
                row["kind"], row["how"] = "duplicate", f"{name} already from another morph"
                continue
            add(name, pc.name, d, raw, [(pc.src, k, 1.0)])
    for expr, binds in scene.expressions.items():
        got = expression_shape(expr)
        if got is None or got[1] in shapes or not binds:
            rows.append({"mesh": "(VRM)", "morph": expr, "kind": "unused" if got is None
                         else "duplicate", "as": got[1] if got else "",
                         "how": "not an AU" if got is None else
                         ("binds nothing" if not binds else f"{got[1]} already from a morph")})
            continue
        kind, name = got
        gain = scene.vrm_look.get(look_au(name) or "", 1.0) if \
            scene.vrm_look_type == "expression" else 1.0
        for pc in parts:
            m = pc.mesh
            acc = None
            used: list[Bind] = []
            for mi, k, w in binds:
                if mi == pc.src and m.morph_deltas is not None and 0 <= k < len(m.morph_deltas):
                    d = gain * w * frame.apply_vector(m.morph_deltas[k])
                    acc = d if acc is None else acc + d
                    used.append((mi, k, gain * w))
            if acc is not None and np.any(np.abs(acc) > 1e-7):
                add(name, pc.name, acc, f"VRM {expr}", used)
        rows.append({"mesh": "(VRM)", "morph": expr, "kind": kind, "as": name,
                     "how": "VRM expression" + (f" ×{gain:.2g} (lookAt range)"
                                                if gain != 1.0 else "")})
    return shapes, origin, rows, links


def _eye_aus_on_eyes(shapes: Shapes, origin: dict[str, str], rows: list[dict],
                     turning: Collection[str]) -> None:
    """Drop the eye AUs' shapes (eyeLook…, VRM look…) from eyes that turn: the turn already
    moves them (Ready Player Me's eye meshes carry eyeLook morphs that would turn them again),
    so pose, render and the exported file turn them alike; shapes left empty are dropped."""
    base = load_table()["aus"]
    names = {n for code in EYE_AUS for n in base[code].get("shapes", {})}
    names |= {n for code in EYE_AUS for alt in vrm_table()["aus"].get(code, []) for n in alt}
    names |= {n + s for n in names for s in ("_L", "_R")}
    for n in names & set(shapes):
        hit = [o for o in shapes[n] if o in turning]
        for o in hit:
            del shapes[n][o]
        if hit:
            for r in rows:
                if r["as"] == n and (r["mesh"] in hit or r["mesh"] == "(VRM)"):
                    r["how"] += "; on the eyes: they turn by rotation, not by this morph"
        if not shapes[n]:
            del shapes[n]
            origin.pop(n, None)
            for r in rows:
                if r["as"] == n and r["kind"] not in ("empty", "unused", "duplicate"):
                    r["kind"] = "eye turn"


def _head_weight(scene: GltfScene, parts: list[Piece], verts: list[np.ndarray],
                 bones: Mapping[str, int | None], anchors: Mapping[str, np.ndarray]
                 ) -> np.ndarray:
    """Per vertex: how much it follows head motion (skin weight of the head bone and its
    children; 1 for meshes under the head; else the chin → neck-base fall-off)."""
    head_node = bones["head"]
    below = scene.descendants(head_node) if head_node is not None else set()
    top, bot = float(anchors["chin"][1]), float(anchors["neck_base"][1])
    out = []
    for pc, v in zip(parts, verts, strict=True):
        m = pc.mesh
        if head_node is not None and m.joints is not None:
            w = np.where(np.isin(m.joints, list(below)), m.weights, 0.0).sum(1)
            out.append(w / np.maximum(m.weights.sum(1), 1e-9))
        elif head_node is not None and m.node in below:
            out.append(np.ones(len(v)))
        else:
            t = np.clip((v[:, 1] - bot) / max(top - bot, 1e-6), 0.0, 1.0)
            out.append(t * t * (3 - 2 * t))
    return np.concatenate(out).astype(np.float32)


def _face_piece(parts: list[Piece], path: Path) -> int:
    """The piece that holds the face: the skin with the most AU morphs (then vertices); a
    file that names no skin: among the pieces named nothing or body (Mixamo's "Body")."""
    def score(i: int) -> tuple[int, int]:
        m = parts[i].mesh
        n = sum(1 for k, name in enumerate(m.morph_names) if classify(name) and
                np.any(m.morph_deltas[k] != 0))
        return n, len(m.vertices)

    for ok in (("skin",), (None, "body")):
        cand = [i for i, pc in enumerate(parts) if (pc.role.role if pc.role else None) in ok]
        if cand:
            return max(cand, key=score)
    raise DataError(f"{path}: every mesh is named as eyes, teeth, hair, glasses or clothes; "
                    "no face mesh to animate (name the face mesh 'Head' or 'Face')")


def _objects(scene: GltfScene, parts: list[Piece], verts: list[np.ndarray],
             pivots: Mapping[int, np.ndarray | None]) -> tuple[list[MeshObject], dict]:
    """The head objects of ``parts`` (head-frame vertices ``verts``) and their materials."""
    objs, materials = [], {}
    for i, (pc, v) in enumerate(zip(parts, verts, strict=True)):
        m, cat = pc.mesh, role_category(pc.role.role)
        out = []
        for k, f in m.primitives:
            mat = scene.materials[k] if 0 <= k < len(scene.materials) else None
            key = render_material(mat.name if mat else m.name, pc.role.role,
                                  bool(mat and mat.toon))
            if mat is None:
                out.append(Part(key, f))
                continue
            materials[mat.name] = mat
            tex, mode = part_texture(mat, key)
            out.append(Part(key, f, tex, mode))
        # glTF's v runs down the image, mimika's up; no UVs: the flat colour's 1×1 texture
        uvs = (np.zeros((len(v), 2)) if m.uvs is None else
               np.c_[m.uvs[:, 0], 1.0 - m.uvs[:, 1]])
        objs.append(MeshObject(pc.name, cat, v.astype(np.float32), tuple(out), pivots.get(i),
                               uvs))
    return objs, materials


def load_gltf_head(path: str | Path) -> tuple[Head, AvatarRig]:
    """The head and AU rig of a glTF/GLB/VRM file (see the module doc)."""
    p = Path(path)
    scene = read_gltf(p)
    bones = {k: _bone(scene, k) for k in ("head", "neck", "eye_L", "eye_R")}
    eye_bones = {b for b in (bones["eye_L"], bones["eye_R"]) if b is not None}
    parts = pieces(scene, eye_bones)
    face_i = _face_piece(parts, p)
    face = parts[face_i]
    face.role = Role("skin", face.role.how if face.role and face.role.role == "skin"
                     else "holds the face")
    matches = {k: mt for k, n in enumerate(face.mesh.morph_names) if (mt := classify(n))
               and np.any(face.mesh.morph_deltas[k] != 0)}
    frame = _frame(scene, face.mesh, matches, p)
    lm_idx, lm_pts = landmarks68(frame.apply(face.mesh.vertices), frame.features,
                                 template_landmarks())
    rest_world = scene.node_world  # lower_arms replaces it
    notes = lower_arms(scene, [pc.mesh for pc in parts], frame.apply, frame.rotation,
                       float(lm_pts[27:31, 0].mean()))
    verts = [frame.apply(pc.mesh.vertices) for pc in parts]
    # the mouth at the lips (inner lip landmarks): closed lips leave no opening in front,
    # and the cavity found behind them lies deeper than the teeth
    feats = {"eye_L": frame.features.eye_L, "eye_R": frame.features.eye_R,
             "mouth": lm_pts[60:68].mean(0), "chin": lm_pts[8]}
    skin_v = verts[face_i]
    above = skin_v[skin_v[:, 1] > lm_pts[8, 1]]
    tree = cKDTree(skin_v)
    for pc, v in zip(parts, verts, strict=True):
        if pc.role is None:
            pc.role = geometry_role(v, tree.query(v)[0], feats, (above.min(0), above.max(0)))
    # eyes: one piece per eye, turning about its bone or sphere centre
    bone_at = {b: frame.apply(scene.node_position(b)) for b in eye_bones}
    split: list[Piece] = []
    for pc, v in zip(parts, verts, strict=True):
        split += split_sides(pc, v[:, 0]) if pc.role.role == "eyes" else [pc]
    skin_name = face.name
    parts = split
    face_i = next(i for i, pc in enumerate(parts) if pc.name == skin_name)
    verts = [frame.apply(pc.mesh.vertices) for pc in parts]
    expression_gaze = scene.vrm_version is not None and scene.vrm_look_type == "expression"
    pivots = {i: eye_pivot(pc, v, scene, bone_at) for i, (pc, v) in
              enumerate(zip(parts, verts, strict=True))
              if pc.role.role == "eyes" and not expression_gaze}
    mesh_objs, materials = _objects(scene, parts, verts, pivots)
    shapes, origin, rows, links = _shapes(scene, parts, frame)
    _eye_aus_on_eyes(shapes, origin, rows, {parts[i].name for i, c in pivots.items()
                                            if c is not None})
    eyes: dict[str, np.ndarray] = {}
    for c in (c for c in pivots.values() if c is not None):
        eyes.setdefault("eye_L" if c[0] > 0 else "eye_R", c)
    for side, pt in (("eye_L", frame.features.eye_L), ("eye_R", frame.features.eye_R)):
        eyes.setdefault(side, pt - [0.0, 0.0, 1.2])  # no eye mesh: behind the opening
    anchors = head_anchors(verts[face_i], lm_pts, eyes)
    if bones["head"] is not None:  # head AUs turn about the head bone
        anchors["neck_pivot"] = frame.apply(scene.node_position(bones["head"]))
    if bones["neck"] is not None:  # the neck bone's root is where the neck starts to bend
        neck = frame.apply(scene.node_position(bones["neck"]))
        if neck[1] < anchors["chin"][1]:
            anchors["neck_base"] = neck
    weight = _head_weight(scene, parts, verts, bones, anchors)
    roles = {pc.name: pc.role.role for pc in parts}
    body = any(role_category(r) == "body" for r in roles.values()) or bool(
        verts[face_i][:, 1].min() < lm_pts[8, 1] - BODY_BELOW_CHIN_CM)
    head = Head(p.stem, tuple(mesh_objs), lm_idx, anchors, landmark_object=skin_name,
                description=f"glTF character from {p}",
                meta={"source": str(p), "frame": frame.describe(), "frame_obj": frame,
                      "morphs": rows, "materials": materials, "roles": roles,
                      "role_how": {pc.name: pc.role.how for pc in parts}, "body": body,
                      "pose": notes,
                      "parts": {o.name: [scene.materials[k].name if 0 <= k < len(
                          scene.materials) else "default" for k, _ in pc.mesh.primitives]
                          for pc, o in zip(parts, mesh_objs, strict=True)},
                      "head_bone": scene.node_names[bones["head"]]
                      if bones["head"] is not None else None})
    eye_turn = scene.vrm_look if scene.vrm_version is not None and not expression_gaze \
        else None
    rig, cover = build_rig(head, shapes, origin, head_weight=weight,
                           generator=skin_fields(roles), eye_turn=eye_turn)
    if not any(c is not None for c in pivots.values()):  # no eye object turns
        for code in (c for c in EYE_AUS if c in cover):
            src, how = cover[code]
            cover[code] = (src, how.replace("eye rotation + ", "").replace(
                "eye rotation", "no eye object turns"))
    head.meta["coverage"] = cover
    head.meta["gltf"] = AvatarSource(
        p, scene, rest_world, frame, {pc.name: (pc.src, pc.mesh.index) for pc in parts},
        {n: [b for obj, bs in per.items() if obj in shapes.get(n, {}) for b in bs]
         for n, per in links.items()}, bones)
    log.info("%s: %s; %d of its morphs used", p, frame.describe(),
             sum(r["kind"] not in ("unused", "duplicate", "empty", "eye turn") for r in rows))
    return head, rig
