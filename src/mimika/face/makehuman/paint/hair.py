"""Hair strands with alpha for the MakeHuman hair proxies (shells and cards).

Strands are laid out analytically, not by tracing: on the big shells a strand is a line of
constant azimuth about a *pole* (the crown, or a ponytail's band) — so strands converge at the
crown, fall straight down long hair and run on across UV seams; on small cards (locks, tufts,
which often share texture space) strands run straight along the card's own root→tip direction
in texture space. Each texel gets a strand coordinate (cm across the strands) and an along
coordinate; clumps, strands and fibres are 1-D noise tables over the across coordinate.
Strand tips thin out near the mesh's open border (distance in cm, each strand ending at its own
random length), which softens the hairline and the ends; roots (near the scalp) are darker.
Curly styles (``curl`` > 0) use contour lines of 3-D noise instead.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from mimika.face.makehuman.build import SCALE as CM
from mimika.face.makehuman.build import Piece
from mimika.face.makehuman.character_file import Character
from mimika.face.makehuman.paint import color
from mimika.face.makehuman.paint.noise import fbm3, seed_of, smoothstep, value3
from mimika.face.makehuman.paint.raster import Atlas, rasterize
from mimika.face.makehuman.paint.regions import uv_islands
from mimika.face.makehuman.paint.surface import boundary_edges, face_jacobians
from mimika.face.makehuman.paint.tables import table

#: islands smaller than this (cm²) are cards: strands straight in texture space
CARD_CM2 = 250.0
#: how long a strand shows on the surface before it dives under others (cm, random around it)
SEGMENT_CM = 0.5
#: how many tapered locks end together at a fringe or hairline (a clump)
CLUMP_LOCKS = 6.0
#: opacity of a lock at its very tip (it grows to 1 over its taper)
TIP_OPACITY = 0.3


def styles() -> dict:
    """Settings per asset (``data/hair.json``)."""
    return table("hair")


def style(name: str) -> dict:
    """Settings of hair style ``name`` (a default for styles the table lacks)."""
    return styles().get(name, styles()["short02"])


def is_coily(name: str | None) -> bool:
    """Whether hair style ``name`` is coily (drawn as coils, without one strand direction)."""
    return style(name or "").get("curl", 0) > 0


class _Table:
    """A periodic 1-D random table read with linear interpolation."""

    def __init__(self, n: int, seed: int) -> None:
        self.v = np.random.default_rng(seed).random(n).astype(np.float32)
        self.n = n

    def __call__(self, x: np.ndarray) -> np.ndarray:
        i = np.floor(x)
        f = (x - i).astype(np.float32)
        i = i.astype(np.int64) % self.n
        return self.v[i] * (1 - f) + self.v[(i + 1) % self.n] * f

    def strands(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Strands one unit wide across ``x``: each one's random value and where ``x`` lies
        in it (0 … 1 from side to side)."""
        i = np.floor(x)
        return self.v[i.astype(np.int64) % self.n], (x - i).astype(np.float32)


def _locks(table: _Table, x: np.ndarray, grown: np.ndarray, soft: np.ndarray
           ) -> np.ndarray:
    """Coverage of tapered locks one unit wide across ``x`` whose tips lie where ``grown``
    (0 at the tip … 1 at full width) rises; ``soft``: a texel's width in those units (the
    edges are anti-aliased over it)."""
    r, f = table.strands(x)
    # each lock ends at its own length, its neighbours' alike: clumps of locks about
    # :data:`CLUMP_LOCKS` wide taper together (independent lengths read as a saw blade)
    r = 0.4 * r + 0.6 * table(x / CLUMP_LOCKS + 1000.5)
    u = np.clip(grown - 0.6 * r, 0.0, 1.0) / 0.4
    half = 0.5 * np.sqrt(np.clip(u, 0.0, 1.0))
    # a lock thins to a few strands before it ends: its last part is see-through; one
    # narrower than a texel covers only its share of it
    soft = np.maximum(soft, 0.05)
    sheer = (TIP_OPACITY + (1.0 - TIP_OPACITY) * smoothstep(0.0, 1.0, u)) * \
        np.clip(2.0 * half / soft, 0.0, 1.0)
    return sheer * smoothstep(0.0, 1.0, (half - np.abs(f - 0.5)) / soft + 0.5)


def _cells(p: np.ndarray, size: float, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Cellular (Worley) noise at points ``p`` (T, 3) cm, cells ``size`` cm: the distances
    to the nearest and second-nearest feature points (in cells) and a random value per
    nearest cell."""
    q = np.asarray(p, np.float64) / size
    base = np.floor(q).astype(np.int64)
    rnd = np.random.default_rng(seed).random((4096, 4))
    d1 = np.full(len(q), np.inf)
    d2 = np.full(len(q), np.inf)
    r1 = np.zeros(len(q))
    for off in np.stack(np.meshgrid(*[[-1, 0, 1]] * 3, indexing="ij"), -1).reshape(-1, 3):
        c = base + off
        r = rnd[(c * np.array([73856093, 19349663, 83492791])).sum(1) % 4096]
        d = np.linalg.norm(c + r[:, :3] - q, axis=1)
        closer = d < d1
        d2 = np.where(closer, d1, np.minimum(d2, d))
        r1 = np.where(closer, r[:, 3], r1)
        d1 = np.where(closer, d, d1)
    return d1.astype(np.float32), d2.astype(np.float32), r1.astype(np.float32)


def _border_distance(at: Atlas, uv: np.ndarray, tris: np.ndarray, weld, island: np.ndarray
                     ) -> np.ndarray:
    """Per covered texel: distance in texels to the open border (UV seams excluded) of its
    own UV island — cards often share texture space, so each island is measured alone."""
    e = boundary_edges(tris, weld)
    e_isl = island[e[:, 0]]
    px = np.column_stack([uv[:, 0] * at.w, (1 - uv[:, 1]) * at.h])
    tex_isl = island[tris[at.faces_at(), 0]]
    t = at.texels
    ty, tx = t // at.w, t % at.w
    out = np.full(len(t), 0.0, np.float32)
    for i in np.unique(tex_isl):
        sel = tex_isl == i
        ei = e[e_isl == i]
        if not len(ei):
            out[sel] = 1e3  # a closed island: no border
            continue
        a, b = px[ei[:, 0]], px[ei[:, 1]]
        n = np.ceil(np.linalg.norm(b - a, axis=1) * 2).astype(np.int64) + 1
        k = (np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n)) / np.repeat(n - 1, n).clip(1)
        pts = np.repeat(a, n, 0) + k[:, None] * np.repeat(b - a, n, 0)
        x0, y0 = int(min(tx[sel].min(), pts[:, 0].min())) - 1, \
            int(min(ty[sel].min(), pts[:, 1].min())) - 1
        x1, y1 = int(max(tx[sel].max(), pts[:, 0].max())) + 2, \
            int(max(ty[sel].max(), pts[:, 1].max())) + 2
        mask = np.ones((y1 - y0, x1 - x0), bool)
        mask[(pts[:, 1] - y0).astype(np.int64), (pts[:, 0] - x0).astype(np.int64)] = False
        out[sel] = ndimage.distance_transform_edt(mask)[ty[sel] - y0, tx[sel] - x0]
    return out


def _frame(axis) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    a = np.asarray(axis, np.float64)
    a /= np.linalg.norm(a)
    e1 = np.cross(a, [0.0, 0.0, 1.0]) if abs(a[2]) < 0.9 else np.cross(a, [1.0, 0.0, 0.0])
    e1 /= np.linalg.norm(e1)
    return a, e1, np.cross(a, e1)


def _pole_coords(p: np.ndarray, pole: np.ndarray, axis) -> tuple[np.ndarray, np.ndarray]:
    """Azimuth (radians) about the pole's axis and distance from the pole (cm)."""
    _, e1, e2 = _frame(axis)
    d = p - pole
    return np.arctan2(d @ e2, d @ e1), np.linalg.norm(d, axis=1)


def _poles(st: dict, pos: np.ndarray) -> list[tuple[np.ndarray, np.ndarray, float]]:
    """(pole point cm, axis, applies below y) for the style on this hair mesh."""
    top = pos[np.argmax(pos[:, 1])]
    ref = np.array([0.0, top[1], top[2]])
    out = [(ref + st["pole"], np.asarray(st["axis"], float), np.inf)]
    if "tail" in st:
        t = st["tail"]
        out.append((ref + t["pole"], np.asarray(t["axis"], float), top[1] - t["below_cm"]))
    return out


def _strand_way(p: np.ndarray, poles: list) -> np.ndarray:
    """The strands' root→tip direction at points ``p`` (cm; not unit): away from the first
    pole, straight down below a tail's band."""
    way = p - poles[0][0]
    for *_, below in poles[1:]:
        way[p[:, 1] < below] = [0.0, -1.0, 0.0]
    return way


def paint_hair_flow(piece: Piece, character: Character) -> np.ndarray:
    """RGB flow map of the hair piece for the renderer's strand highlights: per texel the
    strands' root→tip direction — away from the style's pole, straight down below a tail's
    band — as (a, b) in red and green (0.5 + 0.5·, unit), the direction on the surface being
    a·∇u + b·∇v (the frame a renderer rebuilds from the UVs' screen derivatives, as for
    normal maps); in blue how well the surface carries it (1: along the surface)."""
    st = style(character.hair or "")
    size = int(st["size"]) // 2
    uv = piece.uvs
    tris = np.concatenate(list(piece.parts.values()))
    pos = piece.vertices.astype(np.float64) * CM
    at = rasterize(uv, tris, (size, size))
    p = at.at(pos)
    flow = _strand_way(p, _poles(st, pos))
    flow /= np.maximum(np.linalg.norm(flow, axis=1, keepdims=True), 1e-12)
    jac = face_jacobians(pos, uv, tris)[at.faces_at()]  # (T, 3, 2): ∂p/∂u, ∂p/∂v
    ab = np.einsum("tij,ti->tj", jac, flow)  # (∇u, ∇v)ᵀ (a, b) = the flow in the plane
    ab /= np.maximum(np.linalg.norm(ab, axis=1, keepdims=True), 1e-12)
    # where the way out from the pole pierces a triangle (crumpled cards), its shadow in the
    # triangle's plane is short and its direction there is noise
    n = np.cross(jac[:, :, 0], jac[:, :, 1])
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
    carried = np.sqrt(np.clip(1.0 - np.einsum("ti,ti->t", flow, n) ** 2, 0.0, 1.0))
    rgb = np.column_stack([0.5 + 0.5 * ab, carried])
    return at.image(np.round(rgb * 255).astype(np.uint8))


def _across(at: Atlas, p: np.ndarray, pos, uv, tris, jac, tsz, st: dict, poles
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per texel: the across-strand coordinate (cm; on shells measured 10 cm from the pole),
    the local strand spacing relative to that (strands converge toward the pole), and whether
    the texel is on a card."""
    fid = at.faces_at()
    across = np.zeros(len(p), np.float32)
    n_around = max(int(2 * np.pi * 10.0 / st["strand_cm"]), 64)
    for pole, axis, below in poles:
        sel = p[:, 1] < below
        phi, _ = _pole_coords(p[sel], pole, axis)
        across[sel] = phi / (2 * np.pi) * n_around * st["strand_cm"]
    a0, *_ = _frame(poles[0][1])
    rad = np.linalg.norm(np.cross(p - poles[0][0], a0), axis=1).astype(np.float32)
    scale = np.clip(rad / 10.0, 0.05, None)

    # cards: straight strands along the island's mean root→tip direction in texture space
    lab = uv_islands(tris, len(uv))[tris[:, 0]]
    area3 = np.linalg.norm(np.cross(jac[:, :, 0], jac[:, :, 1]), axis=1)
    uvarea = np.abs(np.linalg.det(np.stack([uv[tris[:, 1]] - uv[tris[:, 0]],
                                            uv[tris[:, 2]] - uv[tris[:, 0]]], 1)))
    w = area3 * uvarea  # twice the triangle's area, cm²
    card = (np.bincount(lab, 0.5 * w, lab.max() + 1)[lab] < CARD_CM2)[fid]
    if card.any():
        flow3 = _strand_way(pos[tris].mean(1), poles)
        flow_uv = np.einsum("fji,fi->fj", np.linalg.pinv(jac), flow3)  # (F, 2)
        flow_uv /= np.maximum(np.linalg.norm(flow_uv, axis=1, keepdims=True), 1e-12)
        mean = np.stack([np.bincount(lab, w * flow_uv[:, k]) for k in (0, 1)], 1)
        d = (mean / np.maximum(np.linalg.norm(mean, axis=1, keepdims=True), 1e-12))[lab[fid]]
        t = at.texels
        tx = np.column_stack([t % at.w + 0.5, at.h - (t // at.w + 0.5)])  # texel, v up
        q = (tx[:, 0] * -d[:, 1] + tx[:, 1] * d[:, 0]) * tsz  # cm across
        across[card] = q[card]
        scale[card] = 1.0
    return across, scale, card


def paint_hair(piece: Piece, character: Character) -> np.ndarray:
    """RGBA (sRGB, straight alpha) strand texture for the hair piece."""
    st = style(character.hair or "")
    size = int(st["size"])
    uv = piece.uvs
    tris = np.concatenate(list(piece.parts.values()))
    pos = piece.vertices.astype(np.float64) * CM
    at = rasterize(uv, tris, (size, size))
    p = at.at(pos)
    jac = face_jacobians(pos, uv, tris)  # (F, 3, 2) cm per UV unit
    cm_tex = np.sqrt(np.linalg.norm(np.cross(jac[:, :, 0], jac[:, :, 1]), axis=1)) / size
    tsz = cm_tex.astype(np.float32)[at.faces_at()]  # cm per texel
    island = uv_islands(tris, len(uv))
    dist = _border_distance(at, uv, tris, piece.weld, island) * tsz
    seed = seed_of("hair", character.hair, character.hair_color, character.name)
    poles = _poles(st, pos)
    across, scale, card = _across(at, p, pos, uv, tris, jac, tsz, st, poles)
    n_around = max(int(2 * np.pi * 10.0 / st["strand_cm"]), 64)
    qn = across + 0.5 * st["wave_cm"] * fbm3(p, 3.0, seed + 1, octaves=2) / np.maximum(scale,
                                                                                       0.3)

    def octave(spacing: float, k: int) -> np.ndarray:
        v = _Table(max(round(n_around * st["strand_cm"] / spacing), 16), seed + k)(
            qn / np.float32(spacing))
        # fade an octave out where its strands get narrower than ~2 texels (aliasing)
        keep = smoothstep(1.0, 2.5, spacing * scale / np.maximum(tsz, 1e-6))
        return 0.5 + (v - 0.5) * keep

    # fade: how far from the border strands end (narrow cards and tufts keep a body of hair)
    isl = island[tris[at.faces_at(), 0]]
    deepest = np.zeros(isl.max() + 1, np.float32)
    np.maximum.at(deepest, isl, dist)
    fade = np.clip(0.4 * deepest[isl], 0.03, float(st["fade_cm"]))
    edge = smoothstep(0.0, fade, dist)
    base = color.hex_linear(character.hair_color)
    if st.get("curl", 0) > 0:
        tone, alpha = _coils(p, st, seed, dist, fade, card)
    else:
        clump = octave(st["clump_cm"], 11)
        strand = octave(st["strand_cm"] * 3, 12)
        # the finest strands the texture resolves: lines with darker gaps; away from the
        # pole, where strands diverge, ever finer octaves take over (strands stay as fine)
        level = np.log2(np.maximum(scale, 1.0))
        fibre = sum(np.clip(1.0 - np.abs(level - k), 0.0, 1.0) * (octave(
            _fine_cm(st, tsz) / 2 ** k, 13 + 4 * k) - 0.5) for k in range(3)) + 0.5
        # the gaps between strands close and open along them (strands cross and weave)
        gap = smoothstep(0.3, 0.05, fibre) * smoothstep(0.3, 0.6, value3(p, 0.4, seed + 18,
                                                                         order=1))
        tone = (1.0 + 0.12 * (clump - 0.5) + 0.15 * (strand - 0.5) + 0.3 * (fibre - 0.5)) * \
            (1.0 - 0.3 * gap) * (1.0 + 0.06 * fbm3(p, 1.2, seed + 9, octaves=2))
        # strand ends: tapered locks a few texels wide, each ending at its own length,
        # two rows offset by half a lock so the hair is whole where the locks are grown
        lock_cm = max(0.07, 3.0 * float(np.median(tsz)))
        grown = np.clip(dist / fade, 0.0, 1.0)
        soft = tsz / (lock_cm * np.maximum(scale, 0.3))
        x = qn / (lock_cm * np.maximum(scale, 0.3))
        tables = [_Table(4096, seed + 14 + k) for k in range(2)]
        alpha = np.maximum(_locks(tables[0], x, grown, soft), _locks(tables[1], x + 0.5, grown,
                                                                      soft))
        alpha = np.where(dist >= fade, 1.0, alpha)

    # colour: darker roots near the scalp, lighter tips
    # at the crown strands converge below the texture's resolution: a whorl of short hairs
    whorl = 1.0 - smoothstep(1.0, 2.5, st["strand_cm"] * 3 * scale / np.maximum(tsz, 1e-6))
    if st.get("curl", 0) <= 0:
        tone = tone + 0.3 * whorl * (value3(p, 0.09, seed + 8, order=1) - 0.5)
    lift = at.at(np.linalg.norm(piece.meta.get("offsets", np.zeros_like(pos)), axis=1) * CM)
    root = 1.0 - smoothstep(0.15, 1.2, lift)
    tone = tone * (1.0 - st["root_dark"] * root) * (1.0 + 0.12 * (1.0 - edge))
    _, along = _pole_coords(p, *poles[0][:2])
    c = _grey_strands(base[None, :] * tone[:, None], base, qn * np.maximum(scale, 1.0) ** 0.5,
                      along.astype(np.float32), seed, _fine_cm(st, tsz))
    return at.image(color.rgba8(c, alpha))


def _fine_cm(st: dict, tsz: np.ndarray) -> float:
    """The finest strand spacing (cm) the texture resolves (~2.5 texels)."""
    return max(st["strand_cm"] * 1.5, 2.5 * float(np.median(tsz)))


def _coils(p: np.ndarray, st: dict, seed: int, dist: np.ndarray, fade: np.ndarray,
           card: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Coily hair: coils ``curl`` cm across (cellular noise), lit on top and dark in the
    crevices between them, fine spiralling strands inside each; on the halo cards and at the
    hairline coils stand out one by one (alpha by coil, not a uniform fuzz). Returns the
    tone and alpha per texel."""
    cs = float(st["curl"])
    # irregular, rounded coils: cells over warped positions
    warp = np.stack([fbm3(p, cs * 2.0, seed + 20 + k, octaves=2) for k in range(3)], 1)
    d1, d2, r = _cells(p + 0.3 * cs * warp, cs, seed + 3)
    crevice = smoothstep(0.0, 0.3, d2 - d1)  # 0 between coils
    top = 1.0 - smoothstep(0.15, 0.95, d1)  # 1 at a coil's centre
    spiral = 0.5 + 0.5 * np.sin(2 * np.pi * (3.0 * d1 + r) + 4.0 * fbm3(p, cs, seed + 4,
                                                                        octaves=1))
    fibre = value3(p, cs * 0.25, seed + 6, order=1)
    tone = (0.75 + 0.35 * top) * (0.75 + 0.25 * crevice) * (0.88 + 0.24 * r) * \
        (0.85 + 0.3 * spiral) * (0.8 + 0.4 * fibre)
    # coverage: whole coils, their edges soft; toward a border only the coils' cores remain
    grown = np.clip(dist / np.maximum(fade, 1e-3), 0.0, 1.0)
    body = smoothstep(0.0, 0.25, crevice * (0.4 + 0.6 * top) - 0.6 * (1.0 - grown))
    alpha = np.where(grown >= 1.0, 1.0, body)
    # halo cards stay translucent (seen edge-on, opaque ones draw dark lines): a fine frizz
    # of single hairs (drawn by whole coils, they read as a lace of dark blobs around the
    # head)
    frizz = smoothstep(0.45, 0.8, value3(p, cs * 0.15, seed + 7, order=1)) * \
        (0.6 + 0.4 * fibre)
    alpha = np.where(card, 0.5 * frizz * smoothstep(0.0, 0.3, grown), alpha)
    return tone, alpha


def _grey_strands(c: np.ndarray, base: np.ndarray, across: np.ndarray, along: np.ndarray,
                  seed: int, fine_cm: float) -> np.ndarray:
    """Greying hair: a share of thin white strands among darker ones (mean tone kept); each
    shows on the surface over lengths of a few millimetres (``along``: cm along the strands)
    and dives under its neighbours between them, so they read as single hairs, not lines."""
    s = color.to_srgb8(base).astype(np.float32) / 255.0
    sat = (s.max() - s.min()) / max(float(s.max()), 1e-6)
    grey = float(smoothstep(0.3, 0.15, np.float32(sat)) * smoothstep(0.2, 0.35,
                                                                      np.float32(s.max())))
    if grey <= 0:
        return c
    share = 0.3  # white strands
    r, f = _Table(4096, seed + 16).strands(across / np.float32(fine_cm))
    shows = smoothstep(0.45, 0.6, _Table(4096, seed + 17)(along / np.float32(SEGMENT_CM)
                                                           + 997.0 * r))
    white = (r < share) * smoothstep(0.35, 0.15, np.abs(f - 0.5)) * shows
    lum = float(color.luminance(base))
    # white hair is faintly yellow (keratin) and takes a little of its neighbours' colour;
    # neutral grey read as light-blue dashes under the studio's sky-blue ambient
    tint = 0.5 + 0.5 * base / max(lum, 1e-6)
    light = (min(1.25 * lum, 0.5) * tint / float(color.luminance(tint))).astype(np.float32)
    k = float(white.mean())
    dark = np.maximum(base - k * light, 0.2 * base) / (1 - k)
    mixed = dark[None, :] * (1 - white[:, None]) + light[None, :] * white[:, None]
    mixed *= (c / np.maximum(base, 1e-6)).mean(1, keepdims=True)
    return c * (1 - grey) + mixed * grey
