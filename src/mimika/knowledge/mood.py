"""Mood: how often and how long expressions appear (seed 002 §6.3.2, §6.5).

Mood changes frequency and duration, never the type of expression. Values live in
``knowledge.json`` → ``mood``: ``interval_s`` (mean seconds between expression starts) and
``duration_scale`` (factor on default durations).
"""

from __future__ import annotations

import difflib
from dataclasses import dataclass

from mimika.errors import ParameterError
from mimika.knowledge._data import section


@dataclass(frozen=True)
class Mood:
    name: str
    frequency: str  #: rare | normal | frequent
    interval_s: float  #: expected mean time between expression starts
    duration_scale: float  #: factor on default expression durations
    variety: str  #: limited | normal | large

    def describe(self) -> str:
        length = ("long" if self.duration_scale > 1.05 else
                  "short" if self.duration_scale < 0.95 else "normal-length")
        return (f"mood {self.name!r}: {self.frequency} expressions (about one every "
                f"{self.interval_s:g} s), {length} (default durations ×{self.duration_scale:g}), "
                f"{self.variety} variety")


def moods() -> dict[str, Mood]:
    """Every known mood by name."""
    return {k: Mood(k, v["frequency"], float(v["interval_s"]), float(v["duration_scale"]),
                    v["variety"]) for k, v in section("mood").items()}


def get_mood(name: str | None) -> Mood:
    """The mood called ``name`` (None → neutral); unknown names raise with suggestions."""
    table = moods()
    key = (name or "neutral").strip().lower()
    if key not in table:
        close = difflib.get_close_matches(key, list(table), n=3)
        hint = f"; did you mean {', '.join(close)}?" if close else ""
        raise ParameterError(f"unknown mood {name!r}{hint} (known: {', '.join(table)})")
    return table[key]
