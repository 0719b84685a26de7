"""Skin paint: albedo (RGB) and gloss (alpha) over the hm08 skin.

The head island (face, scalp, ears, neck) gets its own atlas, ``HEAD_SIZE`` texels, cropped
from the UV layout at a uniform scale (≈ 2 950 texels per UV unit, the density of a 2 950²
full-layout map, ≈ 0.25 mm per texel on the face) — the head vertices' UVs are remapped into
it. The rest of the body keeps the original layout at ``BODY_SIZE`` (hands, arms, chest in a
neckline are seen small). Everything is computed per texel from bind-pose positions (cm) and
the 68 landmarks, so regions follow any phenotype and patterns are continuous across seams.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from mimika.face.makehuman.base import first_copies, landmark_ids, polyline
from mimika.face.makehuman.build import SCALE as CM
from mimika.face.makehuman.build import Piece, asset_path
from mimika.face.makehuman.character_file import Character
from mimika.face.makehuman.paint import color
from mimika.face.makehuman.paint.noise import fbm3, seed_of, smoothstep, value3
from mimika.face.makehuman.paint.raster import rasterize
from mimika.face.makehuman.paint.regions import sample, skin_regions, uv_mask
from mimika.face.makehuman.paint.surface import (
    adjacency,
    boundary_edges,
    cavity,
    diffuse,
    face_jacobians,
    smooth_normals,
    welded,
)
from mimika.face.makehuman.proxy import read_mhclo

HEAD_SIZE = (1024, 2048)
BODY_SIZE = (1024, 1024)
#: texels left around the head island in its atlas
PAD = 6
#: skin farther than this from the hair's surface (cm) is not tinted by it
HAIR_REACH = 1.5


def landmarks(piece: Piece) -> np.ndarray:
    """The 68 landmarks (68, 3) in cm at the piece's bind pose."""
    return piece.vertices[first_copies(piece.weld, landmark_ids())].astype(np.float64) * CM


def head_uvs(uv: np.ndarray, verts: np.ndarray) -> np.ndarray:
    """UVs of ``verts`` cropped into the head atlas (uniform scale, centred, PAD texels)."""
    w, h = HEAD_SIZE
    lo, hi = uv[verts].min(0), uv[verts].max(0)
    span = np.maximum(hi - lo, 1e-6)
    s = min((w - 2 * PAD) / span[0], (h - 2 * PAD) / span[1])  # texels per UV unit
    off = (np.array([w, h]) - span * s) / 2
    out = uv.copy()
    out[verts] = ((uv[verts] - lo) * s + off) / np.array([w, h])
    return out.astype(np.float32)


def _lid_margin(pos: np.ndarray, tris: np.ndarray, weld: np.ndarray, lm: np.ndarray
                ) -> np.ndarray:
    """Per vertex: distance (cm) to the eye openings' rims (the lid margins)."""
    from scipy.spatial import cKDTree

    rim = np.unique(boundary_edges(tris, weld))
    eyes = np.stack([lm[36:42].mean(0), lm[42:48].mean(0)])
    near = np.min(np.linalg.norm(pos[rim][:, None] - eyes[None], axis=2), axis=1) < 2.2
    if not near.any():
        return np.full(len(pos), 10.0)
    return cKDTree(pos[rim[near]]).query(pos)[0]


def _scalp_cover(piece: Piece, character: Character, pos: np.ndarray) -> np.ndarray:
    """Per vertex: how much hair lies over the skin here — 1 under the hair's body, fading
    over its thinned-out border (where strand tips let the skin show between them) and where
    the hair's surface lies farther than :data:`HAIR_REACH` (the hair is fitted from its
    ``.mhclo`` onto this skin's bind pose)."""
    from scipy.sparse.csgraph import dijkstra
    from scipy.spatial import cKDTree

    if not character.hair:
        return np.zeros(len(pos))
    proxy = read_mhclo(asset_path("hair", character.hair))
    base = np.zeros((int(piece.weld.max()) + 1, 3))
    base[piece.weld] = piece.vertices
    if not np.isin(np.unique(proxy.refs), piece.weld).all():
        return np.zeros(len(pos))
    hp = proxy.fit(base).astype(np.float64) * CM
    f = proxy.mesh.faces
    e = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    n = len(hp)
    g = sp.coo_matrix((np.linalg.norm(hp[e[:, 0]] - hp[e[:, 1]], axis=1), (e[:, 0], e[:, 1])),
                      shape=(n, n)).tocsr()
    rim = np.unique(boundary_edges(f))
    inner = dijkstra(g, directed=False, indices=rim, min_only=True) if len(rim) else \
        np.full(n, 10.0)
    # distance to the hair's surface, not only to its vertices (cards span centimetres):
    # each triangle sampled on a barycentric grid, each sample carrying its corners' depth
    # into the hair from its rim
    b = np.array([(i, j) for i in range(5) for j in range(5 - i)], np.float64) / 4.0
    w = np.c_[1.0 - b.sum(1), b]  # (S, 3)
    pts = np.einsum("sk,fkd->fsd", w, hp[f]).reshape(-1, 3)
    depth = np.einsum("sk,fk->fs", w, np.minimum(inner, 10.0)[f]).ravel()
    d, i = cKDTree(pts).query(pos)
    return smoothstep(HAIR_REACH, 0.5, d) * smoothstep(-0.3, 1.2, depth[i])


class _Face:
    """Region weights of the face from the landmarks, at points ``p`` (T, 3) in cm."""

    def __init__(self, lm: np.ndarray) -> None:
        self.lm = lm
        self.eye_y = lm[36:48, 1].mean()
        self.brow_y = lm[17:27, 1].mean()
        self.chin = lm[8]
        self.mouth_y = lm[[48, 54], 1].mean()
        self.ear_z = lm[[0, 16], 2].mean()

    def blob(self, p: np.ndarray, centres: np.ndarray, r: float) -> np.ndarray:
        d2 = np.min([((p - c) ** 2).sum(1) for c in np.atleast_2d(centres)], axis=0)
        return np.exp(-d2 / (2 * r * r)).astype(np.float32)

    def cheeks(self, p):
        lm = self.lm
        c = [0.35 * lm[k] + 0.35 * lm[n] + 0.3 * lm[e] + [0, -0.3, 0.4]
             for k, n, e in ((2, 31, 41), (14, 35, 46))]
        return self.blob(p, np.array(c), 1.9)

    def nose(self, p):
        lm = self.lm
        return np.maximum(self.blob(p, lm[30], 0.9), 0.8 * self.blob(p, lm[[31, 35]], 0.6))

    def undereye(self, p):
        lm = self.lm
        pts = lm[[40, 41, 46, 47]] + np.array([0, -0.55, -0.1])
        return self.blob(p, pts, 0.55)

    def brows(self, p):
        lm = self.lm
        a = np.concatenate([polyline(lm[17:22], 4), polyline(lm[22:27], 4)])
        return self.blob(p, a + np.array([0, -0.05, -0.2]), 0.32)

    def front(self, p):
        """1 in front of the ears, 0 behind."""
        return smoothstep(self.ear_z - 0.5, self.ear_z + 1.5, p[:, 2])

    def forehead(self, p):
        y = p[:, 1]
        return smoothstep(self.brow_y + 0.2, self.brow_y + 1.4, y) * self.front(p)

    def tzone(self, p):
        lm = self.lm
        bridge = smoothstep(1.3, 0.5, np.abs(p[:, 0])) * smoothstep(lm[30, 1] - 0.5,
                                                                   lm[30, 1] + 0.5, p[:, 1]) \
            * smoothstep(self.brow_y + 1.0, self.brow_y, p[:, 1]) * self.front(p)
        chin = self.blob(p, self.chin + np.array([0, 1.0, 0.3]), 1.3)
        return np.maximum(np.maximum(self.forehead(p) * smoothstep(5.5, 2.0, np.abs(p[:, 0])),
                                     bridge), chin)

    def beard(self, p):
        """Where a beard grows: below a line from the sideburns over the cheeks to the nose,
        down under the jaw onto the upper neck, in front of the ears."""
        lm = self.lm
        ax = np.abs(p[:, 0])
        xs = [0.0, abs(lm[31, 0]) + 0.2, abs(lm[48, 0]) + 1.0, abs(lm[3, 0]),
              abs(lm[0, 0]) + 0.3, abs(lm[0, 0]) + 2.0]
        ys = [lm[33, 1] - 0.15, lm[31, 1] - 0.35, lm[31, 1] - 1.0, lm[2, 1] + 0.2,
              lm[0, 1] + 0.8, lm[0, 1] + 0.8]
        top = np.interp(ax, xs, ys)
        # faded by the distance to that line, not the height above it: where it runs steeply
        # down the cheek a vertical fade ended the stubble in a sharp edge
        q = np.column_stack([ax, p[:, 1]])[:, None, :]
        a = np.column_stack([xs, ys])[:-1]
        ab = np.diff(np.column_stack([xs, ys]), axis=0)
        t = np.clip(((q - a) * ab).sum(-1) / (ab * ab).sum(-1), 0.0, 1.0)
        d = np.linalg.norm(q - (a + t[..., None] * ab), axis=-1).min(1)
        below = smoothstep(0.6, -0.6, np.where(p[:, 1] > top, d, -d))
        neck = smoothstep(self.chin[1] - 4.8, self.chin[1] - 2.6, p[:, 1])
        side = smoothstep(self.ear_z - 1.2, self.ear_z + 0.6, p[:, 2])
        return below * neck * side


def _phenotype(character: Character) -> dict[str, float]:
    ph = character.phenotype
    origin = ph.get("origin") or {}
    tot = sum(origin.values()) or 1.0
    return {"male": float(smoothstep(0.35, 0.9, np.float32(ph.get("gender", 0.5)))),
            "age": float(ph.get("age", 25.0)),
            "caucasian": float(origin.get("caucasian", 1.0 if not origin else 0.0)) / tot}


def skin_layout(piece: Piece) -> tuple[np.ndarray, np.ndarray]:
    """Per triangle: 0 head island, 1 lips, 2 rest of the body; and the UVs the textures use
    (head vertices remapped into the head atlas). Reads the original layout from
    ``piece.meta['uv_layout']`` when the piece's UVs were remapped already."""
    uv0 = piece.meta.get("uv_layout", piece.uvs)
    tris = piece.parts["skin"]
    region = skin_regions(uv0, tris)
    return region, head_uvs(uv0, np.unique(tris[region < 2]))


class _Geometry:
    """Per-vertex quantities of the skin piece the painters share."""

    def __init__(self, piece: Piece) -> None:
        self.uv0 = piece.meta.get("uv_layout", piece.uvs)
        self.tris = piece.parts["skin"]
        self.pos = piece.vertices.astype(np.float64) * CM
        nrm = smooth_normals(self.pos, self.tris, piece.weld)
        self.key, self.m = welded(len(self.pos), piece.weld)
        self.avg = adjacency(self.tris, self.key, self.m)
        self.cav = diffuse(cavity(self.pos, nrm, self.avg, self.key, self.m), self.avg,
                           2)[self.key]


def _seed(character: Character) -> int:
    return seed_of("skin", character.name, character.skin, sorted(character.phenotype.items()))


def paint_head(piece: Piece, character: Character) -> np.ndarray:
    """RGBA head atlas (``HEAD_SIZE``): albedo, alpha = gloss in skin-specular units (lips
    texels rescaled to the lips material)."""
    region, uvs = skin_layout(piece)
    g = _Geometry(piece)
    lm = landmarks(piece)
    margin = _lid_margin(g.pos, g.tris, piece.weld, lm)
    cover = _scalp_cover(piece, character, g.pos)
    head = region < 2
    at = rasterize(uvs, g.tris[head], HEAD_SIZE)
    on_lips = region[head][at.faces_at()] == 1
    return _paint_head(at, g.pos, g.uv0, g.cav, cover, margin, lm, on_lips,
                       color.hex_linear(character.skin), color.hex_linear(character.hair_color),
                       _phenotype(character), _seed(character))


def paint_body(piece: Piece, character: Character) -> np.ndarray:
    """RGBA body map (``BODY_SIZE``, original layout) for the skin outside the head island."""
    region, _ = skin_layout(piece)
    uv0 = piece.meta.get("uv_layout", piece.uvs)
    tris = piece.parts["skin"]
    at = rasterize(uv0, tris[region == 2], BODY_SIZE)
    return _paint_body(at, piece.vertices.astype(np.float64) * CM, uv0,
                       color.hex_linear(character.skin), _seed(character))


def _skin_noise(p: np.ndarray, c: np.ndarray, coarse: np.ndarray, seed: int,
                light: float) -> tuple:
    """Mottling, blotches and pores on colours ``c`` (T, 3) at points ``p`` (cm); ``coarse``
    (T, 2): the per-vertex large-scale mottling and blotch fields. Returns the colours and the
    pore field (for the gloss)."""
    fine = value3(p, 0.3, seed + 10) - 0.5
    c = c * (1.0 + 0.05 * coarse[:, 0] + 0.04 * fine)[:, None]
    c = color.tint(c, (0.06 + 0.08 * light) * coarse[:, 1], (1.0, 0.84, 0.84))
    pores = _pores(p, seed)
    c = c * (1.0 - 0.03 * pores)[:, None]
    return c, pores


def _pores(p: np.ndarray, seed: int) -> np.ndarray:
    """The pores at points ``p`` (T, 3) in cm: 0 … 1 in a pore (the albedo's darker dots, the
    gloss's breaks and the detail map's pits are the same)."""
    return smoothstep(0.56, 0.8, value3(p, 0.045, seed + 30, order=1))


def _coarse(pos: np.ndarray, seed: int) -> np.ndarray:
    """Per-vertex large-scale noise (N, 2): mottling (zero mean) and red blotches (≥ 0)."""
    return np.stack([fbm3(pos, 1.4, seed, octaves=2),
                     np.clip(fbm3(pos, 0.8, seed + 20, octaves=2), 0, None)], 1)


#: per-vertex region fields of the head, in this order
_FIELDS = ("cheeks", "nose", "undereye", "forehead", "tzone", "brows", "beard", "neck",
           "cav", "cover", "mott", "blotch", "margin")


def _head_fields(pos, cav, cover, margin, f: _Face, seed: int) -> np.ndarray:
    """(N, len(_FIELDS)) per-vertex fields (smooth at the mesh's ~4 mm edge length)."""
    neck = smoothstep(f.chin[1] - 1.0, f.chin[1] - 5.0, pos[:, 1])
    return np.column_stack([f.cheeks(pos), f.nose(pos), f.undereye(pos), f.forehead(pos),
                            f.tzone(pos), f.brows(pos), f.beard(pos), neck,
                            np.clip(cav * 3.0, -1.0, 1.0), np.clip(cover, 0, 1),
                            _coarse(pos, seed), margin]).astype(np.float32)


#: skin / lips specular in render/data/materials.json (lips texels carry gloss / this ratio)
SKIN_OVER_LIPS_SPECULAR = 0.16 / 0.3


def _paint_head(at, pos, uv0, cav, cover, margin, lm, on_lips, base, hair, ph, seed
                ) -> np.ndarray:
    f = _Face(lm)
    v = dict(zip(_FIELDS, at.at(_head_fields(pos, cav, cover, margin, f, seed)).T,
                 strict=True))
    p = at.at(pos)
    u0 = at.at(uv0)
    light = float(np.clip((color.luminance(base) - 0.04) / 0.4, 0.0, 1.0))  # fair ↔ dark
    red = 0.45 + 0.55 * light  # redness shows less through dark skin

    c = np.tile(base, (len(p), 1))
    lips = sample(uv_mask("lips"), u0, bilinear=True)
    lids = sample(uv_mask("eyelids"), u0, bilinear=True)
    ears = sample(uv_mask("ears"), u0, bilinear=True)
    mouth = sample(uv_mask("inside-mouth"), u0, bilinear=True)
    cheeks, nose, tz = v["cheeks"], v["nose"], v["tzone"]

    c = color.tint(c, 0.35 * red * cheeks, (1.0, 0.82, 0.82))
    c = color.tint(c, 0.4 * red * nose, (1.0, 0.82, 0.80))
    c = color.tint(c, 0.4 * red * ears, (0.97, 0.8, 0.78))
    c = color.tint(c, 0.7 * lids, (0.9, 0.82, 0.86))
    c = color.tint(c, 0.6 * v["undereye"], (0.9, 0.86, 0.92))
    c = color.tint(c, 0.6 * v["forehead"], (1.03, 1.01, 0.93))
    c = color.tint(c, 0.5 * v["neck"], (1.01, 1.0, 0.94))
    c, pores = _skin_noise(p, c, np.column_stack([v["mott"], v["blotch"]]), seed, light)

    # freckles (fair, European skin), more with age as age spots
    if light > 0.3:
        fr = smoothstep(0.74, 0.82, value3(p, 0.11, seed + 40, order=1))
        where = np.maximum(cheeks, nose) + 0.3 * v["forehead"]
        amount = 0.25 * ph["caucasian"] * light * (1.0 + ph["age"] / 60)
        c = color.tint(c, amount * fr * where, (0.88, 0.78, 0.70))

    # creases and hollows a little darker and redder (light scattered inside)
    cv = v["cav"]
    c = color.tint(c, np.clip(cv, 0, 1) * 0.5, (0.86, 0.78, 0.78))
    c = c * (1.0 - 0.05 * np.clip(-cv, 0, 1))[:, None]  # ridges very slightly lighter

    # lips: a darker, redder version of the skin (purplish on dark skin), fine vertical lines
    lip = base * np.array([0.92, 0.5, 0.52]) * (0.74 + 0.1 * light)
    if ph["male"] < 0.5:  # a touch of colour
        lip = lip * np.array([1.0, 0.88, 0.9])
    lip = lip * (1 - light) * np.array([0.85, 0.85, 1.0]) + lip * light
    lines = value3(p / np.array([0.06, 0.7, 0.06]), 1.0, seed + 50, order=1)
    lipc = lip[None, :] * (0.93 + 0.14 * lines)[:, None]
    c = color.mix(c, lipc, lips * 0.92)
    c = color.mix(c, np.array([0.16, 0.035, 0.03]) * (0.4 + 0.6 * light), mouth)

    # the lash line: the lid margins darker (lash roots), a little redder just inside
    # (never lighter than the skin in shade: grey and white hair painted pale smears)
    rim = np.exp(-(v["margin"] / 0.09) ** 2)
    c = color.mix(c, np.minimum(c * 0.45 + 0.2 * hair, c * 0.6), 0.55 * rim)

    # brows: skin under them a little darker (hair roots); the scalp under hair as dark as
    # the hair in its own shade, so skin between strand tips and cards reads as hair, not as
    # light streaks — under light hair, whose fine hairs vanish, the skin in shade
    pale = color.pale(hair)
    roots = (1 - pale) * (c * 0.55 + 0.45 * hair) + pale * c * 0.8
    c = color.mix(c, roots, 0.45 * v["brows"])
    scalp = v["cover"]
    c = color.mix(c, (1 - pale) * (0.1 * c + 0.5 * hair) + pale * 0.6 * c, scalp)

    # beard shadow: stubble dots over a bluish shadow, strength by sex and age
    g_beard = ph["male"] * (0.55 + 0.45 * smoothstep(18.0, 45.0, np.float32(ph["age"])))
    beard = v["beard"] * (1.0 - smoothstep(0.15, 0.5, lips)) * g_beard
    if g_beard > 0:
        dots = smoothstep(0.45, 0.75, value3(p, 0.035, seed + 60, order=1))
        stubble = 0.3 * hair + 0.7 * c * np.array([0.62, 0.66, 0.76])
        c = color.mix(c, stubble, beard * (0.35 + 0.45 * dots) * (0.5 + 0.5 * light))

    # gloss: T-zone and lips shine, beard and scalp are matte; pores break highlights up
    g = 0.5 + 0.32 * tz + 0.1 * nose - 0.08 * cheeks
    g = g * (1 - lips) + lips * 1.5 * (0.75 + 0.25 * lines)
    g = g + 0.2 * lids * (1 - lips) - 0.3 * beard - 0.35 * scalp - 0.1 * v["neck"]
    g = g * (0.78 + 0.22 * (1.0 - pores)) * (0.9 + 0.2 * (v["mott"] * 0.5))
    g = g * (1 - 0.5 * mouth)
    g = np.where(on_lips, g * SKIN_OVER_LIPS_SPECULAR, g)
    return at.image(color.rgba8(c, np.clip(g, 0.05, 1.0)))


def _paint_body(at, pos, uv0, base, seed) -> np.ndarray:
    p = at.at(pos)
    light = float(np.clip((color.luminance(base) - 0.04) / 0.4, 0.0, 1.0))
    c = np.tile(base * np.array([1.0, 1.0, 1.02]), (len(p), 1))
    c, pores = _skin_noise(p, c, at.at(_coarse(pos, seed)), seed, light)
    nails = sample(uv_mask("fingernails"), at.at(uv0), bilinear=True)
    c = color.mix(c, c * 0.7 + 0.3 * np.array([0.8, 0.6, 0.6]), nails)
    g = 0.55 * (0.8 + 0.2 * (1 - pores)) + 0.4 * nails
    return at.image(color.rgba8(c, g))


# ---------------------------------------------------------------- detail (normal, roughness)
#: the skin's fine relief, depths in cm: pores (T-zone and cheeks deepest), a grain of soft
#: bumps about a millimetre across (what reads at 720p), fine lines by region that deepen
#: with age, the lips' vertical lines; ``rough``: roughness scale by region (glossy T-zone,
#: nose and lips, matte cheeks) and in pores
DETAIL = {"pore": 0.004, "grain": 0.005, "grain_cm": 0.3, "line": 0.008, "lip": 0.006,
          "rough": {"cheeks": 0.3, "nose": -0.25, "tzone": -0.15, "lips": -0.35,
                    "beard": 0.2, "age": 0.15, "pores": 0.2, "noise": 0.15}}


def paint_head_detail(piece: Piece, character: Character) -> np.ndarray:
    """RGBA detail map of the head atlas (``HEAD_SIZE``, the UVs of :func:`paint_head`):
    tangent-space normal of the skin's fine relief (RGB; +x along u, +y along v) and a
    roughness scale (alpha: 0.5 + a / 255)."""
    region, uvs = skin_layout(piece)
    tris = piece.parts["skin"][region < 2]
    pos = piece.vertices.astype(np.float64) * CM
    at = rasterize(uvs, tris, HEAD_SIZE)
    jac = face_jacobians(pos, uvs, tris)[at.faces_at()]  # (T, 3, 2): cm per UV unit
    u0 = at.at(piece.meta.get("uv_layout", piece.uvs))
    return _paint_head_detail(at, pos, u0, jac, landmarks(piece), _phenotype(character),
                              _seed(character))


def _lines(t: np.ndarray, width: float) -> np.ndarray:
    """Furrows (0 … -1) at the integers of ``t``, ``width`` (in units of t) wide."""
    d = t - np.round(t)
    return -np.exp(-(d / width) ** 2).astype(np.float32)


def _fine_lines(p: np.ndarray, f: _Face, seed: int) -> np.ndarray:
    """Fine lines (0 … about -1) at points ``p`` (T, 3) in cm: forehead, crow's feet, under
    the eyes, above the upper lip, the neck's rings."""
    lm = f.lm
    x, y = p[:, 0], p[:, 1]
    wob = value3(p, 0.8, seed + 80) - 0.5  # lines wander and fade in and out
    fade = smoothstep(0.3, 0.6, value3(p, 0.5, seed + 81))
    out = 0.8 * f.forehead(p) * smoothstep(5.0, 3.0, np.abs(x)) \
        * _lines((y - f.brow_y) / 0.9 + 0.6 * wob, 0.07)
    for corner, side in ((lm[36], -1.0), (lm[45], 1.0)):
        q = p - corner
        lat = side * q[:, 0]
        r = np.hypot(lat, q[:, 1])
        ang = np.arctan2(q[:, 1], np.maximum(lat, 1e-6))
        where = smoothstep(0.2, 0.5, r) * smoothstep(2.2, 1.2, r) * smoothstep(0.0, 0.3, lat) \
            * smoothstep(1.1, 0.6, np.abs(ang)) * f.front(p)
        out += where * _lines(ang / 0.28 + 0.8 * wob, 0.12)
    below = f.undereye(p)
    lid = np.interp(np.abs(x), np.abs(lm[[39, 40, 41, 36], 0]), lm[[39, 40, 41, 36], 1])
    out += 0.7 * below * _lines((lid - y) / 0.22 + 0.5 * wob, 0.1)
    lip = smoothstep(0.9, 0.3, np.abs(x)) * smoothstep(lm[33, 1] - 0.2, lm[33, 1] - 0.6, y) \
        * smoothstep(lm[51, 1] - 0.1, lm[51, 1] + 0.4, y) * f.front(p)
    out += 0.6 * lip * _lines(x / 0.3 + 0.7 * wob, 0.1)
    neck = smoothstep(f.chin[1] - 1.5, f.chin[1] - 3.5, y)
    out += 0.8 * neck * _lines((y - f.chin[1]) / 1.4 + 0.5 * wob, 0.05)
    return out * (0.4 + 0.6 * fade)


def _paint_head_detail(at, pos, u0, jac, lm, ph, seed) -> np.ndarray:
    f = _Face(lm)
    p = at.at(pos)
    d = DETAIL
    cheeks, nose, tz = (at.at(g(pos)) for g in (f.cheeks, f.nose, f.tzone))
    beard = at.at(f.beard(pos)) * ph["male"]
    lips = sample(uv_mask("lips"), u0, bilinear=True)
    lids = sample(uv_mask("eyelids"), u0, bilinear=True)
    smooth = 1.0 - np.clip(lips + 0.7 * lids, 0, 1)  # lips and lids: no pores or grain
    age = float(smoothstep(22.0, 70.0, np.float32(ph["age"])))
    pores = _pores(p, seed)
    depth = 0.45 + 0.55 * np.clip(np.maximum(nose, np.maximum(cheeks, 0.8 * tz)), 0, 1)
    h = -d["pore"] * pores * depth * smooth
    h += d["grain"] * fbm3(p, d["grain_cm"], seed + 70, octaves=3, gain=0.6) * smooth
    h += d["line"] * (0.25 + 0.75 * age) * _fine_lines(p, f, seed) * smooth
    h += d["lip"] * lips * (value3(p / np.array([0.06, 0.7, 0.06]), 1.0, seed + 50, order=1)
                            - 0.5)
    r = d["rough"]
    rough = 1.0 + r["cheeks"] * cheeks + r["nose"] * nose + r["tzone"] * tz + r["lips"] * lips \
        + r["beard"] * beard + r["age"] * age + r["pores"] * pores \
        + r["noise"] * fbm3(p, 0.25, seed + 90, octaves=2)
    return _normal_map(at, h, jac, np.clip(rough, 0.5, 1.5) - 0.5)


def _normal_map(at, h: np.ndarray, jac: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """RGBA8 tangent-space normals of the heights ``h`` (T,) in cm over the atlas ``at`` whose
    texels span ``jac`` (T, 3, 2: cm per UV unit along u and v), and ``alpha`` (T,) in 0 … 1."""
    hgt = at.image(h.astype(np.float32))
    gy, gx = np.gradient(hgt)  # per texel; rows run down the image (-v)
    cm_u = at.image(np.linalg.norm(jac[:, :, 0], axis=1).astype(np.float32)) / at.w
    cm_v = at.image(np.linalg.norm(jac[:, :, 1], axis=1).astype(np.float32)) / at.h
    su = np.clip(gx / np.maximum(cm_u, 1e-6), -1, 1)
    sv = np.clip(-gy / np.maximum(cm_v, 1e-6), -1, 1)
    n = np.stack([-su, -sv, np.ones_like(su)], -1)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    rgb = np.round((n * 0.5 + 0.5) * 255.0).astype(np.uint8)
    a = np.round(np.clip(at.image(alpha.astype(np.float32)), 0, 1) * 255.0).astype(np.uint8)
    return np.concatenate([rgb, a[..., None]], -1)
