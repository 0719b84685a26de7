"""Loader for ``knowledge/data/knowledge.json`` (timing, co-occurrence, mood, context, text)."""

from __future__ import annotations

import json
from functools import lru_cache
from importlib import resources
from typing import Any


@lru_cache(maxsize=1)
def knowledge_data() -> dict[str, Any]:
    """The parsed knowledge-base table (cached; treat as read-only)."""
    text = resources.files("mimika.knowledge").joinpath("data/knowledge.json").read_text("utf-8")
    return json.loads(text)


def section(name: str) -> dict[str, Any]:
    """One section without its ``_source`` note."""
    return {k: v for k, v in knowledge_data()[name].items() if not k.startswith("_")}
