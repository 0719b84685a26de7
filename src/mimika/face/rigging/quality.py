"""Checks of generated shapes on a mesh: does an AU tear it, fold it or open its seams?

Measured per AU and side on the face objects' triangles seen from the front at rest (the
inside of a mouth bag or an eye socket folds unseen, in real scans too), UV-seam copies
welded (``bench/bench_rig_quality.py``, tests):

* **stretch** — the longest edge at τ = 1 over its rest length (an edge's length is convex
  in τ, so τ = 1 is its worst); an edge over :data:`TORN` × and :data:`TORN_MM` longer is
  counted as torn;
* **flips** — triangles folded over (facing against the surface around them, so the mesh
  creases onto itself) at τ = ½ or 1, having turned by over 60°, that lay smooth with it at
  rest (within 60°: slivers of a decimated mesh stand on edge and flip at a hair's motion);
  a lip rolling in turns its triangles with it and is no fold;
* **seam gap** — the largest distance (mm) between two copies of one vertex.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from mimika.face.head import MeshObject
from mimika.face.makehuman.artefacts import triangle_normals
from mimika.face.rig import Rig
from mimika.face.rigging.features import depth_behind, welded

__all__ = ["TORN", "TORN_MM", "facing", "measure", "measure_shapes", "triangle_checks"]

#: an edge stretched beyond this many times its length, and by more than TORN_MM, is torn
TORN, TORN_MM = 3.0, 2.0


def facing(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Per triangle, the cosine between its normal and the mean normal at its corners: 1 on
    a smooth surface, below 0 where the mesh folds over onto itself."""
    n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])  # area-weighted
    vn = np.zeros_like(v)
    for k in range(3):
        np.add.at(vn, f[:, k], n)
    around = vn[f].sum(1)
    den = np.linalg.norm(n, axis=1) * np.linalg.norm(around, axis=1)
    return (n * around).sum(1) / np.maximum(den, 1e-30)


def triangle_checks(v: np.ndarray, f: np.ndarray, d: np.ndarray) -> tuple[float, int, int]:
    """(worst edge stretch, torn edges, triangles folded over at τ = ½ or 1 that lay smooth
    with the surface around them at rest) of mesh (v, f) moved by ``d``."""
    e = np.unique(np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), 1), axis=0)
    l0 = np.linalg.norm(v[e[:, 1]] - v[e[:, 0]], axis=1)
    l1 = np.linalg.norm(v[e[:, 1]] + d[e[:, 1]] - v[e[:, 0]] - d[e[:, 0]], axis=1)
    ok = l0 > 1e-4
    ratio = l1[ok] / l0[ok]
    grown = (l1 - l0)[ok] * 10
    n0 = triangle_normals(v, f)
    folds = np.zeros(len(f), bool)
    for t in (0.5, 1.0):
        w = v + t * d
        folds |= (facing(w, f) < 0) & ((triangle_normals(w, f) * n0).sum(1) < 0.5)
    flips = folds & (facing(v, f) > 0.5)
    return (float(ratio.max(initial=1.0)), int(((ratio > TORN) & (grown > TORN_MM)).sum()),
            int(flips.sum()))


def measure(rig: Rig) -> list[dict]:
    """Per AU and side of ``rig`` (its shapes, not the turns): stretch, torn edges, flips
    and seam gap (see the module doc)."""
    from mimika.face.rigging.export import au_shapes

    return measure_shapes(rig.head.objects, au_shapes(rig))


def measure_shapes(objects: Sequence[MeshObject],
                   shapes: Mapping[str, Mapping[str, np.ndarray]]) -> list[dict]:
    """:func:`measure` of ``shapes`` (name → object → deltas, cm) on head ``objects``."""
    meshes = {}
    for o in objects:
        if o.category != "face":
            continue
        labels = o.weld if o.weld is not None else np.arange(o.n_vertices)
        _, first, inv = np.unique(labels, return_index=True, return_inverse=True)
        v, f, _ = welded(o.vertices.astype(float), o.faces.astype(np.int64), first[inv])
        depth, h = depth_behind(v, f)
        f = f[np.all(depth[f] <= 3 * h, axis=1)]
        meshes[o.name] = (v, f, first, first[inv])
    rows = []
    for code, per in shapes.items():
        row = {"au": code, "stretch": 1.0, "torn": 0, "flips": 0, "gap_mm": 0.0}
        for name, d in per.items():
            if name not in meshes:
                continue
            v, f, first, rep = meshes[name]
            s, torn, flips = triangle_checks(v, f, d[first].astype(float))
            row["stretch"] = max(row["stretch"], s)
            row["torn"] += torn
            row["flips"] += flips
            row["gap_mm"] = max(row["gap_mm"], 10 * float(np.abs(d - d[rep]).max()))
        rows.append(row)
    return rows
