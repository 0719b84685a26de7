"""Head geometry: named mesh objects with materials, landmarks and anchor points.

Coordinates are centimetres, y up, +z forward (out of the face, toward the camera), +x toward
the subject's left. Every rig and the renderer work on a :class:`Head`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

#: Object categories of seed 002 Table 4.2: which AUs may move an object; ``body`` (clothes,
#: torso) is moved only by a skeleton, never by face AUs.
CATEGORIES = ("face", "eyes", "teeth", "body")


def frozen_array(a, dtype) -> np.ndarray:
    """A contiguous read-only copy of ``a``."""
    out = np.array(a, dtype=dtype, copy=True, order="C")
    out.setflags(write=False)
    return out


#: how a part's texture alpha is used: ignored, cut out at 0.5, or blended (hair, lashes)
ALPHA_MODES = ("opaque", "mask", "blend")


@dataclass(frozen=True, eq=False)
class Texture:
    """An image painted on a part at its object's UVs: (H, W, 3 or 4) uint8, sRGB colour; row 0
    is the top of the image (v = 1). For skin materials the alpha channel is a gloss map
    (specular scale, 255 = the material's own); for others it is opacity. ``normal``, optional,
    is a detail map at the same UVs: a tangent-space normal (RGB, glTF's convention: +x along
    u, +y along v) and a roughness scale in alpha (0.5 + alpha / 255: 128 is the material's
    own). ``flow``, optional, for hair: the strands' root→tip direction, which the renderer's
    strand highlights follow — red, green: 0.5 + 0.5·(a, b), the direction a·∇u + b·∇v on the
    surface; blue: how well the surface carries it (1: fully)."""

    image: np.ndarray
    name: str = ""
    normal: np.ndarray | None = None
    flow: np.ndarray | None = None

    def __post_init__(self) -> None:
        for which in ("image", "normal", "flow"):
            img = getattr(self, which)
            if img is None:
                continue
            img = np.asarray(img)
            if img.dtype != np.uint8 or img.ndim != 3 or img.shape[2] not in (3, 4):
                raise ValueError(f"texture {self.name!r}: need (H, W, 3|4) uint8 {which}, "
                                 f"got {img.shape} {img.dtype}")
            object.__setattr__(self, which, frozen_array(img, np.uint8))


@dataclass(frozen=True)
class Part:
    """Triangles of one object drawn with one material (and optionally a texture)."""

    material: str  #: key into render/data/materials.json (skin, lips, sclera, iris, pupil, …)
    faces: np.ndarray  #: shape (F, 3), int32 indices into the object's vertices
    texture: Texture | None = None  #: base colour (and alpha); needs the object's UVs
    alpha_mode: str = "opaque"  #: one of :data:`ALPHA_MODES`

    def __post_init__(self) -> None:
        object.__setattr__(self, "faces", frozen_array(self.faces, np.int32).reshape(-1, 3))
        if self.alpha_mode not in ALPHA_MODES:
            raise ValueError(f"alpha_mode {self.alpha_mode!r} must be one of {ALPHA_MODES}")


@dataclass(frozen=True)
class MeshObject:
    """One rigid-topology object of a head (skin, an eyeball, the teeth …)."""

    name: str
    category: str  #: face | eyes | teeth (seed 002 Table 4.2)
    vertices: np.ndarray  #: shape (N, 3), float32, rest positions in cm
    parts: tuple[Part, ...]
    pivot: np.ndarray | None = None  #: rotation centre (eyeball centre for eyes), shape (3,)
    uvs: np.ndarray | None = None  #: shape (N, 2) texture coordinates, optional
    #: (N,) for meshes split at UV seams: the index of the position each vertex was split
    #: from (vertices sharing it get one smooth normal); None when not split
    weld: np.ndarray | None = None
    #: faces are known to wind counter-clockwise seen from outside (the renderer then does
    #: not guess the orientation from the object's centre, which fails for open shapes)
    oriented: bool = False

    def __post_init__(self) -> None:
        if self.category not in CATEGORIES:
            raise ValueError(f"category {self.category!r} must be one of {CATEGORIES}")
        object.__setattr__(self, "vertices", frozen_array(self.vertices, np.float32))
        if self.pivot is not None:
            object.__setattr__(self, "pivot", frozen_array(self.pivot, np.float32))
        if self.uvs is not None:
            object.__setattr__(self, "uvs", frozen_array(self.uvs, np.float32))
        if self.weld is not None:
            object.__setattr__(self, "weld", frozen_array(self.weld, np.int64))

    @property
    def n_vertices(self) -> int:
        return self.vertices.shape[0]

    @property
    def faces(self) -> np.ndarray:
        """All triangles of the object, shape (F, 3)."""
        return np.concatenate([p.faces for p in self.parts]) if self.parts else np.zeros((0, 3))


@dataclass(frozen=True)
class Head:
    """A head: objects plus the points rigs and cameras need.

    ``landmarks`` are the 68 Multi-PIE points as vertex indices into the object named
    ``landmark_object``. ``anchors`` hold named points in cm: ``mouth_corner_L/R``,
    ``neck_pivot`` (head rotation centre), ``chin``, ``neck_base``, ``eye_L``, ``eye_R``.
    """

    name: str
    objects: tuple[MeshObject, ...]
    landmarks: np.ndarray
    anchors: Mapping[str, np.ndarray]
    landmark_object: str = "skin"
    description: str = ""
    meta: dict = field(default_factory=dict, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "landmarks", frozen_array(self.landmarks, np.int64))
        object.__setattr__(
            self, "anchors", {k: frozen_array(v, np.float32) for k, v in self.anchors.items()}
        )
        names = [o.name for o in self.objects]
        if len(set(names)) != len(names):
            raise ValueError(f"object names must be unique: {names}")

    def __getitem__(self, name: str) -> MeshObject:
        for o in self.objects:
            if o.name == name:
                return o
        raise KeyError(name)

    @property
    def rest(self) -> dict[str, np.ndarray]:
        """Rest positions per object name."""
        return {o.name: o.vertices for o in self.objects}

    def landmark_points(self, positions: Mapping[str, np.ndarray] | None = None) -> np.ndarray:
        """The 68 landmarks, shape (68, 3), at ``positions`` (default: rest)."""
        v = (positions or self.rest)[self.landmark_object]
        return np.asarray(v)[self.landmarks]

    @property
    def n_vertices(self) -> int:
        return sum(o.n_vertices for o in self.objects)

    @property
    def n_triangles(self) -> int:
        return sum(len(p.faces) for o in self.objects for p in o.parts)

    def bounds(self, category: str = "face") -> tuple[np.ndarray, np.ndarray]:
        """Axis-aligned bounds (min, max) of the objects in ``category``."""
        pts = np.concatenate([o.vertices for o in self.objects if o.category == category])
        return pts.min(0), pts.max(0)
