"""Texture space: which triangle covers each texel and where (barycentric coordinates), so any
per-vertex quantity (bind-pose position, normal, region weight) can be read per texel.

Painting in texture space from 3D quantities keeps patterns continuous across UV seams.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

#: candidate texels tested per chunk (bounds memory: ~40 bytes each)
_CHUNK = 1 << 21


@dataclass(frozen=True)
class Atlas:
    """The texels of a (h, w) texture covered by triangles ``tris`` at texel coordinates ``px``
    (x right, y down, texel centres at +0.5). ``face``: triangle per texel (-1 where none);
    ``bary``: its barycentric weights; ``near``: the flat index of the nearest covered texel
    (for padding islands so mipmaps do not bleed the background in)."""

    w: int
    h: int
    tris: np.ndarray
    face: np.ndarray
    bary: np.ndarray
    near: np.ndarray

    @property
    def covered(self) -> np.ndarray:
        """(h, w) bool: texels inside a triangle."""
        return self.face >= 0

    @property
    def texels(self) -> np.ndarray:
        """Flat indices of the covered texels (the order of :meth:`at` and :meth:`image`)."""
        return np.flatnonzero(self.face.ravel() >= 0)

    def at(self, attr: np.ndarray) -> np.ndarray:
        """Per-vertex ``attr`` (N,) or (N, k) interpolated at the covered texels: (T,) or
        (T, k) float32."""
        a = np.asarray(attr, np.float32)
        t = self.texels
        corners = self.tris[self.face.ravel()[t]]  # (T, 3)
        b = self.bary.reshape(-1, 3)[t]
        flat = a.reshape(len(a), -1)
        out = np.einsum("nk,nkc->nc", b, flat[corners])
        return out.reshape(len(t), *a.shape[1:])

    def faces_at(self) -> np.ndarray:
        """The triangle of every covered texel (T,)."""
        return self.face.ravel()[self.texels]

    def image(self, values: np.ndarray) -> np.ndarray:
        """Values at the covered texels (T,) or (T, k) as an (h, w) or (h, w, k) image, the
        rest filled from the nearest covered texel (padding against mipmap bleeding)."""
        v = np.asarray(values)
        full = np.zeros((self.h * self.w, *v.shape[1:]), v.dtype)
        full[self.texels] = v
        return full[self.near].reshape(self.h, self.w, *v.shape[1:])


def rasterize(uv: np.ndarray, tris: np.ndarray, size: tuple[int, int]) -> Atlas:
    """Rasterise triangles ``tris`` (F, 3) at texture coordinates ``uv`` (N, 2; v up) into a
    texture of ``size`` = (w, h)."""
    w, h = size
    px = np.empty((len(uv), 2), np.float64)
    px[:, 0] = np.asarray(uv[:, 0], np.float64) * w
    px[:, 1] = (1.0 - np.asarray(uv[:, 1], np.float64)) * h
    tris = np.asarray(tris, np.int64).reshape(-1, 3)
    face = np.full((h, w), -1, np.int32)
    bary = np.zeros((h, w, 3), np.float32)
    p = px[tris]  # (F, 3, 2)
    # triangles laid over exactly the same texels (stacked hair cards) would only overwrite
    # each other: draw the last of each such stack
    _, first_rev = np.unique(np.round(p[::-1].reshape(len(p), 6), 4), axis=0, return_index=True)
    order = np.sort(len(p) - 1 - first_rev)
    lo = np.clip(np.floor(p.min(1) - 0.5), 0, [w - 1, h - 1]).astype(np.int64)
    hi = np.clip(np.ceil(p.max(1) - 0.5), 0, [w - 1, h - 1]).astype(np.int64)
    bw = hi[:, 0] - lo[:, 0] + 1
    counts = bw * (hi[:, 1] - lo[:, 1] + 1)
    a, e1, e2 = p[:, 0], p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    ok = np.abs(det) > 1e-12
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    cum = np.cumsum(counts[order])
    start = 0
    while start < len(order):
        base = cum[start - 1] if start else 0
        stop = int(np.searchsorted(cum, base + _CHUNK, side="right"))
        stop = max(stop, start + 1)
        sel = order[start:stop]
        sel = sel[ok[sel]]
        if len(sel):
            n = counts[sel]
            fid = np.repeat(sel, n)
            local = np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n)
            x = lo[fid, 0] + local % bw[fid]
            y = lo[fid, 1] + local // bw[fid]
            dx = x + 0.5 - a[fid, 0]
            dy = y + 0.5 - a[fid, 1]
            b1 = (dx * e2[fid, 1] - dy * e2[fid, 0]) * inv[fid]
            b2 = (e1[fid, 0] * dy - e1[fid, 1] * dx) * inv[fid]
            b0 = 1.0 - b1 - b2
            eps = -1e-9
            inside = (b0 >= eps) & (b1 >= eps) & (b2 >= eps)
            x, y, fid = x[inside], y[inside], fid[inside]
            face[y, x] = fid
            bary[y, x] = np.stack([b0[inside], b1[inside], b2[inside]], 1)
        start = stop
    covered = face >= 0
    if covered.any():
        _, (iy, ix) = ndimage.distance_transform_edt(~covered, return_indices=True)
        near = (iy * w + ix).ravel()
    else:
        near = np.zeros(h * w, np.int64)
    return Atlas(w, h, tris, face, bary, near)
