"""Morph-target names → what they mean: FACS AUs, ARKit-52 shapes, Oculus/Meta visemes, VRM
expressions (tables in ``face/data/morph_names.json``).

Canonical names: ``AU12``, ``AU12_L``/``AU12_R`` for FACS; the ICT-FaceKit spelling of ARKit
shapes (``eyeBlinkLeft`` → ``eyeBlink_L``, ``jawOpen``), which ``facs/data/ict_aus.json``
composes into AUs; ``viseme_aa`` … for visemes.
"""

from __future__ import annotations

import functools
import json
import re
from dataclasses import dataclass
from importlib import resources

__all__ = ["ARKIT_52", "MorphMatch", "arkit_name", "canonical_arkit", "classify", "table"]


@functools.cache
def table() -> dict:
    return json.loads(resources.files("mimika.face").joinpath("data/morph_names.json")
                      .read_text("utf-8"))


ARKIT_52: tuple[str, ...] = tuple(table()["arkit"])
_SIDES = {"l": "L", "left": "L", "r": "R", "right": "R"}
_FACS = re.compile(r"^au[_ ]?0?(\d{1,2})(?![0-9])(.*)$", re.IGNORECASE)


@dataclass(frozen=True)
class MorphMatch:
    """What a morph name means: ``kind`` facs | arkit | viseme | expression, the canonical
    shape name, and how it was recognised (``how``: the rule, for ``heads --inspect``)."""

    kind: str
    name: str
    how: str


def canonical_arkit(arkit: str) -> str:
    """``eyeBlinkLeft`` → ``eyeBlink_L``; midline names (and ``jawLeft``, ``mouthRight`` …,
    which move to one side rather than act on it) unchanged."""
    for word, side in (("Left", "_L"), ("Right", "_R")):
        base = arkit[: -len(word)]
        if base in ("jaw", "mouth"):
            continue
        if arkit.endswith(word) and base + ("Right" if word == "Left" else "Left") in ARKIT_52:
            return base + side
    return arkit


def arkit_name(canonical: str) -> str | None:
    """``eyeBlink_L`` → ``eyeBlinkLeft`` (None when not an ARKit shape)."""
    if canonical[-2:] in ("_L", "_R"):
        name = canonical[:-2] + ("Left" if canonical[-1] == "L" else "Right")
    else:
        name = canonical
    return name if name in ARKIT_52 else None


def _tokens(name: str) -> list[str]:
    return [t.lower() for t in re.findall(r"[A-Z]?[a-z]+|[A-Z]+(?![a-z])|\d+", name)]


@functools.cache
def _arkit_keys() -> dict[str, str]:
    return {"".join(_tokens(a)): a for a in ARKIT_52}


@functools.cache
def _aliases() -> dict[str, str]:
    return {a.lower(): canon for canon, names in table()["aliases"].items() for a in names}


def _strip(name: str) -> str:
    s = re.split(r"[.:|]", name)[-1].strip()
    for p in table()["prefixes"]:
        m = re.match(p, s)
        if m and m.end() < len(s):
            return s[m.end():]
    return s


def classify(raw: str, *, expression: bool = False) -> MorphMatch | None:
    """The meaning of morph (or, with ``expression``, VRM expression) name ``raw``."""
    s = _strip(raw)
    m = _FACS.match(s)
    if m and 1 <= int(m.group(1)) <= 64:
        code = f"AU{int(m.group(1)):02d}"
        rest = _tokens(m.group(2))
        side = next((_SIDES[t] for t in rest[:1] + rest[-1:] if t in _SIDES), None)
        if side is None and m.group(2)[:1] in ("L", "R") and not m.group(2)[1:2].islower():
            side = m.group(2)[0]
        return MorphMatch("facs", code + (f"_{side}" if side else ""), "FACS name")
    low = s.lower()
    if expression or low.startswith("fcl_") or raw.lower() in ("blinkleft", "blinkright"):
        canon = _aliases().get(low) or _aliases().get(raw.lower())
        if canon:
            kind = "viseme" if canon.startswith("viseme_") else "expression"
            return MorphMatch(kind, canon, "VRM expression" if expression else "VRoid name")
    if expression:
        return None
    if low.startswith("viseme"):
        v = s[len("viseme"):].lstrip("_- ")
        for name in table()["visemes"]:
            if v.lower() == name.lower() or (v.lower(), name) in (("ih", "I"), ("oh", "O"),
                                                                   ("ou", "U")):
                return MorphMatch("viseme", f"viseme_{name}", "Oculus/Meta viseme")
        return None
    tok = _tokens(s)
    keys = _arkit_keys()
    key = "".join(tok)
    if key in keys:
        return MorphMatch("arkit", canonical_arkit(keys[key]), "ARKit name")
    if len(tok) > 1 and tok[-1] in _SIDES:
        base = "".join(tok[:-1]) + ("left" if _SIDES[tok[-1]] == "L" else "right")
        if base in keys:
            return MorphMatch("arkit", canonical_arkit(keys[base]), "ARKit name")
    canon = _aliases().get(low)
    if canon and not canon.startswith("viseme_") and len(low) > 2:
        return MorphMatch("expression", canon, "alias")
    return None
