"""Seed 002 fields for every ICT expression shape (the ARKit set), not only for AUs.

One field per shape (``browDown_L`` … ``noseSneer_R``, 53 in all), fitted exactly as
:func:`~mimika.face.fitting.ict.fit_ict` fits an AU (same frame, splits, held-out half and
families); mouth, jaw and nose shapes are split by the mouth, lid shapes by the eye fissure
(rich family). The document is an ordinary fields file whose ``shapes`` section holds the
fields by shape name (``aus`` stays empty); :func:`shape_fields` parses it. Carried to any face
by its landmarks, these fields generate ARKit-named blendshapes (``mimika rig``) and the shapes
an avatar lacks (``--head avatar.glb``).
"""

from __future__ import annotations

import logging
import time
import zlib
from collections.abc import Mapping, Sequence
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from mimika.errors import DataError, ParameterError
from mimika.face.fitting.ict import (
    FitOptions,
    FitResult,
    Progress,
    _fit_objects,
    _setup,
    accuracy_rows,
)
from mimika.face.head import Head
from mimika.face.rigs.blendshape import ShapeSet
from mimika.face.rigs.field import FieldSet, _field_from_json, parse_fields

if TYPE_CHECKING:
    from mimika.face.makehuman.character_file import Character

log = logging.getLogger(__name__)

__all__ = ["fit_character_shapes", "fit_ict_shapes", "fit_shapes", "shape_fields",
           "shape_split"]


def shape_split(name: str, lid_split: bool) -> str | None:
    """The split surface a shape's field is fitted with: ``mouth`` for mouth, jaw and nose
    shapes (the sneer raises the upper lip: ICT's actor's 0.042 inter-ocular distances, the
    lower lip's 0.007 — unsplit, its field lifted a closed mouth's lower lip as far),
    ``eyes`` for the lid shapes (rich family), none for brows and cheeks."""
    if name.startswith(("mouth", "jaw", "nose")):
        return "mouth"
    if lid_split and name.startswith("eye"):
        return "eyes"
    return None


def fit_ict_shapes(path: str | None = None, names: Sequence[str] | None = None,
                   options: FitOptions | None = None,
                   progress: Progress | None = None) -> FitResult:
    """Fit one field per ICT shape (folder ``path`` or ``$MIMIKA_ICT_DIR``); ``names``: a
    subset (default all). Accuracy rows (held-out skin vertices) are keyed by shape name."""
    from mimika.face.heads.ict import load_ict

    head, shapes = load_ict(path)
    return fit_shapes(head, shapes, names, options, progress)


def character_face(head: Head) -> np.ndarray:
    """The face of a MakeHuman character's skin: above the chin's level less 1 cm, in front
    of the eyes' centres less 6 cm (what the ICT face range is on the ICT head)."""
    v = head["skin"].vertices
    a = head.anchors
    eye_z = (a["eye_L"][2] + a["eye_R"][2]) / 2
    return (v[:, 1] > a["chin"][1] - 1.0) & (v[:, 2] > eye_z - 6.0)


def fit_character_shapes(character: str | Character = "base",
                         names: Sequence[str] | None = None,
                         options: FitOptions | None = None,
                         progress: Progress | None = None) -> FitResult:
    """Fit one field per MakeHuman faceunit (ARKit 52 but ``tongueOut``, named as the AU
    tables name them: ``browDown_L`` …) on a character's skin; ``"base"``: MakeHuman's
    average person without hair or clothes."""
    from mimika.face.heads.character import base_character, character_shapes

    head, shapes = character_shapes(base_character() if character == "base" else character)
    keep = [n for n in shapes.names if n != "tongueOut"]
    return fit_shapes(head, shapes, keep if names is None else names, options, progress,
                      face=character_face(head), source="makehuman")


def fit_shapes(head: Head, shapes: ShapeSet, names: Sequence[str] | None = None,
               options: FitOptions | None = None, progress: Progress | None = None, *,
               face: np.ndarray | None = None, source: str = "ict") -> FitResult:
    """One field per shape of ``shapes`` on ``head`` (``face``: its face vertices, default
    the ICT face range)."""
    opt = options or FitOptions(family="rich")
    t_start = time.perf_counter()
    avail = list(shapes.names)
    todo = list(avail) if names is None else list(dict.fromkeys(names))
    bad = [n for n in todo if n not in avail]
    if bad:
        raise ParameterError(f"no {source} shape named {', '.join(bad)}; shapes: "
                             f"{', '.join(avail)}")
    rest = head.rest

    def pose(k: int) -> dict[str, np.ndarray]:
        return {o: rest[o] + shapes.deltas[o][k] if o in shapes.deltas else rest[o]
                for o in rest}

    st = _setup(head, pose(avail.index("jawOpen"))["skin"], opt, ", one field per shape",
                face, source)
    doc = st.doc
    doc["shapes"] = {}
    heldout: dict[str, np.ndarray] = {}
    measured: dict[str, np.ndarray] = {}
    times: dict[str, float] = {}
    for i, name in enumerate(todo):
        t0 = time.perf_counter()
        rng = np.random.default_rng([opt.seed, zlib.crc32(name.encode())])
        objects, n_mov = _fit_objects(st, pose(avail.index(name)), rng,
                                      shape_split(name, bool(opt.lid_split)), False, name,
                                      heldout, measured)
        if objects:
            doc["shapes"][name] = {"objects": objects}
        times[name] = time.perf_counter() - t0
        log.info("fitted %s in %.2f s (%d moving face vertices)", name, times[name], n_mov)
        if progress:
            progress(i + 1, len(todo))
    fields = shape_fields(doc, source="<fit>")
    rows = accuracy_rows(fields, head, [n for n in todo if n in doc["shapes"]], measured,
                         heldout, st.teeth_names, times)
    return FitResult(doc, rows, opt.family, time.perf_counter() - t_start)


def shape_fields(doc: Mapping, *, source: str = "<memory>") -> FieldSet:
    """The ``shapes`` section of a fields document as a :class:`FieldSet` keyed by shape name
    (frame and splits from the document); use with ``FieldRig(head, fs).field_at(name, …)``."""
    base = parse_fields({**doc, "aus": {}}, source=source)
    linear: dict[str, dict] = {}
    for name, spec in (doc.get("shapes") or {}).items():
        try:
            linear[name] = {cat: _field_from_json(f, base.splits)
                            for cat, f in spec["objects"].items()}
        except (KeyError, ValueError, TypeError) as e:
            raise DataError(f"{source}: shapes.{name}: {e}") from None
    return replace(base, linear=linear)
