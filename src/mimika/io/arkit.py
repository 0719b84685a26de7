"""FACS AUs ↔ ARKit-52 blendshapes (+ head and eye rotations), as Live Link Face names them.

Import (:func:`arkit_to_aus`) follows ``io/data/arkit_aus.json`` (DATA.md's table); export
(:func:`aus_to_arkit`) follows the rig's ``face/data/ict_aus.json`` (AU → shapes with weights),
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

__all__ = ["ARKIT_52", "EXTRAS", "LIVELINK_COLUMNS", "ROTATIONS", "arkit_extras", "arkit_to_aus",
           "aus_to_arkit", "table"]

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


#: Live Link channels no AU can say (and the jaw's direction, which AU30 loses): carried in
#: ``track.meta["arkit_extra"]`` from import to export
EXTRAS = ("JawLeft", "JawRight", "MouthClose", "MouthLeft", "MouthRight", "LeftEyeRoll",
          "RightEyeRoll")


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
    from mimika.face.blendshape import load_table

    spec_of = {**table()["export_extra"], **load_table()["aus"]}
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


def arkit_extras(shapes: np.ndarray, rotations: np.ndarray | None, *, fps: float,
                 names: Sequence[str] = ARKIT_52) -> dict:
    """The :data:`EXTRAS` channels of ARKit frames — ``{"fps": fps, name: (T,) float32}`` —
    for ``track.meta["arkit_extra"]``, where the Live Link writer finds them again."""
    idx = {n: i for i, n in enumerate(names)}
    x = np.asarray(shapes, np.float32)
    out: dict = {"fps": float(fps)}
    for n in EXTRAS:
        if n in idx:
            v = x[:, idx[n]].copy()
        elif n in ROTATIONS and rotations is not None:
            v = np.asarray(rotations, np.float32)[:, ROTATIONS.index(n)].copy()
        else:
            continue
        v.setflags(write=False)
        out[n] = v
    return out
