"""Paint a character: per-piece parts with textures (skin, lips, hair, brows, lashes, irises,
clothes). Textures are procedural — the MakeHuman assets ship without theirs."""

from __future__ import annotations

import numpy as np

from mimika.face.head import Part, Texture
from mimika.face.makehuman.build import Piece
from mimika.face.makehuman.character_file import Character
from mimika.face.makehuman.paint.regions import skin_regions


def solid(hex_color: str, alpha: int = 255) -> Texture:
    """A 4×4 texture of one sRGB colour."""
    h = hex_color.lstrip("#")
    rgb = [int(h[i:i + 2], 16) for i in (0, 2, 4)]
    return Texture(np.tile(np.array([*rgb, alpha], np.uint8), (4, 4, 1)), hex_color)


def parts_of(piece: Piece, character: Character) -> tuple[Part, ...]:
    """The parts of ``piece`` with their materials and textures."""
    if piece.name == "skin":
        tris = piece.parts["skin"]
        region = skin_regions(piece, tris)
        tex = solid(character.skin)
        return tuple(Part(mat, tris[region == k], tex) for k, mat in
                     enumerate(("skin", "lips", "skin_body")) if np.any(region == k))
    out = []
    for mat, faces in piece.parts.items():
        tex, mode = None, "opaque"
        if mat == "iris":
            tex = solid(character.eyes)
        elif mat == "hair":
            tex = solid(character.hair_color)
        elif mat in ("brow", "lash"):
            tex = solid(character.hair_color if mat == "brow" else "#1a1410")
        out.append(Part(mat, faces, tex, mode))
    return tuple(out)
