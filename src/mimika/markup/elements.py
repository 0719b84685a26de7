"""The script language's vocabulary: SSML elements kept, mimika elements and their attributes,
and the timing rules the parser and the printer share (so printing then parsing is exact)."""

from __future__ import annotations

from typing import Any

from mimika.timeline.model import KIND_TIMING, TRANSIENT

#: the mimika namespace (prefix ``m`` is bound to it even when not declared)
MIMIKA_NS = "https://mimika.dev/ns/1"
SSML_NS = "http://www.w3.org/2001/10/synthesis"

#: SSML 1.1 elements kept in the speech (text timing honours break, prosody rate and sub)
SSML_ELEMENTS = frozenset({
    "speak", "p", "s", "break", "prosody", "mark", "lang", "sub", "say-as", "emphasis",
    "phoneme", "voice", "audio", "desc", "lexicon", "lookup", "meta", "metadata", "token", "w",
})

#: mimika element → event kind (None: a declaration, not an event)
MIMIKA_ELEMENTS: dict[str, str | None] = {
    "expr": "expression", "expression": "expression", "neutral": "expression",
    "aus": "aus", "au": "aus",
    "gaze": "gaze", "tilt": "tilt", "turn": "turn",
    "nod": "nod", "shake": "shake", "blink": "blink",
    "channel": None, "settings": None, "mood": None,
}
#: the name the printer writes for each kind
PRINT_NAME = {"expression": "expr", "aus": "aus", "gaze": "gaze", "tilt": "tilt",
              "turn": "turn", "nod": "nod", "shake": "shake", "blink": "blink"}

TIMING_ATTRS = ("start", "at", "end", "dur", "onset", "offset")
COMMON_ATTRS = (*TIMING_ATTRS, "intensity", "ease", "channel")
ATTRS: dict[str, tuple[str, ...]] = {
    "expr": ("name", *COMMON_ATTRS),
    "expression": ("name", *COMMON_ATTRS),
    "neutral": COMMON_ATTRS,
    "aus": ("set", *COMMON_ATTRS),
    "au": ("set", *COMMON_ATTRS),
    "gaze": ("dir", *COMMON_ATTRS),
    "tilt": ("dir", *COMMON_ATTRS),
    "turn": ("dir", *COMMON_ATTRS),
    "nod": ("count", *COMMON_ATTRS),
    "shake": ("count", *COMMON_ATTRS),
    "blink": ("side", *COMMON_ATTRS),
    "channel": ("name", "override", "ease", "bridge"),
    "settings": ("rate", "mood", "duration"),
    "mood": ("name",),
}
REQUIRED: dict[str, tuple[str, ...]] = {
    "expr": ("name",), "expression": ("name",), "aus": ("set",), "au": ("set",),
    "gaze": ("dir",), "tilt": ("dir",), "turn": ("dir",), "channel": ("name",),
    "mood": ("name",),
}


def default_duration(kind: str, name: str, count: int, *, library: Any,
                     mood: str | None) -> float:
    """Duration (s) of an event given with neither ``dur`` nor wrapped words.

    Expressions take the library's duration (times the mood's ``duration_scale``); nods and
    shakes last their kind's duration per repetition; others their kind's default.
    """
    if kind == "expression":
        d = float(library.get(name).duration)
        if mood:
            from mimika.knowledge import get_mood

            d *= get_mood(mood).duration_scale
        return d
    base = KIND_TIMING[kind][0]
    return base * count if kind in ("nod", "shake") else base


def derived_timing(kind: str, name: str, count: int, times: tuple[float, ...],
                   anchor: tuple[int, int] | None, at: float | None, *, library: Any,
                   mood: str | None) -> tuple[float | None, float]:
    """(start, duration) an element gets from its position alone (start None: no anchor)."""
    if anchor is None:
        return None, default_duration(kind, name, count, library=library, mood=mood)
    p0, p1 = anchor
    t0 = times[p0] + (at or 0.0)
    span = times[p1] - times[p0]
    if span > 0 and kind not in TRANSIENT:  # blinks, nods, shakes keep their natural speed
        return t0, span
    return t0, default_duration(kind, name, count, library=library, mood=mood)

