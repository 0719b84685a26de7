"""Carry fitted fields to another head by its 68 landmarks, and load fitted files onto a head."""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from mimika.errors import DataError
from mimika.face.fitting.splits import eye_split, mouth_split, similarity_transform
from mimika.face.head import Head
from mimika.face.rigs.field import (
    FieldRig,
    parse_fields,
)
from mimika.limits import loads_json

log = logging.getLogger(__name__)


# --- transfer -----------------------------------------------------------------------------------


def transfer_fields(doc: Mapping, target: Head, *,
                    source_landmarks: np.ndarray | None = None) -> dict:
    """Carry a fields document to ``target`` (a new document; ``doc`` is not changed).

    The source landmarks (``doc["source"]["landmarks"]`` unless given) are aligned to the
    target's 68 landmarks by a similarity transform v_t ≈ s·R·v_s + t; the field frame becomes
    origin' = t + s·R·origin, scale' = s·scale, rotation' = R_old·Rᵀ (so u is unchanged for
    corresponding points and displacements map by s·R). Split surfaces are rebuilt from the
    target's landmarks (:func:`mouth_split`); head rotations/translations use the target's
    anchors (neck pivot, chin, neck base) and map their axes/vectors by R.
    """
    src = source_landmarks
    if src is None:
        try:
            src = np.asarray(doc["source"]["landmarks"], float)
        except (KeyError, TypeError):
            raise DataError("the fields file has no source landmarks (source.landmarks): it "
                            "was not written by 'mimika fit'; cannot transfer it") from None
    src = np.asarray(src, float).reshape(-1, 3)
    dst = target.landmark_points().astype(float)
    if src.shape != dst.shape:
        raise DataError(f"source has {len(src)} landmarks, target {len(dst)}")
    s, r, t = similarity_transform(src, dst)
    resid = np.linalg.norm(s * src @ r.T + t - dst, axis=1)
    log.info("transfer: scale %.4f, rotation %.2f°, landmark rms %.3f cm", s,
             np.degrees(np.arccos(np.clip((np.trace(r) - 1) / 2, -1, 1))),
             float(np.sqrt((resid**2).mean())))
    import copy

    out = copy.deepcopy(dict(doc))
    frame = out.get("frame", {})
    o = np.asarray(frame.get("origin", [0, 0, 0]), float)
    r_old = np.asarray(frame.get("rotation", np.eye(3)), float)
    frame = {"origin": np.round(t + s * r @ o, 6).tolist(),
             "scale": round(float(frame.get("scale", 1.0)) * s, 8),
             "rotation": np.round(r_old @ r.T, 10).tolist()}
    out["frame"] = frame
    ms = (doc.get("source") or {}).get("mouth_split") or {}
    normal = r @ np.asarray(ms.get("normal", [0.0, 1.0, 0.0]), float)
    offsets = np.asarray(ms.get("offsets", np.zeros((0, 2))), float).reshape(-1, 2)
    offsets = offsets * [1.0, s]  # |x| fractions stay, offsets (cm) scale
    splits = {**out.get("splits", {}), "mouth": mouth_split(dst, normal, offsets)}
    if "eyes" in splits:
        splits["eyes"] = eye_split(dst)
    out["splits"] = splits
    out.pop("split", None)
    a = target.anchors
    for spec in out.get("aus", {}).values():
        kind = spec.get("kind", "linear")
        if kind == "linear":
            continue
        if "axis" in spec:
            spec["axis"] = np.round(r @ np.asarray(spec["axis"], float), 8).tolist()
        if "vector" in spec:
            spec["vector"] = np.round(s * r @ np.asarray(spec["vector"], float), 6).tolist()
        if spec.get("pivot", "object") != "object" and "neck_pivot" in a:
            spec["pivot"] = np.round(np.asarray(a["neck_pivot"], float), 4).tolist()
        if "falloff" in spec and "chin" in a and "neck_base" in a:
            spec["falloff"] = {"top": round(float(a["chin"][1]), 4),
                               "bottom": round(float(a["neck_base"][1]), 4)}
    src_info = dict(out.get("source", {}))
    out["source"] = {**src_info, "head": target.name, "landmarks": np.round(dst, 5).tolist(),
                     "transferred_from": src_info.get("head", "?"),
                     "mouth_split": {"normal": np.round(normal, 8).tolist(),
                                     "offsets": np.round(offsets, 6).tolist()},
                     "similarity": {"scale": s, "rotation": np.round(r, 8).tolist(),
                                    "translation": np.round(t, 6).tolist()}}
    out["head"] = target.name
    return out


def read_fields_json(path: str | Path) -> dict:
    """A fields file as a dict (errors name the file, line and column)."""
    p = Path(path)
    try:
        text = p.read_text("utf-8")
    except OSError as e:
        raise DataError(f"cannot read fields file {p}: {e.strerror}") from None
    return loads_json(text, str(p))  # hostile JSON (NaN, huge integers, deep nests): DataError


#: landmark rms (cm) above which a fitted file is aligned to the head it is loaded on
ALIGN_TOLERANCE_CM = 0.05


def load_fitted_rig(head: Head, path: str | Path) -> FieldRig:
    """A :class:`FieldRig` on ``head`` from a fields file; a file that records the landmarks
    it was fitted on (``source.landmarks``, written by ``mimika fit``) is first carried to
    ``head`` by :func:`transfer_fields` when they differ from the head's (rms > 0.5 mm)."""
    doc = read_fields_json(path)
    src = (doc.get("source") or {}).get("landmarks") if isinstance(doc, dict) else None
    if src is not None:
        src = np.asarray(src, float)
        lm = head.landmark_points().astype(float)
        if src.shape == lm.shape and np.sqrt(((src - lm) ** 2).sum(1).mean()) > \
                ALIGN_TOLERANCE_CM:
            log.info("aligning fields %s to head %r by its landmarks", path, head.name)
            doc = transfer_fields(doc, head)
    return FieldRig(head, parse_fields(doc, source=str(path)))


def landmark_agreement(src_rig, dst_rig, codes: Sequence[str], *, rotation: np.ndarray | None
                       = None, moving: float = 0.2) -> dict[str, tuple[float, float, int]]:
    """Do AUs move the same landmarks the same way on two rigs? Per AU: (mean cosine, min
    cosine, number of landmarks) between the landmark displacements at τ = 1 on ``src_rig``
    (rotated by ``rotation``, the source → target similarity) and on ``dst_rig``, over the
    landmarks whose source displacement is ≥ ``moving`` × the AU's largest one."""
    r = np.eye(3) if rotation is None else np.asarray(rotation, float)
    l0s = src_rig.head.landmark_points().astype(float)
    l0d = dst_rig.head.landmark_points().astype(float)
    out = {}
    for code in codes:
        ds = (src_rig.head.landmark_points(src_rig.deform({code: 1.0})) - l0s) @ r.T
        dd = dst_rig.head.landmark_points(dst_rig.deform({code: 1.0})) - l0d
        ns, nd = np.linalg.norm(ds, axis=1), np.linalg.norm(dd, axis=1)
        sel = ns >= moving * ns.max() if ns.max() > 0 else np.zeros(len(ns), bool)
        if not sel.any():
            continue
        cos = (ds[sel] * dd[sel]).sum(1) / np.maximum(ns[sel] * nd[sel], 1e-12)
        out[code] = (float(cos.mean()), float(cos.min()), int(sel.sum()))
    return out
