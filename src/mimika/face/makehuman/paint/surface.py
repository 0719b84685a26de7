"""Per-vertex quantities on a painted mesh: normals, neighbours, smoothing, concavity, open
borders, and how 3D directions map to texture directions."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp


def boundary_edges(tris: np.ndarray, key: np.ndarray | None = None) -> np.ndarray:
    """Edges (E, 2) used by one triangle only: the open border of a mesh. With ``key`` (N,)
    (e.g. the source vertex of seam-split vertices) edges are compared by key, so UV seams
    are not borders; the returned edges index the original vertices."""
    t = np.asarray(tris, np.int64)
    e = np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]])
    k = e if key is None else np.asarray(key)[e]
    ks = np.sort(k, axis=1)
    _, inv, cnt = np.unique(ks, axis=0, return_inverse=True, return_counts=True)
    return e[cnt[inv.ravel()] == 1]


def face_jacobians(vertices: np.ndarray, uv: np.ndarray, tris: np.ndarray) -> np.ndarray:
    """Per triangle (F, 3, 2): d position / d uv, the 3D vectors along +u and +v."""
    p = np.asarray(vertices, np.float64)[tris]
    t = np.asarray(uv, np.float64)[tris]
    e = np.stack([p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]], 2)  # (F, 3, 2)
    f = np.stack([t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]], 2)  # (F, 2, 2)
    det = f[:, 0, 0] * f[:, 1, 1] - f[:, 0, 1] * f[:, 1, 0]
    det = np.where(np.abs(det) < 1e-12, 1e-12, det)
    finv = np.stack([np.stack([f[:, 1, 1], -f[:, 0, 1]], 1),
                     np.stack([-f[:, 1, 0], f[:, 0, 0]], 1)], 1) / det[:, None, None]
    return np.einsum("fij,fjk->fik", e, finv)


def smooth_normals(vertices: np.ndarray, tris: np.ndarray, weld: np.ndarray | None = None
                   ) -> np.ndarray:
    """Area-weighted unit vertex normals (N, 3), averaged over ``weld`` groups (seams)."""
    v = np.asarray(vertices, np.float64)
    t = np.asarray(tris, np.int64)
    fn = np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]])
    key = np.arange(len(v)) if weld is None else np.unique(weld, return_inverse=True)[1]
    acc = np.zeros((int(key.max()) + 1, 3))
    for k in range(3):
        np.add.at(acc, key[t[:, k]], fn)
    n = acc[key]
    return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)


def welded(n: int, weld: np.ndarray | None) -> tuple[np.ndarray, int]:
    """(key per vertex, number of keys): vertices split at UV seams share a key."""
    if weld is None:
        return np.arange(n), n
    _, key = np.unique(weld, return_inverse=True)
    return key.ravel(), int(key.max()) + 1


def adjacency(tris: np.ndarray, key: np.ndarray, m: int) -> sp.csr_matrix:
    """Row-normalised (m, m) neighbour-averaging matrix over the welded mesh."""
    t = key[np.asarray(tris, np.int64)]
    e = np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]])
    e = np.concatenate([e, e[:, ::-1]])
    a = sp.csr_matrix((np.ones(len(e)), (e[:, 0], e[:, 1])), shape=(m, m))
    a.data[:] = 1.0
    deg = np.asarray(a.sum(1)).ravel()
    return sp.diags(1.0 / np.maximum(deg, 1.0)) @ a


def diffuse(values: np.ndarray, avg: sp.csr_matrix, steps: int) -> np.ndarray:
    """``steps`` rounds of neighbour averaging (half self, half neighbours)."""
    v = np.asarray(values, np.float64)
    for _ in range(steps):
        v = 0.5 * v + 0.5 * (avg @ v)
    return v


def cavity(vertices: np.ndarray, normals: np.ndarray, avg: sp.csr_matrix, key: np.ndarray,
           m: int) -> np.ndarray:
    """Per welded vertex (m,): how far the neighbours' mean lies outside the surface (cm-free
    ratio to the local edge length); positive in creases and hollows."""
    pos = np.zeros((m, 3))
    nrm = np.zeros((m, 3))
    pos[key] = vertices
    nrm[key] = normals
    mean = avg @ pos
    sq = np.einsum("ij,ij->i", pos, pos)
    edge = np.sqrt(np.maximum(avg @ sq - 2 * np.einsum("ij,ij->i", pos, mean) + sq, 1e-18))
    return np.einsum("ij,ij->i", mean - pos, nrm) / edge
