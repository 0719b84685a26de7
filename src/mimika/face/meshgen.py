"""Generic helpers for procedural meshes: implicit primitives, ray projection, grids and stitching.

Everything here is deterministic and vectorised with numpy. Triangles are wound
counter-clockwise seen from outside (the right-hand normal points out of the solid).
"""

from __future__ import annotations

import itertools

import numpy as np

# ---------------------------------------------------------------------------------------------
# implicit primitives (approximate signed distances, negative inside)
# ---------------------------------------------------------------------------------------------


def smin(a: np.ndarray, b: np.ndarray, k: float) -> np.ndarray:
    """Polynomial smooth minimum (smooth union) with blend radius ``k`` (cm)."""
    if k <= 0:
        return np.minimum(a, b)
    h = np.maximum(k - np.abs(a - b), 0.0) / k
    return np.minimum(a, b) - h * h * k * 0.25


def smax(a: np.ndarray, b: np.ndarray, k: float) -> np.ndarray:
    """Smooth maximum (smooth intersection / subtraction when ``b`` is negated)."""
    return -smin(-a, -b, k)


def sd_ellipsoid(p: np.ndarray, c, r, n: float = 2.0) -> np.ndarray:
    """Approximate signed distance to an ellipsoid (``n`` > 2 gives a super-ellipsoid)."""
    r = np.asarray(r, float)
    q = (p - np.asarray(c, float)) / r
    if n == 2.0:
        k0 = np.sqrt(np.einsum("...i,...i->...", q, q))
        k1 = np.sqrt(np.einsum("...i,...i->...", q / r, q / r))
        return k0 * (k0 - 1.0) / np.maximum(k1, 1e-9)
    k0 = np.sum(np.abs(q) ** n, axis=-1) ** (1.0 / n)
    return (k0 - 1.0) * r.min()


def sd_round_cone(p: np.ndarray, a, b, ra: float, rb: float) -> np.ndarray:
    """Signed distance to a capsule from ``a`` (radius ``ra``) to ``b`` (radius ``rb``)."""
    a = np.asarray(a, float)
    ba = np.asarray(b, float) - a
    pa = p - a
    t = np.clip(pa @ ba / (ba @ ba), 0.0, 1.0)
    d = np.linalg.norm(pa - t[..., None] * ba, axis=-1)
    return d - (ra + (rb - ra) * t)


def sd_sphere(p: np.ndarray, c, r: float) -> np.ndarray:
    return np.linalg.norm(p - np.asarray(c, float), axis=-1) - r


# ---------------------------------------------------------------------------------------------
# projection of directions onto an implicit surface
# ---------------------------------------------------------------------------------------------


def directions(az: np.ndarray, el: np.ndarray) -> np.ndarray:
    """Unit vectors for azimuth ``az`` (0 = +z, positive toward +x) and elevation ``el`` (rad)."""
    ce = np.cos(el)
    return np.stack([ce * np.sin(az), np.sin(el), ce * np.cos(az)], axis=-1)


def ray_cast(field, origin, dirs: np.ndarray, r_max: float, tol: float = 1e-5,
             relax: float = 1.0) -> np.ndarray:
    """Distance from ``origin`` along each unit direction to the outermost zero of ``field``.

    ``field(points) -> values`` is negative inside and roughly distance-like. Rays start at
    ``r_max`` (outside) and march inward by ``relax`` times the field value; a step that lands
    inside is undone and the bracket is refined by bisection.
    """
    origin = np.broadcast_to(np.asarray(origin, float), dirs.shape)
    n = len(dirs)
    r_out = np.full(n, float(r_max))  # last point known to be outside
    r_in = np.full(n, np.nan)  # first point found inside
    r = np.full(n, float(r_max))
    active = np.arange(n)
    for it in range(200):
        if active.size == 0:
            break
        if it == 12:
            relax *= 2.0  # slow (grazing) rays: over-relax, overshoots are bisected below
        f = field(origin[active] + dirs[active] * r[active, None])
        done = np.abs(f) < tol
        inside = (f < 0) & ~done
        out = ~inside & ~done
        ia, oa = active[inside], active[out]
        r_in[ia] = r[ia]
        r_out[oa] = r[oa]
        r[oa] -= np.maximum(f[out] * relax, tol * 0.5)
        active = oa
    idx = np.nonzero(~np.isnan(r_in))[0]
    lo, hi = r_in[idx], r_out[idx]
    f_lo = field(origin[idx] + dirs[idx] * lo[:, None]) if idx.size else np.zeros(0)
    f_hi = field(origin[idx] + dirs[idx] * hi[:, None]) if idx.size else np.zeros(0)
    for it in range(60):  # bisection steps alternating with false position
        if idx.size == 0 or np.max(hi - lo) < tol:
            break
        if it % 2:
            mid = 0.5 * (lo + hi)
        else:
            w = f_hi / np.where(f_hi - f_lo > 1e-12, f_hi - f_lo, 1e-12)
            mid = hi - np.clip(w, 0.02, 0.98) * (hi - lo)
        fm = field(origin[idx] + dirs[idx] * mid[:, None])
        ins = fm < 0
        lo = np.where(ins, mid, lo)
        f_lo = np.where(ins, fm, f_lo)
        hi = np.where(ins, hi, mid)
        f_hi = np.where(ins, f_hi, fm)
        conv = np.abs(fm) < tol
        if conv.any():
            lo = np.where(conv, mid, lo)
            hi = np.where(conv, mid, hi)
    r[idx] = 0.5 * (lo + hi)
    return r


# ---------------------------------------------------------------------------------------------
# connectivity builders
# ---------------------------------------------------------------------------------------------


def grid_faces(idx: np.ndarray, skip_rows=()) -> np.ndarray:
    """Triangles of a structured grid ``idx[col, row]`` (cols grow to the right, rows upward).

    Row pairs ``(j, j+1)`` with ``j`` in ``skip_rows`` are left out (openings).
    """
    out = []
    for j in range(idx.shape[1] - 1):
        if j in skip_rows:
            continue
        v00 = idx[:-1, j]
        v10 = idx[1:, j]
        v11 = idx[1:, j + 1]
        v01 = idx[:-1, j + 1]
        out.append(np.stack([v00, v10, v11], 1))
        out.append(np.stack([v00, v11, v01], 1))
    f = np.concatenate(out) if out else np.zeros((0, 3), int)
    return drop_degenerate(f)


def drop_degenerate(f: np.ndarray) -> np.ndarray:
    ok = (f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])
    return f[ok]


def zipper(a: np.ndarray, ta: np.ndarray, b: np.ndarray, tb: np.ndarray,
           closed: bool = False, period: float = 0.0) -> np.ndarray:
    """Triangle strip joining polyline ``a`` to polyline ``b`` by their parameters ``ta``/``tb``.

    Triangles are wound as if ``a`` were the lower row and ``b`` the upper row of a grid whose
    parameter increases to the right. For closed loops give ``period`` of the parameter.
    """
    a = list(a)
    b = list(b)
    ta = list(ta)
    tb = list(tb)
    if closed:
        a = [*a, a[0]]
        b = [*b, b[0]]
        ta = [*ta, ta[0] + period]
        tb = [*tb, tb[0] + period]
    i = j = 0
    tris = []
    while i < len(a) - 1 or j < len(b) - 1:
        if j >= len(b) - 1 or (i < len(a) - 1 and
                               0.5 * (ta[i] + ta[i + 1]) <= 0.5 * (tb[j] + tb[j + 1])):
            tris.append((a[i], a[i + 1], b[j]))
            i += 1
        else:
            tris.append((a[i], b[j + 1], b[j]))
            j += 1
    return drop_degenerate(np.array(tris, int).reshape(-1, 3))


def ring_strips(rings: list[np.ndarray], closed: bool = True) -> np.ndarray:
    """Quads between consecutive rings (same length), wound like :func:`grid_faces`."""
    idx = np.stack(rings, 1)
    if closed:
        idx = np.concatenate([idx, idx[:1]], 0)
    return grid_faces(idx)


def orient_like(new: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """``new`` triangles, flipped if needed so that edges shared with ``ref`` run opposite."""
    shared = np.intersect1d(np.unique(new), np.unique(ref))
    if shared.size == 0:
        raise ValueError("no shared edge")
    v0 = shared[0]
    en = directed_edges(new[(new == v0).any(1)])
    er = directed_edges(ref[(ref == v0).any(1)])
    se = {tuple(e) for e in er.tolist()}
    same = sum((a, b) in se for a, b in en.tolist())
    opp = sum((b, a) in se for a, b in en.tolist())
    if same == opp == 0:
        raise ValueError("no shared edge")
    return new[:, ::-1].copy() if same > opp else new


def fan(center: int, ring: np.ndarray, closed: bool = True) -> np.ndarray:
    """Triangles from ``ring`` (counter-clockwise seen from outside) to ``center``."""
    ring = np.asarray(ring)
    nxt = np.roll(ring, -1) if closed else ring[1:]
    cur = ring if closed else ring[:-1]
    return np.stack([cur, nxt, np.full_like(cur, center)], 1)


# ---------------------------------------------------------------------------------------------
# analysis
# ---------------------------------------------------------------------------------------------


def vertex_normals(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    fn = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    n = np.zeros_like(v, dtype=float)
    for k in range(3):
        np.add.at(n, f[:, k], fn)
    return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)


def directed_edges(f: np.ndarray) -> np.ndarray:
    return np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])


def boundary_edges(f: np.ndarray) -> np.ndarray:
    """Directed edges used by exactly one triangle (and whose reverse is unused)."""
    e = directed_edges(f)
    key = np.sort(e, 1)
    _, inv, cnt = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    return e[cnt[inv.ravel()] == 1]


def boundary_loops(f: np.ndarray) -> list[np.ndarray]:
    """Boundary edges chained into loops (vertex index arrays)."""
    be = boundary_edges(f)
    nxt = {int(a): int(b) for a, b in be}
    loops = []
    seen: set[int] = set()
    for start in list(nxt):
        if start in seen:
            continue
        loop = [start]
        seen.add(start)
        cur = nxt[start]
        while cur != start and cur in nxt and cur not in seen:
            loop.append(cur)
            seen.add(cur)
            cur = nxt[cur]
        loops.append(np.array(loop))
    return loops


def is_oriented_manifold(f: np.ndarray) -> bool:
    """Every undirected edge used at most twice, and shared edges run in opposite directions."""
    e = directed_edges(f)
    if len(np.unique(e, axis=0)) != len(e):
        return False
    key = np.sort(e, 1)
    _, cnt = np.unique(key, axis=0, return_counts=True)
    return bool(cnt.max() <= 2)


def signed_volume(v: np.ndarray, f: np.ndarray) -> float:
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)


def uv_sphere(n_lat: int, n_lon: int):
    """Unit sphere with poles on ±z: returns (vertices, faces, polar angle per vertex).

    Vertex 0 is the +z pole, the last vertex the −z pole.
    """
    th = np.linspace(0, np.pi, n_lat + 1)[1:-1]
    ph = np.linspace(0, 2 * np.pi, n_lon, endpoint=False)
    T, P = np.meshgrid(th, ph, indexing="ij")
    pts = np.stack([np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)], -1).reshape(-1, 3)
    v = np.concatenate([[[0, 0, 1.0]], pts, [[0, 0, -1.0]]])
    theta = np.concatenate([[0.0], T.ravel(), [np.pi]])
    rings = [1 + k * n_lon + np.arange(n_lon) for k in range(n_lat - 1)]
    faces = [np.stack([rings[0], np.full(n_lon, 0), np.roll(rings[0], -1)], 1)]
    for r0, r1 in itertools.pairwise(rings):
        faces.append(np.stack([r0, np.roll(r0, -1), np.roll(r1, -1)], 1))
        faces.append(np.stack([r0, np.roll(r1, -1), r1], 1))
    last = len(v) - 1
    faces.append(np.stack([rings[-1], np.roll(rings[-1], -1), np.full(n_lon, last)], 1))
    f = np.concatenate(faces)
    if signed_volume(v, f) < 0:
        f = f[:, ::-1]
    return v, f, theta


def winding_number(v: np.ndarray, f: np.ndarray, q: np.ndarray, chunk: int = 32) -> np.ndarray:
    """Generalised winding number of the closed mesh ``(v, f)`` at points ``q`` (1 inside)."""
    out = np.empty(len(q))
    for s in range(0, len(q), chunk):
        p = q[s : s + chunk, None, None, :]
        a = v[f][None] - p  # (Q, F, 3, 3)
        la = np.linalg.norm(a, axis=-1)
        x, y, z = a[..., 0, :], a[..., 1, :], a[..., 2, :]
        det = np.einsum("qfi,qfi->qf", x, np.cross(y, z))
        den = (la[..., 0] * la[..., 1] * la[..., 2] + np.einsum("qfi,qfi->qf", x, y) * la[..., 2]
               + np.einsum("qfi,qfi->qf", y, z) * la[..., 0]
               + np.einsum("qfi,qfi->qf", z, x) * la[..., 1])
        out[s : s + chunk] = np.arctan2(det, den).sum(1) / (2 * np.pi)
    return out
