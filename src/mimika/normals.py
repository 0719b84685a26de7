"""Smoothed normals for hair: its volume, not its cards, shapes the shading.

Hair meshes are layers of cards; each card's own vertex normals break highlights and shading
into blocks along the card outlines. Averaging the normals of nearby vertices (a Gaussian
over :data:`HAIR_SMOOTH_CM`) gives the field of the hair's volume; each vertex keeps the side
its card is wound to (double-sided cards face either way), so back faces still flip right.
Used by the renderer every frame and by the glTF writer, so viewers shade hair alike.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

#: material names shaded as hair (``render/data/materials.json`` models ``hair``)
HAIR_MATERIALS = ("hair", "hair_coily")
#: normals averaged over this radius (cm)
HAIR_SMOOTH_CM = 1.2


def smoothing(points: np.ndarray, normals: np.ndarray, radius: float = HAIR_SMOOTH_CM
              ) -> tuple[sp.csr_matrix, np.ndarray]:
    """For :func:`smooth`: a row-normalised Gaussian average over the ``points`` (N, 3)
    within ``radius``, and each point's side (±1) that turns its ``normals`` (N, 3) away from
    the points' centre."""
    from scipy.spatial import cKDTree

    p = np.asarray(points, np.float64)
    tree = cKDTree(p)
    d = tree.sparse_distance_matrix(tree, radius, output_type="coo_matrix")
    w = np.exp(-0.5 * (d.data / (0.5 * radius)) ** 2)
    m = sp.csr_matrix((w, (d.row, d.col)), shape=(len(p), len(p))) + sp.identity(len(p))
    m = sp.diags(1.0 / np.asarray(m.sum(1)).ravel()) @ m  # (distance 0 is not stored)
    side = np.where(np.einsum("ij,ij->i", normals, p - p.mean(0)) < 0, -1.0, 1.0)
    return m.tocsr().astype(np.float32), side.astype(np.float32)


def smooth(normals: np.ndarray, smoothing: tuple[sp.csr_matrix, np.ndarray]) -> np.ndarray:
    """Unit ``normals`` (N, 3) averaged by ``smoothing`` (:func:`smoothing`), float32."""
    m, side = smoothing
    n = np.asarray(m @ (np.asarray(normals, np.float32) * side[:, None]), np.float32)
    return n * (side / np.maximum(np.linalg.norm(n, axis=1), 1e-6))[:, None]


def is_hair(obj) -> bool:
    """Whether a head object (``parts`` with ``material`` names) is drawn as hair."""
    return any(p.material in HAIR_MATERIALS for p in obj.parts)
