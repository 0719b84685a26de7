"""Teeth seated behind the lips where a person's are.

MakeHuman's dentition, fitted by its proxy, sits high behind the lips: at rest the upper
incisors' edges lie above the inner edge of the upper lip and the lower incisors stand well
above that of the lower lip, so parted lips (AU25, a smile) show both rows edge to edge — a
clenched-teeth grimace where a person shows the upper teeth. Each row is moved vertically (not
reshaped) so that at rest its incisal edge sits where the ICT Face Model's scan of an actor has
it (``data/teeth.json``); the tongue goes with the lower row.
"""

from __future__ import annotations

import dataclasses
import functools
import json
from importlib import resources

import numpy as np

from mimika.face.makehuman.build import SCALE, Built

_MM = 0.1 / SCALE  # base units per mm


@functools.cache
def settings() -> dict:
    text = resources.files("mimika.face.makehuman").joinpath("data", "teeth.json")
    return {k: v for k, v in json.loads(text.read_text("utf-8")).items() if k[0] != "_"}


@functools.cache
def _lip_landmarks() -> tuple[int, int, int, int]:
    """Base-mesh vertex ids of landmarks 48, 54 (mouth corners), 62 and 66 (inner lip edges)."""
    text = resources.files("mimika.face.makehuman").joinpath("data", "hm08_landmarks.json")
    ids = json.loads(text.read_text("utf-8"))
    return ids[48], ids[54], ids[62], ids[66]


def rows(built: Built) -> np.ndarray:
    """Per teeth vertex: True for the lower row (the one the jaw carries)."""
    move = np.linalg.norm(built.deltas["teeth"][built.shape_names.index("jawOpen")], axis=1)
    return move > settings()["lower_share"] * move.max()


def incisal_edges(built: Built) -> tuple[float, float]:
    """Heights (base units) of the upper row's lowest and the lower row's highest front tooth
    point near the midline."""
    st = settings()
    teeth = next(p for p in built.pieces if p.name == "teeth")
    v, lower = teeth.vertices, rows(built)
    c48, c54, _, _ = _lip_landmarks()
    mid = np.abs(v[:, 0] - 0.5 * (built.base_vertices[c48, 0] + built.base_vertices[c54, 0]))
    edges = []
    for row, pick in ((~lower, np.min), (lower, np.max)):
        near = row & (mid < st["midline_mm"] * _MM)
        front = near & (v[:, 2] > v[near, 2].max() - st["front_mm"] * _MM)
        edges.append(float(pick(v[front, 1])))
    return edges[0], edges[1]


def seat_teeth(built: Built) -> Built:
    """``built`` with its teeth rows (and tongue) moved to their seats behind the lips."""
    if not any(p.name == "teeth" for p in built.pieces) or "jawOpen" not in built.shape_names:
        return built
    st = settings()
    _, _, l62, l66 = _lip_landmarks()
    up_edge, low_edge = incisal_edges(built)
    d_up = built.base_vertices[l62, 1] - st["upper_below_lip_mm"] * _MM - up_edge
    d_low = built.base_vertices[l66, 1] - st["lower_below_lip_mm"] * _MM - low_edge
    lower = rows(built)
    pieces = []
    for p in built.pieces:
        if p.name in ("teeth", "tongue"):
            v = p.vertices.copy()
            dy = np.where(lower, d_low, d_up) if p.name == "teeth" else d_low
            v[:, 1] += dy
            p = dataclasses.replace(p, vertices=v.astype(p.vertices.dtype))
        pieces.append(p)
    return dataclasses.replace(built, pieces=pieces)
