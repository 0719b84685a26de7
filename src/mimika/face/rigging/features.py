"""Find a face on a mesh: its eye and mouth openings, from geometry alone.

An *opening* is either a hole in the surface (a loop of boundary edges, as most game heads
have at the eyes and mouth) or a cavity seen from the front (a closed mesh whose lids and lips
turn inward into sockets and a mouth bag, as MakeHuman's base mesh): vertices hidden behind
the surface in front of them, not deeper than a tenth of the head. Openings are scored as
two eyes (a mirror pair, side by side) above a mouth (centred below them, about as far below
as they are apart); the best triple wins. Coordinates here are the candidate frame's: y up,
the face looking toward +z, +x the subject's left.

Vertices at one position are taken as one (:func:`weld`): a glTF mesh is cut at its UV seams,
and a seam is no hole — else the seams inside a mouth bag make a second, deeper "mouth".
A mouth or eye must be seen from the front: a hole or cavity whose rim lies behind the face
(inside the mouth bag or an eye socket) scores lower.
"""

from __future__ import annotations

import itertools
import logging
from dataclasses import dataclass

import numpy as np
from scipy import sparse
from scipy.sparse.csgraph import connected_components

log = logging.getLogger(__name__)

__all__ = ["FaceFeatures", "depth_behind", "find_face", "openings", "sphere_fit", "weld", "welded"]

#: vertices closer than this fraction of the mesh's size are one (UV-seam copies)
WELD_TOL = 1e-6


@dataclass(frozen=True)
class FaceFeatures:
    """Eye and mouth openings: centres (3,) and rim points (K, 3); ``score`` ≤ 1 (1 = a
    perfectly mirrored pair of eyes over a centred mouth)."""

    eye_L: np.ndarray
    eye_R: np.ndarray
    mouth: np.ndarray
    rim_L: np.ndarray
    rim_R: np.ndarray
    rim_mouth: np.ndarray
    score: float
    source: str = "openings"

    @property
    def eye_distance(self) -> float:
        return float(np.linalg.norm(self.eye_L - self.eye_R))


@dataclass(frozen=True)
class _Opening:
    rim: np.ndarray  # vertex indices
    points: np.ndarray  # rim positions
    centre: np.ndarray
    visible: float = 1.0  # the fraction of the rim seen from the front

    def extent(self, axis: np.ndarray) -> float:
        return float(np.ptp(self.points @ axis))


def sphere_fit(p: np.ndarray) -> tuple[np.ndarray, float]:
    """Least-squares sphere (centre (3,), radius) through points (N, 3): eyeball centres."""
    from mimika.face.heads.ict import _fit_sphere

    return _fit_sphere(p)


def weld(v: np.ndarray, tol: float = WELD_TOL) -> np.ndarray:
    """Per vertex, the first vertex at its position (rounded to ``tol`` of the mesh's size):
    the copies a UV seam (or a normal seam) cuts a glTF mesh into point to one vertex.
    Linear in the vertices, however many share a position."""
    v = np.asarray(v, float)
    n = len(v)
    if n < 2:
        return np.arange(n)
    r = tol * max(float(np.ptp(v, axis=0).max()), 1e-12)
    _, first, inverse = np.unique(np.round((v - v.min(0)) / r).astype(np.int64), axis=0,
                                  return_index=True, return_inverse=True)
    return first[inverse.reshape(-1)]


def welded(v: np.ndarray, f: np.ndarray, rep: np.ndarray | None = None
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(welded vertices, triangles into them, each vertex's welded index) of (v, f); ``rep``:
    :func:`weld` of ``v`` when known."""
    rep = weld(v) if rep is None else rep
    keep, inverse = np.unique(rep, return_inverse=True)
    return np.asarray(v)[keep], inverse[np.asarray(f)], inverse


def _edges(f: np.ndarray) -> np.ndarray:
    return np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])


def _components(n: int, e: np.ndarray, keep: np.ndarray) -> list[np.ndarray]:
    """Connected components of the vertices ``keep`` (bool (n,)) along edges ``e``."""
    e = e[keep[e[:, 0]] & keep[e[:, 1]]]
    g = sparse.coo_matrix((np.ones(len(e)), (e[:, 0], e[:, 1])), shape=(n, n))
    _, lab = connected_components(g, directed=False)
    out = []
    ids = np.flatnonzero(keep)
    if not len(ids):
        return out
    order = np.argsort(lab[ids], kind="stable")
    grp = lab[ids][order]
    cuts = np.flatnonzero(np.diff(grp)) + 1
    for part in np.split(ids[order], cuts):
        out.append(part)
    return out


def depth_behind(v: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, float]:
    """Per vertex of (v, f), how far (along z) it lies behind the surface seen from +z, and
    the sampling step h: a z-buffer of points sampled over every triangle (spacing h,
    ~300 000 samples over the whole surface). Vertices within 3 h are seen from the front."""
    n = len(v)
    tri = v[f]
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    h = float(np.sqrt(max(area.sum(), 1e-12) / 3e5))
    h = max(h, float(np.ptp(v[:, :2], axis=0).max()) / 2048)  # a sliver: ≤ 2048² cells
    k = np.minimum(np.ceil(np.sqrt(2 * area) / h).astype(np.int64), 64)  # samples per edge
    pts = [v]
    for kk in np.unique(k[k > 1]):
        a, b = np.meshgrid(np.arange(kk + 1), np.arange(kk + 1))
        keep = a + b <= kk
        w = np.c_[a[keep], b[keep]] / kk  # barycentric (w1, w2)
        t = tri[k == kk]
        pts.append((t[:, None, 0] + w[None, :, :1] * (t[:, None, 1] - t[:, None, 0])
                    + w[None, :, 1:] * (t[:, None, 2] - t[:, None, 0])).reshape(-1, 3))
    pts = np.concatenate(pts)
    lo = pts[:, :2].min(0)
    cell = np.floor((pts[:, :2] - lo) / h).astype(np.int64)
    nx = int(cell[:, 0].max()) + 1
    key = cell[:, 1] * nx + cell[:, 0]
    zbuf = np.full(int(key.max()) + 1, -np.inf)
    np.maximum.at(zbuf, key, pts[:, 2])
    return zbuf[key[:n]] - v[:, 2], h


def openings(v: np.ndarray, f: np.ndarray) -> list[_Opening]:
    """Holes (boundary loops) and front cavities of the mesh (v in the candidate frame; seams
    welded, rims given as indices of ``v``)."""
    rep = weld(v)
    f = rep[np.asarray(f)]
    n = len(v)
    e = _edges(f)
    es = np.sort(e, axis=1)
    uniq, cnt = np.unique(es, axis=0, return_counts=True)
    boundary = uniq[cnt == 1]
    out: list[_Opening] = []
    on_b = np.zeros(n, bool)
    on_b[boundary.ravel()] = True
    loops = [c for c in _components(n, boundary, on_b) if len(c) >= 6]
    # cavities: vertices hidden behind the surface in front of them
    depth, h = depth_behind(v, f)
    span = float(np.ptp(v[:, 2])) or 1.0
    front = depth <= 3.0 * h
    out += [_make(v, c, float(front[c].mean())) for c in loops]
    hidden = ~front & (depth < 0.12 * span)
    if hidden.any():
        # rim = front-most (visible) vertices next to hidden ones
        for comp in _components(n, e, hidden):
            if len(comp) < 6:
                continue
            inside = np.zeros(n, bool)
            inside[comp] = True
            touch = e[inside[e[:, 0]] & front[e[:, 1]], 1]
            rim = np.unique(touch)
            if len(rim) >= 6:
                out.append(_make(v, rim))
    return out


def _make(v: np.ndarray, rim: np.ndarray, visible: float = 1.0) -> _Opening:
    p = v[rim]
    return _Opening(rim, p, 0.5 * (p.max(0) + p.min(0)), visible)


def _score(el: _Opening, er: _Opening, m: _Opening) -> float:
    """How much (el, er, m) look like left eye, right eye, mouth (≤ 1); measured in the
    triple's own frame, so a face turned or tilted by up to ~45° scores as one facing +z."""
    dv = el.centre - er.centre
    d = float(np.linalg.norm(dv))
    if d <= 0 or dv[0] < 0.6 * d:
        return -np.inf
    x = dv / d
    mv = 0.5 * (el.centre + er.centre) - m.centre
    along = float(mv @ x)
    perp = mv - along * x
    drop = float(np.linalg.norm(perp))
    if perp[1] < 0.3 * d:
        return -np.inf
    wl, wr, wm = el.extent(x), er.extent(x), m.extent(x)
    terms = [
        0.5 * abs(dv[1]) / d,                              # eyes about level
        abs(wl - wr) / max(wl, wr, 1e-9),                  # a mirror pair
        abs(along) / d,                                    # mouth centred below them
        abs(np.log(drop / d)) / 2,                         # about as far below as apart
        abs(np.log(max(wm, 1e-9) / (0.85 * d))) / 2,       # about as wide as the eye gap
        abs(np.log(max(wl, 1e-9) / (0.45 * d))) / 2,       # eyes ~ half the gap wide
        (1.0 - m.visible) + 0.5 * (2.0 - el.visible - er.visible),  # seen from the front
    ]
    return 1.0 - float(sum(terms))


def find_face(v: np.ndarray, f: np.ndarray) -> FaceFeatures | None:
    """The best eyes-and-mouth triple among the openings of (v, f), or None."""
    ops = openings(v, f)
    top = sorted(ops, key=lambda o: -len(o.rim))[:40]
    best, best_s = None, -np.inf
    for a, b in itertools.permutations(range(len(top)), 2):
        el, er = top[a], top[b]
        if el.centre[0] <= er.centre[0]:
            continue
        for c in range(len(top)):
            if c in (a, b):
                continue
            s = _score(el, er, top[c])
            if s > best_s:
                best, best_s = (el, er, top[c]), s
    if best is None:
        return None
    el, er, m = best
    log.debug("face: eyes %s %s mouth %s (score %.2f, %d openings)", el.centre, er.centre,
              m.centre, best_s, len(ops))
    return FaceFeatures(el.centre, er.centre, m.centre, el.points, er.points, m.points,
                        float(best_s))
