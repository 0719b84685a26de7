"""Bring a face mesh of any size, orientation and unit into mimika's head frame.

The rule (reported by ``mimika heads --inspect`` and ``mimika rig``):

1. **Units** — the file's unit (glTF: metres; OBJ: centimetres assumed) converts to cm. If the
   eyes then sit less than 4 or more than 10 cm apart, the unit was wrong: the power of ten
   (or inches) that brings the eye distance nearest to 6.3 cm is used instead.
2. **Orientation** — start from the file's convention (glTF/VRM 1.0: y up, face toward +z;
   VRM 0.x: toward −z; OBJ: each of y-up and z-up with the face toward ±x or ±z is tried);
   the eye and mouth openings found there (:mod:`~mimika.face.rigging.features`) then set the
   exact frame: x from the right eye to the left eye; y the convention's up made square to x,
   unless the eyes-to-mouth line disagrees with it by more than 25° (then y follows that line,
   leaning back 5°); z = x × y, toward the viewer. Turns under 3° are ignored.
3. **Position** — the midpoint between the eyes moves to (0, 3.5, 8.9) cm, where the ICT and
   built-in heads have it.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from mimika.errors import DataError
from mimika.face.rigging.features import FaceFeatures, find_face

log = logging.getLogger(__name__)

__all__ = ["EYE_MID_CM", "Frame", "candidate_rotations", "detect_frame"]

#: where the midpoint between the eyes goes (cm, head frame)
EYE_MID_CM = np.array([0.0, 3.5, 8.9])
#: human eye distance used to decide the unit (cm), and the plausible range
EYE_DISTANCE_CM, EYE_RANGE_CM = 6.3, (4.0, 10.0)
_UNITS = {"mm": 0.1, "cm": 1.0, "in": 2.54, "dm": 10.0, "m": 100.0}
#: a face score below this means no face was found
MIN_SCORE = 0.2


@dataclass(frozen=True)
class Frame:
    """file point p → head point ``scale · R @ p + t`` (cm); ``features`` in the head frame."""

    scale: float
    rotation: np.ndarray
    translation: np.ndarray
    features: FaceFeatures | None
    unit: str
    notes: list[str] = field(default_factory=list)

    def apply(self, p: np.ndarray) -> np.ndarray:
        return (self.scale * np.asarray(p, float) @ self.rotation.T + self.translation)

    def apply_vector(self, d: np.ndarray) -> np.ndarray:
        return self.scale * np.asarray(d, float) @ self.rotation.T

    def describe(self) -> str:
        ang = np.degrees(np.arccos(np.clip((np.trace(self.rotation) - 1) / 2, -1, 1)))
        return (f"unit {self.unit} (x{self.scale:g} to cm), rotated {ang:.1f}° to face +z "
                f"with y up, eyes' midpoint at {EYE_MID_CM.tolist()} cm"
                + ("; " + "; ".join(self.notes) if self.notes else ""))


def _rot(up: Sequence[float], fwd: Sequence[float]) -> np.ndarray:
    """Rotation taking file axis ``up`` to +y and ``fwd`` to +z."""
    y, z = np.asarray(up, float), np.asarray(fwd, float)
    x = np.cross(y, z)
    return np.stack([x, y, z])


def candidate_rotations(kind: str, vrm_version: int | None = None) -> list[np.ndarray]:
    """Convention frames to try, most likely first (see the module rule, step 2)."""
    if kind == "gltf":
        front = [(0, 0, 1), (0, 0, -1)]
        if vrm_version == 0:
            front.reverse()
        return [_rot((0, 1, 0), f) for f in front]
    out = []
    for up, fwds in (((0, 1, 0), ((0, 0, 1), (0, 0, -1), (1, 0, 0), (-1, 0, 0))),
                     ((0, 0, 1), ((0, -1, 0), (0, 1, 0), (1, 0, 0), (-1, 0, 0)))):
        out += [_rot(up, f) for f in fwds]
    return out


#: faces lean back: the line from the mouth opening up to the eye openings leans back about
#: this much from the vertical (measured 1–27° on seven upright heads: ICT 11°, the built-in
#: head 21°, MakeHuman's base 20°, its presets 1–27°)
FACE_LEAN_DEG = 15.0
#: the mouth overrides the convention's up only when its lean is off by more than this
PITCH_TRUST_DEG = 25.0


def _exact(feat: FaceFeatures) -> np.ndarray:
    """The rotation that levels the eyes along x, keeping the current up (pitch) unless the
    mouth says it is off by more than PITCH_TRUST_DEG (then up follows the eyes-to-mouth line,
    leaning back FACE_LEAN_DEG)."""
    x = feat.eye_L - feat.eye_R
    x /= np.linalg.norm(x)
    y = np.array([0.0, 1.0, 0.0]) - x[1] * x
    y /= np.linalg.norm(y)
    m = 0.5 * (feat.eye_L + feat.eye_R) - feat.mouth
    m -= (m @ x) * x
    m /= np.linalg.norm(m)
    lean = np.degrees(np.arctan2(-(m @ np.cross(x, y)), m @ y))
    if abs(lean - FACE_LEAN_DEG) > PITCH_TRUST_DEG:
        z = np.cross(x, m)
        t = np.radians(FACE_LEAN_DEG)
        y = np.cos(t) * m + np.sin(t) * z
    return np.stack([x, y, np.cross(x, y)])


#: times the openings are looked for again from the frame they gave (a face turned 25° shows
#: its eye and mouth cavities at an angle: the first frame is off by a degree or two)
FRAME_ROUNDS = 3
#: rotations smaller than this are taken as the file's convention (asymmetric openings)
SNAP_DEG = 3.0


def _snap(r: np.ndarray, r0: np.ndarray) -> np.ndarray:
    """``r0`` when ``r`` differs from it by less than SNAP_DEG, else ``r``."""
    c = (np.trace(r @ r0.T) - 1) / 2
    return r0 if np.degrees(np.arccos(np.clip(c, -1, 1))) < SNAP_DEG else r


def _unit(distance_cm: float, unit: str) -> tuple[float, str, str | None]:
    """cm per file unit: the stated unit unless the eye distance says otherwise."""
    s = _UNITS[unit]
    if EYE_RANGE_CM[0] <= distance_cm <= EYE_RANGE_CM[1]:
        return s, unit, None
    raw = distance_cm / s
    name = min(_UNITS, key=lambda u: abs(np.log(raw * _UNITS[u] / EYE_DISTANCE_CM)))
    return _UNITS[name], name, (f"eye distance {distance_cm:.3g} cm in {unit} is not human: "
                                f"read as {name}")


def detect_frame(v: np.ndarray, f: np.ndarray, *, kind: str = "obj", unit: str = "cm",
                 vrm_version: int | None = None, where: str = "mesh") -> Frame:
    """The head frame of the face mesh (v, f) (file units); raises :class:`DataError` when no
    eyes and mouth are found."""
    v = np.asarray(v, float)
    best: tuple[float, np.ndarray, FaceFeatures] | None = None
    for r0 in candidate_rotations(kind, vrm_version):
        feat = find_face(v @ r0.T, f)
        if feat is not None and (best is None or feat.score > best[0]):
            best = (feat.score, r0, feat)
        if best is not None and best[0] > 0.6:
            break
    if best is None or best[0] < MIN_SCORE:
        raise DataError(f"{where}: no face found (no pair of eye openings above a mouth); "
                        "give its landmarks with --landmarks FILE (see docs/avatars.md)")
    _, r0, feat = best
    r = r0
    for _ in range(FRAME_ROUNDS):  # openings seen at an angle: look again from the front
        r_next = _snap(_exact(feat) @ r, r0)
        again = find_face(v @ r_next.T, f)
        turn = np.degrees(np.arccos(np.clip((np.trace(r_next @ r.T) - 1) / 2, -1, 1)))
        r, feat = r_next, again or feat
        if again is None or turn < 0.2:
            break
    s, unit_name, note = _unit(feat.eye_distance * _UNITS[unit], unit)
    t = EYE_MID_CM - s * 0.5 * (feat.eye_L + feat.eye_R)

    def move(p: np.ndarray) -> np.ndarray:
        return s * p + t

    feat = FaceFeatures(move(feat.eye_L), move(feat.eye_R), move(feat.mouth), move(feat.rim_L),
                        move(feat.rim_R), move(feat.rim_mouth), feat.score, feat.source)
    return Frame(s, r, t, feat, unit_name, [note] if note else [])


def frame_from_points(points: dict[str, np.ndarray], unit: str, where: str) -> Frame:
    """The head frame from given eye centres and mouth centre (a landmarks file or skeleton):
    ``eye_L``, ``eye_R`` and ``mouth`` in file units."""
    try:
        el, er, m = (np.asarray(points[k], float) for k in ("eye_L", "eye_R", "mouth"))
    except KeyError as e:
        raise DataError(f"{where}: landmarks need eye_L, eye_R and mouth (missing {e})") from None
    empty = np.zeros((0, 3))
    feat = FaceFeatures(el, er, m, empty, empty, empty, 1.0, "points")
    r = _snap(_exact(feat), np.eye(3))
    s, unit_name, note = _unit(feat.eye_distance * _UNITS[unit], unit)
    t = EYE_MID_CM - s * r @ (0.5 * (el + er))
    fr = Frame(s, r, t, None, unit_name, [note] if note else [])
    feat = FaceFeatures(fr.apply(el), fr.apply(er), fr.apply(m), empty, empty, empty, 1.0,
                        "points")
    return Frame(s, r, t, feat, unit_name, fr.notes)
