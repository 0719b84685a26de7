"""Cloth layers that do not pass through each other.

A garment's panels (collar, lapels, front panels, sleeves) are separate UV islands of one
mesh, laid one over another. Where the asset itself lets an upper panel dip under a lower one
(female_elegantsuit01's right collar wing runs through the jacket front), or where fitting to a
body and lowering the arms pushes one through another, the renderer shows the crossing as a
torn, jagged edge. :func:`layer_offsets` finds the islands that cross, decides which one lies
on top from where they do not cross (most of their overlap), and lifts the upper one clear of
the lower one by a margin, with a smooth falloff so the panel stays a smooth surface.
Where one island passes through itself (a crumpled collar tip), :func:`smooth_crumples`
relaxes it.
"""

from __future__ import annotations

import logging

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from mimika.face.makehuman.artefacts import intersecting_pairs, weld_key

log = logging.getLogger(__name__)


def closest_on_triangles(p: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """The closest point to each ``p`` (K, 3) on the matching triangle ``tri`` (K, 3, 3)."""
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    n = np.cross(b - a, c - a)
    nn = np.einsum("ij,ij->i", n, n)
    ok = nn > 1e-20
    t = np.where(ok, np.einsum("ij,ij->i", p - a, n) / np.where(ok, nn, 1.0), 0.0)
    q = p - t[:, None] * n
    inside = ok.copy()
    for u, v in ((a, b), (b, c), (c, a)):
        inside &= np.einsum("ij,ij->i", np.cross(v - u, q - u), n) >= 0
    best = np.where(inside[:, None], q, np.inf)
    dist = np.where(inside, np.linalg.norm(p - q, axis=1), np.inf)
    for u, v in ((a, b), (b, c), (c, a)):
        e = v - u
        s = np.clip(np.einsum("ij,ij->i", p - u, e) / np.maximum(
            np.einsum("ij,ij->i", e, e), 1e-20), 0.0, 1.0)
        r = u + s[:, None] * e
        d = np.linalg.norm(p - r, axis=1)
        closer = d < dist
        best[closer], dist[closer] = r[closer], d[closer]
    return best


def height_above(p: np.ndarray, v: np.ndarray, tris: np.ndarray, k: int = 8
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For points ``p`` (M, 3) over a surface (``v``, ``tris``): signed height along the
    nearest triangle's normal, that normal, and whether the point lies over the triangle's
    inside (not past the surface's edge)."""
    P = v[tris]
    kd = cKDTree(P.mean(1))
    _, near = kd.query(p, k=min(k, len(tris)))
    near = near.reshape(len(p), -1)
    best_d = np.full(len(p), np.inf)
    best_q = np.zeros_like(p)
    best_t = np.zeros(len(p), np.int64)
    for col in range(near.shape[1]):
        t = near[:, col]
        q = closest_on_triangles(p, P[t])
        d = np.linalg.norm(p - q, axis=1)
        closer = d < best_d
        best_d[closer], best_q[closer], best_t[closer] = d[closer], q[closer], t[closer]
    fn = np.cross(P[best_t, 1] - P[best_t, 0], P[best_t, 2] - P[best_t, 0])
    fn /= np.maximum(np.linalg.norm(fn, axis=1, keepdims=True), 1e-20)
    h = np.einsum("ij,ij->i", p - best_q, fn)
    # over the inside: the offset from the closest point is along the normal
    over = np.abs(h) >= 0.999 * best_d
    return h, fn, over


def _neighbour_mean(tris: np.ndarray, n: int) -> sp.csr_matrix:
    e = np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]])
    a = sp.coo_matrix((np.ones(2 * len(e)), (np.r_[e[:, 0], e[:, 1]], np.r_[e[:, 1], e[:, 0]])),
                      shape=(n, n)).tocsr()
    a.data[:] = 1.0
    deg = np.asarray(a.sum(1)).ravel()
    return sp.diags(1.0 / np.maximum(deg, 1.0)) @ a


def _island_of_vertex(tris: np.ndarray, lab: np.ndarray, n: int) -> sp.csr_matrix:
    """(n, L) incidence of welded vertices in islands."""
    rows = tris.ravel()
    cols = np.repeat(lab, 3)
    m = sp.coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, lab.max() + 1)).tocsr()
    m.data[:] = 1.0
    return m


def smooth_crumples(v: np.ndarray, tris: np.ndarray, islands: np.ndarray, *, rings: int = 2,
                    steps: int = 4, rounds: int = 6) -> np.ndarray:
    """Moves (N, 3) that smooth out the places where one island passes through itself (a
    collar tip crumpled by fitting: neighbouring triangles folded over each other): their
    vertices and ``rings`` rings around them are relaxed toward their neighbours' mean,
    ``steps`` times a round, for up to ``rounds`` rounds while any crossing is left. Of the
    rounds, the one that leaves the fewest crossings counts."""
    v = np.asarray(v, np.float64)
    n = len(v)
    key = np.arange(n)
    avg = _neighbour_mean(tris, n)
    cur = v.copy()
    fewest, best = np.inf, cur
    for _ in range(rounds + 1):
        i, j = intersecting_pairs(cur, tris, cur, tris, key_a=key, key_b=key)
        same = (islands[i] == islands[j]) & (i < j)
        if same.sum() < fewest:
            fewest, best = int(same.sum()), cur.copy()
        if not same.any():
            break
        sel = np.zeros(n)
        sel[tris[np.r_[i[same], j[same]]].ravel()] = 1.0
        for _ in range(rings):
            sel = np.maximum(sel, (avg @ sel > 0).astype(float))
        w = sel[:, None]
        for _ in range(steps):
            cur = cur + 0.5 * w * (avg @ cur - cur)
    return best - v


def layer_offsets(v: np.ndarray, tris: np.ndarray, islands: np.ndarray, *,
                  margin: float = 0.02, zone: float = 0.4, rounds: int = 6,
                  spread: int = 3, stack: float = 0.4, width: float = 0.1) -> np.ndarray:
    """Moves (N, 3) that lift crossing cloth islands clear of each other.

    ``v`` (N, 3) welded positions, ``tris`` (F, 3) into them, ``islands`` (F,) each
    triangle's UV island; lengths in base units (dm): ``margin`` the gap left between
    layers, ``zone`` how far around a crossing the two islands' order is judged — once per
    pair and on ``v``, before any move, so a lift cannot turn an order round (lifting a
    shirt through a jacket made the shirt the upper layer, then lifted it further). A lifted
    vertex carries the other layers lying up to ``stack`` above it (within ``width`` of its
    lift's line) with it, so lifting a shirt under a collar lifts the jacket over the shirt
    too. ``spread`` rings of neighbours follow a lifted vertex, fading out. Of the
    ``rounds``, the one that leaves the fewest crossings counts: at an armpit's fold a lift
    can push a sleeve into the next panel, and later rounds made more than they cleared.
    """
    v = np.asarray(v, np.float64)
    move = np.zeros_like(v)
    n = len(v)
    member = _island_of_vertex(tris, islands, n)
    key = np.arange(n)
    order: dict[tuple[int, int], int] = {}
    fewest, best = np.inf, move
    for r in range(rounds + 1):
        cur = v + move
        i, j = intersecting_pairs(cur, tris, cur, tris, key_a=key, key_b=key)
        li, lj = islands[i], islands[j]
        cross = (li != lj) & (i < j)
        if cross.sum() < fewest:
            fewest, best = int(cross.sum()), move.copy()
        if not cross.any() or r == rounds:
            break
        lift = np.zeros(n)
        direction = np.zeros((n, 3))
        for a, b in {(int(min(x, y)), int(max(x, y)))
                     for x, y in zip(li[cross], lj[cross], strict=True)}:
            pair = cross & (((li == a) & (lj == b)) | ((li == b) & (lj == a)))
            mid = cur[tris[np.r_[i[pair], j[pair]]]].reshape(-1, 3)
            if (a, b) not in order:
                order[(a, b)] = _upper(v, tris, islands, member, a, b, mid, zone)
            up = order[(a, b)]
            lo = b if up == a else a
            # the upper island's vertices near the crossing, measured against the lower one
            near = cKDTree(mid).query(cur, distance_upper_bound=zone / 2)[0] < np.inf
            ids = np.flatnonzero(near & (np.asarray(member[:, up].todense()).ravel() > 0))
            if not len(ids):
                continue
            h, fn, over = height_above(cur[ids], cur, tris[islands == lo])
            need = over & (h < margin) & (h > -zone / 2)
            ids, fn, amount = ids[need], fn[need], (margin - h)[need]
            below = np.asarray(member[:, lo].todense()).ravel() > 0
            ids, fn, amount = _carried(cur, ids, fn, amount, below, stack, width)
            better = amount > lift[ids]
            sel = ids[better]
            lift[sel] = amount[better]
            direction[sel] = fn[better]
        if not lift.any():
            break
        move += _spread(lift, direction, tris, n, spread)
    return best


def _carried(v: np.ndarray, ids: np.ndarray, fn: np.ndarray, amount: np.ndarray,
             skip: np.ndarray, stack: float, width: float
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Lifted vertices ``ids`` (directions ``fn``, ``amount``) and, lifted as much, every
    other vertex (not ``skip``) lying up to ``stack`` above one of them within ``width`` of
    its lift's line: the layers over a lifted panel."""
    if not len(ids):
        return ids, fn, amount
    cand = np.flatnonzero(~skip)
    cand = cand[~np.isin(cand, ids)]
    if not len(cand):
        return ids, fn, amount
    kd = cKDTree(v[cand])
    extra_i, extra_f, extra_a = [ids], [fn], [amount]
    for k, near in enumerate(kd.query_ball_point(v[ids], float(np.hypot(stack, width)))):
        if not near:
            continue
        c = cand[near]
        d = v[c] - v[ids[k]]
        up = d @ fn[k]
        side = np.linalg.norm(d - up[:, None] * fn[k], axis=1)
        c = c[(up > 0) & (up < stack) & (side < width)]
        extra_i.append(c)
        extra_f.append(np.repeat(fn[k][None], len(c), 0))
        extra_a.append(np.full(len(c), amount[k]))
    return np.concatenate(extra_i), np.concatenate(extra_f), np.concatenate(extra_a)


def lift_over(v: np.ndarray, tris: np.ndarray, body_v: np.ndarray, body_t: np.ndarray, *,
              margin: float = 0.05, depth: float = 0.3, stack: float = 0.4,
              reach: float = 0.1, fade: float = 0.2) -> np.ndarray:
    """Moves (N, 3) that lift a garment (welded ``v``, ``tris``) off the body (``body_v``,
    ``body_t``) where it sinks into it or lies within ``margin`` of it, so that it rests
    ``margin`` above it. The lift is a field over the body's surface, not per vertex: every
    cloth vertex up to ``stack`` above the body whose foot point on it lies within ``reach``
    of a sunk vertex's rises as much along the body's normal, fading out over ``fade``
    beyond — so every layer stacked over that spot (shirt, jacket, collar, lapel) rises
    together and keeps its order and spacing. Vertices deeper than ``depth`` are left alone
    (they lie past another part of the body, not under it)."""
    v = np.asarray(v, np.float64)
    h, fn, over = height_above(v, np.asarray(body_v, np.float64), body_t)
    need = np.flatnonzero(over & (h < margin) & (h > -depth))
    if not len(need):
        return np.zeros_like(v)
    foot = v - h[:, None] * fn
    lift = margin - h[need]
    amount = np.zeros(len(v))
    stacked = np.flatnonzero((h < stack) & (h > -depth))
    kd = cKDTree(foot[need])
    for i, near in zip(stacked, kd.query_ball_point(foot[stacked], reach + fade),
                       strict=True):
        if near:
            d = np.linalg.norm(foot[need[near]] - foot[i], axis=1)
            w = np.clip((reach + fade - d) / fade, 0.0, 1.0)
            amount[i] = float(np.max(lift[near] * w))
    return amount[:, None] * fn


def _spread(lift: np.ndarray, direction: np.ndarray, tris: np.ndarray, n: int,
            rings: int) -> np.ndarray:
    """``lift`` (n,) along ``direction`` (n, 3), carried ``rings`` rings of neighbours out
    at half strength per ring so a surface bends instead of creasing."""
    avg = _neighbour_mean(tris, n)
    d = lift[:, None] * direction
    w = (lift > 0).astype(float)
    for _ in range(rings):
        d = np.where(w[:, None] > 0, d, 0.5 * (avg @ d))
        w = np.maximum(w, (avg @ w > 0).astype(float))
    return d


def _upper(v: np.ndarray, tris: np.ndarray, islands: np.ndarray, member: sp.csr_matrix,
           a: int, b: int, mid: np.ndarray, zone: float) -> int:
    """Which of islands ``a``/``b`` lies on top around the crossing points ``mid``: the one
    above the other at most of the vertices within ``zone`` that lie over it."""
    kd = cKDTree(mid)
    score = 0
    for x, y, sign in ((a, b, 1), (b, a, -1)):
        ids = np.flatnonzero(np.asarray(member[:, x].todense()).ravel() > 0)
        ids = ids[kd.query(v[ids], distance_upper_bound=zone)[0] < np.inf]
        if not len(ids):
            continue
        h, _, over = height_above(v[ids], v, tris[islands == y])
        score += sign * int(np.sum(over & (h > 0)) - np.sum(over & (h < 0)))
    return a if score >= 0 else b


def welded(vertices: np.ndarray, tris: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(welded positions, triangles into them, each vertex's welded index)."""
    key = weld_key(vertices)
    ids, first = np.unique(key, return_index=True)
    inv = np.searchsorted(ids, key)
    return np.asarray(vertices, np.float64)[first], inv[tris], inv
