"""Geometric checks of a dressed character: cloth layers that pass through each other (a collar
through its jacket looks torn and jagged), skin through clothes, over-stretched or flipped cloth
triangles.

Everything works on plain arrays (positions (N, 3), triangles (F, 3)), so the same checks run
on a piece being built, on a posed head, or on any frame of a rig. No OpenGL here: the pixel
checks of a rendered frame built on these live in the render layer (``render/artefacts.py``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree


def weld_key(vertices: np.ndarray, decimals: int = 5) -> np.ndarray:
    """Per vertex, the index of its position among the unique positions (a mesh split at UV
    seams has several vertices per position)."""
    _, key = np.unique(np.round(np.asarray(vertices, np.float64), decimals), axis=0,
                       return_inverse=True)
    return key.ravel()


def _segments_hit(p0: np.ndarray, p1: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """Whether each segment p0→p1 (K, 3) crosses the matching triangle (K, 3, 3)."""
    d = p1 - p0
    a = tri[:, 0]
    e1, e2 = tri[:, 1] - a, tri[:, 2] - a
    pv = np.cross(d, e2)
    det = np.einsum("ij,ij->i", e1, pv)
    ok = np.abs(det) > 1e-14
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    s = p0 - a
    u = np.einsum("ij,ij->i", s, pv) * inv
    q = np.cross(s, e1)
    v = np.einsum("ij,ij->i", d, q) * inv
    t = np.einsum("ij,ij->i", e2, q) * inv
    return ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t >= 0) & (t <= 1)


def candidate_pairs(ca: np.ndarray, ra: np.ndarray, cb: np.ndarray, rb: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Pairs (i, j) whose bounding spheres (centres ``c``, radii ``r``) overlap."""
    if not len(ca) or not len(cb):
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    near = cKDTree(cb).query_ball_point(ca, ra + rb.max())
    i = np.repeat(np.arange(len(ca)), [len(n) for n in near])
    j = np.fromiter((x for n in near for x in n), np.int64, len(i))
    keep = np.linalg.norm(ca[i] - cb[j], axis=1) <= ra[i] + rb[j]
    return i[keep], j[keep]


def intersecting_pairs(va: np.ndarray, ta: np.ndarray, vb: np.ndarray, tb: np.ndarray, *,
                       key_a: np.ndarray | None = None, key_b: np.ndarray | None = None
                       ) -> tuple[np.ndarray, np.ndarray]:
    """Triangle pairs (i into ``ta``, j into ``tb``) that pass through each other.

    With ``key_a``/``key_b`` (welded vertex ids, e.g. :func:`weld_key` of one mesh for both),
    pairs sharing a vertex are neighbours, not intersections, and are left out.
    """
    A = np.asarray(va, np.float64)[ta]
    B = np.asarray(vb, np.float64)[tb]
    ca, cb = A.mean(1), B.mean(1)
    ra = np.linalg.norm(A - ca[:, None], axis=2).max(1)
    rb = np.linalg.norm(B - cb[:, None], axis=2).max(1)
    i, j = candidate_pairs(ca, ra, cb, rb)
    if key_a is not None and key_b is not None and len(i):
        share = (key_a[ta[i]][:, :, None] == key_b[tb[j]][:, None, :]).any((1, 2))
        i, j = i[~share], j[~share]
    hit = np.zeros(len(i), bool)
    for x, y, ix, iy in ((A, B, i, j), (B, A, j, i)):
        for k in range(3):
            hit |= _segments_hit(x[ix, k], x[ix, (k + 1) % 3], y[iy])
    return i[hit], j[hit]


def self_intersections(v: np.ndarray, tris: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pairs i < j of a mesh's triangles that pass through each other (neighbours over a
    shared position do not count)."""
    key = weld_key(v)
    i, j = intersecting_pairs(v, tris, v, tris, key_a=key, key_b=key)
    keep = i < j
    return i[keep], j[keep]


def triangle_normals(v: np.ndarray, tris: np.ndarray) -> np.ndarray:
    """Unit normals (F, 3) (zero for degenerate triangles)."""
    p = np.asarray(v, np.float64)[tris]
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    ln = np.linalg.norm(n, axis=1, keepdims=True)
    return n / np.where(ln > 0, ln, 1.0)


def edge_stretch(rest: np.ndarray, posed: np.ndarray, tris: np.ndarray) -> np.ndarray:
    """Per triangle, the largest ratio of an edge's posed length to its rest length, or of
    rest to posed (≥ 1; 1 = no stretch)."""
    def lengths(v: np.ndarray) -> np.ndarray:
        p = np.asarray(v, np.float64)[tris]
        return np.linalg.norm(p - np.roll(p, 1, axis=1), axis=2)

    a, b = lengths(rest), lengths(posed)
    r = np.where(a > 1e-9, b / np.maximum(a, 1e-9), 1.0)
    return np.maximum(r, 1.0 / np.maximum(r, 1e-9)).max(1)


@dataclass
class ClothReport:
    """Offending triangles of one frame (counts; ``pairs`` for a closer look)."""

    cloth_cloth: int  #: cloth triangle pairs passing through each other
    skin_cloth: int  #: skin triangles passing through a cloth triangle
    stretched: int  #: cloth triangles with an edge stretched or squeezed past ``max_stretch``
    flipped: int  #: cloth triangles turned over (normal against their rest normal's turn)
    cloth_tris: np.ndarray  #: indices of the cloth triangles in any of the above
    skin_tris: np.ndarray  #: indices of the skin triangles through cloth

    def total(self) -> int:
        return self.cloth_cloth + self.skin_cloth + self.stretched + self.flipped


def check_cloth(skin_v: np.ndarray, skin_t: np.ndarray, cloth_v: np.ndarray,
                cloth_t: np.ndarray, *, cloth_rest: np.ndarray | None = None,
                turn: np.ndarray | None = None, max_stretch: float = 2.0,
                region: np.ndarray | None = None) -> ClothReport:
    """Check a posed cloth mesh against itself and the posed skin.

    ``cloth_rest``: its rest positions, for stretch and flip checks; ``turn`` (F, 3, 3): each
    cloth triangle's rotation from rest (a flipped triangle's normal points against its turned
    rest normal); ``region``: (lo, hi) corners of a box; only triangles with a corner inside
    count (what a camera sees).
    """
    ct = np.asarray(cloth_t)
    st = np.asarray(skin_t)
    if region is not None:
        lo, hi = np.asarray(region, np.float64)

        def inside(v: np.ndarray, t: np.ndarray) -> np.ndarray:
            p = np.asarray(v)[t]
            return np.any(np.all((p >= lo) & (p <= hi), axis=2), axis=1)

        c_sel = np.flatnonzero(inside(cloth_v, ct))
        s_sel = np.flatnonzero(inside(skin_v, st))
    else:
        c_sel, s_sel = np.arange(len(ct)), np.arange(len(st))
    i, j = self_intersections(cloth_v, ct[c_sel])
    si, sj = intersecting_pairs(skin_v, st[s_sel], cloth_v, ct[c_sel])
    bad = [c_sel[i], c_sel[j], c_sel[sj]]
    stretched = flipped = 0
    if cloth_rest is not None:
        s = edge_stretch(cloth_rest, cloth_v, ct[c_sel]) > max_stretch
        n0 = triangle_normals(cloth_rest, ct[c_sel])
        if turn is not None:
            n0 = np.einsum("fij,fj->fi", turn[c_sel], n0)
        n1 = triangle_normals(cloth_v, ct[c_sel])
        f = np.einsum("ij,ij->i", n0, n1) < 0.0
        stretched, flipped = int(s.sum()), int(f.sum())
        bad += [c_sel[s], c_sel[f]]
    return ClothReport(len(i), len(np.unique(si)), stretched, flipped,
                       np.unique(np.concatenate(bad)), s_sel[np.unique(si)])
