"""A head from any face mesh (OBJ) in mimika's frame, for driving with FieldRig fields.

AUs are fields over space (seed 002), so a mesh of a similar face — centimetres, y up, facing
+z, roughly the built-in head's size — deforms without any per-vertex setup. Its landmarks
are the vertices nearest to the built-in head's landmarks; its anchors are the built-in ones.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from mimika.errors import DataError
from mimika.face.head import Head, MeshObject, Part


def head_from_obj(path: str | Path) -> Head:
    """Load ``path`` as a one-object head (category face, material skin)."""
    from mimika.face.heads.builtin import build_builtin_head
    from mimika.io.obj import read_obj

    mesh = read_obj(path)
    if len(mesh.faces) == 0:
        raise DataError(f"{path}: the mesh has no faces")
    ref = build_builtin_head()
    lo, hi = mesh.vertices.min(0), mesh.vertices.max(0)
    rlo, rhi = ref.bounds("face")
    if np.any(hi < rlo) or np.any(lo > rhi) or (hi - lo).max() > 10 * (rhi - rlo).max():
        raise DataError(
            f"{path}: the mesh (bounds {np.round(lo, 1).tolist()} … {np.round(hi, 1).tolist()}) "
            "is not in mimika's head frame: centimetres, y up, face toward +z, centred like "
            f"the built-in head; or rig it: 'mimika rig {path} -o face.glb', then "
            "--head face.glb (any size, orientation and unit)"
        )
    _, lm = cKDTree(mesh.vertices).query(ref.landmark_points())
    skin = MeshObject("skin", "face", mesh.vertices, (Part("skin", mesh.faces),),
                      uvs=mesh.vertex_uvs())
    return Head(Path(path).stem, (skin,), landmarks=lm, anchors=dict(ref.anchors),
                description=f"face mesh from {path}")
