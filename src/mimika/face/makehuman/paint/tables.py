"""The painters' data tables (``data/*.json``): per-asset settings, documented in each file's
``_doc`` entry."""

from __future__ import annotations

import functools
import json
from importlib import resources


@functools.cache
def table(name: str) -> dict:
    """``data/<name>.json`` without its ``_doc`` entries."""
    text = resources.files("mimika.face.makehuman.paint").joinpath("data", f"{name}.json")
    return {k: v for k, v in json.loads(text.read_text("utf-8")).items()
            if not k.startswith("_")}
