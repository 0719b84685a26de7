"""Blendshapes for any face from seed 002's fields: the shipped per-shape fields (fitted on the
ICT Face Model's 53 expression shapes, ``face/data/ict_shape_fields.json``) are carried to the
face by its 68 landmarks (:func:`~mimika.face.fitting.transfer.transfer_fields`) and evaluated
on its vertices."""

from __future__ import annotations

import functools
import json
from collections.abc import Iterable
from importlib import resources

import numpy as np

from mimika.face.fitting.shapes import shape_fields
from mimika.face.fitting.transfer import transfer_fields
from mimika.face.head import Head
from mimika.face.rigs.field import FieldRig

__all__ = ["ARKIT_SUMS", "Shapes", "generate_shapes", "shape_document", "template_landmarks"]

#: ARKit shapes that are one shape per side in the ICT set: generated as the sum of both
ARKIT_SUMS = {"browInnerUp": ("browInnerUp_L", "browInnerUp_R"),
              "cheekPuff": ("cheekPuff_L", "cheekPuff_R")}
#: shape name → {object name: (N, 3) float32 deltas in cm}
Shapes = dict[str, dict[str, np.ndarray]]


@functools.cache
def shape_document() -> dict:
    """The shipped per-shape fields (``mimika.face.fitting.shapes.fit_ict_shapes``, rich
    family), as a fields document."""
    text = resources.files("mimika.face").joinpath("data/ict_shape_fields.json").read_text(
        "utf-8")
    return json.loads(text)


def template_landmarks() -> np.ndarray:
    """The 68 landmarks (cm) of the face the shipped fields were fitted on (ICT)."""
    return np.asarray(shape_document()["source"]["landmarks"], float)


def available() -> tuple[str, ...]:
    """Shapes the shipped fields can generate (ICT names, plus the ARKit sums)."""
    return (*shape_document()["shapes"], *ARKIT_SUMS)


def generate_shapes(head: Head, names: Iterable[str] | None = None) -> Shapes:
    """Deltas of shapes ``names`` (default: all available) on every object of ``head`` that
    their fields move (face category per vertex, teeth rigidly by side of the mouth)."""
    doc = transfer_fields(shape_document(), head)
    fs = shape_fields(doc, source="ict_shape_fields.json")
    rig = FieldRig(head, fs)
    want = list(available() if names is None else names)
    base = {n for w in want for n in ARKIT_SUMS.get(w, (w,))}
    out: Shapes = {}
    for name in base:
        if name not in fs.linear:
            raise KeyError(name)
        per = {}
        for o in head.objects:
            if o.category in fs.linear[name]:
                d = rig.field_at(name, o.name, o.vertices).astype(np.float32)
                if np.abs(d).max() > 1e-6:
                    per[o.name] = d
        out[name] = per
    for total, parts in ARKIT_SUMS.items():
        if total in want:
            objs = {k for p in parts for k in out[p]}
            out[total] = {k: sum(out[p].get(k, 0) for p in parts) for k in objs}
    return {n: out[n] for n in want}
