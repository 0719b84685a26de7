"""A source glTF's document with all its data in one new binary buffer, for writing it again.

Everything in the JSON is kept as it was — nodes, skins, meshes, materials, textures, samplers,
animations, extensions (VRM, ``KHR_materials_*``, ``KHR_texture_transform`` …) and extras —
except where the bytes live:

* every bufferView is copied from its own buffer into buffer 0 (4-byte aligned), decoded
  when it was meshopt-compressed (``EXT_meshopt_compression`` and its fallback buffers are
  dropped; quantized accessors stay quantized, under ``KHR_mesh_quantization``);
* images keep their encoded bytes (JPEG stays JPEG, WebP stays WebP): external and ``data:``
  URIs are embedded as bufferViews with their MIME type, and images with the same bytes
  share one bufferView, so each is stored once.

New data (morph targets, animation) is appended through the returned :class:`_Builder`,
whose accessor indices continue after the source's.
"""

from __future__ import annotations

import copy
import hashlib
import logging
from typing import Any

from mimika.errors import DataError
from mimika.io.gltf import _Builder
from mimika.io.gltf_source import GltfSource

log = logging.getLogger(__name__)

__all__ = ["MESHOPT", "image_mime", "repack"]

#: the compression extensions decoded here (not written again)
MESHOPT = ("EXT_meshopt_compression", "KHR_meshopt_compression")
_MAGIC = ((b"\x89PNG", "image/png"), (b"\xff\xd8\xff", "image/jpeg"),
          (b"RIFF", "image/webp"), (b"\xabKTX", "image/ktx2"))


def image_mime(data: bytes, declared: Any = None) -> str | None:
    """The MIME type of encoded image ``data``: from its magic bytes, else ``declared``
    (None when neither says)."""
    for magic, mime in _MAGIC:
        if data.startswith(magic) and (mime != "image/webp" or data[8:12] == b"WEBP"):
            return mime
    return declared if isinstance(declared, str) and declared.startswith("image/") else None


def _view_refs(doc: dict[str, Any]) -> list[tuple[dict[str, Any], str]]:
    """Every (object, key) whose value is a bufferView index: accessors, their sparse
    indices and values, images."""
    refs: list[tuple[dict[str, Any], str]] = []
    for acc in doc.get("accessors", []):
        if acc.get("bufferView") is not None:
            refs.append((acc, "bufferView"))
        sp = acc.get("sparse")
        if isinstance(sp, dict):
            refs += [(sp[k], "bufferView") for k in ("indices", "values")
                     if isinstance(sp.get(k), dict)]
    refs += [(im, "bufferView") for im in doc.get("images", [])
             if im.get("bufferView") is not None]
    return refs


def repack(src: GltfSource) -> tuple[dict[str, Any], _Builder]:
    """A copy of ``src``'s document whose bufferViews all lie in one buffer (the builder's),
    images embedded once each; the builder holds the bytes and takes new data."""
    doc = copy.deepcopy(src.doc)
    b = _Builder()
    images = doc.get("images", [])
    owner: dict[bytes, int] = {}  # image bytes → the first image holding them
    same: list[int] = []  # per image: the image whose bytes (and bufferView) it uses
    embed: dict[int, bytes] = {}  # images to embed from a uri
    for i, im in enumerate(images):
        try:
            data = src.image_bytes(i)
        except DataError as e:  # missing or outside the folder: the reader said so too
            log.warning("%s; its uri is kept, not embedded", e)
            same.append(i)
            continue
        mime = image_mime(data, im.get("mimeType"))
        if mime is not None:
            im["mimeType"] = mime
        same.append(owner.setdefault(hashlib.sha1(data).digest(), i))
        if same[i] == i and im.get("bufferView") is None:
            embed[i] = data
    keep = {obj[key] for obj, key in _view_refs({**doc, "images": []})}
    keep |= {im["bufferView"] for i, im in enumerate(images)
             if same[i] == i and im.get("bufferView") is not None}
    new_index: dict[int, int] = {}
    for i, bv in enumerate(src.items("bufferViews")):
        if i not in keep and any(im.get("bufferView") == i for im in images):
            continue  # only images whose bytes are stored elsewhere use it
        new_index[i] = b.add_bytes(src.view(i))
        b.views[-1].update({k: v for k, v in bv.items()
                            if k not in ("buffer", "byteOffset", "byteLength", "extensions")})
        ext = {k: v for k, v in (bv.get("extensions") or {}).items() if k not in MESHOPT}
        if ext:
            b.views[-1]["extensions"] = ext
    for obj, key in _view_refs({**doc, "images": []}):
        obj[key] = new_index[obj[key]]
    for i, im in enumerate(images):  # owners first: a later image may share an earlier one
        if same[i] == i and (i in embed or im.get("bufferView") is not None):
            im["bufferView"] = (b.add_bytes(embed[i]) if i in embed
                                else new_index[im["bufferView"]])
            im.pop("uri", None)
    for i, im in enumerate(images):
        if same[i] != i:
            im["bufferView"] = images[same[i]]["bufferView"]
            im.pop("uri", None)
    b.accessors = doc.setdefault("accessors", [])
    doc["bufferViews"] = b.views
    doc["buffers"] = [{"byteLength": 0}]
    for key in ("extensionsUsed", "extensionsRequired"):
        if key in doc:
            doc[key] = [e for e in doc[key] if e not in MESHOPT]
            if not doc[key]:
                del doc[key]
    return doc, b
