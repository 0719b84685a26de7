"""mimika's per-user cache folder: ``$MIMIKA_CACHE_DIR``, else ``~/.cache/mimika``."""

from __future__ import annotations

import contextlib
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


def touch(path: Path) -> None:
    """Mark a cache entry as just used (for :func:`prune`); a read-only cache is left alone."""
    with contextlib.suppress(OSError):
        os.utime(path)


def prune(folder: Path, pattern: str, max_bytes: int, keep: Path | None = None) -> int:
    """Delete the least recently used ``pattern`` files of ``folder`` (by modification time,
    which :func:`touch` renews on use) until they hold at most ``max_bytes``; ``keep`` is never
    deleted. Returns the bytes freed."""
    entries = []
    for f in folder.glob(pattern):
        try:
            st = f.stat()
        except OSError:
            continue
        entries.append((st.st_mtime, st.st_size, f))
    total = sum(size for _, size, _ in entries)
    freed = 0
    for _, size, f in sorted(entries, key=lambda e: e[0]):
        if total - freed <= max_bytes:
            break
        if f == keep:
            continue
        try:
            f.unlink()
            freed += size
        except OSError:
            continue
    return freed
