"""The objects of a glTF avatar: its meshes split where their primitives have different roles
(VRoid's face mesh holds skin, eyes, mouth, brows and lashes), each with a role
(:mod:`.roles`), eye pivots, and the fallback fields evaluated on the skin only."""

from __future__ import annotations

import re
from collections.abc import Callable, Collection, Mapping
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from mimika.face.head import Head
from mimika.face.heads.gltf_scene import GltfScene, SceneMesh
from mimika.face.heads.roles import Role, motion, name_role, split_groups
from mimika.face.rigging.features import sphere_fit
from mimika.face.rigging.generate import Shapes, generate_shapes

__all__ = ["Piece", "attach_to_skin", "eye_pivot", "pieces", "skin_fields", "split_sides"]

#: a vertex of a brow, lash or beard follows its nearest skin vertex fully within NEAR cm,
#: not at all beyond FAR cm
NEAR, FAR = 1.0, 3.0
#: a round eye piece: sphere radius (cm) and the largest rms distance from it (cm)
EYE_RADIUS, EYE_RMS = (0.7, 2.0), 0.15


@dataclass
class Piece:
    """One head object to be: its mesh (file units), the scene mesh it came from, its name,
    role (None until found) and whether it is that whole mesh."""

    mesh: SceneMesh
    src: int
    name: str
    role: Role | None
    whole: bool = True


def _eye_weight(m: SceneMesh, eye_bones: Collection[int]) -> np.ndarray | None:
    """Per vertex, the skin weight of the eye bones (None without a skin)."""
    if m.joints is None or not eye_bones:
        return None
    return np.where(np.isin(m.joints, list(eye_bones)), m.weights, 0.0).sum(1)


def mesh_role(m: SceneMesh, scene: GltfScene, eye_bones: Collection[int]) -> Role | None:
    """The role of a whole mesh: eyes when its skin holds it to an eye bone, else by its node
    and mesh names."""
    w = _eye_weight(m, eye_bones)
    if w is not None and np.mean(w > 0.5) > 0.9:
        return Role("eyes", "skinned to an eye bone")
    return name_role(m.name, m.mesh_name)


def pieces(scene: GltfScene, eye_bones: Collection[int]) -> list[Piece]:
    """Every scene mesh as one piece, or one per role where its primitives' materials name
    different roles (the skin's part keeps the mesh's name)."""
    out: list[Piece] = []
    names: dict[str, int] = {}

    def unique(base: str) -> str:
        base = re.sub(r"[^\w.-]", "_", base) or "mesh"
        names[base] = names.get(base, 0) + 1
        return base if names[base] == 1 else f"{base}.{names[base] - 1}"

    for i, m in enumerate(scene.meshes):
        mesh_r = mesh_role(m, scene, eye_bones)
        prim = [name_role(scene.materials[k].name, what="material")
                if 0 <= k < len(scene.materials) else None for k, _ in m.primitives]
        if mesh_r is not None and mesh_r.how.startswith("skinned"):
            prim = [None] * len(prim)
        roles = [(r or mesh_r) for r in prim]
        groups = split_groups(r.role if r else None for r in roles)
        if len(groups) == 1:
            role = next((r for r in roles if r is not None), None)
            if role is not None and role.role == "body" and "skin" in groups:
                role = Role("skin", role.how)
            out.append(Piece(m, i, unique(m.name), role))
            continue
        main = "skin" if "skin" in groups else max(groups, key=lambda g: len(groups[g]))
        for g, ids in groups.items():
            how = next((roles[k].how for k in ids if roles[k] is not None), "")
            name = m.name if g == main else f"{m.name}.{g or 'part'}"
            out.append(Piece(m.subset([m.primitives[k] for k in ids], name), i, unique(name),
                             Role(g, how) if g else None, whole=False))
    return out


def split_sides(p: Piece, x: np.ndarray) -> list[Piece]:
    """An eye piece holding both eyes (x: its vertices' head-frame x, cm) as one piece per
    side, ``<name>.L`` and ``<name>.R``, by where each triangle lies."""
    m = p.mesh
    sides = [(k, x[f].mean(1) > 0, f) for k, f in m.primitives]
    if all(s.all() for _, s, _ in sides) or not any(s.any() for _, s, _ in sides):
        return [p]
    return [Piece(m.subset([(k, f[s == left]) for k, s, f in sides if (s == left).any()],
                           f"{m.name}.{side}"), p.src, f"{p.name}.{side}", p.role, p.whole)
            for side, left in (("L", True), ("R", False))]


def eye_pivot(p: Piece, v: np.ndarray, scene: GltfScene, eye_bones: Mapping[int, np.ndarray]
              ) -> np.ndarray | None:
    """Where an eye piece turns (head frame, cm): its eye bone when the skin holds it there
    (or it hangs under the bone), else the centre of the sphere it is. None — it does not
    turn — for a part of a face mesh that no eye bone holds in a file with eye bones
    (VRoid's eye whites) and for a piece that is no sphere (a flat iris without a bone)."""
    m = p.mesh
    for b, pos in eye_bones.items():
        held = m.joints is not None and np.mean(
            np.where(m.joints == b, m.weights, 0.0).sum(1) > 0.5) > 0.5
        if held or m.node in scene.descendants(b):
            return pos
    if eye_bones and not p.whole:
        return None
    c, r = sphere_fit(v)
    rms = float(np.sqrt(np.mean((np.linalg.norm(v - c, axis=1) - r) ** 2)))
    return c if EYE_RADIUS[0] <= r <= EYE_RADIUS[1] and rms <= EYE_RMS else None


def attach_to_skin(head: Head, skin: Collection[str], followers: Collection[str]
                   ) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """For each follower object, per vertex: the skin object (index into ``skin``), the skin
    vertex it follows and how much (1 within :data:`NEAR` cm, 0 beyond :data:`FAR`)."""
    skin = list(skin)
    pts = np.concatenate([head[s].vertices for s in skin])
    owner = np.concatenate([np.full(head[s].n_vertices, i) for i, s in enumerate(skin)])
    start = np.concatenate([[0], np.cumsum([head[s].n_vertices for s in skin])])
    tree = cKDTree(pts)
    out = {}
    for name in followers:
        d, k = tree.query(head[name].vertices)
        w = np.clip((FAR - d) / (FAR - NEAR), 0.0, 1.0)
        out[name] = (owner[k], k - start[owner[k]], w.astype(np.float32))
    return out


def skin_fields(roles: Mapping[str, str]) -> Callable[[Head, list[str]], Shapes]:
    """A shape generator for :func:`~mimika.face.rigging.assemble.build_rig`: the fields
    evaluated on the objects whose role takes them (skin, teeth, tongue), brows, lashes and
    beard following the nearest skin; hair, glasses, eyes, body and clothes left still."""

    def gen(head: Head, names: list[str]) -> Shapes:
        on = [o for o in head.objects if motion(roles[o.name]) == "fields"]
        sub = Head(head.name, tuple(on), head.landmarks, head.anchors,
                   landmark_object=head.landmark_object)
        shapes = generate_shapes(sub, names)
        skin = [o.name for o in on if roles[o.name] == "skin"]
        follow = attach_to_skin(head, skin, [o.name for o in head.objects
                                             if motion(roles[o.name]) == "skin"])
        for per in shapes.values():
            for name, (own, k, w) in follow.items():
                d = np.zeros((head[name].n_vertices, 3), np.float32)
                for i, s in enumerate(skin):
                    if s in per:
                        sel = own == i
                        d[sel] = per[s][k[sel]] * w[sel, None]
                if np.abs(d).max(initial=0) > 1e-6:
                    per[name] = d
        return shapes

    return gen
