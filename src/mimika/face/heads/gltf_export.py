"""A glTF avatar's animation in the avatar's own terms, for an export that keeps the file
(:mod:`mimika.io.gltf_avatar`): the AU track becomes

* **the avatar's own morph weights** — each AU's shapes (ARKit, visemes, FACS, VRM
  expression binds) resolved, per side, to the morphs they were read from, so ``jawOpen``,
  ``viseme_aa`` or a VRM ``aa`` bind move as the rig moves them (a one-sided AU on a shape
  the avatar has only whole gives it at the mean of the sides);
* **morph targets only for what it lacks** — the shapes mimika generated from its fields,
  mapped back into each mesh's own space (through the skin's bind matrices) and added under
  their ARKit name, or written into an empty target of that name;
* **its own joints turned** — head AUs on the head bone, eye AUs on the eye bones (or on eye
  mesh nodes about their centre), as local rotations of those nodes.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from mimika.errors import DataError
from mimika.face.heads.gltf_scene import GltfScene
from mimika.face.morphs import arkit_name, classify
from mimika.face.rigging.frame import Frame
from mimika.facs import base_code
from mimika.io.gltf import rig_motion
from mimika.io.gltf_avatar import AvatarExport, MorphTarget
from mimika.io.gltf_source import load_source
from mimika.tracks import AUTrack

log = logging.getLogger(__name__)

__all__ = ["AvatarSource", "Bind", "Links", "avatar_export"]

#: a file morph a shape is made of: (scene mesh index, morph index, factor)
Bind = tuple[int, int, float]
#: shape → object → the file morphs it is made of there
Links = dict[str, dict[str, list[Bind]]]
#: an eye node's origin this close (file units × head scale, cm) to its pivot turns in place
_PIVOT_CM = 1e-3


@dataclass
class AvatarSource:
    """What an export needs of the file a glTF head was read from: the scene, node world
    matrices before any re-posing (``rest_world``), the head frame, per head object its
    scene mesh and vertex indices there (None: all), per shape the file morphs it is made
    of, and the humanoid bones found (head, neck, eye_L, eye_R → node or None)."""

    path: Path
    scene: GltfScene
    rest_world: np.ndarray
    frame: Frame
    pieces: dict[str, tuple[int, np.ndarray | None]]
    links: dict[str, list[Bind]]
    bones: dict[str, int | None]
    stamp: tuple[int, int] = field(init=False)  #: the file's size and mtime when it was read

    def __post_init__(self) -> None:
        self.stamp = self._stamp()

    def _stamp(self) -> tuple[int, int]:
        try:
            st = self.path.stat()
        except OSError:
            return (-1, -1)
        return st.st_size, st.st_mtime_ns

    def check(self) -> None:
        """Refuse a file that changed (or went) since the head was read from it: the export
        writes the file again by the indices read then."""
        if self._stamp() != self.stamp:
            raise DataError(f"{self.path} changed since the head was loaded from it; load "
                            "it again (restart the command or the studio)")


def _side_values(table: Mapping, track: AUTrack) -> tuple[list[tuple[str, str]], np.ndarray]:
    """The rig's shape rows — (AU, side) — and their values per frame (T, rows): the track's
    channels summed per side and clipped to 1, as the rig mixes them."""
    rows: list[tuple[str, str]] = []
    for code, spec in table["aus"].items():
        if spec.get("shapes"):
            rows += [(code, "L"), (code, "R")]
    index = {r: i for i, r in enumerate(rows)}
    sel = np.zeros((len(track.channels), len(rows)))
    for k, c in enumerate(track.channels):
        if c[:2] != "AU" or base_code(c) not in table["aus"]:
            continue
        b = base_code(c)
        side = c[4:] or str(table["aus"][b].get("bilateral_side", "")).upper()
        for s in ("L", "R"):
            if side in ("", s) and (b, s) in index:
                sel[k, index[(b, s)]] = 1.0
    return rows, np.minimum(np.asarray(track.values, float) @ sel, 1.0)


def _shape_weights(table: Mapping, rows: list[tuple[str, str]], x: np.ndarray,
                   names: Sequence[str]) -> np.ndarray:
    """Per frame the weight of each shape in ``names`` (T, shapes) from the row values ``x``:
    a row's shapes resolved per side as the rig does (``_L``/``_R`` shapes on their side,
    a whole shape at half per side)."""
    col = {n: i for i, n in enumerate(names)}
    coef = np.zeros((len(rows), len(names)))
    for r, (code, side) in enumerate(rows):
        for name, w in table["aus"][code]["shapes"].items():
            if name[-2:] in ("_L", "_R"):
                if name[-1] == side and name in col:
                    coef[r, col[name]] += w
            elif f"{name}_{side}" in col:
                coef[r, col[f"{name}_{side}"]] += w
            elif name in col:
                coef[r, col[name]] += 0.5 * w
    return x @ coef


def _rotation(m: np.ndarray) -> np.ndarray:
    """The rotation part (3, 3) of a linear map that may scale."""
    u, _, vt = np.linalg.svd(m)
    r = u @ vt
    return r if np.linalg.det(r) > 0 else u @ np.diag([1.0, 1.0, -1.0]) @ vt


def _trs(node: Mapping[str, Any]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A glTF node's translation, rotation (x, y, z, w) and scale (from its matrix if it has
    one)."""
    if "matrix" in node:
        m = np.asarray(node["matrix"], float).reshape(4, 4).T
        s = np.linalg.norm(m[:3, :3], axis=0)
        r = m[:3, :3] / np.where(s > 0, s, 1.0)
        if np.linalg.det(r) < 0:
            s[0], r[:, 0] = -s[0], -r[:, 0]
        return m[:3, 3], Rotation.from_matrix(_rotation(r)).as_quat(), s
    return (np.asarray(node.get("translation", [0.0, 0.0, 0.0]), float),
            np.asarray(node.get("rotation", [0.0, 0.0, 0.0, 1.0]), float),
            np.asarray(node.get("scale", [1.0, 1.0, 1.0]), float))


class _Turns:
    """Local rotations (and translations) of file nodes for rotations given in the head
    frame about a pivot: the head frame's axes carried into each node's parent space."""

    def __init__(self, src: AvatarSource, nodes: list[dict[str, Any]], ex: AvatarExport
                 ) -> None:
        self.src, self.nodes, self.ex = src, nodes, ex
        self.axes = src.frame.rotation  # head frame = scale · axes @ file world

    def parent(self, node: int) -> np.ndarray:
        p = int(self.src.scene.node_parent[node])
        return self.src.rest_world[p] if p >= 0 else np.eye(4)

    def turn(self, node: int, rv: np.ndarray, pivot: np.ndarray | None = None,
             shift_cm: np.ndarray | None = None) -> None:
        """Animate ``node``: head-frame rotation vectors ``rv`` (T, 3) about ``pivot`` (file
        world; None: the node's own origin) and head-frame translations ``shift_cm``."""
        t0, q0, s0 = _trs(self.nodes[node])
        if "matrix" in self.nodes[node]:
            self.ex.trs[node] = ([float(v) for v in t0], [float(v) for v in q0],
                                 [float(v) for v in s0])
        par = self.parent(node)
        p_rot = _rotation(par[:3, :3])
        r_head = Rotation.from_rotvec(rv).as_matrix()  # (T, 3, 3)
        r_world = self.axes.T @ r_head @ self.axes
        r_local = p_rot.T @ r_world @ p_rot @ Rotation.from_quat(q0).as_matrix()
        self.ex.rotations[node] = Rotation.from_matrix(r_local).as_quat().astype(np.float32)
        inv = np.linalg.inv(par)
        origin = self.src.rest_world[node, :3, 3]
        t = np.tile(t0, (len(rv), 1))
        if pivot is not None and np.linalg.norm(origin - pivot) * self.src.frame.scale \
                > _PIVOT_CM:
            moved = pivot + np.einsum("tij,j->ti", r_world, origin - pivot)
            t = moved @ inv[:3, :3].T + inv[:3, 3]
        if shift_cm is not None and np.any(shift_cm):
            t = t + (shift_cm @ self.axes / self.src.frame.scale) @ inv[:3, :3].T
        if not np.allclose(t, t0):
            self.ex.translations[node] = t.astype(np.float32)


def _eye_nodes(src: AvatarSource, head: Any) -> tuple[dict[int, np.ndarray], list[str]]:
    """The nodes that turn the eye objects, with the pivot (file world) each turns about:
    the eye bone holding the object, else the object's own mesh node when it is unskinned
    and whole; and the eye objects no node turns."""
    scale, frame = src.frame.scale, src.frame
    out: dict[int, np.ndarray] = {}
    stuck = []
    for o in head.objects:
        if o.category != "eyes" or o.pivot is None:
            continue
        pivot_file = (np.asarray(o.pivot, float) - frame.translation) @ frame.rotation / scale
        bone = next((b for b in (src.bones.get("eye_L"), src.bones.get("eye_R"))
                     if b is not None and np.linalg.norm(
                         frame.apply(src.rest_world[b, :3, 3]) - o.pivot) < 1e-3), None)
        si, idx = src.pieces[o.name]
        sm = src.scene.meshes[si]
        if bone is not None:
            out[bone] = src.rest_world[bone, :3, 3]
        elif idx is None and sm.bind is None:
            out[sm.node] = pivot_file
        else:
            stuck.append(o.name)
    return out, stuck


def _to_mesh_space(src: AvatarSource, si: int, ids: np.ndarray, d_world: np.ndarray
                   ) -> np.ndarray:
    """Deltas ``d_world`` (file world) of scene mesh ``si``'s vertices ``ids`` in the mesh's
    own space: through each vertex's skinning matrix at rest, else its node's matrix."""
    sm = src.scene.meshes[si]
    if sm.bind is not None:
        lin = sm.bind.subset(ids).matrices(src.rest_world)[:, :3, :3]
        return np.linalg.solve(lin, d_world[..., None])[..., 0]
    return d_world @ np.linalg.inv(src.rest_world[sm.node, :3, :3]).T


def _empty_target(src: AvatarSource, si: int, name: str) -> int | None:
    """The index of a morph of scene mesh ``si`` that stands for shape ``name`` and moves
    nothing (its slot can take the generated shape), or None."""
    sm = src.scene.meshes[si]
    for k, raw in enumerate(sm.morph_names):
        mt = classify(raw)
        if (raw == name or (mt is not None and mt.name == name)) and not np.any(
                sm.morph_deltas[k]):
            return k
    return None


def _generated_targets(src: AvatarSource, generated: Mapping, doc: dict[str, Any]
                       ) -> tuple[list[MorphTarget], dict[int, dict[str, int]]]:
    """Morph targets for the shapes mimika generated, per glTF mesh they move, and per glTF
    mesh the target index of each shape."""
    frame = src.frame
    full: dict[tuple[int, str], np.ndarray] = {}  # (scene mesh, shape) → (N, 3) mesh space
    for name, per in generated.items():
        for obj, (idx, vals) in per.items():
            si, index = src.pieces[obj]
            ids = np.asarray(idx if index is None else index[idx], np.int64)
            d_world = np.asarray(vals, float) @ frame.rotation / frame.scale
            n = len(src.scene.meshes[si].vertices)
            arr = full.setdefault((si, name), np.zeros((n, 3), np.float32))
            cur = arr[ids]  # a vertex two pieces share takes the first one's delta
            arr[ids] = np.where(np.any(cur != 0, axis=1, keepdims=True), cur,
                                _to_mesh_space(src, si, ids, d_world))
    targets: list[MorphTarget] = []
    slots: dict[int, dict[str, int]] = {}
    for (si, name), arr in full.items():
        sm = src.scene.meshes[si]
        mi = doc["nodes"][sm.node]["mesh"]
        if name in slots.get(mi, {}):
            continue  # another instance of the same mesh wrote it
        n_old = len(doc["meshes"][mi]["primitives"][0].get("targets", []))
        own = set(sm.morph_names)
        out_name = arkit_name(name) or name
        k = _empty_target(src, si, name)
        if k is None and out_name in own:
            out_name = f"{out_name}.mimika"
        deltas = {pi: arr[a:a + c] for pi, (a, c) in sm.ranges.items()}
        targets.append(MorphTarget(mi, out_name, deltas, k))
        if k is None:
            k = n_old + sum(1 for t in targets[:-1] if t.mesh == mi and t.replaces is None)
        slots.setdefault(mi, {})[name] = k
    return targets, slots


def avatar_export(rig: Any, track: AUTrack | None) -> AvatarExport | None:
    """The additions that animate ``rig``'s avatar file by ``track`` in its own terms, or
    None when the rig's head was not read from a glTF file."""
    src = rig.head.meta.get("gltf")
    if not isinstance(src, AvatarSource):
        return None
    src.check()
    doc = load_source(src.path).doc
    nodes = doc.get("nodes", [])
    ex = AvatarExport(src.path)
    generated = getattr(rig, "generated", {})
    ex.targets, slots = _generated_targets(src, generated, doc)
    own = sorted(n for n, b in src.links.items() if b)

    def listed(filled: bool) -> list[str]:
        return sorted({f"{doc['meshes'][t.mesh].get('name', t.mesh)}/{t.name}"
                       for t in ex.targets if (t.replaces is not None) == filled})

    ex.extras = {"aus": list(rig.supported), "own_morphs": own,
                 "added_morphs": listed(False), "filled_morphs": listed(True)}
    if track is None or not track.n_frames:
        return ex
    rows, x = _side_values(rig.table, track)
    names = [*own, *generated]
    sw = _shape_weights(rig.table, rows, x, names)
    col = {n: i for i, n in enumerate(names)}
    # morph weights per node: its mesh's targets, the driven ones from the shape weights
    drive: dict[int, dict[int, np.ndarray]] = {}
    for name in own:
        for si, k, f in dict.fromkeys(src.links[name]):
            node = src.scene.meshes[si].node
            d = drive.setdefault(node, {})
            d[k] = d.get(k, 0.0) + f * sw[:, col[name]]
    for node in {sm.node for sm in src.scene.meshes}:
        for name, k in slots.get(nodes[node]["mesh"], {}).items():
            drive.setdefault(node, {})[k] = sw[:, col[name]]
    n_new = {}
    for t in ex.targets:
        if t.replaces is None:
            n_new[t.mesh] = n_new.get(t.mesh, 0) + 1
    for node, ks in drive.items():
        mesh = doc["meshes"][nodes[node]["mesh"]]
        n = len(mesh["primitives"][0].get("targets", [])) + n_new.get(nodes[node]["mesh"], 0)
        base = list(mesh.get("weights", []))
        w = np.tile(np.asarray(base + [0.0] * (n - len(base)), float), (track.n_frames, 1))
        for k, v in ks.items():
            w[:, k] = v
        ex.weights[node] = w.astype(np.float32)
    _turn_joints(rig, src, track, nodes, ex)
    return ex


def _turn_joints(rig: Any, src: AvatarSource, track: AUTrack, nodes: list[dict[str, Any]],
                 ex: AvatarExport) -> None:
    """Head AUs on the head bone, eye AUs on the eye nodes (see :func:`_eye_nodes`)."""
    motion = rig_motion(rig)
    vals = np.asarray(track.values, float)

    def summed(table: Mapping[str, np.ndarray]) -> np.ndarray:
        out = np.zeros((track.n_frames, 3))
        for k, c in enumerate(track.channels):
            v = table.get(base_code(c)) if c[:2] == "AU" else None
            if v is not None:
                out += vals[:, k, None] * np.asarray(v, float)[None]
        return out

    turns = _Turns(src, nodes, ex)
    head_rv, head_tr = summed(motion["head_rot"]), summed(motion["head_tr"])
    used = {c for c in track.channels if c[:2] == "AU" and rig.table["aus"].get(
        base_code(c), {}).get("shapes")}
    if (np.any(head_rv) or np.any(head_tr)) and src.bones.get("head") is None:
        log.warning("glTF: %s has no head bone; head turns are not animated", src.path.name)
    elif np.any(head_rv) or np.any(head_tr):
        turns.turn(src.bones["head"], head_rv, shift_cm=head_tr)
        used |= {c for c in track.channels if base_code(c) in motion["head_rot"]
                 or base_code(c) in motion["head_tr"]}
    eye_rv = summed(motion["eye_rot"])
    if np.any(eye_rv):
        eyes, stuck = _eye_nodes(src, rig.head)
        for node, pivot in eyes.items():
            turns.turn(node, eye_rv, pivot)
        if stuck:
            log.warning("glTF: %s: no bone or node turns %s; the eyes do not turn in the "
                        "export", src.path.name, ", ".join(stuck))
        if eyes:
            used |= {c for c in track.channels if base_code(c) in motion["eye_rot"]}
    skipped = [c for c in track.channels if c not in used]
    if skipped:
        log.warning("glTF: %s are not animated in the export", ", ".join(skipped))
