"""Sample inputs for ``mimika rig``, made from heads the project ships: a head's objects
written as the bare files users bring — an OBJ (one mesh, positions shared, texture
coordinates per corner, a ``usemtl`` group per material) and a GLB (a mesh per object, cut at
its UV seams as glTF needs), optionally moved and turned as a character stands in a scene —
and other topologies of a mesh (decimated; remeshed: subdivided, then decimated). For tests
and benches (``bench/bench_rig_quality.py``, ``bench/avatar_accuracy.py``)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from mimika.face.head import Head
from mimika.face.rigging.export import BareMesh, write_bare_glb, write_obj
from mimika.face.rigging.features import welded

__all__ = ["decimated", "ict_game_head", "remeshed", "write_samples"]


def _rotation(yaw_deg: float, pitch_deg: float) -> np.ndarray:
    a, b = np.radians(yaw_deg), np.radians(pitch_deg)
    ry = np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]])
    rx = np.array([[1, 0, 0], [0, np.cos(b), -np.sin(b)], [0, np.sin(b), np.cos(b)]])
    return ry @ rx


def write_samples(head: Head, folder: str | Path, stem: str, objects: Sequence[str] = ("skin",),
                  *, offset_m: Sequence[float] = (0.0, 0.0, 0.0), yaw_deg: float = 0.0,
                  pitch_deg: float = 0.0) -> dict[str, Path]:
    """``<stem>.obj`` and ``<stem>.glb`` of ``head``'s ``objects`` in ``folder``, in metres,
    turned by ``yaw_deg`` (about y) and ``pitch_deg`` (about x) and moved by ``offset_m``.
    Returns {"obj": path, "glb": path}."""
    folder = Path(folder)
    r = _rotation(yaw_deg, pitch_deg)
    meshes, vs, fs, uvs, fuvs, groups = [], [], [], [], [], []
    nv = nt = 0
    for name in objects:
        o = head[name]
        v = (o.vertices.astype(float) * 0.01) @ r.T + np.asarray(offset_m, float)
        f = o.faces.astype(np.int64)
        uv = o.uvs if o.uvs is not None else np.zeros((o.n_vertices, 2))
        meshes.append(BareMesh(name, v, [(p.material, p.faces) for p in o.parts],
                               np.c_[uv[:, 0], 1.0 - uv[:, 1]]))
        wv, wf, _ = welded(v, f, None if o.weld is None else _first(o.weld))
        vs.append(wv)
        fs.append(wf + nv)
        uvs.append(uv)
        fuvs.append(f + nt)
        groups += [(p.material, len(p.faces)) for p in o.parts]
        nv, nt = nv + len(wv), nt + len(uv)
    out = {"glb": write_bare_glb(folder / f"{stem}.glb", meshes)}
    out["obj"] = write_obj(folder / f"{stem}.obj", np.concatenate(vs), np.concatenate(fs),
                           np.concatenate(uvs), np.concatenate(fuvs), groups)
    return out


def ict_game_head(folder: str | Path, stem: str = "ict_game") -> dict[str, Path]:
    """The ICT Face Model's head made the way a game head is (needs ``$MIMIKA_ICT_DIR``):
    face, mouth bag and eye sockets one mesh, eyeballs and teeth their own — as a GLB (each
    mesh cut at its UV seams) and an OBJ (one mesh, positions shared), in metres."""
    from mimika.face.heads.ict import find_ict_dir
    from mimika.io.obj import read_obj

    m = read_obj(find_ict_dir() / "generic_neutral_mesh.obj")
    folder = Path(folder)
    meshes, fs, fuvs, groups = [], [], [], []
    for name, lo, hi in (("head", 0, 14062), ("teeth", 17039, 21451), ("eyeL", 21451, 23021),
                         ("eyeR", 23021, 24591)):
        keep = np.all((m.faces >= lo) & (m.faces < hi), axis=1)
        f, fuv = m.faces[keep].astype(np.int64), m.face_uvs[keep].astype(np.int64)
        pairs, inv = np.unique(np.c_[f.reshape(-1), fuv.reshape(-1)], axis=0,
                               return_inverse=True)
        uv = m.uvs[pairs[:, 1]]
        meshes.append(BareMesh(name, m.vertices[pairs[:, 0]] * 0.01,
                               [(name, inv.reshape(-1, 3))], np.c_[uv[:, 0], 1 - uv[:, 1]]))
        fs.append(f)
        fuvs.append(fuv)
        groups.append((name, len(f)))
    return {"glb": write_bare_glb(folder / f"{stem}.glb", meshes),
            "obj": write_obj(folder / f"{stem}.obj", m.vertices * 0.01, np.concatenate(fs),
                             m.uvs, np.concatenate(fuvs), groups)}


def _first(labels: np.ndarray) -> np.ndarray:
    """Per vertex, the first vertex with its weld label."""
    _, first, inverse = np.unique(labels, return_index=True, return_inverse=True)
    return first[inverse]


def decimated(v: np.ndarray, f: np.ndarray, keep: float) -> tuple[np.ndarray, np.ndarray]:
    """(v, f) simplified to about ``keep`` of its vertices by fast-simplification's
    quadric edge collapse (another topology)."""
    import fast_simplification

    vd, fd = fast_simplification.simplify(np.asarray(v, np.float32), np.asarray(f, np.int32),
                                          target_reduction=1.0 - keep)
    return vd.astype(float), fd.astype(np.int64)


def remeshed(v: np.ndarray, f: np.ndarray, keep: float = 0.6) -> tuple[np.ndarray, np.ndarray]:
    """(v, f) remeshed: every triangle split in four at its edge midpoints, then decimated
    to about ``keep`` of the original vertex count — no vertex or edge of the original
    left where it was, triangles of even size."""
    v = np.asarray(v, float)
    f = np.asarray(f, np.int64)
    e = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    uniq, inv = np.unique(e, axis=0, return_inverse=True)
    mid = len(v) + inv.reshape(3, -1).T  # per triangle: midpoints of edges 01, 12, 20
    v2 = np.concatenate([v, 0.5 * (v[uniq[:, 0]] + v[uniq[:, 1]])])
    a, b, c = f.T
    ab, bc, ca = mid.T
    f2 = np.concatenate([np.c_[a, ab, ca], np.c_[ab, b, bc], np.c_[ca, bc, c], np.c_[ab, bc, ca]])
    return decimated(v2, f2, keep * len(v) / len(v2))
