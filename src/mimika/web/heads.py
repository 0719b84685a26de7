"""The heads a server animates: a name checked once, rigs loaded on first use (the last few
stay loaded) and each head's GLB built once, with its ETag."""

from __future__ import annotations

import hashlib
import logging
import threading
from collections import OrderedDict
from pathlib import Path
from typing import Any

from mimika.errors import DataError

log = logging.getLogger(__name__)


def head_infos() -> list[Any]:
    """:func:`mimika.face.heads.list_heads` (the heads mimika knows, installed or not)."""
    from mimika.face.heads import list_heads

    return list_heads()


def check_head(name: str) -> str:
    """``name`` if it is a head mimika knows or a file; else one clear :class:`DataError`."""
    names = [h.name for h in head_infos()]
    if name not in names and not Path(name).exists():
        raise DataError(f"head {name!r} is not one of the heads here ({', '.join(names)}) "
                        "nor a file (run 'mimika heads')")
    return name


class HeadCache:
    """Rigs by head name, the ``size`` most recently used kept, each with its GLB."""

    def __init__(self, size: int = 2) -> None:
        self._lock = threading.Lock()
        #: name → [rig, glb bytes or None, etag], most recently used last
        self._heads: OrderedDict[str, list[Any]] = OrderedDict()
        self._size = size

    def _entry(self, name: str) -> list[Any]:
        with self._lock:
            e = self._heads.get(name)
            if e is None:
                from mimika.face.heads import load_head

                _, rig = load_head(name)
                log.info("loaded head %s", name)
                e = self._heads[name] = [rig, None, ""]
                while len(self._heads) > self._size:
                    self._heads.popitem(last=False)
            self._heads.move_to_end(name)
            return e

    def rig(self, name: str) -> Any:
        """The rig of head ``name`` (loaded once)."""
        return self._entry(name)[0]

    def glb(self, name: str) -> tuple[bytes, str]:
        """Head ``name`` as GLB (no animation) and its ETag; built once per head."""
        from mimika.web.glb import gltf_bytes

        e = self._entry(name)
        with self._lock:
            if e[1] is None:
                e[1] = gltf_bytes(e[0], None, name=name)
                e[2] = '"' + hashlib.sha1(e[1]).hexdigest()[:16] + '"'
            return e[1], e[2]
