"""Teeth as a person's: crowns of a real length, seated behind the lips where a mouth holds
them.

MakeHuman's dentition has its gums over half of each crown (5-6 mm of a central incisor
shows, where a person's clinical crown is 9-10 mm) and sits high behind the lips: at rest the
upper incisors' edges lie above the inner edge of the upper lip and the lower incisors stand
well above that of the lower lip. Parted lips (AU25, a smile) showed both rows edge to edge —
a clenched-teeth grimace — or, with the gums drawn as gums, a gummy smile. So the crowns
below the gum margin are lengthened toward the bite to their real length, and each row is
then moved vertically so that at rest its incisal edge sits where the ICT Face Model's scan of
an actor has it (``data/teeth.json``); the tongue goes with the lower row. The lips they are
seated against are MakeHuman's, before the rest pose presses them together (lips.py): that
seal is released as soon as the lips part, and the teeth then show as ICT's.
"""

from __future__ import annotations

import dataclasses
import functools
import json
from importlib import resources

import numpy as np

from mimika.face.makehuman.base import landmark_ids
from mimika.face.makehuman.build import SCALE, Built, Piece
from mimika.face.makehuman.paint.regions import uv_islands

_MM = 0.1 / SCALE  # base units per mm
#: the share of a tooth's crown at its biting end that keeps its shape when the crown grows
TIP_SHARE = 0.35


@functools.cache
def settings() -> dict:
    text = resources.files("mimika.face.makehuman").joinpath("data", "teeth.json")
    return {k: v for k, v in json.loads(text.read_text("utf-8")).items() if k[0] != "_"}


@functools.cache
def _lip_landmarks() -> tuple[int, int, int, int]:
    """Base-mesh vertex ids of landmarks 48, 54 (mouth corners), 62 and 66 (inner lip edges)."""
    ids = landmark_ids()
    return int(ids[48]), int(ids[54]), int(ids[62]), int(ids[66])


def gum_faces(piece: Piece) -> np.ndarray:
    """(F,) bool over the teeth piece's triangles: the gums and palate. Each tooth is a UV
    island of its own; an island with ``gum_area`` times the median island's area is gum."""
    tris = np.concatenate(list(piece.parts.values()))
    lab = uv_islands(tris, len(piece.uvs))[tris[:, 0]]
    v = piece.vertices.astype(np.float64)
    area = 0.5 * np.linalg.norm(np.cross(v[tris[:, 1]] - v[tris[:, 0]],
                                         v[tris[:, 2]] - v[tris[:, 0]]), axis=1)
    per = np.bincount(lab, weights=area)
    return (per > settings()["gum_area"] * np.median(per[per > 0]))[lab]


def rows(built: Built) -> np.ndarray:
    """Per teeth vertex: True for the lower row (the one the jaw carries)."""
    move = np.linalg.norm(built.deltas["teeth"][built.shape_names.index("jawOpen")], axis=1)
    return move > settings()["lower_share"] * move.max()


def _front(built: Built, v: np.ndarray, row: np.ndarray) -> np.ndarray:
    """Mask of a row's front vertices near the midline (the central incisors and their gum)."""
    st = settings()
    c48, c54, _, _ = _lip_landmarks()
    mid = np.abs(v[:, 0] - 0.5 * (built.base_vertices[c48, 0] + built.base_vertices[c54, 0]))
    near = row & (mid < st["midline_mm"] * _MM)
    return near & (v[:, 2] > v[near, 2].max() - st["front_mm"] * _MM) if near.any() else near


def _on_gum(teeth: Piece) -> np.ndarray:
    """Per teeth vertex: True on the gums and palate (false everywhere without UVs)."""
    out = np.zeros(len(teeth.vertices), bool)
    if teeth.uvs is not None:
        tris = np.concatenate(list(teeth.parts.values()))
        out[np.unique(tris[gum_faces(teeth)])] = True
    return out


def _edge(built: Built, v: np.ndarray, row: np.ndarray, upper: bool) -> float:
    """Height of a row's incisal edge: the bite-most point of its front teeth at the midline."""
    front = _front(built, v, row)
    if not front.any():
        return float("nan")
    return float(v[front, 1].min() if upper else v[front, 1].max())


def front_incisors(built: Built, teeth: Piece, row: np.ndarray) -> np.ndarray:
    """Mask over ``teeth``'s vertices of the central incisors (not their gum) of ``row``."""
    return _front(built, teeth.vertices, row & ~_on_gum(teeth))


def _lengthen_crowns(built: Built, v: np.ndarray, lower: np.ndarray, gum: np.ndarray,
                     tooth: np.ndarray) -> np.ndarray:
    """Teeth vertices ``v`` with every crown stretched from its row's gum margin toward the
    bite, so a central incisor shows its real crown length below the gum. Each tooth
    (``tooth``: its id per vertex) keeps the shape of its biting end — the last
    :data:`TIP_SHARE` of its crown moves down whole and only the part above it stretches —
    so the corners MakeHuman's low-poly incisors cut off stay as small as they are: stretched
    with the crown they opened into V-shaped gaps that read as saw teeth when only the edges
    show between parted lips."""
    st = settings()
    v = v.astype(np.float64).copy()
    for row, upper, key in ((~lower, True, "upper_crown_mm"), (lower, False, "lower_crown_mm")):
        edge = _edge(built, v, row & ~gum, upper)
        # the margin: the gum's edge nearest the bite over the central incisors
        margin = _edge(built, v, row & gum, upper)
        sign = -1.0 if upper else 1.0
        shown = sign * (edge - margin)
        if not shown > 0:  # no gum over the front teeth (or none found)
            continue
        k = max(st[key] * _MM / shown, 1.0)
        crown = row & ~gum & (sign * (v[:, 1] - margin) > 0)
        for t in np.unique(tooth[crown]):
            sel = crown & (tooth == t)
            d = sign * (v[sel, 1] - margin)  # below the margin, toward the bite
            end = d.max()
            tip = TIP_SHARE * end
            grown = np.where(d >= end - tip, d + (k - 1.0) * end,
                             d * (k * end - tip) / max(end - tip, 1e-9))
            v[sel, 1] = margin + sign * grown
    return v


def _teeth_ids(teeth: Piece) -> np.ndarray:
    """Per teeth vertex: the id of the piece of geometry it belongs to (each tooth is one),
    vertices split at UV seams counted as one."""
    tris = np.concatenate(list(teeth.parts.values()))
    weld = teeth.weld if teeth.weld is not None else np.arange(len(teeth.vertices))
    return uv_islands(weld[tris], int(weld.max()) + 1)[weld]


def seat_teeth(built: Built) -> Built:
    """``built`` with real-length crowns and its teeth rows (and tongue) moved to their seats
    behind the lips."""
    teeth = next((p for p in built.pieces if p.name == "teeth"), None)
    if teeth is None or "jawOpen" not in built.shape_names:
        return built
    st = settings()
    lower, gum = rows(built), _on_gum(teeth)
    v = _lengthen_crowns(built, teeth.vertices, lower, gum, _teeth_ids(teeth))
    _, _, l62, l66 = _lip_landmarks()
    d_up = built.base_vertices[l62, 1] - st["upper_below_lip_mm"] * _MM - _edge(
        built, v, ~lower & ~gum, True)
    d_low = built.base_vertices[l66, 1] - st["lower_below_lip_mm"] * _MM - _edge(
        built, v, lower & ~gum, False)
    if not (np.isfinite(d_up) and np.isfinite(d_low)):
        return built
    pieces = []
    for p in built.pieces:
        if p.name in ("teeth", "tongue"):
            moved = (v if p.name == "teeth" else p.vertices).copy()
            moved[:, 1] += np.where(lower, d_low, d_up) if p.name == "teeth" else d_low
            p = dataclasses.replace(p, vertices=moved.astype(p.vertices.dtype))
        pieces.append(p)
    return dataclasses.replace(built, pieces=pieces)
