"""Text timing of a script's speech without audio (seed 002 §6.4.1, the vowel-unit method).

Every word and punctuation run takes ``units × rate`` seconds, with units counted by
:func:`mimika.knowledge.textsync.vowel_units` (Eq 6.6) — the same times
:func:`~mimika.knowledge.textsync.sync_text` gives for a text without sentence pauses.
SSML adds to that: ``<break time="300ms"/>`` (or ``strength``) inserts silence, ``<prosody
rate="slow">`` stretches its words, ``<sub alias="…">`` is timed by its alias. With audio (TTS or a
recording) pass ``word_times`` instead and positions take the times of the words around them.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass

from mimika.errors import ParameterError
from mimika.timeline.model import Close, Empty, Open, Speech, Text

#: SSML break strengths → seconds of silence
BREAK_STRENGTH = {"none": 0.0, "x-weak": 0.1, "weak": 0.2, "medium": 0.4, "strong": 0.7,
                  "x-strong": 1.2}
#: SSML prosody rate words → speed factors (2 = twice as fast)
RATE_WORDS = {"x-slow": 0.5, "slow": 0.75, "medium": 1.0, "default": 1.0, "fast": 1.25,
              "x-fast": 1.6}
_TIME_RE = re.compile(r"^\s*([+-]?)(\d+(?:\.\d*)?|\.\d+)(?:[eE]([+-]?\d+))?\s*(ms|s)?\s*$")


def parse_time(text: str, *, what: str = "time", signed: bool = False) -> float:
    """``"1.5s"``, ``"300ms"``, ``"2"`` (seconds) → seconds; ``signed`` allows ``+``/``-``."""
    m = _TIME_RE.match(str(text))
    if not m or (m.group(1) and not signed):
        form = '"+0.2s" or "-150ms"' if signed else '"1.5s", "300ms" or "2"'
        raise ParameterError(f"{what}={text!r} is not a time; write it like {form}")
    v = float(m.group(2) + (f"e{m.group(3)}" if m.group(3) else ""))
    if m.group(4) == "ms":
        v /= 1000.0
    if m.group(1) == "-":
        v = -v
    if not math.isfinite(v):
        raise ParameterError(f"{what}={text!r} is not a finite time")
    return v


def format_time(seconds: float, *, signed: bool = False) -> str:
    """Seconds → ``"1.5s"`` so that :func:`parse_time` gives back exactly the same float."""
    s = repr(float(seconds))
    if "e" in s or "E" in s:
        s = f"{float(seconds):.17f}".rstrip("0").rstrip(".") or "0"
        if float(s) != float(seconds):  # pragma: no cover - tiny values
            s = repr(float(seconds))
    elif s.endswith(".0"):
        s = s[:-2]
    if signed and not s.startswith("-"):
        s = "+" + s
    return s + "s"


def rate_factor(text: str) -> float:
    """An SSML prosody ``rate`` → speed factor: ``slow``, ``80%``, ``+10%``, ``1.2``."""
    t = str(text).strip().lower()
    if t in RATE_WORDS:
        return RATE_WORDS[t]
    try:
        if t.endswith("%"):
            body = t[:-1]
            v = float(body) / 100.0
            v = 1.0 + v if body[:1] in "+-" else v
        else:
            v = float(t)
    except ValueError:
        raise ParameterError(f"prosody rate={text!r} must be x-slow … x-fast, a percentage "
                             "(80%, +10%) or a factor (1.2)") from None
    if not (math.isfinite(v) and v > 0):
        raise ParameterError(f"prosody rate={text!r} must make speech faster than 0")
    return v


def break_seconds(attrs: dict[str, str]) -> float:
    """Silence of an SSML ``<break>``: its ``time``, else its ``strength`` (default medium)."""
    if "time" in attrs:
        v = parse_time(attrs["time"], what="break time")
        return v
    s = attrs.get("strength", "medium")
    if s not in BREAK_STRENGTH:
        raise ParameterError(f"break strength={s!r} must be one of {', '.join(BREAK_STRENGTH)}")
    return BREAK_STRENGTH[s]


@dataclass(frozen=True)
class Word:
    text: str
    start: float
    end: float


@dataclass(frozen=True)
class SpeechTiming:
    """``times[p]`` is the time (s) at token position p (0 … len(tokens)); ``words`` in order."""

    times: tuple[float, ...]
    words: tuple[Word, ...]

    @property
    def end(self) -> float:
        return self.times[-1] if self.times else 0.0


def time_speech(speech: Speech, *, rate: float, start: float = 0.0,
                word_times: Sequence[tuple[float, float]] | None = None) -> SpeechTiming:
    """Time every token position of ``speech`` (seconds).

    ``rate`` is seconds per vowel unit; ``word_times`` ((start, end) per word, e.g. from TTS)
    overrides text timing: a position then takes the start of the next word (or the end of the
    previous one after the last word).
    """
    from mimika.knowledge.textsync import tokenize, vowel_units

    t = float(start)
    times = [t]
    words: list[Word] = []
    speeds = [1.0]
    sub_alias: list[str | None] = []
    for tok in speech.tokens:
        if isinstance(tok, Open):
            a = dict(tok.attrs)
            if tok.tag == "prosody" and "rate" in a:
                speeds.append(speeds[-1] * rate_factor(a["rate"]))
            elif tok.tag == "prosody":
                speeds.append(speeds[-1])
            if tok.tag == "sub":
                sub_alias.append(a.get("alias"))
        elif isinstance(tok, Close):
            if tok.tag == "prosody" and len(speeds) > 1:
                speeds.pop()
            if tok.tag == "sub" and sub_alias:
                alias = sub_alias.pop()
                for w, kind in tokenize(alias or ""):
                    d = (1 if kind == "punct" else vowel_units(w)) * rate / speeds[-1]
                    if kind == "word":
                        words.append(Word(w, t, t + d))
                    t += d
        elif isinstance(tok, Empty):
            if tok.tag == "break":
                t += break_seconds(dict(tok.attrs))
        elif isinstance(tok, Text) and not sub_alias:
            for w, kind in tokenize(tok.text):
                d = (1 if kind == "punct" else vowel_units(w)) * rate / speeds[-1]
                if kind == "word":
                    words.append(Word(w, t, t + d))
                t += d
        times.append(t)
    if word_times is None:
        return SpeechTiming(tuple(times), tuple(words))
    if len(word_times) != len(words):
        raise ParameterError(f"word_times has {len(word_times)} entries but the script has "
                             f"{len(words)} words")
    # map each position to the next word's start (by counting words before it)
    new_words = tuple(Word(w.text, float(s), float(e))
                      for w, (s, e) in zip(words, word_times, strict=True))
    starts = [w.start for w in words]
    out = []
    for tp in times:
        k = sum(1 for s in starts if s < tp - 1e-12)  # words begun before this position
        if k < len(new_words):
            out.append(new_words[k].start)
        else:
            out.append(new_words[-1].end if new_words else tp)
    return SpeechTiming(tuple(out), new_words)
