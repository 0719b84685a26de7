"""mimika's per-user cache folder: ``$MIMIKA_CACHE_DIR``, else ``~/.cache/mimika``."""

from __future__ import annotations

import hashlib
import os
from collections.abc import Iterable
from pathlib import Path

ENV_CACHE = "MIMIKA_CACHE_DIR"


def cache_dir(*parts: str) -> Path:
    """The cache folder, or ``parts`` under it (not created)."""
    root = os.environ.get(ENV_CACHE) or Path.home() / ".cache" / "mimika"
    return Path(root).expanduser().joinpath(*parts)


def code_digest(files: Iterable[Path]) -> str:
    """A short hash of ``files``' names and bytes: part of a cache key, so that a change to the
    code or data that made an entry rebuilds it instead of reading a stale one."""
    h = hashlib.sha256()
    for f in sorted(files):
        h.update(f.name.encode())
        h.update(f.read_bytes())
    return h.hexdigest()[:16]
