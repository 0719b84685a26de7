"""Perspective cameras framed on a head's face.

Views orbit around the vertical axis through the face centre: ``front`` looks from +z,
``three-quarter`` is turned 35° toward +x (the camera sees the subject's left cheek) and
``profile`` is turned 90° (camera on the +x side).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from mimika.errors import ParameterError
from mimika.face.head import Head

#: The named views, in order.
VIEWS: tuple[str, ...] = ("front", "three-quarter", "profile")

#: Orbit angle (degrees about +y, camera moving toward +x) of each view.
VIEW_ANGLES: Mapping[str, float] = {"front": 0.0, "three-quarter": 35.0, "profile": 90.0}

#: Default vertical field of view, degrees.
FOV_Y = 20.0

#: Share of the image height the face (hairline to chin) fills by default: a portrait with
#: room for the hair and for a dropped jaw — at 0.75 an open mouth (AU26/27) took the chin to
#: the frame's edge, where face detectors (and viewers) lose it.
FILL = 0.6


def check_view(view: str) -> str:
    """Return ``view`` if it names a view, else raise :class:`ParameterError`."""
    if view not in VIEW_ANGLES:
        raise ParameterError(f"unknown view {view!r}; valid views: {', '.join(VIEWS)}")
    return view


def _unit(v: np.ndarray) -> np.ndarray:
    n = float(np.linalg.norm(v))
    if n == 0.0:
        raise ParameterError("camera vectors must not be zero or parallel")
    return v / n


def look_at(eye: np.ndarray, target: np.ndarray, up: np.ndarray) -> np.ndarray:
    """World-to-camera matrix, shape (4, 4), camera looking down its −z axis."""
    eye = np.asarray(eye, np.float64)
    f = _unit(np.asarray(target, np.float64) - eye)
    s = _unit(np.cross(f, np.asarray(up, np.float64)))
    u = np.cross(s, f)
    m = np.eye(4)
    m[0, :3], m[1, :3], m[2, :3] = s, u, -f
    m[:3, 3] = -m[:3, :3] @ eye
    return m


def perspective(fov_y: float, aspect: float, near: float, far: float) -> np.ndarray:
    """OpenGL projection matrix, shape (4, 4); ``fov_y`` in degrees."""
    f = 1.0 / math.tan(math.radians(fov_y) / 2.0)
    m = np.zeros((4, 4))
    m[0, 0] = f / aspect
    m[1, 1] = f
    m[2, 2] = (far + near) / (near - far)
    m[2, 3] = 2.0 * far * near / (near - far)
    m[3, 2] = -1.0
    return m


@dataclass(frozen=True)
class Camera:
    """A pinhole camera. Positions in cm, ``fov_y`` in degrees, ``aspect`` = width / height."""

    eye: np.ndarray  #: shape (3,)
    target: np.ndarray  #: shape (3,)
    up: np.ndarray  #: shape (3,)
    fov_y: float = FOV_Y
    aspect: float = 4.0 / 3.0
    near: float = 10.0
    far: float = 200.0

    @property
    def view_matrix(self) -> np.ndarray:
        """World-to-camera matrix, shape (4, 4)."""
        return look_at(self.eye, self.target, self.up)

    @property
    def projection_matrix(self) -> np.ndarray:
        """Camera-to-clip matrix, shape (4, 4)."""
        return perspective(self.fov_y, self.aspect, self.near, self.far)

    def project(self, points: np.ndarray, size: tuple[int, int]) -> np.ndarray:
        """Pixel coordinates of world ``points`` (N, 3) in an image of ``size`` = (W, H).

        Returns shape (N, 2): x to the right, y down, (0, 0) the top-left pixel corner.
        """
        p = np.asarray(points, np.float64).reshape(-1, 3)
        clip = np.c_[p, np.ones(len(p))] @ (self.projection_matrix @ self.view_matrix).T
        ndc = clip[:, :2] / clip[:, 3:4]
        w, h = size
        return np.c_[(ndc[:, 0] + 1.0) * 0.5 * w, (1.0 - ndc[:, 1]) * 0.5 * h]

    def outline_mask(self, points: np.ndarray, size: tuple[int, int]) -> np.ndarray:
        """(H, W) bool: the pixels inside the polygon world ``points`` (N, 3, in order, e.g.
        the inner-lip landmarks 60–67: the mouth's opening) project to."""
        from PIL import Image, ImageDraw

        mask = Image.new("L", size, 0)
        px = np.round(self.project(points, size)).astype(int)
        ImageDraw.Draw(mask).polygon([tuple(p) for p in px], fill=1)
        return np.asarray(mask, bool)


def face_frame(head: Head, positions: Mapping[str, np.ndarray] | None = None):
    """Face centre (3,), face height and face width in cm, from the 68 landmarks.

    The height runs from the chin to an estimated hairline (half the brow–chin span above
    the brows), so forehead and chin are both inside it.
    """
    lm = np.asarray(head.landmark_points(positions), np.float64)
    lo, hi = lm.min(0), lm.max(0)
    span = hi[1] - lo[1]  # chin (landmark 8) to the top of the brows
    top, bottom = hi[1] + 0.5 * span, lo[1]
    centre = np.array([(lo[0] + hi[0]) / 2.0, (top + bottom) / 2.0, lm[:, 2].mean()])
    return centre, top - bottom, hi[0] - lo[0]


def head_points(head: Head, positions: Mapping[str, np.ndarray] | None = None) -> np.ndarray:
    """The vertices of the head proper (M, 3): those of the landmark object (the skin) at or
    above the chin (landmark 8) — the skull, face, ears, not the neck or a body below."""
    v = np.asarray((positions or head.rest)[head.landmark_object], np.float64)
    chin = float(head.landmark_points(positions)[8, 1])
    return v[v[:, 1] >= chin]


def frame_head(
    head: Head,
    view: str = "front",
    aspect: float = 4.0 / 3.0,
    fov_y: float = FOV_Y,
    fill: float = FILL,
    eye_line: float | None = None,
    head_share: float | None = None,
) -> Camera:
    """A camera on ``view`` whose image the face (hairline to chin) fills by ``fill`` in height.

    ``head_share`` instead sizes the whole head (crown to chin, :func:`head_points`) to that
    share of the image height. ``eye_line`` puts the eyes that fraction of the image height
    from the top (a TV medium close-up: ``head_share`` ≈ 1/3, ``eye_line`` ≈ 1/3); default:
    the face centred. The framing comes from the rest-pose landmarks, so it stays put while a
    face animates.
    """
    angle = math.radians(VIEW_ANGLES[check_view(view)])
    if not 0.05 <= fill <= 1.0:
        raise ParameterError(f"fill={fill} must be in [0.05, 1]")
    centre, height, width = face_frame(head)
    if head_share is not None:
        if not 0.05 <= head_share <= 1.0:
            raise ParameterError(f"head_share={head_share} must be in [0.05, 1]")
        pts = head_points(head)
        height, fill = float(np.ptp(pts[:, 1])), head_share
    visible_h = max(height / fill, width / (0.85 * aspect))
    if eye_line is not None:
        if not 0.05 <= eye_line <= 0.95:
            raise ParameterError(f"eye_line={eye_line} must be in [0.05, 0.95]")
        eyes_y = float(np.asarray(head.landmark_points(), np.float64)[36:48, 1].mean())
        centre = centre.copy()
        centre[1] = eyes_y - (0.5 - eye_line) * visible_h
    dist = visible_h / 2.0 / math.tan(math.radians(fov_y) / 2.0)
    eye = centre + dist * np.array([math.sin(angle), 0.0, math.cos(angle)])
    reach = 1.5 * visible_h  # generous: the back of the head in profile
    return Camera(
        eye=eye,
        target=centre,
        up=np.array([0.0, 1.0, 0.0]),
        fov_y=fov_y,
        aspect=aspect,
        near=max(dist - reach, 0.05 * dist),
        far=dist + reach,
    )
