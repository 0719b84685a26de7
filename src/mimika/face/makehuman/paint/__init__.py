"""Paint a character: per-piece parts with textures (skin, lips, hair, brows, lashes, irises,
clothes). Textures are procedural — the MakeHuman assets ship without theirs."""

from __future__ import annotations

import numpy as np

from mimika.face.head import Part, Texture
from mimika.face.makehuman.build import Piece
from mimika.face.makehuman.character_file import Character
from mimika.face.makehuman.paint.noise import seed_of


def solid(hex_color: str, alpha: int = 255) -> Texture:
    """A 4×4 texture of one sRGB colour."""
    h = hex_color.lstrip("#")
    rgb = [int(h[i:i + 2], 16) for i in (0, 2, 4)]
    return Texture(np.tile(np.array([*rgb, alpha], np.uint8), (4, 4, 1)), hex_color)


def parts_of(piece: Piece, character: Character) -> tuple[Part, ...]:
    """The parts of ``piece`` with their materials and textures."""
    if piece.name == "skin":
        from mimika.face.makehuman.paint.skin import paint_skin

        sk = paint_skin(piece, character)
        piece.meta.setdefault("uv_layout", piece.uvs)
        piece.uvs = sk.uvs
        head, body = Texture(sk.head, "skin"), Texture(sk.body, "skin_body")
        tris = piece.parts["skin"]
        return tuple(Part(mat, tris[sk.region == k], tex) for k, (mat, tex) in
                     enumerate((("skin", head), ("lips", head), ("skin_body", body)))
                     if np.any(sk.region == k))
    out = []
    for mat, faces in piece.parts.items():
        tex, mode = None, "opaque"
        if mat in ("iris", "sclera"):
            from mimika.face.makehuman.paint.eyes import paint_iris, paint_sclera

            seed = seed_of("eye", character.name, piece.name)
            tex = Texture(paint_iris(character.eyes, seed) if mat == "iris"
                          else paint_sclera(seed), mat)
        elif mat == "hair":
            from mimika.face.makehuman.paint.hair import paint_hair

            tex, mode = Texture(paint_hair(piece, character), "hair"), "blend"
        elif mat in ("brow", "lash"):
            from mimika.face.makehuman.paint.strokes import paint_strokes

            tex, mode = Texture(paint_strokes(piece, character, mat), mat), "blend"
            mat = "eyebrow" if mat == "brow" else "eyelash"
        elif mat == "cloth":
            from mimika.face.makehuman.paint.cloth import paint_cloth

            k = int(piece.name.removeprefix("clothes") or 0)
            asset = character.clothes[k]
            tex = Texture(paint_cloth(piece, asset, character.name), asset)
        out.append(Part(mat, faces, tex, mode))
    return tuple(out)
