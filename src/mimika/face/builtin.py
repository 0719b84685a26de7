"""mimika's built-in head, made entirely by code: a stylised, closed, animatable human head.

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
import itertools
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.interpolate import PchipInterpolator

from mimika.errors import ParameterError
from mimika.face import meshgen as mg
from mimika.face.head import Head, MeshObject, Part

DATA = Path(__file__).parent / "data" / "builtin_head.json"

RESOLUTIONS = (0, 1, 2)


@functools.lru_cache(maxsize=1)
def _params() -> dict:
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
class _Shape:
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
def _shape() -> _Shape:
    P = _params()
    return _Shape(np.asarray(P["centre"], float), P["field"], P["mouth"], P["eyes"])


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


def _build_skin(res: int):
    P = _params()
    G = P["grid"]
    S = _shape()
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


def _opening_loop(info: dict, c_lo: int, c_hi: int, j_lower: int) -> np.ndarray:
    """Boundary loop of a slit opening between corner columns ``c_lo`` < ``c_hi``.

    Ordered: corner c_lo, lower copies left→right, corner c_hi, upper copies right→left.
    """
    idx = info["idx"]
    lower = idx[c_lo + 1 : c_hi, j_lower]
    upper = idx[c_lo + 1 : c_hi, j_lower + 1]
    return np.concatenate([[idx[c_lo, j_lower]], lower, [idx[c_hi, j_lower]], upper[::-1]])


def _eye_socket(V: np.ndarray, loop: np.ndarray, centre: np.ndarray, res: int, ey: dict):
    """Rings from the lid margin back round a sphere behind the eyeball, closed at the back."""
    sc = _params()["grid"]["resolution_scale"][res]
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


def _mouth_pocket(V: np.ndarray, loop: np.ndarray, res: int):
    """The mouth cavity: rings from the lips' inner edges back into a closed dark bag."""
    P = _params()["mouth_cavity"]
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


# =============================================================================================
# eyes, teeth, tongue, brows
# =============================================================================================


def _eyeball(side: int, res: int) -> MeshObject:
    ey = _params()["eyes"]
    sc = _params()["grid"]["resolution_scale"][res]
    R = ey["radius"]
    c = np.array(ey["centre"], float) * [side, 1, 1]
    th_p = np.arcsin(ey["pupil_radius"] / R)
    th_i = np.arcsin(ey["iris_radius"] / R)
    n_p, n_i, n_s = (max(1, round(k * sc)) for k in ey["rings"])
    th = np.concatenate([np.linspace(0, th_p, n_p + 1)[1:], np.linspace(th_p, th_i, n_i + 1)[1:],
                         np.linspace(th_i, np.pi, n_s + 1)[1:-1]])
    nl = max(12, round(ey["n_lon"] * sc))
    ph = np.linspace(0, 2 * np.pi, nl, endpoint=False)
    TH, PH = np.meshgrid(th, ph, indexing="ij")
    rho = R * np.sin(TH)
    z = R * np.cos(TH)
    # flattened, slightly concave iris disc
    zi = R * np.cos(th_i) - ey["iris_depth"] * (1 - (rho / (R * np.sin(th_i))) ** 2)
    z = np.where(th_i + 1e-9 >= TH, zi, z)
    pts = np.stack([rho * np.cos(PH), rho * np.sin(PH), z], -1).reshape(-1, 3)
    front = np.array([[0, 0, R * np.cos(th_i) - ey["iris_depth"]]])
    back = np.array([[0, 0, -R]])
    v = np.concatenate([front, pts, back]) + c
    rings = [1 + k * nl + np.arange(nl) for k in range(len(th))]
    last = len(v) - 1
    faces = [np.stack([rings[0], np.roll(rings[0], -1), np.zeros(nl, int)], 1)]
    for r0, r1 in itertools.pairwise(rings):
        faces.append(np.concatenate([np.stack([r0, r1, np.roll(r1, -1)], 1),
                                     np.stack([r0, np.roll(r1, -1), np.roll(r0, -1)], 1)]))
    faces.append(np.stack([rings[-1], np.full(nl, last), np.roll(rings[-1], -1)], 1))
    # orient outward
    tmp = np.concatenate(faces)
    if mg.signed_volume(v - c, tmp) < 0:
        faces = [f[:, ::-1] for f in faces]
    pupil = np.concatenate(faces[: n_p])
    iris = np.concatenate(faces[n_p : n_p + n_i])
    sclera = np.concatenate(faces[n_p + n_i :])
    name = "eye_L" if side > 0 else "eye_R"
    return MeshObject(name, "eyes", v, (Part("sclera", sclera), Part("iris", iris),
                                        Part("pupil", pupil)), pivot=c)


def _teeth(which: str, res: int) -> MeshObject:
    T = _params()["teeth"]
    P = T[which]
    sc = _params()["grid"]["resolution_scale"][res]
    sgn = P["sign"]  # +1 upper (edge at the bottom), -1 lower (edge at the top)
    widths = np.asarray(T["widths"], float)
    phimax = np.radians(T["arch_end_deg"])
    # arc length of the arch x = W sin(phi), z = z0 - D (1 - cos(phi))
    W, D, z0 = P["arch_half_width"], P["arch_depth"], P["front_z"]
    fine = np.linspace(0, phimax, 400)
    ds = np.hypot(W * np.cos(fine), D * np.sin(fine))
    arc = np.concatenate([[0], np.cumsum(0.5 * (ds[1:] + ds[:-1]) * np.diff(fine))])
    bounds = np.concatenate([[0], np.cumsum(widths)]) * arc[-1] / widths.sum()
    nper = max(3, round(T["samples_per_tooth"] * sc))
    s_half, u_half = [0.0], [0.0]
    for k in range(len(widths)):
        loc = np.linspace(0, 1, nper + 1)[1:]
        s_half.extend(bounds[k] + (bounds[k + 1] - bounds[k]) * loc)
        u_half.extend(loc)
    s_half = np.asarray(s_half)
    u_half = np.asarray(u_half)
    phi_half = np.interp(s_half, arc, fine)
    phi = np.concatenate([-phi_half[:0:-1], phi_half])
    u = np.concatenate([u_half[:0:-1], u_half])  # 0/1 at tooth borders
    frac = np.clip(np.abs(phi) / phimax, 0, 1)
    x = W * np.sin(phi)
    z = z0 - D * (1 - np.cos(phi))
    nx, nz = np.sin(phi) * D, np.cos(phi) * W
    nn = np.hypot(nx, nz)
    nx, nz = nx / nn, nz / nn
    th = P["thickness"][0] + (P["thickness"][1] - P["thickness"][0]) * frac**1.5
    border = np.abs(np.cos(np.pi * u))  # 1 at tooth borders, 0 mid-tooth
    border = np.where(np.abs(phi) < 1e-9, 1.0, border)
    edge = P["edge_y"] + sgn * T["scallop"] * border**3 + sgn * 0.06 * frac
    gum = P["gum_y"] - sgn * T["gum_scallop"] * border**4
    groove = T["groove"] * border**6
    top = P["top_y"]
    mid = 0.5 * (gum + edge)
    # cross-section (offset along the outward normal, y); labial face at offset 0
    sec = [
        (-0.12, np.full_like(phi, top), "gums"),
        (0.02 - 0.0 * groove, gum, "gums"),
        (0.03 - groove, mid, "teeth"),
        (-0.02 - groove, edge + sgn * 0.1, "teeth"),
        (-0.14, edge, "teeth"),
        (-th + 0.15, edge + sgn * 0.06, "teeth"),
        (-th, gum, "teeth"),
        (-th + 0.1, np.full_like(phi, top), "gums"),
    ]
    ns = len(sec)
    pts = []
    for off, yy, _ in sec:
        off = np.broadcast_to(off, phi.shape)
        pts.append(np.stack([x + off * nx, yy, z + off * nz], 1))
    v = np.stack(pts, 1).reshape(-1, 3)  # index = i*ns + k
    n_a = len(phi)
    idx = np.arange(n_a * ns).reshape(n_a, ns)
    faces = {"teeth": [], "gums": []}
    for k in range(ns):
        k2 = (k + 1) % ns
        mat = "gums" if sec[k][2] == "gums" and sec[k2][2] == "gums" else (
            "gums" if k == 0 or k == ns - 1 else "teeth")
        q = np.stack([idx[:-1, k], idx[1:, k], idx[1:, k2], idx[:-1, k2]], 1)
        faces[mat].append(np.concatenate([q[:, [0, 1, 2]], q[:, [0, 2, 3]]]))
    # end caps
    c0 = len(v)
    v = np.concatenate([v, v[idx[0]].mean(0, keepdims=True), v[idx[-1]].mean(0, keepdims=True)])
    faces["gums"].append(mg.fan(c0, idx[0]))
    faces["gums"].append(mg.fan(c0 + 1, idx[-1][::-1]))
    allf = np.concatenate([np.concatenate(f) for f in faces.values()])
    flip = mg.signed_volume(v, allf) < 0
    parts = []
    for mat in ("teeth", "gums"):
        f = np.concatenate(faces[mat])
        parts.append(Part(mat, f[:, ::-1] if flip else f))
    return MeshObject(f"teeth_{which}", "teeth", v, tuple(parts))


def _tongue(res: int) -> MeshObject:
    T = _params()["tongue"]
    sc = _params()["grid"]["resolution_scale"][res]
    v, f, _ = mg.uv_sphere(max(6, round(T["n_lat"] * sc)), max(8, round(T["n_lon"] * sc)))
    v = v[:, [0, 2, 1]] * [1, 1, 1]  # poles on ±y
    f = f[:, ::-1]  # the axis swap mirrors
    r = np.asarray(T["r"], float)
    p = v * r
    p[:, 1] = np.where(p[:, 1] > 0, p[:, 1] * (1 - 0.35 * (p[:, 0] / r[0]) ** 2), p[:, 1])
    p += T["c"]
    if mg.signed_volume(p, f) < 0:
        f = f[:, ::-1]
    return MeshObject("tongue", "teeth", p, (Part("tongue", f),))


def _brows(res: int) -> MeshObject:
    B = _params()["brows"]
    S = _shape()
    sc = _params()["grid"]["resolution_scale"][res]
    cl = np.asarray(B["centreline"], float)
    nu, nv = (max(3, round(k * sc)) for k in B["samples"])
    knots = np.linspace(0, 1, len(cl))
    spl_x = PchipInterpolator(knots, cl[:, 0])
    spl_y = PchipInterpolator(knots, cl[:, 1])
    u = np.linspace(0, 1, nu + 1)
    v = np.linspace(-1, 1, nv + 1)
    U, Vv = np.meshgrid(u, v, indexing="ij")
    cx, cy = spl_x(U), spl_y(U)
    dx, dy = spl_x(U, 1), spl_y(U, 1)
    nrm = np.hypot(dx, dy)
    w = np.interp(U, knots, B["width"])
    px = cx - dy / nrm * Vv * w / 2
    py = cy + dx / nrm * Vv * w / 2
    org = np.stack([px.ravel(), py.ravel(), np.zeros(px.size)], 1)
    dirs = np.tile([0.0, 0.0, 1.0], (len(org), 1))
    r = mg.ray_cast(S.field, org, dirs, 25.0)
    base = org + dirs * r[:, None]
    n = S.normal(base)
    th = np.interp(U, knots, B["thickness"]).ravel()
    prof = np.sqrt(np.clip(1 - Vv.ravel() ** 2, 0, 1)) ** 0.7
    hair = 1 + 0.12 * np.sin(2 * np.pi * (U.ravel() * nu * 0.5 + 0.25))
    h = th * prof * hair - B["sink"] * (1 - prof)
    pts = base + n * h[:, None]
    idx = np.arange(len(pts)).reshape(U.shape)
    f = mg.grid_faces(idx)  # u → +x, v → up: counter-clockwise seen from the front
    left = pts
    right = pts * [-1, 1, 1]
    verts = np.concatenate([left, right])
    faces = np.concatenate([f, f[:, ::-1] + len(left)])
    return MeshObject("brows", "face", verts, (Part("brow", faces),))


# =============================================================================================
# the head
# =============================================================================================


def _nearest(V: np.ndarray, cand: np.ndarray, p) -> int:
    d = np.linalg.norm(V[cand] - np.asarray(p, float), axis=1)
    return int(cand[np.argmin(d)])


def _skin_uvs(S: _Shape, V: np.ndarray, ae: np.ndarray) -> np.ndarray:
    """Texture coordinates of the skin, shape (N, 2) in [0, 1]: the ray parametrisation the
    skin is sampled with (azimuth → u, elevation → v, equirectangular around the vertical
    axis through the head centre), so the only seam runs down the back of the head. Vertices
    of the pockets behind the openings (not on a ray) use their direction from the centre."""
    a = np.empty(len(V))
    e = np.empty(len(V))
    a[: len(ae)], e[: len(ae)] = ae[:, 0], ae[:, 1]
    if len(V) > len(ae):
        pa, pe = S.ae(V[len(ae):])
        a[len(ae):], e[len(ae):] = pa, pe
    return np.stack([(a + 180.0) / 360.0, (e + 90.0) / 180.0], 1).astype(np.float32)


@functools.lru_cache(maxsize=len(RESOLUTIONS))
def build_builtin_head(resolution: int = 1) -> Head:
    """The built-in head at ``resolution`` 0 (coarse), 1 (default, < 25k triangles) or 2 (fine).

    All resolutions sample the same surfaces. Deterministic; cached per resolution.
    """
    if resolution not in RESOLUTIONS:
        raise ParameterError(f"resolution={resolution!r} must be one of {RESOLUTIONS} "
                             "(0 coarse, 1 default, 2 fine)")
    Pm = _params()
    S = _shape()
    V, F, info = _build_skin(resolution)
    A, idx = info["A"], info["idx"]
    col = {k: int(np.argmin(np.abs(A - v))) for k, v in
           (("mR", -S.a_m), ("mL", S.a_m), ("eRo", -S.a_out), ("eRi", -S.a_in),
            ("eLi", S.a_in), ("eLo", S.a_out))}
    jm, je = info["jm"], info["je"]

    # materials on the skin: lips by direction of the face centroid
    ae = info["ae"]
    fa = ae[F].mean(1)
    hu, hl = S.lip_heights(fa[:, 0])
    ml = S.mouth_line(fa[:, 0])
    lips = (np.abs(fa[:, 0]) < S.a_m) & (fa[:, 1] < ml + hu + 1e-6) & (fa[:, 1] > ml - hl - 1e-6)
    parts = {"skin": [F[~lips]], "lips": [F[lips]], "mouth": [], "socket": []}

    # eye sockets
    ey = Pm["eyes"]
    verts = [V]
    nv = len(V)
    for side, (c0, c1) in ((1, ("eLi", "eLo")), (-1, ("eRo", "eRi"))):
        loop = _opening_loop(info, col[c0], col[c1], je)
        centre = np.asarray(ey["centre"], float) * [side, 1, 1]
        allv = np.concatenate(verts)
        P, Fs = _eye_socket(allv, loop, centre, resolution, ey)
        Fs = [f + 0 for f in Fs]
        verts.append(P)
        fs = np.concatenate(Fs)
        fs = mg.orient_like(fs, F)
        parts["socket"].append(fs)
        nv += len(P)
    # mouth pocket
    loop = _opening_loop(info, col["mR"], col["mL"], jm)
    allv = np.concatenate(verts)
    P, Fd = _mouth_pocket(allv, loop, resolution)
    verts.append(P)
    pocket = np.concatenate([np.concatenate(fl) for fl in Fd.values()])
    flip = mg.orient_like(pocket, F) is not pocket
    for mat, fl in Fd.items():
        for f in fl:
            parts[mat].append(f[:, ::-1] if flip else f)
    Vs = np.concatenate(verts)
    skin = MeshObject("skin", "face", Vs, tuple(Part(m, np.concatenate(f))
                                                 for m, f in parts.items() if f),
                      uvs=_skin_uvs(S, Vs, ae))

    objects = [skin, _brows(resolution), _eyeball(1, resolution), _eyeball(-1, resolution),
               _teeth("upper", resolution), _teeth("lower", resolution), _tongue(resolution)]

    # ---- landmarks, anchors, regions -------------------------------------------------------
    lm, regions = _landmarks(Vs, info, col, len(V))
    lmp = Vs[lm]
    ey = np.asarray(Pm["eyes"]["centre"], float)
    anc = Pm["anchors"]
    anchors = {
        "mouth_corner_L": Vs[idx[col["mL"], jm]],
        "mouth_corner_R": Vs[idx[col["mR"], jm]],
        "eye_L": ey * [1, 1, 1],
        "eye_R": ey * [-1, 1, 1],
        "chin": lmp[8],
        "nose_tip": lmp[30],
        "brow_L": Vs[regions["brow_mid_L"]],
        "brow_R": Vs[regions["brow_mid_R"]],
        "neck_base": np.asarray(anc["neck_base"], float),
        "neck_pivot": np.asarray(anc["neck_pivot"], float),
        "jaw_pivot": np.asarray(anc["jaw_pivot"], float),
    }
    return Head("builtin", tuple(objects), lm, anchors, landmark_object="skin",
                description="mimika's built-in procedural head (stylised, made by code)",
                meta={"resolution": resolution, "regions": regions})


def _landmarks(V: np.ndarray, info: dict, col: dict, n_outer: int):
    """The 68 Multi-PIE landmarks as skin vertex indices, and named vertex sets."""
    S = _shape()
    Pm = _params()
    idx, A = info["idx"], info["A"]
    jm, je = info["jm"], info["je"]
    outer = np.arange(n_outer)  # outer skin (no pockets)

    def at(a, row):
        return int(idx[int(np.argmin(np.abs(A - a))), row])

    lm = np.zeros(68, int)
    # jaw line, from the subject's right (-x) round the chin to the left
    guide = np.asarray(Pm["landmark_guides"]["jaw"], float)
    a, e = S.ae(guide)
    guide = S.cast(a, e, Pm["r_max"])  # onto the surface
    for k in range(9):
        g = guide[k]
        lm[k] = _nearest(V, outer, g * [-1, 1, 1])
        lm[16 - k] = _nearest(V, outer, g)
    # brows: skin under the brow centreline, outer→inner on the right, inner→outer on the left
    bc = _brow_centre(np.linspace(0, 1, 5))
    for k in range(5):
        lm[22 + k] = _nearest(V, outer, bc[k])
        lm[21 - k] = _nearest(V, outer, bc[k] * [-1, 1, 1])
    # nose
    c0 = int(np.argmin(np.abs(A)))
    colv = idx[c0]
    top = np.asarray(Pm["landmark_guides"]["nose_bridge_top"], float)
    lm[27] = _nearest(V, colv, top)
    tip = int(colv[np.argmax(V[colv, 2])])
    lm[30] = tip
    for k, f in ((28, 1 / 3), (29, 2 / 3)):
        lm[k] = _nearest(V, colv, top + (V[tip] - top) * f)
    for k, g in zip((31, 32, 33), Pm["landmark_guides"]["nose_base"], strict=True):
        g = np.asarray(g, float)
        lm[k] = _nearest(V, outer, g * [-1, 1, 1])
        lm[66 - k] = _nearest(V, outer, g)  # 35, 34, 33
    # eyes: corners, upper lid (row je+1) and lower lid (row je) at thirds
    ai, ao = S.a_in, S.a_out
    t1, t2 = ao - (ao - ai) / 3, ao - 2 * (ao - ai) / 3  # outer third, inner third
    lm[36:42] = [idx[col["eRo"], je], at(-t1, je + 1), at(-t2, je + 1), idx[col["eRi"], je],
                 at(-t2, je), at(-t1, je)]
    lm[42:48] = [idx[col["eLi"], je], at(t2, je + 1), at(t1, je + 1), idx[col["eLo"], je],
                 at(t1, je), at(t2, je)]
    # lips: outer contour on the red-lip border rows, inner contour on the slit edges
    am = S.a_m
    ju, jl = info["j_lip1"], info["j_lip0"]
    lm[48] = idx[col["mR"], jm]
    lm[54] = idx[col["mL"], jm]
    lm[49:54] = [at(f * am, ju) for f in (-2 / 3, -1 / 3, 0, 1 / 3, 2 / 3)]
    lm[55:60] = [at(f * am, jl) for f in (2 / 3, 1 / 3, 0, -1 / 3, -2 / 3)]
    lm[60] = lm[48]
    lm[64] = lm[54]
    lm[61:64] = [at(f * am, jm + 1) for f in (-1 / 2, 0, 1 / 2)]
    lm[65:68] = [at(f * am, jm) for f in (1 / 2, 0, -1 / 2)]

    in_m, in_e = info["in_mouth"], info["in_eye"]
    right, left = A < 0, A > 0
    regions = {
        "lid_upper_margin_L": idx[in_e & left, je + 1],
        "lid_lower_margin_L": idx[in_e & left, je],
        "lid_upper_margin_R": idx[in_e & right, je + 1],
        "lid_lower_margin_R": idx[in_e & right, je],
        "eye_corners_L": np.array([idx[col["eLi"], je], idx[col["eLo"], je]]),
        "eye_corners_R": np.array([idx[col["eRi"], je], idx[col["eRo"], je]]),
        "lip_upper_inner": idx[in_m, jm + 1],
        "lip_lower_inner": idx[in_m, jm],
        "lip_upper_border": idx[np.abs(A) <= am + 1e-9, ju],
        "lip_lower_border": idx[np.abs(A) <= am + 1e-9, jl],
        "mouth_corners": np.array([idx[col["mR"], jm], idx[col["mL"], jm]]),
        "brow_mid_L": _nearest(V, outer, bc[2]),
        "brow_mid_R": _nearest(V, outer, bc[2] * [-1, 1, 1]),
        "pockets": np.arange(n_outer, len(V)),
        "face_patch_grid": idx,
    }
    return lm, regions


def _brow_centre(u: np.ndarray) -> np.ndarray:
    """Points on the skin under the left brow's centre line at parameters ``u`` in [0, 1]."""
    B = _params()["brows"]
    S = _shape()
    cl = np.asarray(B["centreline"], float)
    knots = np.linspace(0, 1, len(cl))
    x = PchipInterpolator(knots, cl[:, 0])(u)
    y = PchipInterpolator(knots, cl[:, 1])(u)
    org = np.stack([x, y, np.zeros_like(x)], 1)
    d = np.tile([0.0, 0.0, 1.0], (len(u), 1))
    return org + d * mg.ray_cast(S.field, org, d, 25.0)[:, None]
