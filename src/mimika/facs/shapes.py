"""The AU → expression-shape table (``facs/data/ict_aus.json``: each AU as ICT/ARKit shapes
with weights, sides and the head's extra channels), shared by the rigs (face/) and the ARKit
and Live Link formats (io/)."""

from __future__ import annotations

import json
from functools import lru_cache
from importlib import resources

__all__ = ["au_shape_table"]


@lru_cache(maxsize=1)
def _text() -> str:
    return resources.files("mimika.facs").joinpath("data", "ict_aus.json").read_text("utf-8")


def au_shape_table() -> dict:
    """A fresh copy of the parsed table (callers may change it)."""
    return json.loads(_text())
