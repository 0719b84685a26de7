"""glTF 2.0 / GLB export: the head with one morph target per modelled AU, and its animation.

Layout of the exported scene (units: the head's centimetres scaled to metres)::

    neck (joint, at the anchor neck_base)
     └─ head (joint, at the head-rotation pivot; animated rotation + translation: AU51–58)
         ├─ eye_L (at the eyeball pivot; animated rotation: AU61–64) → mesh eye_L
         └─ eye_R …
    skin, brows, teeth, tongue … (skinned meshes at the root, joints [neck, head])

* every object is a mesh; every part of it a primitive with a PBR material whose base colour
  is the renderer's (``render/data/materials.json``, sRGB → linear), roughness from its
  shininess, metallic 0; a part with alpha < 1 (the cornea) is blended;
* **morph targets**: one per modelled linear AU and per side where the AU is sided
  (``AU12``, ``AU12L``, ``AU12R``): the rig's displacement at τ = 1 (:meth:`Rig.deform` of
  ``{code: 1}`` minus rest), kept on the meshes it moves, as sparse accessors (the vertices
  it moves); names in ``mesh.extras.targetNames``;
  on the eyeball meshes eye AUs are rotations, not morphs;
* **head motion** is a skin: each vertex follows the head joint with the rig's neck fall-off
  weight (1 above the chin, smoothstep to 0 at the neck base) and the neck joint with the rest —
  the linear-blend version of the rig's bending neck;
* **animation** ``mimika``: morph weights and joint / eye rotations sampled from an
  :class:`~mimika.tracks.AUTrack` (LINEAR; quaternions normalised); the scene's and the
  animation's ``extras`` carry ``fps``, ``frame_start`` (0), ``frame_end`` and ``duration_s``
  (glTF keeps seconds only; Blender's importer needs the frame rate set before import);
* **naming for Blender**: Blender's importer turns an animated skinned node into an empty
  (named like the node) plus a mesh object (named like the mesh); such nodes are therefore
  called ``<object>_morphs`` and their meshes ``<object>``, so the mesh objects keep the
  head's object names.

Written with numpy + json (no extra dependency); checked by the Khronos glTF-Validator in the
tests. ``.glb`` is binary; ``.gltf`` embeds its buffer as a base64 data URI.
"""

from __future__ import annotations

import base64
import hashlib
import io
import json
import logging
import os
import struct
import weakref
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

import mimika
from mimika import normals
from mimika.errors import ParameterError
from mimika.facs import AU_CATALOGUE
from mimika.io.atomic import atomic_write
from mimika.tracks import AUTrack

if TYPE_CHECKING:  # io/ does not import face/ at run time: a rig is duck-typed here
    from mimika.face.head import Head, Part
    from mimika.face.rig import Rig

log = logging.getLogger(__name__)

__all__ = ["build_gltf", "rig_motion", "save_gltf", "timing_extras", "write_gltf"]

_FLOAT, _UINT, _USHORT = 5126, 5125, 5123
_ARRAY, _ELEMENTS = 34962, 34963
SCALE = 0.01  #: cm → m
_HEAD_AUS = tuple(c for c, a in AU_CATALOGUE.items() if a.group == "head")
_EYE_AUS = tuple(c for c, a in AU_CATALOGUE.items() if a.group == "eyes")


def _materials() -> dict[str, dict]:
    p = Path(mimika.__file__).parent / "render" / "data" / "materials.json"
    data = json.loads(p.read_text("utf-8"))
    return {k: v for k, v in data.items() if isinstance(v, dict)}


def _srgb_to_linear(hex_color: str) -> list[float]:
    h = hex_color.lstrip("#")
    c = np.array([int(h[i:i + 2], 16) for i in (0, 2, 4)]) / 255.0
    lin = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
    return [round(float(x), 6) for x in lin]


def _normals(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Area-weighted vertex normals (N, 3), unit length (+y where undefined)."""
    n = np.zeros_like(v, dtype=np.float64)
    if len(f):
        tri = v[f].astype(np.float64)
        fn = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        for k in range(3):
            np.add.at(n, f[:, k], fn)
    ln = np.linalg.norm(n, axis=1)
    bad = ln < 1e-12
    n[bad] = (0.0, 1.0, 0.0)
    ln[bad] = 1.0
    return (n / ln[:, None]).astype(np.float32)


def _quat(rv: np.ndarray) -> np.ndarray:
    """Rotation vectors (T, 3) radians → unit quaternions (T, 4) as x, y, z, w."""
    th = np.linalg.norm(rv, axis=1)
    k = rv / np.where(th > 1e-12, th, 1.0)[:, None]
    q = np.concatenate([k * np.sin(th / 2)[:, None], np.cos(th / 2)[:, None]], axis=1)
    return (q / np.linalg.norm(q, axis=1, keepdims=True)).astype(np.float32)


def rig_motion(rig: Rig) -> dict[str, Any]:
    """Rigid motions of ``rig``: per AU a rotation vector (rad) / translation (cm) of the head
    or the eyes, the head pivot (cm) and the per-vertex head weight of each object."""
    head = rig.head
    eye_rot: dict[str, np.ndarray] = {}
    head_rot: dict[str, np.ndarray] = {}
    head_tr: dict[str, np.ndarray] = {}
    pivot = np.asarray(head.anchors.get("neck_pivot", np.zeros(3)), float)
    weights: dict[str, np.ndarray] = {}
    fields = getattr(rig, "fields", None)
    if fields is not None:  # FieldRig
        fall = None
        for code, (rot, _cats) in fields.rotations.items():
            if AU_CATALOGUE[code].group == "eyes" and rot.axis is not None:
                eye_rot[code] = rot.axis * rot.angle
            elif rot.vector is not None:
                head_tr[code] = np.asarray(rot.vector, float)
                fall = fall or rot
            elif rot.axis is not None:
                head_rot[code] = rot.axis * rot.angle
                if not isinstance(rot.pivot, str):
                    pivot = np.asarray(rot.pivot, float)
                fall = fall or rot
        for o in head.objects:
            weights[o.name] = (fall.weight(o.vertices.astype(float)) if fall is not None
                               else np.ones(o.n_vertices)).astype(np.float32)
    else:  # BlendshapeRig (or any rig exposing the same tables)
        eye_rot = dict(getattr(rig, "_eye_rot", {}))
        head_rot = dict(getattr(rig, "_head_rot", {}))
        head_tr = dict(getattr(rig, "_head_tr", {}))
        pivot = np.asarray(getattr(rig, "_neck_pivot", pivot), float)
        w = getattr(rig, "neck_weight", None)
        off = 0
        for o in head.objects:
            weights[o.name] = (np.asarray(w[off:off + o.n_vertices], np.float32)
                               if w is not None else np.ones(o.n_vertices, np.float32))
            off += o.n_vertices
    sup = set(rig.supported)
    return {"eye_rot": {c: v for c, v in eye_rot.items() if c in sup},
            "head_rot": {c: v for c, v in head_rot.items() if c in sup},
            "head_tr": {c: v for c, v in head_tr.items() if c in sup},
            "pivot": pivot, "weights": weights}


#: what exports derive from arrays that cannot change (read-only, owning their data) — a
#: texture's PNG bytes, a morph target's bounds — by (id, what), each dropped with its array:
#: a character's PNGs took 2.0 s and its bounds 0.4 s of every 2.4 s pose export
_DERIVED: dict[tuple[int, str], Any] = {}


def _derived(arr: Any, what: str, compute: Any) -> Any:
    """``compute()``, kept while ``arr`` lives when ``arr`` cannot change."""
    if not (isinstance(arr, np.ndarray) and not arr.flags.writeable and arr.flags.owndata):
        return compute()
    key = (id(arr), what)
    if key not in _DERIVED:
        _DERIVED[key] = compute()
        weakref.finalize(arr, _DERIVED.pop, key, None)
    return _DERIVED[key]


class _Builder:
    def __init__(self) -> None:
        self.bin = bytearray()
        self.views: list[dict] = []
        self.accessors: list[dict] = []

    def add(self, arr: np.ndarray, kind: str, comp: int, *, target: int | None = None,
            minmax: bool = False) -> int:
        a = np.ascontiguousarray(arr)
        while len(self.bin) % 4:
            self.bin.append(0)
        view = {"buffer": 0, "byteOffset": len(self.bin), "byteLength": a.nbytes}
        if target is not None:
            view["target"] = target
        self.bin += a.tobytes()
        self.views.append(view)
        n = a.shape[0]
        acc: dict[str, Any] = {"bufferView": len(self.views) - 1, "componentType": comp,
                               "count": int(n), "type": kind}
        if minmax:
            flat = a.reshape(n, -1)
            acc["min"], acc["max"] = _derived(arr, "bounds", lambda: (
                [float(x) for x in flat.min(0)], [float(x) for x in flat.max(0)]))
            if comp != _FLOAT:
                acc["min"] = [int(x) for x in acc["min"]]
                acc["max"] = [int(x) for x in acc["max"]]
        self.accessors.append(acc)
        return len(self.accessors) - 1

    def add_bytes(self, data: bytes) -> int:
        """A buffer view holding ``data`` (an image); returns its index."""
        while len(self.bin) % 4:
            self.bin.append(0)
        self.views.append({"buffer": 0, "byteOffset": len(self.bin), "byteLength": len(data)})
        self.bin += data
        return len(self.views) - 1

    def add_sparse(self, d: np.ndarray) -> int:
        """A sparse VEC3 float accessor of morph deltas ``d`` (N, 3): only the vertices that
        move are stored (an AU moves a few thousand of a head's or body's vertices: a
        character's GLB 25 → 14 MB); one that moves none is an accessor of zeros with no
        data. The split is kept while a read-only ``d`` lives, as bounds are."""
        flat = np.asarray(d, np.float32).reshape(-1, 3)
        ids, vals, lo, hi = _derived(d, "sparse", lambda: _sparse(flat))
        acc: dict[str, Any] = {"componentType": _FLOAT, "count": len(flat), "type": "VEC3",
                               "min": lo, "max": hi}
        if len(ids):
            acc["sparse"] = {"count": len(ids),
                             "indices": {"bufferView": self.add_bytes(ids.tobytes()),
                                         "componentType": _UINT},
                             "values": {"bufferView": self.add_bytes(vals.tobytes())}}
        self.accessors.append(acc)
        return len(self.accessors) - 1


def _sparse(d: np.ndarray) -> tuple[np.ndarray, np.ndarray, list[float], list[float]]:
    """The moving vertices of deltas ``d`` (N, 3): their indices, deltas and the bounds of
    all N (the vertices left out are 0)."""
    ids = np.flatnonzero(np.abs(d).max(1) > 0).astype(np.uint32)
    vals = np.ascontiguousarray(d[ids])
    if not len(ids):
        return ids, vals, [0.0] * 3, [0.0] * 3
    lo, hi = vals.min(0), vals.max(0)
    if len(ids) < len(d):
        lo, hi = np.minimum(lo, 0), np.maximum(hi, 0)
    return ids, vals, lo.astype(float).tolist(), hi.astype(float).tolist()


_DELTAS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _morph_deltas(rig: Rig, codes: tuple[str, ...]) -> dict[str, list[tuple[str, np.ndarray]]]:
    """Morph target deltas per object — the rig at τ = 1 minus rest, in metres — cached per
    rig (they depend only on the rig), so repeated exports do not recompute them."""
    cache = _DELTAS.setdefault(rig, {})
    if codes not in cache:
        head, rest = rig.head, rig.head.rest
        deltas: dict[str, list[tuple[str, np.ndarray]]] = {o.name: [] for o in head.objects}
        for code in codes:
            pos = rig.deform({code: 1.0})
            for o in head.objects:
                if o.category == "eyes" and code[:4] in _EYE_AUS:
                    continue  # eyeballs turn as nodes
                d = (pos[o.name] - rest[o.name]).astype(np.float32)
                if np.abs(d).max() > 1e-6:
                    d *= SCALE
                    d.setflags(write=False)
                    deltas[o.name].append((code, d))
        cache[codes] = deltas
    return cache[codes]


_SKIN_MATERIALS = ("skin", "lips", "skin_body")
_TWO_SIDED = ("hair", "hair_coily", "brow", "lash", "eyebrow", "eyelash", "cloth", "cornea",
              "mouth", "socket")


def _png(image: np.ndarray, drop_alpha: bool) -> bytes:
    from PIL import Image

    def encode() -> bytes:
        img = np.asarray(image, np.uint8)
        if drop_alpha and img.shape[2] == 4:
            img = img[:, :, :3]
        buf = io.BytesIO()
        Image.fromarray(img).save(buf, format="PNG", optimize=False)
        return buf.getvalue()

    return _derived(image, f"png{int(drop_alpha)}", encode)


def _roughness_image(texture: Any) -> np.ndarray:
    """The glTF metallic-roughness image (RGB8, half the detail map's size) of a texture with
    a detail map: G the roughness relative to the material's, over 2 (:func:`_detail`'s
    factor is twice the material's) — the detail map's scale, × 1.3 where the gloss map is 0
    … 0.8 where it is full; B metallic 0; R the gloss map (mimika's studio viewer reads R and
    G for its own shading; glTF viewers ignore R)."""
    n = np.asarray(texture.normal, np.float32)
    img = np.asarray(texture.image, np.float32)
    gloss = img[:, :, 3] / 255.0 if img.shape[2] == 4 and img.shape[:2] == n.shape[:2] else \
        np.ones(n.shape[:2], np.float32)
    scale = 0.5 + (n[:, :, 3] / 255.0 if n.shape[2] == 4 else 0.5)
    out = np.zeros((*n.shape[:2], 3), np.float32)
    out[:, :, 0], out[:, :, 1] = gloss, np.clip(scale * (1.3 - 0.5 * gloss) / 2.0, 0.01, 1.0)
    h, w = (n.shape[0] // 2) * 2, (n.shape[1] // 2) * 2
    out = out[:h, :w].reshape(h // 2, 2, w // 2, 2, 3).mean((1, 3))
    return np.round(out * 255.0).astype(np.uint8)


class _Materials:
    """glTF materials (+ images, textures) per (material name, texture) of the parts."""

    def __init__(self, b: _Builder) -> None:
        self.b = b
        self.src = _materials()
        self.materials: list[dict] = []
        self.images: list[dict] = []
        self.textures: list[dict] = []
        self._index: dict[tuple, int] = {}
        self._textures: dict[bytes, int] = {}

    def _texture(self, part: Part) -> int:
        """The texture of ``part``'s image."""
        return self._png_texture(_png(part.texture.image, part.material in _SKIN_MATERIALS),
                                 part.texture.name or part.material)

    def _png_texture(self, data: bytes, name: str) -> int:
        """The texture of a PNG, one per image (materials sharing an image share its
        texture: the image is stored once)."""
        key = hashlib.sha1(data).digest()
        if key not in self._textures:
            view = self.b.add_bytes(data)
            self.images.append({"bufferView": view, "mimeType": "image/png", "name": name})
            self.textures.append({"source": len(self.images) - 1, "sampler": 0})
            self._textures[key] = len(self.textures) - 1
        return self._textures[key]

    def _detail(self, part: Part) -> tuple[int, int]:
        """The normal and metallic-roughness textures of ``part``'s detail map (its
        texture's ``normal``)."""
        t = part.texture
        name = t.name or part.material
        normal = self._png_texture(_png(t.normal, True), f"{name}_normal")
        mr = _derived(t.normal, "mr", lambda: _png(_roughness_image(t), False))
        return normal, self._png_texture(mr, f"{name}_roughness")

    @staticmethod
    def textured(part: Part) -> bool:
        """The part needs an image (and UVs): a texture larger than one pixel."""
        return part.texture is not None and part.texture.image.shape[:2] != (1, 1)

    def get(self, part: Part) -> int:
        key = (part.material, id(part.texture), part.alpha_mode)
        if key in self._index:
            return self._index[key]
        m = self.src.get(part.material, self.src.get("_default", {"color": "#9a9a9a"}))
        shin = float(m.get("shininess", 20.0))
        alpha = float(m.get("alpha", 1.0))
        pbr: dict[str, Any] = {"baseColorFactor": [*_srgb_to_linear(m["color"]), alpha],
                               "metallicFactor": 0.0,
                               "roughnessFactor": round(float(np.sqrt(2.0 / (shin + 2.0))), 4)}
        out: dict[str, Any] = {"name": part.material, "pbrMetallicRoughness": pbr}
        if part.texture is not None and not self.textured(part):
            # a flat colour (an untextured glTF material read back): its factor
            px = part.texture.image[0, 0]
            pbr["baseColorFactor"] = [*_srgb_to_linear("#" + bytes(px[:3]).hex()),
                                      round(float(px[3]) / 255.0, 6) if len(px) > 3 else alpha]
        elif part.texture is not None:
            pbr["baseColorTexture"] = {"index": self._texture(part)}
            pbr["baseColorFactor"] = [1.0, 1.0, 1.0, alpha]
            if part.texture.normal is not None:
                normal, mr = self._detail(part)
                out["normalTexture"] = {"index": normal}
                pbr["metallicRoughnessTexture"] = {"index": mr}
                pbr["roughnessFactor"] = min(2.0 * pbr["roughnessFactor"], 1.0)
        if part.alpha_mode == "blend" or alpha < 1.0:
            out["alphaMode"] = "BLEND"
        elif part.alpha_mode == "mask":
            out["alphaMode"], out["alphaCutoff"] = "MASK", 0.5
        if part.material in _TWO_SIDED:
            out["doubleSided"] = True
        self.materials.append(out)
        self._index[key] = len(self.materials) - 1
        return self._index[key]


def _uv_attribute(b: _Builder, uvs: np.ndarray) -> int:
    """A TEXCOORD_0 accessor (glTF's v grows downward, mimika's upward)."""
    uv = np.asarray(uvs, np.float32).copy()
    uv[:, 1] = 1.0 - uv[:, 1]
    return b.add(uv, "VEC2", _FLOAT, target=_ARRAY)


def with_textures(doc: dict, mats: _Materials) -> None:
    """Add ``mats``' images, textures and their one sampler to ``doc`` (when there are any)."""
    if mats.textures:
        doc["images"], doc["textures"] = mats.images, mats.textures
        doc["samplers"] = [{"magFilter": 9729, "minFilter": 9987, "wrapS": 33071,
                            "wrapT": 33071}]


#: per object, further vertex attributes to write: {object: {glTF attribute: (N, k) array}}
#: (``COLOR_0`` shading, application-specific ``_NAME`` data)
Attributes = Mapping[str, Mapping[str, np.ndarray]]


def _tangents(v: np.ndarray, n: np.ndarray, uv: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """glTF tangents (N, 4) of a mesh with a normal map: per vertex the direction of growing u
    made orthogonal to the normal ``n``, and in w the handedness that makes cross(n, tangent) ·
    w run up the image (growing v, mimika's; glTF's t grows down) as the normal map's +y."""
    p, t = np.asarray(v, np.float64)[faces], np.asarray(uv, np.float64)[faces]
    e1, e2 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    d1, d2 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
    det = d1[:, 0] * d2[:, 1] - d2[:, 0] * d1[:, 1]
    det = np.where(np.abs(det) < 1e-12, 1e-12, det)[:, None]
    du = (e1 * d2[:, 1:] - e2 * d1[:, 1:]) / det
    dv = (e2 * d1[:, :1] - e1 * d2[:, :1]) / det
    tu, tv = np.zeros_like(np.asarray(v, np.float64)), np.zeros_like(np.asarray(v, np.float64))
    np.add.at(tu, faces.ravel(), np.repeat(du, 3, axis=0))
    np.add.at(tv, faces.ravel(), np.repeat(dv, 3, axis=0))
    n = np.asarray(n, np.float64)
    tu -= n * np.einsum("ij,ij->i", n, tu)[:, None]
    length = np.linalg.norm(tu, axis=1)
    other = np.cross(n, np.where(np.abs(n[:, :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]]))
    tu = np.where(length[:, None] > 1e-12, tu / np.maximum(length, 1e-12)[:, None],
                  other / np.linalg.norm(other, axis=1, keepdims=True))
    w = np.where(np.einsum("ij,ij->i", np.cross(n, tu), tv) < 0.0, -1.0, 1.0)
    return np.c_[tu, w].astype(np.float32)


def inverse_binds(b: _Builder, joints: np.ndarray) -> int:
    """The accessor of the inverse bind matrices of unrotated joints at ``joints`` (J, 3) cm."""
    ibm = np.tile(np.eye(4, dtype=np.float32), (len(joints), 1, 1))
    ibm[:, 3, :3] = -np.asarray(joints, np.float32) * SCALE  # column-major: translation last
    return b.add(ibm.reshape(len(joints), 16), "MAT4", _FLOAT)


def _object_attributes(b: _Builder, o: Any, uvs: bool, extra: Attributes | None = None
                       ) -> tuple[bool, np.ndarray, dict]:
    """(is an eye, its origin, attributes) of a head object: positions (eyes about their
    centre, which their node carries), normals and, with ``uvs``, texture coordinates (zeros
    when the object has none), and ``extra``'s attributes of the object (float). Joints and
    weights are the caller's."""
    eye = o.category == "eyes" and o.pivot is not None
    origin = np.asarray(o.pivot, float) if eye else np.zeros(3)
    v = ((o.vertices - origin) * SCALE).astype(np.float32)
    nrm = _normals(v, o.faces.astype(np.int64))
    if normals.is_hair(o) and len(o.faces):  # shaded as the renderer shades it
        nrm = normals.smooth(nrm, normals.smoothing(o.vertices, nrm))
    attrs = {"POSITION": b.add(v, "VEC3", _FLOAT, target=_ARRAY, minmax=True),
             "NORMAL": b.add(nrm, "VEC3", _FLOAT, target=_ARRAY)}
    if uvs:
        attrs["TEXCOORD_0"] = _uv_attribute(b, o.uvs if o.uvs is not None else
                                            np.zeros((o.n_vertices, 2)))
    if uvs and o.uvs is not None and any(p.texture is not None and p.texture.normal is not None
                                         for p in o.parts):
        attrs["TANGENT"] = b.add(_tangents(v, nrm, o.uvs, o.faces.astype(np.int64)), "VEC4",
                                 _FLOAT, target=_ARRAY)
    for key, arr in (extra or {}).get(o.name, {}).items():
        a = np.ascontiguousarray(arr, np.float32).reshape(o.n_vertices, -1)
        attrs[key] = b.add(a, f"VEC{a.shape[1]}", _FLOAT, target=_ARRAY)
    return eye, origin, attrs


def _object_mesh(b: _Builder, mats: _Materials, o: Any, attrs: dict, targets: list[dict],
                 names: list[str]) -> dict:
    """The glTF mesh of a head object: one primitive per part, sharing attributes and morph
    targets (named in ``extras.targetNames``)."""
    prims = []
    for part in o.parts:
        idx = part.faces.astype(np.uint32).reshape(-1)
        prim = {"attributes": attrs, "indices": b.add(idx, "SCALAR", _UINT, target=_ELEMENTS,
                                                      minmax=True),
                "material": mats.get(part), "mode": 4}
        if targets:
            prim["targets"] = targets
        prims.append(prim)
    mesh: dict[str, Any] = {"name": o.name, "primitives": prims}
    if targets:
        mesh["weights"] = [0.0] * len(targets)
        mesh["extras"] = {"targetNames": names}
    return mesh


def build_gltf(rig: Rig, track: AUTrack | None = None, *, name: str | None = None,
               attributes: Attributes | None = None) -> tuple[dict, bytes]:
    """The glTF JSON document and its binary buffer for ``rig``'s head (+ ``track``), with
    ``attributes`` added to its objects' vertices."""
    if getattr(rig, "skinning", None) is not None:  # a character with a skeleton
        from mimika.io.gltf_skinned import build_skinned_gltf

        return build_skinned_gltf(rig, track, name=name, attributes=attributes)
    head: Head = rig.head
    b = _Builder()
    mats = _Materials(b)
    motion = rig_motion(rig)
    sup = [c for c in rig.supported if c[:4] not in _HEAD_AUS]

    deltas = _morph_deltas(rig, tuple(sup))

    nodes: list[dict] = [{"name": "neck"}, {"name": "head"}]
    neck_base = np.asarray(head.anchors.get("neck_base", motion["pivot"] - [0, 8, 0]), float)
    pivot = motion["pivot"]
    nodes[0]["translation"] = [float(x) for x in neck_base * SCALE]
    nodes[0]["children"] = [1]
    head_t0 = (pivot - neck_base) * SCALE
    nodes[1]["translation"] = [float(x) for x in head_t0]
    nodes[1]["children"] = []
    skin = {"name": "neck-head", "joints": [0, 1], "skeleton": 0,
            "inverseBindMatrices": inverse_binds(b, np.stack([neck_base, pivot]))}
    meshes: list[dict] = []
    roots = [0]
    morph_nodes: list[tuple[int, list[str]]] = []
    eye_nodes: list[tuple[int, str]] = []
    for o in head.objects:
        if not o.parts:
            continue
        eye, origin, attrs = _object_attributes(b, o, any(mats.textured(p) for p in o.parts),
                                                attributes)
        if not eye:
            w = np.clip(motion["weights"][o.name], 0.0, 1.0)
            # the larger weight first; a joint slot with zero weight holds joint 0
            big = w >= 0.5
            joints = np.zeros((o.n_vertices, 4), np.uint16)
            wts = np.zeros((o.n_vertices, 4), np.float32)
            joints[:, 0] = np.where(big, 1, 0)
            wts[:, 0] = np.where(big, w, 1.0 - w)
            wts[:, 1] = 1.0 - wts[:, 0]
            joints[:, 1] = np.where(wts[:, 1] > 0, np.where(big, 0, 1), 0)
            attrs["JOINTS_0"] = b.add(joints, "VEC4", _USHORT, target=_ARRAY)
            attrs["WEIGHTS_0"] = b.add(wts, "VEC4", _FLOAT, target=_ARRAY)
        targets = [{"POSITION": b.add_sparse(d)} for _, d in deltas[o.name]]
        names = [c for c, _ in deltas[o.name]]
        meshes.append(_object_mesh(b, mats, o, attrs, targets, names))
        node: dict[str, Any] = {"name": o.name, "mesh": len(meshes) - 1}
        nodes.append(node)
        ni = len(nodes) - 1
        if eye:
            node["translation"] = [float(x) for x in (origin - pivot) * SCALE]
            nodes[1]["children"].append(ni)
            eye_nodes.append((ni, o.name))
        else:
            node["skin"] = 0
            roots.append(ni)
        if targets:
            morph_nodes.append((ni, names))
    if not nodes[1]["children"]:
        del nodes[1]["children"]
    animated = track is not None and track.n_frames > 0
    if animated:  # Blender names the empty it leaves after the node, the mesh after the mesh
        for ni, _ in morph_nodes:
            if "skin" in nodes[ni]:
                nodes[ni]["name"] = f"{nodes[ni]['name']}_morphs"

    doc: dict[str, Any] = {
        "asset": {"version": "2.0", "generator": f"mimika {mimika.__version__}"},
        "scene": 0,
        "scenes": [{"name": name or head.name, "nodes": roots}],
        "nodes": nodes, "meshes": meshes, "materials": mats.materials, "skins": [skin],
        "extras": {"units": "metres (head modelled in cm)", "aus": sup},
    }
    with_textures(doc, mats)
    if animated:
        timing = timing_extras(track)
        doc["scenes"][0]["extras"] = timing
        doc["animations"] = [_animation(b, track, morph_nodes, eye_nodes, motion, head_t0)]
        doc["animations"][0]["extras"] = dict(timing)
    doc["accessors"] = b.accessors
    doc["bufferViews"] = b.views
    while len(b.bin) % 4:
        b.bin.append(0)
    doc["buffers"] = [{"byteLength": len(b.bin)}]
    return doc, bytes(b.bin)


def timing_extras(track: AUTrack) -> dict[str, float | int]:
    """Frame rate and range of ``track`` as the glTF ``extras`` mimika writes: keys run from
    frame 0 to ``n_frames - 1`` (the animation ends at ``(n_frames - 1) / fps`` s)."""
    last = max(track.n_frames - 1, 1)
    return {"fps": float(track.fps), "frame_start": 0, "frame_end": last,
            "duration_s": round(last / track.fps, 6)}


class _Animation:
    """Samplers and channels of one glTF animation over a track's frame times (a single
    frame becomes two keys: players need an interval), morph weights included."""

    def __init__(self, b: _Builder, track: AUTrack, morph_nodes,
                 derived: Mapping[str, np.ndarray] | None = None) -> None:
        times = (np.arange(track.n_frames) / track.fps).astype(np.float32)
        cols = np.column_stack([track.values, *(derived or {}).values()])
        if len(times) == 1:
            times = np.array([0.0, 1.0 / track.fps], np.float32)
            cols = np.repeat(cols, 2, axis=0)
        self.n = len(times)
        #: the track's channels and ``derived`` ones (a value per frame, morphs driven by
        #: channels, e.g. the lips' release), per key
        self._col = {c: cols[:, j].astype(np.float64)
                     for j, c in enumerate([*track.channels, *(derived or {})])}
        self._zero = np.zeros(self.n)
        self._b, self._t = b, b.add(times, "SCALAR", _FLOAT, minmax=True)
        self.samplers: list[dict] = []
        self.channels: list[dict] = []
        for node, names in morph_nodes:
            self.add(node, "weights", np.stack([self[n] for n in names], axis=1).reshape(-1),
                     "SCALAR")

    def __getitem__(self, channel: str) -> np.ndarray:
        """The channel's values per key (zeros for a channel the track lacks)."""
        return self._col.get(channel, self._zero)

    def weighted(self, vectors: dict[str, np.ndarray]) -> np.ndarray:
        """Σ channel value × vector over ``vectors`` ({channel: (3,)}), shape (keys, 3)."""
        out = np.zeros((self.n, 3))
        for c, vec in vectors.items():
            out += self[c][:, None] * np.asarray(vec)[None, :]
        return out

    def add(self, node: int, path: str, data: np.ndarray, kind: str) -> None:
        self.samplers.append({"input": self._t, "interpolation": "LINEAR",
                              "output": self._b.add(data.astype(np.float32), kind, _FLOAT)})
        self.channels.append({"sampler": len(self.samplers) - 1,
                              "target": {"node": node, "path": path}})

    def doc(self) -> dict:
        return {"name": "mimika", "samplers": self.samplers, "channels": self.channels}


def _animation(b: _Builder, track: AUTrack, morph_nodes, eye_nodes, motion, head_t0) -> dict:
    anim = _Animation(b, track, morph_nodes)
    eye_rv = anim.weighted(motion["eye_rot"])
    for node, _ in eye_nodes:
        anim.add(node, "rotation", _quat(eye_rv), "VEC4")
    head_rv = anim.weighted(motion["head_rot"])
    head_tr = anim.weighted(motion["head_tr"])
    anim.add(1, "rotation", _quat(head_rv), "VEC4")
    anim.add(1, "translation", head_t0[None, :] + head_tr * SCALE, "VEC3")
    used = set(motion["head_rot"]) | set(motion["head_tr"]) | set(motion["eye_rot"]) | {
        n for _, names in morph_nodes for n in names}
    skipped = [c for c in track.channels if c not in used]
    if skipped:
        log.warning("glTF: the head does not model %s; those channels are not animated",
                    ", ".join(skipped))
    return anim.doc()


def write_gltf(path: str | os.PathLike, rig: Rig, track: AUTrack | None = None, *,
               attributes: Attributes | None = None, extras: Mapping | None = None) -> Path:
    """Write ``rig``'s head (and ``track``'s animation) to ``path`` — ``.glb`` or ``.gltf`` —
    atomically, with ``attributes`` added to its objects' vertices and ``extras`` to the
    document's. Returns the path."""
    p = Path(path)
    ext = p.suffix.lower()
    if ext not in (".glb", ".gltf"):
        raise ParameterError(f"glTF output {str(p)!r} must end in .glb or .gltf")
    doc, binary = build_gltf(rig, track, name=p.stem, attributes=attributes)
    if extras:
        doc["extras"] = {**doc.get("extras", {}), **extras}
    return save_gltf(p, doc, binary)


def save_gltf(path: str | os.PathLike, doc: dict, binary: bytes) -> Path:
    """Write a built glTF document and its buffer to ``path`` (``.glb`` binary, ``.gltf`` with
    the buffer as a base64 data URI), atomically."""
    p = Path(path)
    ext = p.suffix.lower()
    doc["buffers"][0]["byteLength"] = len(binary)
    if ext == ".gltf":
        doc["buffers"][0]["uri"] = ("data:application/octet-stream;base64," +
                                    base64.b64encode(binary).decode("ascii"))
        return atomic_write(p, json.dumps(doc, separators=(",", ":")))
    out = glb_bytes(doc, binary)
    log.info("wrote %s (%d bytes)", p, len(out))
    return atomic_write(p, out)


def glb_bytes(doc: dict, binary: bytes) -> bytes:
    """A built glTF document and its buffer as the bytes of one GLB file."""
    doc["buffers"][0]["byteLength"] = len(binary)
    js = json.dumps(doc, separators=(",", ":")).encode("utf-8")
    js += b" " * (-len(js) % 4)
    total = 12 + 8 + len(js) + 8 + len(binary)
    return b"".join([struct.pack("<III", 0x46546C67, 2, total),
                     struct.pack("<II", len(js), 0x4E4F534A), js,
                     struct.pack("<II", len(binary), 0x004E4942), binary])
