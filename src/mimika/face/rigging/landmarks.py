"""The 68 Multi-PIE landmarks on a face mesh, from its eye and mouth openings.

A template's landmarks (those the fields were fitted with, ``source.landmarks`` of the fields
file) are mapped onto the face by an axis-wise scaling that matches its eye distance (x), the
drop from the eyes to the mouth (y) and their mean (z), with the eye midpoint on the face's.
Then the eye contours (36–47) and inner lips (60–67) are fitted to the openings found — each
template contour scaled to its opening's extent and snapped to the nearest rim point — and every
landmark moves to the nearest mesh vertex. A template that knows where the opening finder
lands on it, and its own face surface, is placed opening to opening and then by ICP instead
(``mimika rig --style makehuman``).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from mimika.face.meshgen import vertex_normals
from mimika.face.rigging.features import FaceFeatures
from mimika.face.rigging.template import icp_nonrigid, icp_similarity

__all__ = ["landmarks68"]

_EYE_R, _EYE_L, _INNER_LIPS = slice(36, 42), slice(42, 48), slice(60, 68)


def _fit_contour(tpl: np.ndarray, rim: np.ndarray, *, snap: bool = True) -> np.ndarray:
    """Template contour points moved to the rim's centre and scaled to its width (and, with
    ``snap``, its height, then snapped to the rim: open eyes; a mouth's opening is the lips'
    contact line, not the rim where lips meet the mouth socket, so it keeps its height)."""
    if len(rim) < 3:
        return tpl
    c_t = 0.5 * (tpl.min(0) + tpl.max(0))
    c_r = 0.5 * (rim.min(0) + rim.max(0))
    ext_t = np.maximum(tpl.max(0) - tpl.min(0), 1e-6)
    ext_r = rim.max(0) - rim.min(0)
    k = np.ones(3)
    k[:2 if snap else 1] = (ext_r / ext_t)[:2 if snap else 1]
    p = c_r + (tpl - c_t) * k
    if not snap:
        p[:, 2] = tpl[:, 2]
        return p
    _, i = cKDTree(rim[:, :2]).query(p[:, :2])
    return rim[i]


def landmarks68(vertices: np.ndarray, feat: FaceFeatures, template: np.ndarray,
                template_openings: dict | None = None, surface: np.ndarray | None = None,
                faces: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Vertex indices (68,) and points (68, 3) of the landmarks on ``vertices`` (head frame).
    ``template_openings``: where the opening finder lands on the template face itself
    (``eye_L``, ``eye_R``, ``mouth``); then the template is mapped opening to opening, which
    cancels the finder's bias on faces like the template (closed lids and lips), and the
    contours are not snapped to the openings' rims. ``surface``: points of the template's
    face, mapped the same way and then moved onto ``vertices`` by a similarity ICP — and,
    with the mesh's ``faces``, bent onto it by a non-rigid one — carrying the landmarks
    along (:mod:`~mimika.face.rigging.template`)."""
    t = np.asarray(template, float)
    if template_openings is not None:
        te_l, te_r, tm = (np.asarray(template_openings[k], float)
                          for k in ("eye_L", "eye_R", "mouth"))
    else:
        te_l, te_r = t[_EYE_L].mean(0), t[_EYE_R].mean(0)
        tm = t[_INNER_LIPS].mean(0)
    tmid = 0.5 * (te_l + te_r)
    mid = 0.5 * (feat.eye_L + feat.eye_R)
    sx = feat.eye_distance / np.linalg.norm(te_l - te_r)
    sy = (mid[1] - feat.mouth[1]) / (tmid[1] - tm[1])
    k = np.array([sx, sy, np.sqrt(abs(sx * sy))])
    p = mid + (t - tmid) * k
    if template_openings is not None:
        v = np.asarray(vertices, float)
        if surface is not None:
            surf = mid + (np.asarray(surface, float) - tmid) * k
            sc, r, tr = icp_similarity(surf, v)
            p, surf = sc * p @ r.T + tr, sc * surf @ r.T + tr
            if faces is not None:  # then bent onto the face: other proportions
                p = icp_nonrigid(surf, p, v, vertex_normals(v, faces))
        _, idx = cKDTree(v).query(p)
        return idx.astype(np.int64), v[idx]
    # the template's eye centre and mouth land on the openings' own centres
    p[_EYE_L] += feat.eye_L - p[_EYE_L].mean(0)
    p[_EYE_R] += feat.eye_R - p[_EYE_R].mean(0)
    p[_EYE_L] = _fit_contour(p[_EYE_L], feat.rim_L)
    p[_EYE_R] = _fit_contour(p[_EYE_R], feat.rim_R)
    p[_INNER_LIPS] = _fit_contour(p[_INNER_LIPS], feat.rim_mouth, snap=False)
    _, idx = cKDTree(vertices).query(p)
    return idx.astype(np.int64), np.asarray(vertices)[idx]
