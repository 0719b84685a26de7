"""A blendshape rig on a skinned body: face shapes and eye turns in bind space, then linear
blend skinning over a skeleton for the head, neck, spine and shoulders (and a rest pose).

Head AUs (51–58) become rotations of the neck and head bones, shared out by ``head_share``
(the neck bends, the collar and long hair follow through their skin weights); the rest pose
(for MakeHuman characters: arms lowered from the modelling A-pose) is applied to every frame.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from mimika.face.head import Head
from mimika.face.rigs.blendshape import BlendshapeRig, ShapeSet


@dataclass(frozen=True)
class Skinning:
    """Bones (names, rest ``heads`` (B, 3) in cm, ``parents`` (B,), −1 for the root), skin
    ``weights`` per object (n_obj, B) CSR, the ``rest_pose`` (bone → rotation vector, rad)
    and how head rotations are shared among bones (``head_share``: bone → fraction)."""

    names: tuple[str, ...]
    heads: np.ndarray
    parents: np.ndarray
    weights: Mapping[str, sp.csr_matrix]
    rest_pose: Mapping[str, np.ndarray]
    head_share: Mapping[str, float]
    #: body channel → {bone: rotation vector (rad) at value 1}
    body: Mapping[str, Mapping[str, Sequence[float]]] = field(default_factory=dict)
    translate_bone: str = "neck03"


def _rotations(rv: np.ndarray) -> np.ndarray:
    """Rotation vectors (T, 3) → matrices (T, 3, 3)."""
    th = np.linalg.norm(rv, axis=1)
    k = rv / np.where(th > 1e-12, th, 1.0)[:, None]
    km = np.zeros((len(rv), 3, 3))
    km[:, 0, 1], km[:, 0, 2], km[:, 1, 2] = -k[:, 2], k[:, 1], -k[:, 0]
    km[:, 1, 0], km[:, 2, 0], km[:, 2, 1] = k[:, 2], -k[:, 1], k[:, 0]
    s, c = np.sin(th)[:, None, None], (1 - np.cos(th))[:, None, None]
    return np.eye(3)[None] + s * km + c * (km @ km)


class SkinnedRig(BlendshapeRig):
    """:class:`BlendshapeRig` over ``bind_head`` (unposed) whose motion is skinning.

    ``head`` is what callers see at rest (the bind head in its rest pose); ``deform`` returns
    posed positions of ``head``'s objects.
    """

    def __init__(self, head: Head, bind_head: Head, shapes: ShapeSet, table: Mapping,
                 skinning: Skinning) -> None:
        super().__init__(bind_head, shapes, table)
        self.head = head
        self.bind_head = bind_head
        self.skinning = skinning
        b = len(skinning.names)
        parts = []
        for o in bind_head.objects:
            w = skinning.weights[o.name]
            if w.shape != (o.n_vertices, b):
                raise ValueError(f"skin weights of {o.name!r} have shape {w.shape}, "
                                 f"expected ({o.n_vertices}, {b})")
            parts.append(w)
        self._w = sp.csr_matrix(sp.vstack(parts), dtype=np.float64)
        self._rest_local = {skinning.names.index(k): np.asarray(v, float)
                            for k, v in skinning.rest_pose.items()}
        self._share = {skinning.names.index(k): float(v) for k, v in skinning.head_share.items()}
        self._t_bone = skinning.names.index(skinning.translate_bone)
        self.body_channels = tuple(skinning.body)
        self._supported = (*self._supported, *self.body_channels)
        #: (B_channels, bones, 3): rotation vectors per body channel at value 1
        self._body_rv = np.zeros((len(self.body_channels), b, 3))
        for j, rot in enumerate(skinning.body.values()):
            for bone, rv in rot.items():
                self._body_rv[j, skinning.names.index(bone)] = rv

    def local_rotations(self, head_rv: np.ndarray, body: np.ndarray | None = None
                        ) -> np.ndarray:
        """Each bone's rotation vector about its head (T, B, 3): rest pose + its share of the
        head rotations (T, 3) + body channel values (T, len(body_channels))."""
        sk = self.skinning
        out = np.zeros((len(head_rv), len(sk.names), 3))
        for i, rv in self._rest_local.items():
            out[:, i] += rv
        for i, share in self._share.items():
            out[:, i] += share * np.asarray(head_rv, float)
        if body is not None and body.size:
            out += np.einsum("tc,cbk->tbk", body, self._body_rv)
        return out

    def bone_transforms(self, head_rv: np.ndarray, head_tr: np.ndarray,
                        body: np.ndarray | None = None) -> np.ndarray:
        """World transforms (T, B, 3, 4) for head rotations (T, 3), translations (T, 3) and
        body channel values (T, len(body_channels))."""
        sk = self.skinning
        t_all = len(head_rv)
        rvs = self.local_rotations(head_rv, body)
        out = np.zeros((t_all, len(sk.names), 3, 4))
        for i in range(len(sk.names)):
            rot = _rotations(rvs[:, i])
            h = sk.heads[i]
            local = np.zeros((t_all, 3, 4))
            local[:, :, :3] = rot
            local[:, :, 3] = h - rot @ h
            if i == self._t_bone:
                local[:, :, 3] += head_tr
            j = sk.parents[i]
            if j < 0:
                out[:, i] = local
            else:
                pa = out[:, j]
                out[:, i, :, :3] = pa[:, :, :3] @ local[:, :, :3]
                out[:, i, :, 3] = (pa[:, :, :3] @ local[:, :, 3:4])[..., 0] + pa[:, :, 3]
        return out

    def _move(self, buf: np.ndarray, rv: np.ndarray, tr: np.ndarray,
              body: np.ndarray | None = None) -> None:
        tf = self.bone_transforms(np.asarray(rv, float), np.asarray(tr, float), body)
        w = self._w
        for t in range(len(buf)):
            m = (w @ tf[t].reshape(len(self.skinning.names), 12)).reshape(-1, 3, 4)
            p = buf[t].astype(np.float64)
            buf[t] = (np.einsum("nij,nj->ni", m[:, :, :3], p) + m[:, :, 3]).astype(np.float32)
