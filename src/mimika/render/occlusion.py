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
from mimika.render.mouth import smoothstep

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



#: the lids round each eye among the 68 landmarks (the subject's right eye, left eye): upper
#: and lower lid margins, corner to corner
EYE_LIDS = (((36, 37, 38, 39), (39, 40, 41, 36)), ((42, 43, 44, 45), (45, 46, 47, 42)))
#: the lids' shade on the eyeball: how far below the upper lid (radians seen from the eye's
#: centre) its shadow and the lashes' reach and how dark it is there; the same above the lower
#: lid and in the corners
LID_SHADE = {"upper": (0.4, 0.25), "lower": (0.2, 0.75), "corners": (0.35, 0.6)}


def _angles(p: np.ndarray, centre: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Azimuth and elevation (radians) of points ``p`` (N, 3) seen from ``centre`` (the eye
    looks toward +z)."""
    d = np.asarray(p, np.float64) - centre
    return np.arctan2(d[:, 0], d[:, 2]), np.arctan2(d[:, 1], np.hypot(d[:, 0], d[:, 2]))


def lid_shade(points: np.ndarray, centre: np.ndarray, upper: np.ndarray,
              lower: np.ndarray) -> np.ndarray:
    """Per eyeball point (N, 3): the light the lids let reach it, 1 in the open middle, down
    to :data:`LID_SHADE`'s darkness just under the upper lid, above the lower and in the
    corners — from the lid margins ``upper`` and ``lower`` (K, 3) seen from the eye's
    ``centre``."""
    az, el = _angles(points, centre)

    def margin(pts: np.ndarray) -> np.ndarray:
        a, e = _angles(pts, centre)
        order = np.argsort(a)
        return np.interp(az, a[order], e[order])

    out = np.ones(len(az))
    for d, key in ((margin(upper) - el, "upper"), (el - margin(lower), "lower")):
        reach, dark = LID_SHADE[key]
        out *= dark + (1.0 - dark) * smoothstep(0.0, 1.0, d / reach)
    ends = _angles(np.concatenate([upper, lower]), centre)[0]
    reach, dark = LID_SHADE["corners"]
    out *= dark + (1.0 - dark) * smoothstep(
        0.0, 1.0, np.minimum(az - ends.min(), ends.max() - az) / reach)
    return out.astype(np.float32)


def eye_occlusion(head: Any, objects: list) -> dict[str, np.ndarray]:
    """The occlusion of each eye object of ``head`` (category ``eyes``; ``objects``: the
    renderer's GPU objects, their buffers holding the rest pose) by the lids
    (:func:`lid_shade`, the lids from the landmarks) — smooth where a bake from a few dozen
    directions, few of them through the eye opening, is blotchy."""
    lm = np.asarray(head.landmark_points(), np.float64)
    out = {}
    for o in objects:
        if o.category != "eyes":
            continue
        p = o.interleaved[:, :3].astype(np.float64)
        pivot = getattr(head[o.name], "pivot", None)
        centre = p.mean(0) if pivot is None else np.asarray(pivot, np.float64)
        upper, lower = min(EYE_LIDS, key=lambda ul: float(np.linalg.norm(
            lm[list(ul[0])].mean(0) - centre)))
        out[o.name] = lid_shade(p, centre, lm[list(upper)], lm[list(lower)])
    return out
