"""EXT_meshopt_compression (and KHR_meshopt_compression): compressed bufferViews decoded by
PyPI ``meshopt`` (meshoptimizer's own decoder), sizes checked before decoding."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from mimika.errors import DataError

__all__ = ["MAX_DECODED", "decode_view"]

#: largest decoded bufferView (bytes)
MAX_DECODED = 1024**3
_MODES = {"ATTRIBUTES", "TRIANGLES", "INDICES"}
_FILTERS = {None, "NONE", "OCTAHEDRAL", "QUATERNION", "EXPONENTIAL", "COLOR"}


def decode_view(src: bytes, ext: dict[str, Any], fail: Callable[[str], DataError]) -> bytes:
    """The plain bytes of a compressed bufferView whose extension object is ``ext``."""
    count, stride = ext.get("count"), ext.get("byteStride")
    mode, filt = ext.get("mode"), ext.get("filter")
    if not (isinstance(count, int) and isinstance(stride, int) and count >= 0
            and 0 < stride <= 256 and mode in _MODES and filt in _FILTERS):
        raise fail(f"a meshopt bufferView has bad count/byteStride/mode/filter "
                   f"({count!r}, {stride!r}, {mode!r}, {filt!r})")
    if mode != "ATTRIBUTES" and stride not in (2, 4):
        raise fail(f"a meshopt {mode} bufferView has byteStride {stride} (2 or 4)")
    if count * stride > MAX_DECODED:
        raise fail(f"a meshopt bufferView decodes to {count * stride} bytes, over "
                   f"{MAX_DECODED}")
    try:
        import meshopt
    except ImportError:  # pragma: no cover - a core dependency
        raise DataError("EXT_meshopt_compression needs the meshopt package: pip install "
                        "meshopt") from None
    try:
        out = meshopt.decode_gltf_buffer(bytes(src), count, stride, mode,
                                         None if filt == "NONE" else filt)
    except Exception as e:  # the decoder refuses malformed streams
        raise fail(f"a meshopt bufferView does not decode ({str(e)[:80]})") from None
    return out.tobytes()
