"""The AU Blender's rules in plain words, for the studio's per-rule switches."""

from __future__ import annotations

import functools
import json
from importlib import resources
from typing import Any


@functools.cache
def _texts() -> dict[str, Any]:
    text = resources.files("mimika.studio").joinpath("data/rules.json").read_text("utf-8")
    return json.loads(text)


def _au(code: str) -> str:
    from mimika.facs import AU_CATALOGUE

    return f"{AU_CATALOGUE[code].name} ({code})"


def explain(rule: Any, fuzzy: dict[str, Any]) -> dict[str, str]:
    """``{"title", "text"}`` of one :class:`~mimika.facs.blender.Rule`."""
    t = _texts()
    tpl = t["kinds"][rule.kind]
    terms = [rule.target, *(x.au for x in rule.terms)]
    names = dict(zip("abc", (_au(c) for c in terms), strict=False))
    names.update(zip("ABC", terms, strict=False))
    lo = hi = ""
    fz = ""
    if rule.kind == "strong":
        f = rule.terms[0].fuzzy or "z"
        fz = t["fuzzy"].get(f, f)
        lo, hi = fuzzy[f].points[0], fuzzy[f].points[1]
    elif rule.kind == "exclusion":
        lo, hi = fuzzy["x"].points[2], fuzzy["x"].points[3]
    fill = {**names, "fuzzy": fz, "lo": f"{lo:g}" if lo != "" else "",
            "hi": f"{hi:g}" if hi != "" else ""}
    fill.setdefault("c", "")
    fill.setdefault("C", "")
    return {"title": tpl["title"].format(**fill), "text": tpl["text"].format(**fill)}


def rules_info() -> list[dict[str, Any]]:
    """Every rule of the default Blender: notation, kind, AUs read/lowered and its text."""
    from mimika.facs.blender import Blender

    b = Blender.default()
    return [{"rule": r.notation, "kind": r.kind, "aus": list(r.aus), "outputs": list(r.outputs),
             **explain(r, b.fuzzy)} for r in b.rules]
