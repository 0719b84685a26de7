"""An avatar's arms lowered from its A or T pose through its skeleton, so a head-and-shoulders
shot shows shoulders and not the arms held out as bars.

Each upper-arm joint (VRM humanoid ``leftUpperArm``/``rightUpperArm``, else a joint named as
``avatar_roles.json``'s ``bones.upper_arm`` says: Mixamo/Ready Player Me/Avaturn ``LeftArm``,
Character Creator ``CC_Base_L_Upperarm``, MakeHuman ``upperarm01.L`` …) turns about its
own position, with everything below it, until the arm points :data:`HANG_DEG` from straight
down and outward; the skinned meshes are placed again through their joints (linear-blend
skinning with the file's bind matrices), morph deltas with them.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from mimika.face.heads.gltf_scene import GltfScene, SceneMesh
from mimika.face.heads.roles import bone_pattern

__all__ = ["HANG_DEG", "RAISED_DEG", "lower_arms", "upper_arms"]

#: how far from straight down a lowered arm points, outward (degrees)
HANG_DEG = 12.0
#: arms nearer than this to hanging (degrees from straight down) are left as they are
RAISED_DEG = 25.0


def _bare(name: str) -> str:
    return name.replace("mixamorig:", "").split("|")[-1].split(":")[-1]


def upper_arms(scene: GltfScene) -> list[int]:
    """The upper-arm joints (VRM humanoid first, else by name): at most one per side."""
    vrm = [scene.bones[b] for b in ("leftUpperArm", "rightUpperArm") if b in scene.bones]
    if vrm:
        return vrm
    rx = bone_pattern("upper_arm")
    return [i for i, n in enumerate(scene.node_names) if rx.search(_bare(n))][:2]


def _elbow(scene: GltfScene, joint: int) -> int | None:
    """The child of ``joint`` farthest from it (the elbow), or None."""
    kids = np.flatnonzero(scene.node_parent == joint)
    if not len(kids):
        return None
    d = np.linalg.norm(scene.node_world[kids, :3, 3] - scene.node_world[joint, :3, 3], axis=1)
    return int(kids[np.argmax(d)]) if d.max() > 0 else None


def _turn(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rotation matrix (3, 3) of ``angle`` radians about unit ``axis``."""
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * (k @ k)


def lower_arms(scene: GltfScene, meshes: Sequence[SceneMesh],
               to_head: Callable[[np.ndarray], np.ndarray], rotation: np.ndarray,
               midline_x: float) -> list[str]:
    """Lower raised arms in place (``meshes`` placed again); returns notes ("lowered
    'LeftArm' by 78°"). ``to_head`` maps file points to the head frame, whose rotation part
    is ``rotation`` (3, 3); ``midline_x``: the face's middle in the head frame."""
    rest = scene.node_world
    world = rest.copy()
    notes = []
    down = np.array([0.0, -1.0, 0.0])
    for j in upper_arms(scene):
        e = _elbow(scene, j)
        if e is None:
            continue
        p, q = to_head(rest[[j, e], :3, 3])
        arm = q - p
        if np.linalg.norm(arm) <= 0:
            continue
        arm /= np.linalg.norm(arm)
        side = 1.0 if p[0] >= midline_x else -1.0
        hang = np.radians(HANG_DEG)
        goal = np.array([side * math.sin(hang), -math.cos(hang), 0.0])
        if np.degrees(math.acos(np.clip(arm @ down, -1, 1))) < RAISED_DEG:
            continue
        axis = np.cross(arm, goal)
        angle = math.acos(np.clip(arm @ goal, -1, 1))
        if np.linalg.norm(axis) < 1e-9 or angle < 1e-6:
            continue
        r_head = _turn(axis / np.linalg.norm(axis), angle)
        r_file = rotation.T @ r_head @ rotation
        delta = np.eye(4)
        delta[:3, :3] = r_file
        delta[:3, 3] = rest[j, :3, 3] - r_file @ rest[j, :3, 3]
        below = sorted(scene.descendants(j))
        world[below] = delta @ world[below]
        notes.append(f"lowered {scene.node_names[j]!r} by {np.degrees(angle):.0f}°")
    if notes:
        moved = set(np.flatnonzero(np.any(np.abs(world - rest) > 1e-12, axis=(1, 2))))
        for m in meshes:
            if (m.bind is not None and moved & set(m.bind.joint_nodes.tolist())) or \
                    m.node in moved:
                m.posed(rest, world)
        scene.node_world = world
    return notes
