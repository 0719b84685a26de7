"""Paint a character: per-piece parts with procedural textures — skin albedo and gloss, hair
strands, brow and lash strokes, irises and scleras, garment fabrics (the MakeHuman assets ship
without theirs). Textures are cached on disk (:mod:`.cache`).

:func:`parts_of` is what :mod:`mimika.face.heads.character` calls for every piece. For the skin
it also remaps the head island's UVs into the head atlas (``piece.uvs``; the original layout
stays in ``piece.meta['uv_layout']``, so calling it again is safe).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from mimika.face.head import Part, Texture
from mimika.face.makehuman.build import Piece
from mimika.face.makehuman.character_file import Character
from mimika.face.makehuman.paint.cache import cached_texture, piece_digest, texture_key

#: renderer material of each piece material (textured hair cards get their own entries)
MATERIALS = {"brow": "eyebrow", "lash": "eyelash"}


def _digest(piece: Piece) -> str:
    return piece_digest(piece.vertices, piece.meta.get("uv_layout", piece.uvs), piece.weld,
                        *piece.parts.values())


def _texture(kind: str, piece: Piece, settings: dict, paint) -> Texture:
    key = texture_key(kind, _digest(piece), settings)
    return Texture(cached_texture(kind, key, paint), kind)


def _skin_parts(piece: Piece, ch: Character) -> tuple[Part, ...]:
    from mimika.face.makehuman.paint.skin import (
        paint_body,
        paint_head,
        paint_head_detail,
        skin_layout,
    )

    region, uvs = skin_layout(piece)
    who = {"name": ch.name, "skin": ch.skin, "phenotype": ch.phenotype_values()}
    head = _texture("skin", piece, {**who, "hair": ch.hair, "hair_color": ch.hair_color},
                    lambda: paint_head(piece, ch))
    detail = _texture("skin_detail", piece, who, lambda: paint_head_detail(piece, ch))
    head = replace(head, normal=detail.image)
    body = _texture("skin_body", piece, who, lambda: paint_body(piece, ch))
    piece.meta.setdefault("uv_layout", piece.uvs)
    piece.uvs = uvs
    tris = piece.parts["skin"]
    return tuple(Part(mat, tris[region == k], tex) for k, (mat, tex) in
                 enumerate((("skin", head), ("lips", head), ("skin_body", body)))
                 if np.any(region == k))


def _part_texture(mat: str, piece: Piece, ch: Character) -> tuple[Texture | None, str]:
    """Texture and alpha mode of one material of a (non-skin) piece."""
    if mat in ("iris", "sclera"):
        from mimika.face.makehuman.paint.eyes import paint_iris, paint_sclera
        from mimika.face.makehuman.paint.noise import seed_of

        seed = seed_of("eye", ch.name, piece.name)
        if mat == "iris":
            return _texture("iris", piece, {"eyes": ch.eyes, "seed": seed},
                            lambda: paint_iris(ch.eyes, seed)), "opaque"
        nasal = {"eye_L": -1.0, "eye_R": 1.0}.get(piece.name, 0.0)
        return _texture("sclera", piece, {"seed": seed, "nasal": nasal},
                        lambda: paint_sclera(seed, nasal)), "opaque"
    if mat == "hair":
        from mimika.face.makehuman.paint.hair import is_coily, paint_hair, paint_hair_flow

        who = {"name": ch.name, "hair": ch.hair, "color": ch.hair_color}
        tex = _texture("hair", piece, who, lambda: paint_hair(piece, ch))
        if not is_coily(ch.hair):
            flow = _texture("hair_flow", piece, {"hair": ch.hair},
                            lambda: paint_hair_flow(piece, ch))
            tex = replace(tex, flow=flow.image)
        return tex, "blend"
    if mat in ("brow", "lash"):
        from mimika.face.makehuman.paint.strokes import paint_strokes

        asset = ch.eyebrows if mat == "brow" else ch.eyelashes
        return _texture(mat, piece, {"name": ch.name, "asset": asset, "color": ch.hair_color},
                        lambda: paint_strokes(piece, ch, mat)), "blend"
    if mat == "cloth":
        from mimika.face.makehuman.paint.cloth import paint_cloth

        asset = ch.clothes[int(piece.name.removeprefix("clothes") or 0)]
        return _texture("cloth", piece, {"name": ch.name, "asset": asset},
                        lambda: paint_cloth(piece, asset, ch.name)), "opaque"
    return None, "opaque"


def _teeth_parts(piece: Piece, ch: Character) -> tuple[Part, ...]:
    from mimika.face.makehuman.paint.teeth import paint_teeth
    from mimika.face.makehuman.teeth import gum_faces

    tris = piece.parts["teeth"]
    gums = gum_faces(piece)
    tex = _texture("teeth", piece, {"name": ch.name}, lambda: paint_teeth(piece, ch.name))
    return Part("teeth", tris[~gums], tex), Part("gums", tris[gums])


def parts_of(piece: Piece, character: Character) -> tuple[Part, ...]:
    """The parts of ``piece`` with their materials and textures."""
    if piece.name == "skin":
        return _skin_parts(piece, character)
    if piece.name == "teeth" and piece.uvs is not None and set(piece.parts) == {"teeth"}:
        return _teeth_parts(piece, character)
    out = []
    for mat, faces in piece.parts.items():
        tex, mode = _part_texture(mat, piece, character) if piece.uvs is not None else \
            (None, "opaque")
        name = MATERIALS.get(mat, mat) if tex is not None else mat
        if mat == "hair" and tex is not None:
            from mimika.face.makehuman.paint.hair import is_coily

            name = "hair_coily" if is_coily(character.hair) else "hair"
        out.append(Part(name, faces, tex, mode))
    return tuple(out)
