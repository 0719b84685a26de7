"""Ambient occlusion of a head at rest, baked per vertex with the GPU.

The head is drawn into depth maps from ``directions`` evenly spread over the sphere
(orthographic, around the face); a vertex is open toward a direction when nothing lies in
front of it there. Its occlusion is the cosine-weighted share of its hemisphere that is open:
eye sockets, the nostrils, the corners of the mouth, the ears, the neck under the chin, the
hairline and the collar come out darker. Textured cut-out parts (hair, lashes) occlude where
their alpha covers. Baked once per head and renderer settings and kept for the process.
"""

from __future__ import annotations

import math
from collections import OrderedDict
from typing import Any

import numpy as np

from mimika.render.camera import look_at

#: baked occlusion per (head id, shown objects): {object name: (N,) float32}
_CACHE: OrderedDict[tuple, dict[str, np.ndarray]] = OrderedDict()


def sphere_directions(n: int) -> np.ndarray:
    """``n`` unit vectors spread evenly over the sphere (a Fibonacci lattice), (n, 3)."""
    k = np.arange(n) + 0.5
    y = 1.0 - 2.0 * k / n
    r = np.sqrt(1.0 - y * y)
    phi = k * math.pi * (3.0 - math.sqrt(5.0))
    return np.stack([r * np.cos(phi), y, r * np.sin(phi)], 1)


def ortho(half: float, near: float, far: float) -> np.ndarray:
    """An orthographic projection of a square ``2·half`` wide, depth ``near`` … ``far``."""
    m = np.eye(4)
    m[0, 0] = m[1, 1] = 1.0 / half
    m[2, 2] = -2.0 / (far - near)
    m[2, 3] = -(far + near) / (far - near)
    return m


def light_view(direction: np.ndarray, centre: np.ndarray, distance: float) -> np.ndarray:
    """A view matrix looking at ``centre`` from ``direction`` (unit, toward the light)."""
    d = np.asarray(direction, np.float64)
    up = np.array([0.0, 1.0, 0.0]) if abs(d[1]) < 0.95 else np.array([0.0, 0.0, 1.0])
    return look_at(centre + distance * d, centre, up)


def bake(key: tuple, ctx: Any, objects: list, draw: Any, centre: np.ndarray, radius: float,
         extent: float, *, directions: int = 48, size: int = 384,
         offset: float = 0.08) -> dict[str, np.ndarray]:
    """Per object (the renderer's GPU objects, their buffers holding the rest pose): the
    ambient occlusion of each vertex, 1 open … 0 closed; vertices farther than ``radius`` cm
    from ``centre`` stay 1, and only geometry within ``radius`` occludes. ``draw(view,
    proj)`` draws every occluder's depth; ``extent`` bounds the scene's reach from
    ``centre``; ``offset`` cm moves each vertex off its surface before the test."""
    if key in _CACHE:
        _CACHE.move_to_end(key)
        return _CACHE[key]
    depth = ctx.depth_texture((size, size))
    fbo = ctx.framebuffer(depth_attachment=depth)
    # only what lies within ``radius`` of the centre occludes (along each view too): the
    # same whether a renderer dropped far-away triangles (a cropped video shot) or not
    dist = extent + radius
    proj = ortho(radius, dist - radius, dist + radius)
    pts = {o.name: o.interleaved[:, :3].astype(np.float64) for o in objects}
    nrm = {o.name: o.interleaved[:, 3:6].astype(np.float64) for o in objects}
    near = {n: np.linalg.norm(p - centre, axis=1) < radius for n, p in pts.items()}
    open_w = {n: np.zeros(len(p)) for n, p in pts.items()}
    all_w = {n: np.zeros(len(p)) for n, p in pts.items()}
    texel = 2.0 * radius / size
    try:
        for d in sphere_directions(directions):
            view = light_view(d, centre, dist)
            fbo.use()
            ctx.viewport = (0, 0, size, size)
            fbo.clear(depth=1.0)
            draw(view, proj)
            zbuf = np.frombuffer(depth.read(alignment=1), np.float32).reshape(size, size)
            m = proj @ view
            for name, p in pts.items():
                sel = near[name]
                if not sel.any():
                    continue
                cos = nrm[name][sel] @ d
                w = np.maximum(cos, 0.0)
                q = np.c_[p[sel] + offset * nrm[name][sel], np.ones(sel.sum())] @ m.T
                x = np.clip(((q[:, 0] + 1) * 0.5 * size).astype(int), 0, size - 1)
                y = np.clip(((q[:, 1] + 1) * 0.5 * size).astype(int), 0, size - 1)
                z = (q[:, 2] + 1) * 0.5
                bias = (1.5 * texel + 0.05) / (2.0 * radius)
                seen = z <= zbuf[y, x] + bias
                open_w[name][sel] += w * seen
                all_w[name][sel] += w
    finally:
        fbo.release()
        depth.release()
    out = {}
    for name in pts:
        ao = np.ones(len(pts[name]), np.float32)
        has = all_w[name] > 1e-9
        ao[has] = (open_w[name][has] / all_w[name][has]).astype(np.float32)
        out[name] = ao
    _CACHE[key] = out
    while len(_CACHE) > 8:
        _CACHE.popitem(last=False)
    return out


#: the eye openings' outlines: the landmarks round each eye (the subject's right, left)
EYE_OUTLINES = (tuple(range(36, 42)), tuple(range(42, 48)))


#: the direction (world, the head at rest) of the light that the lids shade: above the front
#: (a portrait key light), so the eyeball is darker under the upper lid than above the lower
LID_LIGHT = (0.0, 0.5, 0.866)


def opening_light(points: np.ndarray, normals: np.ndarray, outline: np.ndarray) -> np.ndarray:
    """Per point (N, 3) facing ``normals`` (N, 3), unit: the light of a cosine lobe about them
    seen through the polygon ``outline`` (K, 3) (Lambert's form factor of a polygon), over its
    maximum among the points — 1 where the opening is most in view, toward 0 under its rims."""
    a = outline[None, :, :] - points[:, None, :]
    a /= np.linalg.norm(a, axis=2, keepdims=True)
    b = np.roll(a, -1, axis=1)
    g = np.cross(a, b)
    gn = np.maximum(np.linalg.norm(g, axis=2), 1e-12)
    theta = np.arctan2(gn, np.einsum("nkc,nkc->nk", a, b))
    f = np.abs(np.einsum("nk,nkc,nc->n", theta / gn, g, normals)) / (2.0 * math.pi)
    return (f / max(float(f.max()), 1e-9)).astype(np.float32)


def eye_occlusion(landmarks: np.ndarray, objects: list) -> dict[str, np.ndarray]:
    """The occlusion of each eye object (category ``eyes``; the renderer's GPU objects, their
    buffers holding the rest pose) by the lids: the light from :data:`LID_LIGHT` through the
    eye opening nearest to it (:func:`opening_light`, the outline from ``landmarks`` (68, 3))
    — smooth where a bake from a few dozen directions, few of them through the opening, is
    blotchy."""
    outlines = [np.asarray(landmarks, np.float64)[list(ids)] for ids in EYE_OUTLINES]
    out = {}
    for o in objects:
        if o.category != "eyes":
            continue
        p = o.interleaved[:, :3].astype(np.float64)
        near = min(outlines, key=lambda q: float(np.linalg.norm(q.mean(0) - p.mean(0))))
        # light bounced off the lids and lashes reaches the corners too
        out[o.name] = 0.3 + 0.7 * opening_light(p, np.broadcast_to(LID_LIGHT, p.shape), near)
    return out
