"""mimika's per-user cache folder: ``$MIMIKA_CACHE_DIR``, else ``~/.cache/mimika``."""

from __future__ import annotations

import os
from pathlib import Path

ENV_CACHE = "MIMIKA_CACHE_DIR"


def cache_dir(*parts: str) -> Path:
    """The cache folder, or ``parts`` under it (not created)."""
    root = os.environ.get(ENV_CACHE) or Path.home() / ".cache" / "mimika"
    return Path(root).expanduser().joinpath(*parts)
