"""Lips that meet at rest.

MakeHuman's macro targets leave some characters' lips apart in the rest pose: the inner lip
edges of the default character stand 2.4-3.0 mm apart (fuller lips, an older or heavier
face), so the seated teeth show as a white line between them and a neutral face reads as
"surprised" to emotion recognisers trained on photographs (face-api: 0.95 surprised for the
neutral front view). A relaxed face has its lips together, and FACS codes any parting as
AU25. So the rest pose takes as much of the character's own ``mouthClose`` faceunit (lips
toward each other, jaw still) as brings its inner lip edges together on average, measured at
the 68-point landmarks 61-63 and 65-67.

Full lips then overlap in depth: pressed together, they would have to part by the seal before
any opening shows (AU25 at 0.36 left the default character's lips closed seen from the front,
where the ICT scan of an actor opens 3.8 mm; the speech visemes of /s t n/ opened 0.4-1.9 mm
against its 4.4-5.8). So the AUs that part the lips release the seal at once (``lip_release``
in ``makehuman_aus.json``: the rig adds ``-seal`` of ``mouthClose`` with weight
smoothstep(largest of those AUs / full_at)), and the opening then follows the AUs as ICT's.

A dropping jaw carries the lower lip as it carries the lower incisors
(:func:`lower_lip_follows_jaw`): MakeHuman's ``jawOpen`` let it fall past them.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from mimika.face.makehuman.base import landmark_ids, polyline
from mimika.face.makehuman.build import Built

#: the most of ``mouthClose`` a rest pose takes (it presses the lips together beyond that)
MAX_WEIGHT = 0.2
#: how far (base units) beyond the lower lip's outline the jaw's motion fades into its own
JAW_REACH = 0.08


def _inner_lips() -> tuple[np.ndarray, np.ndarray]:
    """Base-mesh vertex ids of the inner lip edges: upper 61-63 and the lower ones under them
    (67-65), as pairs."""
    ids = landmark_ids()
    return ids[[61, 62, 63]], ids[[67, 66, 65]]


def seal_weight(built: Built) -> float:
    """How much of ``mouthClose`` closes the character's lips at rest (0: they meet)."""
    if "mouthClose" not in built.shape_names:
        return 0.0
    upper, lower = _inner_lips()
    skin = built.pieces[0]
    d = np.zeros_like(built.base_vertices)
    d[skin.weld] = built.deltas[skin.name][built.shape_names.index("mouthClose")]
    v = built.base_vertices
    gap = float(np.mean(v[upper, 1] - v[lower, 1]))
    rate = float(np.mean(d[lower, 1] - d[upper, 1]))  # closing per unit of mouthClose
    if gap <= 0.0 or rate <= 0.0:
        return 0.0
    return min(gap / rate, MAX_WEIGHT)


def seal_lips(built: Built) -> Built:
    """``built`` with its rest pose's lips together (every piece and the base mesh moved by
    :func:`seal_weight` of ``mouthClose``; the shape deltas stay as they are)."""
    w = seal_weight(built)
    if w == 0.0:
        return built
    k = built.shape_names.index("mouthClose")
    skin = built.pieces[0]
    pieces = [dataclasses.replace(p, vertices=(p.vertices + w * built.deltas[p.name][k])
                                  .astype(p.vertices.dtype)) for p in built.pieces]
    base = built.base_vertices.copy()
    base[skin.weld] += w * built.deltas[skin.name][k]
    return dataclasses.replace(built, pieces=pieces, base_vertices=base.astype(
        built.base_vertices.dtype), lip_seal=w)


def lower_lip_follows_jaw(built: Built) -> Built:
    """``built`` with the lower lip carried by ``jawOpen`` as the jaw carries the lower
    incisors.

    MakeHuman's ``jawOpen`` drops the lower lip a quarter further than the lower incisors and
    the chin (33, 26, 27 mm), so an open mouth bared the lower row — 4 mm at AU26, 7 mm at
    AU27 — where the ICT scan of an actor keeps the lip at the teeth's edge (0.1, 0.5 mm). On
    the lower lip (between its outer and inner outline, fading out over :data:`JAW_REACH`
    beyond them and toward the corners) the skin's ``jawOpen`` becomes the front incisors'."""
    from mimika.face.makehuman.teeth import front_incisors, rows

    teeth = next((p for p in built.pieces if p.name == "teeth"), None)
    if teeth is None or "jawOpen" not in built.shape_names:
        return built
    k = built.shape_names.index("jawOpen")
    lower = rows(built)
    front = front_incisors(built, teeth, lower)
    if not front.any():
        return built
    incisors = built.deltas["teeth"][k][front].astype(np.float64).mean(0)
    skin = built.pieces[0]
    d = built.deltas[skin.name].copy()
    # only what the jaw already carries (the upper lip touches the lower one at rest)
    carried = d[k][:, 1] / min(float(incisors[1]), -1e-9)
    w = _lower_lip_weight(built.base_vertices.astype(np.float64),
                          skin.vertices.astype(np.float64)) \
        * np.clip((carried - 0.3) / 0.3, 0.0, 1.0)
    d[k] += (w[:, None] * (incisors - d[k])).astype(d.dtype)
    return dataclasses.replace(built, deltas={**built.deltas, skin.name: d})


def _lower_lip_weight(base: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Per skin vertex ``v``: 1 on the lower lip (between its outer outline 48, 59-55, 54 and
    its inner one 60, 67-65, 64), fading to 0 :data:`JAW_REACH` beyond and at the corners."""
    from scipy.spatial import cKDTree

    ids = landmark_ids()
    outer = polyline(base[ids[[48, 59, 58, 57, 56, 55, 54]]], 10)
    inner = polyline(base[ids[[48, 60, 67, 66, 65, 64, 54]]], 10)
    area = np.concatenate([inner + (outer - inner) * a for a in np.linspace(0.0, 1.0, 7)])
    dist = cKDTree(area).query(v)[0]
    mid = 0.5 * (base[ids[48], 0] + base[ids[54], 0])
    half = 0.5 * abs(base[ids[54], 0] - base[ids[48], 0])
    corner = np.clip((np.abs(v[:, 0] - mid) / half - 0.6) / 0.4, 0.0, 1.0)
    return np.exp(-(dist / (0.5 * JAW_REACH)) ** 2) * (1.0 - corner * corner * (3 - 2 * corner))
