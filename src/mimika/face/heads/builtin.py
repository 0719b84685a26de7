"""mimika's built-in head, made entirely by code: a stylised, closed, animatable human head.

Assembles the implicit skin (:mod:`.builtin_skin`: one smooth implicit function sampled along
rays, with eye and mouth openings leading into closed pockets) and the eyeballs, teeth, tongue
and brows (:mod:`.builtin_parts`), and places the 68 Multi-PIE landmarks and the anchors.
Resolutions 0/1/2 sample the *same* surfaces at different densities; all shape numbers live in
``data/builtin_head.json``.

Coordinates: cm, y up, +z forward (the face looks toward +z), +x toward the subject's left.
"""

from __future__ import annotations

import functools

import numpy as np

from mimika.errors import ParameterError
from mimika.face import meshgen as mg
from mimika.face.head import Head, MeshObject, Part
from mimika.face.heads.builtin_parts import brows, eyeball, teeth, tongue
from mimika.face.heads.builtin_skin import (
    RESOLUTIONS,
    Shape,
    brow_centre,
    build_skin,
    eye_socket,
    mouth_pocket,
    opening_loop,
    params,
    shape,
)


def _nearest(V: np.ndarray, cand: np.ndarray, p) -> int:
    d = np.linalg.norm(V[cand] - np.asarray(p, float), axis=1)
    return int(cand[np.argmin(d)])


def _skin_uvs(S: Shape, V: np.ndarray, ae: np.ndarray) -> np.ndarray:
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
    Pm = params()
    S = shape()
    V, F, info = build_skin(resolution)
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
        loop = opening_loop(info, col[c0], col[c1], je)
        centre = np.asarray(ey["centre"], float) * [side, 1, 1]
        allv = np.concatenate(verts)
        P, Fs = eye_socket(allv, loop, centre, resolution, ey)
        Fs = [f + 0 for f in Fs]
        verts.append(P)
        fs = np.concatenate(Fs)
        fs = mg.orient_like(fs, F)
        parts["socket"].append(fs)
        nv += len(P)
    # mouth pocket
    loop = opening_loop(info, col["mR"], col["mL"], jm)
    allv = np.concatenate(verts)
    P, Fd = mouth_pocket(allv, loop, resolution)
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

    objects = [skin, brows(resolution), eyeball(1, resolution), eyeball(-1, resolution),
               teeth("upper", resolution), teeth("lower", resolution), tongue(resolution)]

    # ---- landmarks, anchors, regions -------------------------------------------------------
    lm, regions = _landmarks(Vs, info, col, len(V))
    lmp = Vs[lm]
    ey = np.asarray(Pm["eyes"]["centre"], float)
    anc = Pm["anchors"]
    brow_mid = brow_centre(np.array([0.5]))[0]
    anchors = {
        "mouth_corner_L": Vs[idx[col["mL"], jm]],
        "mouth_corner_R": Vs[idx[col["mR"], jm]],
        "eye_L": ey * [1, 1, 1],
        "eye_R": ey * [-1, 1, 1],
        "chin": lmp[8],
        "nose_tip": lmp[30],
        "brow_L": brow_mid,  # the skin under the brow's middle, at every resolution
        "brow_R": brow_mid * [-1, 1, 1],
        "neck_base": np.asarray(anc["neck_base"], float),
        "neck_pivot": np.asarray(anc["neck_pivot"], float),
        "jaw_pivot": np.asarray(anc["jaw_pivot"], float),
    }
    return Head("builtin", tuple(objects), lm, anchors, landmark_object="skin",
                description="mimika's built-in procedural head (stylised, made by code)",
                meta={"resolution": resolution, "regions": regions})


def _landmarks(V: np.ndarray, info: dict, col: dict, n_outer: int):
    """The 68 Multi-PIE landmarks as skin vertex indices, and named vertex sets."""
    S = shape()
    Pm = params()
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
    bc = brow_centre(np.linspace(0, 1, 5))
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
        "pockets": np.arange(n_outer, len(V)),
        "face_patch_grid": idx,
    }
    return lm, regions
