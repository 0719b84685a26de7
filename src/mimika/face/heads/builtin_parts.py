"""The built-in head's eyeballs, teeth, tongue and brows (numbers in ``data/builtin_head.json``)."""

from __future__ import annotations

import numpy as np
from scipy.interpolate import PchipInterpolator

from mimika.face import meshgen as mg
from mimika.face.eyeball import eyeball_object
from mimika.face.head import MeshObject, Part
from mimika.face.heads.builtin_skin import params, shape


def eyeball(side: int, res: int) -> MeshObject:
    ey = params()["eyes"]
    sc = params()["grid"]["resolution_scale"][res]
    rings = tuple(max(1, round(k * sc)) for k in ey["rings"])
    return eyeball_object("eye_L" if side > 0 else "eye_R",
                          np.array(ey["centre"], float) * [side, 1, 1], ey["radius"],
                          pupil_radius=ey["pupil_radius"], iris_radius=ey["iris_radius"],
                          iris_depth=ey["iris_depth"], rings=rings,
                          n_lon=max(12, round(ey["n_lon"] * sc)), cornea=ey["cornea"])


def teeth(which: str, res: int) -> MeshObject:
    T = params()["teeth"]
    P = T[which]
    sc = params()["grid"]["resolution_scale"][res]
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


def tongue(res: int) -> MeshObject:
    T = params()["tongue"]
    sc = params()["grid"]["resolution_scale"][res]
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


def brows(res: int) -> MeshObject:
    B = params()["brows"]
    S = shape()
    sc = params()["grid"]["resolution_scale"][res]
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


