"""Painted textures cached on disk: ``${MIMIKA_CACHE_DIR:-~/.cache/mimika}/paint/`` holds one
PNG per texture, named by a hash of everything it depends on (the painters' code and data, the
piece's geometry and UVs, the character settings the painter reads). Files are written
atomically; an unreadable file is painted again."""

from __future__ import annotations

import functools
import hashlib
import io
import json
import logging
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from mimika.cachedir import cache_dir as mimika_cache
from mimika.cachedir import code_digest, prune, touch
from mimika.io.atomic import atomic_write

log = logging.getLogger(__name__)

#: bump when any painter changes its output
PAINT_VERSION = 1
#: painted textures kept at most (least recently used go first)
MAX_BYTES = 768 * 2**20


def cache_dir() -> Path:
    """Where painted textures are kept."""
    return mimika_cache("paint")


def piece_digest(*arrays: np.ndarray | None) -> str:
    """A hash of geometry arrays (vertices, UVs, faces …)."""
    h = hashlib.sha256()
    for a in arrays:
        if a is None:
            h.update(b"-")
            continue
        a = np.ascontiguousarray(a)
        h.update(f"{a.dtype}{a.shape}".encode())
        h.update(a.tobytes())
    return h.hexdigest()


@functools.cache
def painters_digest() -> str:
    """A hash of the painters' code and data (a change repaints, no stale textures)."""
    root = Path(__file__).parent
    return code_digest([*root.glob("*.py"), *root.glob("data/*.json")])


def texture_key(kind: str, digest: str, settings: dict) -> str:
    blob = json.dumps({"v": PAINT_VERSION, "code": painters_digest(), "kind": kind,
                       "geometry": digest, "settings": settings}, sort_keys=True)
    return hashlib.sha256(blob.encode()).hexdigest()[:24]


def cached_texture(kind: str, key: str, paint: Callable[[], np.ndarray]) -> np.ndarray:
    """The texture ``kind``-``key`` from the cache, or ``paint()`` it and store it."""
    from PIL import Image

    path = cache_dir() / f"{kind}-{key}.png"
    if path.is_file():
        try:
            with Image.open(path) as im:
                img = np.asarray(im.convert("RGBA"))
            log.debug("paint: %s from cache", path.name)
            touch(path)
            return img
        except Exception as e:  # a damaged file is painted again
            log.warning("ignoring unreadable painted texture %s (%s)", path, e)
    t0 = time.perf_counter()
    img = paint()
    log.info("painted %s %dx%d in %.2f s", kind, img.shape[1], img.shape[0],
             time.perf_counter() - t0)
    try:
        buf = io.BytesIO()
        Image.fromarray(img).save(buf, format="PNG", compress_level=3)
        atomic_write(path, buf.getvalue())
        prune(path.parent, "*.png", MAX_BYTES, keep=path)
    except OSError as e:
        log.warning("could not cache painted texture %s: %s", path, e)
    return img
