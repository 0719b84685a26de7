"""The timeline: channels of timed events, plus the spoken text they are anchored to.

Times are seconds. An :class:`Event` is an expression, an AU set, a gaze, a head pose or
gesture, or a blink, with ``start``, ``duration`` and optional ``onset``/``offset`` (the rest is
the apex). Events live in :class:`Channel` s; within a channel they may not overlap, and
consecutive events blend into each other without passing through neutral (seed 002 §5.4).
Channels combine additively and are clipped to [0, 1]; an ``override`` channel replaces the AUs
it sets wherever it is active. :class:`Speech` keeps the script's text and SSML structure as
a flat token list, so a parsed script can be printed back (``mimika.markup.to_script``).

All types are frozen and compare by value: ``parse(print(t)) == t`` is the round-trip contract.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field, replace

from mimika import limits
from mimika.errors import ParameterError
from mimika.facs import parse_au
from mimika.timeline.easing import check_easing

#: event kinds; ``transient`` kinds (blink, nod, shake) return to rest on their own and do not
#: chain into their neighbours
KINDS = ("expression", "aus", "gaze", "tilt", "turn", "blink", "nod", "shake")
TRANSIENT = frozenset({"blink", "nod", "shake"})
#: the channel each kind goes to unless the event names one
DEFAULT_CHANNEL = {"expression": "face", "aus": "face", "gaze": "gaze", "tilt": "head",
                   "turn": "head", "nod": "gesture", "shake": "gesture", "blink": "blink"}
#: direction words per kind → AU codes they drive (intensity split evenly for diagonals)
DIRECTIONS = {
    "gaze": {"left": ("AU61",), "right": ("AU62",), "up": ("AU63",), "down": ("AU64",),
             "up-left": ("AU63", "AU61"), "up-right": ("AU63", "AU62"),
             "down-left": ("AU64", "AU61"), "down-right": ("AU64", "AU62"),
             "ahead": (), "center": ()},
    "tilt": {"left": ("AU55",), "right": ("AU56",), "none": ()},
    "turn": {"left": ("AU51",), "right": ("AU52",), "up": ("AU53",), "down": ("AU54",),
             "ahead": ()},
    "blink": {"both": ("AU45",), "left": ("AU45L",), "right": ("AU45R",)},
}
#: default (duration, onset, offset) in seconds of events given without them
KIND_TIMING = {"gaze": (1.0, 0.15, 0.15), "tilt": (1.2, 0.3, 0.3), "turn": (1.2, 0.3, 0.3),
               "blink": (0.3, 0.1, 0.15), "nod": (0.6, 0.0, 0.0), "shake": (0.8, 0.0, 0.0),
               "aus": (1.0, 0.25, 0.25)}
_EPS = 1e-9
#: most repetitions of a nod or shake
MAX_COUNT = 100


def _finite(v: float, what: str) -> float:
    f = float(v)
    if not math.isfinite(f):
        raise ParameterError(f"{what}={v!r} must be a finite number of seconds")
    return f


@dataclass(frozen=True)
class Event:
    """One timed event.

    Parameters
    ----------
    kind : one of :data:`KINDS`
    start, duration : seconds; start ≥ 0, duration > 0
    name : expression name (kind ``expression``) or direction (gaze, tilt, turn, blink)
    aus : for kind ``aus``: ((code, value), …) with values in [0, 1]
    intensity : scale in [0, 1] (for nod/shake: the peak intensity of the head AU)
    onset, offset : rise and decay seconds; None = the expression's / kind's default
    ease : easing name (see :mod:`mimika.timeline.easing`); None = the channel's
    count : repetitions of a nod or shake
    anchor : (first, last) position in the speech tokens the element sits at / wraps
        (set by the script parser; None for events placed by absolute time)
    at : authored shift (s) relative to the anchor's time (kept for printing)
    """

    kind: str
    start: float
    duration: float
    name: str = ""
    aus: tuple[tuple[str, float], ...] = ()
    intensity: float = 1.0
    onset: float | None = None
    offset: float | None = None
    ease: str | None = None
    count: int = 1
    anchor: tuple[int, int] | None = None
    at: float | None = None
    where: str = field(default="", compare=False)  #: source location for messages

    def __post_init__(self) -> None:
        w = f"{self.where}: " if self.where else ""
        if self.kind not in KINDS:
            raise ParameterError(f"{w}event kind {self.kind!r} must be one of {', '.join(KINDS)}")
        start = _finite(self.start, f"{w}start")
        dur = _finite(self.duration, f"{w}dur")
        if start < 0:
            raise ParameterError(f"{w}start={start:g} s is negative; events start at ≥ 0 s")
        if dur <= 0:
            raise ParameterError(f"{w}dur={dur:g} s must be > 0")
        if start + dur > limits.current().max_duration:
            raise limits.over("max_duration", f"{w}the {self.kind} event ends at "
                                              f"{start + dur:g} s")
        object.__setattr__(self, "start", start)
        object.__setattr__(self, "duration", dur)
        k = float(self.intensity)
        if not 0.0 <= k <= 1.0:
            raise ParameterError(f"{w}intensity={self.intensity!r} must be within [0, 1]")
        object.__setattr__(self, "intensity", k)
        for what in ("onset", "offset"):
            v = getattr(self, what)
            if v is not None:
                v = _finite(v, f"{w}{what}")
                if v < 0:
                    raise ParameterError(f"{w}{what}={v:g} s must be ≥ 0")
                object.__setattr__(self, what, v)
        if (self.onset or 0.0) + (self.offset or 0.0) > dur + _EPS:
            raise ParameterError(f"{w}onset {self.onset or 0:g} s + offset {self.offset or 0:g} s "
                                 f"do not fit into dur={dur:g} s")
        if self.ease is not None:
            object.__setattr__(self, "ease", check_easing(self.ease))
        if not 1 <= int(self.count) <= MAX_COUNT:
            raise ParameterError(f"{w}count={self.count!r} must be within 1…{MAX_COUNT}")
        object.__setattr__(self, "count", int(self.count))
        if self.kind == "aus":
            pairs = []
            for code, v in self.aus:
                c = parse_au(code)
                val = float(v)
                if not 0.0 <= val <= 1.0:
                    raise ParameterError(f"{w}{c}={val:g} is outside [0, 1]")
                pairs.append((c, val))
            if len({c for c, _ in pairs}) != len(pairs):
                raise ParameterError(f"{w}an AU is given twice in {self.aus!r}")
            object.__setattr__(self, "aus", tuple(pairs))
        elif self.aus:
            raise ParameterError(f"{w}only kind 'aus' takes AU values")
        if self.kind in DIRECTIONS and self.name not in DIRECTIONS[self.kind]:
            import difflib

            opts = list(DIRECTIONS[self.kind])
            close = difflib.get_close_matches(self.name, opts, n=1)
            hint = f"; did you mean {close[0]!r}?" if close else ""
            raise ParameterError(f"{w}{self.kind} direction {self.name!r} is unknown{hint} "
                                 f"(use {', '.join(opts)})")
        if self.kind == "expression" and not self.name:
            raise ParameterError(f"{w}an expression event needs a name")
        if self.anchor is not None:
            a, b = (int(x) for x in self.anchor)
            if a < 0 or b < a:
                raise ParameterError(f"{w}anchor {self.anchor!r} must be (first ≤ last)")
            object.__setattr__(self, "anchor", (a, b))

    @property
    def end(self) -> float:
        return self.start + self.duration

    @property
    def transient(self) -> bool:
        return self.kind in TRANSIENT

    @property
    def label(self) -> str:
        """A short human label: ``happiness``, ``AU06=0.8 AU12``, ``gaze left``, ``nod×2``."""
        if self.kind == "expression":
            return self.name
        if self.kind == "aus":
            return " ".join(f"{c}={v:g}" for c, v in self.aus)
        if self.kind in ("nod", "shake"):
            return self.kind + (f"×{self.count}" if self.count > 1 else "")
        return f"{self.kind} {self.name}"

    def moved(self, *, start: float | None = None, duration: float | None = None) -> Event:
        """A copy with new timing (the authored anchor shift is dropped)."""
        return replace(self, start=self.start if start is None else start,
                       duration=self.duration if duration is None else duration, at=None)


@dataclass(frozen=True)
class Channel:
    """A named sequence of non-overlapping events.

    ``override``: where this channel is active it replaces (instead of adding to) the AUs it
    sets. ``ease``: default easing of its events. ``bridge``: the longest gap (s) between two
    events that is bridged without returning to neutral (∞ = always, seed 002 §5.4).
    """

    name: str
    events: tuple[Event, ...] = ()
    override: bool = False
    ease: str = "cosine"
    bridge: float = math.inf

    def __post_init__(self) -> None:
        if not self.name or any(ch.isspace() for ch in self.name):
            raise ParameterError(f"channel name {self.name!r} must be a non-empty word")
        object.__setattr__(self, "ease", check_easing(self.ease))
        b = float(self.bridge)
        if math.isnan(b) or b < 0:
            raise ParameterError(f"channel {self.name!r}: bridge={self.bridge!r} must be ≥ 0 s")
        object.__setattr__(self, "bridge", b)
        evs = tuple(sorted(self.events, key=lambda e: (e.start, e.end)))
        for a, b2 in itertools.pairwise(evs):
            if b2.start < a.end - 1e-9:
                at = f"{b2.where}: " if b2.where else ""
                raise ParameterError(
                    f"{at}{b2.label} at {b2.start:g} s overlaps {a.label} "
                    f"({a.start:g}–{a.end:g} s) in channel {self.name!r}; move it, shorten the "
                    "earlier one or put it in another channel (channel=\"…\")")
        object.__setattr__(self, "events", evs)

    @property
    def end(self) -> float:
        return max((e.end for e in self.events), default=0.0)


# -- speech tokens ------------------------------------------------------------------------------
@dataclass(frozen=True)
class Text:
    """Spoken text (may hold several words and punctuation)."""

    text: str


@dataclass(frozen=True)
class Open:
    """Start of an SSML element (``p``, ``s``, ``prosody``, ``sub`` …); attributes in order."""

    tag: str
    attrs: tuple[tuple[str, str], ...] = ()


@dataclass(frozen=True)
class Close:
    tag: str


@dataclass(frozen=True)
class Empty:
    """An empty SSML element: ``break``, ``mark``, ``audio`` …"""

    tag: str
    attrs: tuple[tuple[str, str], ...] = ()


Token = Text | Open | Close | Empty


@dataclass(frozen=True)
class Speech:
    """The spoken part of a script: SSML tokens (inside ``<speak>``) and the root's attributes."""

    tokens: tuple[Token, ...] = ()
    attrs: tuple[tuple[str, str], ...] = ()

    @property
    def text(self) -> str:
        """The plain text (what a TTS engine would say, without ``sub`` aliases)."""
        return "".join(t.text for t in self.tokens if isinstance(t, Text))

    def __bool__(self) -> bool:
        return any(isinstance(t, Text) and t.text.strip() for t in self.tokens)


@dataclass(frozen=True)
class Timeline:
    """Channels of events plus settings.

    Parameters
    ----------
    channels : kept sorted by name
    speech : the script's text and SSML structure (empty for programmatic timelines)
    rate : speaking rate for text timing without audio, seconds per vowel unit (seed Eq 6.6)
    mood : a knowledge-base mood (``happy``, ``depressed`` …) or None
    duration : explicit length in seconds (None = until the last event / the speech ends)
    """

    channels: tuple[Channel, ...] = ()
    speech: Speech = Speech()
    rate: float = 0.16
    mood: str | None = None
    duration: float | None = None

    def __post_init__(self) -> None:
        chans = tuple(sorted(self.channels, key=lambda c: c.name))
        names = [c.name for c in chans]
        if len(set(names)) != len(names):
            raise ParameterError(f"channel names must be unique: {names}")
        object.__setattr__(self, "channels", chans)
        r = float(self.rate)
        if not (math.isfinite(r) and r > 0):
            raise ParameterError(f"rate={self.rate!r} seconds per unit must be > 0")
        object.__setattr__(self, "rate", r)
        if self.duration is not None:
            d = _finite(self.duration, "duration")
            if d <= 0:
                raise ParameterError(f"duration={d:g} s must be > 0")
            limits.check_duration(d, "the timeline's duration")
            object.__setattr__(self, "duration", d)

    # -- access
    def channel(self, name: str) -> Channel:
        for c in self.channels:
            if c.name == name:
                return c
        raise ParameterError(f"no channel {name!r} (channels: "
                             f"{', '.join(c.name for c in self.channels) or 'none'})")

    @property
    def events(self) -> list[tuple[str, Event]]:
        """Every (channel name, event), sorted by start."""
        out = [(c.name, e) for c in self.channels for e in c.events]
        return sorted(out, key=lambda ce: (ce[1].start, ce[0]))

    def speech_end(self) -> float:
        """When the text ends under text timing (0 without speech)."""
        if not self.speech.tokens:
            return 0.0
        from mimika.timeline.speech import time_speech

        return time_speech(self.speech, rate=self.rate).end

    @property
    def end(self) -> float:
        """Length in seconds: ``duration`` if set, else the last event's / the speech's end."""
        if self.duration is not None:
            return self.duration
        return max([c.end for c in self.channels] + [self.speech_end()], default=0.0)

    # -- edits (return new timelines)
    def with_event(self, event: Event, channel: str | None = None) -> Timeline:
        """A copy with ``event`` added to ``channel`` (default: the kind's default channel)."""
        name = channel or DEFAULT_CHANNEL[event.kind]
        chans = {c.name: c for c in self.channels}
        old = chans.get(name, Channel(name))
        chans[name] = replace(old, events=(*old.events, event))
        return replace(self, channels=tuple(chans.values()))

    def with_channels(self, channels: Iterable[Channel]) -> Timeline:
        return replace(self, channels=tuple(channels))


def timeline_from_events(events: Sequence[tuple[str, Event]] | Sequence[Event], **kw) -> Timeline:
    """Build a timeline from events or (channel, event) pairs (channels made as needed)."""
    tl = Timeline(**kw)
    for item in events:
        ch, ev = item if isinstance(item, tuple) else (None, item)
        tl = tl.with_event(ev, ch)
    return tl
