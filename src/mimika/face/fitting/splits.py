"""Geometry the fits share: similarity transforms of landmark sets and the split surfaces
(mouth-corner plane, eye fissures) of sub-object AUs."""

from __future__ import annotations

import logging
from collections.abc import Sequence

import numpy as np

from mimika.face.rigs.field import (
    Split,
)

log = logging.getLogger(__name__)


# --- geometry helpers ---------------------------------------------------------------------------


def similarity_transform(src: np.ndarray, dst: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """Umeyama: scale s, rotation R (3, 3), translation t with dst ≈ s·R·src + t (least squares
    over corresponding points (N, 3))."""
    src = np.asarray(src, float)
    dst = np.asarray(dst, float)
    ms, md = src.mean(0), dst.mean(0)
    a, b = src - ms, dst - md
    u, sv, vt = np.linalg.svd(b.T @ a / len(src))
    sgn = np.eye(3)
    if np.linalg.det(u) * np.linalg.det(vt) < 0:
        sgn[2, 2] = -1
    r = u @ sgn @ vt
    s = float(np.trace(np.diag(sv) @ sgn) / (a**2).sum(1).mean())
    return s, r, md - s * r @ ms


def _lip_line(lm: np.ndarray) -> tuple[float, np.ndarray]:
    """Mouth midline x and the inner-lip line (4, 3): centre, two mid points, corner, as
    (|x − mid|, y, z), mirrored and averaged from landmarks 60–67."""
    mid_x = 0.5 * (lm[64, 0] + lm[60, 0])
    pts = []
    for ids in ((62, 66), (61, 67, 63, 65), (60, 64)):
        q = lm[list(ids)]
        pts.append((0.0 if ids[0] == 62 else float(np.mean(np.abs(q[:, 0] - mid_x))),
                    float(q[:, 1].mean()), float(q[:, 2].mean())))
    return float(mid_x), np.asarray(pts)


def mouth_split(landmarks: np.ndarray, normal: Sequence[float] = (0.0, 1.0, 0.0),
                offsets: np.ndarray | None = None) -> dict:
    """The mouth split surface (fields-file JSON) from the 68 landmarks (cm, head frame).

    A surface through the middle of the inner lip contour (landmarks 60–67: corners 60/64,
    upper 61–63, lower 65–67): s = (v − p)·n − profile(|x|), with the profile through the lip
    line and constant beyond the corners, and a soft band outside the corners (as the built-in
    file does) so the skin stays continuous there. ``normal`` tilts the surface (the seed's
    plane through the corners may tilt); ``offsets`` (M, 2): extra offsets along the normal
    (cm) at |x| given as fractions of the mouth half-width (from :func:`refine_mouth_split`).
    """
    lm = np.asarray(landmarks, float)
    mid_x, line = _lip_line(lm)
    n = np.asarray(normal, float) / np.linalg.norm(normal)
    z0 = float(line[0, 2])
    p = np.array([mid_x, 0.0, z0])
    cx = float(line[-1, 0])
    base = np.c_[line[:, 0], (np.c_[np.zeros(len(line)), line[:, 1:]] - [0, 0, z0]) @ n]
    if offsets is not None and len(offsets):
        xs = np.asarray(offsets, float)[:, 0] * cx
        prof = np.c_[xs, np.interp(xs, base[:, 0], base[:, 1]) + np.asarray(offsets)[:, 1]]
    else:
        prof = base
    prof = np.r_[prof[prof[:, 0] < cx], [[cx, np.interp(cx, prof[:, 0], prof[:, 1])]],
                 [[30.0, np.interp(cx, prof[:, 0], prof[:, 1])]]]
    return {"point": np.round(p, 6).tolist(), "normal": np.round(n, 8).tolist(),
            "profile": np.round(prof, 6).tolist(), "soft": [0.0, round(cx, 6), 1.0]}


def refine_mouth_split(landmarks: np.ndarray, rest: np.ndarray, jaw: np.ndarray,
                       bins: int = 24) -> tuple[np.ndarray, np.ndarray, float]:
    """Tilt and offsets of the mouth split that best separate the lips as a jaw opening
    moves them: ``rest`` (N, 3) face vertices, ``jaw`` (N, 3) their displacement at a full jaw
    drop. Lip vertices near the landmark lip line are labelled lower (they drop ≥ half the
    largest drop there) or upper (≤ a quarter); over tilts of ±60°, the offsets are the
    midpoints of the gap between the classes per |x| bin, and the tilt with the widest
    smallest gap wins. Returns (normal (3,), offsets (M, 2), margin in cm)."""
    lm = np.asarray(landmarks, float)
    mid_x, line = _lip_line(lm)
    cx = float(line[-1, 0])
    ax = np.abs(rest[:, 0] - mid_x)
    y_l = np.interp(ax, line[:, 0], line[:, 1])
    z_l = np.interp(ax, line[:, 0], line[:, 2])
    near = (ax < cx) & (np.abs(rest[:, 1] - y_l) < 0.5) & (rest[:, 2] > z_l - 1.0)
    drop = float(jaw[near, 1].min()) if near.any() else 0.0
    if drop > -0.1:
        return np.array([0.0, 1.0, 0.0]), np.zeros((0, 2)), 0.0
    lower, upper = near & (jaw[:, 1] <= 0.5 * drop), near & (jaw[:, 1] >= 0.25 * drop)
    edges = np.linspace(0.0, 1.0, bins + 1)
    b = np.clip(np.searchsorted(edges, ax / cx, side="right") - 1, 0, bins - 1)
    best = (np.inf, -np.inf, np.array([0.0, 1.0, 0.0]), np.zeros((0, 2)))
    for deg in range(-60, 61, 3):
        t = np.radians(deg)
        n = np.array([0.0, np.cos(t), -np.sin(t)])
        split = Split.from_json(mouth_split(lm, n))
        sv = (rest - split.point) @ split.normal - np.interp(ax, *split.profile.T)
        offs, gaps = [], []
        for k in range(bins):
            lo_k, up_k = lower & (b == k), upper & (b == k)
            if lo_k.any() and up_k.any():
                a_k, b_k = sv[lo_k].max(), sv[up_k].min()
                gap = b_k - a_k
                gaps.append(gap)
                # stay as close to the landmark line as the gap allows (smooth profile)
                off = np.clip(0.0, a_k + 0.2 * gap, b_k - 0.2 * gap) if gap > 0 \
                    else 0.5 * (a_k + b_k)
                offs.append((0.5 * (edges[k] + edges[k + 1]), float(off)))
        if not gaps:
            continue
        final = Split.from_json(mouth_split(lm, n, np.asarray(offs)))
        w = final.upper_weight(rest)
        wrong = int((lower & (w > 0.5)).sum() + (upper & (w < 0.5)).sum())
        if (wrong, -min(gaps)) < (best[0], -best[1]):
            best = (wrong, float(min(gaps)), n, np.asarray(offs))
    wrong, margin, n, offs = best
    log.info("mouth split: tilt %.0f°, %d of %d lip vertices on the wrong side, smallest gap "
             "%.2f mm", np.degrees(np.arctan2(-n[2], n[1])), wrong, int((lower | upper).sum()),
             10 * margin)
    return n, offs, margin


def eye_split(landmarks: np.ndarray) -> dict:
    """The eye-fissure split surface (fields-file JSON) from the 68 landmarks: y =
    profile(|x|) through the middle of both eye openings (36–41 and 42–47, mirrored and
    averaged), constant beyond the corners, soft outside the openings."""
    lm = np.asarray(landmarks, float)
    mid_x = float(0.5 * (lm[39, 0] + lm[42, 0]))
    pts = []
    for ids in ((39, 42), (38, 40, 43, 47), (37, 41, 44, 46), (36, 45)):
        pts.append((float(np.mean(np.abs(lm[list(ids), 0] - mid_x))),
                    float(np.mean(lm[list(ids), 1]))))
    x_in, x_out = pts[0][0], pts[-1][0]
    prof = [(0.0, pts[0][1]), *pts, (30.0, pts[-1][1])]
    return {"point": [round(mid_x, 6), 0.0, 0.0], "normal": [0.0, 1.0, 0.0],
            "profile": np.round(np.asarray(prof), 6).tolist(),
            "soft": [round(x_in, 6), round(x_out, 6), 1.0]}
