"""The built-in head's skin: one implicit surface sampled along rays, with eye and mouth pockets.

The skin is the outer zero set of one implicit function (a smooth blend of ellipsoids, capsules
and spheres plus a lip relief defined over directions), sampled along rays from a centre inside
the head. The ray directions form a structured grid in (azimuth, elevation): a fine face patch
whose rows follow the eyelid margins and the lips, a coarser band round the sides and back, and
ring caps at the crown and under the neck, stitched together. The eye openings and the mouth
slit are cuts along grid rows; each leads into a closed pocket (eye socket, mouth cavity), so the
skin object is a watertight 2-manifold. Resolutions 0/1/2 sample the *same* implicit surface at
different densities. All shape numbers live in ``data/builtin_head.json``.

Coordinates: cm, y up, +z forward (the face looks toward +z), +x toward the subject's left.
"""

from __future__ import annotations

import functools
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.interpolate import PchipInterpolator

from mimika.face import meshgen as mg

DATA = Path(__file__).parents[1] / "data" / "builtin_head.json"

RESOLUTIONS = (0, 1, 2)


@functools.lru_cache(maxsize=1)
def params() -> dict:
    with open(DATA, encoding="utf-8") as fh:
        return json.load(fh)


# =============================================================================================
# the implicit skin
# =============================================================================================


def _rot(deg_y: float, deg_x: float) -> np.ndarray:
    ay, ax = np.radians(deg_y), np.radians(deg_x)
    ry = np.array([[np.cos(ay), 0, np.sin(ay)], [0, 1, 0], [-np.sin(ay), 0, np.cos(ay)]])
    rx = np.array([[1, 0, 0], [0, np.cos(ax), -np.sin(ax)], [0, np.sin(ax), np.cos(ax)]])
    return ry @ rx


def _primitive(item: dict, p: np.ndarray) -> np.ndarray:
    shape = item["shape"]
    if "rot_y" in item or "rot_x" in item:
        c = np.asarray(item["c"], float)
        r = _rot(item.get("rot_y", 0.0), item.get("rot_x", 0.0))
        p = (p - c) @ r + c  # local frame: rotate the point by R^T about c
    if shape == "ellipsoid":
        return mg.sd_ellipsoid(p, item["c"], item["r"], item.get("n", 2.0))
    if shape == "sphere":
        return mg.sd_sphere(p, item["c"], item["r"])
    if shape == "round_cone":
        return mg.sd_round_cone(p, item["a"], item["b"], item["ra"], item["rb"])
    if shape == "plane_y_above":
        return item["y"] - p[..., 1]
    raise ValueError(f"unknown primitive {shape!r}")


def _bound(item: dict) -> tuple[np.ndarray, float] | None:
    """A bounding sphere (centre, radius) of a primitive or group; None when unbounded."""
    if "items" in item:
        bs = [_bound(i) for i in item["items"]]
        if any(b is None for b in bs):
            return None
        c = np.mean([b[0] for b in bs], 0)
        return c, max(np.linalg.norm(b[0] - c) + b[1] for b in bs)
    shape = item["shape"]
    if shape == "ellipsoid":
        n = item.get("n", 2.0)
        return np.asarray(item["c"], float), float(max(item["r"])) * (1.01 if n == 2.0 else 1.75)
    if shape == "sphere":
        return np.asarray(item["c"], float), float(item["r"])
    if shape == "round_cone":
        a, b = np.asarray(item["a"], float), np.asarray(item["b"], float)
        return 0.5 * (a + b), 0.5 * float(np.linalg.norm(b - a)) + max(item["ra"], item["rb"])
    return None


def _eval_ops(ops: list, p: np.ndarray) -> np.ndarray:
    d = None
    for item in ops:
        k = item.get("k", 0.0)
        op = item["op"]
        if d is None:
            d = _eval_ops(item["items"], p) if "items" in item else _primitive(item, p)
            continue
        # only points the primitive can influence (sphere bound + blend radius)
        if "_bound" not in item:
            item["_bound"] = _bound(item)
        b = item["_bound"]
        if b is None:
            sel = slice(None)
            q = p
        else:
            dp = p - b[0]
            lower = np.sqrt(np.einsum("...i,...i->...", dp, dp)) - b[1]
            near = lower < (d + k if op == "union" else k - d if op == "subtract" else np.inf)
            sel = np.nonzero(near)[0]
            if sel.size == 0:
                continue
            q = p[sel]
        v = _eval_ops(item["items"], q) if "items" in item else _primitive(item, q)
        if op == "union":
            d[sel] = mg.smin(d[sel], v, k)
        elif op == "subtract":
            d[sel] = mg.smax(d[sel], -v, k)
        elif op == "intersect":
            d[sel] = mg.smax(d[sel], v, k)
        else:
            raise ValueError(f"unknown op {op!r}")
    return d


@dataclass
class Shape:
    """The head's shape functions: the implicit skin and the direction-space feature curves."""

    centre: np.ndarray
    ops: list
    mouth: dict
    eyes: dict

    def __post_init__(self) -> None:
        m = self.mouth
        a_c, e_c = self.ae(m["corner"])
        _, e_mid = self.ae(m["inner_mid"])
        _, e_top = self.ae(m["upper_top"])
        _, e_bot = self.ae(m["lower_bottom"])
        self.a_m, self.e_mc, self.e_mmid = a_c, e_c, e_mid
        self.h_up0 = e_top - e_mid
        self.h_lo0 = e_mid - e_bot
        self.h_c = m["corner_height_deg"]
        up = np.asarray(m["upper_profile"], float)
        lo = np.asarray(m["lower_profile"], float)
        self.p_up = PchipInterpolator(up[:, 0], up[:, 1], extrapolate=False)
        self.p_lo = PchipInterpolator(lo[:, 0], lo[:, 1], extrapolate=False)
        self.u_up_max = up[-1, 0]
        self.u_lo_max = lo[-1, 0]
        self._eye_curves()

    # --- directions --------------------------------------------------------------------------
    def ae(self, p) -> tuple[np.ndarray, np.ndarray]:
        """Azimuth and elevation (degrees) of points ``p`` seen from the centre."""
        q = np.asarray(p, float) - self.centre
        a = np.degrees(np.arctan2(q[..., 0], q[..., 2]))
        e = np.degrees(np.arctan2(q[..., 1], np.hypot(q[..., 0], q[..., 2])))
        return a, e

    # --- mouth -------------------------------------------------------------------------------
    def mouth_line(self, a: np.ndarray) -> np.ndarray:
        """Elevation (deg) of the lips' meeting line at azimuth ``a`` (deg)."""
        t = np.abs(a) / self.a_m
        q = np.where(t <= 1, t * t, np.where(t < 2, 1 + 2 * (t - 1) - (t - 1) ** 2, 2.0))
        return self.e_mmid + (self.e_mc - self.e_mmid) * q

    def _bow(self, t: np.ndarray) -> np.ndarray:
        b = self.mouth["cupid_bow"]
        return 1 + b * (np.exp(-(((t - 0.3) / 0.16) ** 2)) - 0.5 * np.exp(-((t / 0.1) ** 2)))

    def lip_heights(self, a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Angular heights (deg) of the upper and lower red lip above/below the mouth line."""
        t = np.minimum(np.abs(a) / self.a_m, 1.0)
        w = np.sqrt(np.clip(1 - t * t, 0, 1))
        hu = self.h_c + (self.h_up0 - self.h_c) * w * self._bow(t)
        hl = self.h_c + (self.h_lo0 - self.h_c) * w
        return hu, hl

    def lip_relief(self, a: np.ndarray, e: np.ndarray) -> np.ndarray:
        """Outward displacement (cm) of the lips over the base face, by direction."""
        t = np.abs(a) / self.a_m
        w = np.clip(1 - t * t, 0, 1) ** self.mouth["amplitude_taper"]
        s = e - self.mouth_line(a)
        hu, hl = self.lip_heights(a)
        uu = np.clip(s / hu, 0, self.u_up_max)
        ul = np.clip(-s / hl, 0, self.u_lo_max)
        return w * np.where(s >= 0, self.p_up(uu), self.p_lo(ul))

    # --- eyes --------------------------------------------------------------------------------
    def _eye_curves(self) -> None:
        ey = self.eyes
        c = np.asarray(ey["centre"], float)
        pin = np.asarray(ey["inner_corner"], float)
        pout = np.asarray(ey["outer_corner"], float)
        t = np.linspace(0, 1, 81)
        x = pin[0] + (pout[0] - pin[0]) * t
        y_line = pin[1] + (pout[1] - pin[1]) * t
        z_line = pin[2] + (pout[2] - pin[2]) * t

        def margin(mid_y, peak_t):
            tc = (c[0] - pin[0]) / (pout[0] - pin[0])
            g = np.log(0.5) / np.log(peak_t)
            tt = t**g
            bump = (4 * tt * (1 - tt)) ** 0.8
            y_at_c = pin[1] + (pout[1] - pin[1]) * tc
            tcc = tc**g
            amp = (mid_y - y_at_c) / (4 * tcc * (1 - tcc)) ** 0.8
            y = y_line + amp * bump
            rr = ey["lid_radius"] ** 2 - (x - c[0]) ** 2 - (y - c[1]) ** 2
            zs = c[2] + np.sqrt(np.maximum(rr, 0))
            z = np.where(rr > 0, np.maximum(zs, z_line), z_line)
            return np.stack([x, y, z], 1)

        self.upper_margin_3d = margin(ey["upper_mid_y"], ey["upper_peak_t"])
        self.lower_margin_3d = margin(ey["lower_mid_y"], ey["lower_peak_t"])
        au, eu = self.ae(self.upper_margin_3d)
        al, el = self.ae(self.lower_margin_3d)
        self.a_in, self.a_out = au[0], au[-1]
        self._eu = (au, eu)
        self._el = (al, el)

    def eye_line(self, a: np.ndarray) -> np.ndarray:
        a = np.abs(a)
        au, eu = self._eu
        return np.interp(a, [au[0], au[-1]], [eu[0], eu[-1]])

    def eye_upper(self, a):
        au, eu = self._eu
        return np.interp(np.abs(a), au, eu)

    def eye_lower(self, a):
        al, el = self._el
        return np.interp(np.abs(a), al, el)

    # --- the implicit function ---------------------------------------------------------------
    def field(self, p: np.ndarray) -> np.ndarray:
        q = np.array(p, float, copy=True)
        q[..., 0] = np.abs(q[..., 0])
        d = _eval_ops(self.ops, q)
        a, e = self.ae(q)
        near = np.abs(a) < 2.5 * self.a_m
        if np.any(near):
            d[near] -= self.lip_relief(a[near], e[near])
        return d

    def cast(self, a_deg: np.ndarray, e_deg: np.ndarray, r_max: float) -> np.ndarray:
        dirs = mg.directions(np.radians(a_deg), np.radians(e_deg))
        r = mg.ray_cast(self.field, self.centre, dirs, r_max)
        return self.centre + dirs * r[:, None]

    def normal(self, p: np.ndarray, h: float = 1e-3) -> np.ndarray:
        g = np.stack([self.field(p + h * np.eye(3)[k]) - self.field(p - h * np.eye(3)[k])
                      for k in range(3)], -1)
        return g / np.linalg.norm(g, axis=-1, keepdims=True)


@functools.lru_cache(maxsize=1)
def shape() -> Shape:
    P = params()
    return Shape(np.asarray(P["centre"], float), P["field"], P["mouth"], P["eyes"])


# =============================================================================================
# sampling grids
# =============================================================================================


def _knots(values: list[float], counts: list[int], scale: float) -> np.ndarray:
    out = [values[0]]
    for v0, v1, n in zip(values[:-1], values[1:], counts, strict=True):
        k = max(1, round(n * scale))
        out.extend(np.linspace(v0, v1, k + 1)[1:])
    return np.asarray(out, float)


class _Builder:
    """Collects the ray directions (azimuth, elevation in degrees) of the skin's vertices."""

    def __init__(self, r_max: float) -> None:
        self.r_max = r_max
        self.ae: list[np.ndarray] = []
        self.n = 0

    def add_dirs(self, a: np.ndarray, e: np.ndarray) -> np.ndarray:
        a = np.asarray(a, float).ravel()
        e = np.asarray(e, float).ravel()
        self.ae.append(np.stack([a, e], 1))
        idx = np.arange(self.n, self.n + len(a))
        self.n += len(a)
        return idx


def build_skin(res: int):
    P = params()
    G = P["grid"]
    S = shape()
    sc = G["resolution_scale"][res]
    B = _Builder(P["r_max"])

    # ---- face patch: columns (azimuth) -----------------------------------------------------
    named = {"eye_in": S.a_in, "eye_out": S.a_out, "mouth": S.a_m}
    az_kn = [named.get(v, v) if isinstance(v, str) else v for v in G["patch_az"]]
    half = _knots(az_kn, G["patch_az_counts"], sc)
    cols = np.concatenate([-half[:0:-1], half])  # symmetric, includes 0
    a_edge = half[-1]

    # ---- face patch: per-column row knots ----------------------------------------------------
    A = cols
    mline = S.mouth_line(A)
    hu, hl = S.lip_heights(A)
    eline = S.eye_line(A)
    eup = S.eye_upper(A)
    elo = S.eye_lower(A)
    k_rows = [
        np.full_like(A, G["patch_el_bottom"]),
        np.full_like(A, G["patch_el_chin"]),
        mline - hl,
        mline,  # mouth slit
        mline + hu,
        eline - G["eye_below_deg"] + 0.3 * (elo - eline),
        None,  # eye slit (lower/upper copies)
        eline + G["eye_above_deg"] + 0.3 * (eup - eline),
        np.full_like(A, G["patch_el_top"]),
    ]
    counts = [max(1, round(n * sc)) for n in G["patch_el_counts"]]
    rows_lo: list[np.ndarray] = []  # each entry: elevations per column
    slit_rows = {}
    for s in range(len(k_rows) - 1):
        e0 = k_rows[s] if k_rows[s] is not None else eup
        e1 = k_rows[s + 1] if k_rows[s + 1] is not None else elo
        n = counts[s]
        start = 0 if s == 0 else 1
        for i in range(start, n + 1):
            rows_lo.append(e0 + (e1 - e0) * i / n)
        if s == 2:
            slit_rows["mouth"] = len(rows_lo) - 1
        if s == 5:
            slit_rows["eye"] = len(rows_lo) - 1
            rows_lo.append(eup.copy())  # the upper copy row sits right above
    E = np.stack(rows_lo, 1)  # (cols, rows)
    ncol, nrow = E.shape
    jm, je = slit_rows["mouth"], slit_rows["eye"]
    # the mouth slit needs an upper copy too: insert a duplicate row after jm
    E = np.concatenate([E[:, : jm + 1], E[:, jm : jm + 1], E[:, jm + 1 :]], 1)
    je += 1
    nrow = E.shape[1]
    # columns strictly inside the openings get separate upper/lower vertices
    in_mouth = np.abs(A) < S.a_m - 1e-9
    # the lips' inner edges: two rows a hair apart (closed mouth, open mesh)
    t = np.minimum(np.abs(A) / S.a_m, 1)
    gap = np.degrees(0.5 * P["mouth"]["lip_gap"] / 11.0) * np.sqrt(1 - t * t)
    E[:, jm] -= gap
    E[:, jm + 1] += gap
    in_eye = (np.abs(A) > S.a_in + 1e-9) & (np.abs(A) < S.a_out - 1e-9)
    AA = np.repeat(A[:, None], nrow, 1)
    idx = np.empty((ncol, nrow), int)
    for j in range(nrow):
        if j == jm + 1:
            dup = ~in_mouth
            new = B.add_dirs(AA[~dup, j], E[~dup, j])
            idx[dup, j] = idx[dup, j - 1]
            idx[~dup, j] = new
        elif j == je + 1:
            dup = ~in_eye
            new = B.add_dirs(AA[~dup, j], E[~dup, j])
            idx[dup, j] = idx[dup, j - 1]
            idx[~dup, j] = new
        else:
            idx[:, j] = B.add_dirs(AA[:, j], E[:, j])
    patch_faces = mg.grid_faces(idx, skip_rows=(jm, je))
    # material masks for the patch: lips = between lower and upper lip border rows, |a| <= a_m
    j_lip0 = jm - counts[2]
    j_lip1 = jm + 1 + counts[3]

    # ---- side band (around the back) -----------------------------------------------------------
    side_half = _knots(G["side_az"], G["side_az_counts"], sc)
    side_cols = np.concatenate([side_half[1:], 360.0 - side_half[-2:0:-1]])
    side_rows = _knots(G["side_el"], G["side_el_counts"], sc)
    SA, SE = np.meshgrid(side_cols, side_rows, indexing="ij")
    sidx = B.add_dirs(np.where(SA > 180, SA - 360, SA), SE).reshape(SA.shape)
    side_faces = mg.grid_faces(sidx)

    # seams between the patch edge columns and the side band (param: elevation)
    def col_unique(c):
        v = idx[c]
        keep = np.ones(len(v), bool)
        keep[1:] = v[1:] != v[:-1]
        return v[keep], E[c][keep]

    right_v, right_e = col_unique(ncol - 1)  # a = +a_edge
    left_v, left_e = col_unique(0)  # a = -a_edge
    seam_faces = [
        mg.zipper(right_v, right_e, sidx[0], side_rows)[:, ::-1],
        mg.zipper(sidx[-1], side_rows, left_v, left_e)[:, ::-1],
    ]

    # ---- crown cap -----------------------------------------------------------------------------
    top_loop = np.concatenate([idx[:, -1], sidx[:, -1]])
    top_t = np.concatenate([A, side_cols])
    e_top = G["patch_el_top"]
    step = G["cap_step_deg"] / sc
    cap_e = np.arange(e_top + step, 90 - 0.5 * step, step)
    prev, prev_t = top_loop, top_t
    cap_faces = []
    for ee in cap_e:
        m = max(6, round(360 * np.cos(np.radians(ee)) / step))
        t = -a_edge + (np.arange(m) + 0.5) * 360.0 / m
        ring = B.add_dirs(np.where(t > 180, t - 360, t), np.full(m, ee))
        cap_faces.append(mg.zipper(prev, prev_t, ring, t, closed=True, period=360.0))
        prev, prev_t = ring, t
    pole = B.add_dirs([0.0], [90.0])[0]
    cap_faces.append(mg.fan(pole, prev))

    # ---- neck and its bottom ---------------------------------------------------------------------
    bot_loop = np.concatenate([idx[:, 0], sidx[:, 0]])
    bot_t = top_t
    e_bot = G["patch_el_bottom"]
    cy = S.centre[1]
    rn = G["neck_radius"]
    y0 = cy - rn * np.tan(np.radians(-e_bot))
    dy = G["neck_step_cm"] / sc
    ys = np.arange(y0 - dy, -19.5 + 0.5 * dy, -dy)
    neck_e = list(-np.degrees(np.arctan((cy - ys) / rn)))
    # bottom disc (y = -19.5): rings by radius
    disc_r = np.arange(rn - dy, 0.5 * dy, -dy)
    neck_e += list(-np.degrees(np.arctan((cy + 19.5) / disc_r)))
    neck_faces = []
    prev, prev_t = bot_loop, bot_t
    for k, ee in enumerate(neck_e):
        if k < len(ys):
            m = max(8, round(G["neck_count"] * sc))
        else:
            m = max(6, round(G["neck_count"] * sc * disc_r[k - len(ys)] / rn))
        t = -a_edge + (np.arange(m) + 0.5) * 360.0 / m
        ring = B.add_dirs(np.where(t > 180, t - 360, t), np.full(m, ee))
        neck_faces.append(mg.zipper(ring, t, prev, prev_t, closed=True, period=360.0))
        prev, prev_t = ring, t
    pole = B.add_dirs([0.0], [-90.0])[0]
    neck_faces.append(mg.fan(pole, prev[::-1]))

    # ---- positions ---------------------------------------------------------------------------
    ae = np.concatenate(B.ae)
    V = S.cast(ae[:, 0], ae[:, 1], B.r_max)

    skin_f = np.concatenate([patch_faces, side_faces, *seam_faces, *cap_faces, *neck_faces])
    info = dict(idx=idx, E=E, A=A, jm=jm, je=je, j_lip0=j_lip0, j_lip1=j_lip1,
                in_mouth=in_mouth, in_eye=in_eye, ncol=ncol, side_idx=sidx, ae=ae)
    return V, skin_f, info



# =============================================================================================
# pockets behind the openings
# =============================================================================================


def opening_loop(info: dict, c_lo: int, c_hi: int, j_lower: int) -> np.ndarray:
    """Boundary loop of a slit opening between corner columns ``c_lo`` < ``c_hi``.

    Ordered: corner c_lo, lower copies left→right, corner c_hi, upper copies right→left.
    """
    idx = info["idx"]
    lower = idx[c_lo + 1 : c_hi, j_lower]
    upper = idx[c_lo + 1 : c_hi, j_lower + 1]
    return np.concatenate([[idx[c_lo, j_lower]], lower, [idx[c_hi, j_lower]], upper[::-1]])


def eye_socket(V: np.ndarray, loop: np.ndarray, centre: np.ndarray, res: int, ey: dict):
    """Rings from the lid margin back round a sphere behind the eyeball, closed at the back."""
    sc = params()["grid"]["resolution_scale"][res]
    m = V[loop] - centre
    rho = np.linalg.norm(m, axis=1)
    u = m / rho[:, None]
    th0 = np.arccos(np.clip(u[:, 2], -1, 1))
    ph = np.arctan2(u[:, 1], u[:, 0])
    nk = max(6, round(ey["socket_rings"] * sc))
    rs = ey["socket_radius"]
    th_end = np.pi * 0.96
    # chords between rings and round each ring stay outside the socket radius
    dth = (th_end - th0.min()) / nk
    r_out = rs / np.cos(0.5 * max(dth, 2 * np.pi / len(loop)))
    pts, rings = [], []
    base = len(V)
    # round the socket the rings relax from the margin's angles to evenly spaced ones
    ph = np.unwrap(ph)
    sgn = 1.0 if ph[-1] > ph[0] else -1.0
    ph = sgn * ph
    ph_u = ph[0] + 2 * np.pi * np.arange(len(ph)) / len(ph)
    for k in range(1, nk + 1):
        th = th0 + (th_end - th0) * k / nk
        r = np.full_like(rho, r_out) if k > 1 else 0.25 * rho + 0.75 * r_out
        b = min(1.0, k / 3)  # angle blend
        phk = sgn * (ph + (ph_u - ph) * b)
        q = np.stack([np.sin(th) * np.cos(phk), np.sin(th) * np.sin(phk), np.cos(th)], 1)
        pts.append(centre + q * r[:, None])
        rings.append(base + (k - 1) * len(loop) + np.arange(len(loop)))
    back = base + nk * len(loop)
    P = np.concatenate([*pts, [centre + np.array([0, 0, -r_out])]])
    F = [mg.ring_strips([loop, *rings], closed=True), mg.fan(back, rings[-1])]
    return P, F


def mouth_pocket(V: np.ndarray, loop: np.ndarray, res: int):
    """The mouth cavity: rings from the lips' inner edges back into a closed dark bag."""
    P = params()["mouth_cavity"]
    m = V[loop]
    xc = np.abs(m[:, 0]).max()
    # angle round the mouth: 0 at the +x corner, pi/2 upper middle, pi at the -x corner
    cth = np.clip(m[:, 0] / xc, -1, 1)
    n = len(loop)
    up = np.zeros(n, bool)
    up[(n - 2) // 2 + 2 :] = True  # loop order: corner, lower..., corner, upper...
    th = np.where(up, np.arccos(cth), 2 * np.pi - np.arccos(cth))
    z0 = m[np.argmin(np.abs(m[:, 0])), 2]
    base = len(V)
    pts, rings, mats = [], [], []
    for k, (dep, w, hu, hl, yc, fall, lo_dep, mat) in enumerate(P["rings"]):
        pw = 1.0 if mat == "lips" else P["squareness"]
        c, s = np.cos(th), np.sin(th)
        c = np.sign(c) * np.abs(c) ** pw
        s = np.sign(s) * np.abs(s) ** pw
        x = w * c
        y = yc + np.where(s >= 0, hu, hl) * s
        z = z0 - dep - fall * x * x - lo_dep * np.maximum(-s, 0)
        if k == 0:  # lip roll: follow the actual lip edge closely
            x = 0.5 * (x + m[:, 0] * 0.97)
            z = np.minimum(z, m[:, 2] - 0.12)
        pts.append(np.stack([x, y, z], 1))
        rings.append(base + k * n + np.arange(n))
        mats.append(mat)
    back = base + len(rings) * n
    yb = P["rings"][-1][4]
    Pp = np.concatenate([*pts, [[0.0, yb, z0 - P["back_depth"]]]])
    all_rings = [loop, *rings]
    F = {}
    for k in range(len(rings)):
        f = mg.ring_strips([all_rings[k], all_rings[k + 1]], closed=True)
        F.setdefault(mats[k], []).append(f)
    F.setdefault("mouth", []).append(mg.fan(back, rings[-1]))
    return Pp, F




def brow_centre(u: np.ndarray) -> np.ndarray:
    """Points on the skin under the left brow's centre line at parameters ``u`` in [0, 1]."""
    B = params()["brows"]
    S = shape()
    cl = np.asarray(B["centreline"], float)
    knots = np.linspace(0, 1, len(cl))
    x = PchipInterpolator(knots, cl[:, 0])(u)
    y = PchipInterpolator(knots, cl[:, 1])(u)
    org = np.stack([x, y, np.zeros_like(x)], 1)
    d = np.tile([0.0, 0.0, 1.0], (len(u), 1))
    return org + d * mg.ray_cast(S.field, org, d, 25.0)[:, None]
