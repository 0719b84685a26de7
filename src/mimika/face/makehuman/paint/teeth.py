"""Teeth: MakeHuman's dentition has each tooth as a UV island of its own and the gums and
palate as the few large ones. The gums get their own material; the enamel is ivory with a
slight per-tooth variation, darker toward each tooth's outline — where it meets its
neighbours and the gum — so a row reads as separate teeth, not one white band."""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from mimika.face.makehuman.build import Piece
from mimika.face.makehuman.paint import color
from mimika.face.makehuman.paint.noise import seed_of, smoothstep
from mimika.face.makehuman.paint.raster import rasterize
from mimika.face.makehuman.paint.regions import uv_islands
from mimika.face.makehuman.teeth import gum_faces

SIZE = 512
ENAMEL = "#eee4cf"
#: how far in from a tooth's outline it darkens (share of its inscribed radius) and how much
EDGE, EDGE_DARK = 0.35, 0.3


def paint_teeth(piece: Piece, name: str) -> np.ndarray:
    """RGBA texture of the teeth (alpha: gloss, wet enamel)."""
    tris = np.concatenate(list(piece.parts.values()))
    tooth = tris[~gum_faces(piece)]
    at = rasterize(piece.uvs, tooth, (SIZE, SIZE))
    inside = ndimage.distance_transform_edt(at.covered).ravel()[at.texels]
    lab = uv_islands(tooth, len(piece.uvs))[tooth[at.faces_at(), 0]]
    radius = ndimage.maximum(inside, lab, np.arange(lab.max() + 1))[lab]
    edge = smoothstep(0.0, EDGE, inside / np.maximum(radius, 1.0))
    rng = np.random.default_rng(seed_of("teeth", name))
    tint = 1.0 + 0.05 * rng.standard_normal((lab.max() + 1, 1)).astype(np.float32)
    c = color.hex_linear(ENAMEL)[None, :] * tint[lab] * (1.0 - EDGE_DARK * (1.0 - edge))[:, None]
    return at.image(color.rgba8(c, np.full(len(c), 0.9, np.float32)))
