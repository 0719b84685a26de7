"""The JSON and buffers of a glTF 2.0 / GLB / VRM file, read by the spec and safely.

``.glb`` (and ``.vrm``) chunks are parsed here; a ``.gltf`` is JSON with its buffers and
images beside it or in ``data:`` URIs. External URIs resolve only inside the file's own
folder: absolute paths, ``..``, other schemes, devices and symlinks that lead out are
refused. Each bufferView is read from its own ``buffer``; compressed views
(EXT_meshopt_compression) are decoded by :mod:`mimika.io.gltf_ext`. ``extensionsRequired``
is checked against what mimika can read: an unsupported one is a one-line
:class:`~mimika.errors.DataError` that names it and the fix.
"""

from __future__ import annotations

import base64
import binascii
import stat
import struct
from pathlib import Path
from typing import Any
from urllib.parse import unquote

from mimika.errors import DataError
from mimika.io.gltf_ext import REQUIRED_FIXES, SUPPORTED, meshopt
from mimika.limits import loads_json

__all__ = ["MAX_FILE_BYTES", "GltfSource", "load_source"]

#: largest glTF/GLB file or external buffer/image read (bytes)
MAX_FILE_BYTES = 2 * 1024**3
_GLB_MAGIC = b"glTF"
_JSON, _BIN = 0x4E4F534A, 0x004E4942


class GltfSource:
    """``doc`` (the glTF JSON as dicts and lists) and its buffers, read on demand."""

    def __init__(self, path: Path, doc: dict[str, Any], glb_bin: bytes | None) -> None:
        self.path = path
        self.doc = doc
        self._glb_bin = glb_bin
        self._buffers: dict[int, bytes] = {}
        self._views: dict[int, bytes] = {}

    def fail(self, what: str) -> DataError:
        return DataError(f"{self.path}: {what}; export the file again from your tool")

    def items(self, key: str) -> list[Any]:
        """The top-level array ``key`` (``[]`` when absent), checked to be a list of objects."""
        v = self.doc.get(key, [])
        if not isinstance(v, list) or not all(isinstance(x, dict) for x in v):
            raise self.fail(f"'{key}' is not a list of objects")
        return v

    def item(self, key: str, index: Any, where: str) -> dict[str, Any]:
        """``doc[key][index]``, with a one-line error naming ``where`` when out of range."""
        arr = self.items(key)
        if isinstance(index, bool) or not isinstance(index, int) or not 0 <= index < len(arr):
            raise self.fail(f"{where} names {key[:-1]} {index!r}, which does not exist")
        return arr[index]

    def buffer(self, index: int) -> bytes:
        """Buffer ``index``: the GLB BIN chunk, a data: URI or a file beside this one."""
        if index in self._buffers:
            return self._buffers[index]
        b = self.item("buffers", index, "a bufferView")
        uri = b.get("uri")
        if uri is None:
            if index != 0 or self._glb_bin is None:
                raise self.fail(f"buffer {index} has no uri and is not the GLB's binary chunk")
            data = self._glb_bin
        else:
            data = self.read_uri(uri, f"buffer {index}")
        length = b.get("byteLength")
        if not isinstance(length, int) or length < 0 or length > len(data):
            raise self.fail(f"buffer {index} says {length!r} bytes but holds {len(data)}")
        self._buffers[index] = data[:length]
        return self._buffers[index]

    def view(self, index: Any) -> bytes:
        """The bytes of bufferView ``index``, decompressed when it is meshopt-compressed."""
        if index in self._views:
            return self._views[index]
        bv = self.item("bufferViews", index, "an accessor or image")
        ext = (bv.get("extensions") or {}).get("EXT_meshopt_compression")
        if isinstance(ext, dict):
            src = self._slice(ext, f"bufferView {index} (meshopt)")
            data = meshopt.decode_view(src, ext, self.fail)
        else:
            data = self._slice(bv, f"bufferView {index}")
        self._views[index] = data
        return data

    def _slice(self, spec: dict[str, Any], where: str) -> bytes:
        buf = self.buffer(spec.get("buffer"))
        off, length = spec.get("byteOffset", 0), spec.get("byteLength")
        if not all(isinstance(x, int) and not isinstance(x, bool) and x >= 0
                   for x in (off, length)) or off + length > len(buf):
            raise self.fail(f"{where} lies outside its buffer (offset {off!r}, length "
                            f"{length!r}, buffer {len(buf)} bytes)")
        return buf[off:off + length]

    def image_bytes(self, index: int) -> bytes:
        """The encoded bytes (PNG, JPEG, WebP …) of image ``index``."""
        im = self.item("images", index, "a texture")
        if im.get("bufferView") is not None:
            return self.view(im["bufferView"])
        if isinstance(im.get("uri"), str):
            return self.read_uri(im["uri"], f"image {index}")
        raise self.fail(f"image {index} has neither a bufferView nor a uri")

    def read_uri(self, uri: Any, where: str) -> bytes:
        """A data: URI's bytes, or a file's inside this file's folder (never outside it)."""
        if not isinstance(uri, str) or not uri:
            raise self.fail(f"{where} has a uri that is not a string")
        if uri.startswith("data:"):
            head, sep, body = uri.partition(",")
            if not sep or not head.endswith(";base64"):
                raise self.fail(f"{where}: a data: URI must be base64")
            if len(body) > MAX_FILE_BYTES * 4 // 3 + 4:
                raise self.fail(f"{where}: its data: URI is over {MAX_FILE_BYTES} bytes")
            try:
                return base64.b64decode(body, validate=True)
            except (binascii.Error, ValueError):
                raise self.fail(f"{where}: its data: URI is not valid base64") from None
        return read_beside(self.path, uri, where)


def read_beside(path: Path, uri: str, where: str) -> bytes:
    """The bytes of relative ``uri`` next to ``path``: refused when absolute, with a scheme,
    climbing out with ``..``, a symlink leading out of the folder, or not a regular file."""
    rel = unquote(uri)
    low = rel.lower()
    parts = Path(rel.replace("\\", "/")).parts
    if (":" in low.split("/")[0] or rel.startswith(("/", "\\")) or ".." in parts
            or "\x00" in rel):
        raise DataError(f"{path}: {where} points at {uri!r}, outside the file's folder; mimika "
                        "reads only files beside the glTF (put it there, or pack a .glb)")
    folder = path.parent.resolve()
    target = folder / Path(*parts) if parts else folder
    try:
        real = target.resolve(strict=True)
        st = real.stat()
    except (OSError, RuntimeError):
        raise DataError(f"{path}: the file of {where}, {uri!r}, is missing; copy it next to "
                        f"{path.name} (or export one .glb, which holds it)") from None
    if not real.is_relative_to(folder):
        raise DataError(f"{path}: {where}: {uri!r} leads out of the file's folder (a link); "
                        "copy the real file beside it")
    if not stat.S_ISREG(st.st_mode):
        raise DataError(f"{path}: {where}: {uri!r} is not a regular file")
    if st.st_size > MAX_FILE_BYTES:
        raise DataError(f"{path}: {where}: {uri!r} is over {MAX_FILE_BYTES} bytes")
    with open(real, "rb") as fh:
        return fh.read(MAX_FILE_BYTES + 1)


def _parse_glb(path: Path, data: bytes) -> tuple[bytes, bytes | None]:
    if len(data) < 20:
        raise DataError(f"{path}: a GLB shorter than its header; export it again")
    _, version, length = struct.unpack_from("<4sII", data)
    if version != 2:
        raise DataError(f"{path}: GLB version {version}, mimika reads glTF 2.0; convert it "
                        "(e.g. Blender: import, then export glTF 2.0)")
    end = min(length, len(data))
    pos, json_bytes, bin_bytes = 12, None, None
    while pos + 8 <= end:
        clen, ctype = struct.unpack_from("<II", data, pos)
        chunk = data[pos + 8:pos + 8 + clen]
        if len(chunk) != clen:
            raise DataError(f"{path}: a GLB chunk runs past the end of the file; export it "
                            "again")
        if ctype == _JSON and json_bytes is None:
            json_bytes = chunk
        elif ctype == _BIN and bin_bytes is None and json_bytes is not None:
            bin_bytes = chunk
        pos += 8 + clen + (-clen % 4)
    if json_bytes is None:
        raise DataError(f"{path}: the GLB has no JSON chunk; export it again")
    return json_bytes, bin_bytes


def load_source(path: str | Path) -> GltfSource:
    """Read ``path``'s JSON (and GLB binary chunk); check its asset version and
    ``extensionsRequired``. Buffers and images are read when first asked for."""
    p = Path(path)
    try:
        st = p.stat()
        if not stat.S_ISREG(st.st_mode):
            raise DataError(f"{p}: not a regular file")
        if st.st_size > MAX_FILE_BYTES:
            raise DataError(f"{p}: over {MAX_FILE_BYTES} bytes; too large to read")
        with open(p, "rb") as fh:
            data = fh.read(MAX_FILE_BYTES + 1)
    except OSError as e:
        raise DataError(f"{p}: cannot be read ({e.strerror})") from None
    glb_bin = None
    if data[:4] == _GLB_MAGIC:  # .glb, .vrm and misnamed files: decided by the magic
        text, glb_bin = _parse_glb(p, data)
    else:
        text = data
    try:
        doc = loads_json(text.decode("utf-8-sig"), str(p))
    except UnicodeDecodeError:
        raise DataError(f"{p}: not a glTF/GLB file (neither GLB nor UTF-8 JSON); export it "
                        "again as glTF 2.0") from None
    if not isinstance(doc, dict):
        raise DataError(f"{p}: not a glTF file (its JSON is not an object)")
    asset = doc.get("asset")
    version = str(asset.get("version", "")) if isinstance(asset, dict) else ""
    if not version.startswith("2."):
        raise DataError(f"{p}: glTF version {version or '(none)'}, mimika reads glTF 2.0; "
                        "convert it (e.g. Blender: import, then export glTF 2.0)")
    required = doc.get("extensionsRequired", [])
    if not isinstance(required, list):
        raise DataError(f"{p}: 'extensionsRequired' is not a list; export it again")
    missing = [str(e) for e in required if e not in SUPPORTED]
    if missing:
        fix = REQUIRED_FIXES.get(missing[0], "re-export the file without it")
        raise DataError(f"{p}: needs the glTF extension{'s' if len(missing) > 1 else ''} "
                        f"{', '.join(missing)}, which mimika does not read; {fix}")
    return GltfSource(p, doc, glb_bin)
