"""FACS AUs ↔ ARKit-52 blendshapes (+ head and eye rotations), as Live Link Face names them.

Import (:func:`arkit_to_aus`) follows ``io/data/arkit_aus.json`` (DATA.md's table); export
(:func:`aus_to_arkit`) follows the rig's ``facs/data/ict_aus.json`` (AU → shapes with weights),
whose primary entries are the exact inverse. Sides: ARKit ``…Left`` is the subject's left (L).
Equal left and right values import as the bilateral AU plus one-sided residuals.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from functools import lru_cache
from importlib import resources

import numpy as np

from mimika.facs import parse_au
from mimika.facs.shapes import au_shape_table

__all__ = ["ARKIT_52", "LIVELINK_COLUMNS", "ROTATIONS", "apply_extras", "arkit_extras",
           "arkit_to_aus", "aus_to_arkit", "extra_names", "shape_groups", "table"]

#: the 52 ARKit blendshapes in Live Link Face's column order
ARKIT_52 = (
    "EyeBlinkLeft", "EyeLookDownLeft", "EyeLookInLeft", "EyeLookOutLeft", "EyeLookUpLeft",
    "EyeSquintLeft", "EyeWideLeft", "EyeBlinkRight", "EyeLookDownRight", "EyeLookInRight",
    "EyeLookOutRight", "EyeLookUpRight", "EyeSquintRight", "EyeWideRight", "JawForward",
    "JawRight", "JawLeft", "JawOpen", "MouthClose", "MouthFunnel", "MouthPucker", "MouthRight",
    "MouthLeft", "MouthSmileLeft", "MouthSmileRight", "MouthFrownLeft", "MouthFrownRight",
    "MouthDimpleLeft", "MouthDimpleRight", "MouthStretchLeft", "MouthStretchRight",
    "MouthRollLower", "MouthRollUpper", "MouthShrugLower", "MouthShrugUpper", "MouthPressLeft",
    "MouthPressRight", "MouthLowerDownLeft", "MouthLowerDownRight", "MouthUpperUpLeft",
    "MouthUpperUpRight", "BrowDownLeft", "BrowDownRight", "BrowInnerUp", "BrowOuterUpLeft",
    "BrowOuterUpRight", "CheekPuff", "CheekSquintLeft", "CheekSquintRight", "NoseSneerLeft",
    "NoseSneerRight", "TongueOut",
)
#: the 9 rotation columns (radians)
ROTATIONS = ("HeadYaw", "HeadPitch", "HeadRoll", "LeftEyeYaw", "LeftEyePitch", "LeftEyeRoll",
             "RightEyeYaw", "RightEyePitch", "RightEyeRoll")
LIVELINK_COLUMNS = ("Timecode", "BlendShapeCount", *ARKIT_52, *ROTATIONS)
_INDEX = {n: i for i, n in enumerate(ARKIT_52)}


#: ARKit shapes no AU can say
_NO_AU = ("MouthClose", "MouthLeft", "MouthRight")


@lru_cache(maxsize=1)
def table() -> dict:
    """``io/data/arkit_aus.json``: ARKit → AU import table, head and eye rotation scales."""
    text = resources.files("mimika.io").joinpath("data/arkit_aus.json").read_text("utf-8")
    return json.loads(text)


def _arkit_name(ict: str) -> tuple[str, str | None]:
    """``mouthSmile_L`` → (``MouthSmile``, ``L``); ``jawOpen`` → (``JawOpen``, None)."""
    side = None
    if ict.endswith(("_L", "_R")):
        ict, side = ict[:-2], ict[-1]
    return ict[0].upper() + ict[1:], side


def _targets(base: str, side: str | None) -> list[tuple[int, float]]:
    """ARKit column indices (and weights) a shape ``base`` on ``side`` (None: both) drives."""
    if base + "Left" in _INDEX:
        sides = ("L", "R") if side is None else (side,)
        return [(_INDEX[base + ("Left" if s == "L" else "Right")], 1.0) for s in sides]
    if base in _INDEX:  # one midline ARKit shape: each side contributes half
        return [(_INDEX[base], 1.0 if side is None else 0.5)]
    return []


def aus_to_arkit(values: np.ndarray, channels: Sequence[str]) -> tuple[np.ndarray, np.ndarray]:
    """AU frames (T, K) → ARKit blendshapes (T, 52) in [0, 1] and rotations (T, 9) in radians."""
    spec_of = {**table()["export_extra"], **au_shape_table()["aus"]}
    v = np.asarray(values, np.float64).reshape(len(values), len(channels))
    out = np.zeros((len(v), len(ARKIT_52)))
    rot = np.zeros((len(v), len(ROTATIONS)))
    head_rv = np.zeros((len(v), 3))
    eye_rv = np.zeros((len(v), 3))
    for k, raw in enumerate(channels):
        code = parse_au(raw)
        base, side = code[:4], code[4:] or None
        spec = spec_of.get(base)
        if spec is None:
            continue
        if side is None and spec.get("bilateral_side"):
            side = spec["bilateral_side"]
        for shape, w in spec.get("shapes", {}).items():
            sbase, sside = _arkit_name(shape)
            if sside is not None and side is not None and sside != side:
                continue
            for j, f in _targets(sbase, sside or side):
                out[:, j] += w * f * v[:, k]
        if "head_rotate_deg" in spec:
            head_rv += np.radians(spec["head_rotate_deg"])[None, :] * v[:, k:k + 1]
        if "eye_rotate_deg" in spec:
            eye_rv += np.radians(spec["eye_rotate_deg"])[None, :] * v[:, k:k + 1]
    # mimika convention: +yaw toward the subject's right, +pitch down, +roll toward the right
    rot[:, 0], rot[:, 1], rot[:, 2] = -head_rv[:, 1], head_rv[:, 0], head_rv[:, 2]
    for base in (3, 6):
        rot[:, base], rot[:, base + 1] = -eye_rv[:, 1], eye_rv[:, 0]
    return np.clip(out, 0.0, 1.0).astype(np.float32), rot.astype(np.float32)


def arkit_to_aus(shapes: np.ndarray, rotations: np.ndarray | None = None, *,
                 names: Sequence[str] = ARKIT_52) -> tuple[np.ndarray, tuple[str, ...]]:
    """ARKit frames (T, len(names)) in [0, 1] (+ optional rotations (T, 9), radians) → AU
    frames (T, K) and their channel codes. Eye rotations are not used (the eyeLook shapes
    already carry gaze); head rotations become AU51–56."""
    idx = {n: i for i, n in enumerate(names)}
    x = np.clip(np.asarray(shapes, np.float64), 0.0, 1.0)

    def col(name: str) -> np.ndarray:
        return x[:, idx[name]] if name in idx else np.zeros(len(x))

    cols: dict[str, np.ndarray] = {}
    for code, spec in table()["aus"].items():
        if "L" in spec:
            left, right = col(spec["L"]), col(spec["R"])
            both = np.minimum(left, right)
            cols[code] = both
            rest = spec.get("residual", code)
            cols[rest + "L"] = left - both
            cols[rest + "R"] = right - both
        elif "max" in spec:
            cols[code] = np.max([col(n) for n in spec["max"]], axis=0)
        else:
            cols[code] = np.mean([col(n) for n in spec["mean"]], axis=0)
    if rotations is not None:
        from mimika.io.rotations import head_aus

        r = np.asarray(rotations, np.float64)
        cols.update(head_aus(r[:, 0], r[:, 1], r[:, 2]))
    aus = table()["aus"]
    keep = [c for c, v in cols.items() if c in aus or np.any(v > 1e-6)]
    keep.sort(key=lambda c: (int(c[2:4]), ("", "L", "R").index(c[4:])))
    vals = np.stack([cols[c] for c in keep], axis=1) if keep else np.zeros((len(x), 0))
    return np.clip(vals, 0.0, 1.0).astype(np.float32), tuple(keep)


@lru_cache(maxsize=1)
def shape_groups() -> dict[str, tuple[str, tuple[str, ...]]]:
    """AUs imported from several shapes at once: ``{code: ("mean" | "max", shapes)}`` (AU28
    from both lip rolls, AU30 from JawLeft/JawRight, AU61–64 from both eyes' look shapes)."""
    return {c: (k, tuple(spec[k])) for c, spec in table()["aus"].items()
            for k in ("mean", "max") if len(spec.get(k, ())) > 1}


@lru_cache(maxsize=1)
def extra_names() -> tuple[str, ...]:
    """What an AU track cannot carry exactly: MouthClose, MouthLeft/Right, the shapes of
    :func:`shape_groups` (how the group's AU splits between them: the jaw's direction, each
    eye's and each lip's share) and the 9 rotations (as their difference from what the AUs
    imply: eye roll, the tracker's own eye angles, head turns beyond intensity 1)."""
    return (*_NO_AU, *(n for _, names in shape_groups().values() for n in names), *ROTATIONS)


def arkit_extras(shapes: np.ndarray, rotations: np.ndarray | None, *, fps: float,
                 names: Sequence[str] = ARKIT_52) -> dict:
    """The :func:`extra_names` channels of ARKit frames — ``{"fps": fps, name: (T,)}`` — for
    ``track.meta["arkit_extra"]``, where :func:`apply_extras` finds them again on export."""
    idx = {n: i for i, n in enumerate(names)}
    x = np.clip(np.asarray(shapes, np.float32), 0.0, 1.0)  # as the AUs see them
    out: dict = {"fps": float(fps)}
    for n in extra_names():
        if n in idx:
            out[n] = x[:, idx[n]].copy()
    if rotations is not None:
        vals, chans = arkit_to_aus(x, rotations, names=names)
        implied = aus_to_arkit(vals, chans)[1]
        rest = np.asarray(rotations, np.float32) - implied
        out.update({n: rest[:, j].copy() for j, n in enumerate(ROTATIONS)})
    for v in out.values():
        if isinstance(v, np.ndarray):
            v.setflags(write=False)
    return out


def apply_extras(shapes: np.ndarray, rot: np.ndarray, extra: dict[str, np.ndarray]) -> None:
    """Put the :func:`extra_names` channels (resampled to the frames of ``shapes``) back into
    exported ARKit frames, in place: the no-AU shapes as they were, each shape group's
    exported value split between its shapes in the imported proportions, and the rotations'
    differences added — exact when the AUs were not changed, following them when they were."""
    for name in _NO_AU:
        if name in extra:
            shapes[:, _INDEX[name]] = np.clip(extra[name], 0.0, 1.0)
    for agg, names in shape_groups().values():
        if not all(n in extra for n in names):
            continue
        pool = np.mean if agg == "mean" else np.max
        raw = np.stack([extra[n] for n in names], axis=1).astype(np.float64)
        ref = pool(raw, axis=1)
        now = pool(np.stack([shapes[:, _INDEX[n]] for n in names], axis=1), axis=1)
        has = ref > 1e-6
        for j, n in enumerate(names):
            shapes[has, _INDEX[n]] = np.clip(now[has] * raw[has, j] / ref[has], 0.0, 1.0)
    for j, name in enumerate(ROTATIONS):
        if name in extra:
            rot[:, j] += extra[name]
