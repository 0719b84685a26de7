"""Blendshapes for any face from seed 002's fields: per-shape fields fitted on one rig's
expression shapes are carried to the face by its 68 landmarks
(:func:`~mimika.face.fitting.transfer.transfer_fields`) and evaluated on its vertices.

Two styles are shipped: ``ict`` (the ICT Face Model's 53 light-stage scans of an actor,
``face/data/ict_shape_fields.json``, the default) and ``makehuman`` (MakeHuman's 51 artist-made
ARKit faceunits but ``tongueOut``, ``face/data/makehuman_shape_fields.json``): two rigs' ideas
of the same ARKit names, which differ by about 2× in strength (docs/avatars.md)."""

from __future__ import annotations

import functools
import json
from collections.abc import Callable, Iterable
from dataclasses import replace
from importlib import resources

import numpy as np
from scipy.spatial import cKDTree

from mimika.errors import ParameterError
from mimika.face.fitting.shapes import shape_fields
from mimika.face.fitting.splits import similarity_transform
from mimika.face.fitting.transfer import transfer_fields
from mimika.face.head import Head
from mimika.face.rigs.field import FieldSet, LinearField, SplitField

__all__ = ["ARKIT_SUMS", "STYLES", "Shapes", "available", "generate_shapes", "shape_document",
           "template", "template_landmarks"]

#: shipped per-shape field sets (``face/data/<style>_shape_fields.json``)
STYLES = ("ict", "makehuman")
#: ARKit shapes that are one shape per side in the ICT set: generated as the sum of both
ARKIT_SUMS = {"browInnerUp": ("browInnerUp_L", "browInnerUp_R"),
              "cheekPuff": ("cheekPuff_L", "cheekPuff_R")}
#: along the mesh, a vertex within this of equally near both sides of a split (skin joining
#: the lips or lids past the opening's end) takes both fields, blended (cm)
SPLIT_BLEND_CM = 0.3
#: below the chin the fields fade out between these depths, in chin → nose-bridge lengths:
#: they were fitted on a head and neck, and evaluated on a body they reach the chest and
#: shoulders (a cheek field moved a character's shoulder 3 cm, through her neckline)
NECK_FADE = (0.4, 0.8)
#: shape name → {object name: (N, 3) float32 deltas in cm}
Shapes = dict[str, dict[str, np.ndarray]]


@functools.cache
def shape_document(style: str = "ict") -> dict:
    """A shipped per-shape fields document (``mimika.face.fitting.shapes``, rich family)."""
    if style not in STYLES:
        raise ParameterError(f"unknown shape style {style!r}; styles: {', '.join(STYLES)}")
    text = resources.files("mimika.face").joinpath(f"data/{style}_shape_fields.json"
                                                   ).read_text("utf-8")
    return json.loads(text)


def template_landmarks(style: str = "ict") -> np.ndarray:
    """The 68 landmarks (cm) of the face a style's fields were fitted on: the template the
    landmarks of a new face are placed from, so they follow the same convention."""
    return np.asarray(shape_document(style)["source"]["landmarks"], float)


def template(style: str = "ict") -> dict:
    """Everything the landmark placer knows of a style's template face: ``landmarks``, and
    where present ``openings`` and ``surface`` (:func:`~mimika.face.rigging.template.
    face_template`)."""
    src = shape_document(style)["source"]
    out = {"template": template_landmarks(style), "template_openings": src.get("openings")}
    if "surface" in src:
        out["surface"] = np.asarray(src["surface"], float)
    return out


def available(style: str = "ict") -> tuple[str, ...]:
    """Shapes a style's fields can generate (AU-table names, plus the ARKit sums)."""
    have = shape_document(style)["shapes"]
    return (*have, *(s for s, parts in ARKIT_SUMS.items()
                     if s not in have and all(p in have for p in parts)))


def _support(f: LinearField, eps: float) -> list[tuple[np.ndarray, np.ndarray]]:
    """Boxes (lo, hi) in field coordinates outside which ``f`` moves points less than
    ``eps`` (field units): each Gaussian to where it falls below eps, each RBF centre to 4σ."""
    boxes = []
    for g in f.gaussians:
        r = np.sqrt(2 * np.log(max(abs(g.eta), eps) / eps)) * np.sqrt(np.diag(np.linalg.inv(
            g.B)))
        boxes.append((g.mean - r, g.mean + r))
    if f.rbf is not None:
        r = 4.0 * f.rbf.sigma
        boxes.append((f.rbf.centers.min(0) - r, f.rbf.centers.max(0) + r))
    return boxes


def _in_boxes(u: np.ndarray, boxes: list[tuple[np.ndarray, np.ndarray]]) -> np.ndarray:
    out = np.zeros(len(u), bool)
    for lo, hi in boxes:
        out |= np.all((u >= lo) & (u <= hi), axis=1)
    return out


def _field_on(fs: FieldSet, field: LinearField | SplitField, upper: np.ndarray | None,
              v: np.ndarray, eps: float) -> np.ndarray:
    """Displacements (cm) of ``field`` at points ``v``, evaluated only inside its support
    (FieldRig.field_at, culled for large meshes); ``upper``: split weights of the points."""
    u = fs.to_u(v)
    out = np.zeros_like(u)
    halves = ((field, None),) if isinstance(field, LinearField) else (
        (field.upper, upper), (field.lower, None if upper is None else 1.0 - upper))
    for f, w in halves:
        if f is None:
            continue
        sel = _in_boxes(u, _support(f, eps))
        if f.rbf is not None:  # the residual: only within 4σ of one of its centres
            near = np.isfinite(cKDTree(f.rbf.centers).query(
                u, distance_upper_bound=4.0 * f.rbf.sigma)[0])
            sel &= near | _in_boxes(u, _support(replace(f, rbf=None), eps))
        if w is not None:
            sel &= w > 0
        if sel.any():
            d = f(u[sel])
            out[sel] += d if w is None else d * w[sel, None]
    return fs.to_head(out)


def _neck_fade(head: Head) -> Callable[[np.ndarray], np.ndarray]:
    """Weights (N,) for points (N, 3): 1 down to :data:`NECK_FADE`'s first depth below the
    chin along the face's own up (chin → nose bridge), 0 past its second, smooth between."""
    lm = head.landmark_points().astype(float)
    up = lm[27] - lm[8]
    h = float(np.linalg.norm(up))
    up /= h

    def weight(v: np.ndarray) -> np.ndarray:
        depth = (lm[8] - v) @ up / h  # how far below the chin, in face lengths
        t = np.clip((NECK_FADE[1] - depth) / (NECK_FADE[1] - NECK_FADE[0]), 0.0, 1.0)
        return t * t * (3 - 2 * t)

    return weight


def _rigid(v: np.ndarray, d: np.ndarray) -> np.ndarray:
    """The displacement of the rigid motion that best matches ``d`` at points ``v``
    (Kabsch), so a tooth row or tongue moves as one piece."""
    if not np.any(d):
        return d
    _, r, _ = similarity_transform(v, v + d)  # its rotation; the scale is dropped
    c = v.mean(0)
    return (v - c) @ r.T + c + d.mean(0) - v


def generate_shapes(head: Head, names: Iterable[str] | None = None, style: str = "ict"
                    ) -> Shapes:
    """Deltas of shapes ``names`` (default: all available) of ``style`` on every object of
    ``head`` that their fields move: face objects per vertex; rigid objects (teeth, tongue)
    take one side of the mouth split — the side most of their vertices lie on (the FieldRig
    uses the centroid, which puts long upper teeth below the lips)."""
    full = shape_document(style)
    # the shapes are in field coordinates: only the frame, splits and source move
    doc = transfer_fields({k: v for k, v in full.items() if k != "shapes"}, head)
    doc["shapes"] = full["shapes"]
    fs = shape_fields(doc, source=f"{style}_shape_fields.json")
    eps = 1e-4 / fs.scale  # 1 µm
    fade = _neck_fade(head)
    upper = {}
    for sname, sp in fs.splits.items():
        for o in head.objects:
            v = o.vertices.astype(float)
            if o.category == "face":  # along the mesh, its UV-seam copies as one vertex
                _, first, inv = np.unique(np.arange(len(v)) if o.weld is None else o.weld,
                                          return_index=True, return_inverse=True)
                upper[sname, o.name] = sp.surface_weight(v[first], inv[o.faces],
                                                         blend=SPLIT_BLEND_CM)[inv]
            else:  # rigid objects (teeth rows, tongue) go whole, by where most of them lies
                upper[sname, o.name] = np.full(len(v), float(sp.upper_weight(v).mean() > 0.5))
    want = list(available(style) if names is None else names)
    base = {n for w in want for n in (ARKIT_SUMS.get(w, (w,)) if w not in fs.linear else (w,))}
    out: Shapes = {}
    for name in base:
        if name not in fs.linear:
            raise KeyError(name)
        per = {}
        for o in head.objects:
            f = fs.linear[name].get(o.category)
            if f is None:
                continue
            w = None if isinstance(f, LinearField) else upper[f.split, o.name]
            v = o.vertices.astype(float)
            d = _field_on(fs, f, w, v, eps) * fade(v)[:, None]
            if o.category != "face":  # teeth and tongue stay rigid: the best rigid motion
                d = _rigid(v, d)
            d = d.astype(np.float32)
            if np.abs(d).max() > 1e-6:
                per[o.name] = d
        out[name] = per
    for total, parts in ARKIT_SUMS.items():
        if total in want and total not in fs.linear:
            objs = {k for p in parts for k in out[p]}
            out[total] = {k: sum(out[p].get(k, 0) for p in parts) for k in objs}
    return {n: out[n] for n in want}
