"""FACS appearance changes on the skin: which furrows an AU brings, where on a face they lie.

The patterns themselves are drawn by ``shaders/wrinkles.glsl`` in **face units**: a point's
place in front of the face, x toward the subject's left and y up, in inter-ocular distances
from the eye midpoint — the same on every head. This module gives the shader each skin
vertex's face coordinates and the landmarks it needs (brows, eye corners, nose wing, mouth
corners, lips, chin; the left and right halves averaged), and turns a frame's AU intensities
into each group's depth per side from ``render/data/wrinkles.json`` — deeper with a
character's age.
"""

from __future__ import annotations

import functools
import json
from collections.abc import Mapping
from importlib import resources

import numpy as np

from mimika.face.head import Head
from mimika.face.rig import split_sides


@functools.cache
def table() -> dict:
    """The wrinkle groups, their depths, the AU → group table and the depths at rest."""
    text = resources.files("mimika.render").joinpath("data/wrinkles.json").read_text("utf-8")
    return json.loads(text)


def age_factor(head: Head) -> float:
    """0 at 20 years or younger … 1 at 70 or older; 0.3 for heads without an age."""
    age = (head.meta.get("phenotype") or {}).get("age", head.meta.get("age"))
    if age is None:
        return 0.3
    return float(np.clip((float(age) - 20.0) / 50.0, 0.0, 1.0))


class Wrinkles:
    """The wrinkles of one head: ``face`` (N, 3) per vertex of its landmark object (face-unit
    x, y and how much of the face it is, 0 … 1), ``uniforms`` (the landmarks in face units)
    and :meth:`weights` per frame."""

    def __init__(self, head: Head) -> None:
        t = table()
        self.groups: tuple[str, ...] = tuple(t["groups"])
        lm = head.landmark_points().astype(np.float64)
        eye_l, eye_r = (np.asarray(head.anchors[k], np.float64) for k in ("eye_L", "eye_R"))
        iod = float(np.linalg.norm(eye_l - eye_r))
        mid = (eye_l + eye_r) / 2.0
        f = (lm[:, :2] - mid[:2]) / iod

        def pair(a: int, b: int) -> tuple[float, float]:  # left/right landmarks, mirrored
            return (0.5 * (abs(f[a, 0]) + abs(f[b, 0])), 0.5 * (f[a, 1] + f[b, 1]))

        self.uniforms = {
            "u_brow_y": float(f[17:27, 1].mean()),
            "u_eye_out": pair(36, 45), "u_eye_in": pair(39, 42),
            "u_lid_y": float(f[[40, 41, 46, 47], 1].mean()),
            "u_wing": pair(31, 35), "u_nasion_y": float(f[27, 1]),
            "u_corner": pair(48, 54), "u_lip_top": float(f[51, 1]),
            "u_lip_bot": float(f[57, 1]), "u_chin_y": float(f[8, 1]),
        }
        v = head[head.landmark_object].vertices.astype(np.float64)
        fv = (v[:, :2] - mid[:2]) / iod
        # in front of the ears and no farther than the face is wide
        depth = (v[:, 2] - (mid[2] - 0.55 * iod)) / (0.2 * iod)
        on = np.clip(depth, 0.0, 1.0) * (np.abs(fv[:, 0]) < 1.1)
        self.face = np.c_[fv, on].astype(np.float32)
        a = age_factor(head)
        self.gain = 0.7 + 0.6 * a
        depth_cm = np.array([t["depth_cm"][g] for g in self.groups])
        self.depth = depth_cm * self.gain
        rest = np.array([t["rest"].get(g, 0.0) for g in self.groups]) * a
        self.rest = np.repeat(rest * depth_cm, 2)  # (left, right) per group
        self._rows = {au: np.array([m.get(g, 0.0) for g in self.groups])
                      for au, m in t["aus"].items()}

    def description(self) -> dict:
        """What a player needs to draw this head's wrinkles itself (the studio viewer, from
        a GLB's ``extras.wrinkles``): the groups, their depths (cm, age included), the depths
        at rest per side, the AU table and the landmark uniforms."""
        return {"groups": list(self.groups), "depth": np.round(self.depth, 5).tolist(),
                "rest": np.round(self.rest, 5).tolist(), "aus": table()["aus"],
                "uniforms": {k: (list(v) if isinstance(v, tuple) else v)
                             for k, v in self.uniforms.items()}}

    def weights(self, aus: Mapping[str, float] | None) -> np.ndarray:
        """Each group's depth in cm per side — (28,) as left, right, left, right … — for a
        frame's AU intensities (``AU12``, ``AU12L`` …; others ignored)."""
        amount = np.zeros((len(self.groups), 2))
        face = {c: v for c, v in (aus or {}).items() if c[:2] == "AU" and c[:4] in self._rows}
        for code, (tl, tr) in split_sides(face).items():
            row = self._rows.get(code)
            if row is not None:
                amount += row[:, None] * np.array([tl, tr])[None, :]
        w = (np.clip(amount, 0.0, 1.0) * self.depth[:, None]).ravel()
        return np.maximum(w, self.rest).astype(np.float32)
