"""The inside of the mouth: which vertices lie in it, and how much light reaches them.

Light enters the oral cavity only through the opening between the lips. A point inside,
D behind the opening, sees the opening (a disc of radius r) in a solid angle whose share of
its sky is about r² / (r² + D²): the front teeth of a wide-open mouth are lit nearly fully,
the molars, the back of the tongue and the throat hardly at all, and everything goes dark as
the lips close. The opening is the ellipse the inner-lip landmarks (60–67) span frame by
frame (r: the radius of a disc of its area); D adds to a point's depth behind it how far the
point lies outside it sideways (the inside of the cheeks, the teeth behind the lips).

Inside = the teeth and tongue (category ``teeth``), and the skin or cavity meshes lying behind
the inner-lip contour between the mouth corners (for the characters, whose mouth is part of
the body mesh, and ICT's mouth socket) — or, where a head's maker marks its mouth's lining
(``head.meta["mouth_lining"]``, 0 … 1 per vertex of its landmark object), that lining: the
characters' cheeks, palate and floor of the mouth reach past those bounds, and seen from
three-quarter the inside of the near cheek stood unlit, black beside the molars. Skin inside
the mouth takes the colour of the oral mucosa in the shaders.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from mimika.face.head import Head

#: the opening's share of a point's sky falls faster than a thin disc's would (r² / (r² + k·D²)):
#: the lips, cheeks and teeth around the opening shade the cavity as well
DEPTH_FALLOFF = 1.5
#: inner-lip landmarks: corners 60, 64; upper 61–63; lower 65–67
_UPPER, _LOWER = [61, 62, 63], [67, 66, 65]


def smoothstep(e0: float, e1: float, x: np.ndarray) -> np.ndarray:
    """0 below ``e0``, 1 above ``e1``, a smooth cubic between."""
    t = np.clip((x - e0) / (e1 - e0), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


class MouthCavity:
    """Inside-the-mouth weights of a head's vertices (at rest) and their visibility through
    the lip opening (per frame). Objects with nothing inside are left out."""

    def __init__(self, head: Head) -> None:
        self.head = head
        lm = head.landmark_points().astype(np.float64)
        inner = lm[60:68]
        self.width = float(np.linalg.norm(lm[64] - lm[60]))
        #: the inner-lip gap of the closed mouth at rest (landmarks 61–63 over 65–67), cm
        self.rest_gap = max(float(np.mean(lm[_UPPER, 1] - lm[_LOWER, 1])), 0.0)
        centre = inner.mean(0)
        contour = lm[[60, 61, 62, 63, 64]]
        order = np.argsort(contour[:, 0])
        self.inside: dict[str, np.ndarray] = {}
        self.ids: dict[str, np.ndarray] = {}
        half = 0.5 * self.width
        for o in head.objects:
            if o.category in ("eyes", "body"):
                continue
            v = o.vertices.astype(np.float64)
            if o.category == "teeth":
                w = np.ones(len(v))
            elif o.name == head.landmark_object and "mouth_lining" in head.meta:
                w = np.asarray(head.meta["mouth_lining"], np.float64)  # its maker knows
            else:
                zc = np.interp(v[:, 0], contour[order, 0], contour[order, 2])
                depth = zc - v[:, 2]  # behind the inner-lip contour, cm (the throat ≈ 6)
                w = (smoothstep(0.05, 0.45, depth) * (1.0 - smoothstep(6.0, 7.5, depth))
                     * (1.0 - smoothstep(0.8 * half, 1.05 * half, np.abs(v[:, 0] - centre[0])))
                     * (1.0 - smoothstep(0.45 * half, 0.75 * half,
                                          np.abs(v[:, 1] - centre[1]))))
            ids = np.flatnonzero(w > 1e-3)
            if len(ids):
                self.ids[o.name] = ids
                self.inside[o.name] = w[ids].astype(np.float32)

    def aperture(self, landmarks: np.ndarray) -> tuple[np.ndarray, np.ndarray, float, float]:
        """The opening for the 68 landmarks (68, 3): centre (3,), axes (3, 3) — across (the
        corners), up, out of the mouth — and half-width and half-gap in cm."""
        lm = np.asarray(landmarks, np.float64)
        across = lm[64] - lm[60]
        width = float(np.linalg.norm(across))
        across /= max(width, 1e-9)
        up = (lm[_UPPER].mean(0) - lm[_LOWER].mean(0))
        gap = max(float(np.linalg.norm(up)) - self.rest_gap, 0.0)
        up -= (up @ across) * across
        up /= max(float(np.linalg.norm(up)), 1e-9)
        out = np.cross(across, up)  # +x left, +y up → +z out of the face
        return lm[60:68].mean(0), np.stack([across, up, out]), 0.5 * width, 0.5 * gap

    def _visibility(self, landmarks: np.ndarray, positions: Mapping[str, np.ndarray]
                    ) -> dict[str, np.ndarray]:
        rest = self.head.rest
        centre, axes, hw, hg = self.aperture(landmarks)
        r2 = hw * hg
        out = {}
        for name, ids in self.ids.items():
            q = (np.asarray(positions.get(name, rest[name]))[ids] - centre) @ axes.T
            depth = np.maximum(-q[:, 2], 0.0)
            rho = np.sqrt((q[:, 0] / max(hw, 1e-3)) ** 2 + (q[:, 1] / max(hg, 1e-3)) ** 2)
            side = 0.5 * np.maximum(rho - 1.0, 0.0) * np.sqrt(r2)
            v = r2 / (r2 + DEPTH_FALLOFF * (depth**2 + side**2) + 1e-9)
            out[name] = (1.0 - self.inside[name] * (1.0 - v)).astype(np.float32)
        return out

    def shade(self, open_cm: float = 1.2) -> dict[str, np.ndarray]:
        """Per object with vertices inside: a fixed visibility (n_inside,) for a mouth open
        ``open_cm`` between the lips — what a file without mimika's renderer (glTF vertex
        colours) can carry: the teeth and tongue darken toward the throat."""
        lm = self.head.landmark_points().astype(np.float64).copy()
        lm[[61, 62, 63], 1] += 0.5 * open_cm
        lm[[65, 66, 67], 1] -= 0.5 * open_cm
        return self._visibility(lm, {})

    def visibility(self, positions: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Per object with vertices inside: (n_inside,) light reaching each of them, 0 … 1
        (1 outside the mouth); ``positions`` are this frame's (rest where missing)."""
        skin = positions.get(self.head.landmark_object,
                             self.head.rest[self.head.landmark_object])
        return self._visibility(np.asarray(skin)[self.head.landmarks], positions)
