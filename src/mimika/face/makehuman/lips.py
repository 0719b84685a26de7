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
"""

from __future__ import annotations

import dataclasses

import numpy as np

from mimika.face.makehuman.base import landmark_ids
from mimika.face.makehuman.build import Built

#: the most of ``mouthClose`` a rest pose takes (it presses the lips together beyond that)
MAX_WEIGHT = 0.2


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
