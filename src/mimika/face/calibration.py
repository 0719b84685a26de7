"""How far an AU moves a head's face, measured against a physical reference.

The reference is the ICT Face Model: light-stage scans of a real actor's expressions. For an AU
at intensity 1 a head's skin moves by |Δv| per vertex; over the **face front** (the skin in
front of the ears between the chin and the hairline, facing the camera — not the neck, body or
the inside of the mouth) two figures summarise it, both in units of the head's inter-ocular
distance (IOD, eye centre to eye centre) so heads of any size compare:

* ``peak`` — the largest displacement;
* ``extent`` — the area-weighted 95th percentile: the displacement that 5 % of the face's area
  exceeds. A brow raise that lifts the whole forehead has a large extent; one that moves only
  the brows a small one, at the same peak.

How the motion is *shaped* — which way the lip corners, lids, brows and nose go — is compared on
the 68 landmarks: :func:`shape_error` is the length of the difference between a head's and the
reference's landmark displacements (IOD units, 3-D) over the length of the reference's.

How far the lids close is a third figure: the eye opening is small, so an AU can move the
face as far as ICT's and still leave the eyes as wide (a smile without its narrowed eyes).
:func:`lid_motion` is the change of the eye opening (upper to lower lid landmarks) in IOD.

A head is calibrated when, AU by AU, these lie within :data:`TOLERANCE` of the reference's
(``bench/au_calibration.py`` prints the table; docs/rigs.md#calibration lists it).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass

import numpy as np

from mimika.face.head import Head

__all__ = ["EXCEPTIONS", "EXTRA_AUS", "LID_AUS", "SEED_AUS", "TOLERANCE", "FaceFront",
           "au_displacement", "au_motion", "eye_opening", "face_front", "inter_ocular",
           "landmark_motion",
           "lid_motion", "lip_opening", "motion", "ratios", "shape_error"]

#: the 22 AUs of seed 002 that move the face (its head and eye turns are rotations)
SEED_AUS = ("AU01", "AU02", "AU04", "AU05", "AU06", "AU07", "AU09", "AU10", "AU12", "AU15",
            "AU16", "AU17", "AU18", "AU20", "AU22", "AU23", "AU24", "AU25", "AU26", "AU27",
            "AU28", "AU43")
#: mimika's further face AUs that ICT's shapes also cover
EXTRA_AUS = ("AU11", "AU14", "AU45", "AU46")
#: calibrated: reference × [low, high]
TOLERANCE = (0.7, 1.4)
#: AU → (figures not compared, why). Motions confined to the eyelids cover well under 5 % of
#: the face, so their 95th percentile measures how many mesh vertices a head puts on its
#: lids, not how far a lid moves; closing the eye moves the lid as far as that head's eye is
#: open — FACS defines the closure, not a distance
EXCEPTIONS: Mapping[str, tuple[tuple[str, ...], str]] = {
    "AU05": (("extent",), "upper lid raise: only the lid moves (ICT's 95th percentile is "
                          "0.3 % IOD)"),
    "AU43": (("peak", "extent"), "eyes closed: the lids meet, however wide the eye is open"),
    "AU45": (("peak", "extent"), "blink: the lids meet, however wide the eye is open"),
    "AU46": (("peak", "extent"), "wink: one eye's lids meet"),
}


#: the AUs whose change of the eye opening is compared: on ICT the lid raiser opens the eyes
#: by 4 % IOD, the cheek raiser, lid tightener and nose wrinkler narrow them by 2–4 % (the
#: closures 43/45/46 close them whatever their size; other AUs move the lids < 1 %)
LID_AUS = ("AU05", "AU06", "AU07", "AU09")
#: 68-point landmark pairs (upper lid, lower lid) across the eye openings
LID_PAIRS = ((37, 41), (38, 40), (43, 47), (44, 46))


@dataclass(frozen=True)
class FaceFront:
    """The face front of a head's landmark object: ``mask`` (N,) of its vertices, their
    ``area`` (N,) in cm² (a third of each adjacent triangle) and the head's ``iod`` in cm."""

    mask: np.ndarray
    area: np.ndarray
    iod: float


def _normals(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    fn = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    n = np.zeros_like(v)
    for k in range(3):
        np.add.at(n, f[:, k], fn)
    return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)


def face_front(head: Head) -> FaceFront:
    """The face front of ``head`` (see the module docstring): within one IOD of the midline,
    from just below the chin (landmark 8) to 1.25 IOD above the eyes, no deeper than 0.6 IOD
    behind the eye centres, normals turned toward the camera (+z) by more than 75°'s cosine."""
    obj = head[head.landmark_object]
    v = obj.vertices.astype(np.float64)
    f = obj.faces.astype(np.int64)
    iod = inter_ocular(head)
    mid = (np.asarray(head.anchors["eye_L"], np.float64)
           + np.asarray(head.anchors["eye_R"], np.float64)) / 2
    chin = head.landmark_points().astype(np.float64)[8]
    n = _normals(v, f)
    mask = ((np.abs(v[:, 0] - mid[0]) <= iod) & (v[:, 1] >= chin[1] - 0.05 * iod)
            & (v[:, 1] <= mid[1] + 1.25 * iod) & (v[:, 2] >= mid[2] - 0.6 * iod)
            & (n[:, 2] > 0.25))
    tri = 0.5 * np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]),
                               axis=1)
    area = np.zeros(len(v))
    np.add.at(area, f.ravel(), np.repeat(tri / 3.0, 3))
    return FaceFront(mask, area, iod)


def motion(displacement: np.ndarray, front: FaceFront) -> tuple[float, float]:
    """``(peak, extent)`` of per-vertex displacements (N, 3) cm over ``front``, in IOD."""
    d = np.linalg.norm(np.asarray(displacement, np.float64), axis=1)[front.mask] / front.iod
    w = front.area[front.mask]
    order = np.argsort(d)
    cum = np.cumsum(w[order])
    k = min(int(np.searchsorted(cum, 0.95 * cum[-1])), len(d) - 1)
    return float(d.max()), float(d[order][k])


def landmark_motion(displacement: np.ndarray, head: Head) -> np.ndarray:
    """The landmarks' displacements (68, 3) in IOD units, from per-vertex displacements (N, 3)
    of the head's landmark object."""
    return np.asarray(displacement, np.float64)[head.landmarks] / inter_ocular(head)


def inter_ocular(head: Head) -> float:
    """The head's inter-ocular distance (eye centre to eye centre, cm)."""
    return float(np.linalg.norm(np.asarray(head.anchors["eye_L"], np.float64)
                                - np.asarray(head.anchors["eye_R"], np.float64)))


def lip_opening(rig, aus: Mapping[str, float], step: float = 0.001) -> float:
    """How far apart the lips stand seen from straight ahead, in IOD: on the mouth's midline,
    the height of the run of rays (along −z, ``step`` IOD apart) that pass between the lips —
    meeting no skin of the landmark object within 0.05 IOD behind the deeper of their inner
    edges (68-point landmarks 62 and 66; a dropped jaw takes the lower lip back). Full lips
    that touch in front are closed, however far apart their inner edges."""
    head = rig.head
    o = head.landmark_object
    skin = np.asarray(rig.deform(aus)[o], np.float64)
    lm = skin[head.landmarks]
    iod = inter_ocular(head)
    x0 = lm[[48, 54], 0].mean()
    cy, cz = lm[[62, 66], 1].mean(), lm[[62, 66], 2].min()
    f = np.concatenate([p.faces for p in head[o].parts])
    tri = skin[f]
    c = tri.mean(1)
    tri = tri[(np.abs(c[:, 0] - x0) < 0.1 * iod) & (np.abs(c[:, 1] - cy) < 0.4 * iod)
              & (c[:, 2] > cz - 0.25 * iod)]
    # rays (x0, y, +∞) → −z meet a triangle where (x0, y) lies inside its x-y projection
    a, b, d = tri[:, 0], tri[:, 1], tri[:, 2]
    ys = cy + np.arange(-0.35, 0.35, step) * iod
    den = (b[:, 1] - d[:, 1]) * (a[:, 0] - d[:, 0]) + (d[:, 0] - b[:, 0]) * (a[:, 1] - d[:, 1])
    ok = np.abs(den) > 1e-12
    a, b, d, den = a[ok], b[ok], d[ok], den[ok]
    py = ys[:, None] - d[None, :, 1]
    w0 = ((b[:, 1] - d[:, 1]) * (x0 - d[:, 0]) + (d[:, 0] - b[:, 0]) * py) / den
    w1 = ((d[:, 1] - a[:, 1]) * (x0 - d[:, 0]) + (a[:, 0] - d[:, 0]) * py) / den
    w2 = 1 - w0 - w1
    z = w0 * a[:, 2] + w1 * b[:, 2] + w2 * d[:, 2]
    inside = (w0 >= 0) & (w1 >= 0) & (w2 >= 0)
    front = np.where(inside, z, -np.inf).max(1)  # the nearest skin along each ray
    is_open = front < cz - 0.05 * iod
    i = int(np.argmin(np.abs(ys - cy)))
    if not is_open[i]:
        near = np.flatnonzero(is_open & (np.abs(ys - cy) < 0.06 * iod))
        if not len(near):
            return 0.0
        i = int(near[np.argmin(np.abs(near - i))])
    lo, hi = i, i
    while lo > 0 and is_open[lo - 1]:
        lo -= 1
    while hi < len(ys) - 1 and is_open[hi + 1]:
        hi += 1
    return (hi - lo + 1) * step


def shape_error(moved: np.ndarray, reference: np.ndarray) -> float:
    """How differently two heads' landmarks move (:func:`landmark_motion` of each): the
    difference's length over the reference's (0: the same motion; 1: as far off as no
    motion at all)."""
    return float(np.linalg.norm(moved - reference) / max(np.linalg.norm(reference), 1e-12))


def eye_opening(landmarks: np.ndarray) -> float:
    """Mean height of the eye openings: upper minus lower lid landmark, along the head's up
    axis (y), of landmark positions (68, 3) — or of their displacements, for its change."""
    lm = np.asarray(landmarks, np.float64)
    return float(np.mean([lm[u, 1] - lm[lo, 1] for u, lo in LID_PAIRS]))


def lid_motion(rig, codes: Iterable[str] = LID_AUS) -> dict[str, float]:
    """How far each AU of ``codes`` the rig models, at intensity 1, opens (+) or narrows (−)
    the eyes, in IOD (:func:`eye_opening` of the landmark displacements)."""
    head = rig.head
    o = head.landmark_object
    rest = head.rest[o].astype(np.float64)
    return {code: eye_opening(landmark_motion(
                np.asarray(rig.deform({code: 1.0})[o], np.float64) - rest, head))
            for code in codes if code in rig.supported}


def au_displacement(rig, code: str) -> np.ndarray:
    """How AU ``code`` at intensity 1 moves each vertex of the head's landmark object (N, 3).

    A rig whose rest pose holds the lips together (its ``release``) measures the AUs that
    part them from the released lips: the seal is its rest pose's, not the AU's motion (ICT's
    scan rests with the lips 0.7 mm apart)."""
    o = rig.head.landmark_object
    d = np.asarray(rig.deform({code: 1.0})[o], np.float64) - rig.head.rest[o]
    if getattr(rig, "release", None):
        d -= float(rig.release_weights(np.ones((1, 1)), [code])[0]) * rig.release_deltas()[o]
    return d


def au_motion(rig, codes: Iterable[str] = SEED_AUS) -> dict[str, tuple[float, float]]:
    """``(peak, extent)`` of each AU of ``codes`` the rig models, at intensity 1 (both sides),
    from :func:`au_displacement`."""
    front = face_front(rig.head)
    return {code: motion(au_displacement(rig, code), front) for code in codes
            if code in rig.supported}


def ratios(measured: Mapping[str, tuple[float, float]],
           reference: Mapping[str, tuple[float, float]]
           ) -> dict[str, tuple[float | None, float | None]]:
    """AU → (peak ratio, extent ratio), each None where :data:`EXCEPTIONS` leaves it out, for
    the AUs both measured."""
    out = {}
    for code, (p, e) in measured.items():
        if code not in reference:
            continue
        skip = EXCEPTIONS.get(code, ((), ""))[0]
        out[code] = tuple(None if what in skip else (x / r if r > 0 else float("inf"))
                          for what, x, r in zip(("peak", "extent"), (p, e), reference[code],
                                                strict=True))
    return out
