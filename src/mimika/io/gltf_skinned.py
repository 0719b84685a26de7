"""glTF 2.0 export of a skinned character (:class:`~mimika.face.rigs.skinned.SkinnedRig`):
the whole person — meshes with their textures, the skeleton, AU morph targets, animation.

Layout (metres; the character is modelled in cm)::

    root → spine05 → … → neck01 → neck02 → neck03 → head ─┬─ eye_L (rigid, AU61–64)
                     └→ clavicle.L → shoulder01.L → …    └─ eye_R
    skin, hair, brows, lashes, teeth, tongue, clothes (skinned to every joint)

* joints sit at their bind positions with identity orientation, so a joint's local rotation
  is the rig's rotation about the bone's head in world axes; the rest pose (arms lowered) is
  the joints' default rotation, vertices are in bind space;
* morph targets: the rig's shape offsets per modelled AU (and L/R side) in bind space —
  morphs apply before skinning in glTF, as in the rig; names in ``mesh.extras.targetNames``;
  ``lips_release`` undoes the rest pose's lip seal, weighted by the AUs that part the lips
  (``extras.rig.release`` says how; the animation carries its weights);
* materials carry the painted textures (PNG, sRGB) with ``alphaMode`` BLEND for hair and
  lashes, MASK for cut-outs; skin textures drop their alpha (a gloss map for mimika's shader);
* animation ``mimika``: morph weights, joint rotations (head AUs shared over neck and head,
  body channels, rest pose) and eye rotations, sampled from an AUTrack.
"""

from __future__ import annotations

import weakref
from typing import Any

import numpy as np

import mimika
from mimika.facs import AU_CATALOGUE
from mimika.io.gltf import (
    _ARRAY,
    _FLOAT,
    _USHORT,
    SCALE,
    _Animation,
    _Builder,
    _Materials,
    _object_attributes,
    _object_mesh,
    _quat,
    inverse_binds,
    timing_extras,
    with_textures,
)
from mimika.tracks import AUTrack


def _morph_codes(rig: Any) -> list[str]:
    """AUs (and sides) with shape offsets: the morph targets, in catalogue order."""
    return [c for c in rig.supported if c in AU_CATALOGUE or c[:4] in AU_CATALOGUE
            if AU_CATALOGUE[c[:4]].group != "head" and rig.shape_deltas(c)]


_TARGETS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
#: the morph of the rig's ``release`` (lips held together at rest, parted by AU09/10/16/25–27):
#: its weight follows those AUs (``extras.rig.release``), animated like the AUs' own
RELEASE = "lips_release"


def _targets(rig: Any) -> tuple[list[str], dict[str, list[tuple[str, np.ndarray]]]]:
    """The morph AUs and the targets per object — (AU, read-only delta in metres), empty ones
    left out — cached per rig: they depend on it only, and read-only arrays keep their bounds
    too (:func:`mimika.io.gltf._derived`), so a pose export does not recompute either."""
    if rig not in _TARGETS:
        codes = _morph_codes(rig)
        deltas = {c: rig.shape_deltas(c) for c in codes}
        if rig.release:
            deltas[RELEASE] = rig.release_deltas()
        out: dict[str, list[tuple[str, np.ndarray]]] = {}
        for o in rig.bind_head.objects:
            out[o.name] = []
            for c in deltas:
                d = deltas[c].get(o.name)
                if d is None or np.abs(d).max() <= 1e-6:
                    continue
                t = (d * SCALE).astype(np.float32)
                t.setflags(write=False)
                out[o.name].append((c, t))
        _TARGETS[rig] = codes, out
    return _TARGETS[rig]


def build_skinned_gltf(rig: Any, track: AUTrack | None = None, *, name: str | None = None,
                       attributes: Any = None) -> tuple[dict, bytes]:
    """The glTF document and binary buffer of a skinned character (+ ``track``)."""
    sk = rig.skinning
    bind = rig.bind_head
    b = _Builder()
    mats = _Materials(b)
    nb = len(sk.names)
    heads = np.asarray(sk.heads, float)
    rest = {sk.names.index(k): np.asarray(v, float) for k, v in sk.rest_pose.items()}

    nodes: list[dict] = []
    for i, bone in enumerate(sk.names):
        p = sk.parents[i]
        t = heads[i] - (heads[p] if p >= 0 else 0.0)
        node: dict[str, Any] = {"name": bone, "translation": [float(x) for x in t * SCALE]}
        if i in rest:
            node["rotation"] = [float(x) for x in _quat(rest[i][None])[0]]
        nodes.append(node)
    for i in range(nb):
        kids = [j for j in range(nb) if sk.parents[j] == i]
        if kids:
            nodes[i]["children"] = kids
    skin = {"name": "skeleton", "joints": list(range(nb)), "skeleton": 0,
            "inverseBindMatrices": inverse_binds(b, heads)}

    codes, morphs = _targets(rig)
    head_j = sk.names.index("head")
    meshes: list[dict] = []
    roots = [0]
    morph_nodes: list[tuple[int, list[str]]] = []
    eye_nodes: list[tuple[int, str]] = []
    for o in bind.objects:
        if not o.parts:
            continue
        eye, origin, attrs = _object_attributes(b, o, o.uvs is not None, attributes)
        if not eye:
            joints, wts = _top4(sk.weights[o.name])
            attrs["JOINTS_0"] = b.add(joints, "VEC4", _USHORT, target=_ARRAY)
            attrs["WEIGHTS_0"] = b.add(wts, "VEC4", _FLOAT, target=_ARRAY)
        names, targets = [], []
        for c, d in [] if eye else morphs.get(o.name, []):
            names.append(c)
            targets.append({"POSITION": b.add_sparse(d)})
        meshes.append(_object_mesh(b, mats, o, attrs, targets, names))
        node = {"name": o.name, "mesh": len(meshes) - 1}
        nodes.append(node)
        ni = len(nodes) - 1
        if eye:
            node["translation"] = [float(x) for x in (origin - heads[head_j]) * SCALE]
            nodes[head_j].setdefault("children", []).append(ni)
            eye_nodes.append((ni, o.name))
        else:
            node["skin"] = 0
            roots.append(ni)
        if targets:
            morph_nodes.append((ni, names))

    doc: dict[str, Any] = {
        "asset": {"version": "2.0", "generator": f"mimika {mimika.__version__}"},
        "scene": 0,
        "scenes": [{"name": name or rig.head.name, "nodes": roots}],
        "nodes": nodes, "meshes": meshes, "materials": mats.materials, "skins": [skin],
        "extras": {"units": "metres (character modelled in cm)", "aus": codes,
                   "character": rig.head.meta.get("character", rig.head.name),
                   "rig": rig_description(rig)},
    }
    with_textures(doc, mats)
    if track is not None and track.n_frames:
        # Blender turns an animated skinned node into an empty named like the node plus a
        # mesh object named like the mesh: name the node apart so the mesh keeps its name
        for ni, _ in morph_nodes:
            if "skin" in nodes[ni]:
                nodes[ni]["name"] = f"{nodes[ni]['name']}_morphs"
        timing = timing_extras(track)
        doc["scenes"][0]["extras"] = timing
        doc["animations"] = [_animation(b, rig, track, morph_nodes, eye_nodes)]
        doc["animations"][0]["extras"] = dict(timing)
    doc["accessors"] = b.accessors
    doc["bufferViews"] = b.views
    while len(b.bin) % 4:
        b.bin.append(0)
    doc["buffers"] = [{"byteLength": len(b.bin)}]
    return doc, bytes(b.bin)


def rig_description(rig: Any) -> dict[str, Any]:
    """How AU values move the joints, for players that drive the skeleton themselves (the
    studio): each joint's local rotation (rotation vector, rad, world axes at bind) is
    ``rest[joint] + share[joint] · Σ value·head_rot[AU] + Σ value·body[channel][joint]``;
    eyes turn by ``Σ value·eye_rot[AU]``; ``head_translate_m[AU]`` moves ``translate_joint``."""
    sk = rig.skinning

    def r(v: Any) -> list[float]:
        return [round(float(x), 6) for x in np.asarray(v, float)]

    release = {} if not rig.release else {"release": {
        "target": RELEASE, "by": list(rig.release[0]), "full_at": rig.release[1],
        "weight": "smoothstep(largest value of 'by' (either side) / full_at)"}}
    return {
        **release,
        "rest": {k: r(v) for k, v in sk.rest_pose.items()},
        "head_share": {k: float(v) for k, v in sk.head_share.items()},
        "head_rot": {c: r(v) for c, v in rig._head_rot.items()},
        "head_translate_m": {c: r(np.asarray(v) * SCALE) for c, v in rig._head_tr.items()},
        "translate_joint": sk.translate_bone,
        "eye_rot": {c: r(v) for c, v in rig._eye_rot.items()},
        "body": {c: {b: r(v) for b, v in bones.items()} for c, bones in sk.body.items()},
    }


def _top4(w: Any) -> tuple[np.ndarray, np.ndarray]:
    """Joint indices (N, 4) uint16 and weights (N, 4) summing to 1 from a (N, B) matrix: the
    four largest influences per vertex."""
    dense = np.asarray(w.todense() if hasattr(w, "todense") else w, np.float64)
    order = np.argsort(-dense, axis=1)[:, :4]
    wt = np.take_along_axis(dense, order, axis=1)
    wt = np.where(wt > 1e-6, wt, 0.0)
    s = wt.sum(1, keepdims=True)
    wt = np.where(s > 0, wt / np.where(s > 0, s, 1), [[1.0, 0, 0, 0]])
    joints = np.where(wt > 0, order, 0).astype(np.uint16)
    return joints, wt.astype(np.float32)


def _animation(b: _Builder, rig: Any, track: AUTrack, morph_nodes, eye_nodes) -> dict:
    sk = rig.skinning
    derived = {RELEASE: rig.release_weights(track.values, track.channels)} if rig.release \
        else None
    anim = _Animation(b, track, morph_nodes, derived)
    eye_rv = anim.weighted(rig._eye_rot)
    head_rv = anim.weighted(rig._head_rot)
    head_tr = anim.weighted(rig._head_tr)
    for node, _ in eye_nodes:
        anim.add(node, "rotation", _quat(eye_rv), "VEC4")
    body = np.stack([anim[c] for c in rig.body_channels], 1) if rig.body_channels \
        else np.zeros((anim.n, 0))
    local = rig.local_rotations(head_rv, body)  # (T, B, 3)
    for i in range(len(sk.names)):
        if np.ptp(local[:, i], axis=0).max() > 1e-7:
            anim.add(i, "rotation", _quat(local[:, i]), "VEC4")
    if np.any(head_tr):
        i = sk.names.index(sk.translate_bone)
        p = sk.parents[i]
        t0 = (np.asarray(sk.heads[i]) - np.asarray(sk.heads[p])) * SCALE
        anim.add(i, "translation", t0[None] + head_tr * SCALE, "VEC3")
    return anim.doc()
