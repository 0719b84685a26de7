"""Correction shapes that make an AU move a head's landmarks as a real face's do.

A character's AU is a recipe of shapes on its own mesh, calibrated so that it moves the face
as far as the ICT Face Model's light-stage scans of an actor (docs/rigs.md#calibration) — as
far, but not always the same way: its smile pulled the mouth corners more sideways than the
actor's and lifted the middle of the lower lip with them, so the mouth curved less and a
smile at 0.6 did not read. For an AU whose table entry asks for it (``"match_landmarks":
true``), the difference between the reference's motion of the landmarks (:data:`LANDMARKS`;
inter-ocular distances, ``data/ict_landmark_motion.json``, written by ``scripts/calibrate.py
landmarks``) and the head's is spread over the skin by Gaussian radial basis functions under
half an inter-ocular distance wide, so it fades out within a few centimetres, and added to
the AU as one more shape (``fit.<AU>``, split between the sides as the table's midline
shapes are).
"""

from __future__ import annotations

import copy
import functools
import json
from collections.abc import Mapping, Sequence
from importlib import resources

import numpy as np
from scipy.spatial import cKDTree

from mimika.face.head import MeshObject
from mimika.face.rigs.blendshape import BlendshapeRig, ShapeSet

#: the landmarks matched: all but the upper lip's inner edge (61–63): where a mesh's closed
#: lips touch, both lips' inner edges lie at one point, which a smooth field moves as one;
#: the lower lip's is matched (it keeps the lower teeth hidden in a smile) and the upper
#: lip's follows the outer edge. The jaw's outline holds the cheeks: without it the field
#: left a dent below the cheekbone that the key light showed as a bruise
LANDMARKS = np.r_[0:61, 64:68]
#: width of the radial basis functions, in inter-ocular distances (0.3 left a dent too)
SIGMA = 0.45
#: the correction's reach beyond the landmarks: whole up to the first distance from the
#: nearest one, none past the second (IOD)
REACH = (0.25, 0.5)
#: ridge on the basis matrix (neighbouring landmarks a few millimetres apart)
RIDGE = 1e-3
#: the prefix of the correction shapes' names
PREFIX = "fit."


@functools.cache
def reference_motion() -> dict[str, np.ndarray]:
    """Per AU at intensity 1, the ICT Face Model's 68 landmark displacements (68, 3) in
    inter-ocular distances (x toward the subject's left, y up, z forward)."""
    text = resources.files("mimika.face").joinpath("data", "ict_landmark_motion.json")
    doc = json.loads(text.read_text("utf-8"))
    return {code: np.asarray(m, np.float64) for code, m in doc["aus"].items()}


def correction(points: np.ndarray, anchors: np.ndarray, residual: np.ndarray,
               sigma: float) -> np.ndarray:
    """Offsets (N, 3) at ``points`` (N, 3) that are ``residual`` (L, 3) at ``anchors`` (L, 3)
    (up to the ridge) and fade out over ``sigma`` (the same unit as the points)."""
    a = np.asarray(anchors, np.float64)
    k = np.exp(-((a[:, None] - a[None]) ** 2).sum(-1) / (2 * sigma * sigma))
    w = np.linalg.solve(k + RIDGE * np.eye(len(a)), np.asarray(residual, np.float64))
    p = np.asarray(points, np.float64)
    out = np.empty_like(p)
    for s in range(0, len(p), 4096):  # (chunk × L) kernel at a time
        d = ((p[s:s + 4096, None] - a[None]) ** 2).sum(-1)
        out[s:s + 4096] = np.exp(-d / (2 * sigma * sigma)) @ w
    return out


def match_landmarks(rig: BlendshapeRig, skin: MeshObject, landmarks: np.ndarray, iod: float,
                    shapes: ShapeSet, table: Mapping, codes: Sequence[str], weight: np.ndarray
                    ) -> tuple[ShapeSet, dict]:
    """``shapes`` and ``table`` with a correction shape per AU of ``codes``: ``rig`` is the
    head's rig built from them, ``skin`` its skin at rest in the frame its shapes move in,
    ``landmarks`` (68,) the landmarks' skin vertices, ``iod`` its inter-ocular distance (cm)
    and ``weight`` (N,) how much of the correction each skin vertex takes (the skull and neck
    none)."""
    ref = reference_motion()
    skin_name = skin.name
    anchors = np.asarray(landmarks)[LANDMARKS]
    v = skin.vertices
    names, extra = list(shapes.names), []
    table = copy.deepcopy(dict(table))
    # the landmarks say nothing of the skin beyond them (the forehead, the scalp): the
    # correction fades out between REACH[0] and REACH[1] IOD from the nearest one
    near = cKDTree(v[anchors]).query(v)[0] / iod
    t = np.clip((REACH[1] - near) / (REACH[1] - REACH[0]), 0.0, 1.0)
    weight = np.asarray(weight) * t * t * (3 - 2 * t)
    for code in codes:
        residual = ref[code][LANDMARKS] * iod - rig.shape_deltas(code)[skin_name][anchors]
        extra.append(correction(v, v[anchors], residual, SIGMA * iod) * weight[:, None])
        names.append(PREFIX + code)
        table["aus"][code]["shapes"][PREFIX + code] = 1.0
    deltas = {}
    for obj, d in shapes.deltas.items():
        add = (np.stack(extra) if obj == skin_name
               else np.zeros((len(extra), *d.shape[1:]), d.dtype))
        deltas[obj] = np.concatenate([d, add.astype(d.dtype)])
    return ShapeSet(tuple(names), deltas), table
