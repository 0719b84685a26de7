"""Clothes: a garment map per outfit (UV islands → fabrics, ``data/garments.json``) painted with
procedural fabrics — suit twill, pinstripes, oxford shirting, a repp-striped tie, denim with
stitched seams, jersey knit, metal buttons — plus creases darkened from the mesh's concavity.

Patterns run in each island's own frame: *along* is the island's mean texture direction of
"down the body" (the bind pose's −y on the surface), *across* is perpendicular; both in cm.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from mimika.errors import DataError
from mimika.face.makehuman.build import SCALE as CM
from mimika.face.makehuman.build import Piece
from mimika.face.makehuman.paint import color
from mimika.face.makehuman.paint.noise import fbm3, seed_of, smoothstep, value3
from mimika.face.makehuman.paint.raster import Atlas, rasterize
from mimika.face.makehuman.paint.regions import uv_islands
from mimika.face.makehuman.paint.surface import (
    adjacency,
    cavity,
    diffuse,
    face_jacobians,
    smooth_normals,
    welded,
)
from mimika.face.makehuman.paint.tables import table

SIZE = 2048


def garments() -> dict:
    """Settings per asset (``data/garments.json``)."""
    return table("garments")


def garment_map(asset: str, tris: np.ndarray, uv: np.ndarray) -> tuple[list[str], np.ndarray]:
    """Fabric names and, per triangle, the index of its fabric."""
    table = garments()
    outfit = table["outfits"].get(asset)
    if outfit is None:
        raise DataError(f"no garment map for clothes {asset!r} in paint/data/garments.json; "
                        f"mapped: {', '.join(sorted(table['outfits']))}")
    lab = uv_islands(tris, len(uv))[tris[:, 0]]
    names = sorted({outfit["default"], *outfit["islands"].values()})
    per_island = np.full(lab.max() + 1, names.index(outfit["default"]))
    for k, fabric in outfit["islands"].items():
        if int(k) <= lab.max():
            per_island[int(k)] = names.index(fabric)
    return names, per_island[lab]


def _frames(pos, uv, tris, lab) -> tuple[np.ndarray, np.ndarray]:
    """Per island: unit texture direction of "down the body" (2,), and cm per UV unit."""
    jac = face_jacobians(pos, uv, tris)
    down = np.einsum("fji,i->fj", np.linalg.pinv(jac), np.array([0.0, -1.0, 0.0]))
    uvarea = np.abs(np.linalg.det(np.stack([uv[tris[:, 1]] - uv[tris[:, 0]],
                                            uv[tris[:, 2]] - uv[tris[:, 0]]], 1)))
    scale = np.sqrt(np.linalg.norm(np.cross(jac[:, :, 0], jac[:, :, 1]), axis=1))
    w = uvarea
    nd = down / np.maximum(np.linalg.norm(down, axis=1, keepdims=True), 1e-12)
    n = lab.max() + 1
    d = np.stack([np.bincount(lab, w * nd[:, k], n) for k in (0, 1)], 1)
    d /= np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-12)
    d[np.linalg.norm(d, axis=1) < 0.5] = [0.0, -1.0]
    cm_per_uv = np.bincount(lab, w * scale, n) / np.maximum(np.bincount(lab, w, n), 1e-12)
    return d, cm_per_uv


def _aa(period_cm: float, tsz: np.ndarray) -> np.ndarray:
    """Contrast kept for a pattern of ``period_cm`` at texel size ``tsz`` (cm): fades out below
    ~3 texels per period (it would alias)."""
    return smoothstep(2.0, 4.0, period_cm / np.maximum(tsz, 1e-6))


def _line(d_cm: np.ndarray, width_cm: float, tsz: np.ndarray) -> np.ndarray:
    """Coverage of a line of ``width_cm`` at distance ``d_cm`` from its centre, box-filtered
    over the texel."""
    return np.clip((width_cm / 2 + tsz / 2 - np.abs(d_cm)) / np.maximum(tsz, 1e-6), 0, 1) * \
        np.clip(width_cm / np.maximum(tsz, 1e-6), 0, 1)


def _fabric(f: dict, a, b, p, tsz, edge, seed) -> tuple[np.ndarray, np.ndarray]:
    """Linear colour (T, 3) and gloss (T,) of fabric ``f`` at along/across cm ``a``/``b``."""
    base = color.hex_linear(f["color"])
    per = f.get("scale_mm", 0.7) * 0.1
    kind = f["pattern"]
    shade = np.ones(len(a), np.float32)
    mix_to, mix_w = None, np.zeros(len(a), np.float32)
    fibre = value3(p, 0.25, seed, order=1) - 0.5
    if kind in ("weave", "pinstripe"):
        tw = np.cos(2 * np.pi * (a + b) / per) * _aa(per, tsz)
        shade = 1.0 + 0.06 * tw + 0.08 * fibre
        if kind == "pinstripe":
            sp = f["stripe_cm"]
            d = (np.mod(b, sp) - sp / 2)
            mix_to, mix_w = color.hex_linear(f["stripe"]), 0.8 * _line(d, 0.07, tsz)
    elif kind == "oxford":
        bw = np.cos(2 * np.pi * a / per) * np.cos(2 * np.pi * b / per) * _aa(per, tsz)
        shade = 1.0 + 0.05 * bw + 0.05 * fibre
    elif kind == "repp":
        sp = f["stripe_cm"]
        diag = (a - b) / np.sqrt(2)
        d = np.mod(diag, sp) - sp / 2
        mix_to, mix_w = color.hex_linear(f["stripe"]), _line(d, 0.18 * sp, tsz)
        rib = np.cos(2 * np.pi * (a + b) / per) * _aa(per, tsz)
        shade = 1.0 + 0.08 * rib + 0.04 * fibre
    elif kind == "denim":
        tw = np.cos(2 * np.pi * (a - 2 * b) / (per * 2.2)) * _aa(per * 2.2, tsz)
        slub = value3(p / np.array([0.15, 1.5, 0.15]), 1.0, seed + 1, order=1) - 0.5
        wash = fbm3(p, 6.0, seed + 2, octaves=2)
        shade = 1.0 + 0.12 * tw + 0.12 * slub + 0.1 * wash + 0.05 * fibre
        mix_to = np.array([0.75, 0.78, 0.82], np.float32)
        mix_w = np.clip(0.08 + 0.08 * tw + 0.12 * wash, 0, 0.4)
    elif kind == "jersey":
        rib = np.cos(2 * np.pi * b / per) * _aa(per, tsz)
        shade = 1.0 + 0.06 * rib + 0.06 * fibre
    elif kind == "metal":
        shade = 1.0 + 0.1 * fibre
    c = base[None, :] * shade[:, None]
    if mix_to is not None:
        c = color.mix(c, mix_to, mix_w)
    seam = f.get("seams")
    if seam and seam != "none":  # a stitched seam 3 mm in from panel borders, dashed
        stitch = _line(edge - 0.3, 0.06, tsz) * (np.mod(a, 0.35) < 0.22)
        c = color.mix(c, color.hex_linear(seam), 0.85 * stitch)
        c = c * (1.0 - 0.25 * np.exp(-(edge / 0.12) ** 2))[:, None]  # seam shadow
    return c, np.full(len(a), f.get("gloss", 0.3), np.float32)


def _tie(p: np.ndarray, island_pos: np.ndarray) -> np.ndarray:
    """Coverage of a tie (knot under the collar, blade widening downward) at points ``p``
    (cm) on the shirt front whose vertices are ``island_pos``."""
    front = island_pos[np.abs(island_pos[:, 0]) < 1.5]
    top = float(front[:, 1].max()) - 0.4
    y = top - p[:, 1]  # cm below the knot's top
    knot = np.interp(y, [0.0, 2.6, 3.4], [2.0, 1.6, 1.3])
    blade = 1.3 + 0.09 * np.clip(y - 3.4, 0, None)
    half = np.where(y < 3.4, knot, np.minimum(blade, 4.0))
    x = np.abs(p[:, 0])
    inside = np.clip((half - x) / 0.08, 0, 1) * (y > -0.1)
    return inside.astype(np.float32), half, x, y


def paint_cloth(piece: Piece, asset: str, seed_key: str = "") -> np.ndarray:
    """RGBA (alpha: gloss) texture of a clothes piece made from ``asset``."""
    tris = np.concatenate(list(piece.parts.values()))
    uv = piece.uvs
    pos = piece.vertices.astype(np.float64) * CM
    names, fab = garment_map(asset, tris, uv)
    lab = uv_islands(tris, len(uv))[tris[:, 0]]
    down, cm_per_uv = _frames(pos, uv, tris, lab)
    at: Atlas = rasterize(uv, tris, (SIZE, SIZE))
    fid = at.faces_at()
    t = at.texels
    px = np.column_stack([(t % SIZE + 0.5) / SIZE, 1.0 - (t // SIZE + 0.5) / SIZE])  # uv
    isl = lab[fid]
    d = down[isl]
    scale = cm_per_uv[isl]
    a = (px[:, 0] * d[:, 0] + px[:, 1] * d[:, 1]) * scale  # cm along "down"
    b = (px[:, 0] * -d[:, 1] + px[:, 1] * d[:, 0]) * scale  # cm across
    tsz = (scale / SIZE).astype(np.float32)
    p = at.at(pos)
    edge = _panel_edge(at) * tsz

    seed = seed_of("cloth", asset, seed_key)
    c = np.zeros((len(t), 3), np.float32)
    g = np.zeros(len(t), np.float32)
    table = garments()["fabrics"]
    kind_t = fab[fid]
    for k, name in enumerate(names):
        sel = kind_t == k
        if sel.any():
            c[sel], g[sel] = _fabric(table[name], a[sel], b[sel], p[sel], tsz[sel], edge[sel],
                                     seed + k)
    outfit = garments()["outfits"][asset]
    for ins in outfit.get("inserts", []):
        if ins["shape"] != "tie":
            continue
        for i in ins["islands"]:
            sel = isl == i
            if not sel.any():
                continue
            ipos = pos[np.unique(tris[lab == i])]
            cov, half, x, y = _tie(p[sel], ipos)
            tc, tg = _fabric(table[ins["fabric"]], y, x, p[sel], tsz[sel], edge[sel], seed + 99)
            # the blade's edges roll away from the light, the knot sits in shadow
            tc = tc * (1.0 - 0.35 * smoothstep(0.6, 1.0, x / np.maximum(half, 1e-3)))[:, None]
            tc = tc * (1.0 - 0.3 * smoothstep(2.2, 3.3, y) * smoothstep(4.2, 3.3, y))[:, None]
            shadow = np.clip((half + 0.35 - x) / 0.35, 0, 1) * (1 - cov) * (y > 0.0)
            c[sel] = color.mix(c[sel] * (1 - 0.35 * shadow)[:, None], tc, cov)
            g[sel] = g[sel] * (1 - cov) + tg * cov

    # creases: concave places darker, folds' ridges a touch lighter
    nrm = smooth_normals(pos, tris, piece.weld)
    key, m = welded(len(pos), piece.weld)
    avg = adjacency(tris, key, m)
    cav = np.clip(diffuse(cavity(pos, nrm, avg, key, m), avg, 2)[key] * 3.0, -1, 1)
    cv = at.at(cav)
    c = c * (1.0 - 0.35 * np.clip(cv, 0, 1) + 0.06 * np.clip(-cv, 0, 1))[:, None]
    return at.image(color.rgba8(c, g))


def _panel_edge(at: Atlas) -> np.ndarray:
    """Per covered texel: distance in texels to its island's border (panel seams)."""
    dist = ndimage.distance_transform_edt(at.covered)
    return dist.ravel()[at.texels].astype(np.float32)
