"""EXT_texture_webp: a texture's WebP image (Pillow decodes WebP), preferred over the
fallback ``source`` as the extension says."""

from __future__ import annotations

from typing import Any

__all__ = ["texture_source"]


def texture_source(texture: dict[str, Any]) -> Any:
    """The image index a texture shows: its WebP source when it has one, else ``source``."""
    ext = (texture.get("extensions") or {}).get("EXT_texture_webp")
    if isinstance(ext, dict) and ext.get("source") is not None:
        return ext["source"]
    return texture.get("source")
