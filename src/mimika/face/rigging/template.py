"""A style's template face, for placing the 68 landmarks on a new face the way the style's
fields were fitted: where the opening finder lands on the template itself (so its bias on
faces like the template — closed lids and lips — cancels) and points of the template's face
surface, laid onto the new face by a similarity ICP and then bent onto it (other proportions:
a longer lower face, a flatter nose) by a smooth non-rigid ICP that carries the landmarks."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from mimika.face.fitting.splits import similarity_transform
from mimika.face.head import Head
from mimika.face.rigging.features import find_face

__all__ = ["face_template", "icp_nonrigid", "icp_similarity", "welded_skin"]


def welded_skin(head: Head) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The skin with its UV-seam copies merged, as a mesh file would have it: vertices,
    faces and, per merged vertex, the skin vertex it was (to index per-vertex data)."""
    skin = head["skin"]
    faces = np.concatenate([p.faces for p in skin.parts])
    if skin.weld is None:
        return skin.vertices.astype(float), faces, np.arange(skin.n_vertices)
    _, first, inverse = np.unique(skin.weld, return_index=True, return_inverse=True)
    return skin.vertices[first].astype(float), inverse[faces], first


def face_template(head: Head, n_surface: int = 2000, seed: int = 0) -> dict:
    """``openings`` (eye_L, eye_R, mouth as the finder sees them) and ``surface`` (up to
    ``n_surface`` points of the face between the chin and above the brows, in front of the
    ears) of ``head``, cm, for a fields document's ``source``."""
    v, f, _ = welded_skin(head)
    feat = find_face(v, f)
    if feat is None:
        raise ValueError(f"{head.name}: the opening finder finds no face on the template")
    lm = head.landmark_points().astype(float)
    sel = ((v[:, 1] > lm[8, 1] - 0.5) & (v[:, 1] < lm[24, 1] + 2.5)
           & (np.abs(v[:, 0]) < np.abs(lm[0, 0]) + 0.5) & (v[:, 2] > 0.5 * (lm[0, 2] + lm[16, 2])))
    pts = v[sel]
    if len(pts) > n_surface:
        pts = pts[np.sort(np.random.default_rng(seed).choice(len(pts), n_surface, False))]
    return {"openings": {k: np.round(getattr(feat, k), 5).tolist()
                         for k in ("eye_L", "eye_R", "mouth")},
            "surface": np.round(pts, 4).tolist()}


def icp_similarity(points: np.ndarray, target: np.ndarray, iterations: int = 10,
                   keep: float = 80.0) -> tuple[float, np.ndarray, np.ndarray]:
    """The similarity (s, R, t) that moves ``points`` onto the surface sampled by ``target``
    (vertices), p ↦ s·R·p + t: iterated closest points, each round fitted on the ``keep`` %
    nearest pairs (the rest lie where the faces differ: ears, hairline, open mouths)."""
    tree = cKDTree(target)
    s_all, r_all, t_all = 1.0, np.eye(3), np.zeros(3)
    p = np.asarray(points, float)
    for _ in range(iterations):
        d, j = tree.query(p)
        ok = d <= max(float(np.percentile(d, keep)), 0.2)
        s, r, t = similarity_transform(p[ok], target[j[ok]])
        p = s * p @ r.T + t
        s_all, r_all, t_all = s * s_all, r @ r_all, s * r @ t_all + t
    return s_all, r_all, t_all


def _farthest(p: np.ndarray, k: int) -> np.ndarray:
    """Indices of ``k`` farthest-point samples of ``p`` (from its first point)."""
    out = [0]
    d = np.linalg.norm(p - p[0], axis=1)
    for _ in range(min(k, len(p)) - 1):
        out.append(int(np.argmax(d)))
        d = np.minimum(d, np.linalg.norm(p - p[out[-1]], axis=1))
    return np.asarray(out)


def icp_nonrigid(points: np.ndarray, carried: np.ndarray, target: np.ndarray,
                 normals: np.ndarray, *, centres: int = 40, sigma: float = 2.5,
                 stiffness: tuple[float, ...] = (3.0, 1.0, 0.3, 0.1), rounds: int = 4,
                 keep: float = 80.0) -> np.ndarray:
    """``carried`` points moved with ``points`` as these are bent onto the surface ``target``
    (vertices with unit ``normals``): a smooth displacement (Gaussian RBFs of width ``sigma``
    cm on farthest-point ``centres``) fitted point-to-plane plus point-to-point at weight
    0.3, with decreasing ridge ``stiffness``; each round on the ``keep`` % nearest pairs."""
    tree = cKDTree(target)
    ctr = points[_farthest(points, centres)]

    def phi(x: np.ndarray) -> np.ndarray:
        return np.exp(-((x[:, None] - ctr[None]) ** 2).sum(-1) / (2 * sigma ** 2))

    ph = phi(points)
    k = len(ctr)
    w = np.zeros((k, 3))
    for lam in stiffness:
        for _ in range(rounds):
            cur = points + ph @ w
            d, j = tree.query(cur)
            ok = d <= max(float(np.percentile(d, keep)), 0.1)
            q, n, f = target[j[ok]], normals[j[ok]], ph[ok]
            # unknowns: w (k, 3) flattened; plane rows Σ_c n_c·f·w_c, point rows 0.3·f·w_c
            plane = (f[:, :, None] * n[:, None, :]).reshape(len(f), 3 * k)
            a = np.vstack([plane, 0.3 * np.kron(f, np.eye(3))])
            b = np.concatenate([(n * (q - points[ok])).sum(1),
                                0.3 * (q - points[ok]).reshape(-1)])
            w = np.linalg.solve(a.T @ a + lam * len(f) / k * np.eye(3 * k), a.T @ b
                                ).reshape(k, 3)
    return carried + phi(carried) @ w
