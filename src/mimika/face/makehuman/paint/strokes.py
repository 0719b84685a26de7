"""Brow and lash hairs: individual tapered strokes with alpha, drawn per card.

Each card (one UV island: a brow, an upper or lower lash row) gets card coordinates per vertex
from its bind-pose geometry — ``s`` along the card from the nose outward, ``t`` across it
(brows bottom→top, lashes root→tip). Hairs are drawn as anti-aliased polylines on a canvas in
(s, t) at the card's physical size (Pillow, supersampled), and every texel reads the canvas at
its interpolated (s, t). Settings per asset: ``data/strokes.json``.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from PIL import Image, ImageDraw
from scipy import ndimage
from scipy.sparse.csgraph import dijkstra

from mimika.face.makehuman.build import SCALE as CM
from mimika.face.makehuman.build import Piece
from mimika.face.makehuman.character_file import Character
from mimika.face.makehuman.paint import color
from mimika.face.makehuman.paint.noise import seed_of, smoothstep
from mimika.face.makehuman.paint.raster import rasterize
from mimika.face.makehuman.paint.regions import uv_islands
from mimika.face.makehuman.paint.surface import boundary_edges
from mimika.face.makehuman.paint.tables import table

SIZE = 1024
#: canvas resolution (cm per pixel) and supersampling of the drawing
CANVAS_CM = 0.004
SUPER = 3
#: hair density at a brow's inner end, relative to its body
HEAD_DENSITY = 0.8
#: where a brow begins on its card, as a share of the card's width from its inner end
BROW_START = 0.08


def settings() -> dict:
    """Settings per asset (``data/strokes.json``)."""
    return table("strokes")


def _across(pos: np.ndarray, tris: np.ndarray, s: np.ndarray, up: np.ndarray
            ) -> tuple[np.ndarray, float]:
    """Per vertex of one card: ``t`` in [0, 1] from its lower border (``up`` smaller) to its
    upper border, by geodesic distances over the card's edges; and the card's mean height (cm).
    Border vertices are split into the two sides by ``up`` against its median along ``s``."""
    n = len(pos)
    e = np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]])
    w = np.linalg.norm(pos[e[:, 0]] - pos[e[:, 1]], axis=1)
    g = sp.coo_matrix((w, (e[:, 0], e[:, 1])), shape=(n, n)).tocsr()
    border = np.unique(boundary_edges(tris))
    bins = np.clip((s * 12).astype(int), 0, 11)
    med = np.array([np.median(up[bins == k]) if np.any(bins == k) else np.nan
                    for k in range(12)])
    med = np.interp(np.arange(12), np.flatnonzero(~np.isnan(med)), med[~np.isnan(med)])
    hi = up[border] > med[bins[border]]
    lo_v, hi_v = border[~hi], border[hi]
    d0 = dijkstra(g, directed=False, indices=lo_v, min_only=True)
    d1 = dijkstra(g, directed=False, indices=hi_v, min_only=True)
    t = d0 / np.maximum(d0 + d1, 1e-9)
    return t, float(np.median((d0 + d1)[np.isfinite(d0 + d1)]))


def _along(pos: np.ndarray, tris: np.ndarray) -> np.ndarray:
    """Per vertex of a card: the share of the way from one end to the other (ends: the
    extremes along its longest axis), by geodesic distances over its edges. (An angle around
    the eyeball folds back on lash rows that curl, smearing hairs into bands.)"""
    n = len(pos)
    e = np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]])
    w = np.linalg.norm(pos[e[:, 0]] - pos[e[:, 1]], axis=1)
    g = sp.coo_matrix((w, (e[:, 0], e[:, 1])), shape=(n, n)).tocsr()
    axis = np.linalg.svd(pos - pos.mean(0), full_matrices=False)[2][0]
    x = pos @ axis
    d0, d1 = dijkstra(g, directed=False, indices=[int(x.argmin()), int(x.argmax())])
    return d0 / np.maximum(d0 + d1, 1e-9)


def _cards(pos: np.ndarray, tris: np.ndarray, lab: np.ndarray, kind: str):
    """Per island: (vertex ids, s, t, length cm, height cm, is_lower) in card coordinates."""
    out = []
    eyes = {}
    if kind == "lash":  # an eyeball centre per side from the lash rows around it
        for side in (-1, 1):
            q = pos[np.sign(pos[:, 0]) == side]
            eyes[side] = np.array([q[:, 0].mean(), q[:, 1].mean(), q[:, 2].min() - 0.9])
    tri_lab = lab[tris[:, 0]]
    for i in range(lab.max() + 1):
        ids = np.flatnonzero(lab == i)
        local = np.full(len(pos), -1)
        local[ids] = np.arange(len(ids))
        ltris = local[tris[tri_lab == i]]
        p = pos[ids]
        ax = np.abs(p[:, 0])
        s = _along(p, ltris)
        if np.corrcoef(s, ax)[0, 1] < 0:
            s = 1.0 - s  # s grows away from the nose
        if kind == "brow":
            up, lower = p[:, 1], False
        else:
            side = 1 if p[:, 0].mean() > 0 else -1
            lower = bool(p[:, 1].mean() < eyes[side][1])
            up = np.linalg.norm(p - eyes[side], axis=1)  # roots on the lid, tips farther out
        t, height = _across(p, ltris, s, up)
        if kind == "lash" and p[t > 0.9, 2].mean() < p[t < 0.1, 2].mean():
            t = 1.0 - t  # lashes grow forward from the lid margin
        order = np.argsort(s)
        length = float(np.linalg.norm(np.diff(p[order], axis=0), axis=1).sum())
        length = min(length, 1.2 * float(np.linalg.norm(p[order[-1]] - p[order[0]])) + 0.3)
        out.append((ids, s, t, length, height, lower))
    return out


def _lid_spans(pos: np.ndarray, cards: list) -> list[tuple[float, float]]:
    """Per lash card, the stretch of ``s`` along the lid opening: an upper row may run on past
    the outer corner of the eye (a wing toward the temple, eyelashes02–04), where lashes drawn
    read as an eyeliner line up to the brow; the opening is the lower row's reach on that side
    (its ends are the eye's corners). Rows without a lower partner keep their whole length."""
    reach = {}
    for ids, _, _, _, _, lower in cards:
        if lower:
            x = pos[ids, 0]
            reach[np.sign(x.mean())] = (np.abs(x).min(), np.abs(x).max())
    spans = []
    for ids, s, _, _, _, lower in cards:
        x = pos[ids, 0]
        side = reach.get(np.sign(x.mean()))
        inside = None if lower or side is None else \
            (np.abs(x) >= side[0] - 0.1) & (np.abs(x) <= side[1] + 0.1)
        spans.append((0.0, 1.0) if inside is None or not inside.any()
                     else (float(s[inside].min()), float(s[inside].max())))
    return spans


def _draw(strokes, size: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """Rasterise strokes [(points (k, 2) px, widths (k,) px, tone in [0, 2])] → coverage and
    tone."""
    w, h = size
    cov = Image.new("L", (w * SUPER, h * SUPER), 0)
    ton = Image.new("L", (w * SUPER, h * SUPER), 0)
    dc, dt = ImageDraw.Draw(cov), ImageDraw.Draw(ton)
    for pts, widths, tone in strokes:
        q = pts * SUPER
        for k in range(len(q) - 1):
            wd = max(round(widths[k] * SUPER), 1)
            seg = [tuple(q[k]), tuple(q[k + 1])]
            dc.line(seg, fill=255, width=wd)
            dt.line(seg, fill=int(np.clip(tone / 2, 0, 1) * 255), width=wd)
    a = np.asarray(cov.reduce(SUPER), np.float32) / 255.0
    t = np.asarray(ton.reduce(SUPER), np.float32) * (2 / 255.0)
    return a, np.where(a > 1e-3, t / np.maximum(a, 1e-3), 1.0)


def _stroke(root, angle, length, width, bend, n=6):
    """A curved tapering hair: points and widths (canvas px)."""
    k = np.linspace(0, 1, n)
    ang = angle + bend * k
    step = length / (n - 1)
    d = np.stack([np.cos(ang), np.sin(ang)], 1) * step
    pts = root + np.concatenate([[[0, 0]], np.cumsum(d[:-1], 0)])
    return pts, width * (1.0 - 0.75 * k)


def _brow_shape(st: dict, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Centre line and thickness (shares of the card height) of the brow along ``s``."""
    thick = st["head"] + (st["tail"] - st["head"]) * np.clip((s - 0.15) / 0.85, 0, 1) ** 1.2
    thick = thick * np.clip(s / 0.06, 0.35, 1.0) * np.clip((1.0 - s) / 0.04, 0.2, 1.0)
    s = np.clip(s, 0, 1)
    centre = st["centre"] + st["arch"] * (np.sin(np.pi * s ** 0.8) - 0.25 - 0.25 * s) * 0.5
    return centre, thick


def _density(s: np.ndarray) -> np.ndarray:
    """Share of a brow's hairs along it: sparse and light at the head (a dense, dark head
    reads as a knitted brow), densest in the body, thinning to the tail."""
    return (HEAD_DENSITY + (1.0 - HEAD_DENSITY) * smoothstep(0.0, 0.25, s)) \
        * np.clip(1.0 - 0.6 * (s - 0.25) / 0.75, 0.3, 1.0)


def _brow_start(p: np.ndarray, s: np.ndarray) -> float:
    """Where along a brow card (share of ``s``) the brow's head sits: :data:`BROW_START` of the
    way out from the card's inner end across its width (``|x|``). MakeHuman's cards run on over the
    glabella toward the nose; a brow drawn from there sits low and close to its twin and
    reads as a frown (AU4) at rest."""
    ax = np.abs(p[:, 0])
    at = ax.min() + BROW_START * (ax.max() - ax.min())
    order = np.argsort(s)
    return float(np.interp(at, np.maximum.accumulate(ax[order]), s[order]))


def brow_canvas(length_cm: float, height_cm: float, st: dict, seed: int, start: float = 0.0
                ) -> tuple[np.ndarray, np.ndarray]:
    """Coverage and tone canvases (y up = t) of one brow: a soft base of fine hairs under
    individual strokes whose direction turns from upright (inner end) to lateral (tail).
    The brow begins ``start`` (a share of the card's length) from the card's inner end."""
    rng = np.random.default_rng(seed)
    w = max(int(length_cm / CANVAS_CM), 8)
    h = max(int(height_cm / CANVAS_CM), 8)
    px = 1.0 / CANVAS_CM  # px per cm
    n = int(st["count"])
    s = rng.random(n * 3)
    v = rng.uniform(-1, 1, n * 3)
    keep = rng.random(n * 3) < _density(s)
    s, v = s[keep][:n], v[keep][:n]
    stray = rng.random(len(s)) < st["fade"]
    v = np.where(stray, v * 1.6, v)
    centre, thick = _brow_shape(st, s)
    y = (centre + 0.5 * thick * v) * h
    x = (start + (1.0 - start) * s) * w
    lift = np.radians(st["lift_deg"])
    base = np.where(s < 0.12, np.radians(70), np.radians(70) + (lift - np.radians(70))
                    * np.clip((s - 0.12) / 0.2, 0, 1))
    base = base - np.radians(18) * np.clip((s - 0.7) / 0.3, 0, 1)  # the tail points down
    ang = base - np.radians(10) * v + np.radians(st["jitter_deg"]) * rng.standard_normal(len(s))
    length = st["length_cm"] * px * (0.6 + 0.4 * rng.random(len(s))) * np.where(s < 0.15, 0.7, 1)
    width = st["width_mm"] * 0.1 * px * (0.8 + 0.4 * rng.random(len(s)))
    tone = 0.8 + 0.45 * rng.random(len(s))  # some hairs catch the light
    strokes = []
    for i in np.argsort(rng.random(len(s))):
        pts, wd = _stroke(np.array([x[i], y[i]]), ang[i], length[i], width[i],
                          -0.35 * rng.random())
        pts[:, 1] = h - pts[:, 1]  # image rows go down
        strokes.append((pts, wd, tone[i]))
    cov, ton = _draw(strokes, (w, h))
    # the base: the brow's body filled softly (vellus hairs and hair roots)
    gs = ((np.arange(w) + 0.5) / w - start) / (1.0 - start)
    gt = 1.0 - (np.arange(h) + 0.5) / h
    c, th = _brow_shape(st, gs)
    d = np.abs(gt[:, None] - c[None, :]) / np.maximum(th[None, :] / 2, 1e-3)
    soft = np.clip((1.15 - d) / 0.6, 0, 1) * (_density(gs) * (gs > 0))[None, :] * st["base"]
    total = 1.0 - (1.0 - cov) * (1.0 - soft.astype(np.float32))
    tone_all = (ton * cov + 1.05 * soft * (1 - cov)) / np.maximum(total, 1e-3)
    return total, np.where(total > 1e-3, tone_all, 1.0).astype(np.float32)


def lash_canvas(length_cm: float, height_cm: float, st: dict, lower: bool, seed: int,
                span: tuple[float, float] = (0.0, 1.0)) -> tuple[np.ndarray, np.ndarray]:
    """Coverage and tone canvases (y up = toward the tips) of one lash row; ``span``: the
    stretch of the card (shares of its length) along the lid opening, where lashes grow."""
    rng = np.random.default_rng(seed)
    w = max(int(length_cm / CANVAS_CM), 8)
    h = max(int(height_cm / CANVAS_CM), 8)
    px = 1.0 / CANVAS_CM
    s0, s1 = span
    n = int(st["count"] * (st["lower_share"] if lower else 1.0))
    u = np.sort(rng.uniform(0.03, 0.97, n))  # along the opening, corner to corner
    full = np.sin(np.pi * u) ** 0.6
    keep = rng.random(n) < 0.45 + 0.55 * full  # sparse at the corners
    u, full = u[keep], full[keep]
    s = s0 + (s1 - s0) * u
    length = h * (0.45 + 0.5 * full) * (0.85 + 0.2 * u) * rng.uniform(0.8, 1.05, len(s))
    if lower:
        length *= st["lower_length"] / 0.6
    length = np.minimum(length, 0.96 * h)
    ang = np.radians(90 + st["splay_deg"] * (0.5 - u) * 2 * (0.6 + 0.4 * (1 - full)))
    ang += np.radians(7) * rng.standard_normal(len(s))
    root = np.column_stack([s * w, h * rng.uniform(0.0, 0.06, len(s))])
    tips = root + np.column_stack([np.cos(ang), np.sin(ang)]) * length[:, None]
    if not lower and st["clump"] > 1:  # tips gather into clumps
        g = np.arange(len(s)) // int(st["clump"])
        mean = np.stack([np.bincount(g, tips[:, k]) / np.bincount(g) for k in (0, 1)], 1)
        tips = tips + 0.25 * (mean[g] - tips)
    width = st["width_mm"] * 0.1 * px * rng.uniform(0.8, 1.2, len(s)) * (0.7 if lower else 1)
    tone = rng.uniform(0.85, 1.15, len(s)) * (1.6 if lower else 1.0)  # lower: finer, lighter
    strokes = []
    # the lash line (upper lid): short dense hairs and roots along the lid margin
    m = 0 if lower else len(s)
    ls = s0 + (s1 - s0) * np.sort(rng.uniform(0.02, 0.98, m))
    for i in range(m):
        r0 = np.array([ls[i] * w, h * rng.uniform(0.0, 0.03)])
        pts, wd = _stroke(r0, np.radians(90 + rng.normal(0, 12)),
                          h * rng.uniform(0.05, 0.12), width.mean() * 0.7, 0.0, n=3)
        pts[:, 1] = h - pts[:, 1]
        strokes.append((pts, wd, 0.8))
    curl = st["curl"] * (0.5 if lower else 1.0)
    for i in range(len(s)):
        k = np.linspace(0, 1, 7)[:, None]
        mid = 0.5 * (root[i] + tips[i])
        d = tips[i] - root[i]
        normal = np.array([-d[1], d[0]]) * curl * 0.25 * np.sign(u[i] - 0.5 + 1e-6)
        ctrl = mid + normal
        pts = (1 - k) ** 2 * root[i] + 2 * (1 - k) * k * ctrl + k ** 2 * tips[i]
        pts[:, 1] = h - pts[:, 1]
        strokes.append((pts, width[i] * (1.0 - 0.8 * k[:, 0]), tone[i]))
    cov, ton = _draw(strokes, (w, h))
    # the lash line: roots in two or three rows along the lid margin, seen end-on, read as
    # one dark line under the hairs
    t = 1.0 - (np.arange(h) + 0.5) / h
    band = st["line"] * (0.5 if lower else 1.0) * np.clip((0.2 - t) / 0.12, 0.0, 1.0)
    along = np.clip(((np.arange(w) + 0.5) / w - s0) / max(s1 - s0, 1e-6), 0.0, 1.0)
    band = band[:, None] * np.sin(np.pi * along)[None, :] ** 3
    total = 1.0 - (1.0 - cov) * (1.0 - band.astype(np.float32))
    return total, np.where(total > 1e-3, (ton * cov + band * (1 - cov)) / np.maximum(total, 1e-3),
                           1.0).astype(np.float32)


def _per_texel(uv: np.ndarray, tris: np.ndarray, s: np.ndarray, t: np.ndarray
               ) -> tuple[float, float]:
    """How far ``s`` and ``t`` (per vertex) change from one texel to the next on a card
    (medians over its triangles of the gradients' lengths, texture of SIZE texels)."""
    px = uv[tris] * SIZE  # (F, 3, 2)
    e = px[:, 1:] - px[:, :1]  # (F, 2, 2)
    ok = np.abs(np.linalg.det(e)) > 1e-9
    grads = []
    for f in (s, t):
        df = f[tris[ok, 1:]] - f[tris[ok, :1]]  # (F, 2)
        g = np.linalg.solve(e[ok], df[..., None])[..., 0]
        grads.append(float(np.median(np.linalg.norm(g, axis=1))) if ok.any() else 0.0)
    return grads[0], grads[1]


def _lookup(canvas: np.ndarray, s: np.ndarray, t: np.ndarray) -> np.ndarray:
    h, w = canvas.shape
    coords = np.stack([(1.0 - t) * h - 0.5, s * w - 0.5])
    return ndimage.map_coordinates(canvas, coords, order=1, mode="constant", cval=0.0)


def paint_strokes(piece: Piece, character: Character, kind: str) -> np.ndarray:
    """RGBA texture of a brow (``kind`` 'brow') or lash ('lash') piece."""
    asset = character.eyebrows if kind == "brow" else character.eyelashes
    st = settings().get(asset or "", settings()["eyebrow001" if kind == "brow"
                                                 else "eyelashes01"])
    hair = color.hex_linear(character.hair_color)
    pale = color.pale(hair)
    if kind == "brow":  # brows thin with age; grey and white hairs are translucent and
        # their fine base does not show: as dense as dark ones, they read as pale paint
        age = float(character.phenotype.get("age", 25.0))
        st = {**st, "base": st["base"] * (1.0 - 0.85 * pale),
              "count": st["count"] * (1.0 - 0.35 * float(smoothstep(45.0, 80.0, age)))}
    tris = np.concatenate(list(piece.parts.values()))
    uv = piece.uvs
    pos = piece.vertices.astype(np.float64) * CM
    lab = uv_islands(tris, len(uv))
    at = rasterize(uv, tris, (SIZE, SIZE))
    fid = at.faces_at()
    alpha = np.zeros(len(fid), np.float32)
    tone = np.full(len(fid), 0.7, np.float32)
    tex_island = lab[tris[fid, 0]]
    cards = _cards(pos, tris, lab, kind)
    spans = _lid_spans(pos, cards) if kind == "lash" else [(0.0, 1.0)] * len(cards)
    for i, ((ids, s, t, length, height, lower), span) in enumerate(zip(cards, spans,
                                                                          strict=True)):
        sel = tex_island == lab[ids[0]]
        if not sel.any():
            continue
        seed = seed_of(kind, asset, character.name, i)
        a, tn = (brow_canvas(length, height, st, seed, _brow_start(pos[ids], s))
                 if kind == "brow"
                 else lash_canvas(length, height, st, lower, seed, span))
        # a texel shows the mean of the hairs it covers (no aliasing on thin UV islands)
        local = np.full(len(pos), -1)
        local[ids] = np.arange(len(ids))
        card = local[tris[np.isin(tris[:, 0], ids)]]
        ds, dt = _per_texel(uv[ids], card, s, t)
        sigma = (0.45 * dt * a.shape[0], 0.45 * ds * a.shape[1])
        if max(sigma) > 0.5:
            at_ = ndimage.gaussian_filter(a * tn, sigma)
            a = ndimage.gaussian_filter(a, sigma)
            tn = np.where(a > 1e-3, at_ / np.maximum(a, 1e-3), 1.0).astype(np.float32)
        vst = np.zeros((len(pos), 2))
        vst[ids] = np.column_stack([s, t])
        ts = at.at(vst)[sel]
        alpha[sel] = _lookup(a, ts[:, 0], ts[:, 1])
        tone[sel] = _lookup(tn, ts[:, 0], ts[:, 1])
    if kind == "lash":
        base = 0.2 * hair + 0.8 * np.array([0.006, 0.005, 0.004], np.float32)
        base = base * st["tone"] / 0.3
    else:
        base = hair * st["tone"]
    c = base[None, :] * tone[:, None]
    # hairs that catch the light show even in black brows
    c = c + np.float32(0.03) * np.clip(tone - 1.0, 0, None)[:, None]
    opacity = 1.15 * (1.0 - 0.4 * pale) if kind == "brow" else 1.15
    return at.image(color.rgba8(c, np.clip(alpha * opacity, 0, 1)))
